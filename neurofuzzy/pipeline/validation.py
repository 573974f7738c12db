"""Data kept out of a time-series fit, and how well the fitted model predicts it.

Two ways to hold data out (``nf.fit(..., validate_on=...)``, ``neurofuzzy fit
--validate-on``):

- **load cases**: some of the experiments (indices into the list, or their names), fitted on
  the others and then simulated whole;
- **a time window**: a time in seconds; every experiment is fitted on its frames before it,
  and its frames from it on are predicted by simulating the whole recording.

The prediction error is the RMS per marker over the held-out frames (as the fit's own RMS is
counted: :func:`~neurofuzzy.experiment.rms_error`), reported beside the fitted RMS and, where
the data's marker noise is known, as a multiple of the RMS the noise alone gives.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, index_of
from ..experiment import model_errors

__all__ = ["HeldOut", "hold_out", "validation"]


@dataclass(frozen=True)
class HeldOut:
    """The split: ``fitted`` experiments (cut where a window is held out), the ``held``
    ones (whole) and the first held-out frame of each (0 for a load case)."""

    fitted: list
    held: list
    first_frame: list
    names: list
    fitted_names: list
    describe: dict


def hold_out(experiments: list, validate_on, names: Sequence[str]) -> HeldOut:
    """Split ``experiments`` by ``validate_on``: a time (a float, s), or load cases (a name, or
    a sequence of indices or names); a bare integer is refused as ambiguous."""
    names = [str(n) for n in names]
    if isinstance(validate_on, bool | int | np.integer):
        raise InputError(f"got {validate_on!r}: a time window is a float in seconds "
                         f"({float(validate_on)!r}), load cases a list ([{validate_on!r}])",
                         key="validate_on")
    if isinstance(validate_on, float | np.floating):
        return _window(experiments, float(validate_on), names)
    if isinstance(validate_on, str | os.PathLike):
        validate_on = [validate_on]
    chosen = []
    for item in validate_on:
        chosen.append(index_of(item, names))
        if chosen[-1] is None:
            raise InputError(f"{item!r} is not one of the experiments ({', '.join(names)}); "
                             "hold out load cases by their files, or a time window by a time "
                             "in seconds", key="validate_on")
    chosen = sorted(set(chosen))
    if not chosen or len(chosen) == len(experiments):
        raise InputError(f"must hold out some of the {len(experiments)} experiments and leave "
                         "one to fit (with one experiment, hold out a time window: a time in "
                         "seconds)", key="validate_on")
    kept = [i for i in range(len(experiments)) if i not in chosen]
    return HeldOut([experiments[i] for i in kept], [experiments[i] for i in chosen],
                   [0] * len(chosen), [names[i] for i in chosen], [names[i] for i in kept],
                   {"experiments": [names[i] for i in chosen]})


def _window(experiments, start: float, names):
    fitted, first = [], []
    for experiment, name in zip(experiments, names):
        frame = int(np.ceil(start / experiment.dt - 1e-9))
        if not np.isfinite(start) or frame < 3 or frame >= experiment.n_frames:
            raise InputError(f"holds out the frames from {start:g} s on, but {name} runs "
                             f"{(experiment.n_frames - 1) * experiment.dt:g} s in frames of "
                             f"{experiment.dt:g} s: give a time inside it, after its first "
                             "frames", key="validate_on")
        fitted.append(experiment.first_frames(frame))
        first.append(frame)
    return HeldOut(fitted, list(experiments), first, names, names, {"from_time": start})


def validation(model, split: HeldOut, *, substeps: int, fitted_rms: float,
               noise_rms: float | None) -> dict:
    """The prediction error on the held-out data (module docstring) as the summary's
    ``validation`` object."""
    errors = model_errors(model, split.held, substeps=substeps)
    if errors is None:
        rms = float("inf")
    else:
        total = count = 0.0
        for diff, experiment, first in zip(errors, split.held, split.first_frame):
            # model_errors counts from frame 1
            window = diff[max(first - 1, 0):]
            total += float(np.sum(window * window))
            count += int(experiment.observation.seen[1:][max(first - 1, 0):].sum())
        rms = float(np.sqrt(total / max(count, 1)))
    out = dict(split.describe)
    out.update(rms_error=rms, fitted_rms_error=float(fitted_rms))
    if noise_rms:
        out["noise_rms"] = float(noise_rms)
        out["times_noise"] = rms / float(noise_rms)
    return out
