"""Candidates of the effect catalogue, proposed where the residuals point (every registered
effect class proposes its own, :meth:`~neurofuzzy.effects.Effect.propose`), and the evidence
of one-step residual forces they are scored against (:class:`Evidence`; the trajectory-space
evidence of element models and embedded markers is :mod:`.trajectory`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..effects import EFFECTS
from ..model import Model
from .residuals import (Residuals, Samples, model_templates, orthonormal, residual_analysis,
                        spring_templates)
from .scoring import Candidate, initial_params, score_candidates

__all__ = ["Evidence", "TakenByEffects", "propose_candidates", "inclusion_region"]

#: A spring joins (or leaves) an inclusion region when that explains this much more residual.
REGION_GAIN = 0.005


class TakenByEffects:
    """What a model's effects already have (for :meth:`~neurofuzzy.effects.Effect.propose`):
    their names and the nodes, springs and elements located effects use."""

    model: Model

    @property
    def present(self) -> set[str]:
        return {e.name for e in self.model.effects}

    @property
    def taken_nodes(self) -> set[int]:
        return {int(n) for e in self.model.effects for n in e.nodes}

    @property
    def taken_springs(self) -> set[int]:
        return {int(j) for e in self.model.effects for j in e.springs}

    @property
    def taken_elements(self) -> set[int]:
        return {int(k) for e in self.model.effects for k in e.elements}


@dataclass
class Evidence(TakenByEffects):
    """What the one-step residual forces say: for :meth:`~neurofuzzy.effects.Effect.propose`
    the effects the model has, the mean residual force per node, what located effects already
    use and the inclusion region search; for the diagnosis the candidates' scores and start
    parameters."""

    model: Model
    samples: Samples
    base: np.ndarray
    analysis: Residuals | None = None

    @classmethod
    def of(cls, model, experiments, substeps: int) -> Evidence:
        analysis = residual_analysis(model, experiments, substeps=substeps)
        return cls(model, analysis.samples, model_templates(model, analysis.samples), analysis)

    def residuals(self) -> Residuals:
        return self.analysis

    #: least fraction of the residual above the noise a candidate must explain
    min_explained = 0.3

    @property
    def noise_rms(self) -> float:
        """RMS marker error that noise alone explains (metres, per marker)."""
        return self.samples.marker_noise * np.sqrt(3.0)

    @property
    def size(self) -> int:
        return int(self.samples.force.size)

    def score(self, candidates) -> list[Candidate]:
        return score_candidates(self.model, self.samples, self.base, candidates)

    def initial_params(self, effect) -> np.ndarray:
        return initial_params(effect, self.model, self.samples, self.base)

    @property
    def mean_force(self) -> np.ndarray:
        """(n_nodes, 3) mean residual force of every node over the frames and experiments."""
        mean_force = np.zeros((self.model.n_nodes, 3))
        for data in self.samples.experiment:
            rows = data["rows"]
            mean_force[rows] += data["residual"][:, rows].mean(axis=0) / len(
                self.samples.experiment)
        return mean_force

    def inclusion_region(self, taken: set[int]) -> list[int]:
        return inclusion_region(self.model, self.samples, taken, self.base)

    def element_region(self, taken: set[int]) -> list[int]:
        """Element regions are searched in trajectory space (:mod:`.trajectory`)."""
        return []


def propose_candidates(model, evidence) -> list:
    """Every effect of the registry, instantiated where the residuals (``evidence``) point."""
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
    rows = np.ascontiguousarray(templates.T)                       # (S, n): one per spring
    square = np.einsum("ij,ij->i", rows, rows)                     # |t_j|²
    along = rows @ target                                          # t_j · r
    allowed &= square > 0

    def explained(region):
        column = rows[region].sum(axis=0)
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
        members = sorted(region) if len(region) > 1 else []
        # the region's column c plus (or minus) one spring's: |c ± t_j|² and (c ± t_j)·r
        # from c·t_j, |t_j|² and t_j·r, one product for every trial
        column = rows[sorted(region)].sum(axis=0)
        moves = np.array(border + members, dtype=int)
        sign = np.r_[np.ones(len(border)), -np.ones(len(members))]
        norm2 = (column @ column + 2 * sign * (rows[moves] @ column) + square[moves])
        gains = np.where(norm2 > 0, (column @ target + sign * along[moves]) ** 2
                         / np.where(norm2 > 0, norm2, 1.0) / total, 0.0)
        if not len(moves) or gains.max() < best + REGION_GAIN:
            break
        pick = int(np.argmax(gains))
        move = int(moves[pick])
        region = region | {move} if pick < len(border) else region - {move}
        best = float(gains[pick])
    return sorted(region)
