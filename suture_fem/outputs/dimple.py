"""The slab's skin surface: its displacement along the outward normal, and the dimple over each cone (mm).

With ``geometry.tissue_shape = "slab"`` the skin is the free plane x = ``geometry.thread_depth_mm`` with
outward normal +x (:mod:`suture_fem.geometry.slab`). Its normal displacement u_n = u . n is taken at the
displacement nodes of the skin's facets (each node once, on its owning rank). The dimple depth over a cone
is the largest inward displacement (-u_n) of the skin nodes over the cone: y within the cone's axial span
(base to apex) and |z| at most the thread's depth (the skin within one depth of the plane through the thread,
where a load at that depth is felt most); positive when the skin sinks there, negative when the whole skin over
the cone rises. It is measured from the skin's undeformed plane, so it includes the slab's overall tilt, not only
the local depression. The profile is u_n along the skin's line above the thread (z = 0), ordered by y.

The dimple's relief over a cone is the local depression without the tilt: a straightedge laid on the deformed
profile across the cone, from one thread depth before its span to one thread depth after it (within the skin's
ends), and the largest depth of the profile under it (the chord between the profile's values at the window's
ends, less u_n, at the profile's nodes in the window); positive where the skin dips under the straightedge,
zero or negative where it bulges. On the line above the thread only.
"""

from __future__ import annotations

from typing import Any

import dolfinx.fem
import numpy as np

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.regions import MM, Facet
from suture_fem.geometry.slab import SKIN_NORMAL
from suture_fem.outputs.base import Quantity, Setup, State, global_max
from suture_fem.scene.schema import OutputSection

#: A skin node lies on the line above the thread when |z| is below this (m).
ON_LINE_M = 1e-9


class Dimple(Quantity):
    """``dimple_depth_mm`` per cone, the skin's largest inward and outward displacement and its profile."""

    option = "dimple"
    slab_only = True

    @staticmethod
    def describe(output: OutputSection) -> dict[str, str]:
        """What the skin entries are."""
        return {
            "dimple_depth_mm": "per cone (far end first): the largest inward displacement -u.n of the skin surface's "
                               "nodes over the cone (y within the cone's span, |z| <= the thread's depth); n = +x, the "
                               "skin's outward normal",
            "skin_inward_mm": "largest inward displacement -u.n over the skin surface's nodes",
            "skin_outward_mm": "largest outward displacement u.n over the skin surface's nodes",
            "skin_profile_mm": "[y, u.n] at the skin's nodes on the line above the thread (z = 0), by y",
            "dimple_relief_mm": "per cone: the largest depth of the skin profile (z = 0) under a straightedge laid on "
                                "it from one thread depth before the cone's span to one after it (the tilt removed)",
        }

    def __init__(self, setup: Setup):
        super().__init__(setup)
        physics = setup.physics
        V, tagged = physics.V, physics.tagged
        fdim = physics.mesh.topology.dim - 1
        nodes = np.asarray(dolfinx.fem.locate_dofs_topological(V, fdim, meshmod.facets(tagged, Facet.SKIN)))
        self.nodes = np.unique(nodes[nodes < V.dofmap.index_map.size_local])  # owned: each node once
        self.xyz = setup.node_xy[self.nodes]
        self.spans = [(min(c.base_z, c.apex_z) * MM, max(c.base_z, c.apex_z) * MM) for c in tagged.geometry.cones]
        self.footprint = tagged.geometry.slab.x_skin * MM  # the thread's depth: |z| within it is over the thread

    def totals(self, state: State) -> dict[str, Any]:
        """The skin's entries for the current state (collective)."""
        gdim = self.setup.physics.mesh.geometry.dim
        u = self.setup.physics.u.x.array.reshape(-1, gdim)[self.nodes]
        normal = (u @ np.asarray(SKIN_NORMAL)) / MM
        inward, outward = global_max(state.comm, -normal, self.xyz), global_max(state.comm, normal, self.xyz)
        y, near = self.xyz[:, 1], np.abs(self.xyz[:, 2]) <= self.footprint * (1 + 1e-9)
        over = [near & (y >= lo) & (y <= hi) for lo, hi in self.spans]
        dimples = [global_max(state.comm, -normal[cone], self.xyz[cone]) for cone in over]
        line = np.abs(self.xyz[:, 2]) < ON_LINE_M
        local = [[float(a) / MM, float(b)] for a, b in zip(y[line], normal[line])]
        profile = sorted(p for part in state.comm.allgather(local) for p in part)
        reliefs = [relief(profile, lo / MM - self.footprint / MM, hi / MM + self.footprint / MM)
                   for lo, hi in self.spans]
        return {
            "dimple_depth_mm": [d.value for d in dimples],
            "dimple_depth_at_mm": [d.at_mm for d in dimples],
            "skin_inward_mm": inward.value,
            "skin_inward_at_mm": inward.at_mm,
            "skin_outward_mm": outward.value,
            "skin_outward_at_mm": outward.at_mm,
            "skin_profile_mm": profile,
            "dimple_relief_mm": [r[0] for r in reliefs],
            "dimple_relief_at_y_mm": [r[1] for r in reliefs],
        }


def relief(profile: list[list[float]], start: float, end: float) -> tuple[float | None, float | None]:
    """(depth, y): the largest depth of ``profile`` ([y, u_n] by y, mm) under its chord from ``start`` to ``end``.

    The window is clipped to the profile's span; (None, None) where it holds fewer than three nodes.
    """
    y, u = (np.array([p[i] for p in profile]) for i in (0, 1))
    if len(y) == 0:
        return None, None
    start, end = max(start, y[0]), min(end, y[-1])
    inside = (y >= start) & (y <= end)
    if np.count_nonzero(inside) < 3:
        return None, None
    u0, u1 = np.interp([start, end], y, u)
    depth = u0 + (u1 - u0) * (y[inside] - start) / (end - start) - u[inside]
    k = int(np.argmax(depth))
    return float(depth[k]), float(y[inside][k])
