"""The typed scene: one frozen dataclass per section, built once from the validated mapping.

Every stage receives the section it needs (``scene.geometry`` for the geometry, ``scene.mesh`` for the
mesh sizes, ``scene.solver`` for the Newton solver, ...). :meth:`Scene.as_dict` gives back the
JSON-ready mapping that results.json records under ``scene``; :meth:`Scene.with_values` derives a new,
re-validated scene with some keys changed (the studies vary scenes that way).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from suture_fem.geometry.regions import REGIONS
from suture_fem.scene.schema import (
    SECTIONS,
    EffectsSection,
    GeometrySection,
    LoadingSection,
    MeshSection,
    OutputSection,
    Params,
    SolverSection,
)


@dataclass(frozen=True)
class MaterialSpec:
    """One region's material: its model name and its validated parameters (Pa unless dimensionless)."""

    model: str
    params: Params

    def as_dict(self) -> dict[str, Any]:
        """The ``[materials.<region>]`` table: model and parameters."""
        return {"model": self.model, **self.params.as_dict()}


@dataclass(frozen=True)
class MaterialsSection:
    """``[materials.*]``: one :class:`MaterialSpec` per material region, and ``tissue_scale``."""

    hypodermis: MaterialSpec
    dermis: MaterialSpec
    epidermis: MaterialSpec
    suture: MaterialSpec
    tissue_scale: float = 1.0

    def of(self, region: str) -> MaterialSpec:
        """The material of a region by name (``hypodermis``, ``dermis``, ``epidermis``, ``suture``)."""
        return getattr(self, region)


def _section(cls: type, data: dict[str, Any]) -> Any:
    values = {}
    for f in fields(cls):
        v = data[f.name]
        if isinstance(v, list):
            v = tuple(v)
        elif isinstance(v, dict):
            v = Params.of(v)
        values[f.name] = v
    return cls(**values)


def _plain(value: Any) -> Any:
    if isinstance(value, Params):
        return value.as_dict()
    if isinstance(value, tuple):
        return list(value)
    return value


@dataclass(frozen=True)
class Scene:
    """A validated scene (see :func:`suture_fem.pipeline.load_scene`)."""

    geometry: GeometrySection
    mesh: MeshSection
    materials: MaterialsSection
    loading: LoadingSection
    solver: SolverSection
    output: OutputSection
    effects: EffectsSection

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        """From a mapping that :func:`suture_fem.scene.load.validate` has already checked."""
        materials = MaterialsSection(**{
            r: MaterialSpec(data["materials"][r]["model"],
                            Params.of({k: v for k, v in data["materials"][r].items() if k != "model"}))
            for r in REGIONS
        }, tissue_scale=float(data["materials"].get("tissue_scale", 1.0)))
        sections = {name: _section(kind, data[name]) for name, kind in SECTIONS.items()}
        return cls(materials=materials, **sections)

    def as_dict(self) -> dict[str, Any]:
        """The JSON-ready nested mapping (results.json ``scene``; the input of ``with_values``)."""
        out: dict[str, Any] = {}
        for name in ("geometry", "mesh", "materials", "loading", "solver", "output", "effects"):
            section = getattr(self, name)
            if name == "materials":
                out[name] = {"tissue_scale": section.tissue_scale, **{r: section.of(r).as_dict() for r in REGIONS}}
            else:
                out[name] = {f.name: _plain(getattr(section, f.name)) for f in fields(section)}
        return out

    def get(self, dotted: str) -> Any:
        """Value of a dotted key, e.g. ``scene.get("geometry.cones")``."""
        node: Any = self.as_dict()
        for part in dotted.split("."):
            node = node[part]
        return node

    def with_values(self, values: dict[str, Any]) -> Scene:
        """A new scene with the given dotted keys set, validated like a scene file (SceneError if not)."""
        from suture_fem.scene.load import merge, unflatten, validate

        data = self.as_dict()
        for dotted, value in values.items():
            data = merge(data, unflatten(dotted, value), f"scene key {dotted}")
        return Scene.from_dict(validate(data))
