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


def test_docs_api_lists_the_public_names_and_every_call_it_documents_exists():
    import inspect
    import re
    from dataclasses import fields

    from suture_fem.model import Model
    from suture_fem.outputs.results import Results
    from suture_fem.scene import Scene

    text = (ROOT / "docs" / "api.md").read_text()
    sections = dict(re.findall(r"^## `?(\w+)`?\n(.*?)(?=^## |\Z)", text, flags=re.S | re.M))
    head = text.split("\n## ")[0]
    listed = {n for row in re.findall(r"^\| (`.*?) \|", head, flags=re.M) for n in re.findall(r"`(\w+)`", row)}
    assert listed == set(suture_fem.__all__)

    def has(cls, name):  # a class attribute, a dataclass field or an attribute __init__ sets
        fielded = hasattr(cls, "__dataclass_fields__") and name in {f.name for f in fields(cls)}
        return hasattr(cls, name) or fielded or re.search(rf"self\.{name}\b", inspect.getsource(cls)) is not None

    documented = {
        Scene: set(re.findall(r"(?<![.\w])[Ss]cene\.(\w+)", sections["Scene"])),
        Model: set(re.findall(r"(?<![.\w])model\.(\w+)", sections["Model"])),
        Results: {name for cell in re.findall(r"^\| (`.*?) \|", sections["Results"], re.M)
                  for name in re.findall(r"`(\w+)", cell)} - {"Results"}
        | set(re.findall(r"\bResults\.(\w+)", sections["Results"])),
    }
    for cls, names in documented.items():
        assert names, cls
        missing = sorted(n for n in names if not has(cls, n))
        assert missing == [], f"docs/api.md documents {cls.__name__}.{missing}"
    pictures = set(re.findall(r"`sf\.(\w+)\(", sections["Pictures"]))
    assert pictures and pictures <= set(suture_fem.__all__)
