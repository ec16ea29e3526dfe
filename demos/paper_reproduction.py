# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python (suture_fem)
#     language: python
#     name: suture-fem
# ---

# %% [markdown]
# # Reproducing Mousavi et al.: Tables 1 and 2, Figures 2-4
#
# The paper pulls a Silhouette Soft suture with 1 to 4 hollow cones out of a three-layer facial
# tissue cylinder at 1 to 4 N and reports the displacement USUM, the von Mises stress SEQV and the
# equivalent strain EPTOEQV (Tables 1 and 2), USUM contour plots (Figures 2-3) and a
# force-displacement curve (Figure 4). `suture-fem reproduce` solves the same cases, one load ramp
# per cone count, and puts every paper value next to ours (`suture_fem/studies/reproduce/`,
# `docs/reproduction.md`).
#
# ## The protocol
#
# The paper does not give every dimension. The honest protocol (MODEL.md):
#
# 1. fix every open dimension from public data first (cone spacing 6.25 mm from the product's
#    entry-to-exit lengths, thread radius 0.125 mm from USP 3-0);
# 2. calibrate ONE parameter against ONE value, USUM = 4.0 mm at 4 cones, 1 N (no open dimension
#    reaches it: the tissue length moves USUM by at most 5 %; one global scale of the tissue's
#    compliance does, docs/reproduction.md);
# 3. everything else is a prediction, reported with its relative error
#    $e = (\text{ours} - \text{paper}) / \text{paper}$.
#
# ## What is compared with what
#
# * USUM $= \max |u|$ over the model. It is the thread's pulled end, and it converges with the mesh.
# * The paper's SEQV values (0.2-2.5 MPa) are tissue stresses: our overall maximum is the thread's
#   axial stress $F/(\pi r_t^2) \approx 20$ MPa per newton. So SEQV is compared with the tissue's
#   maximum $\sigma_{vM} = \sqrt{\tfrac32\, s:s}$ ($s$ the deviatoric Cauchy stress), and EPTOEQV
#   with the tissue's maximum equivalent Hencky strain $\sqrt{\tfrac23\, e:e}$, $e = \ln V$ deviatoric.
# * A sharp cone rim is a re-entrant corner: the stress there is singular, its peak grows without
#   bound as the mesh is refined. Next to each peak we therefore show the maximum farther than
#   `output.rim_exclusion_mm` (0.1 mm) from every cone corner ("outside rims").

# %%
# %matplotlib inline
import json
import os
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, display

import suture_fem as sf

CI = bool(os.environ.get("CI"))  # CI runs every demo on a coarser discretisation
SUTURE_FEM = str(Path(sys.executable).with_name("suture-fem"))  # the command of this kernel's environment

# %% [markdown]
# ## Calibrate one parameter, solve 1-4 cones and compare
#
# `suture-fem reproduce` runs the study with its default protocol: it calibrates ONE
# parameter, `materials.tissue_scale` (every tissue constant times one factor), on ONE paper value
# (USUM 4.0 mm at 4 cones, 1 N) by bounded least squares with the direct-method sensitivity, then
# solves every cone count uncalibrated (`out/.../uncalibrated/`) and calibrated (one ramp each) and
# writes `comparison.json`, `comparison.md` and the figures. The full run (1-4 cones to 4 N) takes
# minutes on 2 cores; under `CI` this notebook solves a reduced version (linear elements on the
# scene's own mesh, `--cones 1 4`, to 1 N: the calibration target and one prediction), whose missing
# values show as "-" below (the command then exits 3: paper values without ours). The calibration
# alone is 7 ramps of 4 cones to 1 N (about 23 s CPU). The solved cases are read back typed with
# `sf.Results.read` (each cone count's `results.json`).

# %%
out = Path("out/paper_reproduction")
command = [SUTURE_FEM, "reproduce", "--out", str(out), "--jobs", "1"]  # calibrates materials.tissue_scale (default)
if CI:
    sets = ["mesh.degree=1", "loading.force_n=1.0", "loading.report_forces_n=[]", "solver.initial_step=0.05",
            "solver.max_step=0.25"]
    # the scene's own mesh for both cone counts, not reproduce's per-count rungs
    command += [a for s in sets for a in ("--set", s)] + ["--mesh", "scene", "--cones", "1", "4"]
done = subprocess.run(command, capture_output=True, text=True)
print(done.stdout)
assert done.returncode in ((0, 3) if CI else (0,)), done.stderr[-3000:]
cmp = json.loads((out / "comparison.json").read_text())
cones = sorted(int(p.name.split("_")[1]) for p in out.glob("cones_*"))
cal = cmp["calibration"]
print(f"{cmp['run']['dofs']}; {cmp['run']['wall_time_s']:.0f} s")
print(f"calibrated {cal['key']} = {cal['value']:.4f}, 95 % interval [{cal['ci95'][0]:.4f}, {cal['ci95'][1]:.4f}] "
      f"(from {cal['uncertainty_from'].split(':')[0]}); {cal['cost']['evaluations']} evaluations, "
      f"{cal['cost']['cpu_time_s']:.0f} s CPU")

# %% [markdown]
# ## Tables 1 and 2, side by side
#
# Every value of the paper with ours, uncalibrated and calibrated, and each relative error; the
# calibrated USUM carries its linearised 95 % band (the parameter's interval through dUSUM/dp).
# "role" says whether it was the calibration target, a prediction or not used (Table 1 prints
# 23549 kPa for SEQV at 4 cones, 1 N, ten times the trend of its neighbours: a typo).

# %%
unit = {"usum_mm": ("USUM (mm)", 1.0), "seqv_pa": ("SEQV (kPa)", 1e-3), "eptoeqv": ("EPTOEQV", 1.0)}


def fmt(v, scale, pct=False):
    if v is None:
        return "-"
    return f"{v:+.1%}" if pct else f"{v * scale:.4g}"


print(f"{'source':8} {'cones':>5} {'F (N)':>5} {'quantity':11} {'paper':>8} {'uncal.':>8} {'error':>8} "
      f"{'calibr.':>8} {'+-95 %':>6} {'error':>8}  role")
for r in cmp["rows"]:
    name, s = unit[r["quantity"]]
    band = f"{r['band95']:.3f}" if r["band95"] is not None else "-"
    print(f"{r['source']:8} {r['cones']:5d} {r['force_n']:5g} {name:11} {r['paper'] * s:8.4g} "
          f"{fmt(r['uncalibrated'], s):>8} {fmt(r['uncalibrated_rel_error'], s, True):>8} {fmt(r['ours'], s):>8} "
          f"{band:>6} {fmt(r['rel_error'], s, True):>8}  {r['role']}")

# %% [markdown]
# ## The paper's trends
#
# Whatever the absolute values, the paper makes qualitative claims: more cones hold the thread
# better (USUM falls with the cone count), the tissue stiffens (USUM grows less than linearly with
# the force, $\mathrm{USUM}/F$ falls), the stress falls with the cone count and rises with the force.

# %%
for t in cmp["trends"]:
    holds = {True: "yes", False: "NO", None: "- (not solved here)"}[t["holds"]]
    print(f"{holds:20} {t['trend']}")

# %% [markdown]
# ## Force against displacement (Figure 4) and the USUM contours (Figures 2 and 3)
#
# The curves are every converged load step of each ramp, calibrated (solid) and uncalibrated
# (dashed); the squares are the paper's USUM values.
# The contour pictures show the half-section mirrored into the full section on the deformed shape,
# in bands of one colour scale shared by every panel.

# %%
def curve(folder, n):
    return np.array(sf.Results.read(folder / f"cones_{n}" / "results.json").force_displacement)


fig, ax = plt.subplots(figsize=(7, 4.3), layout="constrained")
for i, n in enumerate(cones):
    colour = plt.cm.viridis(0.85 * i / max(len(cones) - 1, 1))
    fd, before = curve(out, n), curve(out / "uncalibrated", n)
    ax.plot(fd[:, 1], fd[:, 0], ".-", color=colour, label=f"{n} cone{'s' if n > 1 else ''}, calibrated")
    ax.plot(before[:, 1], before[:, 0], "--", color=colour, alpha=0.7, label=f"{n} cone{'s' if n > 1 else ''}, "
            "uncalibrated")
    paper = np.array([[r["force_n"], r["paper"]] for r in cmp["rows"]
                      if r["quantity"] == "usum_mm" and r["cones"] == n])
    if len(paper):
        ax.plot(paper[:, 1], paper[:, 0], "s", mfc="none", ms=7, color=colour, label=f"{n} cones, paper")
ax.set_xlabel("thread-end displacement (mm)")
ax.set_ylabel("pulling force (N)")
ax.set_xlim(left=0)
ax.set_ylim(bottom=0)
ax.grid(alpha=0.3)
ax.legend(fontsize=8)
plt.show()

for name in cmp.get("figures", []):
    if name.startswith(("fig2", "fig3", "trends")):
        print(name)
        display(Image(filename=str(out / name), width=900))

# %% [markdown]
# ## The calibration: one parameter, one value
#
# One value and one parameter determine the parameter exactly, so its 95 % interval is that of the
# paper's printed precision (4.0 mm: +-0.05 mm) through the sensitivity. `--calibrate KEY` chooses
# another parameter, `--calibrate none` none. `docs/reproduction.md` has the three candidates the
# issue names side by side (tissue scale, clamp radius, force scale, degree 1): each closes the
# 35-44 % gap, and the seven USUM values barely tell them apart. Below: the gap before, the target
# after, and the shape of the USUM values (relative to the target case), which no global scale moves
# much.

# %%
before = {(r["cones"], r["force_n"]): r["uncalibrated"] for r in cmp["rows"] if r["quantity"] == "usum_mm"}
t = cal["target"]
print(f"calibration: {cal['status']}; USUM at {t['cones']} cones, {t['force_n']:g} N: "
      f"{before[(t['cones'], t['force_n'])]:.3f} mm uncalibrated, {cal['usum_mm_in_this_run']:.3f} mm calibrated, "
      f"against the paper's {t['usum_mm']:g} mm")
shape = cmp["usum_relative_to_target"]
print("USUM relative to the 4-cone, 1 N value (ours / paper):",
      ", ".join(f"{s['cones']} cones {s['force_n']:g} N {s['ours']:.3f} / {s['paper']:.3f}" for s in shape))

# %% [markdown]
# ## Checks

# %%
solved = {n: sf.Results.read(out / f"cones_{n}" / "results.json") for n in cones}
at_1n = {n: next(r for r in res.at_forces if r.force_n == 1.0) for n, res in solved.items()}
usum = {n: r.usum_mm for n, r in at_1n.items()}
seqv = {n: (r.peak("seqv_pa", "tissue").value, r.peak("seqv_outside_rim_pa", "tissue").value) for n, r in at_1n.items()}
rows = [r for r in cmp["rows"] if r["ours"] is not None and r["rel_error"] is not None]
usum_rows = [r for r in rows if r["quantity"] == "usum_mm"]
predicted = [r for r in usum_rows if r["role"] == "predicted"]
print("USUM at 1 N by cone count, calibrated (mm):", ", ".join(f"{n}: {u:.3f}" for n, u in usum.items()))
print("USUM errors against the paper, uncalibrated:",
      ", ".join(f"{r['cones']} cones {r['force_n']:g} N {r['uncalibrated_rel_error']:+.1%}" for r in usum_rows))
print("USUM prediction errors, calibrated:",
      ", ".join(f"{r['cones']} cones {r['force_n']:g} N {r['rel_error']:+.1%}" for r in predicted))
print("tissue SEQV at 1 N, calibrated, peak / outside rims (kPa):",
      ", ".join(f"{n}: {p / 1e3:.0f} / {o / 1e3:.0f}" for n, (p, o) in seqv.items()))
for n, why in cmp["stopped"].items():  # a ramp that stopped before its last force keeps its converged part
    print(f"calibrated, {n} cone(s): {why.split(';')[0]}")
eptoeqv = [r for r in rows if r["quantity"] == "eptoeqv"]
print("EPTOEQV peak errors, uncalibrated / calibrated:",
      ", ".join(f"{r['cones']} cones {r['force_n']:g} N {r['uncalibrated_rel_error']:+.1%} / {r['rel_error']:+.1%}"
                for r in eptoeqv))

target = (cal["target"]["cones"], cal["target"]["force_n"])
assert cal["status"] == "calibrated" and abs(cal["usum_mm_in_this_run"] - cal["target"]["usum_mm"]) <= 0.05
assert cal["ci95"][0] < cal["value"] < cal["ci95"][1] < 1.0  # a softer tissue than the literature's
assert all(r["uncalibrated_rel_error"] < -0.3 for r in usum_rows)  # uncalibrated: a third too stiff everywhere
assert predicted and all(abs(r["rel_error"]) < 0.1 for r in predicted)  # calibrated: every prediction within 10 %
assert usum[max(cones)] < usum[min(cones)]  # more cones hold the thread better
assert all(o < p for p, o in seqv.values())  # the rim peak is above the stress outside the rims
assert all("gent_limit" in why for why in cmp["stopped"].values())  # only the epidermis's stretch limit stops a ramp
# the softer tissue strains more, away from the paper's strain peaks
assert all(r["rel_error"] > r["uncalibrated_rel_error"] and abs(r["rel_error"]) > abs(r["uncalibrated_rel_error"])
           for r in eptoeqv)

# %% [markdown]
# ## Conclusion
#
# * **Uncalibrated, the trends reproduce and the magnitudes do not.** Every uncalibrated USUM is
#   more than 30 % below the paper's (printed under Checks): our suture-tissue system is stiffer,
#   by an almost constant factor, and no open dimension closes that (the tissue length moves USUM by
#   at most 5 %, docs/reproduction.md).
# * **One parameter fitted on one value closes it.** The tissue scale fitted to USUM 4.0 mm at 4
#   cones, 1 N (a tissue about three times softer, its interval from the paper's 0.1 mm printing)
#   brings every predicted USUM within 10 % (printed), with the cone-count and force trends kept.
# * **That one parameter is a choice the seven USUM values cannot make.** A clamp radius moved from
#   3.6 to 6.15 mm does as well, a force scaled by 2.79 nearly (docs/reproduction.md, the three side
#   by side): they differ from each other by less than each misses the paper. They differ in the
#   tissue's stress and strain near the cones, and in whether a 1-cone pull past about 2 N reaches
#   the epidermis's stretch limit, which is what a measured curve (`suture-fem calibrate`) could
#   tell apart. Under the tissue scale the calibrated 1-cone ramp stops at the epidermis's Gent
#   limit at about 2 N (docs/reproduction.md: 2.12 N at degree 1; a stop is printed under Checks),
#   after every paper value it predicts.
# * **Stresses depend on where you look.** The tissue's SEQV peak sits at a sharp cone rim, a
#   singular point, and is above the maximum outside 0.1 mm of the rims (printed per cone count), so
#   the paper's stress values cannot be matched without knowing how ANSYS's mesh resolved the rim.
#   The calibrated strain peaks (EPTOEQV, printed) rise with the softer tissue and move away from the
#   paper's.
# * Under `CI` only 1 and 4 cones to 1 N are solved on linear elements (one prediction: 1 cone at
#   1 N); the full run (unset `CI`) fills every row of the tables above.
