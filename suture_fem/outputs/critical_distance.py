"""SEQV and EPTOEQV averaged over a disc of radius ``output.critical_distance_mm``, maximised over positions.

The theory of critical distances (area method): the stress and strain averaged over a disc of the
r-z section (weighted by 2 pi r) of a named radius, at the position where that average is largest,
over the disc's part in the region (each tissue layer, and the whole tissue). An integral of the
field, it has a limit under refinement even at a sharp cone rim. The averaging is in
:mod:`suture_fem.outputs.disc`; results.json gives the value and the disc's centre (``_at_mm``).

The largest average of the tissue need not be a cone's: on the paper scene the thread's exit from the
pulled face concentrates strain (and, with rounded rims, stress) more than any cone. The cone-count
question of the paper is about the cones, so each average is also given with the disc's centre near a
cone (``seqv_cd_cone_pa``, ``eptoeqv_cd_cone``: within :data:`CONE_ZONE_RADII` critical distances of a
cone's surface), for the whole tissue only (the cones stand in the hypodermis: a layer's own value would
repeat the tissue's or be absent) and only with cones.

In 3-D the disc is a ball (:mod:`suture_fem.outputs.ball_search`: the same keys, the centre (x, y, z), near a
cone measured in (r, y) = (sqrt(x^2 + z^2), y)).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from suture_fem.geometry.regions import MM, TISSUE_REGIONS, WHOLE_TISSUE
from suture_fem.outputs.ball_search import BallRegion, ball_maxima
from suture_fem.outputs.base import REPORT_REGIONS, Maximum, Quantity, Setup, State
from suture_fem.outputs.disc import CellField, DiscMax, DiscPoints, coarse_starts, max_disc_average, top_points
from suture_fem.outputs.eptoeqv import Eptoeqv
from suture_fem.outputs.seqv import Seqv
from suture_fem.scene.schema import OutputSection
from suture_fem.support import compat

#: The averaged fields: (results.json name, the ``output.quantities`` option, values at the points of a region).
FIELDS = (
    ("seqv_cd_pa", Seqv.option, lambda state, region: state.von_mises(region)),
    ("eptoeqv_cd", Eptoeqv.option, lambda state, region: state.hencky(region)[0]),
)


#: The same averages with the disc's centre near a cone: results.json names.
CONE_NAMES = {"seqv_cd_pa": "seqv_cd_cone_pa", "eptoeqv_cd": "eptoeqv_cd_cone"}
#: "Near a cone": the disc's centre at most this many critical distances from a cone's surface, so the
#: disc reaches the band of the tissue the cone's surface strains. The concentrations the cones do not
#: cause lie farther: the thread's exit from the pulled face is 3 mm beyond the last cone's apex on the
#: paper scene (30 critical distances at the default 0.1 mm). The zone grows with the critical
#: distance: from 1 mm on it reaches that exit on the paper scene; and a near-cone maximum whose disc
#: sits on the zone's edge lies on the slope of a concentration outside it (its ``_at_mm`` shows it).
CONE_ZONE_RADII = 3.0


def _box(comm: Any, xy: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box (lo, hi) of a region's points on every rank (collective)."""
    from mpi4py import MPI

    pts = xy.reshape(-1, 2) if xy is not None else np.zeros((0, 2))
    lo, hi = np.empty(2), np.empty(2)
    comm.Allreduce(pts.min(axis=0) if len(pts) else np.full(2, np.inf), lo, op=MPI.MIN)
    comm.Allreduce(pts.max(axis=0) if len(pts) else np.full(2, -np.inf), hi, op=MPI.MAX)
    return lo, hi


def _maximum(found: DiscMax) -> Maximum:
    return Maximum(found.value, [c / MM for c in found.at] if found.at is not None else None)


def cone_distance(cones: list[Any], points: np.ndarray) -> np.ndarray:
    """Distance (mm) of points (k, 2) in mm to the nearest cone surface (arcs taken as 16 chords each)."""
    return _segment_distance(cone_segments(cones), points)


def cone_segments(cones: list[Any]) -> tuple[np.ndarray, np.ndarray] | None:
    """The cones' outlines as straight segments (start points, end points; mm), each arc as 16 chords; None: no cone."""
    a, b = [], []
    for cone in cones:
        for kind, seg in cone.outline:
            if kind == "line":
                a.append(seg[0])
                b.append(seg[1])
                continue
            (p, c, q) = (np.asarray(x, dtype=float) for x in seg)
            t0, t1 = np.arctan2(*(p - c)[::-1]), np.arctan2(*(q - c)[::-1])
            t1 = t0 + (t1 - t0 + np.pi) % (2 * np.pi) - np.pi  # the short way round: a fillet is under a half turn
            t = np.linspace(t0, t1, 17)
            arc = c + np.linalg.norm(p - c) * np.column_stack([np.cos(t), np.sin(t)])
            a.extend(arc[:-1])
            b.extend(arc[1:])
    return (np.asarray(a, dtype=float), np.asarray(b, dtype=float)) if a else None


def _segment_distance(segments: tuple[np.ndarray, np.ndarray] | None, points: np.ndarray) -> np.ndarray:
    """Distance of points (k, 2) to the nearest of the segments (inf without any)."""
    if segments is None:
        return np.full(len(points), np.inf)
    a, b = segments
    d = b - a
    along = np.einsum("kij,ij->ki", points[:, None, :] - a[None], d) / np.maximum((d * d).sum(axis=1), 1e-300)
    t = np.clip(along, 0.0, 1.0)
    nearest = a[None] + t[..., None] * d[None]
    return np.sqrt(((points[:, None, :] - nearest) ** 2).sum(axis=2)).min(axis=1)


class CriticalDistance(Quantity):
    """``seqv_cd_pa`` and ``eptoeqv_cd`` per tissue layer and tissue, the near-cone variants for the tissue.

    Per layer only with ``output.critical_distance_layers`` (the whole tissue's values do not depend on it:
    each region's search is its own).
    """

    option = None

    @classmethod
    def wanted(cls, quantities: tuple[str, ...]) -> bool:
        """Asked for with SEQV or EPTOEQV (each average with its own field)."""
        return any(option in quantities for _, option, _ in FIELDS)

    @staticmethod
    def describe(output: OutputSection, dimension: int = 2) -> dict[str, str]:
        """Where the averages are taken (a disc of the r-z section in 2-D, a ball in 3-D)."""
        if output.critical_distance_mm <= 0:
            return {}
        radius = f"{output.critical_distance_mm:g} mm (output.critical_distance_mm)"
        if dimension == 3:
            shape, centre = (f"ball of radius {radius} over the ball's part in the region, the half model read on its "
                             "mirror image (the whole solid's ball)", "the ball's centre (x, y, z)")
        else:
            shape, centre = (f"disc of radius {radius} in the r-z section, weighted by 2 pi r, over the disc's part "
                             "in the region", "the disc's centre")
        disc = (f"average over a {shape}, at the position where it is largest (theory of critical distances); "
                f"_at_mm is {centre}; converges under refinement")
        near = (f"; the same with the {shape.split()[0]}'s centre within {CONE_ZONE_RADII:g} critical distances of a "
                "cone's surface (the concentration the cones cause, apart from the thread's exit and other far ones)")
        return {"seqv_cd_pa": "von Mises stress " + disc, "eptoeqv_cd": "equivalent Hencky strain " + disc,
                "seqv_cd_cone_pa": "von Mises stress " + disc + near, "eptoeqv_cd_cone": "equivalent Hencky strain "
                + disc + near}

    def __init__(self, setup: Setup, radius_mm: float | None = None):
        super().__init__(setup)
        self.radius = (setup.output.critical_distance_mm if radius_mm is None else radius_mm) * MM
        self.fields = [(name, fn) for name, option, fn in FIELDS if option in setup.quantities]
        points = setup.points
        mesh = setup.physics.mesh
        owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self.parts: dict[str, Any] = {}
        self.stacked: set[str] = set()  # regions whose cells are their layers' cells in order (the whole tissue)
        self._fits: tuple[State | None, dict] = (None, {})  # the fitted coefficients of the state last evaluated
        segments = cone_segments(setup.physics.tagged.geometry.cones)  # once: the search asks for every grid
        zone = CONE_ZONE_RADII * self.radius / MM
        self.near_cones = (None if segments is None else
                           lambda c: _segment_distance(segments, np.asarray(c) / MM) <= zone)
        self.balls: dict[str, Any] = {}  # 3-D: each region's ball search
        if self.radius <= 0 or points is None:
            return
        layers_too = setup.output.critical_distance_layers  # each layer's own search: about 60 % of the cost
        for region in (*TISSUE_REGIONS, WHOLE_TISSUE) if layers_too else (WHOLE_TISSUE,):
            layers = TISSUE_REGIONS if region == WHOLE_TISSUE else (region,)
            cells = np.concatenate([points.cells[t] for r in layers for t in REPORT_REGIONS[r] if len(points.cells[t])]
                                   or [np.zeros(0, dtype=np.int32)])
            mine = cells < owned
            if mesh.geometry.dim == 3:
                self.balls[region] = self._ball(region, layers, cells[mine], mine, segments, zone)
                continue
            xy = np.concatenate([points.xy[r] for r in layers]).reshape(len(cells), -1, 2) if len(cells) else None
            locate = compat.cell_locator(mesh, cells[mine])
            self.parts[region] = (layers, cells[mine], mine, None if xy is None else xy[mine], locate,
                                  _box(setup.physics.comm, xy), DiscPoints(locate))
        if layers_too and len(self.parts) == len(TISSUE_REGIONS) + 1 and np.array_equal(
                self.parts[WHOLE_TISSUE][1], np.concatenate([self.parts[r][1] for r in TISSUE_REGIONS])):
            self.stacked.add(WHOLE_TISSUE)

    def _ball(self, region: str, layers: tuple[str, ...], cells: np.ndarray, mine: np.ndarray, segments: Any,
              zone: float) -> tuple[Any, ...]:
        """A region's 3-D search: (layers, which of its cells are owned, :class:`BallRegion`, near the cones).

        The 3-D models are half models (z <= 0, symmetric about z = 0): the balls are read on the mirror.
        A centre is near a cone when its (r, z) = (sqrt(x^2 + z^2), y) is (the thread along y).
        """
        ball = BallRegion(self.setup.physics.mesh, cells, self.radius, mirror_z=True)
        near = None
        if segments is not None and region == WHOLE_TISSUE:
            def allowed(c: np.ndarray) -> np.ndarray:
                c = np.asarray(c, dtype=float).reshape(-1, 3)
                return _segment_distance(segments, np.column_stack([np.hypot(c[:, 0], c[:, 2]), c[:, 1]]) / MM) <= zone

            near = (allowed, allowed(ball.centroids))
        return layers, mine, ball, near

    def _measure_ball(self, state: State, region: str) -> dict[str, Any]:
        """The 3-D maxima: each field's cell values (the mean over a cell's points) searched over balls."""
        layers, mine, ball, near = self.balls[region]
        out: dict[str, Any] = {}
        for name, fn in self.fields:
            values = np.concatenate([fn(state, r) for r in layers])
            values = values.reshape(len(mine), -1)[mine].mean(axis=1) if len(mine) else np.zeros(0)
            found, near_max = ball_maxima(ball, values, near)
            if near_max is not None and near_max.at is not None:
                out[CONE_NAMES[name]] = _maximum(near_max)
            out[name] = _maximum(found)
        return out

    def _measure(self, state: State, region: str) -> dict[str, Any]:
        if region in self.balls:
            return self._measure_ball(state, region)
        if region not in self.parts:
            return {}
        xy = self.parts[region][3]
        out: dict[str, Any] = {}
        for name, fn in self.fields:
            field, values = self.field(state, region, fn)
            flat_xy = xy.reshape(-1, 2) if xy is not None else np.zeros((0, 2))
            starts = (top_points(state.comm, values.reshape(-1), flat_xy, self.radius),
                      coarse_starts(field, *self.parts[region][5], self.radius))
            known: dict = {}  # the two searches share the averages they both compute
            found = max_disc_average(field, starts, self.radius, known=known)
            if self.near_cones is not None and region == WHOLE_TISSUE:
                near = found
                if found.at is None or not self.near_cones(np.array([found.at]))[0]:
                    near = max_disc_average(field, starts, self.radius, self.near_cones, known)
                if near.value > found.value:  # the restricted search found more: the overall maximum is that
                    found = near
                if near.at is not None:
                    out[CONE_NAMES[name]] = _maximum(near)
            out[name] = _maximum(found)
        return out

    def field(self, state: State, region: str, fn: Any) -> tuple[CellField, np.ndarray]:
        """A region's field ``fn`` (a function of :data:`FIELDS`) at the state: (the fitted field, its point values)."""
        layers, cells, mine, xy, locate, _, discs = self.parts[region]
        values = np.concatenate([fn(state, r) for r in layers])
        if not len(mine):
            values = np.zeros((0, 1))
        else:  # a rank's own cells only (a view where they all are)
            values = values.reshape(len(mine), -1)
            values = values if mine.all() else values[mine]
        xy = xy if xy is not None else np.zeros((0, 1, 2))
        if self._fits[0] is not state:
            self._fits = (state, {})
        fits = self._fits[1]
        coeffs = None
        if region in self.stacked and all((fn, r) in fits for r in layers):  # each cell's fit is its own: the
            coeffs = np.concatenate([fits[fn, r] for r in layers])  # same points and values, the same numbers
        field = CellField(self.setup.physics.mesh, cells, xy, values, locate, discs, coeffs=coeffs)
        fits[fn, region] = field.coeffs
        return field, values

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """The largest disc averages of one tissue layer (collective)."""
        return self._measure(state, region) if region in TISSUE_REGIONS else {}

    def in_tissue(self, state: State) -> dict[str, Any]:
        """The largest disc averages over the whole tissue (discs may cross the layers' interfaces)."""
        return self._measure(state, WHOLE_TISSUE)
