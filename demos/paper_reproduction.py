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
# 2. calibrate at most one remaining dimension against one value, USUM = 4.0 mm at 4 cones, 1 N;
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
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, display
from mpi4py import MPI

from suture_fem.pipeline import load_scene
from suture_fem.studies import reproduce as rp
from suture_fem.support.logging import setup_logging

CI = bool(os.environ.get("CI"))  # CI runs every demo on a coarser discretisation
comm = MPI.COMM_WORLD
setup_logging(comm)

# %% [markdown]
# ## Solve 1-4 cones and compare
#
# `rp.reproduce` is what `suture-fem reproduce` runs: one ramp per cone count, `comparison.json`,
# `comparison.md` and the figures in the output folder. The full run (degree 2, 1-4 cones to 4 N)
# takes about 5 min on 2 cores; under `CI` this notebook solves a reduced version (linear elements,
# 1 and 4 cones, to 2 N), whose missing values show as "-" below.

# %%
if CI:
    overrides = ["mesh.degree=1", "loading.force_n=2.0", "loading.report_forces_n=[1.0]",
                 "solver.initial_step=0.05", "solver.max_step=0.25"]
    cones = (1, 4)
else:
    overrides, cones = [], rp.CONES
scene = load_scene(rp.SCENE, overrides)
out = Path("out/paper_reproduction")
cmp = rp.reproduce(scene, out, comm, cones=cones, calibrate_key="none")  # every value a prediction (below)
print(f"{cmp['run']['dofs']}; {cmp['run']['wall_time_s']:.0f} s")

# %% [markdown]
# ## Tables 1 and 2, side by side
#
# Every value of the paper with ours and the relative error; "role" says whether it was the
# calibration target, a prediction or not used (Table 1 prints 23549 kPa for SEQV at 4 cones, 1 N,
# ten times the trend of its neighbours: a typo).

# %%
cmp = json.loads((out / "comparison.json").read_text())
unit = {"usum_mm": ("USUM (mm)", 1.0), "seqv_pa": ("SEQV (kPa)", 1e-3), "eptoeqv": ("EPTOEQV", 1.0)}


def fmt(v, scale, pct=False):
    if v is None:
        return "-"
    return f"{v:+.1%}" if pct else f"{v * scale:.4g}"


print(f"{'source':8} {'cones':>5} {'F (N)':>5} {'quantity':11} {'paper':>8} {'ours':>8} {'error':>8} "
      f"{'outside rims':>12} {'error':>8}  role")
for r in cmp["rows"]:
    name, s = unit[r["quantity"]]
    print(f"{r['source']:8} {r['cones']:5d} {r['force_n']:5g} {name:11} {r['paper'] * s:8.4g} {fmt(r['ours'], s):>8} "
          f"{fmt(r['rel_error'], s, True):>8} {fmt(r['ours_outside_rims'], s):>12} "
          f"{fmt(r['rel_error_outside_rims'], s, True):>8}  {r['role']}")

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
# The curves are every converged load step of each ramp; the squares are the paper's USUM values.
# The contour pictures show the half-section mirrored into the full section on the deformed shape,
# in bands of one colour scale shared by every panel.

# %%
fd = {n: np.array(json.loads((out / f"cones_{n}" / "results.json").read_text())["force_displacement"])
      for n in cones}
fig, ax = plt.subplots(figsize=(7, 4.3), layout="constrained")
for i, n in enumerate(cones):
    colour = plt.cm.viridis(0.85 * i / max(len(cones) - 1, 1))
    ax.plot(fd[n][:, 1], fd[n][:, 0], ".-", color=colour, label=f"{n} cone{'s' if n > 1 else ''}, suture_fem")
    paper = np.array([[p.force_n, p.value] for p in rp.PAPER if p.quantity == "usum_mm" and p.cones == n])
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
# `suture-fem reproduce` calibrates ONE parameter on ONE paper value (USUM 4.0 mm at 4 cones, 1 N) by
# default, `materials.tissue_scale` (every tissue constant times one factor), then predicts every
# other value (`--calibrate KEY` chooses another, `--calibrate none` nothing). This notebook solves
# the uncalibrated scene, to show the gap the calibration has to close; `docs/reproduction.md` has
# the calibrated runs side by side (degree 1): tissue_scale 0.311 puts all six predicted USUM values
# within 10 %, a force scale of 2.79 five of them within 3 % and the 1-cone value at -14 %. Seven
# numbers barely tell such global scalings apart. Below, the gap to the target of this run.

# %%
cal = cmp["calibration"]
usum_target = cal["usum_mm_in_this_run"]
print(f"calibration: {cal['status']}; USUM at {cal['target']['cones']} cones, {cal['target']['force_n']:g} N: "
      f"{usum_target:.3f} mm against the paper's {cal['target']['usum_mm']:g} mm "
      f"({usum_target / cal['target']['usum_mm'] - 1:+.1%})")
shape = cmp["usum_relative_to_target"]
print("USUM relative to the 4-cone, 1 N value (ours / paper):",
      ", ".join(f"{s['cones']} cones {s['force_n']:g} N {s['ours']:.3f} / {s['paper']:.3f}" for s in shape))

# %% [markdown]
# ## Checks

# %%
solved = {n: json.loads((out / f"cones_{n}" / "results.json").read_text()) for n in cones}
usum = {n: rp.ours(solved, n, 1.0, "usum_mm")[0] for n in cones}
seqv = {n: rp.ours(solved, n, 1.0, "seqv_pa") for n in cones}
rows = [r for r in cmp["rows"] if r["ours"] is not None and r["rel_error"] is not None]
usum_err = [r["rel_error"] for r in rows if r["quantity"] == "usum_mm"]
print("USUM at 1 N by cone count (mm):", ", ".join(f"{n}: {u:.3f}" for n, u in usum.items()))
print("tissue SEQV at 1 N, peak / outside rims (kPa):",
      ", ".join(f"{n}: {p / 1e3:.0f} / {o / 1e3:.0f}" for n, (p, o) in seqv.items()))
print("relative USUM errors against the paper:", ", ".join(f"{e:+.1%}" for e in usum_err))
print(f"largest prediction error: {cmp['largest_prediction_error']['rel_error']:+.1%} "
      f"({cmp['largest_prediction_error']['source']}, {cmp['largest_prediction_error']['quantity']}, "
      f"{cmp['largest_prediction_error']['cones']} cones, {cmp['largest_prediction_error']['force_n']:g} N)")

seqv_rows = [r for r in rows if r["quantity"] == "seqv_pa"]
eptoeqv_err = [e for r in rows if r["quantity"] == "eptoeqv" for e in (r["rel_error"], r["rel_error_outside_rims"])]
print("paper's SEQV between our outside-rims value and our peak:",
      ", ".join(f"{r['cones']} cones {r['force_n']:g} N: {r['ours_outside_rims'] / 1e3:.0f} < {r['paper'] / 1e3:.0f} < "
                f"{r['ours'] / 1e3:.0f} kPa" for r in seqv_rows))
print(f"largest |EPTOEQV error| (peak and outside rims): {max(map(abs, eptoeqv_err)):.1%}")

assert not cmp["stopped"]
assert cal["status"] == "not calibrated" and usum_target < cal["target"]["usum_mm"]
assert all(e < 0 for e in usum_err)  # ours is stiffer than the paper's at every solved USUM
assert usum[max(cones)] < usum[min(cones)]  # more cones hold the thread better
assert all(o < p for p, o in seqv.values())  # the rim peak is above the stress outside the rims
assert all(r["ours_outside_rims"] < r["paper"] < r["ours"] for r in seqv_rows)
assert max(map(abs, eptoeqv_err)) < 0.25

# %% [markdown]
# ## Conclusion
#
# * **The trends reproduce, the magnitudes do not.** USUM falls with the number of cones (printed
#   under Checks), as in the paper; but every USUM of ours is below the paper's (all relative USUM
#   errors printed are negative, about a third in the full run): our suture-tissue system is stiffer.
# * **No open dimension closes that gap; one global scaling does.** The tissue length moves USUM
#   the wrong way; a tissue about three times softer (or, indistinguishably on these seven numbers,
#   a force about 2.8 times larger) brings the predictions within about 10 % (docs/reproduction.md).
#   Here nothing is calibrated and every value is a prediction (status "not calibrated" above).
# * **Stresses depend on where you look.** The tissue's SEQV peak sits at a sharp cone rim, a
#   singular point, and is above the maximum outside 0.1 mm of the rims (printed per cone count);
#   every SEQV of the paper lies between the two (printed), so its stress values cannot be matched
#   without knowing how ANSYS's mesh resolved the rim. EPTOEQV agrees better: its largest error,
#   peak or outside the rims, is printed and stays below 25 %.
# * Under `CI` only 1 and 4 cones to 2 N are solved on linear elements; the full run (unset `CI`)
#   fills every row of the tables above.
