"""The stop's advice names what carries the scene further, for the contact stops whose cure is known."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from suture_fem.physics.materials import Limit
from suture_fem.solve.diagnosis import advice
from suture_fem.support.errors import StopCause


def physics(degree=2, mixed=False, thread=True, friction=False, cones=False, track=False):
    effects = SimpleNamespace(cone_contact=cones, unilateral_thread=thread, frictional_thread=friction, mixed=mixed,
                              thread_track=track or thread)
    return SimpleNamespace(effects=effects, degree=degree)


def test_a_frictionless_thread_gets_the_thread_advice_not_the_tissue_advice():
    plain = advice(physics(), StopCause.INVERTED_ELEMENT)
    assert "incompressibility" not in plain and 'effects.thread_interface = "sliding"' in plain


def test_the_mixed_formulation_with_unilateral_contact_is_refused_before_meshing():
    from suture_fem import Scene
    from suture_fem.physics.effects.record import check_scene  # what Model and the CLI run before meshing
    from suture_fem.support.errors import SceneError

    mixed = {"mesh.degree": 2, "effects.incompressibility": "mixed"}
    for key, model in [(key, model) for key in ("thread", "cone") for model in ("frictionless", "coulomb")]:
        scene = Scene.builtin("paper").with_values({**mixed, f"effects.{key}_interface": model})
        with pytest.raises(SceneError, match=rf'"mixed" needs .* got effects.{key}_interface = "{model}"; use') as err:
            check_scene(scene)
        assert "\n" not in str(err.value)
    for model in ("tied", "sliding"):  # allowed: bilateral interfaces
        check_scene(Scene.builtin("paper").with_values({**mixed, "effects.thread_interface": model,
                                                        "effects.cone_interface": model}))


def test_no_contact_advice_for_a_stop_it_does_not_explain():
    assert advice(physics(mixed=True), StopCause.GENT_LIMIT) == ""
    assert "mesh.degree = 1" in advice(physics(cones=True, thread=False), StopCause.NEWTON_DIVERGENCE)


def test_unilateral_cones_at_p1_get_the_release_advice_not_the_degree_they_already_have():
    p1 = physics(degree=1, thread=False, cones=True)
    p1.effects.cone_interface = "frictionless"
    text = advice(p1, StopCause.NEWTON_DIVERGENCE)
    assert "release" in text and "mesh.degree = 1" not in text and "incompressibility" not in text
    tied = physics(degree=1, thread=False)
    assert "mesh.degree" not in advice(tied, StopCause.INVERTED_ELEMENT)
    assert "or use mesh.degree = 1" in advice(physics(degree=2, thread=False), StopCause.INVERTED_ELEMENT)


def test_nothing_tied_is_pointed_to_the_moved_end_not_to_the_release():
    free = physics(degree=1, thread=True, cones=True)
    free.effects.cone_interface = "coulomb"
    text = advice(free, StopCause.INVERTED_ELEMENT)
    assert "nothing tied" in text and 'loading.control = "displacement"' in text and "release" not in text
    moved = physics(degree=1, thread=True, cones=True)
    moved.effects.cone_interface, moved.control = "coulomb", object()  # the end already moved
    text = advice(moved, StopCause.INVERTED_ELEMENT)
    assert "nothing tied" in text and "loading.control" not in text and 'thread_interface = "tied"' in text


def test_sliding_cones_on_the_wall_guard_are_pointed_to_a_stiffer_penalty_and_only_there():
    walled = SimpleNamespace(quantity=Limit.CONE_DEPTH)
    sliding = physics(degree=1, thread=False, cones=True)
    sliding.effects.cone_interface = "sliding"
    text = advice(sliding, StopCause.NEWTON_DIVERGENCE, walled)
    assert "raise effects.contact_penalty" in text and "incompressibility" not in text
    inverted = advice(sliding, StopCause.INVERTED_ELEMENT, SimpleNamespace(quantity=Limit.J))
    assert "contact_penalty" not in inverted and "incompressibility" in inverted  # the tissue's advice, as before
    thread = physics(degree=1, thread=True, cones=True)
    thread.effects.cone_interface = "sliding"
    assert 'effects.thread_interface = "sliding"' in advice(thread, StopCause.INVERTED_ELEMENT)


def test_cones_pulled_base_first_with_nothing_tied_are_pointed_to_a_finer_mesh():
    def cones(kind: str, base_first: bool, interface: str = "frictionless", track: bool = True):
        p = physics(degree=1, thread=False, cones=interface != "tied", track=track)
        p.effects.cone_interface = interface
        cone = SimpleNamespace(base_z=5.54, apex_z=3.0) if base_first else SimpleNamespace(base_z=3.0, apex_z=5.54)
        p.tagged = SimpleNamespace(geometry=SimpleNamespace(kind=kind, cones=[cone]))
        return advice(p, StopCause.NEWTON_DIVERGENCE)

    for kind in ("hollow", "full"):  # full cones stop base first too, since the next layer is searched
        text = cones(kind, True)
        assert "pulled base first" in text and "mesh.refinement = 1" in text
        assert "mesh.refinement = 1" in cones(kind, True, "coulomb")
    for other in (cones("hollow", False), cones("full", False), cones("hollow", True, "tied"),
                  cones("hollow", True, track=False)):  # the thread tied: one cone reaches 4 mm (P1)
        assert "pulled base first" not in other


def test_held_corners_are_pointed_to_the_measured_default():
    held = physics(degree=1, thread=False, cones=True)
    held.effects.cone_interface = "frictionless"
    held.cone_contact = SimpleNamespace(held=object())  # effects.cone_corners = "held"
    text = advice(held, StopCause.INVERTED_ELEMENT)
    assert 'effects.cone_corners = "held"' in text and '"measured"' in text and "release" not in text
    held.cone_contact.held = None  # measured: the release advice as before
    assert "release" in advice(held, StopCause.INVERTED_ELEMENT)
