"""Reading scenes: TOML files, built-in scenes and ``--set KEY=VALUE`` overrides, validated.

A scene is a nested mapping of sections (``geometry``, ``mesh``, ``materials``, ``loading``,
``solver``, ``effects``, ``output``). Every key has a default in ``defaults.toml`` and a rule in
:mod:`suture_fem.scene.schema`; a scene file lists only what it changes. :func:`parse_scene` merges a
file (or a built-in scene name) and overrides on the defaults, checks every key's type and range and
the cross-key rules of the scene alone, and returns the typed :class:`~suture_fem.scene.model.Scene`.
The checks that need the geometry or the effects run in :func:`suture_fem.pipeline.load_scene`, still
before any meshing.
"""

from __future__ import annotations

import copy
import difflib
import logging
import os
import stat
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from suture_fem.geometry.regions import REGIONS
from suture_fem.scene.balance import check_steps, check_tolerances
from suture_fem.scene.laws import LAWS, models_for
from suture_fem.scene.model import Scene
from suture_fem.scene.schema import PETSC_OPTIONS, RULES, Rule, default_values
from suture_fem.support.errors import SceneError, shown

log = logging.getLogger("suture_fem")


def defaults() -> dict[str, Any]:
    """The default scene (a fresh copy)."""
    return default_values()


def builtin_names() -> list[str]:
    """Names of the scenes shipped inside the package."""
    folder = resources.files("suture_fem.scene").joinpath("builtin")
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def looks_like_path(source: str | Path) -> bool:
    """The rule that tells a scene file from a built-in scene: a path ends in .toml or names a folder.

    ``paper`` is always the built-in scene, even when a file or folder named ``paper`` sits in the
    current folder; ``./paper``, ``dir/paper.toml`` and ``paper.toml`` are files.
    """
    text = str(source)
    return isinstance(source, Path) or text.endswith(".toml") or "/" in text or os.sep in text


def read_scene_source(source: str | Path) -> tuple[dict[str, Any], str]:
    """Read a scene file or a built-in scene by name; return (raw mapping, description)."""
    if looks_like_path(source):
        path = Path(source)
        where = f"scene file {str(path)!r}"
        text = read_text_file(path, where)
    elif str(source) in builtin_names():
        text = resources.files("suture_fem.scene").joinpath(f"builtin/{source}.toml").read_text()
        where = f"built-in scene {source!r}"
    else:
        hint = f"; to read the file {source!r} in this folder, write ./{source}" if Path(source).exists() else ""
        raise SceneError(f"scene {str(source)!r} is not a built-in scene (one of {', '.join(builtin_names())}) "
                         f"and not a file path (a path ends in .toml or contains /){hint}")
    return parse_toml(text, where), where


#: Largest data file (scene, sweep, measured curve) read, in bytes: the paper's scenes are 2-4 KB.
MAX_FILE_BYTES = 1 << 20


def read_text_file(path: Path, where: str, error: type[SceneError] = SceneError) -> str:
    """The UTF-8 text of a data file (scene, sweep, curve); ``error`` in one line when it cannot be read.

    Only a regular file of at most MAX_FILE_BYTES is read: a device (/dev/zero), a FIFO or a socket
    would never end or never come, so it is refused before a byte is read (opened without blocking).
    """
    if path.is_dir():
        raise error(f"{where} is a folder, not a file")
    if not path.exists():
        raise error(f"{where} does not exist")
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        with os.fdopen(fd, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                raise error(f"{where} is not a regular file (a device, FIFO or socket); give a file")
            data = f.read(MAX_FILE_BYTES + 1)
        if len(data) > MAX_FILE_BYTES:
            raise error(f"{where} is larger than {MAX_FILE_BYTES // 1024} KiB; a data file is a few KB")
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{where} is not UTF-8 text (byte {exc.start}); save it as UTF-8") from None
    except OSError as exc:
        raise error(f"{where} cannot be read: {exc.strerror or exc}") from None


#: Deepest nesting of tables and arrays a scene or sweep file may use (scenes need three levels).
MAX_NESTING = 16


def parse_toml(text: str, where: str) -> dict[str, Any]:
    """Parse TOML text; SceneError in one line for invalid or absurdly nested TOML."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{where}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"{where}: tables or arrays nested too deeply (at most {MAX_NESTING} levels)") from None
    if _depth(data) > MAX_NESTING:
        raise SceneError(f"{where}: tables or arrays nested too deeply (at most {MAX_NESTING} levels)")
    return data


def _depth(value: Any, level: int = 0) -> int:
    if level > MAX_NESTING:
        return level
    if isinstance(value, dict):
        return max((_depth(v, level + 1) for v in value.values()), default=level + 1)
    if isinstance(value, list):
        return max((_depth(v, level + 1) for v in value), default=level + 1)
    return level


def parse_override(text: str) -> tuple[str, Any]:
    """Parse ``KEY=VALUE``; VALUE is read as a TOML value, else taken as a bare string."""
    if "=" not in text:
        raise SceneError(f"--set {text!r}: expected KEY=VALUE, for example geometry.cones=2")
    key, raw = (s.strip() for s in text.split("=", 1))
    if not key:
        raise SceneError(f"--set {shown(text)}: empty key")
    check_key_depth(key, "--set")
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    except RecursionError:
        raise SceneError(f"--set {key}: value nested too deeply") from None
    if _depth(value) > MAX_NESTING:
        raise SceneError(f"--set {key}: value nested too deeply (at most {MAX_NESTING} levels)")
    return key, value


def check_key_depth(key: str, where: str) -> None:
    """SceneError when a dotted key has more parts than any scene key can (a scene key has at most four)."""
    if key.count(".") >= MAX_NESTING:
        raise SceneError(f"{where} {shown(key)}: {key.count('.') + 1} dotted parts; a scene key has at most "
                         f"{MAX_NESTING}, e.g. solver.petsc_options.snes_max_it")


def _flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Dotted key -> value.

    A table's entries are keys of their own (so overrides merge into it); an empty table is a value
    (``petsc_options = {}``).
    """
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict) and value:
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
        return Rule("str", choices=models_for(region))
    model = scene["materials"][region].get("model")
    params = LAWS[model].parameters if model in LAWS else {}
    if name not in params:
        allowed = ", ".join(["model", *params]) or "model"
        raise SceneError(f"scene key {key}: not a parameter of the {model!r} model (allowed: {allowed})")
    return params[name]


PETSC_PREFIX = "solver.petsc_options."


def _petsc_rule(key: str) -> Rule | None:
    if not key.startswith(PETSC_PREFIX):
        return None
    name = key[len(PETSC_PREFIX):]
    if name not in PETSC_OPTIONS:
        raise SceneError(f"scene key {key}: not an allowed solver option (allowed: {', '.join(PETSC_OPTIONS)})")
    return PETSC_OPTIONS[name]


def merge(base: dict[str, Any], overlay: dict[str, Any], where: str) -> dict[str, Any]:
    """Return base with overlay's keys set on it (keys checked to exist, values not yet)."""
    known = list(_flatten(base))
    merged = copy.deepcopy(base)
    for key, value in _flatten(overlay).items():
        if key.startswith("materials.") and key not in RULES:
            region = key.split(".")[1] if key.count(".") >= 2 else None
            if region not in REGIONS:
                raise SceneError(f"{where}: scene key {key}: unknown region (one of {', '.join(REGIONS)})")
            # A change of model replaces the region's parameter set.
            if key.endswith(".model") and value != merged["materials"][region].get("model"):
                merged["materials"][region] = {}
        elif key not in known and not key.startswith(PETSC_PREFIX):
            raise _unknown(key, known)
        if key == "solver.petsc_options" and value == {}:
            continue  # an empty table adds nothing; the options already set stay
        _set(merged, key, value)
    return merged


def validate(scene: dict[str, Any]) -> dict[str, Any]:
    """Check every key's type and range, and the cross-key rules; return the normalised scene."""
    out = copy.deepcopy(scene)
    for key, value in _flatten(scene).items():
        rule = RULES.get(key) or _material_rule(key, scene) or _petsc_rule(key)
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
    loading["report_displacements_mm"] = sorted(set(d for d in loading["report_displacements_mm"]
                                                    if d <= loading["displacement_mm"]))
    if not solver["min_step"] <= solver["initial_step"] <= solver["max_step"]:
        raise SceneError(
            "scene keys solver.min_step <= solver.initial_step <= solver.max_step must hold, got "
            f"{solver['min_step']:g}, {solver['initial_step']:g}, {solver['max_step']:g}"
        )
    if solver["easy_iterations"] > solver["max_iterations"]:
        raise SceneError("scene key solver.easy_iterations must be <= solver.max_iterations")
    check_steps(out)
    check_tolerances(out)
    return out


def _check_material(region: str, params: dict[str, Any]) -> None:
    law = LAWS.get(params.get("model"))
    if law is not None:
        law.check_table(region, params)


def parse_scene(source: str | Path | None = "paper", overrides: list[str] | None = None) -> Scene:
    """Defaults, then the scene file or built-in scene, then ``KEY=VALUE`` overrides; validated and typed."""
    scene = defaults()
    if source is not None:
        raw, where = read_scene_source(source)
        scene = merge(scene, raw, where)
    for text in overrides or []:
        key, value = parse_override(text)
        scene = merge(scene, unflatten(key, value), f"--set {text}")
    return Scene.from_dict(validate(scene))


def unflatten(key: str, value: Any) -> dict[str, Any]:
    """The nested mapping that sets one dotted key, e.g. {"mesh": {"degree": 1}}."""
    tree: dict[str, Any] = {}
    _set(tree, key, value)
    return tree
