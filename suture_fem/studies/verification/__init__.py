"""Verification problems for the axisymmetric hyperelastic operator: is the discrete model solving the right equations?

Both problems are solved with the production pieces: the kinematics of :mod:`suture_fem.physics.kinematics`
(F with the hoop term, dV = 2 pi r dr dz), the energies of :mod:`suture_fem.physics.materials`, the
elastic terms of :mod:`suture_fem.physics.effects` with the residual as the Gateaux derivative of the
total energy (plus the pressure equation of the mixed formulation), the same quadrature degree, and the
production Newton solver (:class:`suture_fem.solve.newton.NewtonSolver`). Only the mesh (a rectangle in
(r, z)), the loads and the boundary conditions differ (:mod:`.problem`). Newton's method starts from
the interpolant of the exact solution with full steps: the solver's robustness is tested elsewhere,
these problems test the discretisation.

* :mod:`.problem`: the rectangle mesh, the production weak form on it, the solve.
* :mod:`.manufactured`: manufactured solutions (body force -Div P(u*)), weighted error norms, observed rates.
* :mod:`.tube`: Rivlin's telescopic shear of a (layered) tube on a rigid core, exact and computed.
"""
