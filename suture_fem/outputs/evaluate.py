"""Outputs: the paper's USUM, SEQV and EPTOEQV, overall and per region, and the balance checks.

* USUM: maximum of |u| over the displacement nodes (mm).
* SEQV: maximum von Mises equivalent of the full 3x3 Cauchy stress sigma = J^-1 P F^T, hoop
  component included, over the quadrature points of the energy integral (Pa).
* EPTOEQV: maximum of sqrt(2/3 dev(h):dev(h)) with the Hencky strain h = 1/2 ln B (ANSYS's
  equivalent strain with effective Poisson ratio 0.5), over the same quadrature points.
* SEQV outside the rims: the same maximum over points farther than ``output.rim_exclusion_mm``
  from every cone corner and from the two points where the thread crosses the tissue's end faces
  (all re-entrant corners of the suture-tissue interface). The sharp-corner peak is a singularity;
  this measure is not, but it still depends on the mesh (docs/ledger.md measures how much).
* Reaction: the axial force of the fixed outer surface on the tissue, from the assembled residual
  at the fixed degrees of freedom; at equilibrium it is minus the applied force.
Every maximum is reduced over all ranks with its location; ranks that own no cell of a region
take part with -inf.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.regions import MM, REGION_TAGS, TISSUE_REGIONS
from suture_fem.physics import kinematics
from suture_fem.physics.materials import cauchy
from suture_fem.physics.problem import REGION_OF_TAG, Physics, quadrature_degree
from suture_fem.scene.schema import OutputSection
from suture_fem.support import compat
from suture_fem.support.parallel import on_root

#: Regions reported separately (the suture is thread + cones).
REPORT_REGIONS = REGION_TAGS


def von_mises(s: np.ndarray) -> np.ndarray:
    """Von Mises equivalent of symmetric tensors given as columns (rr, zz, tt, rz)."""
    mean = (s[:, 0] + s[:, 1] + s[:, 2]) / 3.0
    d = s[:, :3] - mean[:, None]
    return np.sqrt(1.5 * (np.sum(d**2, axis=1) + 2.0 * s[:, 3] ** 2))


def hencky_equivalent(b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(equivalent Hencky strain, J) from left Cauchy-Green tensors given as columns (rr, zz, tt, rz)."""
    half_tr = 0.5 * (b[:, 0] + b[:, 1])
    det2 = b[:, 0] * b[:, 1] - b[:, 3] ** 2
    disc = np.sqrt(np.maximum(half_tr**2 - det2, 0.0))
    lam = np.stack([half_tr + disc, half_tr - disc, b[:, 2]], axis=1)
    h = 0.5 * np.log(lam)
    dev = h - h.mean(axis=1, keepdims=True)
    return np.sqrt(2.0 / 3.0 * np.sum(dev**2, axis=1)), np.sqrt(np.prod(lam, axis=1))


def _global_max(comm: Any, values: np.ndarray, coords: np.ndarray) -> tuple[float, list[float] | None]:
    """Max over ranks with its (r, z) in mm; (-inf, None) where nobody owns a value."""
    if len(values):
        k = int(np.argmax(values))
        local = (float(values[k]), [float(c) / MM for c in coords[k, :2]])
    else:
        local = (-np.inf, None)
    return max(comm.allgather(local), key=lambda t: t[0])


class Outputs:
    """Compiles what the outputs need once, then evaluates them for the current state."""

    def __init__(self, physics: Physics, output: OutputSection, quantities: tuple[str, ...] = ("usum", "seqv", "eptoeqv")):
        self.physics = physics
        self.quantities = quantities
        self.rim_exclusion = output.rim_exclusion_mm * MM
        g = physics.tagged.geometry
        singular = [*g.corners, (g.r_thread, 0.0), (g.r_thread, g.length)]
        self.corners = np.array(singular, dtype=float).reshape(-1, 2) * MM
        V = physics.V
        self.node_xy = V.tabulate_dof_coordinates()[:, :2]
        dofs = V.dofmap.list.array.reshape(-1, V.dofmap.dof_layout.num_dofs)
        self.region_nodes = {}
        self.region_cells = {}
        for name, tags in REPORT_REGIONS.items():
            cells = meshmod.region_cells(physics.tagged, tags)
            self.region_cells[name] = cells
            self.region_nodes[name] = np.unique(dofs[cells]) if len(cells) else np.zeros(0, dtype=np.int32)
        self.tensor_exprs: dict[int, Any] = {}
        if {"seqv", "eptoeqv"} & set(quantities):
            points = compat.quadrature_points("triangle", quadrature_degree(physics.degree))
            F = physics.F
            B = F * F.T
            self.x_expr = compat.expression(physics.x, points)
            by_region: dict[str, Any] = {}
            for tag, region in REGION_OF_TAG.items():
                if region not in by_region:
                    sigma = cauchy(physics.materials[region], F)
                    comps = kinematics.in_plane(sigma) + kinematics.in_plane(B)
                    by_region[region] = compat.expression(ufl.as_vector(comps), points)
                self.tensor_exprs[tag] = by_region[region]

    def thread_end_displacement_mm(self) -> float:
        """Axial displacement of the pulled end face (2 pi r-weighted mean), mm."""
        comm = self.physics.comm
        val = dolfinx.fem.assemble_scalar(self.physics.form("end_displacement"))
        return comm.allreduce(val, op=MPI.SUM) / self.physics.pull_area / MM

    def strain_energy_j(self) -> float:
        val = dolfinx.fem.assemble_scalar(self.physics.form("energy"))
        return self.physics.comm.allreduce(val, op=MPI.SUM)

    def reaction_force_n(self) -> tuple[float, float]:
        """(axial force of the fixed outer surface on the body, residual norm at the free dofs), N.

        Both come from one assembly of the residual without boundary conditions: at the fixed
        outer-surface dofs it is the reaction; at the unconstrained dofs it is what equilibrium
        leaves over, which bounds the force balance error.
        """
        b = dolfinx.fem.petsc.assemble_vector(self.physics.form("residual"))
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        n_owned = b.getLocalSize()
        owned = self.physics.outer_z_dofs[self.physics.outer_z_dofs < n_owned]
        local = float(np.sum(b.array[owned]))
        free = np.ones(n_owned, dtype=bool)
        for bc in self.physics.bcs:
            fixed = bc.dof_indices()[0]
            free[fixed[fixed < n_owned]] = False
        local_sq = float(np.sum(b.array[free] ** 2))
        b.destroy()
        comm = self.physics.comm
        return comm.allreduce(local, op=MPI.SUM), float(np.sqrt(comm.allreduce(local_sq, op=MPI.SUM)))

    def _point_fields(self, region: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(von Mises, Hencky equivalent, J, coordinates) at the quadrature points of a region."""
        mesh = self.physics.mesh
        vm, eq, jac, xy = [], [], [], []
        for tag in REPORT_REGIONS[region]:
            cells = meshmod.region_cells(self.physics.tagged, tag)
            if len(cells) == 0:
                continue
            vals = compat.eval_expression(self.tensor_exprs[tag], mesh, cells).reshape(-1, 8)
            vm.append(von_mises(vals[:, :4]))
            e, j = hencky_equivalent(vals[:, 4:])
            eq.append(e)
            jac.append(j)
            xy.append(compat.eval_expression(self.x_expr, mesh, cells).reshape(-1, 2))
        if not vm:
            z = np.zeros(0)
            return z, z, z, np.zeros((0, 2))
        return np.concatenate(vm), np.concatenate(eq), np.concatenate(jac), np.concatenate(xy)

    def evaluate(self) -> dict[str, Any]:
        """Every requested output for the current state, JSON-ready (collective)."""
        comm = self.physics.comm
        u = self.physics.u.x.array.reshape(-1, 2)
        out: dict[str, Any] = {
            "force_n": float(self.physics.traction.value) * self.physics.pull_area,
            "thread_end_displacement_mm": self.thread_end_displacement_mm(),
            "strain_energy_j": self.strain_energy_j(),
        }
        out["reaction_force_n"], out["free_residual_norm_n"] = self.reaction_force_n()
        out["force_balance_rel"] = abs(out["reaction_force_n"] + out["force_n"]) / max(out["force_n"], 1e-300)
        regions: dict[str, Any] = {}
        overall: dict[str, tuple[float, Any, str]] = {}

        def keep(name: str, region: str, value: float, where: Any) -> None:
            regions[region][name] = value
            regions[region][name + "_at_mm"] = where
            if value > overall.get(name, (-np.inf, None, ""))[0]:
                overall[name] = (value, where, region)

        for region, nodes in self.region_nodes.items():
            regions[region] = {}
            if "usum" in self.quantities:
                mag = np.linalg.norm(u[nodes], axis=1) / MM
                keep("usum_mm", region, *_global_max(comm, mag, self.node_xy[nodes]))
            if {"seqv", "eptoeqv"} & set(self.quantities):
                vm, eq, jac, xy = self._point_fields(region)
                if "seqv" in self.quantities:
                    keep("seqv_pa", region, *_global_max(comm, vm, xy))
                    far = self._outside_rims(xy)
                    keep("seqv_outside_rim_pa", region, *_global_max(comm, vm[far], xy[far]))
                if "eptoeqv" in self.quantities:
                    keep("eptoeqv", region, *_global_max(comm, eq, xy))
                    far = self._outside_rims(xy)
                    keep("eptoeqv_outside_rim", region, *_global_max(comm, eq[far], xy[far]))
                jmin = comm.allreduce(float(np.min(jac, initial=np.inf)), op=MPI.MIN)
                jmax = comm.allreduce(float(np.max(jac, initial=-np.inf)), op=MPI.MAX)
                regions[region]["j_range"] = [jmin, jmax] if np.isfinite(jmin) else None
        for name, (value, where, region) in overall.items():
            out[name] = value
            out[name + "_at_mm"] = where
            out[name + "_region"] = region
        tissue = {}
        for name in overall:
            best = max((regions[r][name], regions[r][name + "_at_mm"], r) for r in TISSUE_REGIONS
                       if regions[r].get(name + "_at_mm") is not None) if any(
                regions[r].get(name + "_at_mm") is not None for r in TISSUE_REGIONS) else (None, None, None)
            tissue[name], tissue[name + "_at_mm"], tissue[name + "_region"] = best
        regions["tissue"] = tissue
        out["regions"] = regions
        out["where"] = {
            "usum_mm": "maximum over displacement nodes",
            "seqv_pa": "maximum over quadrature points of the energy integral",
            "eptoeqv": "maximum over quadrature points of the energy integral",
            "seqv_outside_rim_pa": f"as seqv_pa, over points farther than {self.rim_exclusion / MM:g} mm "
            "from every cone corner and from where the thread crosses the tissue's end faces",
        }
        return out

    def cell_maxima(self) -> dict[str, np.ndarray]:
        """Per local cell (ghosts included), the maximum over its quadrature points of the von Mises
        stress (Pa, key "von_mises_pa") and of the equivalent Hencky strain ("eptoeqv"), indexed by
        local cell number: for field files and pictures.
        """
        index_map = self.physics.mesh.topology.index_map(self.physics.mesh.topology.dim)
        num = index_map.size_local + index_map.num_ghosts
        fields = {"von_mises_pa": np.zeros(num), "eptoeqv": np.zeros(num)}
        for tag, expr in self.tensor_exprs.items():
            cells = meshmod.region_cells(self.physics.tagged, tag)
            if len(cells) == 0:
                continue
            vals = compat.eval_expression(expr, self.physics.mesh, cells).reshape(-1, 8)
            fields["von_mises_pa"][cells] = von_mises(vals[:, :4]).reshape(len(cells), -1).max(axis=1)
            fields["eptoeqv"][cells] = hencky_equivalent(vals[:, 4:])[0].reshape(len(cells), -1).max(axis=1)
        return fields

    def _outside_rims(self, xy: np.ndarray) -> np.ndarray:
        if len(self.corners) == 0 or len(xy) == 0:
            return np.ones(len(xy), dtype=bool)
        d = np.min(np.linalg.norm(xy[:, None, :] - self.corners[None, :, :], axis=2), axis=1)
        return d > self.rim_exclusion


class FieldWriter:
    """XDMF output for ParaView: displacement (P1) and the cell-wise maximum von Mises stress."""

    def __init__(self, physics: Physics, outputs: Outputs, path: str):
        self.physics, self.outputs = physics, outputs
        mesh = physics.mesh
        # Written into a hidden folder and moved beside results.json on close, so the .xdmf/.h5 pair
        # is complete or absent (the .xdmf names its .h5 by a relative path, which the move keeps).
        self.final = Path(path)
        self.staging = self.final.parent / f".{self.final.stem}.partial"
        on_root(mesh.comm, f"creating {self.staging}", self.staging.mkdir, parents=True, exist_ok=True)
        self.file = compat.create_xdmf(mesh.comm, str(self.staging / self.final.name))
        self.file.write_mesh(mesh)
        self.u1 = dolfinx.fem.Function(compat.vector_space(mesh, 1), name="displacement_m")
        self.vm = dolfinx.fem.Function(compat.scalar_space(mesh, "DG", 0), name="von_mises_pa")

    def write(self, force_n: float) -> None:
        self.u1.interpolate(self.physics.u)
        if self.outputs.tensor_exprs:
            vm = self.outputs.cell_maxima()["von_mises_pa"]
            self.vm.x.array[: len(vm)] = vm
            self.vm.x.scatter_forward()
            self.file.write_function(self.vm, force_n)
        self.file.write_function(self.u1, force_n)

    def close(self) -> None:
        self.file.close()
        comm = self.physics.comm
        comm.barrier()
        on_root(comm, f"moving {self.final.name} into place", self._move_into_place)

    def _move_into_place(self) -> None:
        for f in self.staging.iterdir():
            os.replace(f, self.final.parent / f.name)
        self.staging.rmdir()
