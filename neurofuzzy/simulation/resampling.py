"""An experiment at a simulator's step: :func:`resampled` (the frames a simulator stepping at
``dt`` would record, for a fit or a check at that step)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import InputError

__all__ = ["resampled"]


def resampled(experiment, dt: float):
    """The :class:`~neurofuzzy.experiment.Experiment` at frames ``dt`` apart, a whole number
    ``k`` of its own: every ``k``-th frame, its markers too, and the load averaged over each
    step's ``k`` frames (its impulse kept), as a simulator stepping at ``dt`` takes it."""
    ratio = dt / experiment.dt
    k = int(round(ratio))
    if k < 1 or abs(ratio - k) > 1e-6 * ratio:
        raise InputError(f"the target's step {dt:g} s is not a whole number of the "
                         f"recording's frame spacing {experiment.dt:g} s", key="--dt")
    n = (experiment.n_frames - 1) // k + 1
    if n < 3:
        raise InputError(f"a step of {dt:g} s leaves {n} frames of the recording "
                         f"({experiment.n_frames} frames {experiment.dt:g} s apart)",
                         key="--dt")
    frames = np.arange(n) * k
    loads = experiment.forces_per_frame()[:(n - 1) * k].reshape(n - 1, k, -1, 3).mean(axis=1)
    loads = np.concatenate([loads, experiment.forces_per_frame()[frames[-1]][None]])
    markers = experiment.markers
    if markers is not None:
        markers = replace(markers, positions=markers.positions[frames])
    return experiment.replace(dt=float(dt), positions=experiment.positions[frames],
                              external_forces=loads, markers=markers)
