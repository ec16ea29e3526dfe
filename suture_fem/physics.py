"""Physics: the weak form of a scene, assembled from its regions' materials and its loads.

The total potential is

    Pi(u) = sum_regions  int W_region(F(u)) 2 pi r dr dz  -  int t . u 2 pi r ds_pull

with t = F / (pi r_t^2) e_z on the thread's pulled end face, so that the 2 pi r-weighted integral of t
over the face is exactly the applied force F. The residual is the Gateaux derivative of Pi and the
Jacobian its derivative again (UFL), so the tangent is exactly consistent.
Outer epidermis surface: u = 0. Axis: u_r = 0. Everything else traction-free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import dolfinx
import dolfinx.fem
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem import compat, kinematics
from suture_fem import mesh as meshmod
from suture_fem.materials import Material, from_params

#: Cell tag -> scene material region.
REGION_OF_TAG = {
    meshmod.HYPODERMIS: "hypodermis",
    meshmod.DERMIS: "dermis",
    meshmod.EPIDERMIS: "epidermis",
    meshmod.THREAD: "suture",
    meshmod.CONE: "suture",
}


def quadrature_degree(degree: int) -> int:
    """Quadrature degree for the (non-polynomial) hyperelastic integrands of a degree-k field."""
    return 2 * degree


@dataclass
class Physics:
    """The discrete problem of a scene: unknowns, forms, boundary conditions, load parameter.

    Attributes:
        tagged: the mesh and its tags.
        V: displacement space; u: the displacement (the unknown); materials: region -> material.
        traction: the axial traction on the pulled face (Pa), set by the load stepping.
        residual, jacobian: UFL forms; bcs: Dirichlet conditions.
        energy: UFL form of the total strain energy (J).
        end_displacement: UFL form of the 2 pi r-weighted integral of u_z over the pulled face.
    """

    tagged: meshmod.TaggedMesh
    degree: int
    V: Any
    u: Any
    materials: dict[str, Material]
    traction: Any
    residual: Any
    jacobian: Any
    bcs: list[Any]
    energy: Any
    end_displacement: Any
    outer_z_dofs: np.ndarray
    pull_area: float
    dx: Any
    x: Any
    F: Any
    left_out: dict[str, str] = field(default_factory=dict)
    _compiled: dict[str, Any] = field(default_factory=dict, repr=False)

    def form(self, name: str) -> Any:
        """The compiled dolfinx form of attribute `name` (residual, jacobian, energy, ...), compiled once."""
        if name not in self._compiled:
            self._compiled[name] = dolfinx.fem.form(getattr(self, name))
        return self._compiled[name]

    @property
    def mesh(self) -> Any:
        return self.tagged.mesh

    @property
    def comm(self) -> Any:
        return self.tagged.mesh.comm

    def traction_for(self, force_n: float) -> float:
        """Traction (Pa) whose 2 pi r-weighted integral over the pulled face is force_n."""
        return force_n / self.pull_area

    def set_force(self, force_n: float) -> None:
        self.traction.value = self.traction_for(force_n)

    def num_dofs(self) -> int:
        im = self.V.dofmap.index_map
        return int(im.size_global * self.V.dofmap.index_map_bs)

    def region_tags(self, region: str) -> tuple[int, ...]:
        return tuple(t for t, r in REGION_OF_TAG.items() if r == region)


def build_physics(tagged: meshmod.TaggedMesh, scene: dict[str, Any]) -> Physics:
    """Forms and boundary conditions of a scene on a mesh."""
    mesh = tagged.mesh
    degree = scene["mesh"]["degree"]
    V = compat.vector_space(mesh, degree)
    u = dolfinx.fem.Function(V, name="displacement")
    v = ufl.TestFunction(V)
    du = ufl.TrialFunction(V)
    x = ufl.SpatialCoordinate(mesh)
    F = kinematics.deformation_gradient(u, x)
    weight = kinematics.volume_weight(x)
    q = quadrature_degree(degree)
    dx = ufl.Measure("dx", domain=mesh, subdomain_data=tagged.cell_tags, metadata={"quadrature_degree": q})
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=tagged.facet_tags, metadata={"quadrature_degree": q})

    materials = {region: from_params(scene["materials"][region]) for region in sorted(set(REGION_OF_TAG.values()))}
    present = _present_tags(tagged)
    energy_density = 0
    for region, material in materials.items():
        tags = tuple(t for t, r in REGION_OF_TAG.items() if r == region and t in present)
        if tags:
            energy_density += material.energy(F) * weight * dx(tags)
    traction = dolfinx.fem.Constant(mesh, PETSc.ScalarType(0.0))
    external = traction * kinematics.axial(u) * weight * ds(meshmod.PULL_FACE)
    potential = energy_density - external
    residual = ufl.derivative(potential, u, v)
    jacobian = ufl.derivative(residual, u, du)

    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    outer = meshmod.facets(tagged, meshmod.OUTER)
    axis = meshmod.facets(tagged, meshmod.AXIS)
    zero2 = np.zeros(2, dtype=PETSc.ScalarType)
    outer_dofs = dolfinx.fem.locate_dofs_topological(V, fdim, outer)
    axis_r_dofs = dolfinx.fem.locate_dofs_topological(V.sub(0), fdim, axis)
    bcs = [
        dolfinx.fem.dirichletbc(zero2, outer_dofs, V),
        dolfinx.fem.dirichletbc(PETSc.ScalarType(0.0), axis_r_dofs, V.sub(0)),
    ]
    outer_z = dolfinx.fem.locate_dofs_topological(V.sub(1), fdim, outer)
    r_t = tagged.geometry.r_thread * meshmod.MM
    return Physics(
        tagged=tagged,
        degree=degree,
        V=V,
        u=u,
        materials=materials,
        traction=traction,
        residual=residual,
        jacobian=jacobian,
        bcs=bcs,
        energy=energy_density,
        end_displacement=kinematics.axial(u) * weight * ds(meshmod.PULL_FACE),
        outer_z_dofs=np.asarray(outer_z, dtype=np.int32),
        pull_area=math.pi * r_t**2,
        dx=dx,
        x=x,
        F=F,
    )


def _present_tags(tagged: meshmod.TaggedMesh) -> set[int]:
    """Cell tags present anywhere on the communicator (a region may be absent, e.g. no cones)."""
    local = set(int(t) for t in np.unique(tagged.cell_tags.values))
    return set().union(*tagged.mesh.comm.allgather(local))
