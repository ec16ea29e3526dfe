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


def _solved(cones, seqv_cd, eptoeqv_cd, refinement=0, scale=1.0):
    """A results.json of one cone count solved on P1 r<refinement> of the reproduce scene, sharp rims."""
    res = _results(seqv_cd, eptoeqv_cd, 400e3, 1.5)  # sharp rims in the ladders: no fillet bars
    res["scene"] = {"geometry": {"cones": cones, "cone_fillet_mm": 0.0}, "materials": {"tissue_scale": scale},
                    "output": {"critical_distance_mm": 0.1},
                    "mesh": {"degree": 1, "refinement": refinement, "size_suture_mm": 0.15}}
    return res


@pytest.fixture
def ladders(monkeypatch):
    from suture_fem.studies.reproduce import stress_errors

    table = {(n, 1.0, 0.0, 0.1): {(1, k): {"seqv_cd_pa": v * s, "eptoeqv_cd": 1.0}
                                  for k, v in enumerate((1.2, 1.1, 1.05))} for n, s in ((2, 100e3), (4, 40e3))}
    table[(2, 1.0, 0.0, 0.1)][(1, 2)]["seqv_cd_pa"] = 104e3  # the 2-cone finest rung: ratio 42e3 / 104e3
    monkeypatch.setattr(stress_errors, "LADDERS", table)
    return table


def test_error_bars_are_the_distance_to_the_finest_rung_plus_the_last_spread(ladders):
    from suture_fem.studies.reproduce.stress_errors import error_bar, ratio_error_bar

    # 4 cones, P1 r0: |48 - 42| + |42 - 44| over 42
    assert error_bar(_solved(4, 48e3, 1.0), "seqv_cd_pa") == pytest.approx(8 / 42)
    assert error_bar(_solved(4, 42e3, 1.0, refinement=2), "seqv_cd_pa") == pytest.approx(2 / 42)
    assert error_bar(_solved(4, 48e3, 1.0), "eptoeqv_cd") == 0.0  # the same on every rung
    assert error_bar(_solved(4, 48e3, 1.0, scale=0.31), "seqv_cd_pa") is None  # no ladder of the calibrated case
    assert error_bar(_solved(3, 48e3, 1.0), "seqv_cd_pa") is None
    # the ratio rung by rung: 0.4, 0.4, 42/104; its bar at r0
    r_fine, r_second = 42 / 104, 0.4
    expected = (abs(0.4 - r_fine) + abs(r_fine - r_second)) / r_fine
    assert ratio_error_bar(_solved(2, 120e3, 1.0), _solved(4, 48e3, 1.0), "seqv_cd_pa") == pytest.approx(expected)
    assert ratio_error_bar(_solved(2, 120e3, 1.0), _solved(4, 42e3, 1.0, refinement=2), "seqv_cd_pa") is None


def test_the_comparison_carries_the_bars_and_both_columns(ladders):
    from suture_fem.studies.reproduce.stress import stress_markdown

    solved = {2: _solved(2, 120e3, 1.0), 4: _solved(4, 48e3, 1.0)}
    calibrated = {n: _solved(n, 2 * v, 1.2, scale=0.31) for n, v in ((2, 120e3), (4, 48e3))}
    cmp = stress_comparison(calibrated, uncalibrated=solved)
    row = next(r for r in cmp["uncalibrated"]["rows"] if r["measure"] == "seqv_cd_pa")
    assert row["error_rel"][4] == pytest.approx(8 / 42) and row["fall_2_to_4"] == pytest.approx(0.6)
    assert row["fall_error"] == pytest.approx(0.4 * (abs(0.4 - 42 / 104) * 2) / (42 / 104))
    assert next(r for r in cmp["rows"] if r["measure"] == "seqv_cd_pa")["error_rel"] == {2: None, 4: None}
    text = "\n".join(stress_markdown(cmp))
    assert "**uncalibrated**" in text and "**calibrated**" in text
    assert "48 kPa +- 19 %" in text and "(n.m.)" in text
    assert "seqv_cd_pa: 60 +- 0.76 %" in cmp["uncalibrated"]["answer"]
