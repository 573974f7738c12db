"""How far a fitted model stays from the data, against the marker noise: the lack of fit.

One definition for every fit and diagnosis (command line, JSON, report, progress):

- **RMS error**, per marker: ``sqrt(mean |simulated - measured|²)`` in metres over every
  measured marker position (or tracked node) of frames 1 onwards, each a 3-D distance (so it
  is √3 times the RMS per coordinate). Where the learner fits the markers' rest positions
  (:func:`~neurofuzzy.observation.remove_offsets`), after removing them.
- **Marker noise**, per marker as well: ``√3 σ`` with ``σ`` the noise per coordinate,
  estimated from the fit's error itself: model error is smooth in time, white noise is not,
  so the third differences in time of the error are noise (variance ``20 σ²``; a robust
  median estimate over runs of four measured frames; third rather than first differences
  because they suppress a smooth error far more, so what the model misses is not read as
  noise); where that is not measurable, from the third differences of the measurements (an
  upper bound when the motion is fast against the frame rate).
- **Ratio** ``RMS / noise`` and a **verdict** in words: "explained to the noise" up to
  :data:`EXPLAINED` (the noise estimate is good to about ten per cent, and a model has to
  reach the noise, not beat it), else "residual N× the noise: this model class misses
  something" with where (the markers that carry half the excess) and when (the frames
  where the excess is at least half its peak) the misfit lives.

A model that stays above the noise is still the best such a model can do, but its values are
biased by what it misses and its standard errors, which assume the noise is all there is, are
too small: read them with the verdict.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..noise import noise_level
from ..formatting import json_safe, length_text

__all__ = ["LackOfFit", "lack_of_fit", "model_lack_of_fit", "EXPLAINED"]

#: Largest ratio of the RMS error to the marker noise read as "explained to the noise".
EXPLAINED = 1.2
#: Below this fraction of the motion an error is rounding (noise-free data fitted exactly).
EXACT = 1e-9
#: Below this fraction of the motion the noise is not measurable (no tracking is that good).
NOISE_FLOOR = 1e-4


@dataclass(frozen=True)
class LackOfFit:
    """The residual of a fit against the marker noise (module docstring).

    Attributes
    ----------
    rms : float
        RMS error per marker (m).
    noise : float
        Marker noise per marker (m): ``√3`` times ``noise_per_coordinate``.
    noise_per_coordinate : float
        Standard deviation of the noise of one coordinate (m).
    noise_how : str
        How the noise was estimated.
    ratio : float
        ``rms / noise`` (inf when the data carry no measurable noise but the model misses).
    explained : bool
        ``ratio <= EXPLAINED`` (or an exact fit of noise-free data).
    verdict : str
        The result in words.
    where : dict or None
        ``{"centroid": [x, y, z] (m), "markers": n, "share": fraction of the excess}``: the
        markers (or tracked nodes) that carry half the squared error above the noise.
    when : dict or None
        ``{"experiment": index, "from": s, "to": s}``: the frames whose excess is at least
        half the largest.
    per_marker, per_frame : list of ndarray
        Per experiment: RMS error of every measured row over its frames, and of every frame
        (1 onwards) over its rows (m; NaN where nothing is measured).
    marker_positions : list of (n_rows, 3) ndarray
        Per experiment: where every row is at rest (m).
    times : list of ndarray
        Per experiment: the time of frames 1 onwards (s).
    """

    rms: float
    noise: float
    noise_per_coordinate: float
    noise_how: str
    ratio: float
    explained: bool
    verdict: str
    where: dict | None = None
    when: dict | None = None
    per_marker: list = field(default_factory=list, repr=False)
    per_frame: list = field(default_factory=list, repr=False)
    marker_positions: list = field(default_factory=list, repr=False)
    times: list = field(default_factory=list, repr=False)

    def to_dict(self) -> dict:
        """JSON-ready: the numbers with their units, the verdict, where and when."""
        return json_safe({
            "rms": self.rms, "noise": self.noise, "ratio": self.ratio,
            "verdict": self.verdict, "explained": self.explained,
            "units": "m, per marker (3-D distance; per coordinate is 1/sqrt(3) of it)",
            "noise_per_coordinate": self.noise_per_coordinate, "noise_how": self.noise_how,
            "explained_up_to": self.explained_up_to, "where": self.where, "when": self.when})

    @property
    def explained_up_to(self) -> float:
        """The largest ratio read as "explained to the noise" (:data:`EXPLAINED`)."""
        return EXPLAINED

    @property
    def short(self) -> str:
        """One line for progress and summaries: ``RMS 41.2 µm per marker, 1.19x the noise``."""
        ratio = (f"{self.ratio:.2f}x the noise" if np.isfinite(self.ratio) and self.noise > 0
                 else "noise-free data" if np.isfinite(self.ratio) else "no measurable noise")
        return f"RMS {length_text(self.rms)} per marker, {ratio}"


def lack_of_fit(experiments: Sequence, errors: Sequence[np.ndarray]) -> LackOfFit:
    """The lack of fit of a model from its errors on ``experiments``.

    Parameters
    ----------
    experiments : sequence of Experiment
    errors : sequence of (n_frames - 1, n_rows, 3) float
        Per experiment, simulated minus measured (m) at frames 1 onwards for every row of its
        :attr:`~neurofuzzy.experiment.Experiment.observation` (zero where not measured), rest
        offsets already removed where they are fitted.
    """
    total, count = 0.0, 0
    per_marker, per_frame, positions, times, sigmas = [], [], [], [], []
    for experiment, error in zip(experiments, errors):
        observation = experiment.observation
        seen = observation.seen[1:]
        squared = np.where(seen, np.sum(np.nan_to_num(error) ** 2, axis=-1), 0.0)
        total += float(squared.sum())
        count += int(seen.sum())
        with np.errstate(invalid="ignore", divide="ignore"):
            per_marker.append(np.sqrt(squared.sum(axis=0) / seen.sum(axis=0)))
            per_frame.append(np.sqrt(squared.sum(axis=1) / seen.sum(axis=1)))
        positions.append(observation.apply(experiment.mesh.rest_positions))
        times.append(experiment.dt * np.arange(1, experiment.n_frames))
        runs = seen[3:] & seen[2:-1] & seen[1:-2] & seen[:-3]
        third = np.diff(np.nan_to_num(error), n=3, axis=0)[runs]
        sigmas.append((np.median(third**2) / 0.455 / 20.0, third.size) if third.size else None)
    rms = float(np.sqrt(total / count)) if count else 0.0
    motion = _motion(experiments)
    sigma, how = _noise(sigmas, experiments, motion)
    noise = float(np.sqrt(3.0) * sigma)
    exact = rms <= EXACT * max(motion, 1e-300)
    if noise > 0:
        ratio = rms / noise
        explained = ratio <= EXPLAINED
    else:      # noise-free data: explained to what no tracking could resolve
        ratio = 0.0 if exact else float("inf")
        explained = rms <= NOISE_FLOOR * motion
    where = when = None
    if not explained:
        where, when = _where(per_marker, positions, noise), _when(per_frame, times, noise)
    verdict = _verdict(rms, noise, ratio, explained, exact, where, when)
    return LackOfFit(rms=rms, noise=noise, noise_per_coordinate=float(sigma), noise_how=how,
                     ratio=float(ratio), explained=bool(explained), verdict=verdict, where=where,
                     when=when, per_marker=per_marker, per_frame=per_frame,
                     marker_positions=positions, times=times)


def model_lack_of_fit(model, experiments: Sequence, *, substeps: int = 1,
                      offsets: bool = False) -> LackOfFit:
    """The lack of fit of ``model`` on ``experiments``, simulated with ``substeps`` steps per
    frame (markers' rest offsets fitted with ``offsets``)."""
    from ..experiment import model_errors

    errors = model_errors(model, experiments, substeps=substeps, offsets=offsets)
    if errors is None:
        errors = [np.full((e.n_frames - 1, e.observation.n_rows, 3), np.inf)
                  for e in experiments]
    return lack_of_fit(experiments, errors)


def _noise(estimates, experiments, motion: float) -> tuple[float, str]:
    """σ per coordinate from the error's third differences, pooled over experiments; the
    measurements' third differences where those say nothing; 0 below :data:`NOISE_FLOOR`
    of the motion (noise-free data: what is left is rounding and model error)."""
    usable = [(variance, n) for variance, n in filter(None, estimates)]
    if usable:
        variance = sum(v * n for v, n in usable) / sum(n for _, n in usable)
        if np.sqrt(variance) <= NOISE_FLOOR * motion:
            return 0.0, "not measurable: the data carry no noise"
        if variance > 0:
            return float(np.sqrt(variance)), ("third differences in time of the fit's error "
                                              "(model error is smooth, noise is not)")
    sigma = noise_level(list(experiments))
    if sigma > 0:
        return sigma, ("third differences in time of the measurements (an upper bound when "
                       "the motion is fast against the frame rate)")
    return 0.0, "not measurable: the data carry no noise"


def _motion(experiments) -> float:
    """Largest measured displacement from frame 0 (m)."""
    largest = 0.0
    for experiment in experiments:
        values = experiment.observation.values
        with np.errstate(invalid="ignore"):
            moved = np.nan_to_num(np.abs(values - values[:1]))
        largest = max(largest, float(moved.max(initial=0.0)))
    return largest


def _where(per_marker, positions, noise) -> dict | None:
    """The rows that carry half the squared error above the noise, and their centre."""
    excess = np.concatenate([np.nan_to_num(r) ** 2 for r in per_marker]) - noise**2
    points = np.concatenate(positions)
    excess = np.maximum(excess, 0.0)
    if not excess.sum() > 0:
        return None
    order = np.argsort(-excess)
    cumulative = np.cumsum(excess[order]) / excess.sum()
    chosen = order[: int(np.searchsorted(cumulative, 0.5)) + 1]
    weights = excess[chosen]
    return {"centroid": (weights @ points[chosen] / weights.sum()).tolist(),
            "markers": int(len(chosen)), "of": int(len(points)),
            "share": float(weights.sum() / excess.sum())}


def _when(per_frame, times, noise) -> dict | None:
    """The span of frames whose excess over the noise is at least half the largest."""
    best = None
    for index, (rms, time) in enumerate(zip(per_frame, times)):
        excess = np.nan_to_num(rms) ** 2 - noise**2
        if excess.size and (best is None or excess.max() > best[0]):
            best = (float(excess.max()), index, excess, time)
    if best is None or best[0] <= 0:
        return None
    peak, index, excess, time = best
    strong = np.flatnonzero(excess >= 0.5 * peak)
    return {"experiment": index, "experiments": len(times), "from": float(time[strong[0]]),
            "to": float(time[strong[-1]]), "peak": float(time[int(np.argmax(excess))])}


def _verdict(rms, noise, ratio, explained, exact, where, when) -> str:
    if exact:
        return f"explained exactly (RMS {length_text(rms)} per marker: noise-free data)"
    if noise == 0 and explained:
        return (f"explained to {NOISE_FLOOR:.0e} of the motion (RMS {length_text(rms)} per "
                "marker; noise-free data)")
    if noise == 0:
        return (f"the data carry no measurable noise, and the model misses them by "
                f"{length_text(rms)} per marker: this model class misses something; the "
                "values are what such a model sees; run `neurofuzzy diagnose`")
    if explained:
        return (f"explained to the noise (RMS {length_text(rms)} per marker, {ratio:.2f}x the "
                f"marker noise of {length_text(noise)})")
    text = (f"residual {ratio:.2f}x the noise (RMS {length_text(rms)} per marker, marker noise "
            f"{length_text(noise)}): this model class misses something; "
            "the values are what such a model sees and their standard errors understate "
            "their uncertainty; run `neurofuzzy diagnose`")
    parts = []
    if where is not None:
        centre = ", ".join(f"{1e3 * c:.1f}" for c in where["centroid"])
        parts.append(f"near ({centre}) mm ({where['markers']} of {where['of']} markers carry "
                     "half of it)")
    if when is not None:
        parts.append(f"from {1e3 * when['from']:.0f} to {1e3 * when['to']:.0f} ms"
                     + (f" of experiment {when['experiment'] + 1}" if when["experiments"] > 1 else ""))
    return text + ("; the misfit is mostly " + " and ".join(parts) if parts else "")
