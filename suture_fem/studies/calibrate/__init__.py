"""``suture-fem calibrate``: fit scene keys to a measured pull curve, with honest uncertainty.

``data`` (the measured curve: CSV or the paper's values), ``keys`` (what may be fitted, its bounds and
whether its sensitivity is direct or a finite difference), ``sensitivity`` (the direct method,
du/dp = -A^-1 dR/dp), ``model`` (one ramp per evaluation and cone count, the physics built once per
mesh), ``fit`` (bounded least squares, Gauss-Newton covariance, intervals, identifiability), ``report``
(calibration.md and calibration.png), ``study`` (the entry, :func:`calibrate`).
"""

from suture_fem.studies.calibrate.data import DataError, Point, load, paper_points, read_csv
from suture_fem.studies.calibrate.keys import FitKey, parse_fit
from suture_fem.studies.calibrate.study import calibrate

__all__ = ["DataError", "FitKey", "Point", "calibrate", "load", "paper_points", "parse_fit", "read_csv"]
