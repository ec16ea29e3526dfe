"""Pictures of any field of a solved state for the demos, rendered off-screen with pyvista.

Not a demo (the leading underscore keeps it out of the demo glob): the demos import it from their
own folder. The grid comes from :mod:`suture_fem.plots` (``field_grid`` + ``full_section``: the
half-section mirrored about the axis into a full section, z horizontal with the pulled end on the
right, on the deformed shape at true scale). ``plots.render_usum`` draws USUM contours into PNG
files; here any point or cell field (the von Mises stress on a logarithmic scale, the tissue alone,
a zoomed frame) is drawn into a figure the notebook shows. pyvista renders with a parallel camera
framed on known bounds, so the image sits on matplotlib axes with its extent in mm: labelled axes
and a colour bar with units come from matplotlib.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

if not os.environ.get("DISPLAY"):  # no X server: render through EGL (Mesa) instead of trying X first
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

import matplotlib.colors as mcolors  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import pyvista as pv  # noqa: E402

from suture_fem import plots  # noqa: E402
from suture_fem.geometry import regions  # noqa: E402

pv.OFF_SCREEN = True
SUTURE_GREY = "#9a9a9a"


def section(outputs: Any, deformed: bool = True) -> pv.UnstructuredGrid:
    """The solved state of ``outputs`` (what run_scene's ``on_report`` hands over, or its half-section
    grid from ``plots.field_grid``) as a full section in mm: point data ``usum_mm``, cell data
    ``von_mises_kpa``, ``eptoeqv`` and ``region`` (cell tags)."""
    half = outputs if isinstance(outputs, pv.DataSet) else plots.field_grid(outputs)
    grid = plots.full_section(half, deformed)
    grid.cell_data["von_mises_kpa"] = grid.cell_data["von_mises_pa"] / 1e3
    return grid


def bounds_of(*grids: pv.DataSet, pad_mm: float = 0.3) -> tuple[float, float, float, float]:
    """(z0, z1, r0, r1) in mm enclosing every grid (for panels that share one view)."""
    b = np.array([g.bounds[:4] for g in grids])
    return b[:, 0].min() - pad_mm, b[:, 1].max() + pad_mm, b[:, 2].min() - pad_mm, b[:, 3].max() + pad_mm


def render(
    grid: pv.DataSet,
    scalars: str,
    norm: mcolors.Normalize,
    cmap: str,
    bounds: tuple[float, float, float, float],
    tissue_only: bool = False,
    width_px: int = 1800,
) -> np.ndarray:
    """RGB image, ``width_px`` wide, of ``grid`` coloured by ``scalars``, exactly covering ``bounds`` (mm).

    With ``tissue_only`` the suture is drawn in flat grey (its stresses are 100-1000 times the
    tissue's and would swamp the colour scale).
    """
    z0, z1, r0, r1 = bounds
    width, height = width_px, int(round(width_px * (r1 - r0) / (z1 - z0)))
    plotter = pv.Plotter(off_screen=True, window_size=(width, height))
    plotter.set_background("white")
    log = isinstance(norm, mcolors.LogNorm)
    suture = np.isin(grid.cell_data["region"], regions.SUTURE)
    coloured = grid.extract_cells(np.flatnonzero(~suture)) if tissue_only else grid
    plotter.add_mesh(coloured, scalars=scalars, cmap=cmap, clim=(norm.vmin, norm.vmax), log_scale=log,
                     show_scalar_bar=False, interpolate_before_map=True)
    if tissue_only:
        plotter.add_mesh(grid.extract_cells(np.flatnonzero(suture)), color=SUTURE_GREY, show_scalar_bar=False)
    plotter.enable_parallel_projection()
    centre = ((z0 + z1) / 2, (r0 + r1) / 2)
    plotter.camera.focal_point = (*centre, 0.0)
    plotter.camera.position = (*centre, 100.0)
    plotter.camera.up = (0.0, 1.0, 0.0)
    plotter.camera.parallel_scale = (r1 - r0) / 2
    plotter.camera.clipping_range = (1.0, 1000.0)
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return image


def field_panels(
    grids: list[pv.DataSet],
    titles: list[str],
    scalars: str,
    label: str,
    norm: mcolors.Normalize,
    cmap: str = "turbo",
    tissue_only: bool = False,
    bounds: tuple[float, float, float, float] | None = None,
    xlabel: str = "z (mm), deformed shape; the thread is pulled toward +z",
    width_in: float = 11.0,
) -> plt.Figure:
    """One panel per grid, stacked, on one view (``bounds`` in mm, default: all of every grid) and one
    colour scale, with a colour bar labelled ``label``."""
    bounds = bounds or bounds_of(*grids)
    aspect = (bounds[3] - bounds[2]) / (bounds[1] - bounds[0])
    fig, axes = plt.subplots(len(grids), 1, figsize=(width_in, 0.6 + len(grids) * (width_in * 0.82 * aspect + 0.45)),
                             squeeze=False, sharex=True, layout="constrained")
    for ax, grid, title in zip(axes[:, 0], grids, titles):
        ax.imshow(render(grid, scalars, norm, cmap, bounds, tissue_only), extent=bounds, interpolation="antialiased")
        ax.set_title(title, fontsize=10, loc="left")
        ax.set_ylabel("r (mm)")
    axes[-1, 0].set_xlabel(xlabel)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=axes[:, 0].tolist(), label=label,
                 fraction=0.04, pad=0.01)
    return fig
