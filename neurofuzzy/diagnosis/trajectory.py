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
mean error. An inclusion is searched as a ball of elements with extra Young's modulus: balls
centred on a grid of ``SCAN_PER_SIDE`` points along the object's longest side with radii of
``SCAN_RADII`` of that side, each scored by the share of the residual it explains once the
model's own columns are projected out (its sensitivity column from a forward pass, a
simulation's cost each: only for a shortlist of balls, chosen by the projection of every ball's
column on the residual, all from one backward sweep); then around the best, balls on a grid
twice as fine with radii 0.7, 1 and 1.4 times its radius, each scored. The best ball of the
second scan is the region. (A compact region is what the catalogue's inclusion is; scoring
whole regions rather than the many small blocks they are made of keeps surface markers, which
see the inside only through smooth, overlapping sensitivities, from smearing it: a regression
on blocks put it 6 mm from a 5× stiffer sphere on 7.5 mm voxels, and refitted shrank the gap
only 1.3 times; the ball scan puts it within 3 mm and the refit shrinks the gap 3.1 times.)

While the model explains the data to the noise, an inclusion must explain ``MIN_EXPLAINED`` of
the misfit above it to be refitted; a first scan whose best ball explains less than
``FINER_SCAN_SHARE`` of that skips the second scan (the region is that ball), which cannot lift
it so far: the second scan's best explained 1.2 to 1.5 times the first's on the probed block
(a 5x and a 1.5x stiffer sphere on 7.5 mm voxels, a 1.5x one and a relaxing block on 4 mm),
and on the 4 mm voxels it is 81 sensitivity columns, 83 of a diagnosis's 199 s.

A linearised explanation underestimates what a refit achieves when the model is far off
(hidden gravity makes the fit without it soften the whole block), so candidates are refitted
on their evidence score rather than on the share they explain linearly, and the refit
decides.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..effects import StiffInclusion
from ..experiment import duration
from ..forces import tetrahedron_geometry
from ..learn import Parameterization, Sensitivity
from ..learn.steps import fits_offsets
from .candidates import TakenByEffects
from .residuals import Residuals, orthonormal
from .scoring import Candidate, residual_sum_of_squares

__all__ = ["TrajectoryEvidence", "SCAN_PER_SIDE", "SCAN_RADII", "REFINE_RADII",
           "MIN_EXPLAINED", "FINER_SCAN_SHARE", "MAX_OWN_STEP"]

#: Ball centres per side of the object's bounding box in the first inclusion scan.
SCAN_PER_SIDE = 4
#: Ball radii of the first scan, as fractions of the object's longest side.
SCAN_RADII = (0.1, 0.175, 0.25)
#: Radii of the second scan, as factors of the best first-scan radius.
REFINE_RADII = (0.7, 1.0, 1.4)
#: Balls scored exactly per scan: the best this many by each proxy of their gain
#: (:meth:`TrajectoryEvidence.shortlist`), with the powers of the ball's element count the
#: proxies divide by.
SHORTLIST_EACH = 8
SHORTLIST_POWERS = (0.5, 1.0, 1.5, 2.0)
#: Least fraction of the residual above the noise a candidate's linearised fit must explain to
#: be refitted while the model explains the data to the noise.
MIN_EXPLAINED = 0.1
#: Least fraction of ``MIN_EXPLAINED`` the first scan's best ball must explain, while the
#: model explains the data to the noise, for the finer scan to be made (module docstring).
FINER_SCAN_SHARE = 0.5
#: The most factor a partial switch's linearised step moves a model's own E or η by (the
#: same bound on the learner's coordinates of the others: :meth:`TrajectoryEvidence.stepped`).
MAX_OWN_STEP = 2.0


def _balls(centroids, centres, radii, taken) -> list[np.ndarray]:
    """The elements (centroids within the radius, not ``taken``) of every ball, non-empty and
    distinct."""
    balls, seen = [], set()
    free = np.ones(len(centroids), bool)
    free[list(taken)] = False
    for centre in centres:
        distance = np.linalg.norm(centroids - centre, axis=1)
        for radius in radii:
            members = np.flatnonzero((distance <= radius) & free)
            key = members.tobytes()
            if members.size and key not in seen:
                seen.add(key)
                balls.append(members)
    return balls


@dataclass
class TrajectoryEvidence(TakenByEffects):
    """What the free-run marker error of a fitted model says.

    Attributes
    ----------
    model : Model
        The fitted model.
    residual : (n,) float
        Marker (or tracked node) errors at every measured frame, in units of ``length_unit``.
    base : (n, p) float
        Their sensitivities to the model's own parameters.
    noise : float
        Marker noise per coordinate (in units of ``length_unit``).
    at_noise : bool
        Does the model explain the data to the noise (its lack of fit's verdict)? Then a
        candidate must explain ``min_explained`` of the misfit above the noise.
    """

    model: object
    experiments: list
    substeps: int
    length_unit: float
    residual: np.ndarray = field(repr=False, default=None)
    base: np.ndarray = field(repr=False, default=None)
    noise: float = 0.0
    at_noise: bool = False
    _runs: list | None = field(repr=False, default=None)
    _candidate_columns: dict = field(repr=False, default_factory=dict)

    @classmethod
    def of(cls, model, experiments, substeps: int, noise: float,
           at_noise: bool = False) -> TrajectoryEvidence:
        """The evidence of ``model`` fitted to ``experiments`` at ``substeps``, with the
        marker noise per coordinate ``noise`` (m) of its lack of fit and its verdict
        ``at_noise`` (explained)."""
        length = model.length_unit
        evidence = cls(model, list(experiments), int(substeps), length, at_noise=at_noise)
        evidence.residual, columns = evidence._sensitivities([])
        evidence.base = columns[0]
        evidence.noise = noise / length
        return evidence

    def _sensitivities(self, effects):
        """``(residual, [own columns, columns of every effect])`` with ``effects`` added to
        the model at their parameters (zero: the fitted trajectory)."""
        probe = self.model.with_effects(*effects)
        parameters = Parameterization(probe)
        sensitivity = Sensitivity(parameters, self.length_unit,
                                  offsets=fits_offsets("auto", self.experiments))
        theta = parameters.initial()
        # the columns split over the cores (each thread simulates the state once)
        self._runs = [sensitivity.run(theta, e, substeps=self.substeps, tangents=True,
                                      threads=None) for e in self.experiments]
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
        """The elements of the ball that explains most of the residual the model's own
        parameters leave (module docstring: a scan, then a finer one around the best)."""
        if self.model.elements is None:
            return []
        centroids, balls, step = self.first_scan(taken)
        best = self._best_ball(balls, centroids)
        if best is None:
            return []
        centre, radius, gain = best
        if self.at_noise and gain < FINER_SCAN_SHARE * self.min_explained * self.excess:
            return self._members(centroids, centre, radius, taken)
        finer = [centre + 0.5 * step * (np.array(index) - 1) for index in np.ndindex(3, 3, 3)]
        # every ball of the finer scan scored exactly: their gains are within a few per
        # cent of each other, too close for the shortlist's proxies
        best = self._best_ball(_balls(centroids, finer, [f * radius for f in REFINE_RADII],
                                      taken), centroids, shortlisted=False)
        return self._members(centroids, *best[:2], taken)

    @staticmethod
    def _members(centroids, centre, radius, taken) -> list[int]:
        members = np.flatnonzero(np.linalg.norm(centroids - centre, axis=1) <= radius)
        return sorted(int(k) for k in members if k not in taken)

    @property
    def excess(self) -> float:
        """What the model's own parameters leave of the residual's sum of squares above the
        noise's (units of ``length_unit`` squared; the share a candidate explains is of this)."""
        return residual_sum_of_squares(self.base, self.residual) - self.size * self._sigma2

    def first_scan(self, taken: set[int]):
        """``(centroids, balls, step)``: the elements' centroids, the balls of the first
        scan (``SCAN_PER_SIDE`` centres along the longest side, ``SCAN_RADII``) and the
        spacing of their centres."""
        geometry = tetrahedron_geometry(self.model.mesh)
        centroids = self.model.mesh.rest_positions[geometry.nodes].mean(axis=1)
        low, high = centroids.min(axis=0), centroids.max(axis=0)
        side = max(float(np.max(high - low)), 1e-300)
        step = side / SCAN_PER_SIDE
        counts = np.maximum(np.ceil((high - low) / step - 1e-9).astype(int), 1)
        centres = [low + step * (np.array(index) + 0.5) for index in np.ndindex(*counts)]
        return centroids, _balls(centroids, centres, [f * side for f in SCAN_RADII],
                                 taken), step

    def _best_ball(self, balls, centroids, shortlisted: bool = True):
        """``(centre, radius, gain)`` of the ball whose extra Young's modulus explains most
        of the residual left by the model's own parameters (None without balls): the balls of
        :meth:`shortlist` (``shortlisted``) or all scored exactly."""
        if not balls:
            return None
        target = self._target()
        if shortlisted:
            balls = self.shortlist(balls, target)
        gains = self.ball_gains(balls, target)
        members = balls[int(np.argmax(gains))]
        centre = centroids[members].mean(axis=0)
        return (centre, float(np.linalg.norm(centroids[members] - centre, axis=1).max())
                + 1e-12, float(gains.max()))

    def _target(self) -> np.ndarray:
        """The residual the model's own parameters leave (projected off their columns)."""
        basis = orthonormal(self.base)
        return self.residual - basis @ (basis.T @ self.residual)

    def ball_gains(self, balls, target=None) -> np.ndarray:
        """What each ball's extra Young's modulus explains of the residual ``target`` (the
        model's own parameters' leftover by default): ``(cᵀt)² / ‖c‖²`` from its exact
        sensitivity column ``c``, projected off the model's own."""
        target = self._target() if target is None else target
        basis = orthonormal(self.base)
        _, columns = self._sensitivities([StiffInclusion.of_elements(self.model, members)
                                          for members in balls])
        gains = []
        for column in columns[1:]:
            column = column[:, 0] - basis @ (basis.T @ column[:, 0])
            norm2 = float(column @ column)
            gains.append((column @ target) ** 2 / norm2 if norm2 > 0 else 0.0)
        return np.array(gains)

    def shortlist(self, balls, target=None) -> list[np.ndarray]:
        """The balls worth a sensitivity column (a forward tangent each, about a simulation's
        cost): a ball's gain is ``(cᵀt)² / ‖c‖²`` with ``c`` its column projected off the
        model's own and ``t`` the residual they leave, and every ``cᵀt`` comes from one
        backward sweep (``Jᵀt``, the adjoint; ``cᵀt`` needs no projection, as ``t`` is
        projected). ``‖c‖²`` of a ball of ``k`` elements grows between ``k`` and ``k²`` times
        an element's (from columns unrelated to one another to columns all alike), so the
        shortlist is the best ``SHORTLIST_EACH`` balls by ``(cᵀt)² / k^a`` for each ``a`` of
        ``SHORTLIST_POWERS`` (every ball without the compiled gradient, or when they are
        few). Measured on the probed block, the first scan's best ball ranks among the first
        three by three of the four proxies. Balls within a few per cent of the best may be
        missed: the finer scan, where most are that close, scores all of its balls."""
        if len(balls) <= len(SHORTLIST_POWERS) * SHORTLIST_EACH:
            return balls
        target = self._target() if target is None else target
        probe = self.model.with_effects(*[StiffInclusion.of_elements(self.model, members)
                                          for members in balls])
        parameters = Parameterization(probe)
        sensitivity = Sensitivity(parameters, self.length_unit,
                                  offsets=fits_offsets("auto", self.experiments))
        theta, first = parameters.initial(), len(self.model.effects)
        products, offset = np.zeros(parameters.size), 0
        for experiment, run in zip(self.experiments, self._runs):
            size = run.residuals.size
            cotangent = target[offset:offset + size].reshape(run.residuals.shape)
            offset += size
            products += sensitivity.gradient(theta, experiment, substeps=self.substeps,
                                             cotangent=cotangent)[1]
        products = np.array([products[parameters.blocks[f"effect:{first + i}"].slice][0]
                             for i in range(len(balls))])
        sizes = np.array([len(members) for members in balls], float)
        chosen = set()
        for power in SHORTLIST_POWERS:
            chosen.update(np.argsort(-products**2 / sizes**power)[:SHORTLIST_EACH].tolist())
        return [balls[index] for index in sorted(chosen)]

    # -- scoring --------------------------------------------------------------------------------
    def score(self, candidates) -> list[Candidate]:
        """Candidates ranked by ΔBIC (best first): the residual regressed on the model's own
        sensitivities with and without each candidate's."""
        if not candidates:
            return []
        switches = [c for c in candidates if c.switches_material]
        for effect in switches:
            self._candidate_columns[id(effect)] = self._switched(effect)
        others = [c for c in candidates if c not in switches]
        if others:                  # one compiled forward pass carries them all
            _, columns = self._sensitivities(others)
            self._candidate_columns.update(zip(map(id, others), columns[1:]))
        columns = [None] + [self._candidate_columns[id(c)] for c in candidates]
        target = self.residual
        n = target.size
        sigma2 = self._sigma2
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

    def _switched(self, effect) -> np.ndarray:
        """(n_residuals, 1): the change of the residual when the elements' material is
        switched (``effect.probe_switch``: a law, a little of a Prony term), the secant of
        the switch from one compiled run of the switched model at the fitted values (a
        switch has no tangent: a law changes whole, relaxation has internal variables)."""
        switched = effect.probe_switch(self.model, duration(self.experiments))
        parameters = Parameterization(switched)
        sensitivity = Sensitivity(parameters, self.length_unit,
                                  offsets=fits_offsets("auto", self.experiments))
        theta = parameters.initial()
        with np.errstate(all="ignore"):
            runs = [sensitivity.run(theta, e, substeps=self.substeps)
                    for e in self.experiments]
        change = np.concatenate([run.residuals.ravel() for run in runs]) - self.residual
        return np.nan_to_num(change, nan=0.0, posinf=0.0, neginf=0.0)[:, None]

    def initial_params(self, effect) -> np.ndarray:
        """The candidate's parameters of the linearised refit (the Gauss–Newton step)."""
        return self.linearised_step(effect)[1]

    def linearised_step(self, effect) -> tuple[np.ndarray, np.ndarray]:
        """``(own, params)``: the Gauss–Newton step of the model's own parameters (those of
        :class:`~neurofuzzy.learn.Parameterization` of :attr:`model`) and the candidate's
        parameters, fitted together to the residual."""
        extra = self._candidate_columns[id(effect)]
        both = np.concatenate([self.base, extra], axis=1)
        norms = np.linalg.norm(both, axis=0)
        norms[norms == 0] = 1.0
        solution, *_ = np.linalg.lstsq(both / norms, -self.residual, rcond=None)
        solution = solution / norms
        return solution[:self.base.shape[1]], solution[self.base.shape[1]:]

    def stepped(self, own: np.ndarray):
        """:attr:`model` with its own parameters moved by ``own`` (:meth:`linearised_step`),
        each by at most ``log(MAX_OWN_STEP)`` in the learner's coordinates (the logarithms of
        E and η: a factor of 2; ν's and the effects' are scaled otherwise): a linearisation
        from far off can ask for a step no refit should start from."""
        parameters = Parameterization(self.model)
        limit = np.log(MAX_OWN_STEP)
        return parameters.model(parameters.initial() + np.clip(own, -limit, limit))

    min_explained = MIN_EXPLAINED

    @property
    def _sigma2(self) -> float:
        """The noise's variance per coordinate (a floor of rounding for noise-free data)."""
        return max(self.noise, 1e-12 * float(np.abs(self.residual).max() or 1.0)) ** 2

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

