"""The scene schema: every key once, with its type, allowed range and unit.

Each section of a scene is a frozen dataclass; each of its fields is one scene key, declared with :func:`key` (its
:class:`Rule` and unit). Default values and their sources are written beside the keys in ``defaults.toml`` (a test
checks that the two list the same keys); :func:`section` gives every field its default from there, so a section is
also built in code with keyword arguments (``GeometrySection(cones=2)``: every other key its default, each value
checked by its rule). :data:`RULES` is derived from these declarations: a key's range is stated in one place.
"""

from __future__ import annotations

from dataclasses import fields

from suture_fem.scene.balance import BALANCE_TOL, MIN_FORCE_N, MIN_STEP
from suture_fem.scene.rules import (  # noqa: F401  (re-exported: the schema's names, used across the package)
    INF,
    MIN_LENGTH_MM,
    Params,
    Rule,
    _length,
    _pos,
    _Section,
    default_values,
    frozen,
    key,
    plain,
    section,
)

MM, N, PA, S = "mm", "N", "Pa", "s"


@section("geometry")
class GeometrySection(_Section):
    """``[geometry]``: the suture and the tissue cylinder (lengths in mm)."""

    cones: int = key(Rule("int", lo=0, hi=64))
    cone_kind: str = key(Rule("str", choices=("hollow", "full")))
    cone_height_mm: float = key(_length(100.0), MM)
    cone_base_diameter_mm: float = key(_length(100.0), MM)
    cone_top_diameter_mm: float = key(_length(100.0), MM)
    cone_wall_mm: float = key(_length(10.0), MM)
    cone_spacing_mm: float = key(_length(1000.0), MM)
    cone_orientation: str = key(Rule("str", choices=("apex_to_pull", "base_to_pull")))
    cone_fillet_mm: float = key(_pos(10.0, lo_open=False), MM)
    thread_radius_mm: float = key(_length(10.0), MM)
    thread_free_length_mm: float = key(_length(1000.0), MM)
    hypodermis_mm: float = key(_length(1000.0), MM)
    dermis_mm: float = key(_length(1000.0), MM)
    epidermis_mm: float = key(_length(1000.0), MM)
    margin_pull_mm: float = key(_length(1000.0), MM)
    margin_far_mm: float = key(_length(1000.0), MM)
    dimension: int = key(Rule("int", lo=2, hi=3))
    tissue_shape: str = key(Rule("str", choices=("cylinder", "slab")))
    thread_depth_mm: float = key(Rule("float", lo=1.0, hi=10.0), MM)
    slab_half_width_mm: float = key(Rule("float", lo=2.0, hi=100.0), MM)


@section("mesh")
class MeshSection(_Section):
    """``[mesh]``: element sizes at refinement 0 and the Lagrange degree."""

    refinement: int = key(Rule("int", lo=0, hi=6))
    degree: int = key(Rule("int", lo=1, hi=2))
    size_suture_mm: float = key(_length(10.0), MM)
    size_rim_mm: float = key(_length(10.0), MM)
    size_far_mm: float = key(_length(100.0), MM)
    grading_mm: float = key(_length(1000.0), MM)
    fillet_elements: int = key(Rule("int", lo=1, hi=256))
    geometry_degree: int = key(Rule("int", lo=1, hi=2))


@section("loading")
class LoadingSection(_Section):
    """``[loading]``: the pull (a force, or the pulled end's displacement), where it is reported, its time course."""

    force_n: float = key(Rule("float", lo=MIN_FORCE_N, hi=1000.0), N)
    force_scale: float = key(_pos(100.0))
    report_forces_n: tuple[float, ...] = key(Rule("floats", lo=MIN_FORCE_N, hi=1000.0), N)
    control: str = key(Rule("str", choices=("force", "displacement")))
    displacement_mm: float = key(_pos(100.0), MM)
    report_displacements_mm: tuple[float, ...] = key(Rule("floats", lo=0.0, hi=100.0, lo_open=True), MM)
    start_force_n: float = key(_pos(1000.0, lo_open=False), N)
    ramp_s: float = key(_pos(1e6), S)
    hold_s: float = key(_pos(1e6, lo_open=False), S)


@section("solver")
class SolverSection(_Section):
    """``[solver]``: load stepping, Newton tolerances, linear solver."""

    initial_step: float = key(Rule("float", lo=MIN_STEP, hi=1.0))
    min_step: float = key(Rule("float", lo=MIN_STEP, hi=1.0))
    max_step: float = key(Rule("float", lo=MIN_STEP, hi=1.0))
    grow: float = key(Rule("float", lo=1.0, hi=10.0))
    easy_iterations: int = key(Rule("int", lo=1, hi=100))
    max_iterations: int = key(Rule("int", lo=1, hi=1000))
    rtol: float = key(_pos(BALANCE_TOL))  # of a step's first residual: a larger one cannot balance the step
    atol: float = key(_pos(1.0), N)  # also <= BALANCE_TOL x the pull (scene/balance.py)
    linear_solver: str = key(Rule("str", choices=("mumps", "superlu_dist", "petsc")))
    linear_method: str = key(Rule("str", choices=("auto", "direct", "gamg", "hypre")))
    iterative_from_dofs: int = key(Rule("int", lo=0, hi=10**10))
    petsc_options: Params = key(Rule("table"))
    inertia_correction: bool = key(Rule("bool"))
    trust_region: str = key(Rule("str", choices=("auto", "on", "off")))
    gent_limit_fraction: float = key(Rule("float", lo=0.0, hi=1.0, lo_open=True))

    def method_for(self, dimension: int, unknowns: int) -> str:
        """"direct", "gamg" or "hypre": ``linear_method`` with "auto" resolved.

        "auto" is a Krylov method (GAMG) in 3-D from ``iterative_from_dofs`` unknowns on, else direct.
        """
        if self.linear_method != "auto":
            return self.linear_method
        return "gamg" if dimension == 3 and unknowns >= self.iterative_from_dofs else "direct"


#: The optional outputs a scene may ask for in ``output.quantities``, in the order they are computed:
#: declared here once (the scene checks them before anything is imported). Each is the ``option`` of
#: one Quantity class in ``outputs/`` (checked when the class is defined, and by a test), and
#: results.json's ``effects.outputs`` lists those left out.
OUTPUT_QUANTITIES: tuple[str, ...] = ("usum", "seqv", "eptoeqv", "interface", "dimple")
#: Those of the slab only (``geometry.tissue_shape = "slab"``): the skin surface's normal displacement.
SLAB_QUANTITIES: tuple[str, ...] = ("dimple",)
#: Those computed from the stress and strain at the quadrature points (one compiled expression per material).
POINT_QUANTITIES: tuple[str, ...] = ("seqv", "eptoeqv")


@section("output")
class OutputSection(_Section):
    """``[output]``: which quantities, fields and measures are computed."""

    fields: bool = key(Rule("bool"))
    rim_exclusion_mm: float = key(_pos(100.0, lo_open=False), MM)
    critical_distance_mm: float = key(_pos(10.0, lo_open=False), MM)
    critical_distance_layers: bool = key(Rule("bool"))
    quantities: tuple[str, ...] = key(Rule("strs", choices=OUTPUT_QUANTITIES))


#: The thread interfaces whose tissue side has its own nodes along the bare thread (the split track).
TRACK_INTERFACES = ("sliding", "frictionless", "coulomb")


@section("effects")
class EffectsSection(_Section):
    """``[effects]``: the physics a scene calls for, and the constants of each effect."""

    inertia: bool = key(Rule("bool"))
    suture: str = key(Rule("str", choices=("elastic", "rigid")))
    incompressibility: str = key(Rule("str", choices=("displacement", "mixed")))
    gravity: bool = key(Rule("bool"))
    density_hypodermis_kg_m3: float = key(_pos(1e5), "kg/m^3")
    density_dermis_kg_m3: float = key(_pos(1e5), "kg/m^3")
    density_epidermis_kg_m3: float = key(_pos(1e5), "kg/m^3")
    density_suture_kg_m3: float = key(_pos(1e5), "kg/m^3")
    rayleigh_mass_per_s: float = key(_pos(1e9, lo_open=False), "1/s")
    rayleigh_stiffness_s: float = key(_pos(1.0, lo_open=False), S)
    time_scheme: str = key(Rule("str", choices=("newmark", "generalized_alpha")))
    spectral_radius: float = key(Rule("float", lo=0.0, hi=1.0))
    time_step_s: float = key(_pos(1e6), S)
    gravity_m_s2: float = key(_pos(1e3, lo_open=False), "m/s^2")
    gravity_direction: str = key(Rule("str", choices=("-z", "+z")))
    thread_interface: str = key(Rule("str", choices=("tied", *TRACK_INTERFACES)))
    cone_interface: str = key(Rule("str", choices=("tied", *TRACK_INTERFACES)))
    contact_penalty: float = key(_pos(1e8))
    cone_contact_method: str = key(Rule("str", choices=("augmented", "penalty")))
    augmented_penalty: float = key(_pos(1e8))
    contact_penetration_mm: float = key(_pos(1.0), MM)
    cone_corners: str = key(Rule("str", choices=("measured", "held")))
    friction_coefficient: float = key(Rule("float", lo=0.0, hi=2.0))
    friction_slip_mm: float = key(_pos(1.0), MM)

    @property
    def thread_track(self) -> bool:
        """The tissue has its own nodes along the bare thread (a sliding or a frictionless thread)."""
        return self.thread_interface in TRACK_INTERFACES

    @property
    def cone_contact(self) -> bool:
        """The tissue has its own nodes on the cones' surfaces (sliding, frictionless or Coulomb cones)."""
        return self.cone_interface in TRACK_INTERFACES

    def density(self, region: str) -> float:
        """Mass density (kg/m^3) of a material region."""
        return getattr(self, f"density_{region}_kg_m3")


from suture_fem.scene.strength import StrengthSection  # noqa: E402  (it builds on the rules above)

SECTIONS: dict[str, type] = {  # the sections with fixed keys, by name (``materials``: per region, scene/laws.py)
    "geometry": GeometrySection,
    "mesh": MeshSection,
    "loading": LoadingSection,
    "solver": SolverSection,
    "output": OutputSection,
    "effects": EffectsSection,
    "strength": StrengthSection,
}

#: The ``[materials]`` keys that are not a region's table: ``tissue_scale`` multiplies every tissue
#: constant (c10, c20, ..., mu, the volumetric 1/d) of the three tissue layers (not Gent's jm, not the suture).
MATERIAL_KEYS: dict[str, Rule] = {"tissue_scale": _pos(1000.0)}

#: Rules for every fixed key, by dotted name (derived from the declarations above).
RULES: dict[str, Rule] = {
    **{f"{name}.{f.name}": f.metadata["rule"] for name, cls in SECTIONS.items() for f in fields(cls)},
    **{f"materials.{name}": rule for name, rule in MATERIAL_KEYS.items()},
}
#: Unit of every fixed key that has one.
UNITS: dict[str, str] = {
    f"{name}.{f.name}": f.metadata["unit"] for name, cls in SECTIONS.items() for f in fields(cls) if f.metadata["unit"]
}

#: The PETSc options a scene may set in ``solver.petsc_options`` (under the solver's own prefix), each
#: with its type and range: line search, tolerances, iteration limits, the direct solver and its
#: ordering, MUMPS controls. Nothing else is accepted: viewer, monitor, log and options-file options
#: would create or overwrite files, and ``pc_type = "python"`` would import and run any module.
PETSC_OPTIONS: dict[str, Rule] = {
    "snes_linesearch_type": Rule("str", choices=("bt", "basic", "l2", "cp", "nleqerr")),
    "snes_linesearch_order": Rule("int", lo=1, hi=3),
    "snes_linesearch_damping": Rule("float", lo=0.0, hi=1.0, lo_open=True),
    "snes_linesearch_maxstep": _pos(1e12),
    "snes_linesearch_minlambda": _pos(1.0),
    "snes_linesearch_max_it": Rule("int", lo=1, hi=100),
    "snes_max_it": Rule("int", lo=1, hi=1000),
    "snes_max_funcs": Rule("int", lo=1, hi=10**7),
    "snes_rtol": _pos(BALANCE_TOL),
    "snes_atol": _pos(1.0),  # N; also <= BALANCE_TOL x the pull, as solver.atol
    "snes_stol": _pos(1.0, lo_open=False),
    "snes_divergence_tolerance": Rule("float", lo=-1.0, hi=1e300),
    "snes_lag_jacobian": Rule("int", lo=-2, hi=100),
    "ksp_type": Rule("str", choices=("preonly",)),
    "pc_type": Rule("str", choices=("lu", "cholesky")),
    "pc_factor_mat_solver_type": Rule("str", choices=("mumps", "superlu_dist", "petsc")),
    "pc_factor_mat_ordering_type": Rule("str", choices=("nd", "rcm", "qmd", "1wd", "natural")),
    "mat_mumps_icntl_7": Rule("int", lo=0, hi=7),  # sequential ordering
    "mat_mumps_icntl_8": Rule("int", lo=-2, hi=77),  # scaling
    "mat_mumps_icntl_10": Rule("int", lo=-100, hi=100),  # iterative refinement steps
    "mat_mumps_icntl_13": Rule("int", lo=-1, hi=1),  # root parallelism
    "mat_mumps_icntl_14": Rule("int", lo=0, hi=100000),  # workspace increase (%)
    "mat_mumps_icntl_23": Rule("int", lo=0, hi=10**7),  # working memory per process (MB)
    "mat_mumps_icntl_24": Rule("int", lo=0, hi=1),  # null pivot detection
    "mat_mumps_icntl_28": Rule("int", lo=0, hi=2),  # sequential or parallel analysis
    "mat_mumps_icntl_29": Rule("int", lo=0, hi=2),  # parallel ordering tool
    "mat_mumps_icntl_35": Rule("int", lo=0, hi=3),  # block low-rank factorisation
    "mat_mumps_cntl_1": Rule("float", lo=0.0, hi=1.0),  # relative pivoting threshold
    "mat_mumps_cntl_3": Rule("float", lo=-1e300, hi=1e300),  # absolute pivoting threshold
    "mat_mumps_cntl_4": Rule("float", lo=-1.0, hi=1e300),  # static pivoting threshold
    "mat_mumps_cntl_5": Rule("float", lo=0.0, hi=1e300),  # fixation for null pivots
    "mat_mumps_cntl_7": Rule("float", lo=0.0, hi=1.0),  # block low-rank dropping
}

#: The material laws a ``[materials.<region>]`` table may name, and their parameters: ``scene/laws.py`` (``LAWS``).
