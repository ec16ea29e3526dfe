"""Coulomb friction between the thread and the tissue's side of its track (``effects.thread_interface = "coulomb"``).

The normal part is the frictionless thread's (:mod:`suture_fem.physics.effects.contact`): the tissue's
track nodes may leave the thread (u_r > 0) but not enter it, by the penalty p = kappa <-u_r>. The
tangential part acts node to node, between each track node a (the tissue's) and the thread's surface node
b it faced in the reference configuration, on the relative axial displacement g = u_z(a) - u_z(b):

    t = b_a tanh(g / s),   b_a -> mu p_a (Coulomb's slip limit),

s = ``effects.friction_slip_mm`` the regularising slip (CONTACT.md: a sharp stick/slip switch makes
Newton chatter; an arctan or elastic-slip law helps; MOOSE and FEBio regularise the same way). Node a
receives the residual w t and node b its opposite, w the node's 2 pi r-weighted lumped track area.
In 3-D (the half model, the thread along y) the same terms act on u_y, w is the node's lumped track area
doubled (the half model's weight) and p the penalty's nodal force along the node's e_r over w.

The bound b is held fixed during a Newton solve (Tresca friction: the terms are then the derivative of
w b s ln cosh(g / s), so the Jacobian stays symmetric and the line search's energy objective stays
exact), and moved to mu p between solves until it settles: a fixed point on the contact pressure
(Panagiotopoulos's process; Wriggers, Computational Contact Mechanics, 2006, section 10.5), relaxed by
Aitken's factor (:meth:`ThreadFriction.update_bound`); between its updates the state follows by chord steps
with the last factorisation, and a last full Newton solve gives the answer
(:func:`~suture_fem.physics.effects.fixed_point.settle`). A step is converged when the friction forces
differ from Coulomb's by less than the solver's absolute tolerance (:mod:`suture_fem.solve.newton`).
Coupling the bound to the pressure inside Newton (the non-symmetric Coulomb tangent) was tried first:
a track node at the open/closed kink with a large slip switches its friction force on and off between
iterations, and Newton stalled on the paper scene's first load step.

The law is written on the total slip g (a deformation theory of friction): the same as an incremental
law wherever the slip grows in one direction, which a monotone pull gives; a slip that reverses is not
followed (the traction flips only when g changes sign).

Pairing by reference position is exact for the rigid suture (every thread node moves by the same d) and
for the elastic suture up to the thread's stretch over the slip: the thread point facing node a after a
slip of length l is displaced by u_z(b) + eps l, eps the thread's axial strain (F / (pi r_t^2 E)), so g
is off by eps l where the tissue slips (the friction force there is b sign(g) either way) and the
friction force reaches the thread up to l from where it acts. No contact search is needed at any slip.

The terms are assembled here, by hand, from arrays of node pairs (UFL forms cannot couple two nodes that
share no cell), into the full residual and Jacobian before the solver's reduction; the Jacobian's
sparsity is extended once by the pairs' couplings.
"""

from __future__ import annotations

import math
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.outline import radial_directions
from suture_fem.geometry.regions import Facet
from suture_fem.physics import kinematics
from suture_fem.physics.constraints import mark_dofs
from suture_fem.physics.effects.contact import radial
from suture_fem.physics.effects.fixed_point import Aitken, Anderson, update_norms
from suture_fem.physics.effects.pattern import widen
from suture_fem.physics.forms import measures
from suture_fem.physics.residual_memo import ResidualMemo
from suture_fem.support import compat

#: Reference positions closer than this (m) are the same node of a split track (duplicated coordinates).
MATCH_TOLERANCE_M = 1e-12


class SlipBound:
    """The slip bound's fixed point, shared by the thread's and the cones' Coulomb terms.

    A subclass has ``comm``, ``mu``, ``weight`` (per pair, m^2), ``bound`` (per pair, Pa) and
    :meth:`pressure` (the contact pressure per pair now, Pa).
    """

    comm: Any
    mu: float
    weight: np.ndarray
    bound: np.ndarray
    #: :meth:`residual` before the last :meth:`update_bound` (N)
    last_residual: float = math.inf
    #: the last update's change of the bound relative to the bound (2-norms of w b): 1 from a bound of 0
    last_change: float = math.inf

    def pressure(self) -> np.ndarray:
        """The contact pressure at each pair now (Pa)."""
        raise NotImplementedError

    def start(self) -> None:
        """Forget the fixed point's history (a new load step's solve)."""
        self._aitken = Aitken(self.comm)
        self._anderson: Anderson | None = None

    def accelerate(self) -> None:
        """For the rest of this step, Anderson's acceleration from the bound as it is (:func:`.fixed_point.settle`)."""
        self._anderson = Anderson(self.comm)

    @property
    def accelerated(self) -> bool:
        """This step's updates go under Anderson's acceleration (:meth:`accelerate`)."""
        return self._anderson is not None

    def update(self, tolerance: float) -> bool:
        """One update between Newton solves; True when the law held to ``tolerance`` (N) before it (collective)."""
        return self.update_bound() <= tolerance

    def frozen(self) -> tuple[np.ndarray, ...]:
        """Copies of what the updates between solves hold (the bound): a state's part, kept with it."""
        return (self.bound.copy(),)

    def thaw(self, kept: tuple[np.ndarray, ...]) -> None:
        """Set what :meth:`frozen` returned."""
        self.bound = kept[0].copy()

    def reset(self) -> None:
        """At rest: no contact pressure yet, so no slip bound."""
        self.bound[:] = 0.0

    def residual(self) -> float:
        """How far the friction forces are from Coulomb's law: the 2-norm over the track of w |mu p - bound| (N)."""
        return math.sqrt(self.comm.allreduce(float(np.sum(self._gap_forces() ** 2))))

    def _gap_forces(self) -> np.ndarray:
        return self.weight * (self.mu * self.pressure() - self.bound)

    def update_bound(self) -> float:
        """One fixed-point update of the bound toward mu times the contact pressure now (collective).

        Returns :meth:`residual` before the update. The update is relaxed by Aitken's factor (Irons and
        Tuck 1969; Kuettler and Wall, Comput Mech 43:61, 2008), omega_k = -omega_{k-1} r_{k-1} . (r_k -
        r_{k-1}) / |r_k - r_{k-1}|^2, r the residual forces: a node that opens under a larger bound and
        closes under a smaller one makes the plain iteration cycle, and a steep pressure-to-bound map
        makes it diverge. After :meth:`accelerate`, Anderson's acceleration instead (:class:`.fixed_point.Anderson`).
        """
        r = self._gap_forces()
        old, area = self.bound, np.maximum(self.weight, 1e-300)
        if self._anderson is not None:
            self.bound = np.maximum(self._anderson.next(old, r / area, self.weight), 0.0)
        else:
            self.bound = np.maximum(old + self._aitken.factor(r) * r / area, 0.0)
        self.last_residual, self.last_change = update_norms(self.comm, r, self.weight * (self.bound - old),
                                                        self.weight * self.bound)
        return self.last_residual


class ThreadFriction(SlipBound):
    """Coulomb friction's nodal terms on a split thread track (see the module docstring).

    Built from arrays, so the same terms serve a scene's thread (:meth:`of_physics`) and a rigid surface
    (a verification's plug: one dof per pair, the surface's axial displacement in ``surface``).

    Attributes:
        mu: the friction coefficient; slip: s (m); pairs: the track nodes owned on this rank.
        dofs: (pairs, 2) global dofs (u_z(a), u_z(b)), or (pairs, 1) (u_z(a)) against a rigid surface.
        track: the nodes a in the normal force's vector; weight: (pairs,) their 2 pi r-weighted lumped
        track area (m^2); bound: (pairs,) the frozen slip limit b (Pa); surface: a rigid surface's u_z (m).
    """

    def __init__(self, comm: Any, state: Any, dofs: np.ndarray, weight: np.ndarray, track: np.ndarray, normal: Any,
                 mu: float, slip_m: float, radial: np.ndarray | None = None):
        """``state``: the state's PETSc vector; ``normal``: the compiled form of the penalty's nodal force.

        ``radial``: in 3-D, (pairs, 3) the unit vector e_r off the thread's axis at each track node (None in 2-D).
        """
        self.comm, self.mu, self.slip = comm, float(mu), float(slip_m)
        self.radial = radial
        self.dofs, self.weight, self.track, self._normal = dofs, weight, track, normal
        self.pairs = len(weight)
        self.surface = 0.0
        self.bound = np.zeros(self.pairs)
        self.start()
        self._local = PETSc.Vec().createSeq(dofs.size, comm=PETSc.COMM_SELF)
        index = PETSc.IS().createGeneral(dofs.ravel().astype(PETSc.IntType), comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(state, index, self._local, None)
        index.destroy()

    @classmethod
    def of_physics(cls, physics: Any, mu: float, kappa: float, slip_m: float) -> ThreadFriction:
        """A scene's: the tissue's owned track nodes paired with the thread's surface nodes they faced."""
        track, thread, weight = _nodes(physics)
        dofs, weight = _pairs(physics, track, thread, weight)
        xyz = physics.V.tabulate_dof_coordinates()[track]
        e_r = radial_directions(xyz) if physics.mesh.geometry.dim == 3 else None
        return cls(physics.comm, compat.function_vector(physics.state), dofs, weight, track,
                   _normal_form(physics, kappa), mu, slip_m, e_r)

    @classmethod
    def on(cls, physics: Any, section: Any, kappa: float) -> ThreadFriction:
        """The friction of a built Physics (its track split, its normal penalty kappa); its numbers join the record.

        ``section``: the scene's ``[effects]`` (``friction_coefficient``, ``friction_slip_mm``).
        """
        friction = cls.of_physics(physics, section.friction_coefficient, kappa, section.friction_slip_mm * regions.MM)
        physics.notes.setdefault("interfaces", {}).update(friction.notes())
        return friction

    def _slips(self, u_vec: Any) -> np.ndarray:
        """G = u_z(a) - u_z(b) (or - the surface's u_z) per pair at the state vector ``u_vec`` (m; collective)."""
        self._scatter.scatter(u_vec, self._local, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        values = self._local.getArray(readonly=True).reshape(self.pairs, self.dofs.shape[1])
        return values[:, 0] - (values[:, 1] if values.shape[1] > 1 else self.surface)

    def law(self, g: np.ndarray) -> dict[str, np.ndarray]:
        """Traction t (Pa, on the tissue's node against its slip g) at the frozen bound, and its slip derivative."""
        th = np.tanh(g / self.slip)
        return {"t": self.bound * th, "dt_dg": self.bound * (1.0 - th * th) / self.slip}

    def pressure(self) -> np.ndarray:
        """The contact pressure at each pair's track node now (Pa): the penalty's normal force there over w.

        The force is the penalty term's own (consistent) nodal force, the one the tissue balances, so the
        friction bound mu p and the interface output's nominal pressure are the same number. In 3-D its
        component along the node's e_r (the force's x and z parts follow e_r across the node's facets); the
        output projects on the facets' averaged normal instead, which the polygonal track tilts off e_r.
        """
        b = dolfinx.fem.petsc.assemble_vector(self._normal)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.radial is None:
            force = b.array[2 * self.track]
        else:
            force = np.sum(b.array[3 * self.track[:, None] + np.arange(3)] * self.radial, axis=1)
        b.destroy()
        return np.maximum(force, 0.0) / self.weight

    def potential(self, u_vec: Any) -> float:
        """Sum of w b s ln cosh(g / s), b the frozen bound: the terms' potential, for the line search (collective)."""
        x = np.abs(self._slips(u_vec)) / self.slip
        log_cosh = x + np.log1p(np.exp(-2.0 * x)) - math.log(2.0)
        return float(self.comm.allreduce(float(np.sum(self.weight * self.bound * self.slip * log_cosh))))

    def forces(self, u_vec: Any) -> np.ndarray:
        """W t per pair (N): the axial friction force the tissue's node resists its slip with (collective)."""
        return self.weight * self.law(self._slips(u_vec))["t"]

    def add_residual(self, u_vec: Any, b: Any) -> None:
        """Add w t to node a's and -w t to node b's axial residual (b: the full residual, assembled; collective)."""
        f = self.forces(u_vec)
        values = np.stack([f, -f], axis=1)[:, : self.dofs.shape[1]]
        b.setValues(self.dofs.ravel().astype(PETSc.IntType), values.ravel(), addv=PETSc.InsertMode.ADD_VALUES)
        b.assemble()

    def add_jacobian(self, u_vec: Any, A: Any) -> None:
        """Add the terms' derivative (symmetric: the bound is frozen) to the full Jacobian A, assembled (collective)."""
        kg = self.weight * self.law(self._slips(u_vec))["dt_dg"]
        n = self.dofs.shape[1]
        if self.pairs:  # each pair's block as compressed rows, in one call
            block = (kg[:, None, None] * np.array([[1.0, -1.0], [-1.0, 1.0]]))[:, :n, :n]
            rows = self.dofs.astype(PETSc.IntType)
            A.setValuesIJV(np.arange(0, rows.size * n + 1, n, dtype=PETSc.IntType), np.repeat(rows, n, axis=0).ravel(),
                           block.ravel(), addv=PETSc.InsertMode.ADD_VALUES, rowmap=rows.ravel())
        A.assemble()

    def extend_pattern(self, A: Any) -> None:
        """Make room in A, once, for every coupling the terms add (:func:`~.pattern.widen`)."""
        n = self.dofs.shape[1]
        widen(A, np.repeat(self.dofs, n, axis=1).ravel(), np.tile(self.dofs, (1, n)).ravel())

    def status(self, u_vec: Any) -> dict[str, int]:
        """How many track nodes stick (|g| < 2 s: within the regularisation), slip, and are open now (all ranks)."""
        closed = self.pressure() > 0.0
        stick = closed & (np.abs(self._slips(u_vec)) < 2.0 * self.slip)
        counts = np.array([stick.sum(), (closed & ~stick).sum(), (~closed).sum()])
        stick_n, slip_n, open_n = (int(v) for v in self.comm.allreduce(counts))
        return {"stick_nodes": stick_n, "slip_nodes": slip_n, "open_nodes": open_n}

    def notes(self) -> dict[str, Any]:
        """The record's numbers: the coefficient, the penalties, the pairs."""
        return {"friction_coefficient": self.mu, "friction_slip_mm": self.slip / regions.MM,
                "friction_pairs": int(self.comm.allreduce(self.pairs))}

    def destroy(self) -> None:
        """Free the scatter and its local vector."""
        self._scatter.destroy()
        self._local.destroy()


def _nodes(physics: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """V's owned track nodes of the tissue, local thread-surface nodes, and every local node's lumped track area.

    The area is 2 pi r-weighted in 2-D, and in 3-D the half model's doubled (:func:`kinematics.volume_weight`).
    """
    V, mesh, tagged = physics.V, physics.mesh, physics.tagged
    bs = V.dofmap.index_map_bs
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    n_local = V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts
    owned = V.dofmap.index_map.size_local
    suture = mark_dofs(V, meshmod.region_cells(tagged, regions.SUTURE)).reshape(n_local, -1).any(axis=1)
    on_track = np.zeros(n_local, dtype=bool)
    on_track[dolfinx.fem.locate_dofs_topological(V, fdim, meshmod.facets(tagged, Facet.TRACK))] = True
    track = np.flatnonzero(on_track & ~suture)
    track = track[track < owned]
    xyz = V.tabulate_dof_coordinates()
    r = xyz[:, 0] if bs == 2 else np.hypot(xyz[:, 0], xyz[:, 2])  # off the thread's axis (y in 3-D)
    r_t = tagged.geometry.r_thread * regions.MM
    thread_cells = mark_dofs(V, meshmod.region_cells(tagged, regions.Cell.THREAD)).reshape(n_local, -1).any(axis=1)
    thread = np.flatnonzero(thread_cells & (np.abs(r - r_t) < 1e-9 * max(tagged.geometry.z_end, 1.0)))
    v = ufl.TestFunction(V)
    x = ufl.SpatialCoordinate(mesh)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged.facet_tags)
    b = dolfinx.fem.petsc.assemble_vector(compat.form(kinematics.volume_weight(x) * v[1] * ds(int(Facet.TRACK))))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    weight = b.array[: bs * owned].reshape(-1, bs)[:, 1].copy()
    b.destroy()
    return track, thread, weight


def _normal_form(physics: Any, kappa: float) -> Any:
    """The penalty's radial nodal force on the tissue's track (compiled): int kappa <-u_r> v_r 2 pi r ds_track.

    In 3-D u_r = u . e_r and v_r = v . e_r (:func:`~.contact.radial`), the weight the half model's.
    """
    mesh, tagged = physics.mesh, physics.tagged
    v = ufl.TestFunction(physics.V)
    x = ufl.SpatialCoordinate(mesh)
    _, ds = measures(mesh, tagged.cell_tags, tagged.facet_tags, physics.degree)  # the penalty term's quadrature
    ur = radial(physics.u, x)
    closed = ufl.conditional(ufl.lt(ur, 0.0), -ur, 0.0)
    force = kappa * closed * radial(v, x)
    weighted = force * 2 * math.pi * x[0] if len(x) == 2 else force * kinematics.HALF_MODEL_WEIGHT
    return compat.form(weighted * ds(int(Facet.TRACK)))


def nodal_terms(problem: Any) -> list[Any]:
    """The terms the solver assembles by hand for a problem: a Coulomb thread's, the cones' contact (those present)."""
    return [t for t in (getattr(problem, "friction", None), getattr(problem, "cone_contact", None)) if t is not None]


def full_residual(problem: Any, b: Any = None) -> Any:
    """R at ``problem``'s current state, as the Newton solver solves it (collective).

    The residual form, then every nodal term's part (:func:`nodal_terms`); owned entries assembled. Into ``b``
    (zeroed first), or a new vector: without nodal terms, the one assembled last into a caller's ``b`` when the
    form's inputs are bit for bit the same (:class:`~suture_fem.physics.residual_memo.ResidualMemo`).
    """
    form = problem.form("residual")
    terms = nodal_terms(problem)
    memo = None
    if not terms and hasattr(problem, "kept"):
        memo = problem.kept("residual memo", lambda: ResidualMemo(problem.residual, problem.comm))
    kept = memo.recall() if memo is not None and b is None else None
    if b is None:
        b = dolfinx.fem.petsc.create_vector(form)
    if kept is not None:
        b.array[:] = kept
        return b
    with b.localForm() as local:
        local.set(0.0)
    dolfinx.fem.petsc.assemble_vector(b, form)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    for term in terms:
        term.add_residual(compat.function_vector(problem.state), b)
    if memo is not None:
        memo.keep(b)
    return b


def slip_laws(problem: Any) -> list[SlipBound]:
    """The nodal terms updated between Newton solves: a Coulomb slip bound (mu > 0), an augmented Lagrangian."""
    return [t for t in nodal_terms(problem) if t.mu > 0.0 or getattr(t, "augmented", False)]


def global_dofs(physics: Any, nodes: np.ndarray, component: int) -> np.ndarray:
    """Global indices in the state's vector of V's local ``nodes``' ``component`` (0: r, 1: z; 3-D: x, y, z)."""
    local = physics.V.dofmap.index_map_bs * np.asarray(nodes, dtype=np.int64) + component
    if physics.u_in_state is not None:
        local = np.asarray(physics.u_in_state)[local]
    im = physics.W.dofmap.index_map
    bs = physics.W.dofmap.index_map_bs
    blocks = im.local_to_global(np.asarray(local // bs, dtype=np.int32))
    return np.asarray(blocks, dtype=np.int64) * bs + local % bs


def _pairs(physics: Any, track: np.ndarray, thread: np.ndarray, weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(owned track nodes, 2) global dofs u_z(a), u_z(b), b the thread node at a's place; their weights."""
    xyz = physics.V.tabulate_dof_coordinates()  # (x, y, 0) in 2-D
    key = np.round(xyz / MATCH_TOLERANCE_M).astype(np.int64)
    mine = {tuple(int(c) for c in k): int(d) for k, d in zip(key[thread], global_dofs(physics, thread, 1))}
    faced: dict[tuple[int, ...], int] = {}
    for part in physics.comm.allgather(mine):
        faced.update(part)
    partner = np.array([faced.get(tuple(int(c) for c in k), -1) for k in key[track]], dtype=np.int64)
    missing = int(physics.comm.allreduce(int(np.count_nonzero(partner < 0))))
    if missing:
        raise ValueError(f"{missing} track nodes face no thread node (the track is not split off the thread)")
    dofs = np.stack([global_dofs(physics, track, 1), partner], axis=1)
    return dofs, weight[track]
