"""The fillet refinement (geometry/gmsh_model.py): at least ``mesh.fillet_elements`` elements along every
fillet arc of a coarse paper scene, doubled per refinement, while the far field stays coarse."""

from __future__ import annotations

import pytest

from suture_fem.geometry.gmsh_model import MeshSizes, build_gmsh_model, fillet_arcs
from suture_fem.geometry.section import Geometry
from suture_fem.pipeline import load_scene
from tests.conftest import FAST

ROUNDED = "geometry.cone_fillet_mm=0.04"  # the recommended fillet (the default rims are sharp)


def _mesh(overrides):
    """(segments on each fillet arc, triangles, largest triangle area mm^2) of the paper scene's gmsh mesh."""
    import gmsh
    import numpy as np

    scene = load_scene("paper", FAST + overrides)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        build_gmsh_model(Geometry.from_section(scene.geometry), MeshSizes.from_section(scene.mesh))
        segments = [len(gmsh.model.mesh.getNodes(1, curve, includeBoundary=True)[0]) - 1
                    for curve, _ in fillet_arcs()]
        _, tags, nodes = gmsh.model.mesh.getElements(2)
        all_tags, xyz, _ = gmsh.model.mesh.getNodes()
        tags, nodes = np.concatenate(tags), np.concatenate(nodes).astype(int).reshape(-1, 3)
        index = np.zeros(int(max(all_tags.max(), nodes.max())) + 1, dtype=int)
        index[all_tags.astype(int)] = np.arange(len(all_tags))
        p = xyz.reshape(-1, 3)[index[nodes]][..., :2]
        area = 0.5 * np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1])
                            - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1]))
        return segments, len(tags), float(area.max())
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("elements", [8, 12])
def test_the_fillet_has_the_requested_elements_across_it(elements):
    segments, cells, largest = _mesh([f"mesh.fillet_elements={elements}", ROUNDED])
    assert len(segments) == 8  # 4 hollow cones, each with its outer and inner base rim rounded
    assert min(segments) >= elements
    sharp_segments, sharp_cells, sharp_largest = _mesh(["geometry.cone_fillet_mm=0"])
    assert sharp_segments == []
    assert largest == pytest.approx(sharp_largest, rel=0.25)  # the far field keeps its element size
    assert cells < 1.3 * sharp_cells  # the refinement is local: a few hundred cells per arc


def test_the_fillet_elements_double_with_every_refinement():
    segments, _, _ = _mesh(["mesh.fillet_elements=8", "mesh.refinement=1", "geometry.cones=1", ROUNDED])
    assert len(segments) == 2 and min(segments) >= 16
