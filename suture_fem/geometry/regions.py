"""The one table of region names and tags: every module that names a region or a boundary reads it here.

Cell tags mark the materials of the half-section, facet tags its boundaries and the suture-tissue
interface. The tags are fixed numbers (written into every ``.msh`` file and its JSON record), never
derived from gmsh's entity order. A *material region* (``hypodermis``, ``dermis``, ``epidermis``,
``suture``) is what a scene's ``[materials.*]`` tables and results.json's ``regions`` name; the suture
is meshed as two cell tags (thread and cones) that share one material.
"""

from __future__ import annotations

from enum import IntEnum

#: metres per millimetre (gmsh and scenes work in mm, the solver in SI units)
MM = 1e-3


class Cell(IntEnum):
    """Cell tags of the half-section."""

    HYPODERMIS = 1
    DERMIS = 2
    EPIDERMIS = 3
    THREAD = 4
    CONE = 5


class Facet(IntEnum):
    """Facet tags: boundaries and the suture-tissue interface."""

    OUTER = 11
    AXIS = 12
    PULL_FACE = 13
    TISSUE_PULL_FACE = 14
    TISSUE_FAR_FACE = 15
    THREAD_FAR_FACE = 16
    INTERFACE = 17
    THREAD_FREE_SIDE = 18
    #: the tissue's side of a sliding thread's track (``effects.thread_interface = "sliding"``): its own
    #: nodes, coincident with the thread's surface nodes (which keep the tag ``interface``)
    TRACK = 19
    #: the tissue's side of the cones' surfaces when they are not tied (``effects.cone_interface``): its own
    #: nodes, coincident with the cones' surface nodes (which keep the tag ``interface``)
    CONE_CONTACT = 20
    #: the 3-D half model's symmetry plane through the thread (``geometry.dimension = 3``)
    SYMMETRY = 21
    #: the slab's flat free skin surface (``geometry.tissue_shape = "slab"``)
    SKIN = 22


#: The material regions, tissue layers inside out, then the suture.
TISSUE_REGIONS: tuple[str, ...] = ("hypodermis", "dermis", "epidermis")
SUTURE_REGION = "suture"
REGIONS: tuple[str, ...] = (*TISSUE_REGIONS, SUTURE_REGION)
#: The tissue layers taken together: results.json's ``regions.tissue`` (not a material region: it has no
#: table of its own); the laws of the layers are the "tissue" laws (``scene/laws.py``).
WHOLE_TISSUE = "tissue"
#: Every name of results.json's ``regions``: the material regions and the whole tissue.
REPORTED_REGIONS: tuple[str, ...] = (*REGIONS, WHOLE_TISSUE)

#: Cell tags of each material region.
REGION_TAGS: dict[str, tuple[int, ...]] = {
    "hypodermis": (Cell.HYPODERMIS,),
    "dermis": (Cell.DERMIS,),
    "epidermis": (Cell.EPIDERMIS,),
    "suture": (Cell.THREAD, Cell.CONE),
}
#: Material region of each cell tag.
REGION_OF_TAG: dict[int, str] = {tag: region for region, tags in REGION_TAGS.items() for tag in tags}
TISSUE: tuple[int, ...] = tuple(t for r in TISSUE_REGIONS for t in REGION_TAGS[r])
SUTURE: tuple[int, ...] = REGION_TAGS["suture"]

#: Physical-group names written into .msh files (lower-case enum names).
CELL_TAGS: dict[str, int] = {c.name.lower(): int(c) for c in Cell}
FACET_TAGS: dict[str, int] = {f.name.lower(): int(f) for f in Facet}
