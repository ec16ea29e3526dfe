"""Effects: the parts of the weak form a scene calls for, each built only when called.

A scene's ``[effects]`` section names the physics it needs, and ``output.quantities`` the outputs:

* ``effects.incompressibility`` = ``"displacement"`` / ``"mixed"``: the tissue's volumetric response
  from u alone, or through a pressure field (Taylor-Hood P2/P1).
* ``effects.suture`` = ``"elastic"`` / ``"rigid"``: the suture's St Venant-Kirchhoff energy, or no
  suture energy and one rigid axial motion instead of the suture's unknowns.
* ``effects.inertia`` = true / false: mass (and Rayleigh damping) terms and time integration over ramp
  and hold.
* ``effects.gravity`` = true / false: the tissue's and suture's weight as an axial body force.

Each effect contributes named terms to the residual (:class:`~suture_fem.physics.forms.Terms`); what a
scene leaves off is never built, so no form of it is compiled or assembled, and :meth:`Effects.record`
says what was left out and why (it goes into ``results.json`` as ``effects``).

One module per effect, each with its weak form (dV = 2 pi r dr dz, u the displacement, v its test
function):

* :mod:`.record`: what a scene calls for (:class:`Effects`), the cross-key rules (:func:`check_scene`)
  and the ``effects`` record.
* :mod:`.elastic`: delta Pi[v] with Pi = sum_regions int W(F(u)) dV.
* :mod:`.mixed`: the tissue's volumetric stress through a P1 pressure and its equation.
* :mod:`.rigid`: what a rigid suture changes (no strain energy; one axial motion for its unknowns).
* :mod:`.inertia`: mass, Rayleigh damping, Newmark / generalized-alpha time integration.
* :mod:`.gravity`: the weight as an axial body force.

The pull on the thread's end face, - int t u_z ds with t = F / (pi r_t^2), is in every scene:
:func:`suture_fem.physics.forms.pull_term`.
"""

from suture_fem.physics.effects.elastic import elastic_terms, strain_energy
from suture_fem.physics.effects.gravity import gravity_notes, gravity_term, weight_n
from suture_fem.physics.effects.inertia import Densities, Dynamics, Scheme
from suture_fem.physics.effects.mixed import mixed_tissue_terms, pressure_equation
from suture_fem.physics.effects.record import HOLD_SKIPPED, QUANTITIES, Effects, check_scene
from suture_fem.physics.effects.rigid import rigid_notes, strained_regions

__all__ = [
    "HOLD_SKIPPED",
    "QUANTITIES",
    "Densities",
    "Dynamics",
    "Effects",
    "Scheme",
    "check_scene",
    "elastic_terms",
    "gravity_notes",
    "gravity_term",
    "mixed_tissue_terms",
    "pressure_equation",
    "rigid_notes",
    "strain_energy",
    "strained_regions",
    "weight_n",
]
