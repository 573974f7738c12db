"""Spring homogenisation: Young's modulus, viscosity and density ↔ spring constants, spring
viscosities and node masses on a lattice or tetrahedral mesh (the physics of the rule bases'
spring models; :func:`neurofuzzy.initialize` uses it).

Spring constants from Young's modulus. For a lattice of cubic cells (edge ``a``) with springs on
the cell edges and the four body diagonals of every cell, the affine strain energy of the
springs equals that of an isotropic elastic solid with Poisson's ratio 1/4 when

    k_edge = E a n / 5      (n: number of cells sharing the edge, 4 inside the body)
    k_diag = 3 E a / 10

(derivation in ``rules/README.md``: energy per cell ``½ k_e a² Σε_ii² + ⅔ k_d a² [(tr ε)² +
4 Σ_{i<j} ε_ij²]`` gives C11 = (k_e + 4k_d/3)/a and C12 = C44 = 4k_d/(3a); isotropy
C11 - C12 = 2 C44 needs k_e = 8k_d/3, and then E = 10 k_d / (3a)). Lattices with face
diagonals use van Gelder's rule, ``k = E Σ_cells V / l²`` (A. van Gelder, "Approximate
simulation of elastic membranes by triangulated spring meshes", J. Graphics Tools 3(2), 1998),
applied to the cubic cells.

Tetrahedral meshes (``mesh.tetrahedra`` set, e.g. :func:`~neurofuzzy.mesh.from_tetra`) use van
Gelder's rule on the tetrahedra,

    k = E Σ_{tetrahedra containing the spring} V_tet / l²,

and a node carries a quarter of the volume of every tetrahedron it belongs to. The affine
strain energy of one tetrahedron's six springs is then ``½ E V Σ_e (u_eᵀ ε u_e)²``; averaged
over orientations this is an isotropic solid with Young's modulus E and Poisson's ratio 1/4 for
any tetrahedron shape (both Lamé constants come out as 2E/5, because ``Σ_e |u_e|⁴ = 6``), so an
unstructured mesh is close to E in every direction, a little softer because the nodes relax
non-affinely. ``tests/test_rules_physical.py`` checks the effective modulus and Poisson's ratio of a
lattice block and of a TetGen block under uniaxial load.

Viscosity (Kelvin–Voigt, ``σ = E ε + η ε̇``) gives spring viscosities with the same geometric
factor, ``c = η k / E``. Node masses are density times the volume a node carries (an eighth of
every cubic cell, or a quarter of every tetrahedron, it belongs to).
"""


from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..mesh import TET_EDGES, Mesh, lattice_cells

__all__ = ["LatticeGeometry", "lattice_geometry", "TetraGeometry", "tetra_geometry",
           "tetrahedron_edge_springs", "spring_geometry", "volume_shares",
           "SPRING_POISSON_RATIO", "spring_material_values"]

#: Poisson's ratio an isotropic spring network stands for (cubic lattice with body diagonals;
#: van Gelder springs on tetrahedra, averaged over orientations).
SPRING_POISSON_RATIO = 0.25


@dataclass(frozen=True)
class LatticeGeometry:
    """Per-spring factor (``k = E · factor``) and per-node volume of a cubic-cell lattice."""

    spring_factor: np.ndarray
    node_volume: np.ndarray
    spacing: float


def lattice_geometry(mesh: Mesh) -> LatticeGeometry:
    """Recover the cubic cells of a lattice mesh (:func:`~neurofuzzy.mesh.lattice`,
    :func:`~neurofuzzy.mesh.from_trimesh`) and the factors of the module docstring."""
    lattice = lattice_cells(mesh)
    if lattice is None:
        raise InputError("the mesh is neither a lattice of cubic cells nor a tetrahedral mesh; "
                         "rule-based parameters need one (neurofuzzy.lattice, "
                         "neurofuzzy.from_trimesh, or neurofuzzy.mesh.from_tetra)", key="mesh")
    index, cells, spacing = lattice.index, lattice.cells, lattice.spacing
    cells = np.pad(cells, 1)            # index + 1 below, so lower corners -1 are valid
    a, b = mesh.springs.T
    low = np.minimum(index[a], index[b])
    free_axes = index[a] == index[b]                 # axes along which the spring does not run
    n_cells = np.zeros(mesh.n_springs, dtype=int)
    for shift in np.ndindex(2, 2, 2):
        shift = np.array(shift)
        # a cell contains the spring if it is shifted back only along axes the spring spans
        # no distance on
        valid = ~np.any((shift[None, :] == 1) & ~free_axes, axis=1)
        corner = low - shift[None, :] + 1
        n_cells += valid & cells[tuple(corner.T)]
    offsets = np.abs(index[b] - index[a]).sum(axis=1)
    if np.any(n_cells == 0) or np.any(offsets > 3):
        raise InputError("some springs lie in no complete cubic cell; rule-based parameters "
                         "need a lattice mesh", key="mesh")
    body_lattice = set(np.unique(offsets)) <= {1, 3}
    if body_lattice:
        factor = np.where(offsets == 1, spacing * n_cells / 5.0, 3.0 * spacing / 10.0)
    else:      # van Gelder's rule on the cubic cells
        factor = n_cells * spacing**3 / mesh.rest_lengths**2
    return LatticeGeometry(factor, lattice.cells_per_node() * spacing**3 / 8.0, spacing)


@dataclass(frozen=True)
class TetraGeometry:
    """Per-spring factor (``k = E · factor``) and per-node volume of a tetrahedral mesh.

    Parameters
    ----------
    spring_factor : (n_springs,) float
        ``Σ_{tetrahedra containing the spring} V_tet / l²`` (van Gelder).
    node_volume : (n_nodes,) float
        ``Σ_{tetrahedra containing the node} V_tet / 4``.
    tetrahedron_volume : (n_tets,) float
        Volume of every tetrahedron (positive, whatever its orientation).
    """

    spring_factor: np.ndarray
    node_volume: np.ndarray
    tetrahedron_volume: np.ndarray


def tetra_geometry(mesh: Mesh) -> TetraGeometry:
    """The van Gelder factors of a mesh with tetrahedra (module docstring).

    Raises
    ------
    InputError
        The mesh has no tetrahedra, a tetrahedron is flat (zero volume), or a spring or node
        lies in no tetrahedron.
    """
    if mesh.tetrahedra is None:
        raise InputError("the mesh has no tetrahedra; build it with neurofuzzy.mesh.from_tetra "
                         "or from_surface_tetra", key="mesh")
    if mesh.n_springs == 0 or mesh.n_tetrahedra == 0:
        raise InputError(f"the mesh has {mesh.n_springs} springs and {mesh.n_tetrahedra} "
                         "tetrahedra; rule-based parameters need both", key="mesh")
    tetrahedra = mesh.tetrahedra
    corners = mesh.rest_positions[tetrahedra]                       # (n_tets, 4, 3)
    edges = corners[:, 1:] - corners[:, :1]
    volume = np.abs(np.linalg.det(edges)) / 6.0
    scale = np.max(np.linalg.norm(edges, axis=2), axis=1) ** 3
    flat = volume <= 1e-12 * scale
    if np.any(flat):
        bad = int(np.flatnonzero(flat)[0])
        raise InputError(f"tetrahedron {bad} (nodes {tetrahedra[bad].tolist()}) has zero "
                         f"volume; {int(flat.sum())} such", key="tetrahedra")
    edge_spring, is_spring = tetrahedron_edge_springs(mesh)
    contained = np.zeros(mesh.n_springs)
    np.add.at(contained, edge_spring[is_spring], np.repeat(volume, len(TET_EDGES))[is_spring])
    if np.any(contained == 0):
        bad = int(np.flatnonzero(contained == 0)[0])
        raise InputError(f"spring {bad} (nodes {mesh.springs[bad].tolist()}) is an edge of no "
                         f"tetrahedron; {int(np.sum(contained == 0))} such", key="mesh")
    node_volume = np.zeros(mesh.n_nodes)
    np.add.at(node_volume, tetrahedra.ravel(), np.repeat(volume / 4.0, 4))
    if np.any(node_volume == 0):
        bad = int(np.flatnonzero(node_volume == 0)[0])
        raise InputError(f"node {bad} belongs to no tetrahedron, so it carries no volume",
                         key="mesh")
    return TetraGeometry(contained / mesh.rest_lengths**2, node_volume, volume)


def tetrahedron_edge_springs(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    """For the 6 edges of every tetrahedron (``(n_tets * 6,)``, tetrahedron-major): the index
    of the spring on that edge, and whether there is one."""
    n = mesh.n_nodes
    pairs = np.sort(mesh.tetrahedra[:, TET_EDGES].reshape(-1, 2), axis=1)
    edge_keys = pairs[:, 0] * n + pairs[:, 1]
    spring_keys = np.sort(mesh.springs, axis=1) @ np.array([n, 1])
    order = np.argsort(spring_keys)
    position = np.clip(np.searchsorted(spring_keys[order], edge_keys), 0, mesh.n_springs - 1)
    return order[position], spring_keys[order][position] == edge_keys


def spring_geometry(mesh: Mesh) -> LatticeGeometry | TetraGeometry:
    """:func:`tetra_geometry` for a mesh with tetrahedra, else :func:`lattice_geometry`."""
    return tetra_geometry(mesh) if mesh.tetrahedra is not None else lattice_geometry(mesh)


def volume_shares(mesh: Mesh, geometry: TetraGeometry, tet_tissue: np.ndarray,
                   n_tissues: int) -> tuple[np.ndarray, np.ndarray]:
    """(n_springs, n_tissues) and (n_nodes, n_tissues) float: the fraction of the volume
    around every spring (its tetrahedra) and node (a quarter of its tetrahedra) per tissue."""
    edge_spring, is_spring = tetrahedron_edge_springs(mesh)
    per_edge = len(TET_EDGES)
    spring_volume = np.zeros((mesh.n_springs, n_tissues))
    np.add.at(spring_volume, (edge_spring[is_spring], np.repeat(tet_tissue, per_edge)[is_spring]),
              np.repeat(geometry.tetrahedron_volume, per_edge)[is_spring])
    node_volume = np.zeros((mesh.n_nodes, n_tissues))
    np.add.at(node_volume, (mesh.tetrahedra.ravel(), np.repeat(tet_tissue, 4)),
              np.repeat(geometry.tetrahedron_volume, 4))
    return (spring_volume / spring_volume.sum(axis=1, keepdims=True),
            node_volume / node_volume.sum(axis=1, keepdims=True))


def spring_material_values(model, springs=None, nodes=None) -> dict[str, float]:
    """The material quantities a spring model's constants stand for (medians over the given
    springs and nodes, default all; springs with both ends fixed and fixed nodes are left
    out, their values are never learned), by quantity: E and η from the spring constants by
    the factors of the module docstring, ν the 1/4 a spring network is locked to, density
    from the node masses, and the constants themselves (``stiffness``, ``damping``,
    ``node_mass``)."""
    geometry = spring_geometry(model.mesh)
    moving = model.mesh.free[model.mesh.springs].any(axis=1)
    springs = np.flatnonzero(moving) if springs is None else np.intersect1d(
        np.asarray(springs), np.flatnonzero(moving))
    free = np.flatnonzero(model.mesh.free)   # a fixed node's mass is never learned
    nodes = free if nodes is None else np.intersect1d(np.asarray(nodes), free)
    factor = geometry.spring_factor[springs]
    stiffness, damping = model.springs.stiffness[springs], model.springs.damping[springs]
    return {
        "youngs_modulus": float(np.median(stiffness / factor)),
        "poisson_ratio": SPRING_POISSON_RATIO,
        "stiffness": float(np.median(stiffness)),
        "viscosity": float(np.median(damping / factor)),
        "damping": float(np.median(damping)),
        "density": float(np.sum(model.node_mass[nodes]) / np.sum(geometry.node_volume[nodes])),
        "node_mass": float(np.median(model.node_mass[nodes])),
    }
