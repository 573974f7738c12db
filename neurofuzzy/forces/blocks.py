"""What a learner may change of a term: its parameter blocks (:class:`TermBlocks`), in the
coordinates the learners step in, and the tie groups they share (:class:`TieGroups`).

Every term says which of its values are learned, and how (``term.blocks()``): the springs'
``log_stiffness`` and ``log_damping`` per tie group, the elements' ``log_youngs_modulus``,
``logit_poisson_ratio``, ``log_viscosity`` (and their Prony terms' ``log_relaxation_moduli``,
``log_relaxation_times``, Yeoh's ``log_stiffening``), an effect's raw parameters. Logs keep
stiffness, viscosity and moduli positive and make their steps relative; ``ν = σ(θ)/2`` keeps
Poisson's ratio in (0, 0.5). :class:`neurofuzzy.learn.Parameterization` lays the blocks of a
model's terms side by side in one vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

__all__ = ["TieGroups", "TermBlocks", "SpringBlocks", "ElementBlocks", "EffectBlocks",
           "ELEMENT_BLOCKS", "RELAXATION_BLOCKS"]

#: The element parameter blocks, in order.
ELEMENT_BLOCKS = ("log_youngs_modulus", "logit_poisson_ratio", "log_viscosity")
#: The blocks of the elements' Prony terms (after the element blocks), in order.
RELAXATION_BLOCKS = ("log_relaxation_moduli", "log_relaxation_times")
#: The smallest relative modulus a fit starts from (g = 0 has no logarithm).
SMALLEST_RELATIVE_MODULUS = 1e-3
#: The logarithms of the Prony terms and Yeoh's constant a fit's trial step is held within
#: (e^±40: 4e-18 to 2e17)
LOG_LIMIT = 40.0
#: The smallest Yeoh C₂₀/C₁₀ a fit starts from (0, the neo-Hookean solid, has no logarithm)
SMALLEST_STIFFENING = 1e-3


@dataclass(frozen=True)
class TieGroups:
    """Map between per-member values (springs, or elements) and the shared values of their
    tie groups.

    A tied group shares one value ``shared[k]``; member ``j`` gets ``shared[tie[j]] * ratio[j]``
    where ``ratio`` keeps the proportions the members started with (1 for equal starts).
    """

    tie: np.ndarray
    n_ties: int

    @classmethod
    def of(cls, tie: np.ndarray) -> TieGroups:
        """The groups of a tie array numbered ``0..n_ties-1``."""
        tie = np.asarray(tie, np.intp)
        return cls(tie, int(tie.max()) + 1 if len(tie) else 0)

    def split(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(shared, ratio)`` with ``shared`` the group means of ``values``."""
        count = np.bincount(self.tie, minlength=self.n_ties)
        shared = np.bincount(self.tie, values, self.n_ties) / np.maximum(count, 1)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(shared[self.tie] > 0, values / shared[self.tie], 1.0)
        return shared, ratio

    def reduce(self, per_member: np.ndarray, ratio: np.ndarray) -> np.ndarray:
        """Chain rule: derivative by ``shared`` from derivatives by per-member values."""
        return np.bincount(self.tie, per_member * ratio, self.n_ties)


class TermBlocks:
    """The learned parameters of one term as named blocks.

    Subclasses set :attr:`sizes` (``[(block name, size), …]`` in order) and implement
    :meth:`initial` (the start values of every block), :meth:`term` (the term at given block
    values) and :meth:`names` (a readable name for every parameter).
    """

    sizes: list

    def initial(self) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def term(self, values: dict[str, np.ndarray]):
        raise NotImplementedError

    def names(self) -> list[str]:
        raise NotImplementedError

    def ratio(self, name: str) -> np.ndarray | None:
        """(n_members,) the start ratios of a block's members to their group's shared value
        (None for blocks that are not tied proportions)."""
        return None


class SpringBlocks(TermBlocks):
    """``log_stiffness`` and ``log_damping`` of every tie group of a model's springs."""

    def __init__(self, springs, mesh):
        self.springs = springs
        self.mesh = mesh
        self.tied = TieGroups(springs.tie, springs.n_ties)
        self.stiffness_shared, self.stiffness_ratio = self.tied.split(springs.stiffness)
        self.damping_shared, self.damping_ratio = self.tied.split(springs.damping)
        for key, shared in (("spring_stiffness", self.stiffness_shared),
                            ("spring_damping", self.damping_shared)):
            if np.any(shared <= 0):
                raise InputError("the gradient learner needs positive start values (it learns "
                                 "their logarithm); give a rough positive guess", key=key)
        self.sizes = [("log_stiffness", self.tied.n_ties), ("log_damping", self.tied.n_ties)]

    def initial(self):
        return {"log_stiffness": np.log(self.stiffness_shared),
                "log_damping": np.log(self.damping_shared)}

    def term(self, values):
        tie = self.tied.tie
        return self.springs.replace(
            stiffness=np.exp(values["log_stiffness"])[tie] * self.stiffness_ratio,
            damping=np.exp(values["log_damping"])[tie] * self.damping_ratio)

    def ratio(self, name):
        return {"log_stiffness": self.stiffness_ratio,
                "log_damping": self.damping_ratio}.get(name)

    def names(self):
        labels = self.tie_labels()
        return [f"{quantity}[{label}]" for quantity in ("stiffness", "damping")
                for label in labels]

    def tie_labels(self) -> list[str]:
        """Label of every tie group: a spring-group name, "all springs" or "spring j"."""
        tie, groups, n_ties = self.tied.tie, self.mesh.spring_group, self.tied.n_ties
        n_springs = len(tie)
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
            if counts[k] == 1 and n_ties == n_springs:
                labels.append(f"spring {first[k]}")
            elif counts[k] == n_springs:
                labels.append("all springs")
            elif counts[k] and not mixed[k] and whole[k]:
                labels.append(self.mesh.group_names[group[k]])
            else:
                labels.append(f"tie group {k}")
        return labels


class ElementBlocks(TermBlocks):
    """E, ν and η of every element tie group (``ELEMENT_BLOCKS``), the relative moduli and
    times of the Prony terms (``RELAXATION_BLOCKS``, K · n_ties each, term-major), and Yeoh's
    ``log_stiffening`` of every tie group with Yeoh elements."""

    def __init__(self, elements):
        self.elements = elements
        self.tied = TieGroups(elements.tie, elements.n_ties)
        ties = self.tied.n_ties
        self.modulus_shared, self.modulus_ratio = self.tied.split(elements.youngs_modulus)
        self.viscosity_shared, self.viscosity_ratio = self.tied.split(elements.viscosity)
        # η = 0 has no logarithm: start from η/E = 1 ns, a viscosity too small to see
        self.viscosity_shared = np.maximum(self.viscosity_shared, 1e-9 * self.modulus_shared)
        self.ratio_shared = self.tied.split(elements.poisson_ratio)[0]
        # Prony terms, (K, n_ties) each: a shared value and per-element ratios
        moduli, self.relaxation_moduli_ratio = self._split_terms(elements.relaxation_moduli)
        self.relaxation_moduli = np.maximum(moduli, SMALLEST_RELATIVE_MODULUS)
        self.relaxation_times, self.relaxation_times_ratio = self._split_terms(
            elements.relaxation_times)
        # Yeoh's C20/C10: a shared value per tie group with Yeoh elements, their ratios
        yeoh = elements.stiffens
        self.stiffening_groups = np.unique(elements.tie[yeoh])
        shared = np.ones(ties)
        for group in self.stiffening_groups:
            members = yeoh & (elements.tie == group)
            shared[group] = max(float(np.mean(elements.stiffening[members])),
                                SMALLEST_STIFFENING)
        self.stiffening_shared = shared[self.stiffening_groups]
        self.stiffening_ratio = np.where(
            yeoh, np.maximum(elements.stiffening, SMALLEST_STIFFENING) / shared[elements.tie],
            0.0)
        terms = elements.n_relaxation_terms
        self.sizes = [(name, ties) for name in ELEMENT_BLOCKS]
        if terms:
            self.sizes += [(name, terms * ties) for name in RELAXATION_BLOCKS]
        if len(self.stiffening_groups):
            self.sizes.append(("log_stiffening", len(self.stiffening_groups)))

    def _split_terms(self, values: np.ndarray):
        """``(shared (K, ties), [ratios (n,)] * K)`` of per-element values (n, K)."""
        pairs = [self.tied.split(values[:, k]) for k in range(values.shape[1])]
        return (np.array([pair[0] for pair in pairs]).reshape(-1, self.tied.n_ties),
                [pair[1] for pair in pairs])

    def initial(self):
        ratio = 2.0 * self.ratio_shared
        out = {"log_youngs_modulus": np.log(self.modulus_shared),
               "logit_poisson_ratio": np.log(ratio / (1.0 - ratio)),
               "log_viscosity": np.log(self.viscosity_shared)}
        if self.elements.n_relaxation_terms:
            out["log_relaxation_moduli"] = np.log(self.relaxation_moduli).ravel()
            out["log_relaxation_times"] = np.log(self.relaxation_times).ravel()
        if len(self.stiffening_groups):
            out["log_stiffening"] = np.log(self.stiffening_shared)
        return out

    def term(self, values):
        return self.elements.replace(**self.values(values))

    def values(self, values) -> dict[str, np.ndarray]:
        """The elements' fields (E, ν, η per element; the Prony terms' g and τ, Yeoh's
        constants) at the block values ``values``."""
        tie, elements = self.tied.tie, self.elements
        logistic = 1.0 / (1.0 + np.exp(-values["logit_poisson_ratio"]))
        out = {"youngs_modulus": np.exp(values["log_youngs_modulus"])[tie] * self.modulus_ratio,
               "poisson_ratio": 0.5 * logistic[tie],
               "viscosity": np.exp(values["log_viscosity"])[tie] * self.viscosity_ratio}
        terms = elements.n_relaxation_terms
        if terms:
            for key, block, ratios in (
                    ("relaxation_moduli", "log_relaxation_moduli", self.relaxation_moduli_ratio),
                    ("relaxation_times", "log_relaxation_times", self.relaxation_times_ratio)):
                # a trial step may take log g or log τ anywhere: kept finite and positive
                # (τ → 0 relaxes at once, τ → ∞ never; g → 0 is no term)
                shared = np.exp(np.clip(values[block], -LOG_LIMIT, LOG_LIMIT)).reshape(terms,
                                                                                       -1)
                out[key] = np.stack([shared[k][tie] * ratios[k] for k in range(terms)], axis=1)
        if len(self.stiffening_groups):
            shared = np.zeros(self.tied.n_ties)
            shared[self.stiffening_groups] = np.exp(np.clip(values["log_stiffening"],
                                                            -LOG_LIMIT, LOG_LIMIT))
            # the other laws' elements keep their (unused) value
            out["stiffening"] = np.where(elements.stiffens, shared[tie] * self.stiffening_ratio,
                                         elements.stiffening)
        return out

    def ratio(self, name):
        return {"log_youngs_modulus": self.modulus_ratio,
                "log_viscosity": self.viscosity_ratio}.get(name)

    def names(self):
        n = self.tied.n_ties
        groups = ["all elements"] if n == 1 else [f"element group {k}" for k in range(n)]
        names = [f"{quantity}[{label}]" for quantity in ("youngs_modulus", "poisson_ratio",
                                                         "viscosity") for label in groups]
        terms = self.elements.n_relaxation_terms
        for quantity in ("relaxation_modulus", "relaxation_time") if terms else ():
            names += [f"{quantity}{'' if terms == 1 else k + 1}[{label}]"
                      for k in range(terms) for label in groups]
        return names + [f"stiffening[{groups[k]}]" for k in self.stiffening_groups]


class EffectBlocks(TermBlocks):
    """The raw parameters of effect number ``index`` of a model (block ``effect:index``)."""

    def __init__(self, effect, index: int):
        self.effect = effect
        self.name = f"effect:{index}"
        self.sizes = [(self.name, len(effect.params))]

    def initial(self):
        return {self.name: self.effect.params}

    def term(self, values):
        return self.effect.with_params(values[self.name])

    def names(self):
        return list(self.effect.parameter_names)
