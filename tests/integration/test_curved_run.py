"""A run on quadratic cells (``mesh.geometry_degree = 2``): complete, balanced, its field file written, and the
same displacement as on straight cells, which differ only by the slivers between the fillet arcs and their chords.

Marked long (15-20 s, more when every form and expression is compiled again for the quadratic coordinate
element); benchmarks/long_tests.py runs it; in the Debian 13 root: scripts/test-release.sh trixie -m long
tests/integration/test_curved_run.py.
"""

from __future__ import annotations

import math
from xml.etree import ElementTree

import pytest

from tests.conftest import run_inprocess

SCENE = ["geometry.cones=1", "geometry.cone_fillet_mm=0.04", "mesh.degree=2", "mesh.refinement=0",
         "loading.force_n=0.5", "loading.report_forces_n=[0.5]"]


@pytest.mark.long
def test_a_run_on_quadratic_cells(tmp_path):
    curved = run_inprocess("paper", SCENE + ["mesh.geometry_degree=2", "output.fields=true"], tmp_path / "curved")
    straight = run_inprocess("paper", SCENE, tmp_path / "straight")
    assert (curved["geometry_degree"], straight["geometry_degree"]) == (2, 1)
    assert curved["status"] == "converged"
    assert curved["reaction_force_n"] == pytest.approx(-0.5, rel=1e-8)
    assert (tmp_path / "curved" / "fields.xdmf").is_file() and (tmp_path / "curved" / "fields.h5").is_file()
    # the field file's mesh has the quadratic cells (six nodes each), not their vertex triangles
    xdmf = ElementTree.parse(tmp_path / "curved" / "fields.xdmf")
    topologies = {t.get("TopologyType") for t in xdmf.iter("Topology")}
    assert topologies == {"Triangle_6"}, topologies
    tissue = curved["at_forces"][-1]["regions"]["tissue"]
    assert all(math.isfinite(tissue[k]) for k in ("seqv_fillet_pa", "eptoeqv_fillet", "seqv_cd_pa", "eptoeqv_cd"))
    # the same mesh but for the arcs' mid-side nodes: the displacement hardly moves (measured: 1.0e-5 on this
    # scene, 1e-6 at 1 N on P2 r1 with 32 elements per arc)
    assert curved["usum_mm"] == pytest.approx(straight["usum_mm"], rel=1e-4)
    assert curved["cells"] == straight["cells"]
