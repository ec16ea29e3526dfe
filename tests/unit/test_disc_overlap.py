"""The disc average from the cells' overlaps with the disc (outputs/disc_cells.py): closed forms for a disc
wholly inside the region and for a triangle the circle cuts, and the search's value is that average."""

from __future__ import annotations

import numpy as np
import pytest

from suture_fem.outputs.disc import max_disc_average
from suture_fem.outputs.disc_cells import DiscOverlap, overlap_averages
from tests.unit.test_disc_average import RADIUS, _field, _mesh


def test_a_linear_field_s_average_over_a_disc_inside_the_region_is_the_closed_form():
    # 2 pi r-weighted averages over the disc at (r0, z0): <1> = 1, <r> = r0 + R^2 / (4 r0), <z> = z0; on a
    # coarse mesh (10 x 10 over 1 x 1: the disc meets about 30 cells, a third of them cut) and a finer one
    centres = np.array([[1.0, 0.5], [0.8, 0.35], [1.2, 0.7]])
    exact = 2.0 + 3.0 * (centres[:, 0] + RADIUS**2 / (4 * centres[:, 0])) - 1.5 * centres[:, 1]
    for n in (10, 23):
        mesh = _mesh(n)
        ones = overlap_averages(_field(mesh, lambda r, z: 1.0 + 0 * r), centres, RADIUS)
        assert ones == pytest.approx(1.0, rel=1e-13)
        got = overlap_averages(_field(mesh, lambda r, z: 2.0 + 3.0 * r - 1.5 * z), centres, RADIUS)
        assert got == pytest.approx(exact, rel=1e-12)


def test_a_triangle_the_circle_cuts_gets_the_quarter_disc_s_moments():
    # a right triangle with its right-angle corner at the disc's centre and legs 2R: the disc's part in it is
    # the quarter disc r - r0, z - z0 >= 0 (the hypotenuse is sqrt(2) R from the centre). Its moments:
    # int r dA = r0 pi R^2 / 4 + R^3 / 3, int r^2 dA = r0^2 pi R^2 / 4 + 2 r0 R^3 / 3 + pi R^4 / 16.
    r0, z0, R = 0.7, 0.2, RADIUS
    tri = np.array([[[r0, z0], [r0 + 2 * R, z0], [r0, z0 + 2 * R]]])
    [(cells, w)] = DiscOverlap(tri, R).weights(np.array([r0, z0]))
    assert cells.tolist() == [0]
    int_r = r0 * np.pi * R**2 / 4 + R**3 / 3
    int_r2 = r0**2 * np.pi * R**2 / 4 + 2 * r0 * R**3 / 3 + np.pi * R**4 / 16
    assert w.sum() == pytest.approx(2 * np.pi * int_r, rel=1e-12)
    assert w[0] @ tri[0, :, 0] == pytest.approx(2 * np.pi * int_r2, rel=1e-12)
    # clockwise, and with the corner at the centre moved: the same disc part from the other vertex order
    assert DiscOverlap(tri[:, ::-1], R).weights(np.array([r0, z0]))[0][1].sum() == pytest.approx(w.sum(), rel=1e-13)
    # the same triangle well inside a larger disc: whole, exact
    [(cells, w)] = DiscOverlap(tri, 4 * R).weights(np.array([r0, z0]))
    assert w.sum() == pytest.approx(2 * np.pi * 2 * R**2 * (r0 + 2 * R / 3), rel=1e-13)


def test_a_triangle_s_part_in_the_disc_has_the_moments_of_the_clipped_polygon():
    # random triangles about a unit disc, against the triangle clipped to a 100,000-gon inscribed in the circle
    # (its area short of pi by (2 pi / n)^2 / 6 of it, 4e-9): the polygon's exact area and centroid
    from suture_fem.outputs.disc_cells import cut_moments

    x = np.random.default_rng(0).normal(size=(12, 3, 2)) * 0.8
    m0, m1, _ = cut_moments(x, 1.0)
    t = np.linspace(0.0, 2 * np.pi, 100_001)[:-1]
    for tri, a, first in zip(x, m0, m1):
        poly = _clip(np.column_stack([np.cos(t), np.sin(t)]), tri)
        px, py = poly[:, 0], poly[:, 1]
        c = px * np.roll(py, -1) - np.roll(px, -1) * py
        assert a == pytest.approx(c.sum() / 2, abs=1e-8)
        assert first == pytest.approx([((px + np.roll(px, -1)) * c).sum() / 6,
                                       ((py + np.roll(py, -1)) * c).sum() / 6], abs=1e-8)


def _clip(poly, tri):
    """The convex polygon ``poly`` clipped to the triangle (Sutherland-Hodgman, one edge at a time)."""
    (ax, ay), (bx, by) = tri[1] - tri[0], tri[2] - tri[0]
    if ax * by - ay * bx < 0:
        tri = tri[::-1]
    for i in range(3):
        a, b = tri[i], tri[(i + 1) % 3]
        s = (poly - a) @ np.array([a[1] - b[1], b[0] - a[0]])
        if not len(poly):
            break
        nxt, s_next = np.roll(poly, -1, axis=0), np.roll(s, -1)
        crossing = (s >= 0) != (s_next >= 0)
        cut = poly + (s / np.where(crossing, s - s_next, 1.0))[:, None] * (nxt - poly)
        keep = np.stack([s >= 0, crossing], axis=1)  # each point if inside, then the crossing after it if any
        poly = np.stack([poly, cut], axis=1)[keep]
    return poly if len(poly) >= 3 else np.zeros((3, 2))


def test_the_search_reports_the_largest_overlap_average_and_not_the_point_rule_s():
    # a narrow ridge along z = 0.5 (about one cell wide on a 40 x 40 mesh): the point rule's search finds a
    # centre whose points fall on the ridge (measured: 0.2117 against the overlaps' 0.2032 near it); the value
    # reported is the overlaps' average at the centre reported, the largest of a scan around it
    field = _field(_mesh(40), lambda r, z: np.exp(-((z - 0.5) / 0.02) ** 2) * r)
    rule = max_disc_average(field, np.array([[1.0, 0.45]]), RADIUS, exact=False)
    found = max_disc_average(field, np.array([[1.0, 0.45]]), RADIUS)
    assert found.value == pytest.approx(overlap_averages(field, np.array([found.at]), RADIUS)[0], rel=1e-14)
    assert rule.value > 1.03 * found.value
    k = np.arange(-8, 9) * RADIUS / 16
    scan = overlap_averages(field, np.array(found.at) + np.stack(np.meshgrid(k, k), -1).reshape(-1, 2), RADIUS)
    assert found.value >= scan.max() * (1 - 1e-4)


@pytest.mark.parametrize("kept_pairs", [0, 1_000_000])
def test_overlap_averages_from_kept_weights_are_the_fresh_ones_bit_for_bit(monkeypatch, kept_pairs):
    # a region's overlaps kept for the next field (nothing kept past the limit) against a fresh field's own
    from suture_fem.outputs import disc_cells
    from suture_fem.outputs.disc import CellField
    from suture_fem.outputs.disc_points import DiscPoints
    from suture_fem.support import compat

    monkeypatch.setattr(disc_cells, "KEPT_PAIRS", kept_pairs)
    mesh = _mesh(12)
    first = _field(mesh, lambda r, z: r * z)
    discs = DiscPoints(first.locate)
    rng = np.random.default_rng(5)
    batches = [rng.uniform([0.4, -0.1], [1.6, 1.1], (n, 2)) for n in (9, 25)]
    batches.append(np.concatenate([batches[1][3:], batches[0], [[3.0, 3.0]]]))  # kept, new and outside centres
    xy = np.einsum("qv,nvd->nqd", np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]),
                   mesh.geometry.x[compat.geometry_dofs(mesh)[first.cells][:, :3], :2])
    for f in (lambda r, z: np.sin(5 * r) + z**2, lambda r, z: 1.0 + r * z):
        kept = CellField(mesh, first.cells, xy, f(xy[..., 0], xy[..., 1]), discs.locate, discs)
        for centres in batches:
            assert np.array_equal(overlap_averages(kept, centres, RADIUS), overlap_averages(_field(mesh, f), centres,
                                                                                            RADIUS))
