"""The free parameters of a fit as one flat vector, and back to a model.

Every term of the model gives its blocks (:meth:`~neurofuzzy.forces.ForceTerm.blocks`,
:mod:`neurofuzzy.forces.blocks`), laid side by side in the order of the model's terms:

- ``log_stiffness``, ``log_damping`` (n_ties each): the springs' shared stiffness and viscosity
  of every tie group;
- ``log_youngs_modulus``, ``logit_poisson_ratio``, ``log_viscosity`` (n_element_ties each): the
  tetrahedral elements' E, ν = σ(θ)/2 (so ν stays in (0, 0.5)) and η of every element tie
  group; ``log_relaxation_moduli``, ``log_relaxation_times`` (K · n_element_ties, term-major):
  the relative modulus g and time τ of each of the K Prony terms (elements that relax,
  :mod:`neurofuzzy.forces.relaxation`); ``log_stiffening`` (one per element tie group with
  Yeoh elements): Yeoh's ``C₂₀/C₁₀`` (:mod:`neurofuzzy.forces.laws`);
- ``log_mass`` (n_free_nodes,): log of every free node's mass (when masses are learned);
- ``effect:i``: the raw parameters of the model's effect number i (when effects are
  learned).

Logs keep stiffness, viscosity and mass positive and make their steps relative.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..forces import Springs, Tetrahedra
from ..forces.blocks import (ELEMENT_BLOCKS, RELAXATION_BLOCKS, ElementBlocks, SpringBlocks,
                             TieGroups)
from ..model import Model

__all__ = ["Parameterization", "ELEMENT_BLOCKS", "RELAXATION_BLOCKS", "element_directions",
           "law_constant_columns"]


def law_constant_columns(parameters, model) -> np.ndarray:
    """(n_elements,) the column of every element's ``log_stiffening`` parameter (-1: not a
    Yeoh element, or not learned)."""
    if model.elements is None:
        return np.zeros(0, np.intp)
    columns = np.full(model.mesh.n_tetrahedra, -1, np.intp)
    block = parameters.blocks.get("log_stiffening")
    if block is not None:
        elements = model.elements
        yeoh = elements.stiffens
        groups = parameters.elements.stiffening_groups
        columns[yeoh] = block.start + np.searchsorted(groups, elements.tie[yeoh])
    return columns


def element_directions(model) -> dict[str, sp.csr_matrix]:
    """Per element quantity, the sparse (n_elements, 3 n_element_ties) derivative of every
    element's value by the element parameters (the three element blocks side by side, in
    ``ELEMENT_BLOCKS`` order): ``dE/d log E = E``, ``dν/d logit = ν (1 - 2ν)`` for ``ν = σ/2``,
    ``dη/d log η = η``, each in its element's tie-group column."""
    elements = model.elements
    n, ties = model.mesh.n_tetrahedra, elements.n_ties
    nu = elements.poisson_ratio
    factors = {"youngs_modulus": elements.youngs_modulus,
               "poisson_ratio": nu * (1.0 - 2.0 * nu), "viscosity": elements.viscosity}
    return {name: sp.csr_matrix((factors[name], (np.arange(n), block * ties + elements.tie)),
                                shape=(n, 3 * ties))
            for block, name in enumerate(factors)}


@dataclass
class Block:
    name: str
    start: int
    stop: int

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)


class Parameterization:
    """Flat parameter vector of ``model`` for the gradient learner: the blocks of its terms
    (:mod:`neurofuzzy.forces.blocks`) side by side, and the free nodes' masses.

    Parameters
    ----------
    model : Model
        Start model; fixes tying, the ratios within tie groups and the effects' options.
    learn_masses : bool
        Include the free nodes' masses.
    learn_effects : bool
        Include the parameters of the model's effects.
    """

    def __init__(self, model: Model, *, learn_masses: bool = False,
                 learn_effects: bool = True):
        self.base = model
        self.free_nodes = np.flatnonzero(model.mesh.free)
        self.learn_masses = learn_masses
        self.effects = list(model.effects) if learn_effects else []
        #: the blocks of every learned term, by the term's position in ``model.terms``
        self.terms: dict[int, object] = {}
        effect_index = 0
        for position, term in enumerate(model.terms):
            effect = not isinstance(term, (Springs, Tetrahedra))
            if effect and not learn_effects:
                continue
            self.terms[position] = term.blocks(model, index=effect_index)
            effect_index += effect
        self.springs = next((b for b in self.terms.values() if isinstance(b, SpringBlocks)),
                            None)
        self.elements = next((b for b in self.terms.values() if isinstance(b, ElementBlocks)),
                             None)
        sizes = [size for blocks in self.terms.values() for size in blocks.sizes]
        if learn_masses:
            # after the springs and elements, before the effects (the order of the blocks)
            at = sum(len(b.sizes) for b in (self.springs, self.elements) if b is not None)
            sizes.insert(at, ("log_mass", len(self.free_nodes)))
        blocks, start = [], 0
        for name, size in sizes:
            blocks.append(Block(name, start, start + size))
            start += size
        self.blocks = {block.name: block for block in blocks}
        self.size = start

    @property
    def learn_springs(self) -> bool:
        """Are the springs' constants learned (a model with springs)?"""
        return self.springs is not None

    @property
    def tied(self) -> TieGroups:
        """The springs' tie groups (none for a model without springs)."""
        return (self.springs.tied if self.springs is not None
                else TieGroups(np.zeros(self.base.n_springs, np.intp), 0))

    def ratio(self, name: str) -> np.ndarray | None:
        """(n_members,) the start ratios of the members of block ``name`` to their tie group's
        value (springs' stiffness and damping, elements' E and η; None otherwise)."""
        for blocks in self.terms.values():
            ratio = blocks.ratio(name)
            if ratio is not None:
                return ratio
        return None

    def initial(self) -> np.ndarray:
        """(n_params,) the start model's parameter vector."""
        theta = np.empty(self.size)
        for blocks in self.terms.values():
            for name, values in blocks.initial().items():
                theta[self.blocks[name].slice] = values
        if self.learn_masses:
            theta[self.blocks["log_mass"].slice] = np.log(self.base.node_mass[self.free_nodes])
        return theta

    def _values(self, blocks, theta) -> dict[str, np.ndarray]:
        return {name: theta[self.blocks[name].slice] for name, _ in blocks.sizes}

    def model(self, theta: np.ndarray) -> Model:
        """The model with parameter vector ``theta``."""
        terms = list(self.base.terms)
        for position, blocks in self.terms.items():
            terms[position] = blocks.term(self._values(blocks, theta))
        changes = {"terms": tuple(terms)}
        if self.learn_masses:
            mass = self.base.node_mass.copy()
            mass[self.free_nodes] = np.exp(theta[self.blocks["log_mass"].slice])
            changes["node_mass"] = mass
        return self.base.replace(**changes)

    def element_values(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """The elements' E, ν and η (per element; the Prony terms and Yeoh's constants when
        learned) of the parameter vector ``theta``, by field name."""
        return self.elements.values(self._values(self.elements, theta))

    def physical(self, theta: np.ndarray) -> np.ndarray:
        """(n_params,) every parameter in its own units: ``exp`` of the log blocks (a tie
        group's shared stiffness, viscosity, modulus or mass), Poisson's ratio from its logit,
        effect parameters as they are."""
        theta = np.asarray(theta, float)
        values = theta.copy()
        with np.errstate(over="ignore"):
            for block in self.blocks.values():
                if block.name.startswith("log_"):
                    values[block.slice] = np.exp(theta[block.slice])
                elif block.name == "logit_poisson_ratio":
                    values[block.slice] = 0.5 / (1.0 + np.exp(-theta[block.slice]))
        return values

    def names(self) -> list[str]:
        """A readable name for every parameter ("stiffness[edge]", "mass[node 4]" …), in the
        order of the vector."""
        by_block = {}
        for blocks in self.terms.values():
            names = iter(blocks.names())
            for name, size in blocks.sizes:
                by_block[name] = [next(names) for _ in range(size)]
        by_block["log_mass"] = [f"mass[node {i}]" for i in self.free_nodes]
        return [name for block in self.blocks.values() for name in by_block[block.name]]

    def tie_labels(self) -> list[str]:
        """Label of every spring tie group: a spring-group name, "all springs" or "spring j"."""
        return self.springs.tie_labels() if self.springs is not None else []

    def springs_of(self, index: int) -> np.ndarray:
        """Springs whose value parameter ``index`` sets (empty for masses and effects)."""
        for name in ("log_stiffness", "log_damping"):
            block = self.blocks.get(name)
            if block is not None and block.start <= index < block.stop:
                return np.flatnonzero(self.tied.tie == index - block.start)
        return np.zeros(0, dtype=int)

    def nodes_of(self, index: int) -> np.ndarray:
        """Nodes whose mass parameter ``index`` sets (empty otherwise)."""
        if self.learn_masses:
            block = self.blocks["log_mass"]
            if block.start <= index < block.stop:
                return self.free_nodes[[index - block.start]]
        return np.zeros(0, dtype=int)
