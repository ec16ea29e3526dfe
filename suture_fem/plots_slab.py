"""Pictures of the slab (``geometry.tissue_shape = "slab"``): its skin surface and its cut through the thread.

Both are flat faces of the 3-D half model's grid (``plots.field_grid``, (x, y, z) in mm, the thread along y),
laid into a drawing plane and rendered off-screen by :func:`suture_fem.plots_fields.render` on matplotlib axes:

* the skin surface x = thread depth seen from above, coloured by its displacement along the outward normal
  (u_x, mm; negative = inward, a dimple), mirrored about the symmetry plane z = 0 into the whole skin;
* the cut through the thread's plane (the symmetry face z = 0), coloured by the tissue's von Mises stress
  (per-cell maxima, kPa, logarithmic scale), the suture in grey, undeformed positions.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from suture_fem import plots
from suture_fem.geometry import regions
from suture_fem.plots_fields import render

#: Points closer than this (mm) to a plane lie on it.
ON_PLANE_MM = 1e-6
#: The stress colour scale spans this many decades below the tissue's 99.5th percentile.
DECADES = 3.0


def _face(grid: Any, axis: int, value: float) -> Any:
    """The boundary faces of ``grid`` whose points all lie on the plane (coordinate ``axis``) = ``value``."""
    surface = plots._surface(grid)
    on = np.abs(surface.points[:, axis] - value) < ON_PLANE_MM
    return plots._surface(surface.extract_points(on, adjacent_cells=False))


def _in_plane(face: Any, across: int) -> Any:
    """``face`` laid in the drawing plane: y (along the thread) to the right, coordinate ``across`` upward."""
    out = face.copy()
    out.points = np.column_stack([face.points[:, 1], face.points[:, across], np.zeros(face.n_points)])
    return out


def _figure(bounds: tuple[float, float, float, float]) -> Any:
    """A figure 10 inches wide for a panel of these bounds (mm), at most 9 inches tall."""
    aspect = (bounds[3] - bounds[2]) / (bounds[1] - bounds[0])
    return plots.file_figure(figsize=(10, min(10 * aspect + 1.2, 9.0)), layout="constrained")


def _panel(fig: Any, image: np.ndarray, bounds: tuple[float, float, float, float], norm: Any, cmap: str,
           title: str, ylabel: str, label: str) -> None:
    import matplotlib.cm

    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(image, extent=bounds, interpolation="antialiased")
    ax.set_title(title, fontsize=10, loc="left")
    ax.set_xlabel("y (mm), along the thread; pulled toward +y")
    ax.set_ylabel(ylabel)
    fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=label, fraction=0.04, pad=0.01)


def render_skin(grid: Any, png: str | Path, title: str = "") -> Path:
    """The skin surface coloured by its normal displacement (mm), the whole skin (both halves), from above."""
    import matplotlib.colors as mcolors

    half = _face(grid, 0, float(grid.bounds[1]))  # the skin: the largest x
    half.point_data["u_n_mm"] = half.point_data["u_mm"][:, 0]
    mirrored = half.copy()
    mirrored.points = half.points * np.array([1.0, 1.0, -1.0])
    skin = _in_plane(half.merge(mirrored), 2)
    skin.cell_data["region"] = np.full(skin.n_cells, int(regions.Cell.EPIDERMIS))
    reach = float(np.abs(skin.point_data["u_n_mm"]).max()) or 1.0
    norm = mcolors.Normalize(-reach, reach)
    bounds = tuple(float(b) for b in skin.bounds[:4])
    fig = _figure(bounds)
    _panel(fig, render(skin, "u_n_mm", norm, "RdBu", bounds), bounds, norm, "RdBu",
           title or "skin surface: displacement along the outward normal", "z (mm), across the thread",
           "u.n (mm): < 0 inward (dimple), > 0 outward")
    return plots._save(fig, png)


def render_cut(grid: Any, png: str | Path, title: str = "") -> Path:
    """The symmetry face z = 0 through the thread: the tissue's von Mises stress (kPa, log scale), suture grey."""
    import matplotlib.colors as mcolors

    cut = _in_plane(_face(grid, 2, 0.0), 0)
    cut.cell_data["von_mises_kpa"] = cut.cell_data["von_mises_pa"] / 1e3
    tissue = cut.cell_data["von_mises_kpa"][~np.isin(cut.cell_data["region"], regions.SUTURE)]
    top = float(np.percentile(tissue, 99.5)) if len(tissue) else 1.0
    norm = mcolors.LogNorm(top / 10**DECADES, top)
    bounds = tuple(float(b) for b in cut.bounds[:4])
    fig = _figure(bounds)
    _panel(fig, render(cut, "von_mises_kpa", norm, plots.CMAP, bounds, tissue_only=True), bounds, norm, plots.CMAP,
           title or "cut through the thread (z = 0): tissue von Mises stress, suture grey",
           "x (mm), the skin at the top", "von Mises stress (kPa), cell maxima")
    return plots._save(fig, png)
