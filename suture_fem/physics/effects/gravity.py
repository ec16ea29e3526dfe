"""Gravity (``effects.gravity = true``): the tissue's and suture's weight as an axial body force.

- int rho g s u_z dV, s = -1 for ``"-z"`` (opposite to the pull), +1 for ``"+z"``, u_z the displacement
along the thread; only an axial direction is axisymmetric (the 3-D models keep it). The solver applies it
quasi-statically before the pull, through a 0..1 factor.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from suture_fem.geometry import curved
from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry.regions import REGION_OF_TAG
from suture_fem.physics import kinematics
from suture_fem.physics.effects.inertia import Densities
from suture_fem.physics.forms import FormContext, Terms
from suture_fem.scene.schema import EffectsSection
from suture_fem.support import compat


def gravity_term(ctx: FormContext, e: EffectsSection, factor: Any, terms: Terms) -> None:
    """Weight of every region as an axial body force, scaled by ``factor`` (0 -> 1 in the preload)."""
    g = e.gravity_m_s2 * (1.0 if e.gravity_direction == "+z" else -1.0)
    rho = Densities.from_section(e).by_region
    work = sum(rho[r] * g * kinematics.axial(ctx.u) * ctx.weight * ctx.over(r) for r in ctx.region_tags)
    terms.potential["gravity"] = -factor * work


def weight_n(tagged: meshmod.TaggedMesh, e: EffectsSection) -> float:
    """Total weight rho g V (N) from the mesh geometry, independently of the weak form.

    For a straight-sided triangle int r dA = A r_centroid exactly, so V = sum 2 pi A r_centroid. Quadratic
    cells (``mesh.geometry_degree = 2``) count as their vertex triangles: the slivers between the fillet
    arcs and their chords are below 1e-6 of the section's area at 8 elements per arc (0.04 mm fillets).
    In 3-D, V is twice the half model's tetrahedra's volume, quadratic ones integrated exactly
    (:func:`~suture_fem.geometry.curved.volumes`: their vertex tetrahedra miss about 0.6 % of the
    coarsest cylinder's curved volume).
    """
    mesh = tagged.mesh
    dim = mesh.topology.dim
    n_owned = mesh.topology.index_map(dim).size_local
    geom = mesh.geometry.x[:, :dim]
    cells = compat.geometry_dofs(mesh)
    total = 0.0
    for tag, region in REGION_OF_TAG.items():
        ids = meshmod.region_cells(tagged, tag)
        ids = ids[ids < n_owned]
        p = geom[cells[ids]]
        if dim == 3 and p.shape[1] == 10:  # the half model's quadratic tetrahedra, doubled
            volume = 2.0 * curved.volumes(p)
        elif dim == 3:  # the half model's tetrahedra, doubled
            volume = 2.0 * np.abs(np.linalg.det(p[:, 1:4] - p[:, :1])) / 6.0
        else:
            a, b = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
            area = 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
            volume = 2 * math.pi * area * p[:, :, 0].mean(axis=1)
        total += e.density(region) * float(np.sum(volume))
    return mesh.comm.allreduce(total) * e.gravity_m_s2


def gravity_notes(tagged: meshmod.TaggedMesh, e: EffectsSection) -> dict[str, Any]:
    """The ``gravity`` numbers of the effects record: g, its direction and the total weight."""
    return {"g_m_s2": e.gravity_m_s2, "direction": e.gravity_direction, "weight_n": weight_n(tagged, e),
            "applied": "quasi-statically before the pull"}
