"""The building blocks of the scene schema.

A key's :class:`Rule`, the :func:`key` field, the :func:`section` decorator that reads each default from
``defaults.toml``, and :class:`Params`, an immutable table.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field, fields
from importlib import resources
from typing import Any, ClassVar

from suture_fem.support.errors import SceneError, shown

INF = math.inf


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
        """The allowed values in words, as the one-line error message says them."""
        if self.choices:
            words = ", ".join(f'"{c}"' for c in self.choices)
            return ("a list of any of " if self.kind == "strs" else "one of ") + words
        if self.kind in ("int", "float", "floats"):
            noun = {"int": "an integer", "float": "a finite number", "floats": "a list of finite numbers"}[self.kind]
            parts = []
            if self.lo > -INF:
                parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
            if self.hi < INF:
                parts.append(f"{'<' if self.hi_open else '<='} {self.hi:g}")
            return noun + (" " + " and ".join(parts) if parts else "")
        return {"str": "a string", "bool": "true or false", "table": "a table"}[self.kind]

    def check(self, key: str, value: Any) -> Any:
        """Return the value (ints widened to float where a float is wanted) or raise SceneError."""
        bad = SceneError(f"scene key {key} = {shown(value)}: expected {self.describe()}")
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


#: Shortest length (mm) of a dimension or element size: 1 micrometre, below any tissue layer, above what gmsh meshes.
MIN_LENGTH_MM = 1e-3


def _length(hi: float) -> Rule:
    return Rule("float", lo=MIN_LENGTH_MM, hi=hi)


def key(rule: Rule, unit: str = "") -> Any:
    """A scene key: a dataclass field that carries its rule and unit (its default: :func:`section`)."""
    return field(metadata={"rule": rule, "unit": unit})


def default_values() -> dict[str, Any]:
    """Every key's default, as ``defaults.toml`` writes them (a fresh nested mapping)."""
    return tomllib.loads(resources.files("suture_fem.scene").joinpath("defaults.toml").read_text())


def frozen(value: Any) -> Any:
    """A scene value as a section holds it: lists as tuples, tables as :class:`Params`."""
    if isinstance(value, list):
        return tuple(value)
    if isinstance(value, Mapping) and not isinstance(value, Params):
        return Params.of(value)
    return value


def plain(value: Any) -> Any:
    """A section's value as the scene mapping (and results.json) writes it: tuples as lists, Params as dicts."""
    if isinstance(value, Params):
        return value.as_dict()
    if isinstance(value, tuple):
        return list(value)
    return value


class _Section:
    """What every section shares: each value checked by its key's rule when the section is built."""

    NAME: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for f in fields(self):  # type: ignore[arg-type]
            value = plain(getattr(self, f.name))
            checked = f.metadata["rule"].check(f"{self.NAME}.{f.name}", value)
            object.__setattr__(self, f.name, frozen(checked))

    def as_dict(self) -> dict[str, Any]:
        """The section's table: key -> value, as a scene file writes it."""
        return {f.name: plain(getattr(self, f.name)) for f in fields(self)}  # type: ignore[arg-type]

    @classmethod
    def internal(cls, **values: Any) -> Any:
        """A section the package builds for itself, its values unchecked (verification turns tests off with 0)."""
        obj = object.__new__(cls)
        for f in fields(cls):  # type: ignore[arg-type]
            object.__setattr__(obj, f.name, frozen(values.get(f.name, f.default)))
        return obj


def section(name: str) -> Callable[[type], type]:
    """The frozen dataclass of the scene section ``name``, each field's default read from ``defaults.toml``."""
    table = default_values()[name]

    def build(cls: type) -> type:
        for f_name, value in table.items():
            cls.__dict__[f_name].default = frozen(value)
        cls.NAME = name
        return dataclass(frozen=True)(cls)

    return build


@dataclass(frozen=True)
class Params(Mapping):
    """An immutable mapping (material parameters, PETSc options) that pickles and compares by value."""

    pairs: tuple[tuple[str, Any], ...] = ()

    @classmethod
    def of(cls, mapping: Mapping[str, Any]) -> Params:
        """The same entries, in the same order."""
        return cls(tuple(mapping.items()))

    def __getitem__(self, name: str) -> Any:
        for k, v in self.pairs:
            if k == name:
                return v
        raise KeyError(name)

    def __iter__(self) -> Iterator[str]:
        return (k for k, _ in self.pairs)

    def __len__(self) -> int:
        return len(self.pairs)

    def as_dict(self) -> dict[str, Any]:
        """A plain (mutable) dict copy."""
        return dict(self.pairs)
