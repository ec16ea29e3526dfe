"""Fields for pictures and ParaView: the per-cell maxima of the stress and strain, and the XDMF writer."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import dolfinx.fem
import numpy as np

from suture_fem.outputs.base import PointFields, hencky_equivalent, von_mises
from suture_fem.physics.problem import Physics
from suture_fem.support import compat
from suture_fem.support.parallel import on_root

if TYPE_CHECKING:
    from suture_fem.outputs.evaluate import Outputs


def cell_maxima(points: PointFields) -> dict[str, np.ndarray]:
    """The maximum stress and strain in every local cell.

    Per local cell (ghosts included), the maximum over its quadrature points of the von Mises
    stress (Pa, key "von_mises_pa") and of the equivalent Hencky strain ("eptoeqv"), indexed by
    local cell number (zero in cells of no tag).
    """
    mesh = points.physics.mesh
    index_map = mesh.topology.index_map(mesh.topology.dim)
    num = index_map.size_local + index_map.num_ghosts
    fields = {"von_mises_pa": np.zeros(num), "eptoeqv": np.zeros(num)}
    for tag, cells in points.cells.items():
        if len(cells) == 0:
            continue
        vals = points.tensors(tag)
        fields["von_mises_pa"][cells] = von_mises(vals[:, :4]).reshape(len(cells), -1).max(axis=1)
        fields["eptoeqv"][cells] = hencky_equivalent(vals[:, 4:])[0].reshape(len(cells), -1).max(axis=1)
    return fields


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
        """Append the current state at time ``force_n`` (collective)."""
        self.u1.interpolate(self.physics.u)
        if self.outputs.tensor_exprs:
            vm = self.outputs.cell_maxima()["von_mises_pa"]
            self.vm.x.array[: len(vm)] = vm
            self.vm.x.scatter_forward()
            self.file.write_function(self.vm, force_n)
        self.file.write_function(self.u1, force_n)

    def close(self) -> None:
        """Close the file and move the pair into place (collective)."""
        self.file.close()
        comm = self.physics.comm
        comm.barrier()
        on_root(comm, f"moving {self.final.name} into place", self._move_into_place)

    def _move_into_place(self) -> None:
        for f in self.staging.iterdir():
            os.replace(f, self.final.parent / f.name)
        self.staging.rmdir()
