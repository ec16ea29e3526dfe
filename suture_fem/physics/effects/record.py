"""What a scene calls for, the cross-key rules of the effects, and the ``effects`` record of results.json.

This module builds no form, so scene validation (:func:`check_scene`) needs neither UFL nor dolfinx.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from suture_fem.scene.model import Scene
from suture_fem.scene.schema import OUTPUT_QUANTITIES, POINT_QUANTITIES, SLAB_QUANTITIES, TRACK_INTERFACES
from suture_fem.support.errors import SceneError

#: The output quantities a scene may request (``output.quantities``), in the order they are computed.
QUANTITIES = OUTPUT_QUANTITIES
#: The interface models under which the tissue may leave the suture (a penalty against penetration only).
UNILATERAL = ("frictionless", "coulomb")
#: Why the hold is not solved when nothing in the scene depends on the rate.
HOLD_SKIPPED = (
    "hold skipped: no rate-dependent effect in the scene (inertia off, every material rate-independent), "
    "so the state at the end of the hold equals the state at the peak force"
)


_CONE_PAIRS = ("the tissue's side of every cone surface has its own nodes, each projected onto its cone's outline (the "
               "cone moved as a rigid body) wherever it slides; a penalty acts on its signed distance to the outline")
#: What each cone interface model is, for the record.
CONE_MODELS = {
    "tied": "tied: the cones and the tissue share their interface nodes",
    "sliding": f"bilateral frictionless sliding: {_CONE_PAIRS}, both ways; free along the surface",
    "frictionless": f"unilateral frictionless contact: {_CONE_PAIRS}, against penetration only (the tissue may lift "
                    "off); free along the surface",
    "coulomb": f"unilateral contact with Coulomb friction: {_CONE_PAIRS}, against penetration only; along the surface "
               "the pair sticks until the traction reaches mu times the contact pressure (a regularised slip), then "
               "slides",
}


@dataclass(frozen=True)
class Effects:
    """What a scene calls for (validated ``[effects]`` and ``output.quantities``)."""

    inertia: bool = False
    suture: str = "elastic"
    incompressibility: str = "displacement"
    gravity: bool = False
    quantities: tuple[str, ...] = QUANTITIES
    hold_s: float = 0.0
    thread_interface: str = "tied"
    cone_interface: str = "tied"
    #: the tissue is the slab (``geometry.tissue_shape = "slab"``): its outputs may be asked for
    slab: bool = False

    @classmethod
    def from_scene(cls, scene: Scene) -> Effects:
        """The effects of a scene (its ``[effects]``, ``output.quantities`` and ``loading.hold_s``)."""
        e = scene.effects
        return cls(
            inertia=e.inertia,
            suture=e.suture,
            incompressibility=e.incompressibility,
            gravity=e.gravity,
            quantities=tuple(q for q in QUANTITIES if q in scene.output.quantities),
            hold_s=scene.loading.hold_s,
            thread_interface=e.thread_interface,
            cone_interface=e.cone_interface,
            slab=scene.geometry.tissue_shape == "slab",
        )

    @property
    def rigid(self) -> bool:
        """The suture is rigid (``effects.suture = "rigid"``)."""
        return self.suture == "rigid"

    @property
    def sliding_thread(self) -> bool:
        """The bare thread slides in its track (``effects.thread_interface = "sliding"``)."""
        return self.thread_interface == "sliding"

    @property
    def thread_track(self) -> bool:
        """The tissue has its own nodes along the bare thread (a sliding or a frictionless thread)."""
        return self.thread_interface in TRACK_INTERFACES

    @property
    def unilateral_thread(self) -> bool:
        """The tissue may leave the thread (``effects.thread_interface = "frictionless"`` or ``"coulomb"``)."""
        return self.thread_interface in UNILATERAL

    @property
    def frictional_thread(self) -> bool:
        """Coulomb friction between the thread and the tissue (``effects.thread_interface = "coulomb"``)."""
        return self.thread_interface == "coulomb"

    @property
    def cone_contact(self) -> bool:
        """The tissue has its own nodes on the cones' surfaces (``effects.cone_interface`` not ``"tied"``)."""
        return self.cone_interface in TRACK_INTERFACES

    @property
    def contact(self) -> bool:
        """A penalty acts somewhere: the tissue may leave the thread, or has its own nodes on the cones."""
        return self.unilateral_thread or self.cone_contact

    @property
    def mixed(self) -> bool:
        """The tissue has a pressure field (``effects.incompressibility = "mixed"``)."""
        return self.incompressibility == "mixed"

    def record(self, notes: dict[str, Any] | None = None) -> dict[str, Any]:
        """Each effect on or off, and for each one off or skipped the reason (JSON-ready).

        Args:
            notes: effect name (``inertia``, ``suture``, ``mixed``, ``gravity``) -> the numbers the
                built problem reports for it (see ``Physics.notes``).
        """
        notes = notes or {}
        return {
            "inertia": self._inertia(notes),
            "suture": self._suture(notes),
            "incompressibility": self._incompressibility(notes),
            "gravity": {"on": True, **notes.get("gravity", {})} if self.gravity else {
                "on": False, "left_out": "effects.gravity = false: no body force"},
            "interfaces": self._interfaces(notes),
            "hold": self._hold(),
            "outputs": self._outputs(),
        }

    def _inertia(self, notes: dict[str, Any]) -> dict[str, Any]:
        if self.inertia:
            return {"on": True, **notes.get("inertia", {})}
        return {"on": False, "left_out": "effects.inertia = false: quasi-static load ramp; no mass or "
                "damping form is built, compiled or assembled"}

    def _suture(self, notes: dict[str, Any]) -> dict[str, Any]:
        if self.rigid:
            return {"on": True, "treatment": "rigid", "left_out": "effects.suture = \"rigid\": no suture "
                    "strain energy; the suture's unknowns are replaced by one rigid axial motion",
                    **notes.get("suture", {})}
        return {"on": True, "treatment": "elastic", **notes.get("suture", {})}

    def _incompressibility(self, notes: dict[str, Any]) -> dict[str, Any]:
        if self.mixed:
            return {"on": True, "treatment": "mixed", "formulation":
                    "Taylor-Hood P2 displacement / P1 pressure in the tissue", **notes.get("mixed", {})}
        return {"on": True, "treatment": "displacement",
                "left_out": "effects.incompressibility = \"displacement\": no pressure field"}

    def _interfaces(self, notes: dict[str, Any]) -> dict[str, Any]:
        rec: dict[str, Any] = {"thread": self.thread_interface, "cones": self.cone_interface}
        if self.sliding_thread:
            rec["thread_model"] = ("bilateral frictionless sliding: the tissue's side of the thread's track has its "
                                   "own nodes, held at r = thread radius (u_r = 0) and free along it")
        elif self.frictional_thread:
            rec["thread_model"] = ("unilateral contact with Coulomb friction: the tissue's side of the thread's track "
                                   "has its own nodes, free to leave the thread (u_r > 0) but not to enter it (a "
                                   "penalty), and sticks to the thread node it faced in the reference configuration "
                                   "until the axial traction reaches mu times the contact pressure (a penalty's "
                                   "elastic slip), then slides")
        elif self.unilateral_thread:
            rec["thread_model"] = ("unilateral frictionless contact: the tissue's side of the thread's track has its "
                                   "own nodes, free along it and free to leave the thread (u_r > 0) but not to "
                                   "enter it (u_r >= 0 by a penalty)")
        else:
            rec["thread_model"] = "tied: the thread and the tissue share their interface nodes (the paper's model)"
        rec["cone_model"] = CONE_MODELS[self.cone_interface]
        return {**rec, **notes.get("interfaces", {})}

    def _hold(self) -> dict[str, Any]:
        if self.inertia and self.hold_s > 0:
            return {"solved": True, "reason": "inertia on: the hold is integrated in time"}
        if self.hold_s > 0:
            return {"solved": False, "left_out": HOLD_SKIPPED}
        return {"solved": False, "left_out": "loading.hold_s = 0: no hold"}

    def _outputs(self) -> dict[str, Any]:
        left = [q for q in QUANTITIES if q not in self.quantities and (self.slab or q not in SLAB_QUANTITIES)]
        rec: dict[str, Any] = {"computed": list(self.quantities),
                               "left_out": {q: "not in output.quantities: never computed" for q in left}}
        if not set(POINT_QUANTITIES) & set(self.quantities):
            rec["stress_strain_fields"] = "not compiled: neither seqv nor eptoeqv is requested"
        return rec


def check_scene(scene: Scene) -> None:
    """Cross-key rules of the effects (run by scene validation, before any meshing)."""
    e = scene.effects
    if e.incompressibility == "mixed" and scene.mesh.degree < 2:
        raise SceneError(
            'scene key effects.incompressibility = "mixed" needs mesh.degree = 2 (Taylor-Hood P2/P1 is the stable '
            "pair; P1/P0 and P1/P1 are not), got mesh.degree = 1"
        )
    unilateral = [f'{side}_interface = "{model}"' for side, model in
                  (("thread", e.thread_interface), ("cone", e.cone_interface)) if model in UNILATERAL]
    if e.incompressibility == "mixed" and unilateral:
        raise SceneError(
            'scene key effects.incompressibility = "mixed" needs effects.thread_interface and effects.cone_interface '
            '"tied" or "sliding" (its u-p equations are no energy\'s variation, so no energy line search nor trust '
            "region carries unilateral contact: the paper scene's ramps stopped at 0.20-0.82 N); got effects."
            + " and effects.".join(unilateral) + '; use effects.incompressibility = "displacement"'
        )
    if e.inertia and e.time_step_s > scene.loading.ramp_s + scene.loading.hold_s:
        raise SceneError(
            f"scene key effects.time_step_s = {e.time_step_s:g} must be <= loading.ramp_s + loading.hold_s"
        )
    if scene.loading.control == "displacement" and (e.inertia or e.gravity):
        raise SceneError('scene key loading.control = "displacement" needs effects.inertia = false and '
                         "effects.gravity = false (the time history and the weight's preload are force-driven)")
    start = scene.loading.start_force_n
    if start > 0 and (scene.loading.control != "force" or e.inertia or e.gravity
                      or start >= min((*scene.loading.report_forces_n, scene.loading.force_n))):
        raise SceneError(f"scene key loading.start_force_n = {start:g} needs loading.control = \"force\", no inertia "
                         "nor gravity, and a force below every reported force and loading.force_n")
    if e.cone_interface != "tied" and scene.geometry.cones == 0:
        raise SceneError(f'scene key effects.cone_interface = "{e.cone_interface}" needs geometry.cones >= 1 '
                         '(there is no cone surface); use "tied" with geometry.cones = 0')
    if e.cone_corners == "held" and e.cone_interface not in UNILATERAL:
        raise SceneError(f'scene key effects.cone_corners = "held" needs effects.cone_interface = "frictionless" or '
                         f'"coulomb" (the corners of tied or sliding cones stay on the tissue), got '
                         f'"{e.cone_interface}"')
    if e.cone_interface != "tied" and e.inertia:
        raise SceneError(f'scene key effects.cone_interface = "{e.cone_interface}" needs effects.inertia = false '
                         "(the cones' contact terms are not part of the time history)")
    quantities = scene.output.quantities
    if not quantities:
        raise SceneError("scene key output.quantities must name at least one of " + ", ".join(QUANTITIES))
