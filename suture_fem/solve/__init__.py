"""Solve: SNES Newton on the reduced unknowns, the admissible-domain guard, load-path control, diagnoses.

* :mod:`.stepping`: :func:`~suture_fem.solve.stepping.ramp`, the adaptive step loop along a scene's load path.
* :mod:`.paths`: the load paths (load ramp, gravity preload, time history).
* :mod:`.newton`: :class:`~suture_fem.solve.newton.NewtonSolver` (SNES, line-search and linear-solver
  fallbacks, the round-off floor).
* :mod:`.reduction`: u = T x + g, the unknowns SNES solves for.
* :mod:`.guard`: the admissible domain and the Gent limit at the quadrature points.
* :mod:`.diagnosis`: the cause of a stop and the failure text.
* :mod:`.records`: what a load path did (steps, counters, timings).
"""
