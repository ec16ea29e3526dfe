"""The slab's dimensions (``geometry.tissue_shape = "slab"``), derived from a scene (pure Python, no gmsh).

The slab is a layered block in the 3-D half model's axes (:mod:`suture_fem.geometry.gmsh_3d`): the thread
along y on the axis x = z = 0, the solid in z <= 0 with the symmetry plane z = 0 through the thread. The
skin surface is the plane x = ``thread_depth`` (outward normal +x), then epidermis, dermis and hypodermis
downward; the hypodermis reaches ``hypodermis_mm`` below the thread's axis (the fat under the thread is the
cylinder's), where the deep face x = -hypodermis_mm is fixed. The lateral face z = -``half_width`` is fixed.
Along y the slab spans the cylinder's tissue length, and the thread leaves it at y = L as in the cylinder.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from suture_fem.geometry.regions import TISSUE_REGIONS
from suture_fem.scene.schema import GeometrySection
from suture_fem.support.errors import SceneError

#: The skin surface's outward unit normal (the slab's top face x = thread_depth).
SKIN_NORMAL = (1.0, 0.0, 0.0)
#: Smallest gap (mm) between the cones (or the thread) and the dermis or a lateral face.
GAP_MM = 5e-3


@dataclass(frozen=True)
class Slab:
    """The slab's planes (mm).

    The skin x_skin, the epidermis-dermis x_dermis, the dermis-hypodermis x_hypodermis, the deep face x_deep,
    and the lateral face's distance half_width (the face z = -half_width).
    """

    x_skin: float
    x_dermis: float
    x_hypodermis: float
    x_deep: float
    half_width: float

    @classmethod
    def from_section(cls, g: GeometrySection) -> Slab:
        """The slab of a scene; SceneError (one line naming the key and its range) unless the cones fit the fat."""
        widest = g.cone_base_diameter_mm / 2 if g.cones > 0 else g.thread_radius_mm
        what = f"the cones (base radius {widest:g} mm)" if g.cones > 0 else f"the thread (radius {widest:g} mm)"
        lowest = g.epidermis_mm + g.dermis_mm + widest + GAP_MM
        if g.thread_depth_mm <= lowest:
            raise SceneError(f"scene key geometry.thread_depth_mm = {g.thread_depth_mm:g} puts {what} above the "
                             f"hypodermis; allowed range: more than {lowest:.4g} mm (geometry.epidermis_mm + "
                             "geometry.dermis_mm + the radius) up to 10 mm")
        if g.slab_half_width_mm <= widest + GAP_MM:
            raise SceneError(f"scene key geometry.slab_half_width_mm = {g.slab_half_width_mm:g} cuts {what}; allowed "
                             f"range: more than {widest + GAP_MM:.4g} mm up to 100 mm")
        x_dermis = g.thread_depth_mm - g.epidermis_mm
        return cls(x_skin=g.thread_depth_mm, x_dermis=x_dermis, x_hypodermis=x_dermis - g.dermis_mm,
                   x_deep=-g.hypodermis_mm, half_width=g.slab_half_width_mm)

    @property
    def layers(self) -> list[tuple[float, float]]:
        """(x_low, x_high) of the hypodermis, the dermis and the epidermis (this order)."""
        return [(self.x_deep, self.x_hypodermis), (self.x_hypodermis, self.x_dermis), (self.x_dermis, self.x_skin)]

    def describe(self) -> dict[str, Any]:
        """JSON-ready summary (mm)."""
        return {
            "thread_depth_mm": self.x_skin,
            "half_width_mm": self.half_width,
            "layer_thicknesses_mm": {name: hi - lo for name, (lo, hi) in zip(TISSUE_REGIONS, self.layers)},
            "hypodermis_below_thread_mm": -self.x_deep,
        }
