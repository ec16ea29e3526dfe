"""Hyperelastic materials, each a frozen dataclass with its strain energy written once in UFL.

Energies take the 3x3 deformation gradient F (any kinematics); stresses come from ``ufl.diff``,
never by hand. The tissue forms are ANSYS's (paper Table 3, MODEL.md): the coefficient 1/d_k
multiplies (J - 1)^(2k), so the initial bulk modulus is K0 = 2/d_1.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import Any

import ufl

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


def invariants(F: Any) -> tuple[Any, Any]:
    """J = det F and the isochoric first invariant I1bar = J^(-2/3) tr(F^T F)."""
    J = ufl.det(F)
    return J, J ** (-2.0 / 3.0) * ufl.tr(F.T * F)


@dataclass(frozen=True)
class Yeoh:
    """Compressible Yeoh solid (ANSYS form).

    W = sum_i c_i0 (I1bar - 3)^i + sum_k (1/d_k) (J - 1)^(2k)

    Attributes:
        c: (c10, c20, ...) in Pa.
        inv_d: (1/d1, 1/d2, ...) in Pa.
    """

    c: tuple[float, ...]
    inv_d: tuple[float, ...]

    def __post_init__(self) -> None:
        if not self.c or self.c[0] <= 0:
            raise SceneError(f"Yeoh c10 must be > 0, got {self.c[:1]}")
        if any(v < 0 for v in self.inv_d):
            raise SceneError(f"Yeoh inv_d_k must be >= 0, got {self.inv_d}")

    def isochoric(self, F: Any) -> Any:
        """sum_i c_i0 (I1bar - 3)^i."""
        _, i1 = invariants(F)
        return sum(ci * (i1 - 3) ** (i + 1) for i, ci in enumerate(self.c) if ci != 0.0)

    def volumetric(self, J: Any) -> Any:
        """sum_k (1/d_k) (J - 1)^(2k)."""
        return sum(dk * (J - 1) ** (2 * (k + 1)) for k, dk in enumerate(self.inv_d) if dk != 0.0)

    def energy(self, F: Any) -> Any:
        """W(F): the isochoric plus the volumetric part."""
        return self.isochoric(F) + self.volumetric(ufl.det(F))

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus 2 c10 (Pa)."""
        return 2.0 * self.c[0]

    @property
    def bulk_modulus(self) -> float:
        """Initial bulk modulus K0 = 2/d1 (Pa)."""
        return 2.0 * (self.inv_d[0] if self.inv_d else 0.0)

    def limits(self, F: Any) -> dict[Limit, Any]:
        """UFL expressions that must stay > 0 for the energy to be defined, by quantity."""
        return {Limit.J: ufl.det(F)}


@dataclass(frozen=True)
class Gent:
    """Compressible Gent solid (ANSYS form).

    W = -(mu Jm / 2) ln(1 - (I1bar - 3) / Jm) + (1/d) ((J^2 - 1) / 2 - ln J)

    Finite only while I1bar - 3 < Jm (the locking limit).
    """

    mu: float
    jm: float
    inv_d: float

    def __post_init__(self) -> None:
        if self.mu <= 0 or self.jm <= 0 or self.inv_d < 0:
            raise SceneError(f"Gent needs mu > 0, jm > 0, inv_d >= 0; got {self.mu}, {self.jm}, {self.inv_d}")

    def isochoric(self, F: Any) -> Any:
        """-(mu Jm / 2) ln(1 - (I1bar - 3) / Jm)."""
        _, i1 = invariants(F)
        return -0.5 * self.mu * self.jm * ufl.ln(1 - (i1 - 3) / self.jm)

    def volumetric(self, J: Any) -> Any:
        """(1/d) ((J^2 - 1) / 2 - ln J)."""
        return self.inv_d * ((J**2 - 1) / 2 - ufl.ln(J))

    def energy(self, F: Any) -> Any:
        """W(F): the isochoric plus the volumetric part."""
        return self.isochoric(F) + self.volumetric(ufl.det(F))

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus mu (Pa)."""
        return self.mu

    @property
    def bulk_modulus(self) -> float:
        """Initial bulk modulus K0 = 2/d (Pa)."""
        return 2.0 * self.inv_d

    def limits(self, F: Any) -> dict[Limit, Any]:
        """UFL expressions that must stay > 0 for the energy to be defined: J and Jm - (I1bar - 3)."""
        J, i1 = invariants(F)
        return {Limit.J: J, Limit.GENT_MARGIN: self.jm - (i1 - 3)}


@dataclass(frozen=True)
class StVenantKirchhoff:
    """Linear isotropic elasticity in its finite-rotation form.

    W = lambda/2 (tr E)^2 + mu E:E,  E = (F^T F - I) / 2
    """

    young: float
    poisson: float

    def __post_init__(self) -> None:
        if self.young <= 0 or not -1.0 < self.poisson < 0.5:
            raise SceneError(f"suture needs young > 0 and -1 < poisson < 0.5; got {self.young}, {self.poisson}")

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
        """Shear modulus mu (Pa)."""
        return self.lame[1]

    @property
    def bulk_modulus(self) -> float:
        """Bulk modulus E / (3 (1 - 2 nu)) (Pa)."""
        return self.young / (3 * (1 - 2 * self.poisson))

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
