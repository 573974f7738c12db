"""A long recording diagnosed on its beginning, the answer fitted on all of it.

Every pass of a diagnosis in trajectory space is a simulation of the whole recording, so its
time grows with the frames. Which effect is missing shows in the first oscillations after the
load arrives as well as in all of them, so a recording with more than :data:`LONG` times
:data:`WINDOW` frames of motion is diagnosed on its rest frames and the first
:data:`WINDOW` frames of motion, and the answer's model is then fitted on every frame from
the window's values (one fit at one step, confirmed at two as every winner is; the window's
winner is not confirmed on its own). On sfepy's block (4 mm voxels, 4,800 tetrahedra, 1 kHz,
401 frames) the first 60 frames of motion hold one and a half periods of the probed block's
oscillation and 1.2 relaxation times of the relaxing one, and the diagnosis on them names
each case's hidden effect, or none, right (``benchmarks/diagnosis_profile.py``,
docs/benchmarks.md).

A model that misses the data only after the window (a creep slower than the window, a camera
that slipped) is found out there: when the window's answer explained its frames and all the
frames are not explained, the whole recording is diagnosed after all.
"""

from __future__ import annotations

import numbers
from dataclasses import replace

from ..errors import InputError
from ..learn import auto_substeps
from .refits import FIT_TOLERANCE, confirm, fitted

__all__ = ["WINDOW", "LONG", "check_window", "window_frames", "span", "first_frames",
           "on_all_frames"]

#: Frames of motion (after the load's onset) a long recording is diagnosed on.
WINDOW = 60
#: A recording is diagnosed on a window only when it has more than this many times
#: :data:`WINDOW` frames of motion: shorter ones gain less than the fit on all frames costs.
LONG = 2


def check_window(window, key: str = "window"):
    """``window`` as :func:`diagnose` takes it: ``"auto"``, ``"all"`` (also None) or a whole
    number of frames, at least 2 (a string of digits too, as the command line gives it); an
    :class:`~neurofuzzy.errors.InputError` naming ``key`` otherwise."""
    if window is None or window in ("auto", "all"):
        return window
    if isinstance(window, str) and window.isdigit():
        window = int(window)
    if isinstance(window, bool) or not isinstance(window, numbers.Real) or window != window \
            or int(window) != window or window < 2:
        raise InputError(f"got {window!r}; expected 'auto', 'all' or a whole number of frames "
                         "(at least 2)", key=key)
    return int(window)


def window_frames(experiments, window) -> int | None:
    """The frames of motion to diagnose on (``window``: see :func:`check_window`), or None
    for all of them."""
    window = check_window(window)
    moving = max(e.n_frames - e.load_onset for e in experiments)
    if window is None or window == "all":
        return None
    if window == "auto":
        return WINDOW if moving > LONG * WINDOW else None
    return window if window < moving else None


def span(experiments, frames: int) -> tuple[int, int]:
    """``(shown, total)``: the frames a window of ``frames`` frames of motion holds (its rest
    frames too), and the recording's."""
    return (max(e.load_onset for e in experiments) + frames,
            max(e.n_frames for e in experiments))


def first_frames(experiments, frames: int) -> list:
    """Each experiment cut to its rest frames and ``frames`` frames of motion."""
    return [e.first_frames(e.load_onset + frames) for e in experiments]


def on_all_frames(found, experiments, frames: int, substeps, clock, say, rerun):
    """The window's diagnosis ``found`` with its model fitted on all ``experiments``' frames
    (from its values, at ``substeps``; ``"auto"``: at the model's stable step, confirmed at
    two as every winner is): its ``model_``, ``rms_after``, ``noise_rms`` and ``lack_of_fit`` are
    then all the frames', its findings, ``rms_before`` and ``mesh`` the window's; ``window``
    says which
    (:class:`~.result.Diagnosis`). When the window's answer explained its frames but the
    fit on all of them stays above the noise, the answer did not hold: ``rerun()`` diagnoses
    the whole recording, unless ``max_time`` is spent."""
    shown, total = span(experiments, frames)
    about = {"frames": shown, "of": total, "rms_before": found.rms_before,
             "rms_after": found.rms_after, "held": None, "rediagnosed": False}
    if clock.out():
        clock.left_out(f"the answer not fitted on all {total} frames (only on the first "
                       f"{shown})")
        return replace(found, window=about, provisional=clock.provisional)
    say(f"diagnose: fitting the answer ({', '.join(found.names)}) on all {total} frames, "
        f"from the first {shown} frames' values")
    auto = substeps == "auto"
    steps = max(auto_substeps(found.model_, e.dt) for e in experiments) if auto else substeps
    whole = clock.timed(lambda: fitted(found.model_, experiments, substeps=steps, windows=(),
                                       tolerance=FIT_TOLERANCE))
    if auto:
        whole = clock.timed(lambda: confirm(whole, experiments))
    verdict = whole.lack_of_fit_
    held = verdict.explained or not found.lack_of_fit.explained
    about.update(held=held)
    say(f"diagnose: on all {total} frames, {verdict.short}"
        + ("" if held else f": the first {shown} frames' answer does not hold"))
    if not held and clock.out():
        clock.left_out(f"the whole recording not diagnosed (the first {shown} frames' answer "
                       "does not hold on all of it)")
    elif not held:
        say(f"diagnose: diagnosing all {total} frames")
        about.update(rediagnosed=True)
        return replace(rerun(), window=about)
    return replace(found, model_=whole.model_, rms_after=whole.rms_error_,
                   noise_rms=verdict.noise, lack_of_fit=verdict, window=about,
                   provisional=clock.provisional)
