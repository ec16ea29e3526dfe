"""Hyperelastic materials, each a frozen dataclass with its strain energy written once in UFL.

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
from typing import Any

import dolfinx.fem
import ufl
from petsc4py import PETSc

from suture_fem.scene.model import MaterialSpec
from suture_fem.support.errors import SceneError


class Limit(Enum):
    """A quantity that must stay > 0 for a material's energy to be defined: the keys of ``limits()``."""

    #: J = det F (every material: an inverted element has no energy)
    J = "J"
    #: Jm - (I1bar - 3), Gent's distance to its locking limit
    GENT_MARGIN = "Gent limit Jm - (I1bar - 3)"

    @property
    def label(self) -> str:
        """The quantity as written in logs and diagnoses."""
        return self.value


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
class Yeoh:
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
class Gent:
    """Compressible Gent solid (ANSYS form).

    W = -(mu Jm / 2) ln(1 - (I1bar - 3) / Jm) + (1/d) ((J^2 - 1) / 2 - ln J)

    Finite only while I1bar - 3 < Jm (the locking limit). ``scale`` multiplies mu and 1/d (not Jm).
    """

    mu: Any
    jm: Any
    inv_d: Any
    scale: Any = 1.0

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
class StVenantKirchhoff:
    """Linear isotropic elasticity in its finite-rotation form.

    W = lambda/2 (tr E)^2 + mu E:E,  E = (F^T F - I) / 2
    """

    young: Any
    poisson: Any

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


Material = Yeoh | Gent | StVenantKirchhoff


def from_params(spec: MaterialSpec) -> Material:
    """A material from a validated ``materials.<region>`` table."""
    model, params = spec.model, spec.params
    if model == "yeoh":
        c = _series(params, "c{}0")
        inv_d = _series(params, "inv_d{}")
        return Yeoh(c=c, inv_d=inv_d)
    if model == "gent":
        return Gent(mu=params["mu"], jm=params["jm"], inv_d=params["inv_d"])
    if model == "svk":
        return StVenantKirchhoff(young=params["young"], poisson=params["poisson"])
    raise SceneError(f"unknown material model {model!r}")


def with_constants(spec: MaterialSpec, mesh: Any, scale: Any = 1.0) -> tuple[Material, dict[str, Any]]:
    """A region's material whose parameters are dolfinx Constants, and those Constants by parameter name.

    The names are the scene's (``c10``, ``inv_d1``, ``mu``, ``jm``, ``young``, ...); a Yeoh series has
    a Constant for each coefficient up to its last nonzero one. ``scale`` (a Constant, tissues only)
    multiplies the tissue's constants (:class:`Yeoh`, :class:`Gent`).
    """
    floats = from_params(spec)
    consts: dict[str, Any] = {}

    def const(name: str, value: float) -> Any:
        consts[name] = dolfinx.fem.Constant(mesh, PETSc.ScalarType(value))
        return consts[name]

    if isinstance(floats, Yeoh):
        c = tuple(const(f"c{i + 1}0", v) for i, v in enumerate(floats.c))
        inv_d = tuple(const(f"inv_d{k + 1}", v) for k, v in enumerate(floats.inv_d))
        return Yeoh(c=c, inv_d=inv_d, scale=scale), consts
    if isinstance(floats, Gent):
        return Gent(mu=const("mu", floats.mu), jm=const("jm", floats.jm), inv_d=const("inv_d", floats.inv_d),
                    scale=scale), consts
    return StVenantKirchhoff(young=const("young", floats.young), poisson=const("poisson", floats.poisson)), consts


def _series(params: Mapping[str, Any], pattern: str) -> tuple[float, ...]:
    """Coefficients 1..6 of a series (missing ones are zero), trailing zeros dropped."""
    values = [float(params.get(pattern.format(i), 0.0)) for i in range(1, 7)]
    while values and values[-1] == 0.0:
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
