"""Material laws as extension points: the Protocol, the scene's table of laws, and a new law added in one place."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import pytest
import ufl

from suture_fem.physics import materials
from suture_fem.physics.materials import LAW_CLASSES, Limit, MaterialLaw, TissueLaw, register, unregister
from suture_fem.scene import Scene
from suture_fem.scene.laws import LAWS, VOLUMETRIC, LawDeclaration
from suture_fem.scene.rules import Rule
from suture_fem.support.errors import SceneError


@dataclass(frozen=True)
class NeoHooke:
    """A toy tissue law, everything in this one class: W = scale (mu/2 (I1bar - 3) + kappa/2 (J - 1)^2)."""

    mu: Any
    kappa: Any
    scale: Any = 1.0
    declaration: ClassVar[LawDeclaration] = LawDeclaration(
        "toy_neo_hooke", {"mu": Rule("float", lo=0.0, hi=1e9, lo_open=True), "kappa": VOLUMETRIC},
        required=("mu", "kappa"))

    @classmethod
    def of(cls, values: Mapping[str, Any], scale: Any = 1.0) -> NeoHooke:
        return cls(mu=values["mu"], kappa=values["kappa"], scale=scale)

    @classmethod
    def constants(cls, params: Mapping[str, Any]) -> dict[str, float]:
        return {"mu": float(params["mu"]), "kappa": float(params["kappa"])}

    def isochoric(self, F: Any) -> Any:
        _, i1 = materials.invariants(F)
        return self.scale * 0.5 * self.mu * (i1 - 3)

    def volumetric(self, J: Any) -> Any:
        return self.scale * 0.5 * self.kappa * (J - 1) ** 2

    def energy(self, F: Any) -> Any:
        return self.isochoric(F) + self.volumetric(ufl.det(F))

    def limits(self, F: Any) -> dict[Limit, Any]:
        return {Limit.J: ufl.det(F)}

    def usage(self, limit: Limit, margin: float) -> float | None:
        return None

    def bulk_modulus_form(self) -> Any:
        return self.scale * self.kappa

    @property
    def shear_modulus(self) -> float:
        return materials.number(self.scale) * materials.number(self.mu)

    @property
    def bulk_modulus(self) -> float:
        return materials.number(self.scale) * materials.number(self.kappa)


@pytest.fixture
def toy():
    register(NeoHooke)  # the one place: the class carries its scene declaration
    yield NeoHooke
    unregister("toy_neo_hooke")
    assert "toy_neo_hooke" not in LAWS and "toy_neo_hooke" not in LAW_CLASSES


def test_every_declared_law_has_its_class_and_each_class_provides_the_protocol():
    assert set(LAWS) == set(LAW_CLASSES) == {"yeoh", "gent", "svk"}
    for name, cls in LAW_CLASSES.items():
        assert cls.declaration is LAWS[name]
        law = materials.from_params(Scene.builtin("paper").materials.of(
            {"yeoh": "hypodermis", "gent": "epidermis", "svk": "suture"}[name]))
        assert isinstance(law, MaterialLaw)
        assert isinstance(law, TissueLaw) == (cls.declaration.regions == "tissue")


def test_a_new_law_registered_in_one_place_is_valid_in_a_scene_and_builds_its_forms(toy):
    scene = Scene.builtin("paper").with_values({"materials.epidermis.model": "toy_neo_hooke",
                                                "materials.epidermis.mu": 3000.0, "materials.epidermis.kappa": 5e4})
    assert scene.materials.epidermis.model == "toy_neo_hooke"
    with pytest.raises(SceneError, match=r"materials\.epidermis\.mu"):
        scene.with_values({"materials.epidermis.mu": -1.0})
    with pytest.raises(SceneError, match="not a parameter of the 'toy_neo_hooke' model"):
        scene.with_values({"materials.epidermis.jm": 1.0})
    with pytest.raises(SceneError, match="suture"):  # a tissue law: not for the suture
        scene.with_values({"materials.suture.model": "toy_neo_hooke"})

    import dolfinx.fem
    import dolfinx.mesh
    from mpi4py import MPI

    from suture_fem.support import compat

    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    scale = dolfinx.fem.Constant(mesh, 1.0)
    law, consts = materials.with_constants(scene.materials.epidermis, mesh, scale)
    assert isinstance(law, NeoHooke) and isinstance(law, TissueLaw) and set(consts) == {"mu", "kappa"}
    F = dolfinx.fem.Constant(mesh, np.eye(3))
    P = materials.first_piola(law, F)
    expr = compat.expression(ufl.as_vector([law.energy(F), P[0, 2]]), np.array([[1 / 3, 1 / 3]]))

    def at(gamma: float) -> np.ndarray:
        F.value[:] = np.eye(3)
        F.value[0, 2] = gamma  # simple shear: J = 1, I1bar - 3 = gamma^2
        return compat.eval_expression(expr, mesh, np.array([0], dtype=np.int32)).ravel()

    assert at(0.4) == pytest.approx([0.5 * 3000.0 * 0.16, 3000.0 * 0.4], rel=1e-12)
    consts["mu"].value, scale.value = 1000.0, 2.0  # the law's Constants change with no new form
    assert at(0.4) == pytest.approx([2.0 * 0.5 * 1000.0 * 0.16, 2.0 * 1000.0 * 0.4], rel=1e-12)


def test_a_law_without_what_the_protocol_names_is_refused():
    @dataclass(frozen=True)
    class Half:
        declaration: ClassVar[LawDeclaration] = LawDeclaration("half", {})

        def energy(self, F: Any) -> Any:
            return 0

    with pytest.raises(TypeError, match="lacks of, constants"):
        register(Half)
    assert "half" not in LAWS
