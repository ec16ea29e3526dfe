"""What every output quantity shares.

The Quantity base class, the reduction of a maximum with its location, the von Mises and Hencky
helpers, and the stress and strain at the quadrature points.

Every quantity follows one pattern: it computes its values on this rank, then reduces them over all
ranks (collective, so every rank evaluates the same quantities in the same order). A maximum is
reduced with its location; a rank that owns no value (no cell of a region) takes part with -inf.

The stress and strain outputs (SEQV, EPTOEQV) are taken at the quadrature points of the energy
integral: one compiled expression per material gives the in-plane components of the full 3x3 Cauchy
stress sigma = J^-1 P F^T and of the left Cauchy-Green tensor B = F F^T (hoop components included).
The points' coordinates are those of the reference configuration, so they, and which points lie
outside the rims, are evaluated once per run.
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import numpy as np
import ufl

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.regions import MM, REGION_OF_TAG, REGION_TAGS
from suture_fem.physics import kinematics
from suture_fem.physics.forms import quadrature_degree
from suture_fem.physics.materials import cauchy
from suture_fem.physics.problem import Physics
from suture_fem.scene.schema import OUTPUT_QUANTITIES, POINT_QUANTITIES, OutputSection
from suture_fem.support import compat

#: Regions reported separately (the suture is thread + cones).
REPORT_REGIONS = REGION_TAGS

#: The output options that need the stress and strain at the quadrature points.
POINT_OUTPUTS = frozenset(POINT_QUANTITIES)


def von_mises(s: np.ndarray) -> np.ndarray:
    """Von Mises equivalent of symmetric tensors as columns (rr, zz, tt, rz), or in 3-D (xx, yy, zz, xy, yz, xz)."""
    mean = (s[:, 0] + s[:, 1] + s[:, 2]) / 3.0
    d = s[:, :3] - mean[:, None]
    return np.sqrt(1.5 * (np.sum(d**2, axis=1) + 2.0 * np.sum(s[:, 3:] ** 2, axis=1)))


def hencky_equivalent(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(equivalent Hencky strain, J) from left Cauchy-Green tensors given as columns (rr, zz, tt, rz).

    The Hencky strain is h = 1/2 ln B (from the eigenvalues of B: the two in-plane ones and the hoop
    one); its equivalent is sqrt(2/3 dev(h):dev(h)), ANSYS's EPTOEQV with effective Poisson ratio 0.5.
    In 3-D the columns are (xx, yy, zz, xy, yz, xz) and the eigenvalues are numpy's.
    """
    if b.shape[1] == 6:
        full = np.stack([b[:, [0, 3, 5]], b[:, [3, 1, 4]], b[:, [5, 4, 2]]], axis=1)
        lam = np.linalg.eigvalsh(full) if len(b) else np.zeros((0, 3))
    else:
        half_tr = 0.5 * (b[:, 0] + b[:, 1])
        det2 = b[:, 0] * b[:, 1] - b[:, 3] ** 2
        disc = np.sqrt(np.maximum(half_tr**2 - det2, 0.0))
        lam = np.stack([half_tr + disc, half_tr - disc, b[:, 2]], axis=1)
    h = 0.5 * np.log(lam)
    dev = h - h.mean(axis=1, keepdims=True)
    return np.sqrt(2.0 / 3.0 * np.sum(dev**2, axis=1)), np.sqrt(np.prod(lam, axis=1))


class Maximum(NamedTuple):
    """A maximum over all ranks and where it is: (r, z) (3-D: (x, y, z)) in mm, None where nobody owns a value."""

    value: float
    at_mm: list[float] | None


def global_max(comm: Any, values: np.ndarray, coords: np.ndarray) -> Maximum:
    """Max over ranks with its (r, z) in mm; (-inf, None) where nobody owns a value (collective)."""
    if len(values):
        k = int(np.argmax(values))
        local = (float(values[k]), [float(c) / MM for c in coords[k, :3]])
    else:
        local = (-np.inf, None)
    return Maximum(*max(comm.allgather(local), key=lambda t: t[0]))


class PointFields:
    """The stress and strain tensors at the quadrature points of the energy integral, per cell tag.

    ``tensor_exprs[tag]`` is the compiled expression of the tag's material: 8 components per point,
    the in-plane Cauchy stress (rr, zz, tt, rz) then B (rr, zz, tt, rz); in 3-D 12, the six of each.
    """

    def __init__(self, physics: Physics, output: OutputSection):
        self.physics = physics
        self.dim = gdim = physics.mesh.geometry.dim
        self.width = 8 if gdim == 2 else 12
        points = compat.quadrature_points("triangle" if gdim == 2 else "tetrahedron", quadrature_degree(physics.degree))
        F = physics.F
        B = F * F.T
        self.tensor_exprs: dict[int, Any] = {}
        by_region: dict[str, Any] = {}
        for tag, region in REGION_OF_TAG.items():
            if region not in by_region:
                sigma = cauchy(physics.materials[region], F)
                comps = kinematics.in_plane(sigma, gdim) + kinematics.in_plane(B, gdim)
                by_region[region] = compat.expression(ufl.as_vector(comps), points)
            self.tensor_exprs[tag] = by_region[region]
        self.cells = {tag: meshmod.region_cells(physics.tagged, tag) for tag in self.tensor_exprs}
        x_expr = compat.expression(physics.x, points)
        self.xy = {region: self._stack(region, lambda tag: self._eval(x_expr, self.cells[tag]).reshape(-1, gdim), gdim)
                   for region in REPORT_REGIONS}
        self.outside_rims = {region: self._outside_rims(xy, output) for region, xy in self.xy.items()}

    def tensors(self, tag: int) -> np.ndarray:
        """The 8 (3-D: 12) components at every quadrature point of the tag's local cells, one row per point."""
        return self._eval(self.tensor_exprs[tag], self.cells[tag]).reshape(-1, self.width)

    def region_tensors(self, region: str) -> np.ndarray:
        """:meth:`tensors` of every tag of a region, stacked in the order of :attr:`xy`."""
        return self._stack(region, self.tensors, self.width)

    def _stack(self, region: str, per_tag: Any, width: int) -> np.ndarray:
        parts = [per_tag(tag) for tag in REPORT_REGIONS[region] if len(self.cells[tag])]
        return np.concatenate(parts) if parts else np.zeros((0, width))

    def _eval(self, expr: Any, cells: np.ndarray) -> np.ndarray:
        return compat.eval_expression(expr, self.physics.mesh, cells)

    def _outside_rims(self, xy: np.ndarray, output: OutputSection) -> np.ndarray:
        """Which points lie outside the rims.

        Outside: farther than ``output.rim_exclusion_mm`` from every cone corner and from the two
        points where the thread crosses the tissue's end faces (all re-entrant corners of the
        suture-tissue interface). In 3-D a point's (r, z) is (sqrt(x^2 + z^2), y).
        """
        if self.dim == 3 and len(xy):
            xy = np.column_stack([np.hypot(xy[:, 0], xy[:, 2]), xy[:, 1]])
        g = self.physics.tagged.geometry
        corners = np.array([*g.corners, (g.r_thread, 0.0), (g.r_thread, g.length)], dtype=float).reshape(-1, 2) * MM
        if len(corners) == 0 or len(xy) == 0:
            return np.ones(len(xy), dtype=bool)
        d = np.min(np.linalg.norm(xy[:, None, :] - corners[None, :, :], axis=2), axis=1)
        return d > output.rim_exclusion_mm * MM


class Setup:
    """What the quantities of one run share, built once.

    The physics, each region's displacement nodes and, when a stress or strain output is asked for,
    the :class:`PointFields`.
    """

    def __init__(self, physics: Physics, output: OutputSection, quantities: tuple[str, ...]):
        self.physics, self.output, self.quantities = physics, output, quantities
        V = physics.V
        self.node_xy = V.tabulate_dof_coordinates()[:, :physics.mesh.geometry.dim]
        dofs = compat.cell_dofs(V)
        self.region_nodes: dict[str, np.ndarray] = {}
        for name, tags in REPORT_REGIONS.items():
            cells = meshmod.region_cells(physics.tagged, tags)
            self.region_nodes[name] = np.unique(dofs[cells]) if len(cells) else np.zeros(0, dtype=np.int32)
        self.points = PointFields(physics, output) if POINT_OUTPUTS & set(quantities) else None


class State:
    """One evaluation of the current state.

    Caches what several quantities read: the point fields of a region are evaluated once, however
    many quantities use them.
    """

    def __init__(self, setup: Setup):
        self.setup = setup
        self.comm = setup.physics.comm
        self.force_n = setup.physics.applied_force_n()
        self._cache: dict[tuple[str, str], Any] = {}

    def von_mises(self, region: str) -> np.ndarray:
        """Von Mises stress (Pa) at the region's quadrature points on this rank."""
        return self._cached("von_mises", region, lambda t: von_mises(t[:, : t.shape[1] // 2]))

    def hencky(self, region: str) -> tuple[np.ndarray, np.ndarray]:
        """(equivalent Hencky strain, J) at the region's quadrature points on this rank."""
        return self._cached("hencky", region, lambda t: hencky_equivalent(t[:, t.shape[1] // 2:]))

    def _cached(self, name: str, region: str, of_tensors: Any) -> Any:
        if ("tensors", region) not in self._cache:
            self._cache["tensors", region] = self.setup.points.region_tensors(region)
        if (name, region) not in self._cache:
            self._cache[name, region] = of_tensors(self._cache["tensors", region])
        return self._cache[name, region]


class Quantity:
    """One output of the record, evaluated for the current state (collective).

    A subclass sets ``option``, the name in ``output.quantities`` that asks for it (None: always
    computed), and overrides :meth:`totals` (whole-body entries of the record) and/or
    :meth:`in_region` (entries of ``regions[region]``; each :class:`Maximum` is also maximized over
    the regions and over the tissue, and its location kept as ``<name>_at_mm``).
    """

    option: ClassVar[str | None] = None
    #: computed for the slab only: its ``where`` texts are in the record only when it is asked for
    slab_only: ClassVar[bool] = False

    def __init_subclass__(cls, **kwargs: Any) -> None:
        """A quantity's option is one of the names the scene declares (``scene.schema.OUTPUT_QUANTITIES``)."""
        super().__init_subclass__(**kwargs)
        if cls.option is not None and cls.option not in OUTPUT_QUANTITIES:
            raise TypeError(f"{cls.__name__}.option = {cls.option!r} is not declared in scene.schema.OUTPUT_QUANTITIES")

    def __init__(self, setup: Setup):
        self.setup = setup

    @classmethod
    def wanted(cls, quantities: tuple[str, ...]) -> bool:
        """Whether a scene asking for ``quantities`` (``output.quantities``) gets this one."""
        return cls.option is None or cls.option in quantities

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """Where its maxima are taken, for the record's ``where`` (name -> text)."""
        return {}

    def totals(self, state: State) -> dict[str, Any]:
        """Whole-body entries of the record (collective)."""
        return {}

    def in_region(self, state: State, region: str) -> dict[str, Any]:
        """Entries of one region (collective)."""
        return {}

    def in_tissue(self, state: State) -> dict[str, Any]:
        """Maxima of the whole tissue that are not the largest of the layers' (collective): they replace it."""
        return {}
