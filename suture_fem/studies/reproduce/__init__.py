"""``suture-fem reproduce``: the paper's Tables 1 and 2 and Figures 2-4 in one command.

The honest protocol (docs/reproduction.md):

1. Every dimension the paper leaves open is fixed first from public data (``suture_fem/scene/defaults.toml``
   names each source: cone spacing 6.25 mm from the product's entry-to-exit lengths, thread radius
   0.125 mm from USP 3-0).
2. ONE parameter is calibrated against ONE value, USUM = 4.0 mm for 4 cones at 1 N (:func:`calibrate`:
   ``suture-fem calibrate``'s least squares; default :data:`DEFAULT`, ``materials.tissue_scale``;
   ``--calibrate KEY`` another, ``--calibrate none`` nothing), with its 95 % interval from the
   paper's printed precision.
3. Every other value of the paper is a prediction, reported with its relative error, next to the
   uncalibrated scene's value.

One load ramp per cone count (1, 2, 3, 4 cones to 4 N, reported at 1, 2, 3, 4 N). The command
writes, under DIR (default ``results/reproduce``):

* ``comparison.json`` and ``comparison.md``: every entry of Tables 1 and 2 (and the USUM values of
  section 2.2), the paper's value, ours, the relative error and its role (calibration target,
  prediction, or not used: the typo 23549 kPa of Table 1); the paper's trends and whether ours
  show them;
* ``cones_N/results.json`` for each cone count, ``fields/conesN_FN.vtu`` (pyvista/ParaView);
* ``fig2_usum_4_cones.png``, ``fig3_usum_1_n.png`` (USUM contours like the paper's Figures 2 and
  3, on one colour scale), ``fig4_force_displacement.png``, ``trends_vs_cones.png``,
  ``trends_vs_force.png``.

The paper's SEQV values (0.2-2.5 MPa) are tissue stresses: the overall maximum of our model is the
axial stress of the thread (about 20 MPa per newton), so SEQV is compared with the tissue maximum
``regions.tissue.seqv_pa``; the maximum outside ``output.rim_exclusion_mm`` of every cone corner
(not singular, unlike the peak at a sharp rim, though still mesh-dependent at the meshes used here)
is reported next to it, and likewise for EPTOEQV.

The modules, in the order the study runs: ``paper`` (the paper's values and the cases), ``rungs`` (the
mesh of each cone count and USUM's estimated discretisation error on it), ``calibration`` (one
parameter fitted to one value), ``solve`` (one ramp per cone count), ``jobs`` (those ramps in parallel
processes, ``--jobs``), ``compare`` (ours against
the paper, the trends), ``report`` (comparison.md), ``figures`` (the pictures), ``study`` (the entry,
:func:`reproduce`). The names below are the study's public face.
"""

from suture_fem.studies.paper import CONES, FORCES_N, PAPER, SCENE, TARGET, PaperValue
from suture_fem.studies.reproduce.calibration import CANDIDATES, DEFAULT, calibrate
from suture_fem.studies.reproduce.compare import comparison, ours, trends
from suture_fem.studies.reproduce.study import reproduce

__all__ = ["CANDIDATES", "CONES", "DEFAULT", "FORCES_N", "PAPER", "SCENE", "TARGET", "PaperValue", "calibrate",
           "comparison", "ours", "reproduce", "trends"]
