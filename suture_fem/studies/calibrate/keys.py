"""The parameters a calibration may fit (``--fit KEY[=LOW:HIGH]``): which keys, their bounds, their method.

A fitted key is a continuous number of the scene that a measured curve can inform: a material
constant (``materials.<region>.<name>``), ``materials.tissue_scale``, ``loading.force_scale``, or a
geometric dimension (``geometry.*_mm``). The sensitivity of a key that is a dolfinx Constant of the
forms (every material constant and both scales) is computed by the direct method; a geometric key
changes the mesh, so its sensitivity is a central finite difference over two remeshed solves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from suture_fem.scene import Scene
from suture_fem.scene.load import _material_rule
from suture_fem.scene.schema import RULES, Rule
from suture_fem.support.errors import SceneError

DIRECT = "direct"
FINITE_DIFFERENCE = "central finite difference (remeshed)"

#: Default bounds of the scales: tissue five times softer to five times stiffer, likewise the force.
SCALE_BOUNDS = (0.2, 5.0)


@dataclass(frozen=True)
class FitKey:
    """One fitted scene key: its bounds, its starting value and how its sensitivity is computed."""

    key: str
    lo: float
    hi: float
    start: float
    method: str

    @property
    def geometric(self) -> bool:
        """True when a new value needs a new mesh."""
        return self.method == FINITE_DIFFERENCE


def _rule(key: str, scene: Scene) -> Rule:
    if key in RULES:
        return RULES[key]
    try:
        rule = _material_rule(key, scene.as_dict())
    except SceneError as exc:
        raise SceneError(f"--fit {key}: {str(exc).removeprefix('scene key ' + key + ': ')}") from None
    if rule is None:
        raise SceneError(f"--fit {key}: unknown scene key (fit a materials.*, geometry.*_mm, materials.tissue_scale "
                         "or loading.force_scale key)")
    return rule


def _default_bounds(key: str, value: float, rule: Rule) -> tuple[float, float]:
    if key in ("materials.tissue_scale", "loading.force_scale"):
        lo, hi = SCALE_BOUNDS
    elif key.startswith("geometry."):
        lo, hi = value / 2, value * 2
    else:
        lo, hi = value / 10, value * 10
    return max(lo, rule.lo), min(hi, rule.hi)


def parse_fit(text: str, scene: Scene) -> FitKey:
    """``KEY`` or ``KEY=LOW:HIGH`` checked against the scene (SceneError: one line naming key and range)."""
    key, eq, bounds = text.partition("=")
    key = key.strip()
    rule = _rule(key, scene)
    if rule.kind != "float":
        raise SceneError(f"--fit {key}: not a continuous number ({rule.describe()}); fit a float key")
    if not (key.startswith(("materials.", "geometry.")) or key == "loading.force_scale"):
        raise SceneError(f"--fit {key}: not a model parameter a measured curve can determine (fit a materials.*, "
                         "geometry.* or loading.force_scale key)")
    if key.endswith(".poisson"):
        raise SceneError(f"--fit {key}: Poisson's ratio is not fitted (its bounds are not a positive scale)")
    value = float(scene.get(key))
    if eq:
        lo, hi = _bounds(key, bounds, rule)
    else:
        lo, hi = _default_bounds(key, value, rule)
    if value <= 0:
        raise SceneError(f"--fit {key}: its scene value {value:g} must be > 0 to be fitted")
    method = FINITE_DIFFERENCE if key.startswith("geometry.") else DIRECT
    return FitKey(key, lo, hi, min(max(value, lo), hi), method)


def _bounds(key: str, text: str, rule: Rule) -> tuple[float, float]:
    parts = text.split(":")
    try:
        lo, hi = (float(p) for p in parts) if len(parts) == 2 else (math.nan, math.nan)
    except ValueError:
        lo = hi = math.nan
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise SceneError(f"--fit {key}={text}: bounds must be LOW:HIGH, two finite numbers")
    if not lo < hi:
        raise SceneError(f"--fit {key}={text}: empty bounds (LOW must be < HIGH)")
    if lo <= 0:
        raise SceneError(f"--fit {key}={text}: LOW must be > 0")
    for v in (lo, hi):
        rule.check(f"--fit {key} bound", v)
    return lo, hi
