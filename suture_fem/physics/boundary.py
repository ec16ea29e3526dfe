"""A scene's constraints: supports, pinned pressures, the thread's track, the rigid suture, the pulled end.

:func:`scene_constraints` collects the boundary conditions of the called effects and classifies the
state's dofs into what SNES solves for (:mod:`suture_fem.physics.constraints`).

Displacement control (``loading.control = "displacement"``): the pulled end is moved by d and the force
is its reaction (:class:`DisplacementControl`). The end's axial dofs are then fixed, the thread's pulled
face (elastic suture) or every suture dof (rigid suture: its one axial motion is d itself), and d enters
as the solver's affine offset u = T x + g (:mod:`suture_fem.solve.reduction`), g = d on those dofs. The
force is the residual's internal force summed over them (the suture's friction terms included), which
at equilibrium is what holds the end where it is.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.physics import constraints as cons
from suture_fem.physics.constraints import Unknowns, classify_dofs, pinned_pressure, rigid_suture, supports
from suture_fem.physics.effects import Effects, rigid_notes
from suture_fem.physics.effects.friction import full_residual
from suture_fem.support import compat


class DisplacementControl:
    """The pulled end held at the axial displacement d (m): the solver's offset, and the force it takes.

    Attributes:
        dofs: the end's axial dofs (local indices in the state's space, owned first); owned: how many are owned.
        offset: g, a vector of the state's layout, d on ``dofs`` and 0 elsewhere; d: the displacement (m).
    """

    def __init__(self, bc: Any, state: Any):
        """``bc``: the end's axial condition (its dofs); ``state``: the unknown Function."""
        self.dofs, self.owned = bc.dof_indices()
        self.offset = compat.function_vector(state).duplicate()
        self.d = 0.0
        self.set(0.0)

    def set(self, d_m: float) -> None:
        """Move the end to d (m): the next solve's offset."""
        self.d = float(d_m)
        with self.offset.localForm() as local:
            local.set(0.0)
            local.array[self.dofs] = self.d

    def end_force(self, physics: Any) -> float:
        """The axial force on the end now (N): the residual's internal force summed over its dofs (collective)."""
        b = full_residual(physics)  # friction's and the cones' contact terms act on the suture's dofs too
        local = float(np.sum(b.array[self.dofs[: self.owned]]))
        b.destroy()
        return float(physics.comm.allreduce(local, op=MPI.SUM))

    def destroy(self) -> None:
        """Free the offset."""
        self.offset.destroy()


@dataclass
class Constraints:
    """The boundary conditions, what SNES solves for, and the constraints' numbers for the record.

    ``control``: the pulled end's :class:`DisplacementControl` (None under force control).
    """

    bcs: list[Any]
    outer_z_dofs: np.ndarray
    unknowns: Unknowns
    rigid_displacement: Any
    notes: dict[str, dict[str, Any]]
    control: DisplacementControl | None = None


def scene_constraints(tagged: meshmod.TaggedMesh, effects: Effects, spaces: Any, control: str) -> Constraints:
    """Supports, the mixed formulation's pinned pressures, the track, the rigid suture, the pulled end.

    ``spaces``: W, W_u and the state (physics.problem's spaces); ``control``: ``loading.control``.
    """
    bcs, outer_z = supports(tagged, spaces.W_u)
    notes: dict[str, dict[str, Any]] = {}
    if effects.mixed:
        pin, notes["mixed"] = pinned_pressure(tagged, spaces.W)
        bcs.append(pin)
    if effects.thread_track:  # sliding: u_r = 0 on the tissue's side of the track
        track, notes["interfaces"] = cons.thread_track(tagged, spaces.W_u)
        bcs += [track] if effects.sliding_thread and tagged.mesh.geometry.dim == 2 else []
    hoop = None
    if effects.sliding_thread and tagged.mesh.geometry.dim == 3:  # u . e_r = 0: the reduction's hoop motions
        on_plane, *hoop = cons.thread_track_3d(tagged, spaces.W_u)
        bcs.append(on_plane)
    rigid = rigid_suture(tagged, spaces.W, spaces.W_u) if effects.rigid else None
    if rigid is not None:
        # the constraint as boundary conditions, so everything that reads bcs sees which dofs are
        # constrained; SNES imposes it through the solver's reduction, which updates d
        bcs += rigid.bcs
    end = None
    if control == "displacement":  # the end's axial dofs are fixed; d comes in as the solver's offset
        end = rigid.axial if rigid is not None else _pulled_face(tagged, spaces.W_u)
        bcs += [] if rigid is not None else [end]
    moving = rigid.axial if rigid is not None and end is None else None
    unknowns = classify_dofs(spaces.W, bcs, rigid_bc=moving)
    if hoop is not None:
        unknowns.hold_to_hoop(*hoop)
    if moving is not None:
        notes["suture"] = rigid_notes(unknowns, tagged.mesh.comm)
    return Constraints(bcs=bcs, outer_z_dofs=outer_z, unknowns=unknowns,
                       rigid_displacement=rigid.displacement if moving is not None else None, notes=notes,
                       control=DisplacementControl(end, spaces.state) if end is not None else None)


def _pulled_face(tagged: meshmod.TaggedMesh, W_u: Any) -> Any:
    """U_z = 0 on the thread's pulled end face (its value comes from the offset)."""
    fdim = tagged.mesh.topology.dim - 1
    dofs = dolfinx.fem.locate_dofs_topological(W_u.sub(1), fdim, meshmod.facets(tagged, regions.Facet.PULL_FACE))
    return dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), dofs, W_u.sub(1))
