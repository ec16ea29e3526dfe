"""The paper's stress question (studies/reproduce/stress.py): ours against Table 2, the 2-to-4-cone falls in words."""

from __future__ import annotations

import pytest

from suture_fem.studies.reproduce.stress import paper_table2, stress_comparison

RIM, EXIT = [0.62, 21.85], [0.159, 27.29]  # disc centres (mm): a cone's base rim, the thread's exit


def _results(seqv_cd, eptoeqv_cd, seqv_fillet, eptoeqv_fillet, strain_near_cone=None):
    """A results.json at 1 N; with ``strain_near_cone`` the tissue's largest strain average is at the thread's exit."""
    tissue = {"seqv_cd_pa": seqv_cd, "eptoeqv_cd": eptoeqv_cd, "seqv_fillet_pa": seqv_fillet,
              "eptoeqv_fillet": eptoeqv_fillet, "seqv_pa": 10 * seqv_fillet, "eptoeqv": 2 * eptoeqv_fillet,
              "seqv_cd_cone_pa": seqv_cd, "eptoeqv_cd_cone": strain_near_cone or eptoeqv_cd,
              "seqv_cd_pa_at_mm": RIM, "seqv_cd_cone_pa_at_mm": RIM, "eptoeqv_cd_cone_at_mm": RIM,
              "eptoeqv_cd_at_mm": EXIT if strain_near_cone else RIM}
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
    assert falls["seqv_cd_cone_pa"] == pytest.approx(0.6) and falls["eptoeqv_cd_cone"] == pytest.approx(0.2)
    assert "seqv_cd_cone_pa: 60 %" in cmp["answer"] and "seqv_cd_pa:" not in cmp["answer"]


def test_the_answer_is_the_cones_not_the_thread_exit():
    """The tissue-wide strain average at the thread's exit falls 20 %, the one near a cone 5 %: the answer says no."""
    cmp = stress_comparison({2: _results(100e3, 1.0, 400e3, 1.5, strain_near_cone=0.9),
                             4: _results(40e3, 0.8, 300e3, 1.2, strain_near_cone=0.855)})
    rows = {row["measure"]: row for row in cmp["rows"]}
    assert [r["measure"] for r in cmp["rows"]][:2] == ["seqv_cd_cone_pa", "seqv_cd_pa"]  # both kept, near first
    assert rows["eptoeqv_cd"]["fall_2_to_4"] == pytest.approx(0.2)
    assert rows["eptoeqv_cd_cone"]["fall_2_to_4"] == pytest.approx(0.05)
    assert rows["eptoeqv_cd"]["at_mm"] == {2: EXIT, 4: EXIT} and rows["eptoeqv_cd_cone"]["at_mm"][4] == RIM
    assert "near a cone" in rows["eptoeqv_cd_cone"]["label"] and "tissue-wide" in rows["eptoeqv_cd"]["label"]
    # the fillet peak (20 %) says yes, the near-cone average (5 %) no: partly
    assert "strain falls about 20 % from 2 to 4 cones? partly (eptoeqv_cd_cone: 5 %, eptoeqv_fillet: 20 %" in \
        cmp["answer"]
    assert "eptoeqv_cd:" not in cmp["answer"]


def test_the_markdown_says_where_the_tissue_wide_averages_sit():
    from suture_fem.studies.reproduce.stress import stress_markdown, where_sentence

    exit_ = stress_comparison({2: _results(100e3, 1.0, 400e3, 1.5, strain_near_cone=0.9),
                               4: _results(40e3, 0.8, 300e3, 1.2, strain_near_cone=0.855)})
    sentence = where_sentence(exit_)
    assert "within 3 critical distances of a cone's surface" in sentence
    assert "not at a cone for EPTOEQV 2 cones at (0.159, 27.29), 4 cones at (0.159, 27.29)" in sentence
    assert "SEQV" not in sentence.split("not at a cone")[1]  # the stress averages are at a rim
    text = "\n".join(stress_markdown(exit_))
    assert sentence in text
    assert "| EPTOEQV, critical-distance average near a cone | 4 | 1.240 | 0.855 (n.m.) | 21 % | 5 % (n.m.) |" in text
    at_cones = stress_comparison({2: _results(100e3, 1.0, 400e3, 1.5), 4: _results(40e3, 0.8, 300e3, 1.2)})
    assert "the largest anywhere in the tissue, at a cone in every case shown" in where_sentence(at_cones)
    both = stress_comparison({2: _results(100e3, 1.0, 400e3, 1.5), 4: _results(40e3, 0.8, 300e3, 1.2)},
                             uncalibrated={2: _results(100e3, 1.0, 400e3, 1.5, strain_near_cone=0.9),
                                           4: _results(40e3, 0.8, 300e3, 1.2, strain_near_cone=0.855)})
    assert "not at a cone for EPTOEQV uncalibrated 2 cones at" in where_sentence(both)
    one = stress_comparison({n: _results(100e3 / n, 1.0 / n, 400e3, 1.5, strain_near_cone=0.9 / n) for n in (1, 2, 4)})
    assert "EPTOEQV 1 cone at (0.159, 27.29), 2 cones at" in where_sentence(one)


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

    table = {(n, 1.0, 0.0, 0.1): {(1, k): {"seqv_cd_pa": v * s, "eptoeqv_cd": 1.0, "seqv_cd_cone_pa": v * s,
                                          "eptoeqv_cd_cone": 1.0}
                                  for k, v in enumerate((1.2, 1.1, 1.05))} for n, s in ((2, 100e3), (4, 40e3))}
    for key in ("seqv_cd_pa", "seqv_cd_cone_pa"):
        table[(2, 1.0, 0.0, 0.1)][(1, 2)][key] = 104e3  # the 2-cone finest rung: ratio 42e3 / 104e3
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
    assert "seqv_cd_cone_pa: 60 +- 0.76 %" in cmp["uncalibrated"]["answer"]
    near = next(r for r in cmp["uncalibrated"]["rows"] if r["measure"] == "seqv_cd_cone_pa")
    assert near["error_rel"] == row["error_rel"] and near["fall_error"] == pytest.approx(row["fall_error"])
    assert "| SEQV, critical-distance average near a cone | 4 | 235.5 kPa | 48 kPa +- 19 % |" in text


def test_the_ladder_measures_include_the_near_cone_averages():
    from suture_fem.studies.reproduce.stress_errors import LADDERS, MEASURED

    assert {"seqv_cd_cone_pa", "eptoeqv_cd_cone", "seqv_cd_pa", "eptoeqv_cd"} <= set(MEASURED)
    for ladder in LADDERS.values():
        for values in ladder.values():
            assert set(values) == set(MEASURED)
            assert values["seqv_cd_cone_pa"] <= values["seqv_cd_pa"]  # the near-cone search is restricted
            assert values["eptoeqv_cd_cone"] <= values["eptoeqv_cd"]


def test_ratio_sensitivity_reports_the_near_cone_ratios(monkeypatch):
    """No solving: the Model and the disc averages replaced by fakes with known values per cone count."""
    from suture_fem import pipeline
    from suture_fem.outputs import base, critical_distance
    from suture_fem.studies.reproduce.stress import ratio_sensitivity

    class Scene:
        def __init__(self, values=None):
            self.values = values or {}

        def with_values(self, values):
            return Scene(values)

    class Value:
        def __init__(self, value):
            self.value = value

    class Averages:
        def __init__(self, setup, radius_mm):
            self.cones, self.radius = setup, radius_mm

        def in_tissue(self, state):
            wide = {"seqv_cd_pa": 100e3 / self.cones, "eptoeqv_cd": 1.0}
            near = {"seqv_cd_cone_pa": 80e3 / self.cones * self.radius * 10, "eptoeqv_cd_cone": 0.8 / self.cones}
            return {k: Value(v) for k, v in {**wide, **near}.items()}

    class SolvedModel:  # a Model whose solve reports 1 N and whose outputs' setup is the cone count
        def __init__(self, scene, out, comm):
            self.outputs = type("Outputs", (), {"setup": scene.values["geometry.cones"]})()

        def solve(self):
            tissue = {"seqv_fillet_pa": None, "eptoeqv_fillet": None}
            return {"at_forces": [{"force_n": 1.0, "regions": {"tissue": tissue}}]}

        def reports(self):
            yield {"force_n": 1.0}

    monkeypatch.setattr(pipeline, "scene_model", SolvedModel)
    monkeypatch.setattr(critical_distance, "CriticalDistance", Averages)
    monkeypatch.setattr(base, "State", lambda setup: setup)
    rows = ratio_sensitivity(Scene(), None, fillets_mm=(0.0,), distances_mm=(0.05, 0.1))
    assert [r["critical_distance_mm"] for r in rows] == [0.05, 0.1]
    for r in rows:
        assert r["seqv_cd_pa_ratio"] == pytest.approx(0.5) and r["eptoeqv_cd_ratio"] == pytest.approx(1.0)
        assert r["seqv_cd_cone_pa_ratio"] == pytest.approx(0.5) and r["eptoeqv_cd_cone_ratio"] == pytest.approx(0.5)
        assert r["seqv_fillet_pa_ratio"] is None  # sharp rims: no fillet peak
