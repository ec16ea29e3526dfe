"""Pictures of any field of a solved state, for notebooks: pyvista off-screen renders on matplotlib axes.

The public helpers (``import suture_fem as sf``)::

    grid = sf.field_section(model)                     # the model's current state as a full section (mm)
    fig = sf.field_panels([grid_1n, grid_4n], ["1 N", "4 N"], "von_mises_kpa", "SEQV (kPa)",
                          LogNorm(1e-1, 1e3), tissue_only=True)
    fig = sf.plot_field(model, "usum_mm", png="out/usum.png")   # one panel of the current state

:func:`field_section` mirrors the half-section (``plots.field_grid``) about the axis into a full
section, z horizontal with the pulled end on the right, on the deformed shape at true scale; its point
data are ``u_mm`` and ``usum_mm``, its cell data ``region`` (the cell tags), ``von_mises_pa``,
``von_mises_kpa`` and ``eptoeqv``. pyvista renders with a parallel camera framed on known bounds, so
the image sits on matplotlib axes with its extent in mm: labelled axes and a colour bar with units
come from matplotlib. The figures are pyplot figures (a notebook shows them with ``plt.show()``).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem import plots
from suture_fem.geometry import regions
from suture_fem.support.io import save_figure

#: Colour of the suture where only the tissue is coloured.
SUTURE_GREY = "#9a9a9a"


def _pyvista() -> Any:
    if not os.environ.get("DISPLAY"):  # no X server: render through EGL (Mesa) instead of trying X first
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    return plots._pyvista()


def field_section(state: Any, deformed: bool = True) -> Any:
    """The solved state as a full section in mm (a pyvista grid; None on ranks other than 0).

    Args:
        state: a :class:`~suture_fem.Model` (its current state: the last solve's, or a report's inside
            ``model.reports()`` / ``model.at(force_n)``; collective), its ``outputs``, or a half-section
            grid from ``plots.field_grid``.
        deformed: draw on the deformed shape (true scale); else at the undeformed positions.
    """
    pv = _pyvista()
    if isinstance(state, pv.DataSet):
        half = state
    else:
        half = plots.field_grid(state)
        if half is None:
            return None
    grid = plots.full_section(half, deformed)
    if "von_mises_pa" in grid.cell_data:
        grid.cell_data["von_mises_kpa"] = grid.cell_data["von_mises_pa"] / 1e3
    return grid


def bounds_of(*grids: Any, pad_mm: float = 0.3) -> tuple[float, float, float, float]:
    """(z0, z1, r0, r1) in mm enclosing every grid (for panels that share one view)."""
    b = np.array([g.bounds[:4] for g in grids])
    return b[:, 0].min() - pad_mm, b[:, 1].max() + pad_mm, b[:, 2].min() - pad_mm, b[:, 3].max() + pad_mm


def render(grid: Any, scalars: str, norm: Any, cmap: str, bounds: tuple[float, float, float, float],
           tissue_only: bool = False, width_px: int = 1800) -> np.ndarray:
    """RGB image, ``width_px`` wide, of ``grid`` coloured by ``scalars``, exactly covering ``bounds`` (mm).

    ``norm`` is a matplotlib Normalize (a LogNorm draws on a logarithmic scale). With ``tissue_only``
    the suture is drawn in flat grey (its stresses are 100-1000 times the tissue's and would swamp
    the colour scale).
    """
    import matplotlib.colors as mcolors

    pv = _pyvista()
    z0, z1, r0, r1 = bounds
    width, height = width_px, int(round(width_px * (r1 - r0) / (z1 - z0)))
    plotter = pv.Plotter(off_screen=True, window_size=(width, height))
    plotter.set_background("white")
    suture = np.isin(grid.cell_data["region"], regions.SUTURE)
    coloured = grid.extract_cells(np.flatnonzero(~suture)) if tissue_only else grid
    plotter.add_mesh(coloured, scalars=scalars, cmap=cmap, clim=(norm.vmin, norm.vmax),
                     log_scale=isinstance(norm, mcolors.LogNorm), show_scalar_bar=False, interpolate_before_map=True)
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


def field_panels(grids: list[Any], titles: list[str], scalars: str, label: str, norm: Any, cmap: str = "turbo",
                 tissue_only: bool = False, bounds: tuple[float, float, float, float] | None = None,
                 xlabel: str = "z (mm), deformed shape; the thread is pulled toward +z", width_in: float = 11.0) -> Any:
    """A pyplot figure: one panel per grid (from :func:`field_section`), stacked, on one view and colour scale.

    ``bounds`` in mm default to all of every grid; ``norm`` is the colour scale, ``label`` the colour bar's.
    """
    import matplotlib.pyplot as plt

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


#: Colour-bar labels of the fields a section carries.
LABELS = {"usum_mm": "USUM, |u| (mm)", "von_mises_kpa": "von Mises stress (kPa)", "eptoeqv": "EPTOEQV (-)"}


def plot_field(model: Any, scalars: str = "usum_mm", title: str = "", norm: Any = None, cmap: str = "turbo",
               tissue_only: bool = False, png: str | Path | None = None) -> Any:
    """One field of the model's current state (see :func:`field_section`) in one panel; a pyplot figure.

    ``norm`` defaults to 0 to the field's maximum (of the tissue alone with ``tissue_only``); with
    ``png`` the figure is also written there. Collective; the figure is None on ranks other than 0.
    """
    import matplotlib.colors as mcolors

    grid = field_section(model)
    if grid is None:
        return None
    if norm is None:
        values = grid.point_data[scalars] if scalars in grid.point_data else grid.cell_data[scalars]
        if tissue_only and scalars in grid.cell_data:
            values = values[~np.isin(grid.cell_data["region"], regions.SUTURE)]
        norm = mcolors.Normalize(0.0, float(np.max(values)))
    fig = field_panels([grid], [title], scalars, LABELS.get(scalars, scalars), norm, cmap, tissue_only)
    if png is not None:
        save_figure(fig, png, dpi=130, bbox_inches="tight")
    return fig
