"""Scenes: what to simulate. ``schema`` declares every key, ``load`` reads and validates, ``model`` types."""

from suture_fem.scene.load import builtin_names, parse_override, parse_scene
from suture_fem.scene.model import MaterialSpec, Scene

__all__ = ["MaterialSpec", "Scene", "builtin_names", "parse_override", "parse_scene"]
