"""Contact tests' shared helper: the gmsh model of a two-cone scene with its interfaces split or tied."""

from __future__ import annotations

from typing import Any

import numpy as np

from tests.conftest import FAST


def split_mesh(**splits: bool) -> dict[str, Any]:
    """Mesh the two-cone scene in gmsh with ``build_gmsh_model(**splits)``: the tissue's nodes shared with the
    thread and with the cones, and the physical groups of curves."""
    import gmsh

    from suture_fem.geometry.gmsh_model import MeshSizes, build_gmsh_model
    from suture_fem.geometry.regions import Cell
    from suture_fem.geometry.section import Geometry
    from suture_fem.pipeline import load_scene

    scene = load_scene("paper", [*FAST, "geometry.cones=2"])
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        build_gmsh_model(Geometry.from_section(scene.geometry), MeshSizes.from_section(scene.mesh), **splits)

        def nodes_of(tags):
            out = set()
            for tag in tags:
                for e in gmsh.model.getEntitiesForPhysicalGroup(2, tag):
                    out |= set(np.concatenate(gmsh.model.mesh.getElements(2, e)[2]).tolist())
            return out

        tissue = nodes_of([Cell.HYPODERMIS, Cell.DERMIS, Cell.EPIDERMIS])
        return {"thread": tissue & nodes_of([Cell.THREAD]), "cone": tissue & nodes_of([Cell.CONE]),
                "groups": {t for _, t in gmsh.model.getPhysicalGroups(1)}}
    finally:
        gmsh.finalize()
