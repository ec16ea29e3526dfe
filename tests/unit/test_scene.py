"""Scene validation: every bad input stops before meshing with one line naming the key and range."""

from __future__ import annotations

import pytest

from suture_fem.geometry.section import Geometry
from suture_fem.pipeline import load_scene
from suture_fem.scene import builtin_names, parse_override
from suture_fem.support.errors import SceneError


def test_paper_scene_resolves_with_documented_defaults():
    s = load_scene("paper")
    assert s.geometry.cones == 4 and s.geometry.cone_kind == "hollow"
    assert s.loading.force_n == 4.0
    assert s.materials.hypodermis.params["c20"] == 1400.0
    assert s.materials.epidermis.params["jm"] == 1.2
    assert "paper" in builtin_names()


def test_overrides_are_typed_as_toml_values():
    assert parse_override("geometry.cones=2") == ("geometry.cones", 2)
    assert parse_override("geometry.cone_kind=full") == ("geometry.cone_kind", "full")
    assert parse_override("loading.report_forces_n=[0.5, 1]") == ("loading.report_forces_n", [0.5, 1])
    s = load_scene("paper", ["geometry.cones=2", "loading.force_n=1.5", "mesh.refinement=1"])
    assert (s.geometry.cones, s.loading.force_n, s.mesh.refinement) == (2, 1.5, 1)
    # report forces above the peak are not on the ramp and are dropped, not an error
    assert s.loading.report_forces_n == (1.0,)


@pytest.mark.parametrize(
    "override, words",
    [
        ("geometry.cones=-1", ["geometry.cones", ">= 0"]),
        ("geometry.cones=2.5", ["geometry.cones", "integer"]),
        ("geometry.cone_kind=solid", ["geometry.cone_kind", '"hollow"', '"full"']),
        ("geometry.dermis_mm=-0.5", ["geometry.dermis_mm", ">= 0.001"]),
        ("geometry.cone_spacing_mm=2.0", ["overlap", "geometry.cone_spacing_mm", "geometry.cone_height_mm"]),
        ("geometry.cone_base_diameter_mm=6.5", ["hypodermis", "geometry.cone_base_diameter_mm"]),
        ("materials.epidermis.jm=0", ["materials.epidermis.jm", "> 0"]),
        ("loading.force_n=inf", ["loading.force_n", "finite"]),
        ("loading.force_n=nan", ["loading.force_n", "finite"]),
        ("loading.force_n=true", ["loading.force_n", "finite number"]),
        ("geometry.conez=3", ["unknown scene key geometry.conez", "geometry.cones"]),
        ("materials.dermis.mu=3", ["materials.dermis.mu", "yeoh"]),
        ("materials.skin.mu=3", ["unknown region"]),
        ("mesh.refinement=9", ["mesh.refinement", "<= 6"]),
        ("geometry.cone_wall_mm=0.3", ["geometry.cone_wall_mm", "full"]),
        ("geometry.cone_fillet_mm=0.5", ["geometry.cone_fillet_mm", "allowed range"]),
    ],
)
def test_bad_input_names_the_key_and_range(override, words):
    with pytest.raises(SceneError) as err:
        load_scene("paper", [override])
    message = str(err.value)
    assert "\n" not in message
    for w in words:
        assert w in message, (w, message)


def test_unknown_scene_file_or_name():
    with pytest.raises(SceneError, match="not a built-in scene .* and not a file path"):
        load_scene("no_such_scene")
    with pytest.raises(SceneError, match="does not exist"):
        load_scene("missing.toml")


def test_scene_file_with_bad_toml(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[geometry\ncones = 2\n")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(str(p))


def test_material_model_can_be_switched(tmp_path):
    p = tmp_path / "gent_dermis.toml"
    p.write_text('[materials.dermis]\nmodel = "gent"\nmu = 8000.0\njm = 2.0\ninv_d = 50e3\n')
    s = load_scene(str(p))
    assert s.materials.dermis.as_dict() == {"model": "gent", "mu": 8000.0, "jm": 2.0, "inv_d": 50e3}
    with pytest.raises(SceneError, match="materials.dermis.inv_d is required"):
        p.write_text('[materials.dermis]\nmodel = "gent"\nmu = 8000.0\njm = 2.0\n')
        load_scene(str(p))


def test_geometry_layout_follows_the_scene():
    s = load_scene("paper", ["geometry.cones=3", "geometry.margin_far_mm=2", "geometry.margin_pull_mm=4"])
    g = Geometry.from_section(s.geometry)
    sp, h = s.geometry.cone_spacing_mm, s.geometry.cone_height_mm
    assert g.length == pytest.approx(2 + 2 * sp + h + 4)
    assert [c.base_z for c in g.cones] == pytest.approx([2, 2 + sp, 2 + 2 * sp])
    assert all(c.apex_z == pytest.approx(c.base_z + h) for c in g.cones)  # apex toward the pulled end
    assert g.z_end == pytest.approx(g.length + s.geometry.thread_free_length_mm)
    assert (g.r_hypodermis, g.r_dermis, g.r_epidermis) == pytest.approx((3.0, 3.5, 3.6))
    flipped = Geometry.from_section(load_scene("paper", ["geometry.cone_orientation=base_to_pull"]).geometry)
    assert all(c.apex_z < c.base_z for c in flipped.cones)
    assert Geometry.from_section(load_scene("paper", ["geometry.cones=0"]).geometry).cones == []


def test_hollow_cone_wall_has_the_specified_normal_thickness():
    # sharp rims, so the outline is the polygon itself (the default rounds the base rims)
    g = Geometry.from_section(load_scene("paper", ["geometry.cones=1", "geometry.cone_fillet_mm=0"]).geometry)
    pts = [seg[1][0] for seg in g.cones[0].outline]
    (r_t, z_a), (r_top, _), (r_b, z_b), (r_bi, _), (r_ci, z_c), _ = pts
    # outer and inner walls are parallel lines a normal distance 0.13 mm apart
    tan_a = (r_b - r_top) / (z_a - z_b)
    assert (r_b - r_bi) / (1 + tan_a**2) ** 0.5 == pytest.approx(0.13, rel=1e-12)
    assert z_a - z_c == pytest.approx(0.13)
