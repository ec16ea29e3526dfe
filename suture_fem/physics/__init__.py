"""Physics: axisymmetric kinematics, materials, the effects' weak-form terms and the assembled problem."""
