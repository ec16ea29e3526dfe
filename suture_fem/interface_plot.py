"""The picture of what the suture passes to the tissue: pressure and shear along each cone and the thread.

    plot_interface(results["at_forces"][-1], "interface.png")

(:mod:`suture_fem.outputs.interface` computes the profiles; this draws one report's.)
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from suture_fem.plots import _cmap, _save, file_figure


def plot_interface(record: Mapping[str, Any], png: str | Path, title: str = "") -> Path:
    """The contact pressure and shear along each cone and the bare thread against arc length (one report).

    Args:
        record: one report of results.json (``at_forces[i]``) with ``interface`` and ``load_share_n``.
        png: output path.
        title: the figure's title (default: the force and the interface model).
    """
    interface = record["interface"]
    profiles = interface["profiles"]
    shares = record.get("load_share_n", {})
    fig = file_figure(figsize=(9.0, 6.4), layout="constrained")
    (ax_cp, ax_cs), (ax_tp, ax_ts) = fig.subplots(2, 2)
    cones = [name for name in profiles if name.startswith("cone_")]
    cmap = _cmap("viridis")
    for i, name in enumerate(cones):
        prof = profiles[name]
        colour = cmap(0.85 * i / max(len(cones) - 1, 1))
        label = f"{name.replace('_', ' ')}: {shares.get(name, float('nan')):.3g} N"
        s = np.asarray(prof["s_mm"], dtype=float)
        ax_cp.plot(s, np.asarray(prof["pressure_pa"], dtype=float) / 1e3, "-", color=colour, lw=1.2, label=label)
        ax_cs.plot(s, np.asarray(prof["shear_pa"], dtype=float) / 1e3, "-", color=colour, lw=1.2, label=label)
    if "cone_contact" in interface:
        _cone_contact(ax_cp, ax_cs, interface, cones, cmap)
    thread = profiles.get("thread", {})
    z = np.asarray(thread.get("s_mm", []), dtype=float)
    label = f"thread: {shares.get('thread', float('nan')):.3g} N"
    ax_tp.plot(z, np.asarray(thread.get("pressure_pa", []), dtype=float) / 1e3, ".", ms=2.5, color="C3", label=label)
    ax_ts.plot(z, np.asarray(thread.get("shear_pa", []), dtype=float) / 1e3, ".", ms=2.5, color="C3", label=label)
    for lo, hi in interface.get("separated_mm", []):  # the gap map: where the tissue has left the thread
        for ax in (ax_tp, ax_ts):
            ax.axvspan(lo, hi, color="0.85", lw=0, zorder=0)
    if interface.get("separated_mm"):
        ax_tp.plot([], [], "s", color="0.85", label="tissue off the thread")
    if "slip_mm" in thread:
        twin = ax_ts.twinx()
        twin.plot(z, np.asarray([np.nan if v is None else v for v in thread["slip_mm"]], dtype=float), "-",
                  color="C0", lw=1.0, label="slip")
        twin.set_ylabel("slip (mm)", color="C0")
    ax_cp.set_ylabel("contact pressure (kPa)")
    ax_cs.set_ylabel("shear (kPa)")
    ax_tp.set_ylabel("contact pressure (kPa)")
    ax_ts.set_ylabel("shear (kPa)")
    ax_tp.set_xlabel("z along the thread (mm)")
    ax_ts.set_xlabel("z along the thread (mm)")
    ax_cp.set_title("cones: from the apex on the thread, round the outside", fontsize=9)
    ax_cs.set_title("(and, hollow, the inside) back to the thread", fontsize=9)
    for ax in (ax_cp, ax_cs, ax_tp, ax_ts):
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="0.5", lw=0.6)
    ax_cs.set_xlabel("arc length along the cone (mm)")
    ax_cp.set_xlabel("arc length along the cone (mm)")
    if cones:
        ax_cp.legend(fontsize=7)
    ax_tp.legend(fontsize=7)
    fig.suptitle(title or (f"Interface at F = {record['force_n']:g} N: thread {interface['thread']}, "
                           f"cones {interface['cones']}"), fontsize=11)
    return _save(fig, png)


def _cone_contact(ax_p: Any, ax_s: Any, interface: Mapping[str, Any], cones: list[str], cmap: Any) -> None:
    """The cones' gap map (where the tissue has lifted off, shaded in each cone's colour) and their slip."""
    twin = ax_s.twinx()
    for i, name in enumerate(cones):
        colour = cmap(0.85 * i / max(len(cones) - 1, 1))
        for lo, hi in interface["cone_contact"]["cones"].get(name, {}).get("separated_s_mm", []):
            ax_p.axvspan(lo, hi, color=colour, alpha=0.12, lw=0, zorder=0)
        prof = interface["profiles"][name]
        if "slip_mm" in prof:
            slip = np.asarray([np.nan if v is None else v for v in prof["slip_mm"]], dtype=float)
            twin.plot(np.asarray(prof["s_mm"], dtype=float), slip, "--", color=colour, lw=0.9)
    twin.set_ylabel("slip along the cone (mm, dashed)")
    ax_p.plot([], [], "s", color="0.8", label="tissue lifted off (shaded)")
