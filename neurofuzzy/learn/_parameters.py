"""The free parameters of a fit as one flat vector, and back to a model.

Blocks, in this order (each optional):

- ``log_stiffness`` (n_ties,): log of the shared stiffness of every tie group;
- ``log_damping`` (n_ties,): log of the shared viscosity of every tie group (both spring
  blocks are left out for element models whose springs are all zero);
- ``log_youngs_modulus``, ``logit_poisson_ratio``, ``log_viscosity`` (n_element_ties,): the
  tetrahedral elements' E, ν = σ(θ)/2 (so ν stays in (0, 0.5)) and η of every element tie
  group (element models);
- ``log_relaxation_moduli``, ``log_relaxation_times`` (K · n_element_ties, term-major): the
  relative modulus g and time τ of each of the K Prony terms of every element tie group
  (elements that relax, :mod:`neurofuzzy.forces.relaxation`);
- ``log_stiffening`` (one per element tie group with Yeoh elements): Yeoh's ``C₂₀/C₁₀``
  (:mod:`neurofuzzy.forces.laws`);
- ``log_mass`` (n_free_nodes,): log of every free node's mass (when masses are learned);
- effect parameters, raw, one block per effect (when effects are learned).

Logs keep stiffness, viscosity and mass positive and make their steps relative.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..model import SpringMassModel
from ._base import TieGroups

__all__ = ["Parameterization", "ELEMENT_BLOCKS", "RELAXATION_BLOCKS", "element_directions",
           "stiffening_columns"]

#: The element parameter blocks, in order.
ELEMENT_BLOCKS = ("log_youngs_modulus", "logit_poisson_ratio", "log_viscosity")
#: The blocks of the elements' Prony terms (after the element blocks), in order.
RELAXATION_BLOCKS = ("log_relaxation_moduli", "log_relaxation_times")
#: The smallest relative modulus a fit starts from (g = 0 has no logarithm).
SMALLEST_RELATIVE_MODULUS = 1e-3
#: The Prony terms' logarithms a fit's trial step is held within (e^±40: 4e-18 to 2e17)
LOG_LIMIT = 40.0
#: The smallest Yeoh C₂₀/C₁₀ a fit starts from (0, the neo-Hookean solid, has no logarithm)
SMALLEST_STIFFENING = 1e-3


def stiffening_groups(model) -> np.ndarray:
    """The element tie groups that hold Yeoh elements, ascending (one ``log_stiffening``
    parameter each)."""
    return np.unique(model.element_tie[model.element_stiffens])


def stiffening_columns(parameters, model) -> np.ndarray:
    """(n_elements,) the column of every element's ``log_stiffening`` parameter (-1: not a
    Yeoh element, or not learned)."""
    if not model.has_elements:
        return np.zeros(0, np.intp)
    columns = np.full(model.mesh.n_tetrahedra, -1, np.intp)
    block = parameters.blocks.get("log_stiffening")
    if block is not None:
        yeoh = model.element_stiffens
        columns[yeoh] = block.start + np.searchsorted(stiffening_groups(model),
                                                      model.element_tie[yeoh])
    return columns


def element_directions(model) -> dict[str, sp.csr_matrix]:
    """Per element quantity, the sparse (n_elements, 3 n_element_ties) derivative of every
    element's value by the element parameters (the three element blocks side by side, in
    ``ELEMENT_BLOCKS`` order): ``dE/d log E = E``, ``dν/d logit = ν (1 - 2ν)`` for ``ν = σ/2``,
    ``dη/d log η = η``, each in its element's tie-group column."""
    n, ties = model.mesh.n_tetrahedra, model.n_element_ties
    nu = model.element_poisson_ratio
    factors = {"youngs_modulus": model.element_youngs_modulus,
               "poisson_ratio": nu * (1.0 - 2.0 * nu), "viscosity": model.element_viscosity}
    return {name: sp.csr_matrix((factors[name], (np.arange(n), block * ties + model.element_tie)),
                                shape=(n, 3 * ties))
            for block, name in enumerate(factors)}


def _split_terms(elements: TieGroups, values: np.ndarray, ties: int):
    """``(shared (K, ties), [ratios (n,)] * K)`` of per-element values (n, K) of K terms."""
    pairs = [elements.split(values[:, k]) for k in range(values.shape[1])]
    return (np.array([pair[0] for pair in pairs]).reshape(-1, ties),
            [pair[1] for pair in pairs])


@dataclass
class Block:
    name: str
    start: int
    stop: int

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)


class Parameterization:
    """Flat parameter vector of ``model`` for the gradient learner.

    Parameters
    ----------
    model : SpringMassModel
        Start model; fixes tying, the ratios within tie groups and the effects' options.
    learn_masses : bool
        Include the free nodes' masses.
    learn_effects : bool
        Include the parameters of the model's effects.
    """

    def __init__(self, model: SpringMassModel, *, learn_masses: bool = False,
                 learn_effects: bool = True):
        self.base = model
        self.tied = TieGroups.of(model)
        self.stiffness_shared, self.stiffness_ratio = self.tied.split(model.spring_stiffness)
        self.damping_shared, self.damping_ratio = self.tied.split(model.spring_damping)
        self.learn_springs = not (model.has_elements and not np.any(model.spring_stiffness)
                                  and not np.any(model.spring_damping))
        for key, shared in (("spring_stiffness", self.stiffness_shared),
                            ("spring_damping", self.damping_shared)):
            if self.learn_springs and np.any(shared <= 0):
                raise InputError("the gradient learner needs positive start values (it learns "
                                 "their logarithm); give a rough positive guess", key=key)
        if model.has_elements:
            self.element_tie = model.element_tie
            elements = TieGroups(model.element_tie, model.n_element_ties)
            self.modulus_shared, self.modulus_ratio = elements.split(
                model.element_youngs_modulus)
            self.viscosity_shared, self.viscosity_ratio = elements.split(
                model.element_viscosity)
            # η = 0 has no logarithm: start from η/E = 1 ns, a viscosity too small to see
            self.viscosity_shared = np.maximum(self.viscosity_shared, 1e-9 * self.modulus_shared)
            self.ratio_shared = elements.split(model.element_poisson_ratio)[0]
            # Prony terms, (K, n_element_ties) each: a shared value and per-element ratios
            moduli, self.relaxation_moduli_ratio = _split_terms(
                elements, model.element_relaxation_moduli, model.n_element_ties)
            self.relaxation_moduli = np.maximum(moduli, SMALLEST_RELATIVE_MODULUS)
            self.relaxation_times, self.relaxation_times_ratio = _split_terms(
                elements, model.element_relaxation_times, model.n_element_ties)
            # Yeoh's C20/C10: a shared value per tie group with Yeoh elements, their ratios
            self.stiffening_groups = stiffening_groups(model)
            yeoh = model.element_stiffens
            shared = np.ones(model.n_element_ties)
            for group in self.stiffening_groups:
                members = yeoh & (model.element_tie == group)
                shared[group] = max(float(np.mean(model.element_stiffening[members])),
                                    SMALLEST_STIFFENING)
            self.stiffening_shared = shared[self.stiffening_groups]
            self.stiffening_ratio = np.where(
                yeoh, np.maximum(model.element_stiffening, SMALLEST_STIFFENING)
                / shared[model.element_tie], 0.0)
        self.free_nodes = np.flatnonzero(model.mesh.free)
        self.learn_masses = learn_masses
        self.effects = list(model.effects) if learn_effects else []
        blocks, start = [], 0
        sizes = ([("log_stiffness", model.n_ties), ("log_damping", model.n_ties)]
                 if self.learn_springs else [])
        if model.has_elements:
            sizes += [(name, model.n_element_ties) for name in ELEMENT_BLOCKS]
            if model.n_relaxation_terms:
                sizes += [(name, model.n_relaxation_terms * model.n_element_ties)
                          for name in RELAXATION_BLOCKS]
            if len(self.stiffening_groups):
                sizes.append(("log_stiffening", len(self.stiffening_groups)))
        if learn_masses:
            sizes.append(("log_mass", len(self.free_nodes)))
        sizes += [(f"effect:{i}", len(e.params)) for i, e in enumerate(self.effects)]
        for name, size in sizes:
            blocks.append(Block(name, start, start + size))
            start += size
        self.blocks = {block.name: block for block in blocks}
        self.size = start

    def initial(self) -> np.ndarray:
        """(n_params,) the start model's parameter vector."""
        theta = np.empty(self.size)
        if self.learn_springs:
            theta[self.blocks["log_stiffness"].slice] = np.log(self.stiffness_shared)
            theta[self.blocks["log_damping"].slice] = np.log(self.damping_shared)
        if self.base.has_elements:
            theta[self.blocks["log_youngs_modulus"].slice] = np.log(self.modulus_shared)
            ratio = 2.0 * self.ratio_shared
            theta[self.blocks["logit_poisson_ratio"].slice] = np.log(ratio / (1.0 - ratio))
            theta[self.blocks["log_viscosity"].slice] = np.log(self.viscosity_shared)
            if self.base.n_relaxation_terms:
                theta[self.blocks["log_relaxation_moduli"].slice] = np.log(
                    self.relaxation_moduli).ravel()
                theta[self.blocks["log_relaxation_times"].slice] = np.log(
                    self.relaxation_times).ravel()
            if len(self.stiffening_groups):
                theta[self.blocks["log_stiffening"].slice] = np.log(self.stiffening_shared)
        if self.learn_masses:
            theta[self.blocks["log_mass"].slice] = np.log(self.base.node_mass[self.free_nodes])
        for i, effect in enumerate(self.effects):
            theta[self.blocks[f"effect:{i}"].slice] = effect.params
        return theta

    def model(self, theta: np.ndarray) -> SpringMassModel:
        """The model with parameter vector ``theta``."""
        changes = {}
        if self.learn_springs:
            tie = self.tied.tie
            changes["spring_stiffness"] = np.exp(
                theta[self.blocks["log_stiffness"].slice])[tie] * self.stiffness_ratio
            changes["spring_damping"] = np.exp(
                theta[self.blocks["log_damping"].slice])[tie] * self.damping_ratio
        if self.base.has_elements:
            changes.update(self.element_values(theta))
        if self.learn_masses:
            mass = self.base.node_mass.copy()
            mass[self.free_nodes] = np.exp(theta[self.blocks["log_mass"].slice])
            changes["node_mass"] = mass
        if self.effects:
            changes["effects"] = tuple(e.with_params(theta[self.blocks[f"effect:{i}"].slice])
                                       for i, e in enumerate(self.effects))
        return self.base.replace(**changes)

    def element_values(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """The elements' E, ν and η (per element) of the parameter vector ``theta``."""
        tie = self.element_tie
        logistic = 1.0 / (1.0 + np.exp(-theta[self.blocks["logit_poisson_ratio"].slice]))
        values = {"element_youngs_modulus": np.exp(
                      theta[self.blocks["log_youngs_modulus"].slice])[tie] * self.modulus_ratio,
                  "element_poisson_ratio": 0.5 * logistic[tie],
                  "element_viscosity": np.exp(
                      theta[self.blocks["log_viscosity"].slice])[tie] * self.viscosity_ratio}
        terms = self.base.n_relaxation_terms
        if terms:
            for key, block, ratios in (
                    ("element_relaxation_moduli", "log_relaxation_moduli",
                     self.relaxation_moduli_ratio),
                    ("element_relaxation_times", "log_relaxation_times",
                     self.relaxation_times_ratio)):
                # a trial step may take log g or log τ anywhere: kept finite and positive
                # (τ → 0 relaxes at once, τ → ∞ never; g → 0 is no term)
                shared = np.exp(np.clip(theta[self.blocks[block].slice], -LOG_LIMIT,
                                        LOG_LIMIT)).reshape(terms, -1)
                values[key] = np.stack([shared[k][tie] * ratios[k] for k in range(terms)],
                                       axis=1)
        if len(self.stiffening_groups):
            shared = np.zeros(self.base.n_element_ties)
            shared[self.stiffening_groups] = np.exp(np.clip(
                theta[self.blocks["log_stiffening"].slice], -LOG_LIMIT, LOG_LIMIT))
            # the other laws' elements keep their (unused) value
            values["element_stiffening"] = np.where(self.base.element_stiffens,
                                                    shared[tie] * self.stiffening_ratio,
                                                    self.base.element_stiffening)
        return values

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
        """A readable name for every parameter ("stiffness[edge]", "mass[node 4]" …)."""
        names = []
        if self.learn_springs:
            for quantity in ("stiffness", "damping"):
                names += [f"{quantity}[{label}]" for label in self.tie_labels()]
        if self.base.has_elements:
            n = self.base.n_element_ties
            groups = ["all elements"] if n == 1 else [f"element group {k}" for k in range(n)]
            for quantity in ("youngs_modulus", "poisson_ratio", "viscosity"):
                names += [f"{quantity}[{label}]" for label in groups]
            terms = self.base.n_relaxation_terms
            for quantity in ("relaxation_modulus", "relaxation_time") if terms else ():
                names += [f"{quantity}{'' if terms == 1 else k + 1}[{label}]"
                          for k in range(terms) for label in groups]
            names += [f"stiffening[{groups[k]}]" for k in self.stiffening_groups]
        if self.learn_masses:
            names += [f"mass[node {i}]" for i in self.free_nodes]
        for effect in self.effects:
            names += list(effect.parameter_names)
        return names

    def tie_labels(self) -> list[str]:
        """Label of every tie group: a spring-group name, "all springs" or "spring j"."""
        model = self.base
        tie, groups, n_ties = self.tied.tie, model.mesh.spring_group, self.tied.n_ties
        counts = np.bincount(tie, minlength=n_ties)
        first = np.zeros(n_ties, dtype=int)                     # each tie group's first spring
        present, index = np.unique(tie, return_index=True)
        first[present] = index
        group = groups[first] if len(groups) else np.zeros(n_ties, dtype=int)
        # one spring group, and all of it
        mixed = np.bincount(tie, groups != group[tie], minlength=n_ties) > 0
        whole = np.bincount(groups, minlength=group.max(initial=0) + 1)[group] == counts
        labels = []
        for k in range(n_ties):
            if counts[k] == 1 and model.n_ties == model.n_springs:
                labels.append(f"spring {first[k]}")
            elif counts[k] == model.n_springs:
                labels.append("all springs")
            elif counts[k] and not mixed[k] and whole[k]:
                labels.append(model.mesh.group_names[group[k]])
            else:
                labels.append(f"tie group {k}")
        return labels

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
