"""Rigid tools in frictionless contact with the tissue's surface: a sphere, a flat
cylindrical punch, or any closed triangle surface (an instrument's tip, :class:`SurfaceTool`)
pressed into it (issue 46's indenters), for the static equilibrium
(:func:`~neurofuzzy.simulation.static.equilibrium`'s ``contact``).

**The method: a node-to-rigid-surface penalty.** Every node of the body's surface carries its
share ``A_a`` of the surface area (a third of each surface triangle's at rest). Where a node
lies inside the tool by the depth ``d_a = max(0, -g_a)`` (``g`` the signed distance to the
tool's surface, negative inside), the tool pushes it out along the tool's normal ``n_a`` with
the force ``f_a = κ A_a d_a n_a``: a contact pressure ``κ d`` (``κ`` in Pa/m). The energy
``½ κ Σ A_a d_a²`` is what the Newton solve of the equilibrium minimises with the elastic one,
so the force's exact derivative enters its stiffness and, with it, the equilibrium's
sensitivities that a fit solves for. Why a penalty and not an active-set or
augmented-Lagrangian constraint: it is one more smooth-enough term of the same energy (no
multipliers, no change of the unknowns, the same sparse solve); its price is a penetration
``p / κ`` under a pressure ``p``, which :meth:`Contact.penetration` reports and ``κ`` bounds:
by default ``κ = PENALTY × E / h`` (``E`` the stiffest element's modulus, ``h`` the shortest
surface edge near the tool), a surface node then sinks about ``1 / PENALTY`` of what the
tissue under it gives way. On a sphere pressed to Hertz's depth ten times the penalty moves
the force by 0.05 % (``benchmarks/indentation.py``).

Frictionless: the force is along the tool's normal; a node slides freely along its surface.
The tools are rigid and placed by the position of a reference point (a sphere's centre, the
centre of a punch's flat face, a surface tool's origin) for each solve, and turned by the
attitude a tracker gives (``turned``; :class:`~neurofuzzy.load_steps.ToolPath`). A surface
tool's signed distance is its nearest triangle's, signed by the winding number; its
stiffness leaves out the normal's turning at its edges and corners (flat faces do not turn
it), which the Newton solve's line search absorbs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import InputError

__all__ = ["Sphere", "FlatPunch", "SurfaceTool", "TOOLS", "Contact", "contact_with",
           "PENALTY", "surface_areas", "cells_across_contact", "RESOLVED", "CREASE_DEGREES"]

#: The default penalty: ``κ = PENALTY × E / h`` (module docstring).
PENALTY = 100.0
#: Cells across a sphere's contact radius (:func:`cells_across_contact`) below which a fit
#: says its E is biased by the mesh. Measured: the indentation benchmark's quarter blocks of
#: 8³, 12³ and 16³ cells have 3.8, 6.3 and 8.8 at 0.5 % depth, and their force was 14 to
#: 17 %, 1 to 3 % and 0.1 to 3 % above Hertz's; the indentation tutorial's blocks have 2.3
#: and 5.0, and E came out 15 % and 1.8 % low.
RESOLVED = 4.5


def _finite_positive(value, key: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise InputError(f"got {value!r}; expected a positive length in metres", key=key)
    return value


@dataclass(frozen=True)
class Sphere:
    """A rigid sphere of ``radius`` (m), placed by its centre."""

    radius: float

    def __post_init__(self):
        object.__setattr__(self, "radius", _finite_positive(self.radius, "radius"))

    def gap(self, points: np.ndarray, centre: np.ndarray):
        """``(g, n, curvature)`` per point: the signed distance to the sphere's surface
        (negative inside), the outward normal, and ``1 / r`` (the normal's rate of turning
        per unit of sideways motion, for the stiffness)."""
        offset = points - centre
        distance = np.linalg.norm(offset, axis=1)
        safe = np.where(distance > 0, distance, 1.0)
        normal = offset / safe[:, None]
        normal[distance == 0] = (0.0, 0.0, 1.0)
        return distance - self.radius, normal, 1.0 / safe

    def turned(self, rotation) -> Sphere:
        """The sphere turned by ``rotation`` (3 × 3): itself."""
        return self

    def describe(self) -> str:
        return f"sphere of radius {1e3 * self.radius:g} mm"


@dataclass(frozen=True)
class FlatPunch:
    """A rigid flat-ended cylinder of ``radius`` (m), placed by the centre of its flat face;
    ``axis`` points from the face into the punch (default ``+z``: a punch pressing down)."""

    radius: float
    axis: tuple = (0.0, 0.0, 1.0)

    def __post_init__(self):
        object.__setattr__(self, "radius", _finite_positive(self.radius, "radius"))
        axis = np.asarray(self.axis, float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)) or not np.any(axis):
            raise InputError(f"got {self.axis!r}; expected a non-zero (3,) direction",
                             key="axis")
        object.__setattr__(self, "axis", tuple(axis / np.linalg.norm(axis)))

    def gap(self, points: np.ndarray, centre: np.ndarray):
        """``(g, n, curvature)`` per point: minus the height above the face for points over
        it (within the radius; ``+inf`` beside it), the face's normal ``-axis``, no turning."""
        axis = np.asarray(self.axis)
        offset = points - centre
        height = offset @ axis
        sideways = np.linalg.norm(offset - height[:, None] * axis, axis=1)
        gap = np.where(sideways <= self.radius, -height, np.inf)
        return gap, np.broadcast_to(-axis, points.shape), np.zeros(len(points))

    def turned(self, rotation) -> FlatPunch:
        """The punch turned by ``rotation`` (3 × 3, the tool's frame to the world's): its
        axis ``rotation @ axis``."""
        return FlatPunch(self.radius, tuple(np.asarray(rotation, float) @ np.asarray(self.axis)))

    def describe(self) -> str:
        return f"flat punch of radius {1e3 * self.radius:g} mm"


@dataclass(frozen=True, eq=False)
class SurfaceTool:
    """A rigid tool given as a closed triangle surface (an instrument's tip), in its own
    frame: the path places its origin (the tool's reference point), and its attitude turns it.

    Parameters
    ----------
    vertices : (n, 3) float
        The surface's corners in the tool's frame (m).
    faces : (m, 3) int
        Its triangles; closed (every edge shared by two), either winding.

    Attributes
    ----------
    radius : float
        How far the surface reaches from the reference point (m): only points within it can
        touch, and a path that jumps further between two steps is refused.
    """

    vertices: np.ndarray
    faces: np.ndarray
    radius: float = field(init=False)

    def __post_init__(self):
        import trimesh

        vertices = np.asarray(self.vertices, float)
        faces = np.asarray(self.faces)
        if (vertices.ndim != 2 or vertices.shape[1] != 3 or not np.all(np.isfinite(vertices))
                or faces.ndim != 2 or faces.shape[1] != 3 or faces.dtype.kind not in "iu"
                or len(faces) < 4 or faces.min() < 0 or faces.max() >= len(vertices)):
            raise InputError("a tool's surface needs finite (n, 3) vertices and (m ≥ 4, 3) "
                             "triangles numbering them", key="tool")
        surface = trimesh.Trimesh(vertices, faces, process=False)
        if not surface.is_watertight:
            raise InputError("a tool's surface must be closed (every edge shared by two "
                             "triangles): its inside is where the tissue cannot be", key="tool")
        if surface.volume < 0:                       # wound inward: turn it outward
            faces = faces[:, ::-1]
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "faces", np.ascontiguousarray(faces, dtype=np.int64))
        object.__setattr__(self, "radius", float(np.linalg.norm(vertices, axis=1).max()))
        object.__setattr__(self, "_corner_normals", _corner_normals(vertices, self.faces))

    def gap(self, points: np.ndarray, position: np.ndarray):
        """``(g, n, curvature)`` per point: the signed distance to the surface (negative
        inside, by the winding number), the outward normal at the nearest surface point
        (interpolated from its face's corner normals, :func:`_corner_normals`: continuous
        across a smooth surface's facets, sharp at its creases), and no turning (which the
        stiffness leaves out). ``+inf`` beyond :attr:`radius`."""
        import trimesh

        offset = np.asarray(points, float) - np.asarray(position, float)
        gap = np.full(len(offset), np.inf)
        normal = np.zeros_like(offset)
        normal[:, 2] = 1.0
        near = np.flatnonzero(np.linalg.norm(offset, axis=1) <= self.radius)
        # in units of the tool's reach: trimesh's tolerances are absolute (1e-8), and a
        # millimetre tool's faces in metres fell below them (distances off by 0.09 mm)
        triangles = self.vertices[self.faces] / self.radius
        chunk = max(1, 2_000_000 // len(triangles))
        for start in range(0, len(near), chunk):
            rows = near[start:start + chunk]
            here = offset[rows] / self.radius
            closest = trimesh.triangles.closest_point(
                np.tile(triangles, (len(rows), 1, 1)), np.repeat(here, len(triangles), axis=0)
            ).reshape(len(rows), len(triangles), 3)
            away = here[:, None, :] - closest
            distance = np.linalg.norm(away, axis=2)
            nearest = np.argmin(distance, axis=1)
            pick = np.arange(len(rows))
            d = distance[pick, nearest]
            inside = _winding(triangles, here) > 0.5
            # the normal interpolated from the corners' (Phong's) at the nearest point: the
            # faces' own jump where the nearest face changes, and Newton's method stalls
            weights = trimesh.triangles.points_to_barycentric(
                triangles[nearest], closest[pick, nearest])
            smooth = np.einsum("pk,pkj->pj", weights, self._corner_normals[nearest])
            normal[rows] = smooth / np.linalg.norm(smooth, axis=1, keepdims=True)
            gap[rows] = self.radius * np.where(inside, -d, d)
        return gap, normal, np.zeros(len(offset))

    def turned(self, rotation) -> SurfaceTool:
        """The surface turned by ``rotation`` (3 × 3, the tool's frame to the world's)."""
        return SurfaceTool(self.vertices @ np.asarray(rotation, float).T, self.faces)

    def describe(self) -> str:
        return (f"surface of {len(self.faces)} triangles reaching {1e3 * self.radius:.3g} mm "
                "from its reference point")


#: faces meeting at a smaller angle than this belong to one smooth surface (an icosphere's
#: facets are 4 to 15 degrees apart); at a larger one the edge is a crease (a box's, a
#: chamfer's), which keeps each face's own normal up to it
CREASE_DEGREES = 40.0


def _corner_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 3, 3): each face's normal at its three corners, the area-weighted mean of the
    normals of the faces around that corner within :data:`CREASE_DEGREES` of its own (a
    faceted sphere's normals are then continuous, as Phong's shading makes them, while a
    box's faces keep their own)."""
    corners = vertices[faces]
    weighted = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    unit = weighted / np.linalg.norm(weighted, axis=1, keepdims=True)
    around = sp.csr_array((np.ones(faces.size), (faces.ravel(),
                                                 np.repeat(np.arange(len(faces)), 3))),
                          shape=(len(vertices), len(faces)))
    start, end = around.indptr[faces.ravel()], around.indptr[faces.ravel() + 1]
    count = end - start
    corner = np.repeat(np.arange(faces.size), count)
    other = around.indices[np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
                           + np.repeat(start, count)]
    own = corner // 3
    alike = np.einsum("ij,ij->i", unit[own], unit[other]) > np.cos(np.radians(CREASE_DEGREES))
    normals = np.zeros((faces.size, 3))
    np.add.at(normals, corner[alike], weighted[other[alike]])
    return (normals / np.linalg.norm(normals, axis=1, keepdims=True)).reshape(-1, 3, 3)


def _winding(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The winding number of the closed, outward surface ``triangles`` (t, 3, 3) about each
    of ``points`` (p, 3): 1 inside, 0 outside (the sum of the triangles' solid angles over
    4π, Van Oosterom and Strackee's formula)."""
    a, b, c = (triangles[None, :, k, :] - points[:, None, :] for k in range(3))
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    triple = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
    under = (la * lb * lc + np.einsum("ptk,ptk->pt", a, b) * lc
             + np.einsum("ptk,ptk->pt", a, c) * lb + np.einsum("ptk,ptk->pt", b, c) * la)
    return np.arctan2(triple, under).sum(axis=1) / (2 * np.pi)


def surface_areas(mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(nodes, areas)``: the surface nodes of ``mesh`` and a third of the rest area of each
    surface triangle at its corners."""
    from ..mesh.surface import surface_triangles

    faces = surface_triangles(mesh)
    corners = mesh.rest_positions[faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)
    share = np.bincount(faces.ravel(), np.repeat(area / 3, 3), minlength=mesh.n_nodes)
    nodes = np.flatnonzero(share > 0)
    return nodes, share[nodes]


#: the kinds of rigid tool
TOOLS = (Sphere, FlatPunch, SurfaceTool)


@dataclass(frozen=True)
class Contact:
    """A tool at one position against a body's surface nodes (:func:`contact_with`).

    Attributes
    ----------
    tool : Sphere, FlatPunch or SurfaceTool
    position : (3,) float
        The tool's reference point (m).
    stiffness : float
        The penalty ``κ`` (Pa/m).
    nodes, areas : (m,) int, (m,) float
        The surface nodes the tool may touch and their shares of the surface area (m²).
    """

    tool: object
    position: np.ndarray
    stiffness: float
    nodes: np.ndarray
    areas: np.ndarray = field(repr=False)

    def at(self, position, tool=None) -> Contact:
        """The same contact with the tool moved to ``position`` (and, given ``tool``, that
        tool instead: the same one turned)."""
        position = np.asarray(position, float)
        if position.shape != (3,) or not np.all(np.isfinite(position)):
            raise InputError(f"a tool's position must be 3 finite numbers; got {position!r}",
                             key="tool")
        return Contact(self.tool if tool is None else tool, position, self.stiffness,
                       self.nodes, self.areas)

    def _depths(self, positions: np.ndarray):
        gap, normal, curvature = self.tool.gap(positions[self.nodes], self.position)
        return np.maximum(-gap, 0.0), normal, curvature

    def forces(self, positions: np.ndarray) -> np.ndarray:
        """(n_nodes, 3): the force the tool exerts on every node."""
        depth, normal, _ = self._depths(positions)
        out = np.zeros_like(positions, dtype=float)
        out[self.nodes] = (self.stiffness * self.areas * depth)[:, None] * normal
        return out

    def force_on_body(self, positions: np.ndarray) -> np.ndarray:
        """(3,): the total force the tool exerts on the body (what a load cell on the tool
        reads, with the sign of a plate's reaction: pressing down is negative ``z``)."""
        return self.forces(positions).sum(axis=0)

    def penetration(self, positions: np.ndarray) -> float:
        """The deepest a surface node lies inside the tool (m): the penalty's error."""
        return float(self._depths(positions)[0].max(initial=0.0))

    def touching(self, positions: np.ndarray) -> np.ndarray:
        """The surface nodes inside the tool."""
        return self.nodes[self._depths(positions)[0] > 0]

    def stiffness_matrix(self, positions: np.ndarray) -> sp.csr_array:
        """``-∂forces/∂positions`` (3 n_nodes square, node-major): per touching node
        ``κ A (n nᵀ - d/r (I - n nᵀ))`` (``r`` the sphere's distance to it; a punch's face
        does not turn, so ``κ A n nᵀ``)."""
        depth, normal, curvature = self._depths(positions)
        on = depth > 0
        n = positions.shape[0]
        if not on.any():
            return sp.csr_array((3 * n, 3 * n))
        weight = (self.stiffness * self.areas)[on]
        normal = np.asarray(normal)[on]
        outer = normal[:, :, None] * normal[:, None, :]
        turning = (depth * curvature)[on][:, None, None]
        blocks = weight[:, None, None] * (outer - turning * (np.eye(3) - outer))
        dofs = 3 * self.nodes[on][:, None] + np.arange(3)
        rows = np.repeat(dofs, 3, axis=1).ravel()
        cols = np.tile(dofs, (1, 3)).ravel()
        return sp.csr_array((blocks.ravel(), (rows, cols)), shape=(3 * n, 3 * n))


def contact_with(model, tool, position, *, stiffness: float | str = "auto") -> Contact:
    """The contact of ``tool`` at ``position`` with ``model``'s surface.

    Parameters
    ----------
    model : Model
        An element model (its elements' Young's modulus sets the default penalty).
    tool : Sphere, FlatPunch or SurfaceTool
    position : (3,) float
        The tool's reference point (m): a sphere's centre, a punch's face centre.
    stiffness : float or "auto"
        The penalty ``κ`` (Pa/m); ``"auto"``: ``PENALTY × E / h`` (module docstring).
    """
    if not isinstance(tool, TOOLS):
        raise InputError(f"got {type(tool).__name__}; a tool is a Sphere, a FlatPunch or a "
                         "SurfaceTool", key="tool")
    nodes, areas = surface_areas(model.mesh)
    if stiffness == "auto":
        stiffness = PENALTY * _stiffest(model) / _shortest_edge_near(model, tool, position,
                                                                     nodes)
    stiffness = float(stiffness)
    if not (np.isfinite(stiffness) and stiffness > 0):
        raise InputError(f"got {stiffness!r}; expected a positive penalty in Pa/m",
                         key="stiffness")
    return Contact(tool, np.zeros(3), stiffness, nodes, areas).at(position)


def _stiffest(model) -> float:
    if model.elements is None:
        raise InputError("contact needs an element model (its Young's modulus sets the "
                         "penalty); give stiffness= for a spring network", key="stiffness")
    return float(np.max(model.elements.youngs_modulus))


def _shortest_edge_near(model, tool, position, nodes) -> float:
    """The shortest edge among the surface nodes within two tool radii of ``position``
    (all surface nodes when none is)."""
    rest = model.mesh.rest_positions
    near = np.linalg.norm(rest[nodes] - np.asarray(position, float), axis=1) <= (
        2 * tool.radius + 1e-12)
    chosen = np.zeros(model.n_nodes, bool)
    chosen[nodes[near] if near.any() else nodes] = True
    springs = np.asarray(model.mesh.springs)
    edges = springs[chosen[springs].all(axis=1)]
    if not len(edges):
        edges = springs
    return float(np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1).min())


def cells_across_contact(mesh, tool, positions) -> tuple[float, float] | None:
    """``(a, cells)`` of a sphere pressed to ``positions`` (its centre at step 0, then at
    each load step): Hertz's contact radius ``a = √(R δ)`` at the shallowest loaded step
    (``δ`` its depth into the body at rest), and how many cells span it, ``a`` over the mean
    length of the edges at the surface node the sphere first meets (the mesh's size where the
    contact is). None for another tool, or a sphere that never presses."""
    if not isinstance(tool, Sphere):
        return None
    nodes, _ = surface_areas(mesh)
    rest = mesh.rest_positions[nodes]
    depths = [max(0.0, -float(tool.gap(rest, np.asarray(centre, float))[0].min()))
              for centre in np.asarray(positions, float)[1:]]
    loaded = [depth for depth in depths if depth > 0]
    if not loaded:
        return None
    depth = min(loaded)
    centre = np.asarray(positions, float)[1 + depths.index(depth)]
    first = nodes[np.argmin(tool.gap(rest, centre)[0])]
    springs = np.asarray(mesh.springs)
    edges = springs[(springs == first).any(axis=1)]
    size = np.mean(np.linalg.norm(mesh.rest_positions[edges[:, 0]]
                                  - mesh.rest_positions[edges[:, 1]], axis=1))
    a = float(np.sqrt(tool.radius * depth))
    return a, float(a / size)
