"""Mesh: the gmsh model meshed on rank 0 and distributed as a dolfinx mesh with its tags.

gmsh runs on rank 0 only (OpenCASCADE kernel, :mod:`suture_fem.geometry.gmsh_model`); every rank
learns its outcome. The gmsh model is in millimetres; the dolfinx mesh is scaled to metres (SI
throughout the solver).
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.geometry import curved
from suture_fem.geometry.gmsh_3d import build_gmsh_model_3d
from suture_fem.geometry.gmsh_model import MeshSizes, build_gmsh_model
from suture_fem.geometry.regions import CELL_TAGS, FACET_TAGS, MM, REGION_OF_TAG, REGIONS
from suture_fem.geometry.section import Geometry
from suture_fem.scene.schema import GeometrySection, MeshSection
from suture_fem.support import compat
from suture_fem.support.errors import SceneError
from suture_fem.support.io import WriteError, commit, temporary_name, usable_folder, why, write_json
from suture_fem.support.parallel import on_root


@dataclass
class TaggedMesh:
    """A dolfinx mesh (in metres) with its cell and facet tags."""

    mesh: Any
    cell_tags: Any
    facet_tags: Any
    geometry: Geometry
    sizes: MeshSizes


def create_mesh(comm: Any, geometry_section: GeometrySection, mesh_section: MeshSection,
                split_thread: bool = False, split_cones: bool = False) -> TaggedMesh:
    """Build the mesh of a scene on rank 0 of ``comm`` and distribute it (coordinates in metres).

    ``split_thread``: the tissue gets its own nodes along the bare thread, tagged ``track``
    (``effects.thread_interface`` not tied); ``split_cones``: on the cones' surfaces, tagged
    ``cone_contact`` (``effects.cone_interface`` not tied; :func:`~suture_fem.geometry.gmsh_model.split_interfaces`).
    """
    geometry = Geometry.from_section(geometry_section)
    sizes = MeshSizes.from_section(mesh_section)
    gdim = geometry_section.dimension
    build, args = ((build_gmsh_model_3d, (geometry, sizes, "suture3d", split_thread, split_cones,
                                          mesh_section.geometry_degree)) if gdim == 3 else
                   (build_gmsh_model, (geometry, sizes, "suture", mesh_section.geometry_degree, split_thread,
                                       split_cones)))
    if comm.rank == 0:
        with compat.gmsh_session() as gmsh:
            try:
                on_root(comm, "meshing (gmsh)", build, *args)
                mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(gmsh.model, comm, 0, gdim=gdim)
            finally:
                gmsh.model.remove()
    else:
        on_root(comm, "meshing (gmsh)", build, *args)  # rank 0's outcome, on every rank
        mesh, cell_tags, facet_tags = compat.gmsh_model_to_mesh(None, comm, 0, gdim=gdim)
    mesh.geometry.x[:, :gdim] *= MM
    folded = mesh.comm.allreduce(folded_cells(mesh)) if geometry_degree(mesh) == 2 else 0
    if folded:
        where, cure = (("on the model's curved surfaces", "refine the mesh (mesh.size_*_mm)") if gdim == 3 else
                       ("on the fillet arcs", f"raise mesh.fillet_elements (now {mesh_section.fillet_elements})"))
        raise SceneError(f"mesh.geometry_degree = 2: {folded} quadratic cell(s) {where} fold over (their Jacobian "
                         f"changes sign); {cure}")
    return TaggedMesh(mesh, cell_tags, facet_tags, geometry, sizes)


def present_regions(tagged: TaggedMesh) -> dict[str, tuple[int, ...]]:
    """Region -> its cell tags present anywhere on the communicator (a region may be absent, e.g. no cones)."""
    local = set(int(t) for t in np.unique(tagged.cell_tags.values))
    present = set().union(*tagged.mesh.comm.allgather(local))
    found = {}
    for region in REGIONS:
        tags = tuple(t for t, r in REGION_OF_TAG.items() if r == region and t in present)
        if tags:
            found[region] = tags
    return found


def scene_mesh(comm: Any, scene: Any) -> TaggedMesh:
    """:func:`create_mesh` of a scene (its geometry, mesh and interface models)."""
    return create_mesh(comm, scene.geometry, scene.mesh, split_thread=scene.effects.thread_track,
                       split_cones=scene.effects.cone_contact)


def check_msh_path(path: str | Path) -> Path:
    """The path of a .msh file to write; SceneError (one line) for a folder or another suffix.

    The JSON record is written beside it with the suffix .json, so ``X.json`` would be overwritten.
    """
    path = Path(path)
    if path.is_dir():
        raise SceneError(f"--out {path}: is a folder; give the mesh file's name, e.g. --out {path / 'mesh.msh'}")
    if path.suffix != ".msh":
        raise SceneError(f"--out {path}: the mesh file's name must end in .msh (its JSON record is written beside "
                         f"it with .json), e.g. --out {path.with_suffix('.msh')}")
    usable_folder(path.parent, f"--out {path}: its folder")
    return path


def _write_checked(gmsh: Any, path: Path) -> None:
    """gmsh.write to a temporary name, checked to end with a complete section, flushed, then renamed.

    gmsh does not report a short write (a full disk): a file that does not end with a ``$End...``
    line is removed and the error raised instead of being renamed into place.
    """
    tmp = temporary_name(path, ".msh")  # gmsh picks the format by the suffix
    try:
        gmsh.write(str(tmp))
        with open(tmp, "rb") as f:
            f.seek(max(0, os.fstat(f.fileno()).st_size - 64))
            tail = f.read().rstrip().rsplit(b"\n", 1)[-1]
        if not tail.startswith(b"$End"):
            reason = why(OSError(28, "short write"), path.parent)
            raise WriteError(f"writing {path}: gmsh wrote an incomplete file ({reason}); nothing was written")
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    commit(tmp, path)


def write_msh(geometry_section: GeometrySection, mesh_section: MeshSection, path: str | Path,
              split_thread: bool = False, split_cones: bool = False) -> dict[str, Any]:
    """Write a scene's mesh as a gmsh .msh file (mm) with a JSON record of its parameters beside it.

    Raises SceneError when ``path`` is a folder or does not end in .msh (before meshing), WriteError
    when the disk is full (no partial file is left).
    """
    from suture_fem import __version__

    path = check_msh_path(path)
    geometry = Geometry.from_section(geometry_section)
    sizes = MeshSizes.from_section(mesh_section)
    dim = geometry_section.dimension
    with compat.gmsh_session() as gmsh:
        try:
            if dim == 3:
                build_gmsh_model_3d(geometry, sizes, split_thread=split_thread, split_cones=split_cones,
                                    geometry_degree=mesh_section.geometry_degree)
            else:
                build_gmsh_model(geometry, sizes, geometry_degree=mesh_section.geometry_degree,
                                 split_thread=split_thread, split_cones=split_cones)
            _write_checked(gmsh, path)
            nodes = len(gmsh.model.mesh.getNodes()[0])
            types, tags, _ = gmsh.model.mesh.getElements(dim)
            cells = sum(len(t) for t in tags)
        finally:
            gmsh.model.remove()
    record = {
        "suture_fem_version": __version__,
        "units": "mm",
        "nodes": nodes,
        "triangles" if dim == 2 else "tetrahedra": int(cells),
        "geometry_degree": 2 if {curved.GMSH_TRIANGLE6, curved.GMSH_TETRAHEDRON10} & set(types) else 1,
        "thread_track_split": split_thread,
        **({"cone_surfaces_split": True} if split_cones else {}),
        "cell_tags": CELL_TAGS,
        "facet_tags": FACET_TAGS,
        "geometry": geometry.describe(),
        "sizes_mm": sizes.__dict__,
        "scene": {"geometry": asdict(geometry_section), "mesh": asdict(mesh_section)},
    }
    write_json(path.with_suffix(".json"), record)
    return record


def region_cells(tagged: TaggedMesh, tags: tuple[int, ...] | int) -> np.ndarray:
    """Local cell indices carrying any of the given cell tags."""
    tags = (tags,) if isinstance(tags, int) else tags
    ct = tagged.cell_tags
    return np.sort(ct.indices[np.isin(ct.values, tags)]).astype(np.int32)


def facets(tagged: TaggedMesh, tag: int) -> np.ndarray:
    """Local facet indices carrying a facet tag."""
    ft = tagged.facet_tags
    return ft.indices[ft.values == tag].astype(np.int32)


def describe(tagged: TaggedMesh) -> dict[str, Any]:
    """Global cell count and sizes, JSON-ready."""
    m = tagged.mesh
    n_local = m.topology.index_map(m.topology.dim).size_local
    out = {
        "cells": int(m.comm.allreduce(n_local)),
        "geometry_degree": geometry_degree(m),
        "sizes_mm": tagged.sizes.__dict__,
        "geometry": tagged.geometry.describe(),
    }
    if m.geometry.dim == 3:
        kind = f"{tagged.geometry.kind} (as in 2-D)" if tagged.geometry.cones else "none"
        model = MODEL_3D if tagged.geometry.slab is None else MODEL_SLAB
        cells = {"cells": CURVED_3D} if out["geometry_degree"] == 2 else {}
        out["model_3d"] = model | {"cones": kind} | cells
    return out


#: results.json's description of the 3-D model (``geometry.dimension = 3``).
MODEL_3D = {
    "tissue_shape": "cylinder",
    "symmetry": "half model: the solid z <= 0, symmetry plane z = 0 through the thread's axis (u_z = 0 on it); "
                "energies, forces and reactions are those of the whole solid (the half's doubled)",
    "axes": "x, y, z in mm; the thread along y (the 2-D model's z), r = sqrt(x^2 + z^2)",
    "cells": "linear tetrahedra (straight-sided), the 2-D section revolved by pi",
}
#: results.json's description of the 3-D cells with ``mesh.geometry_degree = 2``.
CURVED_3D = "quadratic tetrahedra, their mid-edge nodes on the model's curved surfaces (gmsh's setOrder(2))"
#: results.json's description of the slab (``geometry.tissue_shape = "slab"``).
MODEL_SLAB = {
    "tissue_shape": "slab",
    "symmetry": "half model: the solid z <= 0, symmetry plane z = 0 through the thread's axis and normal to the skin "
                "(u_z = 0 on it); energies, forces and reactions are those of the whole solid (the half's doubled)",
    "axes": "x, y, z in mm; the thread along y on x = z = 0, the skin surface x = geometry.thread_depth_mm (outward "
            "normal +x), the deep face x = -geometry.hypodermis_mm",
    "supports": "u = 0 on the deep face and on the lateral face z = -geometry.slab_half_width_mm; the skin surface and "
                "the tissue's end faces y = 0 and y = L are free",
    "cells": "linear tetrahedra (straight-sided): the layers as boxes, the thread and cones revolved by pi",
}


def geometry_degree(mesh: Any) -> int:
    """The degree of the mesh's cells, from their nodes: 3 or 4 (straight-sided) -> 1, 6 or 10 (quadratic) -> 2."""
    return {3: 1, 6: 2, 4: 1, 10: 2}[compat.geometry_dofs(mesh).shape[1]]


def folded_cells(mesh: Any) -> int:
    """The local quadratic triangles or tetrahedra whose Jacobian determinant changes sign (or vanishes) inside them.

    :func:`~suture_fem.geometry.curved.folded`: a cell whose curved edge bulges past its opposite corner (or face)
    would integrate with a wrong sign without any error.
    """
    dim = mesh.topology.dim
    return int(np.sum(curved.folded(mesh.geometry.x[:, :dim][compat.geometry_dofs(mesh)])))
