"""Candidates of the effect catalogue, proposed where the residuals point (every registered
effect class proposes its own, :meth:`~neurofuzzy.effects.Effect.propose`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..effects import EFFECTS
from ..model import SpringMassModel
from .residuals import Samples, orthonormal, spring_templates

__all__ = ["Evidence", "propose_candidates", "inclusion_region"]

#: A spring joins (or leaves) an inclusion region when that explains this much more residual.
REGION_GAIN = 0.005


@dataclass
class Evidence:
    """What the residuals say, for :meth:`~neurofuzzy.effects.Effect.propose`: the effects the
    model has, the mean residual force per node, what located effects already use, and the
    inclusion region search."""

    model: SpringMassModel
    samples: Samples
    base: np.ndarray

    @property
    def present(self) -> set[str]:
        return {e.name for e in self.model.effects}

    @property
    def mean_force(self) -> np.ndarray:
        """(n_nodes, 3) mean residual force of every node over the frames and experiments."""
        mean_force = np.zeros((self.model.n_nodes, 3))
        for data in self.samples.experiment:
            rows = data["rows"]
            mean_force[rows] += data["residual"][:, rows].mean(axis=0) / len(
                self.samples.experiment)
        return mean_force

    @property
    def taken_nodes(self) -> set[int]:
        return {int(n) for e in self.model.effects for n in e.nodes}

    @property
    def taken_springs(self) -> set[int]:
        return {int(j) for e in self.model.effects for j in e.springs}

    def inclusion_region(self, taken: set[int]) -> list[int]:
        return inclusion_region(self.model, self.samples, taken, self.base)


def propose_candidates(model, samples: Samples, base: np.ndarray) -> list:
    """Every effect of the registry, instantiated where the residuals point."""
    evidence = Evidence(model, samples, base)
    return [effect for cls in EFFECTS.values() for effect in cls.propose(model, evidence)]


def inclusion_region(model, samples, taken: set[int], base: np.ndarray) -> list[int]:
    """Grow a region of springs, from the best star of springs around one node, while each
    added (or removed) neighbouring spring explains at least ``REGION_GAIN`` more of the
    residual; the region shares one stiffness change ``δ``. Everything is projected off the
    model's own templates first: the fit without the inclusion has already shifted the global
    stiffness to make up for it, and only what that cannot explain points at the region."""
    basis = orthonormal(base)
    templates = spring_templates(model, samples)                  # (n, S)
    templates = templates - basis @ (basis.T @ templates)
    target = samples.force.ravel()
    target = target - basis @ (basis.T @ target)
    total = float(target @ target)
    if total == 0:
        return []
    springs = model.mesh.springs
    allowed = np.ones(model.n_springs, bool)
    allowed[list(taken)] = False
    allowed &= np.linalg.norm(templates, axis=0) > 0

    def explained(region):
        column = templates[:, region].sum(axis=1)
        norm2 = float(column @ column)
        return (column @ target) ** 2 / norm2 / total if norm2 > 0 else 0.0

    stars = [np.flatnonzero(allowed & ((springs[:, 0] == k) | (springs[:, 1] == k)))
             for k in range(model.n_nodes)]
    stars = [star for star in stars if star.size]
    if not stars:
        return []
    region = set(max(stars, key=lambda star: explained(list(star))).tolist())
    best = explained(sorted(region))
    while True:
        nodes = np.unique(springs[sorted(region)])
        border = [j for j in np.flatnonzero(allowed & np.isin(springs, nodes).any(axis=1))
                  if j not in region]
        trials = [(explained(sorted(region | {j})), j) for j in border]
        trials += [(explained(sorted(region - {j})), -j - 1) for j in region if len(region) > 1]
        gain, move = max(trials, default=(best, None))
        if move is None or gain < best + REGION_GAIN:
            break
        region = region | {move} if move >= 0 else region - {-move - 1}
        best = gain
    return sorted(region)
