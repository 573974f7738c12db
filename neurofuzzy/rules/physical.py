"""Material quantities ↔ spring-mass parameters on a lattice mesh.

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
applied to the cubic cells. ``tests/test_rules.py`` checks the effective modulus and Poisson's
ratio of a lattice block under uniaxial load.

Viscosity (Kelvin–Voigt, ``σ = E ε + η ε̇``) gives spring viscosities with the same geometric
factor, ``c = η k / E``. Node masses are density times the volume a node carries (an eighth of
every cell it belongs to).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..mesh import Mesh
from ..model import SpringMassModel, tie_index

__all__ = ["LatticeGeometry", "lattice_geometry", "initialize", "material_values"]


@dataclass(frozen=True)
class LatticeGeometry:
    """Per-spring factor (``k = E · factor``) and per-node volume of a cubic-cell lattice."""

    spring_factor: np.ndarray
    node_volume: np.ndarray
    spacing: float


def lattice_geometry(mesh: Mesh) -> LatticeGeometry:
    """Recover the cubic cells of a lattice mesh (:func:`~neurofuzzy.mesh.lattice`,
    :func:`~neurofuzzy.mesh.from_trimesh`) and the factors of the module docstring."""
    positions = mesh.rest_positions
    spacing = float(np.min(mesh.rest_lengths))
    index = np.rint((positions - positions.min(axis=0)) / spacing).astype(int)
    if not np.allclose(positions.min(axis=0) + index * spacing, positions, atol=1e-6 * spacing):
        raise InputError("the mesh is not a lattice of cubic cells; rule-based parameters need "
                         "one (neurofuzzy.lattice or neurofuzzy.from_trimesh)", key="mesh")
    shape = index.max(axis=0) + 2
    occupied = np.zeros(shape, dtype=bool)
    occupied[tuple(index.T)] = True
    cells = (occupied[:-1, :-1, :-1] & occupied[1:, :-1, :-1] & occupied[:-1, 1:, :-1]
             & occupied[:-1, :-1, 1:] & occupied[1:, 1:, :-1] & occupied[1:, :-1, 1:]
             & occupied[:-1, 1:, 1:] & occupied[1:, 1:, 1:])
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
    corner_counts = np.zeros(mesh.n_nodes)
    inner = cells[1:-1, 1:-1, 1:-1]
    for shift in np.ndindex(2, 2, 2):
        corner = index - np.array(shift)
        inside = np.all((corner >= 0) & (corner < np.array(inner.shape)), axis=1)
        corner_counts[inside] += inner[tuple(corner[inside].T)]
    return LatticeGeometry(factor, corner_counts * spacing**3 / 8.0, spacing)


def initialize(rules, mesh: Mesh, tissue: str | None = None, *, regions: dict | None = None,
               tie: str = "groups") -> tuple[SpringMassModel, dict]:
    """The start model of ``mesh`` from a rule base's tissue(s).

    Parameters
    ----------
    rules : RuleBase
    mesh : Mesh
        A lattice mesh.
    tissue : str, optional
        One tissue for the whole object.
    regions : dict of tissue name → (n_nodes,) bool, optional
        Several tissues: a spring takes the tissue of its first end node's region, a node the
        tissue of its region (nodes in no region take ``tissue``).
    tie : {"global", "groups", "none"}
        Tying of the returned model.

    Returns
    -------
    model : SpringMassModel
    values : dict of tissue → dict of output name → value
        The inferred material values.
    """
    if tissue is None and not regions:
        raise InputError("give a tissue (or regions of tissues)", key="tissue")
    geometry = lattice_geometry(mesh)
    node_tissue = np.full(mesh.n_nodes, tissue, dtype=object)
    for name, mask in (regions or {}).items():
        mask = np.asarray(mask, bool)
        if mask.shape != (mesh.n_nodes,):
            raise InputError(f"region {name!r}: expected a bool mask of shape "
                             f"({mesh.n_nodes},)", key="regions")
        node_tissue[mask] = name
    if any(t is None for t in node_tissue):
        raise InputError("some nodes are in no region and no default tissue is given",
                         key="regions")
    values = {name: rules.tissue(name) for name in dict.fromkeys(node_tissue)}
    spring_tissue = node_tissue[mesh.springs[:, 0]]
    stiffness = np.empty(mesh.n_springs)
    damping = np.empty(mesh.n_springs)
    mass = np.empty(mesh.n_nodes)
    for name, tissue_values in values.items():
        quantities = _by_quantity(rules, tissue_values)
        springs = spring_tissue == name
        nodes = node_tissue == name
        stiffness[springs] = _spring_value(quantities, "youngs_modulus", "stiffness",
                                           geometry.spring_factor[springs], rules.source)
        damping[springs] = _spring_value(quantities, "viscosity", "damping",
                                         geometry.spring_factor[springs], rules.source)
        if "density" in quantities:
            mass[nodes] = quantities["density"] * geometry.node_volume[nodes]
        elif "node_mass" in quantities:
            mass[nodes] = quantities["node_mass"]
        else:
            raise InputError("the rule base has no output for density or node_mass",
                             source=rules.source, key="outputs")
    model = SpringMassModel(mesh, node_mass=mass, spring_stiffness=stiffness,
                            spring_damping=damping)
    # tie within each tissue region: tissue regions × the requested tying
    base_tie = tie_index(mesh, tie)
    _, region_index = np.unique(spring_tissue.astype(str), return_inverse=True)
    combined = base_tie * (region_index.max() + 1) + region_index
    return model.replace(spring_tie=combined), values


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


def material_values(rules, model: SpringMassModel, springs=None, nodes=None) -> dict:
    """The material quantities a model's parameters stand for, per output variable of
    ``rules`` (medians over the given springs and nodes; default all).

    Springs with both ends fixed are left out: their values are never learned.
    """
    geometry = lattice_geometry(model.mesh)
    moving = model.mesh.free[model.mesh.springs].any(axis=1)
    springs = np.flatnonzero(moving) if springs is None else np.intersect1d(
        np.asarray(springs), np.flatnonzero(moving))
    nodes = np.flatnonzero(model.mesh.free) if nodes is None else np.asarray(nodes)
    factor = geometry.spring_factor[springs]
    by_quantity = {
        "youngs_modulus": float(np.median(model.spring_stiffness[springs] / factor)),
        "stiffness": float(np.median(model.spring_stiffness[springs])),
        "viscosity": float(np.median(model.spring_damping[springs] / factor)),
        "damping": float(np.median(model.spring_damping[springs])),
        "density": float(np.sum(model.node_mass[nodes]) / np.sum(geometry.node_volume[nodes])),
        "node_mass": float(np.median(model.node_mass[nodes])),
    }
    return {name: by_quantity[variable.quantity] for name, variable in rules.outputs.items()
            if variable.quantity in by_quantity}
