"""Geometry of the axisymmetric half-section, derived from a scene (pure Python, no gmsh).

Coordinates are (r, z) in millimetres; the thread lies on the axis r = 0. The tissue cylinder spans
z in [0, L]; the far tissue face is z = 0 and the pulled end is at the top: the thread leaves the
tissue at z = L and ends at z = L + thread_free_length, where the force acts along +z.

Cone i (i = 0 nearest the far end) has its base at z = margin_far + i * spacing when the apex
points toward the pulled end (the default); the cone span is (n - 1) * spacing + height.

A hollow cone is the frustum shell between the outer conical surface and a parallel inner surface
one wall thickness inside it (measured normal to the wall), closed at the apex by a flat cap of the
same thickness and open at the base; its inside is hypodermis. A full cone is the solid frustum.
Both sit on the thread surface r = r_t.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from suture_fem.geometry.slab import Slab
from suture_fem.scene.schema import GeometrySection
from suture_fem.support.errors import SceneError

Point = tuple[float, float]
#: ("line", (p, q)) or ("arc", (p, centre, q)): one piece of a closed outline.
Segment = tuple[str, tuple[Point, ...]]

#: Smallest gap (mm) the geometry accepts between two surfaces (below it the mesh degenerates).
MIN_GAP_MM = 5e-3


@dataclass(frozen=True)
class Cone:
    """One cone: its closed outline (counter-clockwise not guaranteed) and its corner points.

    ``points`` are the outline's vertices before filleting and ``radii`` the fillet radius at each filleted one.
    """

    base_z: float
    apex_z: float
    outline: list[Segment]
    corners: list[Point]
    points: list[Point] = field(default_factory=list)
    radii: dict[int, float] = field(default_factory=dict)

    def arcs(self) -> list[tuple[Point, Point, Point, float, float]]:
        """Each fillet arc of the outline: (start, centre, end, radius, length), mm."""
        out = []
        for a, c, b in (seg for kind, seg in self.outline if kind == "arc"):
            radius = math.dist(a, c)
            angle = math.acos(max(-1.0, min(1.0, ((a[0] - c[0]) * (b[0] - c[0]) + (a[1] - c[1]) * (b[1] - c[1]))
                                                / radius**2)))
            out.append((a, c, b, radius, radius * angle))
        return out

    def rounded(self, radius: float, r_thread: float, to_axis: bool = False) -> list[Segment]:
        """The outline with every sharp corner off the thread rounded by at most ``radius`` (the fillets kept).

        The contact search's outline: a convex corner's outward normal jumps, so a node pressed into it
        would have two equilibria; a rounded one turns the normal continuously. A re-entrant corner (a hollow
        cone's cavity floor meeting its inner flank) is rounded too, its arc within 0.225 of its shorter real
        edge from it (the tissue's faces, not the search's floor extended to the axis): the tissue node in that corner,
        pressed by both faces, otherwise had a normal that jumped between them at zero distance, and Newton
        found no equilibrium when a multiplier held it there. The fillet puts cone a few um inside that node at
        rest; its gap is measured from there (``phi0``).

        ``to_axis``: the cone's side on the thread moved to the axis (its points at r = r_thread to r = 0): the
        cone and the thread inside it as one body, the contact search's outline. No tissue faces the cone's own
        side on the thread: a track node (on r = r_thread) would pass it with no gap at all, and a node beside
        the apex cap, squeezed toward the thread, would find it nearer than the cap's face.
        """
        pts = self.points
        if to_axis:
            pts = [(0.0 if abs(r - r_thread) <= 1e-9 else r, z) for r, z in pts]
        area = sum(p[0] * q[1] - q[0] * p[1] for p, q in zip(pts, pts[1:] + pts[:1]))

        def turn(i: int) -> float:  # > 0 at a convex corner, < 0 at a re-entrant one
            a, b, c = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
            return ((b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])) * math.copysign(1.0, area)

        off = [i for i, p in enumerate(pts) if p[0] > r_thread + 1e-9 and (i in self.radii or turn(i) > 0.0)]
        fit = {i: min(radius, 0.5 * _max_radius(pts, i)) for i in off}  # short edges get smaller ones
        inner = [i for i, p in enumerate(pts) if p[0] > r_thread + 1e-9 and i not in self.radii and turn(i) < -1e-12]
        fit.update({i: min(radius, 0.5 * _max_radius(self.points, i)) for i in inner})  # the real edges
        return _outline(pts, {i: self.radii.get(i, fit[i]) for i in off + inner})


@dataclass(frozen=True)
class Geometry:
    """All dimensions (mm) of the half-section.

    Attributes:
        r_thread: thread radius.
        r_hypodermis, r_dermis, r_epidermis: outer radii of the three tissue layers.
        length: tissue length L.
        z_end: axial position of the thread's pulled end face.
        cones: the cones, far end first.
        slab: the slab's planes (3-D ``geometry.tissue_shape = "slab"``), None for the cylinder.
    """

    r_thread: float
    r_hypodermis: float
    r_dermis: float
    r_epidermis: float
    length: float
    z_end: float
    cones: list[Cone] = field(default_factory=list)
    kind: str = "hollow"
    slab: Slab | None = None

    @property
    def corners(self) -> list[Point]:
        """Every cone corner off the thread (where the stress is singular when sharp)."""
        return [p for c in self.cones for p in c.corners]

    @classmethod
    def from_section(cls, g: GeometrySection) -> Geometry:
        """Build the geometry, rejecting dimensions that do not fit (SceneError names the keys)."""
        n, h = g.cones, g.cone_height_mm
        r_t = g.thread_radius_mm
        r_base, r_top = g.cone_base_diameter_mm / 2, g.cone_top_diameter_mm / 2
        r_h = g.hypodermis_mm
        if n > 0:
            if r_top <= r_t + MIN_GAP_MM:
                raise SceneError(
                    "scene key geometry.cone_top_diameter_mm must exceed the thread diameter "
                    f"2 * geometry.thread_radius_mm = {2 * r_t:g} mm, got {2 * r_top:g} mm"
                )
            if r_base < r_top:
                raise SceneError(
                    "scene key geometry.cone_base_diameter_mm must be >= geometry.cone_top_diameter_mm "
                    f"({2 * r_top:g} mm), got {2 * r_base:g} mm"
                )
            if r_base >= r_h - MIN_GAP_MM:
                raise SceneError(
                    "cones do not fit inside the hypodermis: geometry.cone_base_diameter_mm / 2 = "
                    f"{r_base:g} mm must be < geometry.hypodermis_mm = {r_h:g} mm"
                )
        if r_t >= r_h - MIN_GAP_MM:
            raise SceneError(
                f"scene key geometry.thread_radius_mm = {r_t:g} must be < geometry.hypodermis_mm = {r_h:g}"
            )
        if n > 1 and g.cone_spacing_mm <= h + MIN_GAP_MM:
            raise SceneError(
                "cones overlap: geometry.cone_spacing_mm (base to base) must be > geometry.cone_height_mm "
                f"= {h:g} mm, got {g.cone_spacing_mm:g} mm"
            )
        span = (n - 1) * g.cone_spacing_mm + h if n > 0 else 0.0
        length = g.margin_far_mm + span + g.margin_pull_mm
        cones = []
        for i in range(n):
            z_lo = g.margin_far_mm + i * g.cone_spacing_mm
            cones.append(_cone(g, z_lo, r_t, r_base, r_top))
        return cls(
            r_thread=r_t,
            r_hypodermis=r_h,
            r_dermis=r_h + g.dermis_mm,
            r_epidermis=r_h + g.dermis_mm + g.epidermis_mm,
            length=length,
            z_end=length + g.thread_free_length_mm,
            cones=cones,
            kind=g.cone_kind,
            slab=Slab.from_section(g) if g.tissue_shape == "slab" and g.dimension == 3 else None,
        )

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary of the derived dimensions."""
        return {
            "tissue_length_mm": self.length,
            "thread_end_z_mm": self.z_end,
            "layer_outer_radii_mm": [self.r_hypodermis, self.r_dermis, self.r_epidermis],
            "cones": [{"base_z_mm": c.base_z, "apex_z_mm": c.apex_z} for c in self.cones],
            "corners_mm": [list(p) for p in self.corners],
            **({"slab": self.slab.describe()} if self.slab is not None else {}),
        }


def _cone(g: GeometrySection, z_lo: float, r_t: float, r_base: float, r_top: float) -> Cone:
    """Outline of one cone with its base at z_lo (apex up); mirrored when the base faces the pull."""
    h, wall, fillet = g.cone_height_mm, g.cone_wall_mm, g.cone_fillet_mm
    tan_a = (r_base - r_top) / h  # half-angle of the cone
    w = wall * math.sqrt(1.0 + tan_a**2)  # horizontal width of a wall of normal thickness `wall`
    z_b, z_a = z_lo, z_lo + h
    if g.cone_kind == "full":
        pts = [(r_t, z_a), (r_top, z_a), (r_base, z_b), (r_t, z_b)]
        fillet_at = {2}
        corners = [(r_top, z_a), (r_base, z_b)]
    else:
        z_c = z_a - wall  # underside of the apex cap
        r_cavity_top = r_top + tan_a * wall - w
        if wall >= h - MIN_GAP_MM or r_cavity_top <= r_t + MIN_GAP_MM or r_base - w <= r_t + MIN_GAP_MM:
            raise SceneError(
                f"scene key geometry.cone_wall_mm = {wall:g} leaves no hollow inside the cone (the wall "
                f"must be thinner than the gap between the thread, r = {r_t:g} mm, and the cone's outer "
                "surface near its top); use a thinner wall or geometry.cone_kind = \"full\""
            )
        pts = [(r_t, z_a), (r_top, z_a), (r_base, z_b), (r_base - w, z_b), (r_cavity_top, z_c), (r_t, z_c)]
        fillet_at = {2, 3}
        corners = [(r_top, z_a), (r_base, z_b), (r_base - w, z_b), (r_cavity_top, z_c)]
    base_z, apex_z = z_b, z_a
    if g.cone_orientation == "base_to_pull":
        base_z, apex_z = z_a, z_b
        mid = z_b + z_a
        pts = [(r, mid - z) for r, z in pts]
        corners = [(r, mid - z) for r, z in corners]
    radii = {i: fillet for i in fillet_at} if fillet > 0 else {}
    return Cone(base_z=base_z, apex_z=apex_z, outline=_outline(pts, radii), corners=corners, points=pts, radii=radii)


def _outline(pts: list[Point], radii: dict[int, float]) -> list[Segment]:
    """Closed polyline through pts, with a circular fillet of ``radii[i]`` at each vertex i it names."""
    n = len(pts)
    starts: list[Point] = list(pts)
    ends: list[Point] = list(pts)
    arcs: dict[int, tuple[Point, Point, Point]] = {}
    for i, radius in sorted(radii.items()):
        p, prev, nxt = pts[i], pts[i - 1], pts[(i + 1) % n]
        u = _unit(prev, p)
        v = _unit(nxt, p)
        theta = math.acos(max(-1.0, min(1.0, u[0] * v[0] + u[1] * v[1])))
        t = radius / math.tan(theta / 2)  # distance from the corner to each tangent point
        if radius > _max_radius(pts, i):
            raise SceneError(
                f"scene key geometry.cone_fillet_mm = {radius:g} is too large for the cone's rim: "
                f"allowed range 0 to {_max_radius(pts, i):.4g} mm for this cone"
            )
        a = (p[0] + t * u[0], p[1] + t * u[1])
        b = (p[0] + t * v[0], p[1] + t * v[1])
        bis = _unit((p[0] + u[0] + v[0], p[1] + u[1] + v[1]), p)
        d = radius / math.sin(theta / 2)
        c = (p[0] + d * bis[0], p[1] + d * bis[1])
        arcs[i] = (a, c, b)
        ends[i], starts[i] = a, b  # the edge into vertex i ends at a; the edge out starts at b
    segments: list[Segment] = []
    for i in range(n):
        j = (i + 1) % n
        segments.append(("line", (starts[i], ends[j])))
        if j in arcs:
            segments.append(("arc", arcs[j]))
    return segments


def _max_radius(pts: list[Point], i: int) -> float:
    """The largest fillet at vertex i whose tangent points stay within 45 % of each edge from it."""
    p, prev, nxt = pts[i], pts[i - 1], pts[(i + 1) % len(pts)]
    u, v = _unit(prev, p), _unit(nxt, p)
    theta = math.acos(max(-1.0, min(1.0, u[0] * v[0] + u[1] * v[1])))
    return 0.45 * min(_dist(p, prev), _dist(p, nxt)) * math.tan(theta / 2)


def _unit(q: Point, p: Point) -> Point:
    dx, dy = q[0] - p[0], q[1] - p[1]
    norm = math.hypot(dx, dy)
    return dx / norm, dy / norm


def _dist(p: Point, q: Point) -> float:
    return math.hypot(p[0] - q[0], p[1] - q[1])
