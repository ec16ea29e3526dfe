"""Pictures of solved scenes: pyvista off-screen renders of the section, matplotlib curves.

The small API (used by ``suture-fem reproduce`` and meant for the demos):

    grid = field_grid(outputs)                  # collective: the solved state as a pyvista grid (rank 0)
    save_grid(grid, "fields/cones4_1N.vtu")     # .vtu, readable by ParaView and load_grid
    render_usum([grid_a, "b.vtu"], "usum.png", titles=["1 N", "4 N"])
    plot_force_displacement({"4 cones": [[0, 0], [1, 2.6], ...]}, "fd.png", reference={"4 cones": [[1, 4.0]]})
    plot_trends(x, {"USUM (mm)": {"ours": [...], "paper": [...]}, ...}, "trends.png", xlabel="cones")

:func:`suture_fem.interface_plot.plot_interface` draws the contact pressure and shear along each cone
and the thread (one report's ``interface``).

A grid holds the axisymmetric half-section in millimetres (x = z along the thread, y = r), with the
point data ``u_mm`` (displacement vector, 3 components with a zero third one) and ``usum_mm``
(its magnitude), and the cell data ``region`` (the mesh cell tags) and, when the grid is built from
an :class:`~suture_fem.outputs.Outputs`, ``von_mises_pa`` and ``eptoeqv`` (maxima per cell).
:func:`render_usum` mirrors it (r -> -r) into the full longitudinal section like the paper's
Figures 2 and 3, draws every panel on one colour scale in bands, and adds a labelled colour bar.
A 3-D model's grid is its half model in its own (x, y, z) mm (:mod:`suture_fem.plots_slab` draws the slab's).
Rendering is off-screen (no X server needed); pyvista draws the field, matplotlib lays out the
panels, axes in mm and the colour bar.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.geometry import regions

#: Colour map of the contour pictures, drawn in bands (as ANSYS does) of a round step.
CMAP = "turbo"
#: Pixels per millimetre of the pyvista renders.
PIXELS_PER_MM = 60


def _pyvista() -> Any:
    import pyvista

    pyvista.OFF_SCREEN = True
    return pyvista


def file_figure(**kwargs: Any) -> Any:
    """A matplotlib Figure drawn for a file only, without pyplot.

    The process's backend (a notebook's inline backend, an interactive window) is left alone, and the
    figure is never shown or kept open.
    """
    from matplotlib.figure import Figure

    return Figure(**kwargs)


def _cmap(name: str) -> Any:
    import matplotlib

    return matplotlib.colormaps[name]


# --------------------------------------------------------------------------------------------------
# Grids


def field_grid(state: Any) -> Any:
    """The solved state as a pyvista UnstructuredGrid on rank 0 (None on other ranks); collective.

    Args:
        state: a :class:`~suture_fem.Model` (its current state) or its
            :class:`~suture_fem.outputs.Outputs` (adds per-cell von Mises stress and equivalent strain), or a
            :class:`~suture_fem.physics.Physics`.
    """
    from suture_fem.support import compat  # dolfinx: imported when a grid is first built

    state = getattr(state, "outputs", state)  # a Model: its outputs
    outputs = state if hasattr(state, "physics") else None
    physics = outputs.physics if outputs is not None else state
    V, u, comm = physics.V, physics.u, physics.comm
    cells, types, x = compat.vtk_mesh(V)
    num_owned = len(types)
    nodes_per_cell = len(cells) // max(num_owned, 1)
    index_map = V.dofmap.index_map
    # global node numbers, so that nodes shared between ranks become one point of the gathered grid
    global_nodes = index_map.local_to_global(np.arange(len(x), dtype=np.int32))
    connectivity = cells.reshape(-1, nodes_per_cell).astype(np.int64) if num_owned else np.zeros((0, 1), np.int64)
    connectivity[:, 1:] = global_nodes[connectivity[:, 1:]]
    gdim = physics.mesh.geometry.dim
    u_mm = u.x.array.reshape(-1, gdim)[: len(x)] / regions.MM
    tags = np.zeros(num_owned, dtype=np.int32)
    ct = physics.tagged.cell_tags
    in_range = ct.indices < num_owned
    tags[ct.indices[in_range]] = ct.values[in_range]
    cell_data = {"region": tags}
    if outputs is not None and outputs.tensor_exprs:
        cell_data.update({k: v[:num_owned] for k, v in outputs.cell_maxima().items()})
    parts = comm.gather((connectivity, types, global_nodes, x[:, :gdim] / regions.MM, u_mm, cell_data), root=0)
    if comm.rank != 0:
        return None
    pv = _pyvista()
    rz = np.zeros((index_map.size_global, gdim))
    u2 = np.zeros((index_map.size_global, gdim))
    for _, _, g, p, d, _ in parts:
        rz[g], u2[g] = p, d
    owned = [part for part in parts if len(part[1])]
    all_cells = np.concatenate([part[0].ravel() for part in owned])
    all_types = np.concatenate([part[1] for part in owned]).astype(np.uint8)
    if gdim == 3:  # the 3-D half model as it is: (x, y, z) mm, the thread along y
        points, vectors = rz, u2
    else:  # x = z (along the thread), y = r: the thread lies horizontally in the pictures.
        points = np.column_stack([rz[:, 1], rz[:, 0], np.zeros(len(rz))])
        vectors = np.column_stack([u2[:, 1], u2[:, 0], np.zeros(len(u2))])
    grid = pv.UnstructuredGrid(all_cells, all_types, points)
    grid.point_data["u_mm"] = vectors
    grid.point_data["usum_mm"] = np.linalg.norm(u2, axis=1)
    for k in cell_data:
        grid.cell_data[k] = np.concatenate([part[5][k] for part in owned])
    return grid


def save_grid(grid: Any, path: str | Path) -> Path:
    """Write a grid to ``.vtu`` atomically (temporary name in the same folder, then rename)."""
    from suture_fem.support.io import commit, temporary_name

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = temporary_name(path, path.suffix)  # VTK picks the format by the suffix
    try:
        grid.save(str(tmp))
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return commit(tmp, path)


def load_grid(path: str | Path) -> Any:
    """Read a grid written by :func:`save_grid`."""
    return _pyvista().read(str(path))


def nice_levels(lo: float, hi: float, bands: int = 10) -> np.ndarray:
    """Band boundaries from lo up to at least hi, in a round step (1, 2, 2.5 or 5 times a power of 10)."""
    span = max(hi - lo, 1e-12)
    raw = span / bands
    power = 10.0 ** np.floor(np.log10(raw))
    step = next(m * power for m in (1.0, 2.0, 2.5, 5.0, 10.0) if m * power >= raw * (1 - 1e-9))
    n = int(np.ceil(span / step - 1e-9))
    return lo + step * np.arange(n + 1)


def _surface(grid: Any) -> Any:
    """Surface of a grid with its curved (Lagrange) cells subdivided; pyvista >= 0.47 wants the algorithm named."""
    import inspect

    kwargs = {"nonlinear_subdivision": 3}
    if "algorithm" in inspect.signature(grid.extract_surface).parameters:
        kwargs["algorithm"] = "dataset_surface"
    return grid.extract_surface(**kwargs)


def _as_grid(item: Any) -> Any:
    return load_grid(item) if isinstance(item, (str, Path)) else item


def full_section(grid: Any, deformed: bool = True) -> Any:
    """The half-section and its mirror image r -> -r in one grid (on the deformed shape, true scale)."""
    half = grid.copy()
    if deformed:
        half.points = half.points + half.point_data["u_mm"]
    mirror = half.copy()
    mirror.points = mirror.points * np.array([1.0, -1.0, 1.0])
    return half.merge(mirror, merge_points=False)


# --------------------------------------------------------------------------------------------------
# Contour pictures


def _render_panel(grid: Any, bounds: tuple[float, float, float, float], clim: tuple[float, float], bands: int,
                  outline_regions: Iterable[tuple[int, ...]]) -> np.ndarray:
    """One off-screen pyvista render of the full section, framed exactly on ``bounds`` (mm)."""
    pv = _pyvista()
    x0, x1, y0, y1 = bounds
    width = int(round((x1 - x0) * PIXELS_PER_MM))
    height = int(round((y1 - y0) * PIXELS_PER_MM))
    plotter = pv.Plotter(off_screen=True, window_size=(width, height))
    plotter.set_background("white")
    plotter.add_mesh(grid, scalars="usum_mm", cmap=CMAP, clim=clim, n_colors=bands, show_scalar_bar=False,
                     lighting=False)
    regions = grid.cell_data["region"]
    for tags in outline_regions:
        sub = grid.extract_cells(np.flatnonzero(np.isin(regions, tags)))
        if sub.n_cells:
            edges = _surface(sub).extract_feature_edges(
                boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False)
            plotter.add_mesh(edges, color="black", line_width=1.2)
    plotter.enable_parallel_projection()
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    plotter.camera.position = (cx, cy, 100.0)
    plotter.camera.focal_point = (cx, cy, 0.0)
    plotter.camera.up = (0.0, 1.0, 0.0)
    plotter.camera.parallel_scale = 0.5 * (y1 - y0)
    image = plotter.screenshot(return_img=True)
    plotter.close()
    return image


def render_usum(
    panels: Sequence[Any],
    png: str | Path,
    titles: Sequence[str] | None = None,
    clim: tuple[float, float] | None = None,
    deformed: bool = True,
    suptitle: str | None = None,
) -> Path:
    """USUM contours of several solved states, one panel each, on one colour scale; writes a PNG.

    Args:
        panels: grids from :func:`field_grid` or paths of ``.vtu`` files written by :func:`save_grid`.
        png: output path.
        titles: one title per panel.
        clim: colour range in mm (default: 0 to the largest USUM of all panels); the top is rounded up
            so that the bands have a round width.
        deformed: draw on the deformed shape (true scale), as ANSYS contour plots do.
        suptitle: title of the whole figure.

    Each half-section is mirrored (r -> -r) into the full longitudinal section; the suture (thread
    and cones) and the tissue layer interfaces are outlined in black; the colour bar is in mm.
    """
    from matplotlib import cm, colors

    grids = [_as_grid(p) for p in panels]
    titles = list(titles) if titles is not None else [""] * len(grids)
    top = clim[1] if clim is not None else max(float(np.max(g.point_data["usum_mm"])) for g in grids)
    boundaries = nice_levels(clim[0] if clim is not None else 0.0, top)
    clim = (float(boundaries[0]), float(boundaries[-1]))
    sections = [full_section(g, deformed) for g in grids]
    lo = np.min([s.bounds[0::2] for s in sections], axis=0)
    hi = np.max([s.bounds[1::2] for s in sections], axis=0)
    pad = 0.02 * (hi[0] - lo[0])
    bounds = (lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad)
    outlines = (regions.SUTURE, (regions.Cell.HYPODERMIS,), (regions.Cell.EPIDERMIS,))
    images = [_render_panel(s, bounds, clim, len(boundaries) - 1, outlines) for s in sections]

    aspect = (bounds[3] - bounds[2]) / (bounds[1] - bounds[0])
    fig_w = 9.0
    fig = file_figure(figsize=(fig_w, len(images) * (0.8 * fig_w * aspect + 0.45) + 0.6), layout="constrained")
    axes = fig.subplots(len(images), 1, squeeze=False)[:, 0]
    for ax, img, title in zip(axes, images, titles):
        ax.imshow(img, extent=bounds, origin="upper", interpolation="antialiased")
        ax.set_title(title, fontsize=10, loc="left")
        ax.set_ylabel("r (mm)")
        ax.set_xlim(bounds[0], bounds[1])
        ax.set_ylim(bounds[2], bounds[3])
    axes[-1].set_xlabel("z (mm) along the thread; the pulled end is on the right")
    norm = colors.BoundaryNorm(boundaries, _cmap(CMAP).N)
    bar = fig.colorbar(cm.ScalarMappable(norm=norm, cmap=CMAP), ax=list(axes), ticks=boundaries,
                       format="%g", shrink=0.9, aspect=30)
    bar.set_label("USUM, displacement magnitude (mm)")
    if suptitle:
        fig.suptitle(suptitle, fontsize=11)
    return _save(fig, png)


def _save(fig: Any, png: str | Path) -> Path:
    from suture_fem.support.io import save_figure

    return save_figure(fig, png, dpi=130, bbox_inches="tight")


# --------------------------------------------------------------------------------------------------
# Curves


def plot_force_displacement(
    curves: Mapping[str, Sequence[Sequence[float]]],
    png: str | Path,
    reference: Mapping[str, Sequence[Sequence[float]]] | None = None,
    reference_name: str = "paper",
    title: str = "Force against thread end displacement",
) -> Path:
    """Force-displacement curves (the paper's Figure 4 axes: displacement in mm across, force in N up).

    Args:
        curves: label -> [[force_n, displacement_mm], ...] (e.g. results.json ``force_displacement``).
        png: output path.
        reference: label -> [[force_n, displacement_mm], ...], drawn as open markers in the colour of
            the curve with the same label (black when there is none), e.g. the paper's values.
        reference_name: what the reference is, for the legend.
        title: the figure's title.
    """
    fig = file_figure(figsize=(8.2, 4.8), layout="constrained")
    ax = fig.subplots()
    cmap = _cmap("viridis")
    colour = {label: cmap(0.85 * i / max(len(curves) - 1, 1)) for i, label in enumerate(curves)}
    for label, pts in curves.items():
        a = np.asarray(pts, dtype=float).reshape(-1, 2)
        ax.plot(a[:, 1], a[:, 0], "-", marker=".", ms=4, color=colour[label], label=label)
    for label, pts in (reference or {}).items():
        a = np.asarray(pts, dtype=float).reshape(-1, 2)
        ax.plot(a[:, 1], a[:, 0], ls="none", marker="s", ms=7, mfc="none", mew=1.6,
                color=colour.get(label, "black"), label=f"{label}, {reference_name}")
    ax.set_xlabel("thread end displacement (mm)")
    ax.set_ylabel("pulling force (N)")
    ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.set_title(title, fontsize=11)
    return _save(fig, png)


def plot_trends(
    x: Sequence[float],
    quantities: Mapping[str, Mapping[str, Sequence[float | None]]],
    png: str | Path,
    xlabel: str,
    title: str | None = None,
    log_panels: Iterable[str] = (),
) -> Path:
    """Several quantities against one variable, one panel each, ours and the paper's on each panel.

    Args:
        x: the variable (cone counts or forces).
        quantities: panel label -> {series label -> values at x (None where there is no value)}; series
            whose label starts with "paper" are drawn as reference markers, the others as lines.
        png: output path.
        xlabel: label of the x axis.
        log_panels: panel labels drawn with a logarithmic y axis (values spanning decades).
        title: the figure's title.
    """
    fig = file_figure(figsize=(4.2 * len(quantities), 3.8), layout="constrained")
    axes = fig.subplots(1, len(quantities), squeeze=False)
    ours_styles = [dict(marker="o", ls="-", color="tab:blue"), dict(marker="o", ls="--", mfc="none", color="tab:blue"),
                   dict(marker="^", ls=":", color="tab:orange"), dict(marker="v", ls="-.", color="tab:green")]
    reference_style = dict(marker="s", ls="none", ms=7, mfc="none", mew=1.5, color="black")
    xs = np.asarray(x, dtype=float)
    for ax, (label, series) in zip(axes[0], quantities.items()):
        ours = [name for name in series if not name.startswith("paper")]
        for name, values in series.items():
            v = np.array([np.nan if y is None else y for y in values], dtype=float)
            ok = np.isfinite(v)
            style = reference_style if name not in ours else ours_styles[ours.index(name) % len(ours_styles)]
            if ok.any():
                ax.plot(xs[ok], v[ok], label=name, **style)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(label)
        ax.set_xticks(xs)
        if label in log_panels:
            from matplotlib import ticker

            ax.set_yscale("log")
            ax.yaxis.set_major_locator(ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
            ax.yaxis.set_minor_formatter(ticker.NullFormatter())
        else:
            ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    if title:
        fig.suptitle(title, fontsize=12)
    return _save(fig, png)

