"""Contact of the tissue with the cones' surfaces (``effects.cone_interface`` = "sliding", "frictionless", "coulomb").

The mesh gives the tissue its own nodes on every cone surface (facets tagged ``cone_contact``;
:func:`~suture_fem.geometry.gmsh_model.split_interfaces`). The cone is nearly rigid (its modulus is five orders
above the tissue's): its surface now is its reference outline moved axially by t_c, the mean u_z of its interface
nodes. At every residual and Jacobian evaluation each tissue node's place relative to its cone, y = X_a + u_a - t_c
e_z, is projected onto the outline (:func:`~suture_fem.geometry.outline.project`: arc length s, signed distance phi,
positive outside, outward normal n, tangent T), so the search follows it wherever it slides. The search's outline
has each sharp convex corner off the thread rounded by a tenth of the suture's element size
(:meth:`~suture_fem.geometry.section.Cone.rounded`): at a sharp corner the normal jumps and a pressed node has two
equilibria (4.908 and 4.945 mm on one and two ranks before). Distances count from each node's reference distance
(a few um at a rounded corner), so at rest nothing is pressed. With w the node's 2 pi r-weighted lumped area (m^2)
and kappa the penalty (:func:`~suture_fem.physics.effects.contact.penalty_stiffness`), the potential is

    sliding:        sum_a 1/2 kappa w phi^2        (bilateral: the tissue stays on the cone's surface)
    frictionless:   sum_a 1/2 kappa w <-phi>^2     (unilateral: the tissue may lift off, not enter)
    coulomb:        frictionless + sum_a w b s ln cosh(g / s),   g = s(y) - s(X_a),

p = kappa <-phi> the pressure, g the total slip along the outline. Coulomb's bound b is frozen during a Newton
solve and moved to mu p between solves (:class:`~suture_fem.physics.effects.friction.SlipBound`). The friction acts
along T, within phi / R of the slip's gradient beside an arc of radius R (the arc length's own gradient left the
Hessian a term t / R short: the Coulomb cones stopped at 0.2-0.3 N). The Jacobian is kappa w (n n^T + phi d2 phi)
where closed (d2 phi the distance's curvature, 0 beside a line) plus the friction's w t'(g) T T^T. A node's terms
couple its dofs with its cone's axial dofs (through t_c): the matrix pattern is set once.

The unilateral models default to an augmented Lagrangian (``effects.cone_contact_method``; Wriggers 2006, 6.3):
p = <lambda - kappa phi>, the potential (<lambda - kappa phi>^2 - lambda^2) / (2 kappa), lambda frozen during a
Newton solve and moved toward p between solves (:meth:`ConeContact.update`, Aitken-relaxed; chord steps where
:func:`~.fixed_point.settle` allows) until every pressed node is within ``effects.contact_penetration_mm``; a
P2 pair whose update swaps has its kappa doubled (:data:`~.fixed_point.BOOST_MAX`; ``ConeContact.boost``).

Searched too: the tissue's next layer of nodes (:mod:`.cone_pairs`; held off the cones with nothing tied, only
measured with the thread tied: held, the paper scene's frictionless cones stopped at 3.67 N), and the unilateral
cones' corners against the tissue's facets (:mod:`.cone_corners`, 2-D; measured, held with ``effects.cone_corners``
= "held"): tissue sliding round a corner lets the corner through between the surface's nodes.

Left out: the cone's own deformation in the search (its wall's axial strain stays below 0.2 % at 0.8 N a cone; a
1 MPa pressure strains it radially by under 1e-3). The terms are assembled by hand into the full residual and
Jacobian (UFL forms cannot couple nodes that share no cell). In 3-D (the half model) a node's place is its meridian
(r, y - t_c), carried back to its three dofs by :mod:`.cone_frame`; w is weighted by the half model's 2.
"""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry import regions
from suture_fem.geometry.outline import deepest_on_way, project
from suture_fem.physics.effects import cone_frame, cone_notes
from suture_fem.physics.effects.cone_corners import CornerPass, chain
from suture_fem.physics.effects.cone_pairs import WatchedLayer, cone_pairs
from suture_fem.physics.effects.contact import cones_augmented, penalty_stiffness
from suture_fem.physics.effects.fixed_point import BOOST_MAX, UZAWA_OMEGA_MAX, Aitken, Reversals, update_norms
from suture_fem.physics.effects.friction import SlipBound
from suture_fem.physics.effects.pattern import ConeLayout, widen
from suture_fem.support import compat

log = logging.getLogger("suture_fem")

#: A trial state with a tissue node deeper inside a cone than this fraction of its wall, or reached by a way
#: going deeper (:meth:`ConeContact.deepest`), is outside the admissible domain: past the wall's mid-plane the
#: nearest point is on its far side, and the penalty would push the node on through the wall. Below a half,
#: less the ways' sampling (1/16). Converged states lie within the augmented Lagrangian's target (0.15 um); the
#: sliding cones' pure penalty lets a pressed apex node sink 30-50 um at 2-4 N (a quarter stopped one at 1.6 N).
DEPTH_FRACTION = 0.4


class ConeContact(SlipBound):
    """The cones' contact terms (see the module docstring).

    Attributes: pairs: the tissue's cone-contact nodes owned on this rank; nodes: V's local node a of each; dofs:
        (pairs, dim) global dofs (u_r(a), u_z(a); 3-D u_x, u_y, u_z); position: (pairs, dim) reference positions
        (mm); X: (pairs, 2) their places (r, axial) (mm); cone: the cone of each; s0, phi0: the reference arc length
        and distance (mm); weight: m^2; cone_dofs: per cone, the global axial dofs of its interface nodes (every
        rank's); outlines: per cone, its outline; kappa (Pa/m); boost: each pair's penalty / kappa; model; mu (0:
        no friction); slip: s (m); bound: the frozen slip limit (Pa); surface: True on a cone's surface; track: the
        track's tissue (the thread free in its track); near: the tissue's next layer (unilateral, frictionless).
    """

    def __init__(self, comm: Any, state: Any, pairs: dict[str, Any], kappa: float, model: str, mu: float,
                 slip_m: float, target_m: float | None = None, convexified: bool = False, touch_holds: bool = False,
                 wall_m: float = math.inf):
        """``state``: the state's PETSc vector; ``pairs``: :func:`cone_pairs`'s arrays.

        ``target_m``: the augmented Lagrangian's largest penetration (m); None: the pure penalty.
        ``convexified``: the unilateral Jacobian leaves out the distance's curvature where it softens (P2).
        ``touch_holds``: a node that touches with no pressure (p = 0 exactly, as every node at rest) counts as
        closed: with nothing tied, only the contact holds the suture, and at rest it would hold it by nothing
        (a singular Jacobian: the first step from rest moved the suture through the tissue); at P2 too (:meth:`on`).
        ``wall_m``: the cones' wall (m): a trial state's nodes may lie DEPTH_FRACTION of it deep (:meth:`deepest`).
        """
        self.comm, self.kappa, self.model = comm, float(kappa), model
        self.augmented, self.target = target_m is not None, float(target_m or 0.0)
        self.bilateral = model == "sliding"
        self.touch_holds, self.depth_limit = touch_holds, DEPTH_FRACTION * float(wall_m)
        self._reach = 0.5 * float(wall_m) - self.depth_limit  # a shorter move from the limit cannot pass the mid-plane
        self.convexified = convexified and not self.bilateral
        self.safeguarded = self.convexified  # swapping pairs boosted: P2; 3-D too (:meth:`on`)
        self.mu, self.slip = (float(mu) if model == "coulomb" else 0.0), float(slip_m)
        self.nodes, self.dofs, self.position = pairs["nodes"], pairs["dofs"], pairs["X"]
        self.X = cone_frame.place(self.position)[0]
        self.cone, self.weight, self.outlines = pairs["cone"], pairs["weight"], pairs["outlines"]
        self.cone_dofs: list[np.ndarray] = pairs["cone_dofs"]
        self.corner_mm = float(pairs["corner_mm"])
        self.pairs = len(self.weight)
        self.s0, self.phi0 = np.zeros(self.pairs), np.zeros(self.pairs)
        self._of_cone = [np.flatnonzero(self.cone == c) for c in range(len(self.outlines))]
        self.surface = np.asarray(pairs.get("surface", np.ones(self.pairs, dtype=bool)), dtype=bool)
        self.near = np.asarray(pairs.get("near", np.zeros(self.pairs, dtype=bool)), dtype=bool)
        self.track = ~self.surface & ~self.near
        self.hold_next_layer = bool(pairs.get("hold_next_layer", True))  # else measured only (:meth:`status`)
        self.watched = WatchedLayer(state, pairs.get("watched"), self.outlines, self.dofs.shape[1])
        self.corners: CornerPass | None = None  # the cones' corners against the tissue's facets (:meth:`on`)
        self.hold_corners = False  # effects.cone_corners = "held": their terms join these (else only measured)
        for sel, outline in zip(self._of_cone, self.outlines):
            start = project(self.X[sel], outline)
            self.s0[sel], self.phi0[sel] = start.s, start.distance  # phi0: off a rounded corner, a few um
        self.phi0[~self.surface] = 0.0  # the track's and the next layer's start off the cone: the gap is the distance
        self.bound = np.zeros(self.pairs)
        self.multiplier, self.boost = np.zeros(self.pairs), np.ones(self.pairs)  # lambda (Pa); the penalty / kappa
        self._state = state
        self._found: tuple[np.ndarray, dict[str, np.ndarray]] | None = None  # the last search's (input, places)
        self._anchor = self.X.copy()  # where each node was, relative to its cone, at the trial states' start (mm)
        self._layout = ConeLayout(self.dofs, self.cone, self.cone_dofs)
        self.start()
        index_all = np.concatenate([self.dofs.ravel(), *self.cone_dofs]).astype(PETSc.IntType)
        self._local = PETSc.Vec().createSeq(len(index_all), comm=PETSc.COMM_SELF)
        index = PETSc.IS().createGeneral(index_all, comm=PETSc.COMM_SELF)
        self._scatter = PETSc.Scatter().create(state, index, self._local, None)
        index.destroy()

    @classmethod
    def on(cls, physics: Any, scene: Any) -> ConeContact:
        """The cones' contact of a built Physics from its scene's ``[effects]``; its numbers join the record."""
        section = scene.effects
        degree = getattr(physics, "degree", 1)  # the augmented penalty grows as degree^2 / h (docs/contact.md)
        factor = section.augmented_penalty * degree**2 if cones_augmented(section) else section.contact_penalty
        kappa = penalty_stiffness(scene, physics.tagged.sizes.suture, factor)
        target = section.contact_penetration_mm * regions.MM if cones_augmented(section) else None
        p2 = degree != 1  # also held at rest: P2 cones failed their first step without it
        pairs = cone_pairs(physics, hold_next_layer=section.thread_track)
        contact = cls(physics.comm, compat.function_vector(physics.state), pairs, kappa,
                      section.cone_interface, section.friction_coefficient, section.friction_slip_mm * regions.MM,
                      target, convexified=p2, touch_holds=section.thread_track or p2,
                      wall_m=scene.geometry.cone_wall_mm * regions.MM)
        contact.safeguarded = not contact.bilateral and (p2 or physics.mesh.geometry.dim == 3)
        if not contact.bilateral and physics.mesh.geometry.dim == 2:
            pieces = chain(physics, contact.outlines)
            contact.corners = CornerPass(physics.comm, contact._state, pieces, contact.outlines, contact.cone_dofs,
                                         kappa, physics.tagged.sizes.suture * regions.MM)
            contact.hold_corners = section.cone_corners == "held"
        physics.notes.setdefault("interfaces", {}).update(cone_notes.notes(contact))
        return contact

    @property
    def held(self) -> CornerPass | None:
        """The corners when held out of the tissue (``effects.cone_corners = "held"``), else None (measured only)."""
        return self.corners if self.hold_corners else None

    def search(self, u_vec: Any) -> dict[str, np.ndarray]:
        """Each pair's place on its cone now: ``phi``, ``g`` (m), ``n``, ``T`` ((pairs, 2)) (collective).

        Also ``t_c`` (m), the cones' mean axial displacements.
        """
        self._scatter.scatter(u_vec, self._local, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        values = self._local.getArray(readonly=True)
        if self._found is not None and np.array_equal(values, self._found[0]):  # the same state: the same places
            return self._found[1]
        u, t_c = self.moves(values)
        y, e_r = cone_frame.moved(self.position, u, t_c[self.cone], regions.MM)  # 3-D: y = (r, axial)
        out = {"phi": np.zeros(self.pairs), "g": np.zeros(self.pairs), "n": np.zeros((self.pairs, 2)),
               "T": np.zeros((self.pairs, 2)), "curvature": np.zeros(self.pairs), "t_c": t_c, "y": y,
               **({} if e_r is None else {"e_r": e_r})}  # 3-D: each node's unit vector off the axis
        for sel, outline in zip(self._of_cone, self.outlines):
            proj = project(y[sel], outline)
            out["phi"][sel] = (proj.distance - self.phi0[sel]) * regions.MM
            out["g"][sel] = (proj.s - self.s0[sel]) * regions.MM
            out["n"][sel], out["T"][sel] = proj.normal, proj.tangent
            out["curvature"][sel] = proj.curvature / regions.MM  # 1/m
        for array in out.values():
            array.flags.writeable = False  # kept for the next call at the same state
        self._found = (values.copy(), out)
        return out

    def moves(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """From :meth:`search`'s scattered ``values``: each pair's u (pairs, dim) and each cone's t_c."""
        dim = self.dofs.shape[1]
        at, t_c = dim * self.pairs, []
        for dofs in self.cone_dofs:
            t_c.append(float(np.mean(values[at: at + len(dofs)])) if len(dofs) else 0.0)
            at += len(dofs)
        return values[: dim * self.pairs].reshape(self.pairs, dim), np.asarray(t_c)

    def anchor(self) -> None:
        """Take the state now as where the next trial states start from: a Newton iterate, a step's last state."""
        self._anchor = self.search(self._state)["y"].copy()

    def deepest(self) -> tuple[float, float, np.ndarray, int]:
        """The state's deepest tissue node inside a cone: (depth (m), the limit (m), its reference place (mm), cone).

        A node's depth is the deepest its straight way from :meth:`anchor`'s place goes (the line search's
        path; :func:`~suture_fem.geometry.outline.deepest_on_way`) where it moved farther than from the limit to
        the wall's mid-plane (a shorter move from an admissible place cannot pass it), else its depth now. All
        ranks' (collective); the depth is 0 with no node inside; the place and cone only past the limit.
        """
        found = self.search(self._state)
        inside = np.maximum(-found["phi"], 0.0)
        moved = np.linalg.norm(found["y"] - self._anchor, axis=1) > self._reach / regions.MM
        for sel, outline in zip(self._of_cone, self.outlines):
            way = sel[moved[sel]]
            if len(way):
                on_way = deepest_on_way(self._anchor[way], found["y"][way], outline, self.phi0[way]) * regions.MM
                inside[way] = np.maximum(inside[way], on_way)
        k = int(np.argmax(inside)) if self.pairs else -1
        mine = float(inside[k]) if self.pairs else 0.0
        depth = float(self.comm.allreduce(mine, op=MPI.MAX))
        if depth <= self.depth_limit:  # every trial state of a solve: one reduction, no place needed
            return depth, self.depth_limit, np.zeros(2), 0
        local = (mine, self.X[k].copy(), int(self.cone[k])) if mine == depth else None
        where, cone = next(item[1:] for item in self.comm.allgather(local) if item is not None)
        return depth, self.depth_limit, where, cone

    def _pressure(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(p, closed) per pair: p = lambda - kappa phi, clipped at 0 unless bilateral (Pa); closed: p > 0 (or all)."""
        trial = self.multiplier - self.penalty * phi
        if self.bilateral:
            closed = np.ones(self.pairs, dtype=bool)
        else:
            closed = trial >= 0.0 if self.touch_holds else trial > 0.0
        closed[self.near] = trial[self.near] > 0.0  # the next layer only ever pushes
        return np.where(closed, trial, 0.0), closed

    @property
    def penalty(self) -> np.ndarray:
        """Each pair's penalty (Pa/m): kappa x its boost."""
        return self.kappa * self.boost

    def pressure(self) -> np.ndarray:
        """The contact pressure per pair now (Pa; sliding: negative where it holds the tissue on)."""
        return self._pressure(self.search(self._state)["phi"])[0]

    def update(self, tolerance: float) -> bool:
        """Between Newton solves: the Coulomb bound (:meth:`SlipBound.update`), then the multipliers (collective).

        True when both held before the update: the friction to ``tolerance`` (N), every pressed node within the
        target of its cone, either side (the multipliers move only above it: a settled state solves its terms).
        """
        settled = super().update(tolerance) if self.mu > 0.0 else True
        if not self.augmented:
            return settled
        phi = self.search(self._state)["phi"]
        p, closed = self._pressure(phi)
        depth = np.where(closed, np.abs(phi), 0.0)  # pressed nodes off the surface, inside or (lambda > 0) outside
        worst = float(self.comm.allreduce(float(np.max(depth, initial=0.0)), op=MPI.MAX))
        t_c, corners = self.search(self._state)["t_c"], self.held
        worst = max(worst, corners.worst(self._state, t_c)) if corners else worst
        log.debug("cones' contact: %d nodes pressed, the farthest %.3g mm off its cone (target %.3g mm)",
                  self.comm.allreduce(int(np.count_nonzero(closed))), worst / regions.MM, self.target / regions.MM)
        r, old = p - self.multiplier, self.multiplier  # Uzawa moves lambda to p; Aitken's factor speeds it up
        extra = (np.zeros(0),) * 3  # the corners' (rank 0's) residual, change and multipliers
        if worst > self.target:
            self.multiplier = np.maximum(old + self._uzawa.factor(r * self.weight) * r, 0.0)  # unilateral
            if self.safeguarded:  # docs/contact.md, "The multipliers that swap"
                swapped = self._reversals.of(r) & closed  # their penalty doubled (BOOST_MAX)
                self.boost[swapped] = np.minimum(BOOST_MAX, 2.0 * self.boost[swapped])
            extra = corners.move(self._state, t_c) if corners else extra
        if self.mu == 0.0:  # what decides a chord step next (:func:`~.fixed_point.settle`; with Coulomb, its bound's)
            self.last_residual, self.last_change = update_norms(
                self.comm, np.concatenate([self.weight * r, extra[0]]),
                np.concatenate([self.weight * (self.multiplier - old), extra[1]]),
                np.concatenate([self.weight * self.multiplier, extra[2]]))
        return settled and worst <= self.target

    def start(self) -> None:
        """Forget the fixed points' histories (a new load step's solve)."""
        super().start()
        self._uzawa, self._reversals = Aitken(self.comm, UZAWA_OMEGA_MAX), Reversals(self.pairs)

    def frozen(self) -> tuple[np.ndarray, ...]:
        """Copies of the Coulomb bound and the multipliers (the corners' last): a state's part, kept with it."""
        return self.bound.copy(), self.multiplier.copy(), *([self.held.multiplier.copy()] if self.held else [])

    def thaw(self, kept: tuple[np.ndarray, ...]) -> None:
        """Set what :meth:`frozen` returned."""
        self.bound, self.multiplier = kept[0].copy(), kept[1].copy()
        if self.held:
            self.held.multiplier = kept[2].copy()

    def reset(self) -> None:
        """At rest: no pressure, no slip bound, no multiplier."""
        self.bound[:] = 0.0
        self.multiplier[:], self.boost[:] = 0.0, 1.0
        if self.held:
            self.held.multiplier[:] = 0.0

    def _law(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        th = np.tanh(g / self.slip)
        return self.bound * th, self.bound * (1.0 - th * th) / self.slip

    def potential(self, u_vec: Any) -> float:
        """The penalty's and (Coulomb) the frozen-bound friction's potential (J; collective)."""
        found = self.search(u_vec)
        p, _ = self._pressure(found["phi"])  # w (p^2 - lambda^2) / (2 kappa): its phi-derivative is -w p
        value = 0.5 * self.weight * (p**2 - self.multiplier**2) / self.penalty
        if self.mu > 0.0:
            x = np.abs(found["g"]) / self.slip
            value = value + self.weight * self.bound * self.slip * (x + np.log1p(np.exp(-2.0 * x)) - math.log(2.0))
        corners = self.held.potential(u_vec, found["t_c"]) if self.held else 0.0  # every rank's the same
        return float(self.comm.allreduce(float(np.sum(value)))) + corners

    def _gradient(self, u_vec: Any) -> np.ndarray:
        """Per pair: dE/dy (pairs, 2), N; y the node's place in the meridian plane (:mod:`.cone_frame`)."""
        found = self.search(u_vec)
        grad = -(self.weight * self._pressure(found["phi"])[0])[:, None] * found["n"]
        if self.mu > 0.0:
            grad += (self.weight * self._law(found["g"])[0])[:, None] * found["T"]
        return grad

    def _hessian(self, u_vec: Any) -> np.ndarray:
        """Per pair: d2E/dx2 (pairs, dim, dim; the friction's turning tangent left out), x the node's position.

        Convexified (P2, unilateral): -w p d2(phi) is kept only where it stiffens; beside a convex arc or
        corner it is a negative tangential stiffness -w p / R, which at P2 sent Newton down a direction of
        negative curvature until a trial state inverted (docs/contact.md, "P2 cones").
        """
        found = self.search(u_vec)
        p, closed = self._pressure(found["phi"])
        n, T = found["n"], found["T"]
        # d2E = kappa w n n^T (closed) - w p d2(phi), d2(phi) = curvature (I - n n^T) (0 beside a straight segment)
        nn = n[:, :, None] * n[:, None, :]
        curvature = np.minimum(found["curvature"], 0.0) if self.convexified else found["curvature"]
        bend = (-self.weight * p * curvature)[:, None, None] * (np.eye(2)[None, :, :] - nn)
        hess = (self.penalty * self.weight * closed)[:, None, None] * nn + bend
        if self.mu > 0.0:
            hess += (self.weight * self._law(found["g"])[1])[:, None, None] * T[:, :, None] * T[:, None, :]
        if "e_r" not in found:  # 2-D: the place is the position
            return hess
        return cone_frame.hessian(hess, self._gradient(u_vec), found["e_r"], found["y"][:, 0] * regions.MM)

    def add_residual(self, u_vec: Any, b: Any) -> None:
        """Add the terms' gradient to the full residual ``b`` (assembled; collective).

        Node a receives dE/dx; the cone's axial dofs share -dE/dx_z equally (x moves by -t_c e_z).
        """
        grad = self._gradient(u_vec)
        self._layout.add_gradient(b, cone_frame.gradient(grad, self.search(u_vec).get("e_r")), grad[:, 1])
        if self.held:
            self.held.add_residual(u_vec, self.search(u_vec)["t_c"], b)
        b.assemble()

    def add_jacobian(self, u_vec: Any, A: Any) -> None:
        """Add the terms' Hessian (symmetric) to the full Jacobian ``A`` (assembled; collective).

        K_aa = H, K_ab = -H[:, z] alpha, K_bb = sum_a H_zz alpha alpha^T for every pair's H (alpha = 1 / n_b).
        """
        self._layout.add(A, self._hessian(u_vec))
        if self.held:
            self.held.add_jacobian(u_vec, self.search(u_vec)["t_c"], A)
        A.assemble()

    def extend_pattern(self, A: Any) -> None:
        """Make room in A, once, for every coupling the terms add (:func:`~.pattern.widen`)."""
        rows, cols = self._layout.entries()
        if self.held:
            more = self.held.entries()
            rows, cols = np.concatenate([rows, more[0]]), np.concatenate([cols, more[1]])
        widen(A, rows, cols)

    def status(self, u_vec: Any) -> dict[str, Any]:
        """The pressed, sticking, slipping and open nodes and the deepest ones (:func:`.cone_notes.status`)."""
        return cone_notes.status(self, u_vec)

    def pushes(self, u_vec: Any) -> tuple[np.ndarray, np.ndarray]:
        """Per cone, the axial force (N) its contact passes to the track's tissue and to the next layer (all ranks)."""
        grad = self._gradient(u_vec)  # dE/dy: the terms' force on the tissue's node is -dE/dy
        push = np.array([[-float(np.sum(grad[(self.cone == c) & part, 1])) for c in range(len(self.outlines))]
                         for part in (self.track, self.near)])
        track, near = np.asarray(self.comm.allreduce(push))
        return track, near

    def _gap_forces(self) -> np.ndarray:
        """Coulomb's residual forces (:class:`SlipBound`), none at the next layer's nodes (frictionless)."""
        forces = super()._gap_forces()
        forces[self.near] = 0.0
        return forces

    def destroy(self) -> None:
        """Free the scatters and their local vectors."""
        self._scatter.destroy()
        self._local.destroy()
        self.watched.destroy()
        if self.corners:
            self.corners.destroy()

