"""Material quantities ↔ spring-mass parameters on a lattice or tetrahedral mesh.

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
non-affinely. ``tests/test_rules.py`` checks the effective modulus and Poisson's ratio of a
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
from ..model import SpringMassModel

__all__ = ["LatticeGeometry", "lattice_geometry", "TetraGeometry", "tetra_geometry",
           "spring_geometry", "initialize", "material_values"]


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
    edge_spring, is_spring = _tetra_edge_springs(mesh)
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


def _tetra_edge_springs(mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
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


def initialize(rules, mesh: Mesh, tissue: str | None = None, *, regions: dict | None = None,
               tetrahedron_regions: dict | None = None,
               elements: bool = False) -> SpringMassModel:
    """The start model of ``mesh`` from a rule base's tissue(s).

    Parameters
    ----------
    rules : RuleBase
    mesh : Mesh
        A lattice mesh or a mesh with tetrahedra (:func:`spring_geometry`).
    tissue : str, optional
        One tissue for the whole object (with regions: for what lies in no region).
    regions : dict of tissue name → (n_nodes,) bool, optional
        Several tissues by node: a spring takes the tissue of its first end node's region, a
        node the tissue of its region (nodes in no region take ``tissue``; a node in several
        takes the last). The regions of a :class:`~neurofuzzy.mesh.MeshFile` fit here
        once named after tissues (:meth:`~neurofuzzy.mesh.MeshFile.tissue_regions`).
    tetrahedron_regions : dict of tissue name → (n_tetrahedra,) bool, optional
        Several tissues by tetrahedron (meshes with tetrahedra only; instead of ``regions``):
        every tetrahedron contributes its own tissue to van Gelder's sum, so a spring on an
        interface gets ``k = Σ_tissues q_tissue Σ_{its tets of that tissue} V / l²`` and a
        node the mass of a quarter of each of its tetrahedra. This is exact at interfaces,
        where node regions have to give interface springs to one side.
        (``MeshFile.tissue_regions(..., of="tetrahedra")``.)
    elements : bool
        Build tetrahedral finite elements (the mesh needs tetrahedra) whose parameters are the
        tissue's Young's modulus, Poisson's ratio and viscosity themselves, with masses lumped
        from density (:func:`neurofuzzy.rules.materials.element_model`); the springs get zero
        stiffness. Default: the spring network of the module docstring.

    Returns
    -------
    SpringMassModel
        One material region per tissue (``region_names`` and ``region_tissues`` are the tissue
        names; a spring shared by tissues belongs to the one holding most of its volume), tied
        by spring group within each region; re-tie with :meth:`SpringMassModel.tied`. The
        inferred values are ``rules.tissue(name)``.
    """
    if tissue is None and not regions and not tetrahedron_regions:
        raise InputError("give a tissue (or regions of tissues)", key="tissue")
    if regions and tetrahedron_regions:
        raise InputError("give regions (of nodes) or tetrahedron_regions, not both",
                         key="regions")
    geometry = spring_geometry(mesh)
    if tetrahedron_regions:
        if mesh.tetrahedra is None:
            raise InputError("the mesh has no tetrahedra; give regions of nodes instead",
                             key="tetrahedron_regions")
        tet_tissue = _tissue_labels(tetrahedron_regions, mesh.n_tetrahedra, tissue,
                                    "tetrahedron_regions", "tetrahedra")
        names = list(dict.fromkeys(tet_tissue))
        spring_share, node_share = _volume_shares(mesh, geometry, _index_of(tet_tissue, names),
                                                  len(names))
    else:
        node_tissue = _tissue_labels(regions or {}, mesh.n_nodes, tissue, "regions", "nodes")
        names = list(dict.fromkeys(node_tissue))
        node_index = _index_of(node_tissue, names)
        node_share = np.eye(len(names))[node_index]
        spring_share = node_share[mesh.springs[:, 0]]
    values = {name: rules.tissue(name) for name in names}
    if elements:
        from .materials import element_model

        tet_index = (_index_of(tet_tissue, names) if tetrahedron_regions else
                     np.argmax(node_share[mesh.tetrahedra].sum(axis=1), axis=1))
        return element_model(rules, mesh, names, values, tet_index,
                             spring_region=np.argmax(spring_share, axis=1),
                             node_region=np.argmax(node_share, axis=1)).tied("groups")
    stiffness = np.zeros(mesh.n_springs)
    damping = np.zeros(mesh.n_springs)
    mass = np.zeros(mesh.n_nodes)
    for column, tissue_values in enumerate(values.values()):
        quantities = _by_quantity(rules, tissue_values)
        stiffness += spring_share[:, column] * _spring_value(
            quantities, "youngs_modulus", "stiffness", geometry.spring_factor, rules.source)
        damping += spring_share[:, column] * _spring_value(
            quantities, "viscosity", "damping", geometry.spring_factor, rules.source)
        if "density" in quantities:
            mass += node_share[:, column] * (quantities["density"] * geometry.node_volume)
        elif "node_mass" in quantities:
            mass += node_share[:, column] * quantities["node_mass"]
        else:
            raise InputError("the rule base has no output for density or node_mass",
                             source=rules.source, key="outputs")
    model = SpringMassModel(mesh, node_mass=mass, spring_stiffness=stiffness,
                            spring_damping=damping, region_names=tuple(names),
                            region_tissues=tuple(names),
                            spring_region=np.argmax(spring_share, axis=1),
                            node_region=np.argmax(node_share, axis=1))
    return model.tied("groups")


def _tissue_labels(regions: dict, n: int, default: str | None, key: str,
                   what: str) -> np.ndarray:
    """(n,) object: the tissue of every node (or tetrahedron); later regions win."""
    labels = np.full(n, default, dtype=object)
    for name, mask in regions.items():
        mask = np.asarray(mask, bool)
        if mask.shape != (n,):
            raise InputError(f"region {name!r}: got shape {mask.shape}; expected a bool mask "
                             f"of shape ({n},), one value per {what[:-1]}", key=key)
        labels[mask] = name
    missing = sum(label is None for label in labels)
    if missing:
        raise InputError(f"{missing} of the {n} {what} are in none of the regions "
                         f"{', '.join(map(repr, regions)) or '(none given)'} and no default "
                         "tissue is given; give a tissue for the rest (tissue=...)", key=key)
    return labels


def _index_of(labels: np.ndarray, names: list) -> np.ndarray:
    lookup = {name: i for i, name in enumerate(names)}
    return np.array([lookup[label] for label in labels], dtype=np.intp)


def _volume_shares(mesh: Mesh, geometry: TetraGeometry, tet_tissue: np.ndarray,
                   n_tissues: int) -> tuple[np.ndarray, np.ndarray]:
    """(n_springs, n_tissues) and (n_nodes, n_tissues) float: the fraction of the volume
    around every spring (its tetrahedra) and node (a quarter of its tetrahedra) per tissue."""
    edge_spring, is_spring = _tetra_edge_springs(mesh)
    per_edge = len(TET_EDGES)
    spring_volume = np.zeros((mesh.n_springs, n_tissues))
    np.add.at(spring_volume, (edge_spring[is_spring], np.repeat(tet_tissue, per_edge)[is_spring]),
              np.repeat(geometry.tetrahedron_volume, per_edge)[is_spring])
    node_volume = np.zeros((mesh.n_nodes, n_tissues))
    np.add.at(node_volume, (mesh.tetrahedra.ravel(), np.repeat(tet_tissue, 4)),
              np.repeat(geometry.tetrahedron_volume, 4))
    return (spring_volume / spring_volume.sum(axis=1, keepdims=True),
            node_volume / node_volume.sum(axis=1, keepdims=True))


def _by_quantity(rules, values):
    return {rules.outputs[name].quantity: value for name, value in values.items()
            if rules.outputs[name].quantity}


def _spring_value(quantities, material, direct, factor, source):
    if material in quantities:
        return quantities[material] * factor
    if direct in quantities:
        return np.full(factor.shape, quantities[direct])
    raise InputError(f"the rule base has no output for {material} or {direct}", source=source,
                     key="outputs")


#: Poisson's ratio an isotropic spring network stands for (cubic lattice with body diagonals;
#: van Gelder springs on tetrahedra, averaged over orientations).
SPRING_POISSON_RATIO = 0.25


def material_values(rules, model: SpringMassModel, springs=None, nodes=None,
                    elements=None) -> dict:
    """The material quantities a model's parameters stand for, per output variable of
    ``rules``.

    Spring models: medians over the given springs and nodes (default all; springs with both
    ends fixed are left out, their values are never learned); Poisson's ratio is the 1/4 a
    spring network is locked to. Element models: the elements' own E, ν, η (medians over
    ``elements``, default all) and the density of their lumped masses.
    """
    if model.has_elements:
        from .materials import element_values

        chosen = (np.ones(model.mesh.n_tetrahedra, bool) if elements is None
                  else np.isin(np.arange(model.mesh.n_tetrahedra), elements))
        by_quantity = element_values(model, chosen)
        return {name: by_quantity[variable.quantity] for name, variable in rules.outputs.items()
                if variable.quantity in by_quantity}
    geometry = spring_geometry(model.mesh)
    moving = model.mesh.free[model.mesh.springs].any(axis=1)
    springs = np.flatnonzero(moving) if springs is None else np.intersect1d(
        np.asarray(springs), np.flatnonzero(moving))
    nodes = np.flatnonzero(model.mesh.free) if nodes is None else np.asarray(nodes)
    factor = geometry.spring_factor[springs]
    by_quantity = {
        "youngs_modulus": float(np.median(model.spring_stiffness[springs] / factor)),
        "poisson_ratio": SPRING_POISSON_RATIO,
        "stiffness": float(np.median(model.spring_stiffness[springs])),
        "viscosity": float(np.median(model.spring_damping[springs] / factor)),
        "damping": float(np.median(model.spring_damping[springs])),
        "density": float(np.sum(model.node_mass[nodes]) / np.sum(geometry.node_volume[nodes])),
        "node_mass": float(np.median(model.node_mass[nodes])),
    }
    return {name: by_quantity[variable.quantity] for name, variable in rules.outputs.items()
            if variable.quantity in by_quantity}

