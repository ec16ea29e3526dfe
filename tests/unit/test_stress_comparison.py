"""The paper's stress question (studies/reproduce/stress.py): ours against Table 2, the 2-to-4-cone falls in words."""

from __future__ import annotations

import pytest

from suture_fem.studies.reproduce.stress import paper_table2, stress_comparison


def _results(seqv_cd, eptoeqv_cd, seqv_fillet, eptoeqv_fillet):
    tissue = {"seqv_cd_pa": seqv_cd, "eptoeqv_cd": eptoeqv_cd, "seqv_fillet_pa": seqv_fillet,
              "eptoeqv_fillet": eptoeqv_fillet, "seqv_pa": 10 * seqv_fillet, "eptoeqv": 2 * eptoeqv_fillet}
    return {"at_forces": [{"force_n": 1.0, "regions": {"tissue": tissue}}]}


def test_table2_is_the_papers():
    table = paper_table2()
    assert table[2] == {"seqv": 662340.0, "eptoeqv": 1.57} and table[4] == {"seqv": 235490.0, "eptoeqv": 1.24}


def test_the_falls_and_the_answer():
    cmp = stress_comparison({2: _results(100e3, 1.0, 400e3, 1.5), 4: _results(40e3, 0.8, 300e3, 1.2)})
    falls = {row["measure"]: row["fall_2_to_4"] for row in cmp["rows"]}
    assert falls["seqv_cd_pa"] == pytest.approx(0.6) and falls["eptoeqv_cd"] == pytest.approx(0.2)
    assert falls["seqv_fillet_pa"] == pytest.approx(0.25)
    assert cmp["paper_fall_2_to_4"]["seqv"] == pytest.approx(1 - 235490 / 662340)
    assert "stress falls about 60 % from 2 to 4 cones? partly" in cmp["answer"]
    assert "strain falls about 20 % from 2 to 4 cones? yes" in cmp["answer"]
