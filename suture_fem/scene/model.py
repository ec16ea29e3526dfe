"""The typed scene: one frozen dataclass per section, built once from the validated mapping.

Every stage receives the section it needs (``scene.geometry`` for the geometry, ``scene.mesh`` for the
mesh sizes, ``scene.solver`` for the Newton solver, ...). :meth:`Scene.as_dict` gives back the
JSON-ready mapping that results.json records under ``scene``; :meth:`Scene.with_values` derives a new,
re-validated scene with some keys changed (the studies vary scenes that way).

A scene comes from a built-in name (:meth:`Scene.builtin`), a TOML file (:meth:`Scene.from_file`),
dotted keys on the defaults (:meth:`Scene.from_values`) or sections built in code
(:meth:`Scene.of`, e.g. ``Scene.of(geometry=GeometrySection(cones=2))``); each is validated as
``suture-fem run`` validates a scene file (SceneError: one line naming the key and its allowed range).
The checks that need the geometry (cones that fit, the mesh's size) run when the scene is solved
(:func:`suture_fem.pipeline.load_scene`, :class:`suture_fem.Model`), still before any meshing.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
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
    StrengthSection,
    default_values,
    frozen,
    plain,
)
from suture_fem.support.errors import SceneError


@dataclass(frozen=True)
class MaterialSpec:
    """One region's material: its model name and its validated parameters (Pa unless dimensionless)."""

    model: str
    params: Params

    def as_dict(self) -> dict[str, Any]:
        """The ``[materials.<region>]`` table: model and parameters."""
        return {"model": self.model, **self.params.as_dict()}


    @classmethod
    def of(cls, table: dict[str, Any]) -> MaterialSpec:
        """From a ``[materials.<region>]`` table: its ``model`` and its parameters."""
        return cls(table["model"], Params.of({k: v for k, v in table.items() if k != "model"}))


def _default_material(region: str) -> Any:
    return field(default=MaterialSpec.of(default_values()["materials"][region]))


@dataclass(frozen=True)
class MaterialsSection:
    """``[materials.*]``: one :class:`MaterialSpec` per material region, and ``tissue_scale``.

    Each region's default is ``defaults.toml``'s; its values are checked when the section is part
    of a Scene (:meth:`Scene.of`).
    """

    hypodermis: MaterialSpec = _default_material("hypodermis")
    dermis: MaterialSpec = _default_material("dermis")
    epidermis: MaterialSpec = _default_material("epidermis")
    suture: MaterialSpec = _default_material("suture")
    tissue_scale: float = default_values()["materials"]["tissue_scale"]

    def of(self, region: str) -> MaterialSpec:
        """The material of a region by name (``hypodermis``, ``dermis``, ``epidermis``, ``suture``)."""
        return getattr(self, region)


def _section(cls: type, data: dict[str, Any]) -> Any:
    return cls(**{f.name: frozen(data[f.name]) for f in fields(cls)})


@dataclass(frozen=True)
class Scene:
    """A validated scene (module docstring: built-in, file, dotted keys or sections in code)."""

    geometry: GeometrySection
    mesh: MeshSection
    materials: MaterialsSection
    loading: LoadingSection
    solver: SolverSection
    output: OutputSection
    effects: EffectsSection
    strength: StrengthSection

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Scene:
        """From a mapping that :func:`suture_fem.scene.load.validate` has already checked."""
        materials = MaterialsSection(**{r: MaterialSpec.of(data["materials"][r]) for r in REGIONS},
                                     tissue_scale=float(data["materials"].get("tissue_scale", 1.0)))
        sections = {name: _section(kind, data[name]) for name, kind in SECTIONS.items()}
        return cls(materials=materials, **sections)

    def as_dict(self) -> dict[str, Any]:
        """The JSON-ready nested mapping (results.json ``scene``; the input of ``with_values``)."""
        out: dict[str, Any] = {}
        for name in ("geometry", "mesh", "materials", "loading", "solver", "output", "effects", "strength"):
            section = getattr(self, name)
            if name == "materials":
                out[name] = {"tissue_scale": section.tissue_scale, **{r: section.of(r).as_dict() for r in REGIONS}}
            else:
                out[name] = {f.name: plain(getattr(section, f.name)) for f in fields(section)}
        return out

    def get(self, dotted: str) -> Any:
        """Value of a dotted key, e.g. ``scene.get("geometry.cones")``."""
        node: Any = self.as_dict()
        for part in dotted.split("."):
            node = node[part]
        return node

    def with_values(self, values: dict[str, Any]) -> Scene:
        """A new scene with the given dotted keys set, validated like a scene file (SceneError if not).

        ``Scene.builtin("paper").with_values({"geometry.cones": 2, "loading.force_n": 1.5})``.
        """
        from suture_fem.scene.load import merge, unflatten, validate

        data = self.as_dict()
        for dotted, value in values.items():
            data = merge(data, unflatten(dotted, plain(value)), f"scene key {dotted}")
        return Scene.from_dict(validate(data))

    @classmethod
    def builtin(cls, name: str) -> Scene:
        """A scene shipped inside the package, by name (``"paper"``; ``suture-fem scenes`` lists them)."""
        from suture_fem.scene.load import builtin_names, parse_scene

        if name not in builtin_names():
            raise SceneError(f"scene {name!r} is not a built-in scene (one of {', '.join(builtin_names())})")
        return parse_scene(name)

    @classmethod
    def from_file(cls, path: str | Path) -> Scene:
        """A scene file (TOML listing what it changes from the defaults)."""
        from suture_fem.scene.load import parse_scene

        return parse_scene(Path(path))

    @classmethod
    def from_values(cls, values: dict[str, Any] | None = None) -> Scene:
        """The defaults with some dotted keys set: ``Scene.from_values({"geometry.cones": 2})``."""
        from suture_fem.scene.load import parse_scene

        return parse_scene(None).with_values(values or {})

    @classmethod
    def of(cls, **sections: Any) -> Scene:
        """A scene from sections built in code; a section not given has every default.

        ``Scene.of(geometry=GeometrySection(cones=2), loading=LoadingSection(force_n=1.5))``: each
        section is validated key by key when built, the whole scene here (the rules across keys).
        """
        unknown = sorted(set(sections) - {"materials", *SECTIONS})
        if unknown:
            raise SceneError(f"unknown scene section {unknown[0]} (one of materials, {', '.join(SECTIONS)})")
        defaults = {name: kind() for name, kind in SECTIONS.items()}
        scene = cls(materials=sections.get("materials", MaterialsSection()),
                    **{name: sections.get(name, defaults[name]) for name in SECTIONS})
        from suture_fem.scene.load import validate

        return cls.from_dict(validate(scene.as_dict()))
