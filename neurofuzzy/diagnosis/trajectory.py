"""The diagnosis in trajectory space: for element models and for markers embedded anywhere.

One-step residual forces need every node's measured position (:mod:`.residuals`). Markers on
the surface of a continuum see only some points of it, so here the evidence is the free-run
marker error ``r`` of the fitted model itself, and a candidate effect is scored by the
Gauss–Newton step it allows: the regression of ``r`` on the forward sensitivities ``∂r/∂θ`` of
the candidate's parameters together with those of the model's own parameters (a linearised
refit), with the marker noise as variance in the Bayesian information criterion. Every
candidate's sensitivities come from one compiled forward pass, with the candidates added to
the fitted model at zero (so the trajectory is the fitted one).

Localisation: an unmodeled load is proposed at the nodes under the markers with the largest
mean error. An inclusion is found on blocks of elements (a grid of ``BLOCKS_PER_SIDE`` blocks
along the object's longest side): the residual the model's own parameters leave is regressed
on every block's extra Young's modulus at once (ridge regression, as the spring mismatch of
the one-step diagnosis), and the region is the connected set of blocks around the strongest
one whose coefficients have its sign and at least ``REGION_FRACTION`` of its size. (Scanning
blocks one at a time is confounded: with surface markers, single blocks near the held base
mimic much of what a stiffer block inside does.)

A linearised explanation underestimates what a refit achieves when the model is far off
(hidden gravity makes the fit without it soften the whole block), so candidates that explain
at least ``MIN_EXPLAINED`` (less than the one-step diagnosis asks) are refitted, and the refit
decides.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..effects import StiffInclusion
from ..forces import tetrahedron_geometry
from ..learn import Parameterization, Sensitivity
from .candidates import TakenByEffects
from ..noise import marker_noise
from .residuals import Residuals, orthonormal
from .scoring import Candidate, residual_sum_of_squares

__all__ = ["TrajectoryEvidence", "BLOCKS_PER_SIDE", "REGION_FRACTION", "RIDGE",
           "MIN_EXPLAINED"]

#: Blocks of elements per side of the object's bounding box for the inclusion search.
BLOCKS_PER_SIDE = 4
#: A neighbouring block joins the region when its coefficient is at least this fraction of
#: the strongest block's (same sign).
REGION_FRACTION = 0.5
#: Ridge of the block regression, relative to the mean diagonal of the normalised Gram matrix.
RIDGE = 0.1
#: Least fraction of the residual above the noise a candidate's linearised fit must explain to
#: be refitted.
MIN_EXPLAINED = 0.1


@dataclass
class _Blocks:
    """Elements grouped into the cells of a grid over the object, with face neighbours."""

    members: list            # per block: element indices
    cell: np.ndarray         # (n_blocks, 3) int grid cell of every block

    def neighbours(self, block: int) -> list[int]:
        distance = np.abs(self.cell - self.cell[block]).sum(axis=1)
        return np.flatnonzero(distance == 1).tolist()


def _blocks(model, taken: set[int]) -> _Blocks:
    geometry = tetrahedron_geometry(model.mesh)
    centroids = model.mesh.rest_positions[geometry.nodes].mean(axis=1)
    low, high = centroids.min(axis=0), centroids.max(axis=0)
    side = max(float(np.max(high - low)), 1e-300) / BLOCKS_PER_SIDE
    cells = np.floor((centroids - low) / side).astype(int)
    cells = np.minimum(cells, np.maximum(np.ceil((high - low) / side).astype(int) - 1, 0))
    free = np.array([e not in taken for e in range(len(centroids))])
    keys, inverse = np.unique(cells[free], axis=0, return_inverse=True)
    elements = np.flatnonzero(free)
    return _Blocks([elements[inverse.ravel() == k] for k in range(len(keys))], keys)


@dataclass
class TrajectoryEvidence(TakenByEffects):
    """What the free-run marker error of a fitted model says.

    Attributes
    ----------
    model : SpringMassModel
        The fitted model.
    residual : (n,) float
        Marker (or tracked node) errors at every measured frame, in units of ``length_unit``.
    base : (n, p) float
        Their sensitivities to the model's own parameters.
    noise : float
        Marker noise per coordinate (in units of ``length_unit``).
    """

    model: object
    experiments: list
    substeps: int
    length_unit: float
    residual: np.ndarray = field(repr=False, default=None)
    base: np.ndarray = field(repr=False, default=None)
    noise: float = 0.0
    _blocks: _Blocks | None = field(repr=False, default=None)
    _block_columns: np.ndarray | None = field(repr=False, default=None)
    _runs: list | None = field(repr=False, default=None)
    _candidate_columns: dict = field(repr=False, default_factory=dict)

    @classmethod
    def of(cls, model, experiments, substeps: int) -> TrajectoryEvidence:
        length = float(np.mean(model.spring_rest_length))
        evidence = cls(model, list(experiments), int(substeps), length)
        blocks = _blocks(model, set()) if model.has_elements else None
        inclusions = ([StiffInclusion.of_elements(model, members) for members in blocks.members]
                      if blocks is not None else [])
        evidence.residual, columns = evidence._sensitivities(inclusions)
        evidence.base = columns[0]
        evidence._blocks = blocks
        evidence._block_columns = (np.stack([c[:, 0] for c in columns[1:]], axis=1)
                                   if inclusions else None)
        noises = []
        for experiment, run in zip(evidence.experiments, evidence._runs):
            values = experiment.observation.values
            motion = (values - values[:1]) / length
            noises.append(marker_noise(run.residuals, np.nan_to_num(motion)))
        evidence.noise = float(np.sqrt(np.mean(np.square(noises))))
        return evidence

    def _sensitivities(self, effects):
        """``(residual, [own columns, columns of every effect])`` with ``effects`` added to
        the model at their parameters (zero: the fitted trajectory)."""
        probe = self.model.with_effects(*effects)
        parameters = Parameterization(probe)
        sensitivity = Sensitivity(parameters, self.length_unit)
        theta = parameters.initial()
        self._runs = [sensitivity.run(theta, e, substeps=self.substeps, tangents=True)
                      for e in self.experiments]
        residual = np.concatenate([run.residuals.ravel() for run in self._runs])
        jacobian = np.concatenate([run.jacobian.reshape(-1, parameters.size)
                                   for run in self._runs])
        first = len(self.model.effects)
        added = [parameters.blocks[f"effect:{first + i}"].slice for i in range(len(effects))]
        own = np.ones(parameters.size, bool)
        for block in added:
            own[block] = False
        return residual, [jacobian[:, own]] + [jacobian[:, block] for block in added]

    # -- what Effect.propose asks (beside TakenByEffects) ----------------------------------------
    @property
    def mean_force(self) -> np.ndarray:
        """(n_nodes, 3): where a steady push would shrink the error, from the mean marker
        error (``-Hᵀ r̄``: the nodes under the markers that end up too far back)."""
        out = np.zeros((self.model.n_nodes, 3))
        for experiment, run in zip(self.experiments, self._runs):
            mean = run.residuals.mean(axis=0)                          # (rows, 3)
            out -= experiment.observation.adjoint(mean)
        return out

    def inclusion_region(self, taken) -> list[int]:
        """Spring regions need the one-step residuals of complete node data."""
        return []

    def element_region(self, taken: set[int]) -> list[int]:
        """The elements of the connected blocks around the block whose extra Young's modulus
        the joint (ridge) regression finds strongest, with coefficients of its sign and at
        least ``REGION_FRACTION`` of its size."""
        if self._blocks is None:
            return []
        blocks = self._blocks if not taken else _blocks(self.model, taken)
        columns = (self._block_columns if not taken else np.stack(
            [c[:, 0] for c in self._sensitivities(
                [StiffInclusion.of_elements(self.model, m) for m in blocks.members])[1][1:]],
            axis=1))
        basis = orthonormal(self.base)
        target = self.residual - basis @ (basis.T @ self.residual)
        columns = columns - basis @ (basis.T @ columns)
        norms = np.linalg.norm(columns, axis=0)
        if not np.any(target) or not np.any(norms):
            return []
        scaled = columns / np.where(norms > 0, norms, 1.0)
        gram = scaled.T @ scaled
        ridge = RIDGE * np.trace(gram) / len(gram)
        coefficient = np.linalg.solve(gram + ridge * np.eye(len(gram)), scaled.T @ -target)
        coefficient = np.where(norms > 0, coefficient / np.where(norms > 0, norms, 1.0), 0.0)
        seed = int(np.argmax(np.abs(coefficient)))
        strength = coefficient * np.sign(coefficient[seed])
        region, frontier = {seed}, [seed]
        while frontier:
            for b in blocks.neighbours(frontier.pop()):
                if b not in region and strength[b] >= REGION_FRACTION * strength[seed]:
                    region.add(b)
                    frontier.append(b)
        return sorted(int(e) for b in region for e in blocks.members[b])

    # -- scoring --------------------------------------------------------------------------------
    def score(self, candidates) -> list[Candidate]:
        """Candidates ranked by ΔBIC (best first): the residual regressed on the model's own
        sensitivities with and without each candidate's."""
        if not candidates:
            return []
        self._candidate_columns = {}
        for group in self._passes(candidates):
            _, columns = self._sensitivities(group)
            self._candidate_columns.update(zip(map(id, group), columns[1:]))
        columns = [None] + [self._candidate_columns[id(c)] for c in candidates]
        target = self.residual
        n = target.size
        sigma2 = max(self.noise, 1e-12 * float(np.abs(target).max() or 1.0)) ** 2
        rss_base = residual_sum_of_squares(self.base, target)
        excess = rss_base - n * sigma2
        scored = []
        for effect, extra in zip(candidates, columns[1:]):
            rss = residual_sum_of_squares(np.concatenate([self.base, extra], axis=1), target)
            gain = rss_base - rss
            score = gain / sigma2 - extra.shape[1] * np.log(n)
            scored.append(Candidate(
                name=effect.name, score=float(score),
                explained=float(gain / max(excess, gain)) if gain > 0 else 0.0,
                effect=effect, springs=[int(j) for j in effect.springs],
                nodes=[int(i) for i in effect.nodes],
                elements=[int(k) for k in effect.elements]))
        scored.sort(key=lambda c: -c.score)
        return scored

    def _passes(self, candidates) -> list[list]:
        """Candidates grouped into forward passes: all that the compiled kernel runs in one,
        each of the others (numpy path) alone, so one of them does not slow the rest."""
        compiled, alone = [], []
        for effect in candidates:
            probe = Parameterization(self.model.with_effects(effect))
            fast = Sensitivity(probe, self.length_unit).compiled
            (compiled if fast else alone).append(effect)
        return ([compiled] if compiled else []) + [[effect] for effect in alone]

    def initial_params(self, effect) -> np.ndarray:
        """The candidate's parameters of the linearised refit (the Gauss–Newton step)."""
        extra = self._candidate_columns[id(effect)]
        both = np.concatenate([self.base, extra], axis=1)
        norms = np.linalg.norm(both, axis=0)
        norms[norms == 0] = 1.0
        solution, *_ = np.linalg.lstsq(both / norms, -self.residual, rcond=None)
        return (solution / norms)[self.base.shape[1]:]

    min_explained = MIN_EXPLAINED

    @property
    def noise_rms(self) -> float:
        """RMS marker error that noise alone explains (metres, per marker)."""
        return self.noise * self.length_unit * np.sqrt(3.0)

    @property
    def size(self) -> int:
        return int(self.residual.size)

    def residuals(self) -> Residuals:
        """Where and when, for the report: the RMS error per node (markers mapped to their
        nodes), per frame and the noise level, all in metres."""
        model = self.model
        per_node = np.zeros(model.n_nodes)
        weight = np.zeros(model.n_nodes)
        per_frame = None
        for experiment, run in zip(self.experiments, self._runs):
            error = np.sum(run.residuals**2, axis=2) * self.length_unit**2    # (T-1, rows)
            operator = abs(experiment.observation.operator)
            per_node += operator.T @ error.mean(axis=0)
            weight += np.asarray(operator.sum(axis=0)).ravel()
            if per_frame is None:
                per_frame = np.sqrt(error.mean(axis=1))
        per_node = np.sqrt(per_node / np.maximum(weight, 1e-300))
        return Residuals(force=self.residual.reshape(-1, 3), per_node=per_node,
                         per_node_error=per_node, per_spring=np.zeros(model.n_springs),
                         per_frame=per_frame, noise_floor=self.noise_rms,
                         marker_noise=self.noise * self.length_unit, kind="position")

