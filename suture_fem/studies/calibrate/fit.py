"""The fit and its uncertainty: bounded least squares, Gauss-Newton covariance, identifiability.

Residuals r_i = (model_i - data_i) / s_i with s_i the stated standard deviation, else 1 mm (then the
residual variance sigma^2 = |r|^2 / (n - k) estimates the noise). Fitted in the variables
theta / theta_start (so keys of very different sizes are equally scaled) by scipy's bounded
``least_squares`` (trust region reflective), with the Jacobian from the model's sensitivities.

Uncertainty (linearised at the optimum): Cov = sigma^2 (J^T J)^+ with J = dr/dtheta; 95 % intervals
theta_j +- t_{0.975, n-k} sqrt(Cov_jj) (normal quantile when sigma is known). When the data determine
the parameters exactly (n <= k, no standard deviation given, so no residual variance), the data's
stated precision stands in for sigma: a value printed to one unit u in its last digit is known to
+- u/2, a uniform rounding error of standard deviation u / sqrt(12) (the report says so).

Identifiability from the singular values s_1 >= ... >= s_k of the relative sensitivities
dr/d ln theta (singular vectors v_j): the combination sum_j v_kj ln theta_j along the last one is the
least determined, with a 95 % half-width q sigma / s_k in ln units. When that exceeds ln 2 (the data
cannot tell that combination within a factor of two), or s_k < :data:`COLLINEAR` s_1, the parameters
are (nearly) collinear: the data determine only the combination along v_1, prod theta_j^v_1j (a ratio
when two exponents are equal and opposite), and the verdict names it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from suture_fem.studies.calibrate.data import Point
from suture_fem.studies.calibrate.keys import FitKey
from suture_fem.studies.calibrate.model import Model

#: Ratio of the smallest to the largest singular value of the relative sensitivities below which the
#: fitted parameters count as collinear whatever the noise (a 1 % change of the data moves the least
#: determined combination 1000 times more than the best determined one).
COLLINEAR = 1e-3
#: The least determined combination must be known within this factor (95 %) for the parameters to
#: count as determined.
FACTOR = 2.0


def sigmas(points: list[Point]) -> tuple[np.ndarray, str]:
    """The residuals' scales (mm) and where they come from."""
    if all(p.sd_mm is not None for p in points):
        return np.array([p.sd_mm for p in points]), "stated standard deviations"
    return np.ones(len(points)), "residual variance"


def fit(model: Model, max_evaluations: int = 30) -> dict[str, Any]:
    """Fit the model's keys to its data; returns the fit record (values, intervals, correlation, verdict)."""
    keys, points = model.keys, model.points
    start = np.array([k.start for k in keys])
    s, sigma_source = sigmas(points)
    data = np.array([p.value_mm for p in points])
    cache: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def evaluate(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = np.asarray(x, float).tobytes()
        if key not in cache:
            cache.clear()
            y, J = model.predict(x * start)
            cache[key] = ((y - data) / s, J * start / s[:, None])
        return cache[key]

    lo = np.array([k.lo for k in keys]) / start
    hi = np.array([k.hi for k in keys]) / start
    from scipy import optimize  # here, not at import: scipy costs every command 0.3 s of CPU

    result = optimize.least_squares(lambda x: evaluate(x)[0], np.ones(len(keys)), jac=lambda x: evaluate(x)[1],
                                    bounds=(lo, hi), method="trf", x_scale="jac", max_nfev=max_evaluations,
                                    xtol=1e-6, ftol=1e-8, gtol=1e-8)
    theta = result.x * start
    r, Jx = evaluate(result.x)
    y = r * s + data
    J = Jx / start  # dr/dtheta
    return {
        "status": "converged" if result.status > 0 else "not converged",
        "message": result.message,
        **uncertainty(keys, points, theta, r, J, s, sigma_source),
        "predictions_mm": y.tolist(),
        "sensitivities_mm": (J * s[:, None]).tolist(),
    }


def uncertainty(keys: list[FitKey], points: list[Point], theta: np.ndarray, r: np.ndarray, J: np.ndarray,
                s: np.ndarray, sigma_source: str) -> dict[str, Any]:
    """Covariance, 95 % intervals, correlation and the identifiability verdict at the optimum."""
    from scipy import stats

    n, k = J.shape
    dof = n - k
    if sigma_source == "stated standard deviations":
        sigma2, quantile, source = 1.0, stats.norm.ppf(0.975), sigma_source
    elif dof > 0:
        sigma2, quantile, source = float(r @ r) / dof, stats.t.ppf(0.975, dof), f"residual variance ({dof} dof)"
    else:
        precision = np.array([p.resolution_mm for p in points]) / math.sqrt(12)
        J = J * s[:, None] / precision[:, None]
        sigma2, quantile = 1.0, stats.norm.ppf(0.975)
        source = ("the data's stated precision: the data determine the parameters exactly, so the interval "
                  "is that of a value printed to " + ", ".join(sorted({f"{p.resolution_mm:g} mm" for p in points}))
                  + " (a uniform rounding error, standard deviation unit / sqrt(12))")
    cov = sigma2 * np.linalg.pinv(J.T @ J)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    verdict = identifiability(keys, theta, J, quantile * math.sqrt(sigma2))
    params = {}
    for j, key in enumerate(keys):
        half = quantile * sd[j]
        params[key.key] = {"value": float(theta[j]), "ci95": [float(theta[j] - half), float(theta[j] + half)],
                           "sd": float(sd[j]), "bounds": [key.lo, key.hi], "start": key.start,
                           "sensitivity": key.method, "at_bound": bool(np.isclose(theta[j], key.lo, rtol=1e-6)
                                                                       or np.isclose(theta[j], key.hi, rtol=1e-6))}
    pinned = [f"{name} = {p['value']:.6g} (bounds {p['bounds'][0]:g}:{p['bounds'][1]:g})"
              for name, p in params.items() if p["at_bound"]]
    if pinned:  # the optimum is the bound, not a minimum the data made: its interval is not the data's either
        verdict = {**verdict, "identifiable": False, "at_bound": pinned,
                   "verdict": f"NOT determined: {'; '.join(pinned)} stopped at a bound of the search, so the data "
                              "did not set it (the best fit lies at or beyond the bound); its interval is not "
                              "meaningful: widen the bounds (--fit KEY=LOW:HIGH) or check the data"}
    estimated = sigma_source == "residual variance" and dof > 0
    return {"parameters": params, "covariance": cov.tolist(), "correlation": np.nan_to_num(corr).tolist(),
            "residuals_mm": (r * s).tolist(), "sigma_mm": math.sqrt(sigma2) if estimated else None,
            "uncertainty_from": source, "identifiability": verdict}


def identifiability(keys: list[FitKey], theta: np.ndarray, J: np.ndarray, noise: float) -> dict[str, Any]:
    """Whether the data determine every parameter, else which combination they determine.

    ``noise`` is the 95 % half-width of one weighted residual (quantile times sigma).
    """
    names = [k.key for k in keys]
    if len(keys) == 1:  # the same test as the weakest combination below: known within FACTOR at 95 %
        rel = float(np.linalg.norm(J[:, 0] * theta[0]))
        factor = math.exp(min(noise / rel, 700.0)) if rel > 0 else math.inf
        if rel == 0:
            verdict = f"the data do not depend on {names[0]}"
        elif factor <= FACTOR:
            verdict = f"{names[0]} is determined by the data (within a factor {factor:.3g} at 95 %)"
        else:
            verdict = (f"NOT determined: the data tell {names[0]} only within a factor {factor:.3g} at 95 % "
                       f"(allowed: {FACTOR:g})")
        return {"identifiable": factor <= FACTOR, "singular_values": [], "weakest_factor95": factor,
                "verdict": verdict}
    rel = J * theta[None, :]  # dr / d ln theta
    _, sv, vt = np.linalg.svd(rel, full_matrices=False)
    ratio = float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0
    weakest = noise / sv[-1] if sv[-1] > 0 else math.inf  # 95 % half-width of the weakest ln-combination
    factor = math.exp(min(weakest, 700.0))
    if ratio >= COLLINEAR and factor <= FACTOR:
        return {"identifiable": True, "singular_values": sv.tolist(), "ratio": ratio, "weakest_factor95": factor,
                "verdict": f"every parameter is determined (the least determined combination within a factor "
                           f"{factor:.3g} at 95 %; smallest/largest relative singular value {ratio:.2g})"}
    v = vt[0] / np.max(np.abs(vt[0]))
    return {"identifiable": False, "singular_values": sv.tolist(), "ratio": ratio, "weakest_factor95": factor,
            "determined_combination": dict(zip(names, v.tolist())),
            "verdict": f"NOT identifiable: {' and '.join(names)} are (nearly) collinear (smallest/largest relative "
                       f"singular value {ratio:.2g}; the least determined combination only within a factor "
                       f"{factor:.3g} at 95 %); the data determine only {combination(names, v)}, not each "
                       "parameter; their separate values and intervals are not meaningful"}


def combination(names: list[str], v: np.ndarray) -> str:
    """The determined combination in words: a ratio or product of two, else prod name^exponent."""
    big = [(n, e) for n, e in zip(names, v) if abs(e) > 0.05]
    if len(big) == 2 and abs(abs(big[0][1]) - abs(big[1][1])) < 0.2:
        (a, ea), (b, eb) = big
        if ea * eb < 0:
            num, den = (a, b) if ea > 0 else (b, a)
            return f"the ratio {num} / {den}"
        return f"the product {a} * {b}"
    return "the product " + " * ".join(f"{n}^{e:.2f}" for n, e in big)
