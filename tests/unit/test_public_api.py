"""The package's public names: ``suture_fem.__all__``, each importable, none of them loading dolfinx until used."""

from __future__ import annotations

import subprocess
import sys

import suture_fem
from tests.conftest import ROOT


def test_every_public_name_is_importable_from_the_package():
    assert suture_fem.__all__ == [
        "Model", "Results", "Scene", "SceneError", "SolveStopped", "__version__",
        "field_grid", "field_panels", "field_section", "plot_field", "plot_force_displacement", "render_usum"]
    for name in suture_fem.__all__:
        assert getattr(suture_fem, name) is not None, name
    from suture_fem.model import Model
    from suture_fem.scene import Scene

    assert suture_fem.Model is Model and suture_fem.Scene is Scene


def test_importing_the_package_and_building_a_scene_load_no_dolfinx():
    code = ("import sys, suture_fem; s = suture_fem.Scene.builtin('paper').with_values({'geometry.cones': 2}); "
            "print(s.geometry.cones, 'dolfinx' in sys.modules, 'pyvista' in sys.modules)")
    out = subprocess.run([sys.executable, "-P", "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.split() == ["2", "False", "False"]


def test_the_picture_helpers_load_no_dolfinx_or_pyvista_until_called():
    code = ("import sys, suture_fem as sf; sf.plot_field, sf.field_panels, sf.render_usum; "
            "print('dolfinx' in sys.modules, 'pyvista' in sys.modules, 'matplotlib.pyplot' in sys.modules)")
    out = subprocess.run([sys.executable, "-P", "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.split() == ["False", "False", "False"]
