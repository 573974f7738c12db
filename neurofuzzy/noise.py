"""Marker noise from the data: white noise against smooth motion.

Two estimators: :func:`noise_level` from the measured trajectories alone (third differences in
time), and :func:`marker_noise` from a model's error (first differences of ``measured -
model``), sharper once a model follows the motion.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .experiment import Experiment

__all__ = ["noise_level", "marker_noise", "time_noise"]


def noise_level(experiments: Experiment | Sequence[Experiment]) -> float:
    """Standard deviation (metres) of white noise on the measured coordinates.

    Smooth motion has small third differences in time; white noise of variance σ² gives
    third differences of variance 20 σ². The estimate is robust (median of the squares,
    0.455 being the median of χ²₁) and counts only runs of four measured frames. It is an
    upper bound when the motion is fast against the frame rate.
    """
    experiments = [experiments] if isinstance(experiments, Experiment) else experiments
    squares = []
    for experiment in experiments:
        observation = experiment.observation
        values, seen = observation.values, observation.seen
        if len(values) < 5:
            continue
        third = values[3:] - 3 * values[2:-1] + 3 * values[1:-2] - values[:-3]
        valid = seen[3:] & seen[2:-1] & seen[1:-2] & seen[:-3]
        squares.append(third[valid].ravel() ** 2)
    if not squares or not np.concatenate(squares).size:
        return 0.0
    return float(np.sqrt(np.median(np.concatenate(squares)) / 0.455 / 20.0))


def time_noise(series: Sequence[np.ndarray]) -> float | None:
    """Standard deviation of white noise in residuals sampled in time, from their third
    differences: a model's misfit is smooth in time and drops out of them, white noise of
    variance σ² gives third differences of variance 20 σ². ``series`` holds arrays (n_frames,
    ...) with NaN where nothing was measured; only runs of four measured frames count. The
    mean of the squares (not their median, as :func:`noise_level`'s: these weigh a fit, and
    the mean scatters less). None with fewer than 20 such differences."""
    squares = []
    for values in series:
        values = np.asarray(values, float)
        if len(values) >= 4:
            third = values[3:] - 3 * values[2:-1] + 3 * values[1:-2] - values[:-3]
            squares.append(third[np.isfinite(third)].ravel() ** 2)
    squares = np.concatenate(squares) if squares else np.zeros(0)
    if squares.size < 20:
        return None
    return float(np.sqrt(np.mean(squares) / 20.0))


def marker_noise(error: np.ndarray, motion: np.ndarray) -> float:
    """Standard deviation of white marker noise in a trajectory error ``measured - model``.

    Model errors are smooth in time, noise is not: the first difference of the error is
    dominated by noise (variance 2σ²). Robust (median-based); 0 when it is negligible next to
    the motion (noise-free data).
    """
    if error.shape[0] < 3 or error.size == 0:
        return 0.0
    first = np.diff(error, axis=0)
    sigma = float(np.sqrt(np.median(first**2) / 0.455 / 2.0))
    scale = float(np.abs(motion).max()) or 1.0
    return sigma if sigma > 1e-7 * scale else 0.0
