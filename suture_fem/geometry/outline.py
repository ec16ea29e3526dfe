"""Closest points on a cone's outline: the contact search of the cones' interface, and the profiles' arc length.

A cone's outline (:class:`~suture_fem.geometry.section.Cone`) is a closed chain of line and circular-arc
segments in the (r, z) half-plane, starting on the thread at the apex and running round the cone's
tissue-facing surface. :func:`project` gives, for each point, the nearest point of the outline, its arc
length from the outline's start, the signed distance (positive outside the cone), the outward unit normal
(the signed distance's gradient) and the unit tangent along the outline there. Pure numpy, vectorised
over the points; a handful of segments per cone.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

#: Points sampled on each piece of a way between its crossings of an outline (:func:`deepest_on_way`).
WAY_SAMPLES = 7
#: Distance (mm) below which a point counts as on a corner of the outline (its normal is then the corner's).
ON_CORNER_MM = 1e-9


@dataclass(frozen=True)
class Projection:
    """The nearest outline point of each of n points (arrays of length n, or (n, 2))."""

    s: np.ndarray
    distance: np.ndarray
    normal: np.ndarray
    tangent: np.ndarray
    corner: np.ndarray
    curvature: np.ndarray


def _line(points: np.ndarray, p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, ...]:
    d = q - p
    length = float(np.linalg.norm(d))
    t = np.clip(((points - p) @ d) / max(length**2, 1e-300), 0.0, 1.0)
    near = p + t[:, None] * d
    tangent = np.broadcast_to(d / max(length, 1e-300), points.shape)
    return near, t * length, tangent, length, (t <= 0.0) | (t >= 1.0)


def _arc(points: np.ndarray, p: np.ndarray, c: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, ...]:
    radius, a0, sweep = _arc_shape(p, c, q)
    ang = np.arctan2(points[:, 1] - c[1], points[:, 0] - c[0]) - a0
    ang = (ang + math.pi) % (2 * math.pi) - math.pi
    t = np.clip(ang / sweep if sweep else 0.0, 0.0, 1.0)
    phi = a0 + t * sweep
    near = c + radius * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    tangent = math.copysign(1.0, sweep) * np.stack([-np.sin(phi), np.cos(phi)], axis=1)
    return near, t * abs(sweep) * radius, tangent, abs(sweep) * radius, (t <= 0.0) | (t >= 1.0)


def _arc_shape(p: np.ndarray, c: np.ndarray, q: np.ndarray) -> tuple[float, float, float]:
    """An arc's radius, start angle and (signed, the shorter way round) sweep."""
    a0 = math.atan2(*(p - c)[::-1])
    sweep = (math.atan2(*(q - c)[::-1]) - a0 + math.pi) % (2 * math.pi) - math.pi
    return float(np.linalg.norm(p - c)), a0, sweep


def _polygon(outline: tuple) -> np.ndarray:
    """The outline as a polygon (arcs by 16 chords): for the inside test and the orientation."""
    pts = []
    for kind, seg in outline:
        if kind == "line":
            pts.append(seg[0])
        else:
            p, c, q = (np.array(v, dtype=float) for v in seg)
            radius, a0, sweep = _arc_shape(p, c, q)
            pts += [tuple(c + radius * np.array([math.cos(a0 + f * sweep), math.sin(a0 + f * sweep)]))
                    for f in np.linspace(0.0, 1.0, 16, endpoint=False)]
    return np.array(pts, dtype=float)


def _key(outline: list) -> tuple:
    """The outline as a hashable key (its segments' kinds and points as float tuples)."""
    return tuple((kind, tuple(tuple(float(x) for x in v) for v in seg)) for kind, seg in outline)


@functools.lru_cache(maxsize=256)
def _prepared(outline: tuple) -> tuple[list, np.ndarray, bool, list]:
    """What :func:`project` needs of an outline that does not depend on the points, computed once per outline.

    (each segment's (kind, points as arrays), the polygon of :func:`_polygon`, whether it runs
    counter-clockwise, each segment's curvature sign: +1 an arc of a convex part of the cone, -1 a
    concave one, 0 a line).
    """
    segments = [(kind, [np.array(v, dtype=float) for v in seg]) for kind, seg in outline]
    poly = _polygon(outline)
    ccw = 0.5 * float(np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1])) > 0
    signs = [(1.0 if _inside(pts[1][None, :], poly)[0] else -1.0) if kind == "arc" else 0.0 for kind, pts in segments]
    return segments, poly, ccw, signs


def inside(points: np.ndarray, outline: list) -> np.ndarray:
    """Whether each point lies inside the closed outline (ray casting along +r)."""
    return _inside(points, _prepared(_key(outline))[1])


def _inside(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    a, b = poly, np.roll(poly, -1, axis=0)
    x, y = points[:, 0][:, None], points[:, 1][:, None]
    crosses = (a[None, :, 1] > y) != (b[None, :, 1] > y)
    at = a[None, :, 0] + (y - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / np.where(
        b[None, :, 1] == a[None, :, 1], 1e-300, b[None, :, 1] - a[None, :, 1])
    return np.count_nonzero(crosses & (x < at), axis=1) % 2 == 1


def project(points: np.ndarray, outline: list) -> Projection:
    """The nearest point of ``outline`` to each of ``points`` ((n, 2), mm): see :class:`Projection`.

    A tie between two segments (a corner) keeps the earlier segment's arc length. The normal is the
    signed distance's gradient: beside a segment (the nearest point inside it) the segment's outward normal
    there, off a corner (point - corner) / distance, turned outward. Not (point - nearest) / distance beside a
    segment: the nearest point is rounded at its distance from the origin, and over a pressed node's small
    distance that turned the normal (5e-12 at 0.1 um from a cone 24 mm up, and the contact force with it: the
    residual's rounding 15 times that of the unknowns, docs/contact.md, "Nothing tied").
    ``corner``: the nearest point is a corner (an end of its segment) off the point.
    ``curvature`` (1/mm): the signed distance's Hessian is curvature (I - n n^T): 0 beside a straight
    segment, +-1 / (distance to the centre) beside an arc (+ where the cone is convex), sign / distance off
    a corner. The sign is the polygon's inside test (:func:`_polygon`) but beside an arc, where it is the arc's own
    side: the polygon's chords cut inside a convex arc by up to its sagitta (0.05 um for a 0.05 mm fillet), and a
    node pressed into the arc by less read as outside, its distance and contact force flipping sign as it crossed
    a chord (a sliding cone's 3-D run stopped on that jump at 0.24 N). Within ON_CORNER_MM of the arc (a mesh node
    on a fillet, to rounding) the polygon's reading is kept: the results before were computed with it.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    n = len(points)
    segments, poly, ccw, signs = _prepared(_key(outline))
    best = np.full(n, np.inf)
    out = {"s": np.zeros(n), "near": np.zeros((n, 2)), "tangent": np.zeros((n, 2)),
           "end": np.zeros(n, bool), "curvature": np.zeros(n), "arc": np.zeros(n, bool), "in_arc": np.zeros(n, bool)}
    start = 0.0
    for (kind, pts), convex in zip(segments, signs):
        near, s, tangent, length, end = _line(points, *pts) if kind == "line" else _arc(points, *pts)
        dist = np.linalg.norm(points - near, axis=1)
        closer = dist < best - 1e-9  # a tie (a corner shared by two segments) keeps the earlier segment
        best[closer] = dist[closer]
        out["s"][closer], out["near"][closer] = start + s[closer], near[closer]
        out["tangent"][closer], out["end"][closer] = tangent[closer], end[closer]
        out["arc"][closer] = kind == "arc"
        if kind == "arc":  # the distance to a circle bends by 1 / (distance to its centre): + convex, - concave
            to_centre = np.linalg.norm(points - pts[1], axis=1)
            out["curvature"][closer] = convex / np.maximum(to_centre, 1e-300)[closer]
            out["in_arc"][closer] = ((to_centre < np.linalg.norm(pts[0] - pts[1])) == (convex > 0))[closer]
        else:
            out["curvature"][closer] = 0.0
        start += length
    turned = np.stack([out["tangent"][:, 1], -out["tangent"][:, 0]], axis=1)  # the tangent turned clockwise
    outward = turned if ccw else -turned
    corner = out["end"] & (best > ON_CORNER_MM)
    beside_arc = out["arc"] & ~corner & (best > ON_CORNER_MM)  # the arc's own side, not its chords' (on it: either)
    sign = np.where(np.where(beside_arc, out["in_arc"], _inside(points, poly)), -1.0, 1.0)
    offset = points - out["near"]
    normal = np.where(corner[:, None], sign[:, None] * offset / np.maximum(best, 1e-300)[:, None], outward)
    curvature = np.where(corner, sign / np.maximum(best, 1e-300), out["curvature"])
    return Projection(s=out["s"], distance=sign * best, normal=normal, tangent=out["tangent"],
                      corner=corner, curvature=curvature)


def convex_corners(outline: list) -> np.ndarray:
    """The midpoint of each arc round a convex part of the cone (r > 0: off the axis), (k, 2) mm.

    The search's rounded corners and the real fillets: where the cone's surface can cut the tissue's facets.
    """
    segments, _, _, signs = _prepared(_key(outline))
    out = []
    for (kind, pts), convex in zip(segments, signs):
        if kind == "arc" and convex > 0 and min(pts[0][0], pts[2][0]) > 0.0:
            radius, a0, sweep = _arc_shape(*pts)
            out.append(pts[1] + radius * np.array([math.cos(a0 + 0.5 * sweep), math.sin(a0 + 0.5 * sweep)]))
    return np.array(out, dtype=float).reshape(-1, 2)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def deepest_on_way(start: np.ndarray, end: np.ndarray, outline: list, offset: np.ndarray | float = 0.0) -> np.ndarray:
    """How deep inside ``outline`` each straight way from ``start`` to ``end`` ((n, 2), mm) goes: (n,) mm, 0 outside.

    The way is cut where it crosses the outline's polygon (:func:`_polygon`); each piece is sampled at
    WAY_SAMPLES points strictly inside it, projected, and the deepest kept. A way into or through a wall of
    thickness h, straight or slanted, goes min(L, h / 2) deep, L how far it enters, found to within
    h / (2 (WAY_SAMPLES + 1)): a point carried past the wall's mid-plane, or through it, is seen however shallow it
    reads where it ends (measured from the far face). ``offset``: each point's reference distance, subtracted
    from its distances (:class:`~suture_fem.physics.effects.cone_contact.ConeContact`'s phi0).
    """
    start = np.asarray(start, dtype=float).reshape(-1, 2)
    way = np.asarray(end, dtype=float).reshape(-1, 2) - start
    if len(start) == 0:
        return np.zeros(0)
    poly = _prepared(_key(outline))[1]
    edge = np.roll(poly, -1, axis=0) - poly
    denom = _cross(way[:, None, :], edge[None, :, :])  # start + t way = poly_j + s edge_j where these cross
    rel = poly[None, :, :] - start[:, None, :]
    safe = np.where(denom == 0.0, 1.0, denom)
    t, s = _cross(rel, edge[None, :, :]) / safe, _cross(rel, way[:, None, :]) / safe
    cut = np.where((denom != 0.0) & (t > 0.0) & (t < 1.0) & (s >= 0.0) & (s < 1.0), t, 1.0)
    most = int(np.max(np.count_nonzero(cut < 1.0, axis=1)))  # the most crossings of one way
    ends = np.concatenate([np.zeros((len(start), 1)), np.sort(cut, axis=1)[:, :most], np.ones((len(start), 1))],
                          axis=1)
    fractions = np.arange(1, WAY_SAMPLES + 1) / (WAY_SAMPLES + 1)
    at = (ends[:, :-1, None] + fractions[None, None, :] * np.diff(ends, axis=1)[:, :, None]).reshape(len(start), -1)
    points = start[:, None, :] + at[:, :, None] * way[:, None, :]
    distance = project(points.reshape(-1, 2), outline).distance.reshape(at.shape)
    depth = -(distance - np.broadcast_to(np.asarray(offset, dtype=float), (len(start),))[:, None])
    return np.maximum(np.max(depth, axis=1), 0.0)


def meridian(xyz: np.ndarray) -> np.ndarray:
    """Points' (r, z) in the axisymmetric section: as they are in 2-D; (sqrt(x^2 + z^2), y) in 3-D (mm)."""
    if xyz.shape[1] == 2:
        return xyz
    return np.stack([np.hypot(xyz[:, 0], xyz[:, 2]), xyz[:, 1]], axis=1)


def radial_directions(xyz: np.ndarray) -> np.ndarray:
    """Each 3-D point's unit vector (x, 0, z) / r off the thread's axis, y (-x on the axis itself)."""
    e = np.stack([xyz[:, 0], np.zeros(len(xyz)), xyz[:, 2]], axis=1)
    r = np.linalg.norm(e, axis=1)
    e[r == 0.0] = (-1.0, 0.0, 0.0)
    return e / np.where(r == 0.0, 1.0, r)[:, None]
