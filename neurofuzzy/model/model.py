"""The model: a :class:`~neurofuzzy.mesh.Mesh`, node masses and a tuple of force terms.

A model is immutable; learners and tools return new models (``model.replace(...)``,
``model.with_term(...)``).

Terms
-----
Every force of a model is a term (:class:`~neurofuzzy.forces.ForceTerm`) that owns its
parameters: :class:`~neurofuzzy.forces.Springs` (stiffness, damping, rest length and tie group
of every spring), :class:`~neurofuzzy.forces.Tetrahedra` (E, ν, η, material law, Prony terms
of every element) and each effect of :mod:`neurofuzzy.effects`. A spring network and an element
model are the same class with different terms: ``model.springs``, ``model.elements`` (None
when the model has none) and ``model.effects``.

Regions
-------
A model may consist of several materials (an organ with a tumour): ``region_names`` names them
(``region_tissues`` gives the rule-base tissue of each, where known); ``node_region``, the
springs' and the elements' ``region`` say which region every node, spring and element belongs
to. Tying never crosses a region boundary (:meth:`Model.tied`), so every region keeps its own
learned values.

Parameter tying
---------------
The springs' ``tie`` assigns every spring to a tie group. Springs of one tie group are learned
together: the learners change their stiffness (and their viscosity) by one common factor, so
the ratios between tied springs stay as they start (all equal when they start equal, as in the
paper's homogeneous cube). ``tied("global")`` puts every spring into one group, ``"groups"``
uses the mesh's spring groups (e.g. lattice edges and diagonals), ``"none"`` gives every spring
its own parameters; elements are tied per region (or not at all with ``"none"``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError, closest_name
from ..forces import ForceTerm, Springs, Tetrahedra, region_index, vector
from ..forces.laws import LAWS, STIFFENING_CONSTANT
from ..forces.relaxation import relaxation_fields
from ..mesh import Mesh
from .values import PerSpring, Tie, describe, per_spring, tie_index

__all__ = ["Model"]


@dataclass(frozen=True, eq=False, init=False)
class Model:
    """A mesh, the mass of every node and the force terms acting on it.

    Parameters
    ----------
    mesh : Mesh
        Nodes, springs, tetrahedra, spring groups and fixed nodes.
    node_mass : float or (n_nodes,) float
        Mass ``m`` of every node (kg; the paper's ``w_m = 1/m``).
    terms : sequence of ForceTerm
        The forces: at most one :class:`~neurofuzzy.forces.Springs`, at most one
        :class:`~neurofuzzy.forces.Tetrahedra`, and any effects
        (:mod:`neurofuzzy.effects`). Kept in that order (springs, elements, effects as
        given), each checked against the mesh (:meth:`ForceTerm.bound`).
    region_names : tuple of str, optional
        Names of the model's material regions (default one region, ``("object",)``).
    region_tissues : tuple of (str or None), optional
        The rule-base tissue of every region (default unknown).
    node_region : (n_nodes,) int, optional
        Region of every node (default 0).
    """

    mesh: Mesh
    node_mass: np.ndarray
    terms: tuple
    region_names: tuple
    region_tissues: tuple
    node_region: np.ndarray

    def __init__(self, mesh: Mesh, node_mass, terms: Sequence[ForceTerm] = (), *,
                 region_names: Sequence[str] = ("object",), region_tissues=None,
                 node_region=None):
        names = tuple(str(name) for name in region_names)
        if not names or len(set(names)) != len(names):
            raise InputError(f"got {list(names)}; expected distinct names",
                             key="region_names")
        tissues = ((None,) * len(names) if region_tissues is None
                   else tuple(None if t is None else str(t) for t in region_tissues))
        if len(tissues) != len(names):
            raise InputError(f"got {len(tissues)} tissues for {len(names)} regions",
                             key="region_tissues")
        mass = vector(node_mass, mesh.n_nodes, "node_mass", "n_nodes")
        if np.any(mass <= 0):
            raise InputError("must be positive", key="node_mass")
        mass.setflags(write=False)
        nodes = region_index(node_region, mesh.n_nodes, len(names), "node_region", "n_nodes")
        nodes.setflags(write=False)
        for key, value in (("mesh", mesh), ("node_mass", mass), ("region_names", names),
                           ("region_tissues", tissues), ("node_region", nodes)):
            object.__setattr__(self, key, value)
        object.__setattr__(self, "terms", tuple(term.bound(self) for term in _ordered(terms)))

    # -- the terms ----------------------------------------------------------------------------
    @property
    def springs(self) -> Springs | None:
        """The springs' term, or None for a model without springs (element models)."""
        first = self.terms[0] if self.terms else None
        return first if isinstance(first, Springs) else None

    @property
    def elements(self) -> Tetrahedra | None:
        """The tetrahedral elements' term, or None for a model without elements."""
        for term in self.terms[:2]:
            if isinstance(term, Tetrahedra):
                return term
        return None

    @property
    def effects(self) -> tuple:
        """The effects the model carries (every term but its springs and elements)."""
        return tuple(term for term in self.terms if not isinstance(term, (Springs, Tetrahedra)))

    @property
    def force_terms(self) -> tuple:
        """Every force term of the model (:attr:`terms`): its springs, its elements, then its
        effects."""
        return self.terms

    def with_term(self, term: ForceTerm) -> Model:
        """A copy with ``term`` in place of the model's term of its kind (springs, elements),
        or of the effect it was made from (``effect.with_params``: the same class and
        options, or the very object); added when there is none."""
        kind = Springs if isinstance(term, Springs) else (
            Tetrahedra if isinstance(term, Tetrahedra) else None)
        if kind is not None:
            kept = tuple(t for t in self.terms if not isinstance(t, kind))
            return self.replace(terms=(term, *kept))
        return self.replace(terms=self.terms + (term,))

    def with_springs(self, **changes) -> Model:
        """A copy whose springs have some fields changed (``model.with_springs(stiffness=s)``);
        :class:`InputError` for a model without springs."""
        if self.springs is None:
            raise InputError("this model has no springs", key="springs")
        return self.with_term(self.springs.replace(**changes))

    def with_elements(self, **changes) -> Model:
        """A copy whose elements have some fields changed (``model.with_elements(law=
        "neo-hookean")``); :class:`InputError` for a model without elements."""
        if self.elements is None:
            raise InputError("this model has no tetrahedral elements", key="elements")
        return self.with_term(self.elements.replace(**changes))

    def with_effects(self, *effects) -> Model:
        """A copy that carries ``effects`` in addition to those it has."""
        return self.replace(terms=self.terms + tuple(effects))

    def replace(self, **changes) -> Model:
        """A copy with some fields changed: the model's own (``mesh``, ``node_mass``,
        ``terms``, ``region_names`` …) or ``effects`` (the effects in place of the model's; a
        term's own fields change with :meth:`with_springs`, :meth:`with_elements`)."""
        effects = changes.pop("effects", None)
        model = replace(self, **changes) if changes else self
        if effects is not None:
            kept = tuple(t for t in model.terms if isinstance(t, (Springs, Tetrahedra)))
            model = replace(model, terms=kept + tuple(effects))
        return model

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def uniform(cls, mesh: Mesh, *, stiffness: PerSpring, damping: PerSpring,
                node_mass: float | Sequence[float] | None = None,
                total_mass: float | None = None, tie: Tie = "none") -> Model:
        """A spring network with the given constants, per spring group or for all springs.

        Parameters
        ----------
        mesh : Mesh
        stiffness, damping : float, (n_springs,) float or mapping group name -> float
            Spring constant and viscosity; a mapping gives one value per spring group,
            e.g. ``{"edge": 100.0, "diagonal": 50.0}``.
        node_mass : float or (n_nodes,) float, optional
            Mass of each node.
        total_mass : float, optional
            Instead of ``node_mass``: the object's mass, divided equally between the nodes
            (the paper's "predefined masses").
        tie : {"global", "groups", "none"}
            Parameter tying for learning.
        """
        if (node_mass is None) == (total_mass is None):
            raise InputError("give exactly one of node_mass and total_mass")
        masses = (np.full(mesh.n_nodes, total_mass / mesh.n_nodes) if total_mass is not None
                  else node_mass)
        springs = Springs(stiffness=per_spring(mesh, stiffness, "stiffness"),
                          damping=per_spring(mesh, damping, "damping"),
                          tie=tie_index(mesh, tie))
        return cls(mesh, np.broadcast_to(np.asarray(masses, float), (mesh.n_nodes,)),
                   (springs,))

    @classmethod
    def continuum(cls, mesh: Mesh, *, youngs_modulus, poisson_ratio, viscosity,
                  density, volumetric: str = "nodal", law="st-venant-kirchhoff",
                  relaxation=None, stiffening=None) -> Model:
        """A tetrahedral finite-element model of ``mesh`` (which needs ``tetrahedra``).

        Parameters
        ----------
        youngs_modulus, poisson_ratio, viscosity : float or (n_tetrahedra,) float
            E (Pa), ν in (0, 0.5) and η (Pa·s) of every element.
        density : float or (n_tetrahedra,) float
            kg/m³; every node carries a quarter of the mass of each of its tetrahedra
            (lumped mass).
        volumetric : {"nodal", "element"}
            The elements' volumetric form (:class:`~neurofuzzy.forces.Tetrahedra`).
        law : str or (n_tetrahedra,), optional
            The elements' material law: ``"st-venant-kirchhoff"``, ``"neo-hookean"`` or
            ``"yeoh"``.
        relaxation : tuple of (g, τ) pairs, optional
            Prony terms for every element, e.g. ``[(0.5, 0.05)]``: the standard linear solid
            whose long-term modulus is E and instantaneous one 1.5 E, relaxing in 50 ms.
        stiffening : float or (n_tetrahedra,), optional
            The law's own constant: Yeoh's ``C₂₀/C₁₀`` of the Yeoh elements, Mooney–Rivlin's
            ``C₀₁/C₁₀`` of the Mooney–Rivlin ones (the physics calls it ``law_constant``;
            the model file and the commands keep the name ``stiffening``).

        The model has no springs term (the mesh's springs, its tetrahedron edges, exert no
        force).
        """
        from ..forces import tetrahedron_geometry

        geometry = tetrahedron_geometry(mesh)
        n = mesh.n_tetrahedra
        element_mass = np.broadcast_to(np.asarray(density, float), (n,)) * geometry.volume
        node_mass = np.bincount(geometry.nodes.ravel(), np.repeat(element_mass / 4, 4),
                                mesh.n_nodes)
        if np.any(node_mass <= 0):
            raise InputError("some nodes belong to no tetrahedron, so they carry no mass",
                             key="tetrahedra")
        relaxation = relaxation_fields(relaxation)
        elements = Tetrahedra(
            youngs_modulus=np.broadcast_to(youngs_modulus, (n,)),
            poisson_ratio=np.broadcast_to(poisson_ratio, (n,)),
            viscosity=np.broadcast_to(viscosity, (n,)), volumetric=volumetric, law=law,
            stiffening=stiffening,
            relaxation_moduli=relaxation.get("relaxation_moduli"),
            relaxation_times=relaxation.get("relaxation_times"))
        return cls(mesh, node_mass, (elements,))

    def tied(self, tie: Tie) -> Model:
        """A copy with spring tying ``"global"``, ``"groups"`` or ``"none"`` within each
        region (tie groups never span two regions); elements are tied per region, or not at
        all with ``"none"``."""
        terms = []
        for term in self.terms:
            if isinstance(term, Springs):
                term = term.replace(tie=tie_index(self.mesh, tie) * len(self.region_names)
                                    + term.region)
            elif isinstance(term, Tetrahedra):
                term = term.replace(tie=np.arange(len(term.tie), dtype=np.intp)
                                    if tie == "none" else term.region)
            terms.append(term)
        return self.replace(terms=tuple(terms))

    # -- regions --------------------------------------------------------------------------
    def region_springs(self, region: str) -> np.ndarray:
        """Indices of the springs of the region named ``region`` (empty without springs)."""
        index = self._region_index(region)
        return (np.zeros(0, np.intp) if self.springs is None
                else np.flatnonzero(self.springs.region == index))

    def region_elements(self, region: str) -> np.ndarray:
        """Indices of the tetrahedral elements of the region named ``region`` (empty without
        elements)."""
        index = self._region_index(region)
        return (np.zeros(0, np.intp) if self.elements is None
                else np.flatnonzero(self.elements.region == index))

    def region_nodes(self, region: str) -> np.ndarray:
        """Indices of the nodes of the region named ``region``."""
        return np.flatnonzero(self.node_region == self._region_index(region))

    def _region_index(self, region: str) -> int:
        if region not in self.region_names:
            hint = closest_name(str(region), self.region_names)
            raise InputError(f"no region {region!r}" + (f"; did you mean {hint!r}?" if hint
                                                         else f"; the model has "
                                                         f"{list(self.region_names)}"),
                             key="region")
        return self.region_names.index(region)

    # -- derived quantities ---------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        return self.mesh.n_nodes

    @property
    def n_springs(self) -> int:
        return self.mesh.n_springs

    @property
    def n_relaxation_terms(self) -> int:
        """How many Prony terms the elements carry (0: no relaxation, or no elements)."""
        return 0 if self.elements is None else self.elements.n_relaxation_terms

    @property
    def length_unit(self) -> float:
        """The mean rest length of the springs (the mesh's springs for a model without
        springs): the unit of the learners' errors (the paper's E, eq. 2.2)."""
        rest = self.mesh.rest_lengths if self.springs is None else self.springs.rest_length
        return float(np.mean(rest))

    @property
    def node_inverse_mass(self) -> np.ndarray:
        """(n_nodes,) float: the paper's weight ``w_m = 1/m``, zero at fixed nodes (they never
        accelerate)."""
        weight = 1.0 / self.node_mass
        weight[self.mesh.fixed] = 0.0
        return weight

    def group_values(self, values: np.ndarray) -> dict[str, float]:
        """Mean of a per-spring array within each spring group, by group name."""
        groups = self.mesh.spring_group
        return {name: float(values[groups == g].mean())
                for g, name in enumerate(self.mesh.group_names) if np.any(groups == g)}

    def summary(self) -> str:
        """Short human-readable description of the parameters."""
        springs, elements = self.springs, self.elements
        pulls = springs is not None and bool(np.any(springs.stiffness) or np.any(springs.damping))
        parts = [f"{self.n_nodes} nodes ({len(self.mesh.fixed)} fixed)"]
        if elements is not None:
            parts.append(f"{self.mesh.n_tetrahedra} tetrahedral elements, "
                         f"{elements.n_ties} tie group(s)")
        if pulls or elements is None:
            parts.append(f"{self.n_springs} springs" + (
                "" if elements is not None else
                f", {0 if springs is None else springs.n_ties} tie group(s)"))
        lines = [f"Model: {', '.join(parts)}", f"  node mass: {describe(self.node_mass)}"]
        if elements is not None:
            lines.append(f"  elements: Young's modulus {describe(elements.youngs_modulus)}"
                         f" Pa, Poisson's ratio {describe(elements.poisson_ratio)}, "
                         f"viscosity {describe(elements.viscosity)} Pa s")
            lines.append(f"  material law: {elements.law_names()}")
            for law, name in STIFFENING_CONSTANT.items():
                own = elements.law == law
                if own.any():
                    lines.append(f"  {LAWS[law].capitalize()} {name}: "
                                 f"{describe(elements.stiffening[own])}")
            for k in range(elements.n_relaxation_terms):
                lines.append(f"  relaxation term {k + 1}: relative modulus "
                             f"{describe(elements.relaxation_moduli[:, k])}, time "
                             f"{describe(elements.relaxation_times[:, k])} s")
        for g, name in enumerate(self.mesh.group_names if pulls or elements is None else ()):
            sel = self.mesh.spring_group == g
            stiffness = springs.stiffness[sel] if springs is not None else np.zeros(sel.sum())
            damping = springs.damping[sel] if springs is not None else np.zeros(sel.sum())
            lines.append(f"  {name} ({int(sel.sum())} springs): stiffness "
                         f"{describe(stiffness)}, damping {describe(damping)}")
        if len(self.region_names) > 1 or self.region_tissues[0] is not None:
            for index, (name, tissue) in enumerate(zip(self.region_names, self.region_tissues)):
                parts = (f"{int(np.sum(elements.region == index))} elements"
                         if elements is not None else
                         f"{int(np.sum(springs.region == index))} springs"
                         if springs is not None else "")
                lines.append(f"  region {name}{f' ({tissue})' if tissue and tissue != name else ''}"
                             f": {int(np.sum(self.node_region == index))} nodes"
                             + (f", {parts}" if parts else ""))
        lines += [f"  effect: {effect}" for effect in self.effects]
        return "\n".join(lines)


def _ordered(terms) -> tuple:
    """``terms`` as a model keeps them: its springs, its elements, then the effects in the
    order given; at most one term of springs and one of elements."""
    terms = tuple(terms)
    springs = [t for t in terms if isinstance(t, Springs)]
    elements = [t for t in terms if isinstance(t, Tetrahedra)]
    if len(springs) > 1 or len(elements) > 1:
        raise InputError("a model holds at most one Springs and one Tetrahedra term, got "
                         f"{len(springs)} and {len(elements)}", key="terms")
    for term in terms:
        if getattr(term, "switches_material", False) and not isinstance(term, ForceTerm):
            raise InputError(f"{term.name} is a change of the elements' material, not a force "
                             f"a model carries: {term.instead}", key="terms")
        if not isinstance(term, ForceTerm):
            raise InputError(f"got {type(term).__name__}; every term of a model is a "
                             "ForceTerm (Springs, Tetrahedra or an effect)", key="terms")
    effects = tuple(t for t in terms if not isinstance(t, (Springs, Tetrahedra)))
    single = [effect for effect in effects if effect.one_per_model]
    for effect in single:
        if sum(other.name == effect.name for other in single) > 1:
            raise InputError(f"a model carries one {effect.name}"
                             f"{' on elements' if effect.options.get('on') else ''}; two "
                             "add up to one whose parameter is their sum", key="effects")
    return (*springs, *elements, *effects)
