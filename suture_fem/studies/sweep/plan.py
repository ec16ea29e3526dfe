"""The plan: a sweep file expanded into cases (deterministic, the same on every rank).

A sweep file names a base scene and what to vary, either as a grid (every combination, the first
key varying slowest) or as an explicit list of override tables::

    base = "paper"                 # a built-in scene or a scene file (relative to the sweep file)
    out = "results/cone_study"     # optional; default results/<sweep file name>

    [set]                          # optional: overrides for every scene
    "mesh.degree" = 1

    [grid]                         # either this ...
    "geometry.cones" = [1, 2, 3, 4]
    "loading.force_n" = [1.0, 2.0]

    [[scenes]]                     # ... or this, one table per scene
    "geometry.cones" = 2

Keys are dotted scene keys, quoted or written as nested tables (``[grid.geometry]``). Each scene
is the base scene with ``--set KEY=VALUE`` overrides (the sweep's ``[set]``, the command line's
``--set``, then the scene's own), so ``status.json`` records the ``suture-fem run`` command that
reproduces it. Every scene's folder is named ``NNN-HASH``: its position in the sweep, and a hash
of the base scene's content and the scene's overrides.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from suture_fem.pipeline import load_scene
from suture_fem.scene import Scene
from suture_fem.scene.load import check_key_depth, parse_toml, read_scene_source, read_text_file
from suture_fem.support.errors import SceneError

SWEEP_KEYS = ("base", "out", "set", "grid", "scenes")


class SweepError(SceneError):
    """A bad sweep file or sweep argument (exit code 2)."""



@dataclass(frozen=True)
class Case:
    """One scene of a sweep.

    Attributes:
        index: position in the sweep (0-based).
        varied: this scene's own overrides, dotted key -> value.
        overrides: every ``KEY=VALUE`` applied to the base scene, in order.
        scene: the validated scene, or None when it does not validate (``error`` says why).
        name: the folder name, ``NNN-HASH``.
    """

    index: int
    varied: dict[str, Any]
    overrides: tuple[str, ...]
    scene: Scene | None
    error: str | None
    name: str


@dataclass
class Sweep:
    """A sweep file, expanded.

    Attributes:
        path: the sweep file.
        base: the base scene: a built-in name, or a scene file's path (made relative to the sweep file's folder).
        out: the folder of the scene folders and the summary.
        cases: every scene, in the sweep's order.
        varied_keys: the keys any case varies, in order of first appearance (the summary's columns).
    """

    path: Path
    base: str
    out: Path
    cases: list[Case]
    varied_keys: list[str] = field(default_factory=list)


def toml_value(value: Any) -> str:
    """A value written as TOML, the way ``--set KEY=VALUE`` reads it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise SweepError(f"sweep value {value!r}: expected a number, string, boolean, list or table")


def _flatten(tree: dict[str, Any], where: str, prefix: str = "") -> dict[str, Any]:
    """Nested tables to dotted keys (an empty table stays a value, e.g. petsc_options = {})."""
    if not isinstance(tree, dict):
        raise SweepError(f"{where}: expected a table of scene keys, got {tree!r}")
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        if isinstance(value, dict) and value:
            flat.update(_flatten(value, where, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def _short_hash(data: Any) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:8]


def load_sweep(path: str | Path, extra: list[str] | None = None, out: str | Path | None = None) -> Sweep:
    """Read and expand a sweep file; ``extra`` are ``KEY=VALUE`` overrides for every scene.

    Raises SweepError for a malformed sweep file; a scene that does not validate becomes a case
    with its error (it is recorded, not raised).
    """
    path = Path(path)
    raw = _read(path)
    unknown = sorted(set(raw) - set(SWEEP_KEYS))
    if unknown:
        raise SweepError(f"sweep file {path}: unknown key {unknown[0]} (allowed: {', '.join(SWEEP_KEYS)})")
    base = raw.get("base")
    if not isinstance(base, str) or not base:
        raise SweepError(f"sweep file {path}: key base: expected a built-in scene name or a scene file")
    if base.endswith(".toml") or (path.parent / base).is_file():
        base = str(path.parent / base)
    if ("grid" in raw) == ("scenes" in raw):
        raise SweepError(f"sweep file {path}: give exactly one of [grid] (every combination) or [[scenes]] (a list)")
    if "grid" in raw:
        grid = _flatten(raw["grid"], f"sweep file {path}: [grid]")
        if not grid:
            raise SweepError(f"sweep file {path}: [grid] is empty")
        for key, values in grid.items():
            try:
                check_key_depth(key, f"sweep file {path}: grid key")
            except SceneError as exc:
                raise SweepError(str(exc)) from None
            if not isinstance(values, list) or not values:
                raise SweepError(f"sweep file {path}: grid key {key}: expected a non-empty list of values")
        variations = [dict(zip(grid, combo)) for combo in itertools.product(*grid.values())]
    else:
        if not isinstance(raw["scenes"], list) or not raw["scenes"]:
            raise SweepError(f"sweep file {path}: scenes: expected a non-empty array of tables ([[scenes]])")
        variations = [_flatten(t, f"sweep file {path}: scene {i}") for i, t in enumerate(raw["scenes"])]
    common = [f"{k}={toml_value(v)}" for k, v in _flatten(raw.get("set", {}), f"sweep file {path}: [set]").items()]
    common += list(extra or [])
    out_dir = Path(out) if out is not None else _out_folder(raw, path)
    try:
        base_scene, _ = read_scene_source(base)
    except SceneError as exc:
        raise SweepError(f"sweep file {path}: key base: {exc}") from None
    cases = [_case(i, base, base_scene, common, v) for i, v in enumerate(variations)]
    varied_keys = list(dict.fromkeys(k for c in cases for k in c.varied))
    return Sweep(path=path, base=base, out=out_dir, cases=cases, varied_keys=varied_keys)


def _out_folder(raw: dict[str, Any], path: Path) -> Path:
    """The sweep file's ``out``: a relative folder inside the current folder (``--out`` may name any folder).

    A sweep file is data someone may have sent: it chooses the folder's name, never its place; an
    absolute path, ``~`` or ``..`` is refused (the person typing the command gives those with ``--out``).
    """
    value = raw.get("out") or f"results/{path.stem}"
    example = f"for example out = \"results/{path.stem}\""
    if not isinstance(value, str):
        raise SweepError(f"sweep file {path}: key out: expected a folder path as a string, {example} (got {value!r})")
    folder = Path(value)
    if folder.is_absolute() or value.startswith("~") or ".." in folder.parts:
        raise SweepError(f"sweep file {path}: key out: expected a folder inside the current folder (relative, no "
                         f"'..' or '~'), {example} (got {value!r}); give any other folder with --out")
    return folder


def _read(path: Path) -> dict[str, Any]:
    """The sweep file's TOML, read like a scene file (SweepError in one line otherwise).

    A missing, unreadable or non-UTF-8 file, invalid TOML or tables nested too deeply: one line each.
    """
    where = f"sweep file {str(path)!r}"
    try:
        return parse_toml(read_text_file(path, where), where)
    except SweepError:
        raise
    except SceneError as exc:
        raise SweepError(str(exc)) from None


def _case(index: int, base: str, base_scene: dict[str, Any], common: list[str], varied: dict[str, Any]) -> Case:
    """One scene, validated (or with its error); its folder name hashes what the user wrote.

    The hash covers the base scene's content and the overrides, not the resolved scene, so the name
    survives a new suture_fem version that adds keys with defaults.
    """
    overrides = tuple(common + [f"{k}={toml_value(v)}" for k, v in varied.items()])
    try:
        scene, error = load_scene(base, list(overrides)), None
    except SceneError as exc:
        scene, error = None, str(exc)
    digest = _short_hash({"base": base_scene, "overrides": overrides})
    return Case(index, varied, overrides, scene, error, f"{index:03d}-{digest}")


def command_of(sweep: Sweep, case: Case) -> str:
    """The ``suture-fem run`` command that solves one case on its own."""
    sets = [a for o in case.overrides for a in ("--set", o)]
    return shlex.join(["suture-fem", "run", sweep.base, *sets, "--out", str(sweep.out / case.name)])

