"""A rule base's tissues → a start model: :func:`initialize` (the start model of a mesh from the
tissues' inferred values, a spring network or tetrahedral elements) and :func:`element_model`.
The physics of the mapping (spring homogenisation, element models) is
:mod:`neurofuzzy.constants`; this module reads the rule base's outputs and tissues (a
:class:`~neurofuzzy.rules.RuleBase`, used through its methods: nothing of the rules is
imported, so the words never depend on the physics)."""

from __future__ import annotations

import numpy as np

from ..constants import DEFAULT_POISSON_RATIO, spring_geometry, volume_shares
from ..constants import element_model as build_element_model
from ..errors import InputError
from ..forces import Springs
from ..mesh import Mesh
from ..model import Model

__all__ = ["initialize", "element_model"]


def initialize(rules, mesh: Mesh, tissue: str | None = None, *, regions: dict | None = None,
               tetrahedron_regions: dict | None = None,
               elements: bool | None = None) -> Model:
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
    elements : bool, optional
        Build tetrahedral finite elements (the mesh needs tetrahedra) whose parameters are the
        tissue's Young's modulus, Poisson's ratio and viscosity themselves, with masses lumped
        from density (:func:`element_model`); the springs get zero
        stiffness. ``False``: the spring network of the module docstring (which locks
        Poisson's ratio at 1/4, so an incompressible tissue reads back "compressible").
        Default: elements when the mesh has tetrahedra, as ``neurofuzzy mesh`` and ``fit``.

    Returns
    -------
    Model
        One material region per tissue (``region_names`` and ``region_tissues`` are the tissue
        names; a spring shared by tissues belongs to the one holding most of its volume), tied
        by spring group within each region; re-tie with :meth:`Model.tied`. The
        inferred values are ``rules.tissue(name)``.
    """
    if tissue is None and not regions and not tetrahedron_regions:
        raise InputError("give a tissue (or regions of tissues)", key="tissue")
    if regions and tetrahedron_regions:
        raise InputError("give regions (of nodes) or tetrahedron_regions, not both",
                         key="regions")
    if elements is None:
        elements = mesh.tetrahedra is not None
    geometry = spring_geometry(mesh)
    if tetrahedron_regions:
        if mesh.tetrahedra is None:
            raise InputError("the mesh has no tetrahedra; give regions of nodes instead",
                             key="tetrahedron_regions")
        tet_tissue = _tissue_labels(tetrahedron_regions, mesh.n_tetrahedra, tissue,
                                    "tetrahedron_regions", "tetrahedra")
        names = list(dict.fromkeys(tet_tissue))
        spring_share, node_share = volume_shares(mesh, geometry, _index_of(tet_tissue, names),
                                                 len(names))
    else:
        node_tissue = _tissue_labels(regions or {}, mesh.n_nodes, tissue, "regions", "nodes")
        names = list(dict.fromkeys(node_tissue))
        node_index = _index_of(node_tissue, names)
        node_share = np.eye(len(names))[node_index]
        spring_share = node_share[mesh.springs[:, 0]]
    values = {name: rules.tissue(name) for name in names}
    if elements:
        tet_index = (_index_of(tet_tissue, names) if tetrahedron_regions else
                     np.argmax(node_share[mesh.tetrahedra].sum(axis=1), axis=1))
        return element_model(rules, mesh, names, values, tet_index,
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
    springs = Springs(stiffness=stiffness, damping=damping,
                      region=np.argmax(spring_share, axis=1))
    model = Model(mesh, mass, (springs,), region_names=tuple(names), region_tissues=tuple(names),
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


#: the quantities of a Prony term's words
RELAXATION = ("relaxation_modulus", "relaxation_time")
#: the quantity of Yeoh's stiffening in words (the law whose record names it:
#: :data:`~neurofuzzy.forces.laws.LAW_OF_QUANTITY`)
STIFFENING = "strain_stiffening"


def _inputs_of(rules, *quantities) -> set[str]:
    """The input variables of the rules that conclude on an output of ``quantities``."""
    return rules.deciding(name for name, variable in rules.outputs.items()
                          if variable.quantity in quantities)


def element_model(rules, mesh, names, values, element_tissue, *, node_region) -> Model:
    """An element model of ``mesh``: every tetrahedron takes E, ν, η and density of its
    tissue (``element_tissue`` indexes ``names``; ``values[name]`` are the tissue's inferred
    outputs). ν comes from an output of quantity ``poisson_ratio`` where the rule base has
    one and the tissue's description, or an input's ``default:``, decides an input of its
    rules; else (nothing about compressibility: no ν rule fires)
    :data:`~neurofuzzy.constants.DEFAULT_POISSON_RATIO`. Likewise the elements
    relax (one Prony term, :mod:`neurofuzzy.forces.relaxation`) with the ``relaxation_modulus``
    and ``relaxation_time`` outputs where some tissue's description names an input of their
    rules; the others then get g = 0 (no relaxation). And the tissues whose description names
    an input of the ``strain_stiffening`` output's rules become Yeoh elements
    (:mod:`neurofuzzy.forces.laws`) with that ``C₂₀/C₁₀``; the others keep the default law."""
    if mesh.tetrahedra is None:
        raise InputError("element models need a mesh with tetrahedra (a volume mesh, or "
                         "--tetra for a surface)", key="elements")
    per_tissue = {key: np.empty(len(names)) for key in ("youngs_modulus", "poisson_ratio",
                                                         "viscosity", "density")}
    relaxation, stiffening = [], []
    for index, name in enumerate(names):
        quantities = {rules.outputs[output].quantity: value
                      for output, value in values[name].items() if rules.outputs[output].quantity}
        for key in ("youngs_modulus", "viscosity", "density"):
            if key not in quantities:
                raise InputError(f"an element model needs the rule base's {key}; it has "
                                 f"{sorted(quantities)}", source=rules.source, key="outputs")
            per_tissue[key][index] = quantities[key]
        words = rules.tissues.get(name, {})
        said = _inputs_of(rules, "poisson_ratio") & {*words, *rules.defaults_taken(words)}
        per_tissue["poisson_ratio"][index] = (quantities["poisson_ratio"] if said
                                              and "poisson_ratio" in quantities
                                              else DEFAULT_POISSON_RATIO)
        relaxes = (_inputs_of(rules, *RELAXATION) & set(rules.tissues.get(name, {}))
                   and all(key in quantities for key in RELAXATION))
        relaxation.append((quantities["relaxation_modulus"], quantities["relaxation_time"])
                          if relaxes else None)
        stiffens = (_inputs_of(rules, STIFFENING) & set(rules.tissues.get(name, {}))
                    and STIFFENING in quantities)
        stiffening.append(quantities[STIFFENING] if stiffens else None)
    model = build_element_model(mesh, names, per_tissue, element_tissue,
                                node_region=node_region)
    if any(value is not None for value in stiffening):
        yeoh = np.array([value is not None for value in stiffening])
        c = np.array([0.0 if value is None else value for value in stiffening])
        from ..forces.laws import LAW_OF_QUANTITY

        laws = np.where(yeoh, LAW_OF_QUANTITY[STIFFENING], 0)
        model = model.with_elements(law=laws[element_tissue], stiffening=c[element_tissue])
    if not any(relaxation):
        return model
    g = np.array([0.0 if r is None else r[0] for r in relaxation])
    tau = np.array([1.0 if r is None else r[1] for r in relaxation])
    return model.with_elements(relaxation_moduli=g[element_tissue][:, None],
                               relaxation_times=tau[element_tissue][:, None])
