"""The failure measures against the pull, and where each part's measure reaches its strength.

A :class:`Sample` is one converged reported force with, for each part that can fail, the measure the
criterion compares with its strength and where it is: each tissue layer's critical-distance average
(``seqv_cd_pa`` or ``eptoeqv_cd`` of ``regions.<layer>``) and the thread's force (the pull: the thread
carries all of it at its pulled end). :func:`failure_force` finds, on the samples of all passes, the
bracket and the linearly interpolated force at which a part's measure first reaches a strength, and
:func:`first_failure` the part that fails first. Pure functions of the samples: no solve here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from suture_fem.scene.strength import LAYERS

#: Every part that can fail: the tissue layers (they tear) and the thread (it breaks).
PARTS = (*LAYERS, "thread")
#: The critical-distance measure each criterion compares with a layer's strength.
MEASURE = {"stress": "seqv_cd_pa", "strain": "eptoeqv_cd"}


@dataclass(frozen=True)
class Sample:
    """One converged reported force: each part's failure measure and where it is (r, z in mm)."""

    force_n: float
    values: dict[str, float]
    at_mm: dict[str, list[float] | None]


@dataclass(frozen=True)
class Crossing:
    """Where a part's measure first reaches a strength: the bracket of sampled forces and the interpolation."""

    part: str
    below_n: float
    above_n: float
    force_n: float
    at_mm: list[float] | None


def sample(report: Any, criterion: str, thread_end_mm: list[float]) -> Sample:
    """The failure measures of one reported state (a results.json ``at_forces`` entry)."""
    name = MEASURE[criterion]
    regions = report["regions"]
    values = {layer: float(regions[layer][name]) for layer in LAYERS}
    at = {layer: regions[layer].get(name + "_at_mm") for layer in LAYERS}
    values["thread"], at["thread"] = float(report["force_n"]), list(thread_end_mm)
    return Sample(float(report["force_n"]), values, at)


def merged(samples: list[Sample]) -> list[Sample]:
    """The samples in order of force, one per force (a later pass's repeat of a force is dropped)."""
    seen: dict[float, Sample] = {}
    for s in samples:
        seen.setdefault(round(s.force_n, 12), s)
    return [seen[k] for k in sorted(seen)]


def failure_force(samples: list[Sample], part: str, strength: float) -> Crossing | None:
    """Where ``part``'s measure first reaches ``strength`` on the samples (None: not within them).

    The measure is taken as 0 at rest (force 0); between two samples it is interpolated linearly,
    which is exact for the thread (its measure is the force) and converges as the samples close in.
    """
    previous = (0.0, 0.0)
    for s in merged(samples):
        value = s.values[part]
        if value >= strength:
            f0, v0 = previous
            t = (strength - v0) / (value - v0) if value > v0 else 1.0
            return Crossing(part, f0, s.force_n, f0 + t * (s.force_n - f0), s.at_mm[part])
        previous = (s.force_n, value)
    return None


def first_failure(samples: list[Sample], strengths: dict[str, float]) -> Crossing | None:
    """The part that fails first at the given strengths (the smallest interpolated failure force)."""
    found = [c for part, value in strengths.items() if (c := failure_force(samples, part, value)) is not None]
    return min(found, key=lambda c: c.force_n) if found else None


def strengths(scene: Any, which: str = "value") -> dict[str, float]:
    """Each part's strength from ``scene.strength``: its value, or the low or high end of its band."""
    out = {}
    for layer in LAYERS:
        value, band = scene.strength.of(layer)
        out[layer] = value * {"value": 1.0, "low": band[0], "high": band[1]}[which]
    band = scene.strength.thread_break_band
    out["thread"] = scene.strength.thread_break_n * {"value": 1.0, "low": band[0], "high": band[1]}[which]
    return out
