"""suture_fem: axisymmetric FE model of a coned suspension suture in facial tissue."""
__version__ = "0.1.0"
