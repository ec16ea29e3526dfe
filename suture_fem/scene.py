"""Scenes: what to simulate, read from TOML and validated before any meshing.

A scene is a nested mapping of sections (``geometry``, ``mesh``, ``materials``, ``loading``,
``solver``, ``effects``, ``output``). Every key has a default in ``scenes/defaults.toml`` and a rule in
:data:`RULES`; a scene file lists only what it changes. :func:`load_scene` merges a file (or a
built-in scene name) and ``KEY=VALUE`` overrides on the defaults and validates the result.
Cross-key checks that need the geometry (overlapping cones, cones outside the hypodermis) live in
:mod:`suture_fem.geometry` and run from here too, still before any meshing.
"""

from __future__ import annotations

import copy
import difflib
import logging
import math
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from suture_fem.errors import SceneError

INF = math.inf
log = logging.getLogger("suture_fem")


@dataclass(frozen=True)
class Rule:
    """Type and range of one scene key.

    Attributes:
        kind: "int", "float", "str", "bool", "floats" (list of numbers), "strs" (list of strings) or "table".
        lo, hi: closed range for numbers (open when ``lo_open``/``hi_open``).
        choices: allowed strings.
    """

    kind: str
    lo: float = -INF
    hi: float = INF
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()

    def describe(self) -> str:
        if self.choices:
            return ("a list of any of " if self.kind == "strs" else "one of ") + ", ".join(f'"{c}"' for c in self.choices)
        if self.kind in ("int", "float", "floats"):
            noun = {"int": "an integer", "float": "a finite number", "floats": "a list of finite numbers"}[
                self.kind
            ]
            parts = []
            if self.lo > -INF:
                parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
            if self.hi < INF:
                parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
            return noun + (" " + " and ".join(parts) if parts else "")
        return {"str": "a string", "bool": "true or false", "table": "a table"}[self.kind]

    def check(self, key: str, value: Any) -> Any:
        """Return the value (ints widened to float where a float is wanted) or raise SceneError."""
        bad = SceneError(f"scene key {key} = {value!r}: expected {self.describe()}")
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise bad
            return value
        if self.kind == "str":
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise bad
            return value
        if self.kind == "table":
            if not isinstance(value, dict):
                raise bad
            return value
        if self.kind == "strs":
            if not isinstance(value, list) or any(v not in self.choices for v in value):
                raise bad
            return value
        if self.kind == "floats":
            if not isinstance(value, list):
                raise bad
            return [self._number(key, v, bad, float) for v in value]
        return self._number(key, value, bad, int if self.kind == "int" else float)

    def _number(self, key: str, value: Any, bad: SceneError, cast: type) -> Any:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise bad
        if cast is int and not isinstance(value, int):
            raise bad
        value = cast(value)
        if not math.isfinite(value):
            raise bad
        below = value <= self.lo if self.lo_open else value < self.lo
        above = value >= self.hi if self.hi_open else value > self.hi
        if below or above:
            raise bad
        return value


def _pos(hi: float = INF, *, lo: float = 0.0, lo_open: bool = True) -> Rule:
    return Rule("float", lo=lo, hi=hi, lo_open=lo_open)


_MODULUS = _pos(1e13)
_VOLUMETRIC = _pos(1e15, lo_open=False)  # 1/d may be 0 (incompressible limit handled by "mixed")

#: Rules for every fixed key, by dotted name.
RULES: dict[str, Rule] = {
    "geometry.cones": Rule("int", lo=0, hi=64),
    "geometry.cone_kind": Rule("str", choices=("hollow", "full")),
    "geometry.cone_height_mm": _pos(100.0),
    "geometry.cone_base_diameter_mm": _pos(100.0),
    "geometry.cone_top_diameter_mm": _pos(100.0),
    "geometry.cone_wall_mm": _pos(10.0),
    "geometry.cone_spacing_mm": _pos(1000.0),
    "geometry.cone_orientation": Rule("str", choices=("apex_to_pull", "base_to_pull")),
    "geometry.cone_fillet_mm": _pos(10.0, lo_open=False),
    "geometry.thread_radius_mm": _pos(10.0),
    "geometry.thread_free_length_mm": _pos(1000.0),
    "geometry.hypodermis_mm": _pos(1000.0),
    "geometry.dermis_mm": _pos(1000.0),
    "geometry.epidermis_mm": _pos(1000.0),
    "geometry.margin_pull_mm": _pos(1000.0),
    "geometry.margin_far_mm": _pos(1000.0),
    "mesh.refinement": Rule("int", lo=0, hi=6),
    "mesh.degree": Rule("int", lo=1, hi=2),
    "mesh.size_suture_mm": _pos(10.0),
    "mesh.size_rim_mm": _pos(10.0),
    "mesh.size_far_mm": _pos(100.0),
    "mesh.grading_mm": _pos(1000.0),
    "loading.force_n": _pos(1000.0),
    "loading.report_forces_n": Rule("floats", lo=0.0, hi=1000.0, lo_open=True),
    "loading.ramp_s": _pos(1e6),
    "loading.hold_s": _pos(1e6, lo_open=False),
    "solver.initial_step": _pos(1.0),
    "solver.min_step": _pos(1.0),
    "solver.max_step": _pos(1.0),
    "solver.grow": Rule("float", lo=1.0, hi=10.0),
    "solver.easy_iterations": Rule("int", lo=1, hi=100),
    "solver.max_iterations": Rule("int", lo=1, hi=1000),
    "solver.rtol": _pos(1.0),
    "solver.atol": _pos(1.0),
    "solver.linear_solver": Rule("str", choices=("mumps", "superlu_dist", "petsc")),
    "solver.petsc_options": Rule("table"),
    "solver.gent_limit_fraction": Rule("float", lo=0.0, hi=1.0, lo_open=True),
    "output.fields": Rule("bool"),
    "output.rim_exclusion_mm": _pos(100.0, lo_open=False),
    "output.quantities": Rule("strs", choices=("usum", "seqv", "eptoeqv")),
    "effects.inertia": Rule("bool"),
    "effects.suture": Rule("str", choices=("elastic", "rigid")),
    "effects.incompressibility": Rule("str", choices=("displacement", "mixed")),
    "effects.gravity": Rule("bool"),
    **{f"effects.density_{r}_kg_m3": _pos(1e5) for r in ("hypodermis", "dermis", "epidermis", "suture")},
    "effects.rayleigh_mass_per_s": _pos(1e9, lo_open=False),
    "effects.rayleigh_stiffness_s": _pos(1.0, lo_open=False),
    "effects.time_scheme": Rule("str", choices=("newmark", "generalized_alpha")),
    "effects.spectral_radius": Rule("float", lo=0.0, hi=1.0),
    "effects.time_step_s": _pos(1e6),
    "effects.gravity_m_s2": _pos(1e3, lo_open=False),
    "effects.gravity_direction": Rule("str", choices=("-z", "+z")),
}

REGIONS = ("hypodermis", "dermis", "epidermis", "suture")
TISSUE_MODELS = ("yeoh", "gent")

#: Parameters of each material model (a Yeoh model takes c10..c60 and inv_d1..inv_d6).
MODEL_PARAMETERS: dict[str, dict[str, Rule]] = {
    "yeoh": {
        **{f"c{i}0": Rule("float", lo=-1e12, hi=1e12) for i in range(1, 7)},
        **{f"inv_d{k}": _VOLUMETRIC for k in range(1, 7)},
    },
    "gent": {"mu": _MODULUS, "jm": _pos(1e6), "inv_d": _VOLUMETRIC},
    "svk": {"young": _MODULUS, "poisson": Rule("float", lo=-1.0, hi=0.5, lo_open=True, hi_open=True)},
}


def defaults() -> dict[str, Any]:
    """The default scene (a fresh copy)."""
    text = resources.files("suture_fem").joinpath("scenes/defaults.toml").read_text()
    return tomllib.loads(text)


def builtin_names() -> list[str]:
    """Names of the scenes shipped inside the package."""
    folder = resources.files("suture_fem").joinpath("scenes")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml") and p.name != "defaults.toml")


def read_scene_source(source: str | Path) -> tuple[dict[str, Any], str]:
    """Read a scene file or a built-in scene by name; return (raw mapping, description)."""
    path = Path(source)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise SceneError(f"scene file {str(path)!r} does not exist")
        text, where = path.read_text(), str(path)
    elif str(source) in builtin_names():
        text = resources.files("suture_fem").joinpath(f"scenes/{source}.toml").read_text()
        where = f"built-in scene {source!r}"
    else:
        raise SceneError(
            f"scene {str(source)!r} is neither a TOML file nor a built-in scene ({', '.join(builtin_names())})"
        )
    try:
        return tomllib.loads(text), where
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{where}: not valid TOML: {exc}") from None


def parse_override(text: str) -> tuple[str, Any]:
    """Parse ``KEY=VALUE``; VALUE is read as a TOML value, else taken as a bare string."""
    if "=" not in text:
        raise SceneError(f"--set {text!r}: expected KEY=VALUE, for example geometry.cones=2")
    key, raw = (s.strip() for s in text.split("=", 1))
    if not key:
        raise SceneError(f"--set {text!r}: empty key")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def _flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and not (name in RULES and RULES[name].kind == "table"):
            flat.update(_flatten(value, name + "."))
        else:
            flat[name] = value
    return flat


def _set(tree: dict[str, Any], dotted: str, value: Any) -> None:
    *path, leaf = dotted.split(".")
    node = tree
    for part in path:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise SceneError(f"scene key {dotted}: {part} is not a table")
    node[leaf] = value


def _unknown(key: str, known: list[str]) -> SceneError:
    close = difflib.get_close_matches(key, known, n=1)
    hint = f" (did you mean {close[0]}?)" if close else ""
    return SceneError(f"unknown scene key {key}{hint}")


def _material_rule(key: str, scene: dict[str, Any]) -> Rule | None:
    parts = key.split(".")
    if len(parts) != 3 or parts[0] != "materials":
        return None
    region, name = parts[1], parts[2]
    if region not in REGIONS:
        raise SceneError(f"scene key {key}: unknown region {region!r} (one of {', '.join(REGIONS)})")
    if name == "model":
        return Rule("str", choices=("svk",) if region == "suture" else TISSUE_MODELS)
    model = scene["materials"][region].get("model")
    params = MODEL_PARAMETERS.get(model, {})
    if name not in params:
        allowed = ", ".join(["model", *params]) or "model"
        raise SceneError(f"scene key {key}: not a parameter of the {model!r} model (allowed: {allowed})")
    return params[name]


def merge(base: dict[str, Any], overlay: dict[str, Any], where: str) -> dict[str, Any]:
    """Return base with overlay's keys set on it (keys checked to exist, values not yet)."""
    known = list(_flatten(base))
    merged = copy.deepcopy(base)
    for key, value in _flatten(overlay).items():
        if key.startswith("materials."):
            region = key.split(".")[1] if key.count(".") >= 2 else None
            if region not in REGIONS:
                raise SceneError(f"{where}: scene key {key}: unknown region (one of {', '.join(REGIONS)})")
            # A change of model replaces the region's parameter set.
            if key.endswith(".model") and value != merged["materials"][region].get("model"):
                merged["materials"][region] = {}
        elif key not in known and not key.startswith("solver.petsc_options."):
            raise _unknown(key, known)
        _set(merged, key, value)
    return merged


def validate(scene: dict[str, Any]) -> dict[str, Any]:
    """Check every key's type and range, and the cross-key rules; return the normalised scene."""
    out = copy.deepcopy(scene)
    for key, value in _flatten(scene).items():
        rule = RULES.get(key) or _material_rule(key, scene)
        if rule is None:
            raise _unknown(key, list(RULES))
        _set(out, key, rule.check(key, value))
    for region in REGIONS:
        _check_material(region, out["materials"][region])
    loading, solver = out["loading"], out["solver"]
    above = [f for f in loading["report_forces_n"] if f > loading["force_n"]]
    if above:  # e.g. the paper scene (reports at 1, 2, 3 N) run with --set loading.force_n=1.5
        log.info("report forces above loading.force_n = %g N are not on the ramp and are skipped: %s",
                 loading["force_n"], ", ".join(f"{f:g} N" for f in above))
    loading["report_forces_n"] = sorted(set(f for f in loading["report_forces_n"] if f <= loading["force_n"]))
    if not solver["min_step"] <= solver["initial_step"] <= solver["max_step"]:
        raise SceneError(
            "scene keys solver.min_step <= solver.initial_step <= solver.max_step must hold, got "
            f"{solver['min_step']:g}, {solver['initial_step']:g}, {solver['max_step']:g}"
        )
    if solver["easy_iterations"] > solver["max_iterations"]:
        raise SceneError("scene key solver.easy_iterations must be <= solver.max_iterations")
    from suture_fem.geometry import Geometry  # the geometric cross-checks, still before meshing

    Geometry.from_scene(out)
    from suture_fem.effects import check_scene  # the effects' cross-checks

    check_scene(out)
    return out


def _check_material(region: str, params: dict[str, Any]) -> None:
    model = params.get("model")
    if model == "yeoh":
        if not any(k.startswith("c") for k in params):
            raise SceneError(f"scene key materials.{region}: a Yeoh model needs at least c10")
        if params.get("c10", 0.0) <= 0.0:
            raise SceneError(f"scene key materials.{region}.c10 must be > 0 (initial shear modulus 2*c10)")
    required = {"gent": ("mu", "jm", "inv_d"), "svk": ("young", "poisson")}.get(model, ())
    for name in required:
        if name not in params:
            raise SceneError(f"scene key materials.{region}.{name} is required by the {model!r} model")


def load_scene(source: str | Path | None = "paper", overrides: list[str] | None = None) -> dict[str, Any]:
    """Defaults, then the scene file or built-in scene, then ``KEY=VALUE`` overrides; validated."""
    scene = defaults()
    if source is not None:
        raw, where = read_scene_source(source)
        scene = merge(scene, raw, where)
    for text in overrides or []:
        key, value = parse_override(text)
        scene = merge(scene, _unflatten(key, value), f"--set {text}")
    return validate(scene)


def _unflatten(key: str, value: Any) -> dict[str, Any]:
    tree: dict[str, Any] = {}
    _set(tree, key, value)
    return tree


def get(scene: dict[str, Any], dotted: str) -> Any:
    """Value of a dotted key."""
    node: Any = scene
    for part in dotted.split("."):
        node = node[part]
    return node
