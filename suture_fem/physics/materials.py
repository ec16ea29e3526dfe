"""Hyperelastic materials, each a frozen dataclass with its strain energy written once in UFL.

A material law is one class that provides what :class:`MaterialLaw` (a typing Protocol) names: its
scene declaration (``declaration``: its name and parameters, from :data:`suture_fem.scene.laws.LAWS`),
how it is built from its parameters (``of``, ``constants``), its energy, its limits (the quantities
that must stay > 0, watched by the domain guard) and how much of a limit a state uses; a tissue law
(:class:`TissueLaw`) also splits its energy into an isochoric and a volumetric part (the mixed form).
:data:`LAW_CLASSES` finds the class of a scene's ``model``; :func:`register` adds a law from outside
the package in one place (its class, which carries its declaration).

Energies take the 3x3 deformation gradient F (any kinematics); stresses come from ``ufl.diff``,
never by hand. The tissue forms are ANSYS's (paper Table 3, MODEL.md): the coefficient 1/d_k
multiplies (J - 1)^(2k), so the initial bulk modulus is K0 = 2/d_1.

A material's parameters are plain floats (:func:`from_params`: the verification studies, hand
formulas) or dolfinx Constants (:func:`with_constants`: the scene's forms, so a new parameter value
sets a Constant and compiles no new form). A tissue's ``scale`` (``materials.tissue_scale``, default
1) multiplies every one of its constants except Gent's dimensionless jm: every Yeoh energy and the
Gent energy are linear in those constants, so the whole energy is multiplied by it, and the tissue's
stress at a given strain scales by it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any, ClassVar, Protocol, runtime_checkable

import dolfinx.fem
import ufl
from petsc4py import PETSc

from suture_fem.geometry.regions import WHOLE_TISSUE
from suture_fem.scene import laws
from suture_fem.scene.laws import LAWS, LawDeclaration
from suture_fem.scene.model import MaterialSpec
from suture_fem.support.errors import SceneError


class Limit(Enum):
    """A quantity that must stay > 0 for a material's energy to be defined: the keys of ``limits()``."""

    #: J = det F (every material: an inverted element has no energy)
    J = "J"
    #: Jm - (I1bar - 3), Gent's distance to its locking limit
    GENT_MARGIN = "Gent limit Jm - (I1bar - 3)"
    #: not a material's: how deep a tissue node may lie inside a cone, less how deep it lies (the contact's
    #: search is only sound short of the cone's mid-wall; :meth:`ConeContact.deepest`)
    CONE_DEPTH = "depth inside a cone"

    @property
    def label(self) -> str:
        """The quantity as written in logs and diagnoses."""
        return self.value


@runtime_checkable
class MaterialLaw(Protocol):
    """What a material law provides; a scene names it by ``declaration.name``.

    ``of(values, scale)`` builds it from its parameters by name (floats or dolfinx Constants; ``scale``:
    ``materials.tissue_scale`` for a tissue, 1 otherwise); ``constants(params)`` is the parameters it
    keeps as Constants in the forms, with their values (what ``model.set`` can change later).
    """

    declaration: ClassVar[LawDeclaration]

    @classmethod
    def of(cls, values: Mapping[str, Any], scale: Any = 1.0) -> MaterialLaw:
        """The law with these parameter values (checked: SceneError for values it cannot take)."""

    @classmethod
    def constants(cls, params: Mapping[str, Any]) -> dict[str, float]:
        """The parameters the forms keep as Constants, by name, with their values as floats."""

    def energy(self, F: Any) -> Any:
        """The strain energy density W(F) (UFL) of the 3x3 deformation gradient."""

    def limits(self, F: Any) -> dict[Limit, Any]:
        """UFL expressions that must stay > 0 for the energy to be defined, by quantity."""

    def usage(self, limit: Limit, margin: float) -> float | None:
        """The fraction of a physical limit used where its margin is ``margin`` (None: no such fraction)."""

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus (Pa), at the current values."""

    @property
    def bulk_modulus(self) -> float:
        """Initial bulk modulus (Pa), at the current values."""


@runtime_checkable
class TissueLaw(MaterialLaw, Protocol):
    """A law of the tissue layers: the energy split for the mixed (u, p) form, scaled by ``tissue_scale``."""

    def isochoric(self, F: Any) -> Any:
        """The isochoric part of W (a function of I1bar)."""

    def volumetric(self, J: Any) -> Any:
        """The volumetric part of W (a function of J)."""

    def bulk_modulus_form(self) -> Any:
        """The initial bulk modulus as it enters a form (UFL of the Constants, or a float)."""


class _Law:
    """What the built-in laws share: built from their declared parameters, no limit fraction but their own."""

    declaration: ClassVar[LawDeclaration]

    @classmethod
    def constants(cls, params: Mapping[str, Any]) -> dict[str, float]:
        """Every declared parameter the table gives, as a float."""
        return {name: float(params[name]) for name in cls.declaration.parameters if name in params}

    def usage(self, limit: Limit, margin: float) -> float | None:
        """None: no physical limit of this law has a fraction used."""
        return None


def number(value: Any) -> float:
    """A parameter's current value as a float: a number, or the value of a dolfinx Constant."""
    return float(getattr(value, "value", value))


def _scaled(scale: Any, expr: Any) -> Any:
    """The product scale * expr; the expression untouched at a plain scale of 1 (float forms as they were)."""
    return expr if isinstance(scale, (int, float)) and scale == 1.0 else scale * expr


def invariants(F: Any) -> tuple[Any, Any]:
    """J = det F and the isochoric first invariant I1bar = J^(-2/3) tr(F^T F)."""
    J = ufl.det(F)
    return J, J ** (-2.0 / 3.0) * ufl.tr(F.T * F)


@dataclass(frozen=True)
class Yeoh(_Law):
    """Compressible Yeoh solid (ANSYS form).

    W = sum_i c_i0 (I1bar - 3)^i + sum_k (1/d_k) (J - 1)^(2k)

    Attributes:
        c: (c10, c20, ...) in Pa (floats or Constants).
        inv_d: (1/d1, 1/d2, ...) in Pa.
        scale: multiplies every coefficient (``materials.tissue_scale``; a float or a Constant).
    """

    c: tuple[Any, ...]
    inv_d: tuple[Any, ...]
    scale: Any = 1.0
    declaration: ClassVar[LawDeclaration] = LAWS["yeoh"]

    @classmethod
    def of(cls, values: Mapping[str, Any], scale: Any = 1.0) -> Yeoh:
        """From c10..c60 and inv_d1..inv_d6 (missing ones are zero; trailing zeros dropped)."""
        return cls(c=_series(values, "c{}0"), inv_d=_series(values, "inv_d{}"), scale=scale)

    @classmethod
    def constants(cls, params: Mapping[str, Any]) -> dict[str, float]:
        """Each series' coefficients up to its last nonzero one (a zero inside a series too)."""
        law = cls.of(params)
        return {**{f"c{i + 1}0": v for i, v in enumerate(law.c)},
                **{f"inv_d{k + 1}": v for k, v in enumerate(law.inv_d)}}

    def __post_init__(self) -> None:
        if not self.c or number(self.c[0]) <= 0:
            raise SceneError(f"Yeoh c10 must be > 0, got {[number(c) for c in self.c[:1]]}")
        if any(number(v) < 0 for v in self.inv_d):
            raise SceneError(f"Yeoh inv_d_k must be >= 0, got {[number(v) for v in self.inv_d]}")
        if number(self.scale) <= 0:
            raise SceneError(f"tissue scale must be > 0, got {number(self.scale)}")

    def isochoric(self, F: Any) -> Any:
        """Scaled: scale * sum_i c_i0 (I1bar - 3)^i."""
        _, i1 = invariants(F)
        return _scaled(self.scale, sum(ci * (i1 - 3) ** (i + 1) for i, ci in enumerate(self.c) if number(ci) != 0.0))

    def volumetric(self, J: Any) -> Any:
        """Scaled: scale * sum_k (1/d_k) (J - 1)^(2k)."""
        terms = [dk * (J - 1) ** (2 * (k + 1)) for k, dk in enumerate(self.inv_d) if number(dk) != 0.0]
        return _scaled(self.scale, sum(terms)) if terms else 0

    def energy(self, F: Any) -> Any:
        """W(F): the isochoric plus the volumetric part."""
        return self.isochoric(F) + self.volumetric(ufl.det(F))

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus 2 scale c10 (Pa), at the current values."""
        return 2.0 * number(self.scale) * number(self.c[0])

    @property
    def bulk_modulus(self) -> float:
        """Initial bulk modulus K0 = 2 scale / d1 (Pa), at the current values."""
        return 2.0 * number(self.scale) * (number(self.inv_d[0]) if self.inv_d else 0.0)

    def bulk_modulus_form(self) -> Any:
        """K0 as it enters a form: 2 scale / d1 (a UFL expression of the Constants, or a float)."""
        return _scaled(self.scale, 2.0 * self.inv_d[0]) if self.inv_d else 0.0

    def limits(self, F: Any) -> dict[Limit, Any]:
        """UFL expressions that must stay > 0 for the energy to be defined, by quantity."""
        return {Limit.J: ufl.det(F)}


@dataclass(frozen=True)
class Gent(_Law):
    """Compressible Gent solid (ANSYS form).

    W = -(mu Jm / 2) ln(1 - (I1bar - 3) / Jm) + (1/d) ((J^2 - 1) / 2 - ln J)

    Finite only while I1bar - 3 < Jm (the locking limit). ``scale`` multiplies mu and 1/d (not Jm).
    """

    mu: Any
    jm: Any
    inv_d: Any
    scale: Any = 1.0
    declaration: ClassVar[LawDeclaration] = LAWS["gent"]

    @classmethod
    def of(cls, values: Mapping[str, Any], scale: Any = 1.0) -> Gent:
        """From mu, jm and inv_d."""
        return cls(mu=values["mu"], jm=values["jm"], inv_d=values["inv_d"], scale=scale)

    def usage(self, limit: Limit, margin: float) -> float | None:
        """(I1bar - 3) / Jm for the locking limit's margin Jm - (I1bar - 3); None for J."""
        return 1.0 - margin / number(self.jm) if limit is Limit.GENT_MARGIN else None

    def __post_init__(self) -> None:
        mu, jm, inv_d = number(self.mu), number(self.jm), number(self.inv_d)
        if mu <= 0 or jm <= 0 or inv_d < 0 or number(self.scale) <= 0:
            raise SceneError(f"Gent needs mu > 0, jm > 0, inv_d >= 0, scale > 0; got {mu}, {jm}, {inv_d}, "
                             f"{number(self.scale)}")

    def isochoric(self, F: Any) -> Any:
        """-(scale mu Jm / 2) ln(1 - (I1bar - 3) / Jm)."""
        _, i1 = invariants(F)
        return _scaled(self.scale, -0.5 * self.mu * self.jm * ufl.ln(1 - (i1 - 3) / self.jm))

    def volumetric(self, J: Any) -> Any:
        """(scale / d) ((J^2 - 1) / 2 - ln J)."""
        return _scaled(self.scale, self.inv_d * ((J**2 - 1) / 2 - ufl.ln(J)))

    def energy(self, F: Any) -> Any:
        """W(F): the isochoric plus the volumetric part."""
        return self.isochoric(F) + self.volumetric(ufl.det(F))

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus scale mu (Pa), at the current values."""
        return number(self.scale) * number(self.mu)

    @property
    def bulk_modulus(self) -> float:
        """Initial bulk modulus K0 = 2 scale / d (Pa), at the current values."""
        return 2.0 * number(self.scale) * number(self.inv_d)

    def bulk_modulus_form(self) -> Any:
        """K0 as it enters a form: 2 scale / d (a UFL expression of the Constants, or a float)."""
        return _scaled(self.scale, 2.0 * self.inv_d)

    def limits(self, F: Any) -> dict[Limit, Any]:
        """UFL expressions that must stay > 0 for the energy to be defined: J and Jm - (I1bar - 3)."""
        J, i1 = invariants(F)
        return {Limit.J: J, Limit.GENT_MARGIN: self.jm - (i1 - 3)}


@dataclass(frozen=True)
class StVenantKirchhoff(_Law):
    """Linear isotropic elasticity in its finite-rotation form.

    W = lambda/2 (tr E)^2 + mu E:E,  E = (F^T F - I) / 2
    """

    young: Any
    poisson: Any
    declaration: ClassVar[LawDeclaration] = LAWS["svk"]

    @classmethod
    def of(cls, values: Mapping[str, Any], scale: Any = 1.0) -> StVenantKirchhoff:
        """From young and poisson (the suture: no scale)."""
        return cls(young=values["young"], poisson=values["poisson"])

    def __post_init__(self) -> None:
        young, poisson = number(self.young), number(self.poisson)
        if young <= 0 or not -1.0 < poisson < 0.5:
            raise SceneError(f"suture needs young > 0 and -1 < poisson < 0.5; got {young}, {poisson}")

    @property
    def lame(self) -> tuple[float, float]:
        """(lambda, mu) from Young's modulus and Poisson's ratio (Pa)."""
        E, nu = self.young, self.poisson
        return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))

    def energy(self, F: Any) -> Any:
        """lambda/2 (tr E)^2 + mu E:E with the Green-Lagrange strain E."""
        lam, mu = self.lame
        E = 0.5 * (F.T * F - ufl.Identity(3))
        return 0.5 * lam * ufl.tr(E) ** 2 + mu * ufl.inner(E, E)

    @property
    def shear_modulus(self) -> float:
        """Shear modulus mu (Pa), at the current values."""
        return number(self.young) / (2 * (1 + number(self.poisson)))

    @property
    def bulk_modulus(self) -> float:
        """Bulk modulus E / (3 (1 - 2 nu)) (Pa), at the current values."""
        return number(self.young) / (3 * (1 - 2 * number(self.poisson)))

    def limits(self, F: Any) -> dict[Limit, Any]:
        """UFL expressions that must stay > 0 for the energy to be defined: J."""
        return {Limit.J: ufl.det(F)}


Material = MaterialLaw

#: The class of each law a scene may name, by name.
LAW_CLASSES: dict[str, type[MaterialLaw]] = {cls.declaration.name: cls for cls in (Yeoh, Gent, StVenantKirchhoff)}


def register(cls: type[MaterialLaw]) -> type[MaterialLaw]:
    """Add a material law (a class with what :class:`MaterialLaw` names, its ``declaration`` included).

    Its name and parameters become valid in a scene's ``[materials.<region>]`` table and the scene's
    forms use its energy. Usable as a class decorator; :func:`unregister` removes it again.
    """
    missing = [name for name in ("declaration", "of", "constants", "energy", "limits", "usage", "shear_modulus",
                                 "bulk_modulus") if not hasattr(cls, name)]
    if not missing and cls.declaration.regions == WHOLE_TISSUE:
        missing += [name for name in ("isochoric", "volumetric", "bulk_modulus_form") if not hasattr(cls, name)]
    if missing:
        raise TypeError(f"material law {cls.__name__} lacks {', '.join(missing)}")
    laws.declare(cls.declaration)
    LAW_CLASSES[cls.declaration.name] = cls
    return cls


def unregister(name: str) -> None:
    """Remove a registered law by name (the built-in ones stay)."""
    if name not in ("yeoh", "gent", "svk"):
        LAW_CLASSES.pop(name, None)
        laws.withdraw(name)


def law_class(model: str) -> type[MaterialLaw]:
    """The class of a law by its scene name (SceneError for an unknown one)."""
    if model not in LAW_CLASSES:
        raise SceneError(f"unknown material model {model!r}")
    return LAW_CLASSES[model]


def from_params(spec: MaterialSpec) -> MaterialLaw:
    """A material from a validated ``materials.<region>`` table (parameters as floats)."""
    return law_class(spec.model).of({k: float(v) for k, v in spec.params.as_dict().items()})


def with_constants(spec: MaterialSpec, mesh: Any, scale: Any = 1.0) -> tuple[MaterialLaw, dict[str, Any]]:
    """A region's material whose parameters are dolfinx Constants, and those Constants by parameter name.

    The names are the scene's (``c10``, ``inv_d1``, ``mu``, ``jm``, ``young``, ...): the law's
    ``constants`` (a Yeoh series has a Constant for each coefficient up to its last nonzero one).
    ``scale`` (a Constant, tissues only) multiplies the tissue's constants (:class:`Yeoh`, :class:`Gent`).
    """
    cls = law_class(spec.model)
    cls.of(spec.params.as_dict())  # the law's own checks, on the floats
    consts = {name: dolfinx.fem.Constant(mesh, PETSc.ScalarType(value))
              for name, value in cls.constants(spec.params.as_dict()).items()}
    return cls.of(consts, scale), consts


def _series(params: Mapping[str, Any], pattern: str) -> tuple[Any, ...]:
    """Coefficients 1..6 of a series (floats or Constants; missing ones are 0.0), trailing zeros dropped."""
    values = [params.get(pattern.format(i), 0.0) for i in range(1, 7)]
    values = [float(v) if isinstance(v, (int, float)) else v for v in values]
    while values and number(values[-1]) == 0.0:
        values.pop()
    return tuple(values)


def first_piola(material: Material, F: Any) -> Any:
    """P = dW/dF by automatic differentiation (F must not already be a ufl.variable)."""
    Fv = ufl.variable(F)
    return ufl.diff(material.energy(Fv), Fv)


def cauchy(material: Material, F: Any) -> Any:
    """Sigma = J^-1 P F^T."""
    Fv = ufl.variable(F)
    P = ufl.diff(material.energy(Fv), Fv)
    return P * Fv.T / ufl.det(Fv)
