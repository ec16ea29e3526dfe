"""suture_fem: axisymmetric FE model of a coned suspension suture in facial tissue.

The Python API (docs/api.md)::

    from suture_fem import Model, Scene

    scene = Scene.builtin("paper").with_values({"geometry.cones": 2, "loading.force_n": 1.5})
    model = Model(scene)          # mesh, physics and outputs, built once
    results = model.solve()       # the load ramp: typed Results (results.usum_mm, results.at_forces, ...)

* :class:`Scene`: what to simulate (``Scene.builtin``, ``Scene.from_file``, ``Scene.from_values``,
  ``Scene.of``, ``scene.with_values``), validated (:class:`SceneError`: one line naming the key).
* :class:`Model`: one scene's mesh, physics and outputs; ``solve``, ``set``, ``u``, ``mesh``.
* :class:`Results`: what a solve computed; results.json is ``results.to_dict()``.
* :class:`SolveStopped`: the load ramp stopped with a diagnosis (``cause``, ``load_reached``).
* Pictures (pyvista off-screen, matplotlib): :func:`field_grid` (a solved state's half-section, e.g.
  ``sf.field_grid(model.outputs)``), :func:`field_section` (a solved state as a full section),
  :func:`field_panels` and :func:`plot_field` (any field on axes in mm), :func:`render_usum` (USUM
  contours in bands, to a PNG), :func:`plot_force_displacement` (curves, to a PNG).

The names are imported when first used, so ``import suture_fem`` (and ``suture-fem --help``) loads
no dolfinx.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from suture_fem.support import startup as _startup

_startup.install()  # PETSc, when first imported, starts without option files or PETSC_OPTIONS

__version__ = "0.1.0"

__all__ = ["Model", "Results", "Scene", "SceneError", "SolveStopped", "__version__",
           "field_grid", "field_panels", "field_section", "plot_field", "plot_force_displacement", "render_usum"]

#: Where each public name lives.
_HOMES = {
    "Model": "suture_fem.model",
    "Results": "suture_fem.outputs.results",
    "Scene": "suture_fem.scene.model",
    "SceneError": "suture_fem.support.errors",
    "SolveStopped": "suture_fem.support.errors",
    "field_grid": "suture_fem.plots",
    "field_panels": "suture_fem.plots_fields",
    "field_section": "suture_fem.plots_fields",
    "plot_field": "suture_fem.plots_fields",
    "plot_force_displacement": "suture_fem.plots",
    "render_usum": "suture_fem.plots",
}


def __getattr__(name: str) -> Any:
    """A public name, imported from its module when first asked for."""
    if name not in _HOMES:
        raise AttributeError(f"module 'suture_fem' has no attribute {name!r}")
    value = getattr(import_module(_HOMES[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The module's names and the public API."""
    return sorted({*globals(), *__all__})
