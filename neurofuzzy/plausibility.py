"""What a body of tissue and its recording can be: sizes and time scales checked against
physics where they enter (mesh files, marker recordings, experiment files, options).

A value that cannot be right is refused with an :class:`~neurofuzzy.errors.InputError` that
names the file or option and the likely fix ("did you mean --scale 0.001?"); a value that is
possible but unusual is a :class:`~neurofuzzy.errors.PlausibilityWarning` and the work goes
on. The limits are in one place, below, with the reason for each.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from .errors import InputError, PlausibilityWarning

__all__ = ["BODY_EXTENT", "USUAL_BODY_EXTENT", "FRAME_STEPS", "MARKER_SPREAD", "extent",
           "check_body_size", "scale_hint", "check_frame_period", "check_marker_spread",
           "check_same_body", "check_resampling", "check_recording", "check_fit_inputs",
           "check_length_option", "warn"]

#: (smallest, largest) extent in metres of a body of tissue a model can be made of: below a
#: tenth of a millimetre there is no tissue sample to track; above 3 m nothing is one organ or
#: specimen (a whole human body is 2 m). Outside: refused.
BODY_EXTENT = (1e-4, 3.0)
#: outside this the size is possible but unusual (warned): a millimetre sample, a 1 m limb
USUAL_BODY_EXTENT = (1e-3, 1.0)
#: (warned, refused) frame period in units of the model's stable step: measured motion is
#: sampled finer than the tissue's fastest dynamics allow an explicit step to be (at most a
#: few steps per frame on real recordings); hundreds mean times read in the wrong unit
#: (milliseconds as seconds give 1000 times too many)
FRAME_STEPS = (50.0, 100.0)
#: (refused, warned) spread of a marker cloud against the mesh's extent: markers that cover
#: less than 2 % of the body sit in one corner of it (a unit mismatch between the recording
#: and the mesh); less than 20 % is unusual (a small patch tracked)
MARKER_SPREAD = (0.02, 0.2)
#: candidate unit factors to metres, for hints
_UNITS = (("mm", 1e-3), ("cm", 1e-2), ("m", 1.0), ("in", 0.0254))


def warn(message: str) -> None:
    """Say that a value is unusual (a :class:`PlausibilityWarning`) and go on."""
    warnings.warn(PlausibilityWarning(message), stacklevel=3)


def extent(points: np.ndarray) -> float:
    """The largest side of the bounding box of ``points`` (n, 3), NaN rows ignored."""
    points = np.asarray(points, float).reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1)]
    if len(points) == 0:
        return 0.0
    return float(np.max(points.max(axis=0) - points.min(axis=0)))


def scale_hint(raw_extent: float, option: str = "--scale") -> str:
    """``"; did you mean --scale 0.001 (millimetres)?"`` for a body whose coordinates span
    ``raw_extent`` before scaling: the unit whose factor gives the most ordinary size."""
    best = None
    for name, factor in _UNITS:
        size = raw_extent * factor
        if USUAL_BODY_EXTENT[0] <= size <= USUAL_BODY_EXTENT[1]:
            distance = abs(math.log10(size / 0.1))            # an organ is about 10 cm
            if best is None or distance < best[0]:
                best = (distance, name, factor)
    if best is None:
        return ""
    _, name, factor = best
    unit = {"mm": "millimetres", "cm": "centimetres", "m": "metres", "in": "inches"}[name]
    return f"; did you mean {option} {factor:g} (the file in {unit})?"


def check_body_size(points: np.ndarray, *, source: str | None, what: str = "the body",
                    tissue: str | None = None, key: str | None = None,
                    scale: float | None = None, option: str = "--scale") -> float:
    """Refuse a body whose size no tissue can have; warn when it is unusual.

    Parameters
    ----------
    points : (n, 3) float
        Rest positions (metres).
    source : str or None
        The file, for the message.
    what : str
        What the points are ("the mesh", "the experiment's mesh").
    tissue : str, optional
        The tissue, for the message ("a liver 40 m across").
    key : str, optional
        The option or key to name.
    scale : float, optional
        The factor the file's coordinates were multiplied by (``--scale``): the hint then
        proposes a factor for the raw coordinates.
    option : str
        The option that scales the file, for the hint.

    Returns
    -------
    float
        The extent (m).
    """
    size = extent(points)
    low, high = BODY_EXTENT
    body = f"a body of {tissue}" if tissue else "a body of tissue"
    if not low <= size <= high:
        raw = size / (scale or 1.0)
        hint = scale_hint(raw, option) if option else ""
        raise InputError(f"{what} spans {size:.3g} m, which {body} cannot "
                         f"({low * 1e3:g} mm to {high:g} m): the coordinates are in another "
                         f"unit than metres{hint or '; give them in metres'}", source=source,
                         key=key)
    usual_low, usual_high = USUAL_BODY_EXTENT
    if not usual_low <= size <= usual_high:
        where = f"{source}: " if source else ""
        hint = scale_hint(size / (scale or 1.0), option) if option else ""
        warn(f"{where}{what} spans {size:.3g} m, unusual for {body}; check the length "
             f"unit{hint}")
    return size


def check_frame_period(max_step: float, dt: float, *, source: str | None,
                       duration: float | None = None, key: str | None = None,
                       fix: str = "", escape: str = "give --substeps N to simulate N steps "
                                                     "per frame anyway",
                       refuse: bool = True) -> None:
    """Refuse a frame period that is hundreds of the model's stable steps (times read in the
    wrong unit); warn when it is merely many.

    Parameters
    ----------
    max_step : float
        The model's stable step (s, :func:`~neurofuzzy.simulation.stability_limit`).
    dt : float
        The frame period (s).
    source, key : str, optional
        What to name.
    duration : float, optional
        The recording's length (s), for the message.
    fix : str
        What to do if the times are in milliseconds (e.g. "state '# time units: ms'").
    escape : str
        How to go on if the times are right (the user then takes responsibility).
    refuse : bool
        False: only warn (the user asserted the period, e.g. with an explicit option).
    """
    if not (math.isfinite(max_step) and max_step > 0 and math.isfinite(dt) and dt > 0):
        return
    ratio = dt / max_step
    warned, refused = FRAME_STEPS
    length = f" (the recording spans {duration:.3g} s)" if duration else ""
    said = (f"frames {dt:.3g} s apart{length} are {ratio:.0f} times the model's stable step "
            f"({max_step:.3g} s)")
    if ratio > refused and refuse:
        raise InputError(f"{said}: the tissue's dynamics are far faster than the sampling, "
                         "which happens when times in milliseconds are read as seconds "
                         f"(times are in seconds){'; ' + fix if fix else ''}. If the times are "
                         f"right, {escape}", source=source, key=key)
    if ratio > warned:
        where = f"{source}: " if source else ""
        warn(f"{where}{said}; fits will need many substeps per frame (are the times in "
             "seconds?)")


def check_marker_spread(markers: np.ndarray, mesh_points: np.ndarray, *, source: str,
                        mesh_source: str | None) -> None:
    """Refuse a marker cloud that covers a sliver of the mesh (a unit mismatch puts every
    marker in one corner); warn when it covers little of it.

    Parameters
    ----------
    markers : (n_markers, 3) float
        Marker positions at rest (m); NaN rows ignored. Fewer than three markers are not
        judged.
    mesh_points : (n_nodes, 3) float
        The mesh's rest positions (m).
    """
    markers = np.asarray(markers, float).reshape(-1, 3)
    markers = markers[np.isfinite(markers).all(axis=1)]
    body = extent(mesh_points)
    if len(markers) < 3 or body <= 0:
        return
    spread = extent(markers)
    ratio = spread / body
    refused, warned = MARKER_SPREAD
    said = (f"the markers span {spread:.3g} m, {100 * ratio:.2g} % of the mesh"
            + (f" {mesh_source}" if mesh_source else "") + f" ({body:.3g} m across)")
    if ratio < refused and spread > 0:
        factor = body / spread
        raise InputError(f"{said}: they sit in one corner of it, as when the recording and "
                         f"the mesh are in different units (about {factor:.3g} times apart); "
                         "check the recording's unit ('# units:' or --units) and the mesh's "
                         "(neurofuzzy mesh --scale)", source=source)
    if ratio < warned:
        warn(f"{source}: {said}: a small patch of the surface is tracked, or the units "
             "differ")


def check_same_body(model_points: np.ndarray, data_points: np.ndarray, *, model_source: str,
                    data_source: str) -> None:
    """Refuse a model and an experiment whose rest shapes are different sizes (another unit
    or another object with the same numbering)."""
    model_size, data_size = extent(model_points), extent(data_points)
    if model_size <= 0 or data_size <= 0:
        return
    ratio = max(model_size, data_size) / min(model_size, data_size)
    if ratio > 2.0:
        raise InputError(f"its mesh spans {data_size:.3g} m and the model {model_source} spans "
                         f"{model_size:.3g} m ({ratio:.3g} times apart): they are not the same "
                         "body (another length unit?)", source=data_source,
                         key="rest_positions")


def check_resampling(capture_period: float, dt: float, *, source: str,
                     key: str | None = None) -> None:
    """Refuse resampling a recording to a step hundreds of times finer than its captures
    (times read in the wrong unit); warn at ten times (piecewise-linear motion)."""
    if not (math.isfinite(capture_period) and capture_period > 0 and dt > 0):
        return
    ratio = capture_period / dt
    said = (f"the captures are {capture_period:.3g} s apart, {ratio:.0f} times the step "
            f"{dt:.3g} s they would be resampled to")
    if ratio > FRAME_STEPS[1]:
        raise InputError(f"{said}: were the times written in milliseconds? Times are in "
                         "seconds; state '# time units: ms' in the file or convert them",
                         source=source, key=key)
    if ratio > 10:
        warn(f"{source}: {said}; the motion between captures would be straight lines "
             "(prefer the capture rate, and substeps in the fit)")


def check_recording(markers, mesh, *, dt: float | None, model=None,
                    topology: str | None = None, dt_option: str | None = None) -> None:
    """A marker recording against the body it is attached to: its spread against the mesh
    (:func:`check_marker_spread`), its frame period against the model's stable step
    (:func:`check_frame_period`) and against the step it is resampled to.

    Parameters
    ----------
    markers : MarkerData
    mesh : Mesh
    dt : float or None
        The step the recording is resampled to (None: its capture period).
    model : Model, optional
        The model it will be fitted with (its stable step).
    topology : str, optional
        The file of ``mesh``, for messages.
    dt_option : str, optional
        How ``dt`` was given ("--dt"), when the user gave it.
    """
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        rest = np.nanmean(markers.positions, axis=0)               # (n_markers, 3)
    check_marker_spread(rest, mesh.rest_positions, source=markers.source, mesh_source=topology)
    period = markers.frame_period
    duration = float(markers.times[-1] - markers.times[0])
    if dt is not None:
        check_resampling(period, dt, source=markers.source)
    if model is not None:
        from .simulation import stability_limit

        step = dt if dt is not None else period
        check_frame_period(stability_limit(model).max_step, step, duration=duration,
                           source=markers.source, refuse=dt_option is None,
                           fix="state '# time units: ms' in the file or convert the times",
                           escape="give the step to resample to with --dt (a fit will then "
                                  "need many substeps per frame)")


def check_fit_inputs(experiments, model, *, substeps="auto",
                     model_source: str | None = None, physical: bool = True) -> None:
    """What a fit's experiments must be against physics and against its start model: a body
    of tissue's size, the start model's size (when it comes from a file) and, unless the
    substeps are given, frames that are not hundreds of the model's stable steps apart.

    ``physical``: the start model's time scales are the tissue's (a model file, a rule
    base's tissue), not an estimate from these very data (which scales with their times and
    cannot tell seconds from milliseconds); only then are the frames checked against them.
    """
    for experiment in experiments:
        check_body_size(experiment.mesh.rest_positions, source=str(experiment.source),
                        what="its mesh", key="rest_positions", option="")
        if model_source is not None:
            check_same_body(model.mesh.rest_positions, experiment.mesh.rest_positions,
                            model_source=str(model_source), data_source=str(experiment.source))
    if substeps not in ("auto", None) or not physical:
        return
    from .simulation import stability_limit

    max_step = stability_limit(model).max_step
    for experiment in experiments:
        check_frame_period(max_step, experiment.dt, source=str(experiment.source),
                           duration=experiment.dt * (experiment.n_frames - 1), key="dt",
                           fix="import the recording again with its times in seconds "
                               "('# time units: ms')")


def check_length_option(value: float | None, body: float, option: str, what: str, *,
                        refused: float = 1.0, warned: float | None = None) -> None:
    """A length given as an option (metres) against the body's extent ``body``: refused
    above ``refused`` times it ("a marker noise of 0.5 m on a body 4 cm across": the value
    is not in metres), warned about above ``warned`` times it."""
    if value is None or not body > 0 or not math.isfinite(value):
        return
    if value > refused * body:
        raise InputError(f"got {value:g} m: {what} of {value:.3g} m on a body {body:.3g} m "
                         f"across cannot be right; it is in metres (e.g. {value * 1e-3:g} for "
                         f"{value:g} mm)", key=option)
    if warned is not None and value > warned * body:
        warn(f"{option} {value:g} m: {what} is {100 * value / body:.0f} % of the body "
             f"({body:.3g} m across); is it in metres?")
