"""What the suture passes to the tissue through each cone and the bare thread: load shares and tractions.

The force the suture applies to the tissue at an interface node is the tissue's own part of the
residual there: the residual's integrals over tissue cells only (elastic, pressure, gravity and
inertia terms of the three layers; ``Physics.tissue_residual``), assembled at the converged state.
Summed over the tissue's interface nodes its axial component is the pull the tissue carries (at
equilibrium the outer surface's reaction), whatever the interface model: shared nodes (tied), or
the tissue's own nodes on a sliding thread's track. It is split by where the node sits:

* ``cone_k``: a node of a cone cell's interface (the junctions where a cone meets the thread
  included), k = 1 the cone farthest from the pulled end;
* ``thread``: every other interface node (the bare thread, inside a hollow cone's cavity included).

With the cones and the thread both free (nothing tied), a cone also pushes the track's tissue ahead of it
(:meth:`~suture_fem.physics.effects.cone_contact.ConeContact.pushes`): that push is the cone's share,
moved from the thread's, so ``thread`` is what the thread itself passes (its friction). A cone's push on the
tissue's next layer of nodes (off the interface, in the search once tissue wraps round a corner) joins its share.

``load_share_n`` gives each part's axial force (N); the parts sum to the pull to solver tolerance.
In 3-D (the half model) every vector is taken in the meridian plane: its component along the node's direction
off the thread's axis and its axial one (the hoop component left out), and the areas carry the weight 2.

Tractions: dividing a node's force by its 2 pi r-weighted lumped area (the facets' integral of its
shape function) gives the nominal traction (force per reference area; exact for a uniform traction
on straight facets, a smeared nodal value at corners). Its component along the suture's outward
normal (the tissue's inward one, averaged over the node's facets) is the contact pressure ``p``
(positive: the suture presses on the tissue; negative: it pulls the tissue after it, which only a
tied interface can); the component along the interface's tangent, oriented along increasing arc
length, is the shear ``tau``. Each part's profile is ordered by arc length ``s`` (mm) along the
suture's outline: along a cone from its apex on the thread, around its outer surface and (hollow) its
inside, to where it meets the thread again; along the thread from the far tissue face, s = z.

A thread track (sliding or frictionless thread) also gives the ``slip`` (mm): how far the thread has
slid through the tissue at each track node (the reference position along the thread of the thread
point that faces the node now, found by interpolation along the thread's deformed surface, subtracted
from the node's own); the ``gap`` (mm): the node's radial motion off the track (positive: the tissue
has left the thread; negative: the penalty's penetration), with the ranges where it has separated; and
the thread's largest radial contraction along it, which the track (held at the thread's reference
radius) does not follow.
"""

from __future__ import annotations

import math
from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from petsc4py import PETSc

from suture_fem.geometry import mesh as meshmod
from suture_fem.geometry import regions
from suture_fem.geometry.outline import meridian, project, radial_directions
from suture_fem.geometry.regions import MM, Facet
from suture_fem.outputs.base import Quantity, Setup, State
from suture_fem.outputs.cone_gaps import SEPARATION_MM, cone_nodes, cone_record, intervals
from suture_fem.physics import kinematics
from suture_fem.physics.constraints import mark_dofs, mark_facet_nodes
from suture_fem.support import compat

#: The name of the bare thread's part.
THREAD = "thread"
#: The facets of the tissue's interface nodes: a tied interface, a thread's track, the cones' own surfaces.
SIDES = (Facet.INTERFACE, Facet.TRACK, Facet.CONE_CONTACT)


def part_names(cones: int) -> list[str]:
    """The interface's parts in the record's order: ``cone_1`` (farthest from the pull) ..., then the thread."""
    return [f"cone_{k + 1}" for k in range(cones)] + [THREAD]


class Interface(Quantity):
    """``load_share_n``, ``load_share_total_n`` and ``interface`` (the profiles by part) at a reported force."""

    option = "interface"

    def __init__(self, setup: Setup):
        super().__init__(setup)
        physics = setup.physics
        self.physics = physics
        V = physics.V
        mesh = physics.mesh
        fdim = mesh.topology.dim - 1
        mesh.topology.create_connectivity(fdim, mesh.topology.dim)
        facets = np.concatenate([meshmod.facets(physics.tagged, f) for f in SIDES])
        on_facets = np.zeros(_nodes(V), dtype=bool)
        on_facets[dolfinx.fem.locate_dofs_topological(V, fdim, facets)] = True
        tissue = _node_mask(V, meshmod.region_cells(physics.tagged, regions.TISSUE))
        cone = _node_mask(V, meshmod.region_cells(physics.tagged, regions.Cell.CONE))
        cone |= mark_facet_nodes(V, fdim, meshmod.facets(physics.tagged, Facet.CONE_CONTACT))
        self.n_owned = V.dofmap.index_map.size_local
        nodes = np.flatnonzero(on_facets & tissue)
        self.nodes = nodes[nodes < self.n_owned]
        self.dim = mesh.geometry.dim
        xyz = V.tabulate_dof_coordinates()[:, : self.dim] / MM
        self.radial = radial_directions(xyz) if self.dim == 3 else None  # off the thread's axis (y), in x-z
        xy = meridian(xyz)  # (r, z) in 2-D; (r, y) = (sqrt(x^2 + z^2), y) in 3-D
        self.xy_mm = xy[self.nodes]
        g = physics.tagged.geometry
        self.geometry = g
        self.names = part_names(len(g.cones))
        self.part = np.full(len(self.nodes), len(g.cones), dtype=np.int32)  # the thread unless on a cone cell
        for k, c in enumerate(g.cones):
            lo, hi = min(c.base_z, c.apex_z), max(c.base_z, c.apex_z)
            tol = 1e-9 * max(g.z_end, 1.0)
            in_cone = cone[self.nodes] & (self.xy_mm[:, 1] >= lo - tol) & (self.xy_mm[:, 1] <= hi + tol)
            self.part[in_cone] = k
        self.track = np.zeros(len(self.nodes), dtype=bool)
        if physics.effects.thread_track:
            on_track = np.zeros(_nodes(V), dtype=bool)
            on_track[dolfinx.fem.locate_dofs_topological(V, fdim, meshmod.facets(physics.tagged, Facet.TRACK))] = True
            self.track = on_track[self.nodes]
        thread_cells = meshmod.region_cells(physics.tagged, regions.Cell.THREAD)
        thread = _node_mask(V, thread_cells)
        surface = thread & (np.abs(xy[:, 0] - g.r_thread) < 1e-9 * max(g.z_end, 1.0))  # 3-D: the polygon's vertices
        self.thread_surface = np.flatnonzero(surface[: self.n_owned])
        self.thread_xy_mm = xy[self.thread_surface]
        self._area_normal: tuple[np.ndarray, np.ndarray] | None = None
        self._layout: dict[str, tuple[Any, ...]] | None = None
        self._near: Any = None  # the tissue's residual over its cells at the interface (:func:`_near_nodes`)

    @staticmethod
    def describe(output: Any) -> dict[str, str]:
        """Where the load shares and tractions come from."""
        return {"load_share_n": "axial force the suture passes to the tissue through each cone and the bare thread: "
                                "the tissue's part of the residual summed over its interface nodes (N)",
                "interface": "nominal contact pressure and shear at the tissue's interface nodes (nodal force over "
                             "the 2 pi r-weighted lumped reference area) against arc length along each part"}

    def totals(self, state: State) -> dict[str, Any]:
        """The load shares and the interface's profiles (collective; the profiles are complete on every rank)."""
        physics = self.physics
        comm = physics.comm
        force = self._tissue_forces()
        area, normal = self._areas_normals()
        fz = force[:, 1]
        shares = np.array([float(np.sum(fz[self.part == k])) for k in range(len(self.names))])
        shares = comm.allreduce(shares)
        if physics.cone_contact is not None:  # a cone's push on the track's tissue (an interface's) and the next layer
            track, near = physics.cone_contact.pushes(compat.function_vector(physics.state))
            shares[: len(track)] += track + near
            shares[-1] -= float(np.sum(track))
        u = self._in_meridian(physics.u.x.array.reshape(-1, self.dim))
        local = {
            "xy": self.xy_mm, "force": force, "area": area[self.nodes], "normal": normal[self.nodes],
            "part": self.part, "track": self.track, "u": u[self.nodes] / MM,
            "thread_xy": self.thread_xy_mm,
            "thread_u": u[self.thread_surface] / MM,
            **(cone_nodes(physics, self.nodes) if physics.cone_contact is not None else {}),
        }
        gathered = comm.allgather(local)
        merged = {key: np.concatenate([g[key] for g in gathered]) for key in local}
        merged["thread_z_now"], merged["thread_order"] = _thread_map(merged)
        if self._layout is None:  # the mesh's part of the profiles, the same at every state
            self._layout = _layout(merged, self.geometry, self.names)
        profiles = _profiles(merged, self._layout)
        cones = cone_record(physics, profiles, self.names) if physics.cone_contact is not None else {}
        total = float(np.sum(shares))
        friction = {}
        if physics.friction is not None:  # how many track nodes stick, slip, are open; the law's residual
            state = compat.function_vector(physics.state)
            law = physics.friction
            friction = {"friction": {**law.status(state), "coulomb_residual_n": law.residual()}}
        return {
            "load_share_n": {name: float(v) for name, v in zip(self.names, shares)},
            "load_share_total_n": total,
            "interface": {
                "thread": physics.effects.thread_interface,
                "cones": physics.effects.cone_interface,
                "profiles": profiles,
                **_track_summary(merged, profiles),
                **friction,
                **cones,
            },
        }

    def _tissue_forces(self) -> np.ndarray:
        """The tissue's part of the residual at the interface nodes: (n, 2) forces (N) on the tissue."""
        physics = self.physics
        if self._near is None:
            self._near = _near_nodes(physics, self.nodes)
        b = dolfinx.fem.petsc.assemble_vector(self._near)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        values = b.array.copy()
        b.destroy()
        if physics.u_in_state is not None:  # mixed: the displacement part of the state's vector
            owned = np.asarray(physics.u_in_state)[: self.dim * self.n_owned]
            values = values[owned]
        return self._in_meridian(values[: self.dim * self.n_owned].reshape(-1, self.dim))[self.nodes]

    def _areas_normals(self) -> tuple[np.ndarray, np.ndarray]:
        """Each owned node's 2 pi r-weighted lumped interface area (m^2) and the suture's outward unit normal there.

        Assembled once (the reference configuration): the facets of a tied interface are interior
        facets between a tissue and a suture cell (their tissue-side normal picked by a cellwise tissue
        indicator); a track's and the cones' contact facets are the tissue's boundary.
        """
        if self._area_normal is None:
            physics = self.physics
            V, mesh = physics.V, physics.mesh
            chi = dolfinx.fem.Function(compat.scalar_space(mesh, "DG", 0))
            chi.x.array[:] = 0.0
            tissue_cells = meshmod.region_cells(physics.tagged, regions.TISSUE)
            chi.x.array[compat.cell_dofs(chi.function_space)[tissue_cells].ravel()] = 1.0
            compat.scatter_reverse_add(chi.x)  # a ghost cell's mark reaches its owner, then every copy
            chi.x.array[:] = np.minimum(chi.x.array, 1.0)
            chi.x.scatter_forward()
            v = ufl.TestFunction(V)
            n = ufl.FacetNormal(mesh)
            x = ufl.SpatialCoordinate(mesh)
            w = kinematics.volume_weight(x)
            w = ufl.as_ufl(1.0) * w if isinstance(w, float) else w  # 3-D's constant weight, restricted below
            dS = ufl.Measure("dS", domain=mesh, subdomain_data=physics.tagged.facet_tags)
            ds = ufl.Measure("ds", domain=mesh, subdomain_data=physics.tagged.facet_tags)
            n_tissue = chi("+") * n("+") + chi("-") * n("-")  # the tissue's outward normal on a tied facet
            one = ufl.as_vector([1.0] + [0.0] * (self.dim - 1))
            sides = ds(int(Facet.TRACK)) + ds(int(Facet.CONE_CONTACT))  # the tissue's own boundary
            forms = (w("+") * ufl.dot(one, v("+")) * dS(int(Facet.INTERFACE)) + w * ufl.dot(one, v) * sides,
                     w("+") * ufl.dot(n_tissue, v("+")) * dS(int(Facet.INTERFACE)) + w * ufl.dot(n, v) * sides)
            out = []
            for form in forms:
                b = dolfinx.fem.petsc.assemble_vector(compat.form(form))
                b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                out.append(b.array[: self.dim * self.n_owned].reshape(-1, self.dim).copy())
                b.destroy()
            area = out[0][:, 0]
            normal = -self._in_meridian(out[1])  # the suture's outward normal = minus the tissue's
            length = np.linalg.norm(normal, axis=1)
            normal = np.divide(normal, length[:, None], out=np.zeros_like(normal), where=length[:, None] > 0)
            self._area_normal = (area, normal)
        return self._area_normal

    def _in_meridian(self, vectors: np.ndarray) -> np.ndarray:
        """Per local node (owned first), a vector's (radial, axial) components.

        As they are in 2-D; in 3-D (v . e_r, v_y), e_r the node's direction off the thread's axis (hoop left out).
        """
        if self.dim == 2:
            return vectors
        n = len(vectors)
        return np.stack([np.sum(vectors * self.radial[:n], axis=1), vectors[:, 1]], axis=1)


def _near_nodes(physics: Any, nodes: np.ndarray) -> Any:
    """``Physics.tissue_residual`` over the tissue cells that hold one of the owned ``nodes`` (on any rank), compiled.

    The same integrals (so the same compiled kernels: the cells a form integrates are not in its signature)
    over fewer cells, in the same order: at the nodes every entry is the same sum of the same cells' parts.
    """
    V, mesh = physics.V, physics.mesh
    mark = dolfinx.fem.Function(V)
    bs = V.dofmap.index_map_bs
    mark.x.array[:] = 0.0
    mark.x.array[bs * np.asarray(nodes, dtype=np.int64)] = 1.0
    mark.x.scatter_forward()  # a ghost copy of a node learns it is one
    on = mark.x.array.reshape(-1, bs)[:, 0] > 0
    tags = physics.tagged.cell_tags
    cells = np.asarray(tags.indices, dtype=np.int32)
    near = on[compat.cell_dofs(V)[cells]].any(axis=1)
    kept = dolfinx.mesh.meshtags(mesh, mesh.topology.dim, cells[near], np.asarray(tags.values)[near])
    return compat.form(ufl.Form([i.reconstruct(subdomain_data=kept) for i in physics.tissue_residual.integrals()]))


def _nodes(V: Any) -> int:
    """Local nodes (owned and ghost) of a blocked space."""
    return V.dofmap.index_map.size_local + V.dofmap.index_map.num_ghosts


def _node_mask(V: Any, cells: np.ndarray) -> np.ndarray:
    """Per local node of V: touched by any of the cells on any rank."""
    return mark_dofs(V, cells).reshape(-1, V.dofmap.index_map_bs).any(axis=1)


def _arc_coordinate(points: np.ndarray, outline: list) -> np.ndarray:
    """Arc length (mm) of each point's nearest position on a cone's outline, from the outline's first point.

    The outline (:class:`~suture_fem.geometry.section.Cone`) starts on the thread at the apex, runs round
    the cone's tissue-facing surface and closes along the thread (:func:`~suture_fem.geometry.outline.project`).
    """
    return project(points, outline).s


def _layout(m: dict[str, np.ndarray], g: Any, names: list[str]) -> dict[str, tuple[Any, ...]]:
    """What the profiles take from the mesh alone, per part: (nodes by arc length, tangents, s, r, z lists).

    The nodes ordered by arc length, the tangents oriented along it and the rounded lists of s, r and z:
    the nodes, normals and parts of every rank are the same at every state, so :meth:`Interface.totals`
    keeps this once.
    """
    out = {}
    for k, name in enumerate(names):
        sel = np.flatnonzero(m["part"] == k)
        xy = m["xy"][sel]
        if name == THREAD:
            s = xy[:, 1]
        else:
            s = _arc_coordinate(xy, g.cones[k].outline)
        order = np.lexsort((xy[:, 1], xy[:, 0], s))  # by arc length, ties by position: the same on any partition
        sel, s = sel[order], s[order]
        tangent = m["normal"][sel][:, ::-1] * [1.0, -1.0]  # the normal turned by -90 degrees, (n_z, -n_r); oriented:
        if len(sel) > 1:  # orient along increasing s
            if np.all(np.diff(s) > 0) or np.ptp(s) == 0:
                ds_dir = np.gradient(m["xy"][sel], s, axis=0) if np.ptp(s) > 0 else tangent
            else:  # nodes at one arc length (3-D: round the thread's axis): the outline's own direction there
                ds_dir = np.tile([0.0, 1.0], (len(sel), 1)) if name == THREAD else \
                    project(m["xy"][sel], g.cones[k].outline).tangent
            flip = np.sum(tangent * ds_dir, axis=1) < 0
            tangent[flip] *= -1
        out[name] = (sel, tangent, _rounded(s), _rounded(m["xy"][sel, 0]), _rounded(m["xy"][sel, 1]))
    return out


def _profiles(m: dict[str, np.ndarray], layout: dict[str, tuple[Any, ...]]) -> dict[str, dict[str, Any]]:
    """Each part's pressure, shear (Pa), slip (mm) against arc length, ordered (all ranks' nodes merged)."""
    out: dict[str, dict[str, Any]] = {}
    area = np.maximum(m["area"], 1e-300)
    traction = m["force"] / area[:, None]
    pressure = np.sum(traction * m["normal"], axis=1)
    for name, (sel, tangent, s_mm, r_mm, z_mm) in layout.items():
        shear = np.sum(traction[sel] * tangent, axis=1)
        prof: dict[str, Any] = {
            "s_mm": list(s_mm),
            "r_mm": list(r_mm),
            "z_mm": list(z_mm),
            "pressure_pa": _rounded(pressure[sel]),
            "shear_pa": _rounded(shear),
            "axial_force_n": float(np.sum(m["force"][sel, 1])),
        }
        if len(sel):
            peak = int(np.argmax(pressure[sel]))
            prof["peak_pressure_pa"] = float(pressure[sel][peak])
            prof["peak_pressure_at_mm"] = [float(v) for v in m["xy"][sel[peak]]]
        if name != THREAD and "cone_gap" in m:  # the tissue's own nodes on the cone (tied junctions: 0)
            prof["gap_mm"] = _rounded(m["cone_gap"][sel])
            prof["slip_mm"] = _rounded(m["cone_slip"][sel])
        if name == THREAD and np.any(m["track"][sel]):
            prof["slip_mm"] = _rounded(_slip(m, sel))
            prof["gap_mm"] = _rounded(np.where(m["track"][sel], m["u"][sel, 0], 0.0))
        out[name] = prof
    return out


def _slip(m: dict[str, np.ndarray], sel: np.ndarray) -> np.ndarray:
    """How far the thread has slid through the tissue at each track node (mm; NaN where no thread faces it).

    The thread's surface nodes give its deformed axial position z(Z) = Z + u_z(Z), monotone along it;
    the thread point facing a track node now is Z_t with z(Z_t) = the node's deformed z, and the slip
    is the node's reference Z minus Z_t (positive toward the pull).
    """
    tz, order = m["thread_z_now"], m["thread_order"]
    Z = m["xy"][sel, 1]
    z_now = Z + m["u"][sel, 1]
    facing = np.interp(z_now, tz[order], m["thread_xy"][order, 1], left=np.nan, right=np.nan)
    slip = Z - facing
    return np.where(m["track"][sel], slip, 0.0)


def _thread_map(m: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The thread surface's deformed axial positions and their sorting order (unique reference nodes)."""
    Z = m["thread_xy"][:, 1]
    _, first = np.unique(np.round(Z, 12), return_index=True)
    tz = Z + m["thread_u"][:, 1]
    keep = np.zeros(len(Z), dtype=bool)
    keep[first] = True
    tz = np.where(keep, tz, np.nan)
    order = np.argsort(tz)
    order = order[keep[order]]
    return tz, order


def _track_summary(m: dict[str, np.ndarray], profiles: dict[str, Any]) -> dict[str, Any]:
    """A thread track's largest slip, the thread's contraction there, and where the tissue has left it (mm)."""
    if not np.any(m["track"]):
        return {}
    slip = np.asarray(profiles[THREAD].get("slip_mm", []), dtype=float)
    tz, order = m["thread_z_now"], m["thread_order"]
    sel = np.flatnonzero(m["track"])
    z_now = m["xy"][sel, 1] + m["u"][sel, 1]
    ur = np.interp(z_now, tz[order], m["thread_u"][order, 0], left=np.nan, right=np.nan)
    contraction = -ur  # the track is r = r_t; the thread's surface sits at r_t + u_r there
    gap = m["u"][sel, 0]  # the tissue's radial displacement off the track: + open, - penetration
    order = np.argsort(m["xy"][sel, 1])
    return {
        "slip_max_mm": float(np.nanmax(slip)) if np.any(np.isfinite(slip)) else None,
        "thread_contraction_max_mm": float(np.nanmax(contraction)) if np.any(np.isfinite(contraction)) else None,
        "opening_max_mm": float(max(np.max(gap), 0.0)),
        "penetration_max_mm": float(max(-np.min(gap), 0.0)),
        "separated_mm": intervals(m["xy"][sel, 1][order], gap[order] > SEPARATION_MM),
    }


def _rounded(values: np.ndarray) -> list[float | None]:
    """A JSON list with 7 significant digits (NaN as null)."""
    return [float(f"{v:.7g}") if math.isfinite(v) else None for v in np.asarray(values, dtype=float).tolist()]
