"""The accuracy-cost ledger: ``suture-fem convergence SCENE [--set KEY=VALUE ...] [--out DIR]``.

A ladder of solves of one scene, refinement by refinement (every element size halves per step) for
each element degree (and each incompressibility formulation, where the scene has that choice), and
for every rung: wall time, degrees of freedom, Newton iterations, peak memory and the outputs.
From the ladder, Richardson extrapolation with the observed order estimates every rung's error; a
quantity whose changes do not shrink under refinement (the raw stress maximum at a sharp cone rim)
is reported as having no limit, next to maxima that keep away from the singular points.

The modules, in the order of the study:

* :mod:`.quantities`: what is followed through the ladder (USUM, the stress and strain maxima).
* :mod:`.ladder`: the rungs, each solved in its own process (or in this one) with its cost.
* :mod:`.singular`: the model's singular points and the tissue's maxima away from them (one rung's solve).
* :mod:`.richardson`: the observed order, the extrapolated limit, the two-rung error.
* :mod:`.analysis`: per force and quantity, the estimate of every ladder, the reference, every rung's error.
* :mod:`.report`: ``ledger.json``, ``ledger.md``, ``ledger.png`` in the output folder.
* :mod:`.study`: all of the above for one ladder.
* :mod:`.estimate`: ``suture-fem run --error-estimate``, the two-rung estimate of a single run.

Outputs in DIR: ``ledger.json``, ``ledger.md`` (tables), ``ledger.png`` (relative error against
wall time, log-log, one curve per quantity and degree; ``ledger-cpu.png`` the same against CPU time,
which a busy machine does not inflate) and ``rungs/<name>/`` (each rung's
results.json, run.log and rung.json). Rungs whose folder already holds a converged result of the
same resolved scene are reused (``--redo`` solves them again).
"""
