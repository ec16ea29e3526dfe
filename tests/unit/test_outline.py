"""The cone contact's search: the nearest point of an outline against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from suture_fem.geometry.outline import deepest_on_way, inside, project

#: The unit square, counter-clockwise: arc length 0-1 along z = 0, 1-2 along r = 1, ...
SQUARE = [("line", ((0.0, 0.0), (1.0, 0.0))), ("line", ((1.0, 0.0), (1.0, 1.0))),
          ("line", ((1.0, 1.0), (0.0, 1.0))), ("line", ((0.0, 1.0), (0.0, 0.0)))]


def test_a_point_beside_a_face_projects_onto_it_with_its_outward_normal():
    p = project(np.array([[1.3, 0.25], [0.9, 0.25]]), SQUARE)
    assert p.distance == pytest.approx([0.3, -0.1])  # outside positive, inside negative
    assert p.s == pytest.approx([1.25, 1.25])
    assert p.normal == pytest.approx(np.array([[1.0, 0.0], [1.0, 0.0]]))  # the signed distance's gradient
    assert p.tangent == pytest.approx(np.array([[0.0, 1.0], [0.0, 1.0]]))
    assert not p.corner.any()


def test_a_point_off_a_corner_is_at_the_corners_distance_and_the_same_on_a_clockwise_outline():
    clockwise = [(kind, (b, a)) for kind, (a, b) in reversed(SQUARE)]
    for outline in (SQUARE, clockwise):
        p = project(np.array([[1.3, 1.4]]), outline)
        assert p.distance[0] == pytest.approx(0.5)
        assert p.normal[0] == pytest.approx([0.6, 0.8])
        assert p.corner[0]


def test_a_point_on_the_outline_has_the_faces_normal_and_an_arc_gives_its_radius():
    p = project(np.array([[0.5, 0.0]]), SQUARE)
    assert p.distance[0] == pytest.approx(0.0, abs=1e-15) and p.normal[0] == pytest.approx([0.0, -1.0])
    # a quarter disc: the arc from (1, 0) round to (0, 1) about the origin, closed along the axes
    disc = [("line", ((0.0, 0.0), (1.0, 0.0))), ("arc", ((1.0, 0.0), (0.0, 0.0), (0.0, 1.0))),
            ("line", ((0.0, 1.0), (0.0, 0.0)))]
    q = project(np.array([[1.2 * math.cos(0.3), 1.2 * math.sin(0.3)]]), disc)
    assert q.distance[0] == pytest.approx(0.2)
    assert q.s[0] == pytest.approx(1.0 + 0.3)
    assert q.normal[0] == pytest.approx([math.cos(0.3), math.sin(0.3)])
    assert q.tangent[0] == pytest.approx([-math.sin(0.3), math.cos(0.3)])
    assert list(inside(np.array([[0.5, 0.5], [1.5, 0.5], [0.2, 0.9]]), disc)) == [True, False, True]



def test_a_point_between_an_arcs_chord_and_the_arc_reads_inside_and_its_distance_is_continuous():
    """The inside test's polygon cuts an arc by 16 chords; beside the arc its own side decides the sign."""
    disc = [("line", ((0.0, 0.0), (1.0, 0.0))), ("arc", ((1.0, 0.0), (0.0, 0.0), (0.0, 1.0))),
            ("line", ((0.0, 1.0), (0.0, 0.0)))]
    half_chord = 0.5 * (math.pi / 2) / 16  # the middle of the first chord is at this angle, 1 - cos(it) inside
    sagitta = 1.0 - math.cos(half_chord)
    radii = 1.0 - np.array([0.9, 0.5, 0.1, -0.1]) * sagitta  # three between chord and arc, one outside
    points = np.stack([radii * math.cos(half_chord), radii * math.sin(half_chord)], axis=1)
    assert not inside(points[:3], disc).any()  # the polygon's reading
    assert project(points, disc).distance == pytest.approx(radii - 1.0, abs=1e-15)
    crossing = np.stack([np.full(5, math.cos(half_chord)), math.sin(half_chord) + np.linspace(-1e-9, 1e-9, 5)], 1)
    assert (project(crossing * (1.0 - 0.5 * sagitta), disc).distance < 0).all()


@pytest.mark.parametrize("orientation", ["apex_to_pull", "base_to_pull"])
def test_a_cone_closed_to_the_axis_holds_the_track_off_its_side_on_the_thread(orientation):
    """With the thread free, the track's tissue (r = r_t) is searched against the cone and the thread as one body.

    On the cone's own outline a track node beside the cap lies on the cone's side along the thread (distance
    0: the cone would pass with no gap); closed to the axis it is inside, at its depth below the cap's face.
    """
    from suture_fem.geometry.section import Geometry
    from suture_fem.scene import Scene

    scene = Scene.builtin("paper").with_values({"geometry.cones": 1, "geometry.cone_orientation": orientation})
    g = Geometry.from_section(scene.geometry)
    cone, r_t = g.cones[0], g.r_thread
    sign = 1.0 if cone.apex_z > cone.base_z else -1.0  # the cap's face points toward the pull or away
    node = np.array([[r_t, cone.apex_z - sign * 0.01]])  # 10 um inside the cap, on the thread's surface
    assert project(node, cone.rounded(0.015, r_t)).distance[0] == pytest.approx(0.0, abs=1e-12)
    p = project(node, cone.rounded(0.015, r_t, to_axis=True))
    assert p.distance[0] == pytest.approx(-0.01)
    assert p.normal[0] == pytest.approx([0.0, sign])
    ahead = project(np.array([[r_t, cone.apex_z + sign * 0.02]]), cone.rounded(0.015, r_t, to_axis=True))
    assert ahead.distance[0] == pytest.approx(0.02)  # ahead of the cap: its gap to the face
    # a cap node squeezed toward the thread (the tied thread's sliding cone at 3 N: 26 um under the cap's face,
    # 20 um off the thread): on the cone's own outline the side on the thread is nearer, and pushes it toward
    # the axis; closed to the axis the cap's face is nearest, and pushes it back out
    squeezed = np.array([[r_t + 0.020, cone.apex_z - sign * 0.026]])
    own = project(squeezed, cone.rounded(0.015, r_t))
    assert own.distance[0] == pytest.approx(-0.020) and own.normal[0] == pytest.approx([-1.0, 0.0])
    closed = project(squeezed, cone.rounded(0.015, r_t, to_axis=True))
    assert closed.distance[0] == pytest.approx(-0.026) and closed.normal[0] == pytest.approx([0.0, sign])


def test_a_way_through_a_thin_wall_is_seen_half_the_wall_deep_however_it_ends():
    """The wall guard's ways: a node carried through a wall, or past its mid-plane, reads shallow where it ends.

    A wall 0.2 mm thick (1 <= r <= 1.2): straight or slanted through it, the way's deepest point is the
    wall's middle, 0.1 mm deep (sampled exactly: the piece's middle sample); to 0.02 mm short of the far face
    it is 0.1 mm too, found to within 0.18 / 16 mm, though the end reads 0.02 mm; along the face, or ending on
    it, 0; into it by 0.05 mm, 0.05 mm (the end's own depth, sampled to within 0.05 / 8 mm).
    """
    wall = [("line", ((1.0, 0.0), (1.2, 0.0))), ("line", ((1.2, 0.0), (1.2, 5.0))),
            ("line", ((1.2, 5.0), (1.0, 5.0))), ("line", ((1.0, 5.0), (1.0, 0.0)))]
    start = np.array([[1.3, 2.0], [1.3, 2.0], [1.3, 2.0], [1.3, 2.0], [1.3, 1.0], [1.3, 2.0]])
    end = np.array([[0.5, 2.0], [0.5, 3.5], [1.02, 2.0], [1.3, 4.0], [1.2, 4.0], [1.15, 2.0]])
    depth = deepest_on_way(start, end, wall)
    assert depth[:2] == pytest.approx([0.1, 0.1], abs=1e-12)
    assert 0.1 - 0.18 / 16 <= depth[2] <= 0.1 + 1e-12
    assert depth[3:5] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert 0.05 - 0.05 / 8 <= depth[5] <= 0.05 + 1e-12
    assert project(end[2:3], wall).distance[0] == pytest.approx(-0.02)  # what the end alone reads
    # an offset (a node starting off a rounded corner) is taken off each distance
    assert deepest_on_way(start[:1], end[:1], wall, offset=np.array([0.01]))[0] == pytest.approx(0.11)


def test_the_cavity_floors_corner_is_rounded_within_the_floor_and_turns_the_normal_continuously():
    """A hollow cone's cavity floor meets its inner flank in a re-entrant corner, where a tissue node sits.

    Pulled base first, both faces press that node; with the corner sharp its normal jumped between theirs
    (82 degrees) across the bisector at zero distance. Rounded (within the floor's real 28 um, not the
    search's floor extended to the axis), the normal turns continuously all round the node.
    """
    from suture_fem.geometry.section import Geometry
    from suture_fem.scene import Scene

    scene = Scene.builtin("paper").with_values({"geometry.cones": 1, "geometry.cone_orientation": "base_to_pull"})
    g = Geometry.from_section(scene.geometry)
    cone, r_t = g.cones[0], g.r_thread
    corner = cone.points[4]  # the cavity floor's outer end, on the inner flank
    floor_z = cone.points[5][1]
    assert corner[1] == pytest.approx(floor_z) and corner[0] - r_t == pytest.approx(0.0276, abs=1e-4)
    outline = cone.rounded(0.1, r_t, to_axis=True)
    arcs = [seg for kind, seg in outline if kind == "arc" and abs(seg[2][1] - floor_z) < 1e-12]
    assert len(arcs) == 1
    a, c, b = arcs[0]
    assert r_t < b[0] < corner[0] and math.dist(b, corner) <= 0.225 * (corner[0] - r_t) + 1e-12  # on the real floor
    angles = np.linspace(0.0, 2.0 * math.pi, 145)
    for radius in (0.001, 0.003):  # inside and beyond the fillet's depth at the corner (2.3 um)
        ring = np.array(corner) + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
        n = project(ring, outline).normal
        turn = np.degrees(np.arccos(np.clip(np.sum(n[1:] * n[:-1], axis=1), -1.0, 1.0)))
        assert turn.max() < 5.0  # 2.5 degrees apart round the node: 1.2 at most; the sharp corner jumped 82
