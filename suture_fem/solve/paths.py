"""Load paths: the parameter a run steps along and the loads it sets at each value.

The load path is the load fraction (quasi-static, :class:`LoadRamp`), the fraction of the pulled end's
displacement (displacement control, :class:`DisplacementRamp`), or time over ramp and hold (with
inertia, :class:`TimeHistory`); with gravity the weight is applied first, quasi-statically, at
zero pull force (:class:`GravityPreload`).
"""

from __future__ import annotations

from suture_fem.geometry.regions import MM
from suture_fem.physics.problem import Physics
from suture_fem.scene.model import Scene


class Path:
    """A parameter s the run steps along, from 0 to ``targets[-1]``, hitting every target exactly."""

    label = "load"
    reports = True
    #: The tangent predictor applies (du/ds from -dR/ds, a finite difference of the residual over ``rate_step``).
    linear_in_s = True
    #: The loads are dead and linear in s: dR/ds is the same all along the path (computed once, exactly, with
    #: a unit step); otherwise it is recomputed at each state with the small step ``rate_step``.
    dead_load = True
    rate_step = 1.0

    def __init__(self, physics: Physics, targets: list[float], initial: float, min_step: float, max_step: float,
                 grow: float):
        """Targets (report points, the end last) and the step controls, in units of s."""
        self.physics = physics
        self.targets, self.initial, self.min_step, self.max_step, self.grow = targets, initial, min_step, max_step, grow
        self.end = targets[-1]

    def force(self, s: float) -> float:
        """The pull force (N) at s."""
        raise NotImplementedError

    def apply(self, s_from: float, s_to: float) -> None:
        """Set the loads (and time step) of a trial from s_from to s_to."""
        self.physics.set_force(self.force(s_to))

    def accept(self, s_from: float, s_to: float) -> None:
        """After a converged and reported step."""

    def restore(self, s: float) -> None:
        """Loads of the converged state at s (after a failed trial, e.g. when the path stops)."""
        self.physics.set_force(self.force(s))

    def before_report(self, s: float) -> None:
        """After a converged step, before its outputs are evaluated."""

    def time(self, s: float) -> float | None:
        """The time (s) at s, with inertia; None on a quasi-static path."""
        return None

    def describe(self, s: float) -> str:
        """Where s is, for the log."""
        return f"F = {self.force(s):8.4f} N ({100 * s / self.end:5.1f} %)"


class LoadRamp(Path):
    """Quasi-static: s is the fraction of ``loading.force_n``."""

    def __init__(self, physics: Physics, scene: Scene):
        """Targets at every ``loading.report_forces_n`` and at the peak; steps from ``[solver]``."""
        o, f_max = scene.solver, scene.loading.force_n
        self.f_max = f_max
        targets = sorted(set(f / f_max for f in scene.loading.report_forces_n) | {1.0})
        super().__init__(physics, targets, o.initial_step, o.min_step, o.max_step, o.grow)

    def force(self, s: float) -> float:
        """The fraction s of the peak force."""
        return s * self.f_max


class DisplacementRamp(Path):
    """Displacement control: s is the fraction of ``loading.displacement_mm``; the force is the end's reaction."""

    #: R is not linear in the prescribed displacement: dR/ds by a small difference at each state.
    dead_load = False
    rate_step = 1e-6

    def __init__(self, physics: Physics, scene: Scene):
        """Targets at every ``loading.report_displacements_mm`` and at the end; steps from ``[solver]``."""
        o, d_max = scene.solver, scene.loading.displacement_mm
        self.d_max = d_max * MM
        targets = sorted(set(d / d_max for d in scene.loading.report_displacements_mm) | {1.0})
        super().__init__(physics, targets, o.initial_step, o.min_step, o.max_step, o.grow)
        self._force: tuple[float, float] | None = None  # (s, the end's force there)

    def force(self, s: float) -> float:
        """The force the end takes in the current state (N; the caller asks at a converged s).

        One residual assembly per converged state: the stepping asks for it three times (the step's
        record, the log, the report), so it is kept until the loads change.
        """
        if self._force is None or self._force[0] != s:
            self._force = (s, self.physics.applied_force_n())
        return self._force[1]

    def apply(self, s_from: float, s_to: float) -> None:
        """No traction; the end at the fraction s_to of the displacement."""
        self._force = None
        self.physics.set_force(0.0)
        self.physics.control.set(s_to * self.d_max)

    def restore(self, s: float) -> None:
        """The end where the converged state at s has it."""
        self.apply(s, s)

    def describe(self, s: float) -> str:
        """The end's displacement and its force, for the log."""
        return f"d = {s * self.d_max / MM:8.4f} mm  F = {self.force(s):8.4f} N ({100 * s / self.end:5.1f} %)"


class GravityPreload(Path):
    """The weight, ramped from 0 to 1 at zero pull force, before the pull (no reports)."""

    label = "gravity"
    reports = False

    def __init__(self, physics: Physics, scene: Scene):
        """One target (the full weight), tried in one step first."""
        o = scene.solver
        super().__init__(physics, [1.0], 1.0, o.min_step, 1.0, o.grow)

    def force(self, s: float) -> float:
        """No pull while the weight is applied."""
        return 0.0

    def apply(self, s_from: float, s_to: float) -> None:
        """Zero pull, the fraction s_to of the weight."""
        self.physics.set_force(0.0)
        self.physics.gravity_factor.value = s_to

    def restore(self, s: float) -> None:
        """The weight of the converged state at s."""
        self.apply(s, s)

    def describe(self, s: float) -> str:
        """The fraction of the weight applied, for the log."""
        return f"gravity {100 * s:5.1f} %"


class TimeHistory(Path):
    """Inertia: s is time; the force ramps over ``loading.ramp_s`` and is held for ``loading.hold_s``."""

    label = "time"
    linear_in_s = False  # the time step and the inertia terms change with t

    def __init__(self, physics: Physics, scene: Scene):
        """Targets at the report forces' times, the end of the ramp and of the hold; steps of ``time_step_s``."""
        load, o = scene.loading, scene.solver
        self.f_max, self.ramp_s = load.force_n, load.ramp_s
        dt = scene.effects.time_step_s
        targets = {f / self.f_max * self.ramp_s for f in load.report_forces_n} | {self.ramp_s}
        if load.hold_s > 0:
            targets.add(self.ramp_s + load.hold_s)
        super().__init__(physics, sorted(targets), dt, o.min_step * self.ramp_s, dt, o.grow)
        self.dynamics = physics.dynamics

    def force(self, t: float) -> float:
        """The ramped, then held, force at time t."""
        return self.f_max * min(t / self.ramp_s, 1.0)

    def apply(self, t_from: float, t_to: float) -> None:
        """The time step, and the force at t_{n+1-alpha_f} (generalized-alpha; alpha_f = 0 for Newmark)."""
        af = self.dynamics.scheme.alpha_f
        self.dynamics.dt.value = t_to - t_from
        self.physics.set_force((1 - af) * self.force(t_to) + af * self.force(t_from))

    def accept(self, t_from: float, t_to: float) -> None:
        """Advance the time integrator's history to the converged state."""
        self.dynamics.accept(self.physics.state)

    def before_report(self, t: float) -> None:
        """Set the force at t itself for the outputs."""
        # with generalized-alpha the step was solved with the force at t_{n+1-alpha_f}; report the force at t
        # (the pulled-face entries of the record's free residual then carry alpha_f times the step's force change)
        self.physics.set_force(self.force(t))

    def time(self, s: float) -> float | None:
        """S is the time."""
        return s

    def describe(self, t: float) -> str:
        """Time and force, for the log."""
        return f"t = {t:8.4f} s  F = {self.force(t):8.4f} N"
