"""Error bars of the tissue's stress and strain measures in ``reproduce``, from measured ladders.

A value solved on one mesh rung (degree, refinement) gets the relative error bar

    |Q_rung - Q_finest| + |Q_finest - Q_second finest|     (divided by |Q_finest|)

from a ladder of the same case (cone count, tissue_scale, fillet radius, critical distance, 1 N) in
:data:`LADDERS`: its distance to the finest rung solved, plus the spread between the two finest rungs
as the finest rung's own uncertainty. The ratio of two cone counts gets the same bar computed from the
ratios rung by rung (both cone counts solved on the same rung), so errors the two cone counts share
cancel in it as they do in the ratio itself. This is the spread between the two finest rungs, not a
Richardson estimate: the ledgers (docs/ledger.md) do not give these measures a settled limit at every
rung, and where they do the spread is the larger of the two.

Where no ladder of the case was measured, the bar is None and the report says "not measured". The
ladders were solved with ``suture-fem convergence paper_reproduction --set geometry.cones=N --set
loading.force_n=1 --set materials.tissue_scale=S --forces 1 --degrees 1 --refinements 0,1,2 --out DIR``
for N = 2, 4 and S = 1, 0.3112 (sharp rims, the scene's default; 12 rungs, 8.9 min of CPU in all on a
shared 2-core machine) and read by
``benchmarks/stress_errors.py DIR...``, which prints this table.
"""

from __future__ import annotations

from typing import Any

#: The tissue measures with ladders: results.json keys under ``regions.tissue`` (the critical-distance
#: averages near a cone and tissue-wide, the fillet peak).
MEASURED = ("seqv_cd_cone_pa", "eptoeqv_cd_cone", "seqv_cd_pa", "eptoeqv_cd", "seqv_fillet_pa", "eptoeqv_fillet")

#: (cones, tissue_scale, cone_fillet_mm, critical_distance_mm) -> rung (degree, refinement) -> measure -> value
#: at 1 N. Rungs of one ladder differ only in mesh.refinement (every size halves) or mesh.degree.
#: Measured (Debian 12, dolfinx 0.5.2, gmsh 4.8; paper_reproduction, sharp rims, 1 N, with the exact disc
#: average of the fitted field, from each triangle's overlap with the disc): tissue_scale 1 (uncalibrated) and
#: 0.3112 (the calibrated value of docs/reproduction.md). Where the discs sit, in every rung: the near-cone
#: stress and strain averages at a cone's base rim (r = 0.62 mm; which cone varies with the case and the rung);
#: the tissue-wide stress average at the same disc, except 4 cones uncalibrated on rungs r1 and r2, where it sits
#: at the thread's exit from the tissue's pulled face; the tissue-wide strain average at that exit (r =
#: 0.125-0.16 mm, z = the tissue's length), not at a cone.
LADDERS: dict[tuple[int, float, float, float], dict[tuple[int, int], dict[str, float | None]]] = {
    (2, 0.3112, 0.0, 0.1): {
        (1, 0): {'seqv_cd_cone_pa': 261796.0, 'eptoeqv_cd_cone': 1.39389, 'seqv_cd_pa': 261796.0,
            'eptoeqv_cd': 1.47735, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 1): {'seqv_cd_cone_pa': 237116.0, 'eptoeqv_cd_cone': 1.39803, 'seqv_cd_pa': 237116.0,
            'eptoeqv_cd': 1.53244, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 2): {'seqv_cd_cone_pa': 218467.0, 'eptoeqv_cd_cone': 1.40041, 'seqv_cd_pa': 218467.0,
            'eptoeqv_cd': 1.54284, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
    },
    (2, 1.0, 0.0, 0.1): {
        (1, 0): {'seqv_cd_cone_pa': 207497.0, 'eptoeqv_cd_cone': 1.06461, 'seqv_cd_pa': 207497.0,
            'eptoeqv_cd': 1.1235, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 1): {'seqv_cd_cone_pa': 188685.0, 'eptoeqv_cd_cone': 1.07044, 'seqv_cd_pa': 188685.0,
            'eptoeqv_cd': 1.17671, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 2): {'seqv_cd_cone_pa': 180275.0, 'eptoeqv_cd_cone': 1.06287, 'seqv_cd_pa': 180275.0,
            'eptoeqv_cd': 1.18714, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
    },
    (4, 0.3112, 0.0, 0.1): {
        (1, 0): {'seqv_cd_cone_pa': 127245.0, 'eptoeqv_cd_cone': 1.2135, 'seqv_cd_pa': 127245.0,
            'eptoeqv_cd': 1.28186, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 1): {'seqv_cd_cone_pa': 109819.0, 'eptoeqv_cd_cone': 1.20174, 'seqv_cd_pa': 109819.0,
            'eptoeqv_cd': 1.33688, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 2): {'seqv_cd_cone_pa': 101204.0, 'eptoeqv_cd_cone': 1.20612, 'seqv_cd_pa': 101204.0,
            'eptoeqv_cd': 1.34652, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
    },
    (4, 1.0, 0.0, 0.1): {
        (1, 0): {'seqv_cd_cone_pa': 101109.0, 'eptoeqv_cd_cone': 0.909022, 'seqv_cd_pa': 101109.0,
            'eptoeqv_cd': 0.956393, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 1): {'seqv_cd_cone_pa': 91848.0, 'eptoeqv_cd_cone': 0.907434, 'seqv_cd_pa': 95519.8,
            'eptoeqv_cd': 1.01156, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
        (1, 2): {'seqv_cd_cone_pa': 89848.8, 'eptoeqv_cd_cone': 0.907586, 'seqv_cd_pa': 98353.6,
            'eptoeqv_cd': 1.02062, 'seqv_fillet_pa': None, 'eptoeqv_fillet': None},
    },
}

#: Two tissue scales are the same case within this relative tolerance (a calibration run lands a few
#: 1e-3 from the value a ladder was measured at; the bars are not that precise).
SCALE_TOLERANCE = 0.02


def _case(results: dict[str, Any]) -> tuple[tuple[int, float, float, float] | None, tuple[int, int]]:
    """The ladder key matching a results.json (None when no ladder was measured) and its rung."""
    scene = results.get("scene", {})
    g, m = scene.get("geometry", {}), scene.get("mesh", {})
    scale = scene.get("materials", {}).get("tissue_scale", 1.0)
    fillet, distance = g.get("cone_fillet_mm", 0.0), scene.get("output", {}).get("critical_distance_mm")
    rung = (m.get("degree"), m.get("refinement"))
    for key in LADDERS:
        cones, s, f, d = key
        if (cones == g.get("cones") and abs(s - scale) <= SCALE_TOLERANCE * s and f == fillet and d == distance
                and m.get("size_suture_mm") == 0.15):
            return key, rung
    return None, rung


def _bar(ladder: dict[tuple[int, int], float], rung: tuple[int, int]) -> float | None:
    """|Q_rung - Q_finest| + |Q_finest - Q_second|, relative to |Q_finest|, on one degree's ladder."""
    same = sorted(k for k in ladder if k[0] == rung[0] and ladder[k] is not None)
    if rung not in same or len(same) < 2 or not ladder[same[-1]]:
        return None
    finest, second = ladder[same[-1]], ladder[same[-2]]
    return (abs(ladder[rung] - finest) + abs(finest - second)) / abs(finest)


def error_bar(results: dict[str, Any], measure: str) -> float | None:
    """The relative error bar of ``measure`` in one cone count's results.json at 1 N, None if not measured."""
    key, rung = _case(results)
    if key is None:
        return None
    return _bar({k: v.get(measure) for k, v in LADDERS[key].items()}, rung)


def ratio_error_bar(results_a: dict[str, Any], results_b: dict[str, Any], measure: str) -> float | None:
    """The relative error bar of ``measure``'s ratio b / a (e.g. 4 over 2 cones), from the ratios rung by rung."""
    (ka, ra), (kb, rb) = _case(results_a), _case(results_b)
    if ka is None or kb is None or ra != rb:
        return None
    a, b = LADDERS[ka], LADDERS[kb]
    ratios = {k: b[k][measure] / a[k][measure] for k in set(a) & set(b)
              if a[k].get(measure) and b[k].get(measure) is not None}
    return _bar(ratios, ra)
