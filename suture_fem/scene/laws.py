"""What a scene may say about a material law: its name, its parameters and their ranges, where it may be used.

A material law is one class in :mod:`suture_fem.physics.materials` (its energy, volumetric part and
limits, written in UFL; the :class:`~suture_fem.physics.materials.MaterialLaw` Protocol). What a
scene file may write for it is checked before anything is meshed, and before dolfinx or UFL is
imported (``suture-fem run`` exits 2 on a bad value at once; ``import suture_fem`` loads no
dolfinx): so the scene layer, which may not import the physics, reads the parameters from this
table, and each law class points at its entry (``declaration = LAWS["gent"]``; a test checks the two
tables name the same laws). A law added from outside the package (a notebook, a test) brings its
declaration as a class attribute and is registered once, with
:func:`suture_fem.physics.materials.register`, which puts the declaration here and the class there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from suture_fem.geometry.regions import SUTURE_REGION, WHOLE_TISSUE
from suture_fem.scene.rules import Rule, _pos
from suture_fem.support.errors import SceneError

MODULUS = _pos(1e13)  # Pa
VOLUMETRIC = _pos(1e15, lo_open=False)  # Pa; 1/d may be 0 (incompressible limit handled by "mixed")


@dataclass(frozen=True)
class LawDeclaration:
    """A material law as a scene names it.

    Attributes:
        name: the ``model`` value of a ``[materials.<region>]`` table.
        parameters: each parameter's rule (type and range; Pa unless the rule says otherwise).
        regions: where the law may be used: :data:`WHOLE_TISSUE` (the tissue layers) or :data:`SUTURE_REGION`.
        required: the parameters a table must give (the others default to 0).
        check: a further check of the table (its parameters by name), raising SceneError; None: none.
    """

    name: str
    parameters: Mapping[str, Rule]
    regions: str = WHOLE_TISSUE
    required: tuple[str, ...] = ()
    check: Callable[[str, Mapping[str, Any]], None] | None = field(default=None, compare=False)

    def check_table(self, region: str, params: Mapping[str, Any]) -> None:
        """A region's table: every required parameter given, and the law's own check (SceneError)."""
        if self.check is not None:
            self.check(region, params)
        for name in self.required:
            if name not in params:
                raise SceneError(f"scene key materials.{region}.{name} is required by the {self.name!r} model")


def _yeoh_check(region: str, params: Mapping[str, Any]) -> None:
    if not any(k.startswith("c") for k in params):
        raise SceneError(f"scene key materials.{region}: a Yeoh model needs at least c10")
    if params.get("c10", 0.0) <= 0.0:
        raise SceneError(f"scene key materials.{region}.c10 must be > 0 (initial shear modulus 2*c10)")


#: The laws a scene may name, by name (the built-in ones; :func:`declare` adds one).
LAWS: dict[str, LawDeclaration] = {}


def declare(declaration: LawDeclaration) -> LawDeclaration:
    """Make a law's name and parameters known to the scene (an existing name is refused)."""
    if declaration.name in LAWS and LAWS[declaration.name] != declaration:
        raise ValueError(f"a material law named {declaration.name!r} is declared already")
    LAWS[declaration.name] = declaration
    return declaration


def withdraw(name: str) -> None:
    """Forget a declared law (a test's toy law)."""
    LAWS.pop(name, None)


def models_for(region: str) -> tuple[str, ...]:
    """The laws a region may use, in declaration order (``suture``: the suture's; any other: the tissue's)."""
    kind = SUTURE_REGION if region == SUTURE_REGION else WHOLE_TISSUE
    return tuple(name for name, law in LAWS.items() if law.regions == kind)


declare(LawDeclaration(  # W = sum_i c_i0 (I1bar - 3)^i + sum_k (1/d_k) (J - 1)^(2k)
    "yeoh",
    {**{f"c{i}0": Rule("float", lo=-1e12, hi=1e12) for i in range(1, 7)},
     **{f"inv_d{k}": VOLUMETRIC for k in range(1, 7)}},
    check=_yeoh_check,
))
declare(LawDeclaration(  # W = -(mu Jm / 2) ln(1 - (I1bar - 3) / Jm) + (1/d) ((J^2 - 1) / 2 - ln J)
    "gent", {"mu": MODULUS, "jm": _pos(1e6), "inv_d": VOLUMETRIC}, required=("mu", "jm", "inv_d"),
))
declare(LawDeclaration(  # Saint Venant-Kirchhoff: the suture (polypropylene)
    "svk", {"young": MODULUS, "poisson": Rule("float", lo=-1.0, hi=0.5, lo_open=True, hi_open=True)},
    regions=SUTURE_REGION, required=("young", "poisson"),
))
