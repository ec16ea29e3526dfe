"""Fields for pictures and ParaView: the per-cell maxima of the stress and strain, and the XDMF writer."""

from __future__ import annotations

import contextlib
import ctypes
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING, Any

import dolfinx.fem
import numpy as np

from suture_fem.geometry import mesh as meshmod
from suture_fem.outputs.base import PointFields, hencky_equivalent, von_mises
from suture_fem.physics.problem import Physics
from suture_fem.support import compat
from suture_fem.support.io import WriteError, commit, remove, why
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
        half = vals.shape[1] // 2  # stress columns, then strain columns
        fields["von_mises_pa"][cells] = von_mises(vals[:, :half]).reshape(len(cells), -1).max(axis=1)
        fields["eptoeqv"][cells] = hencky_equivalent(vals[:, half:])[0].reshape(len(cells), -1).max(axis=1)
    return fields


class FieldWriter:
    """XDMF output for ParaView: displacement (P1; P2 on quadratic cells) and the cell-wise maximum von Mises stress.

    Complete or absent: the pair is written into a hidden folder and moved beside results.json on
    :meth:`close`, after both files are flushed to disk. A failed write (a full disk) removes the
    hidden folder and raises WriteError in one line; :meth:`discard` does the same after any other failure.
    """

    def __init__(self, physics: Physics, outputs: Outputs, path: str):
        self.physics, self.outputs = physics, outputs
        mesh = physics.mesh
        # The .xdmf names its .h5 by a relative path, which the move keeps.
        self.final = Path(path)
        self.staging = self.final.parent / f".{self.final.stem}.partial"
        self.file = None
        on_root(mesh.comm, f"creating {self.staging}", _fresh, self.staging)
        # XDMF writes a Lagrange function of the mesh's own degree (P2 on quadratic cells)
        self.u1 = dolfinx.fem.Function(compat.vector_space(mesh, meshmod.geometry_degree(mesh)), name="displacement_m")
        self.vm = dolfinx.fem.Function(compat.scalar_space(mesh, "DG", 0), name="von_mises_pa")
        _quiet_hdf5()
        self._room_for(_mesh_bytes(mesh) + self._step_bytes())
        self._checked(self._open)

    def _step_bytes(self) -> int:
        """About the bytes one written state adds to the .h5 (XDMF pads 2-vectors to 3 components)."""
        dofs = self.u1.function_space.dofmap.index_map.size_global
        return 8 * (3 * dofs + self.vm.function_space.dofmap.index_map.size_global)

    def _room_for(self, nbytes: int) -> None:
        """Refuse a write the disk has no room for, on every rank at once (collective).

        Under MPI a full disk fails HDF5's collective write on one rank while the others wait inside
        the next collective call for ever; checking the free space first keeps every rank together.
        """
        comm = self.physics.comm
        need = nbytes + (64 << 10)  # HDF5 metadata; the estimate is above the true size (a third on the paper scene)
        need, free = comm.bcast((need, shutil.disk_usage(self.staging).free) if comm.rank == 0 else None, root=0)
        if free < need:
            self.discard()
            raise WriteError(f"writing {self.final.with_suffix('.h5')}: needs about {need / 1024:.0f} KiB, "
                             f"{free / 1024:.0f} KiB free on the disk of {self.final.parent}; no field files were kept")

    def _open(self) -> None:
        self.file = compat.create_xdmf(self.physics.mesh.comm, str(self.staging / self.final.name))
        self.file.write_mesh(self.physics.mesh)

    def _checked(self, fn: Any, *args: Any) -> None:
        """Run an HDF5 write; on failure remove the partial files and raise WriteError (collective)."""
        try:
            fn(*args)
        except (RuntimeError, OSError) as exc:
            self.discard()
            raise WriteError(f"writing {self.final.with_suffix('.h5')}: {why(exc, self.final.parent)}; "
                             "no field files were kept") from None

    def write(self, force_n: float) -> None:
        """Append the current state at time ``force_n`` (collective)."""
        self._room_for(self._step_bytes())
        self.u1.interpolate(self.physics.u)
        if self.outputs.tensor_exprs:
            vm = self.outputs.cell_maxima()["von_mises_pa"]
            self.vm.x.array[: len(vm)] = vm
            self.vm.x.scatter_forward()
            self._checked(self.file.write_function, self.vm, force_n)
        self._checked(self.file.write_function, self.u1, force_n)

    def close(self) -> None:
        """Close the file, flush the pair to disk and move it into place (collective)."""
        file, self.file = self.file, None
        if file is None:
            return
        self._checked(file.close)
        comm = self.physics.comm
        comm.barrier()
        on_root(comm, f"moving {self.final.name} into place", self._move_into_place)

    def discard(self) -> None:
        """Drop the partial files after a failure (never raises; rank 0 removes the hidden folder)."""
        file, self.file = self.file, None
        comm = self.physics.comm
        if comm.rank == 0:
            # Empty the partial files first: their blocks are free again, so HDF5 can close the file
            # (on a full disk its close fails, and under MPI the file's destructor then aborts every rank)
            for f in self.staging.glob("*") if self.staging.is_dir() else ():
                with contextlib.suppress(OSError):
                    os.truncate(f, 0)
        if file is not None:
            comm.barrier()
            try:
                file.close()
            except Exception:  # noqa: BLE001 (the write failed already; the folder goes anyway)
                _keep_unclosed(file)
        if comm.rank == 0:
            remove(self.staging)

    def _move_into_place(self) -> None:
        # the .h5 first: the .xdmf that names it appears only once its data is in place
        names = sorted((f.name for f in self.staging.iterdir()), key=lambda n: not n.endswith(".h5"))
        try:
            for name in names:
                commit(self.staging / name, self.final.parent / name)
        except BaseException:
            remove(self.staging, *(self.final.parent / n for n in names))
            raise
        self.staging.rmdir()


def _mesh_bytes(mesh: Any) -> int:
    """About the bytes of the mesh in the .h5: node coordinates (3 per node) and cells' nodes (int64)."""
    cells = mesh.topology.index_map(mesh.topology.dim).size_global
    nodes = mesh.geometry.index_map().size_global
    return 8 * (3 * nodes + compat.geometry_dofs(mesh).shape[1] * cells)


def _keep_unclosed(file: Any) -> None:
    """Never destroy a file HDF5 failed to close: its C++ destructor would close it again, throw, and abort.

    After a failed write under MPI (a full disk) HDF5 cannot close the file; dolfinx's XDMFFile
    destructor then throws "Failed to close HDF5 file." and every rank aborts in C++ (exit 134,
    dozens of lines). The object is given one reference that is never released, so it outlives the
    interpreter; the operating system closes the descriptor when the process ends.
    """
    ctypes.pythonapi.Py_IncRef(ctypes.py_object(file))


def _fresh(folder: Path) -> None:
    remove(folder)
    folder.mkdir(parents=True)


def _quiet_hdf5() -> None:
    """HDF5's own error stack (dozens of lines on a full disk) stays off the terminal; WriteError says it in one.

    ``H5Eset_auto2(H5E_DEFAULT, NULL, NULL)`` in the HDF5 library dolfinx loaded (found in this
    process's memory map); a no-op where there is none.
    """
    try:
        with open("/proc/self/maps") as maps:
            libs = {line.split()[-1] for line in maps if "libhdf5" in line and ".so" in line}
        for lib in libs:
            ctypes.CDLL(lib).H5Eset_auto2(ctypes.c_int64(0), None, None)
    except (OSError, AttributeError):
        pass
