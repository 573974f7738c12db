"""Is a fit (or a diagnosis) a result at all? A fit that diverged, stayed non-finite or ends
worse than a model that never moves is refused, with its likely cause, before anything is
written. The learners themselves return whatever they reached; the fit pipeline
(:func:`neurofuzzy.pipeline.fit`) decides, for the command line, ``fit-many`` and Python alike."""

from __future__ import annotations

import contextlib
import math

import numpy as np

from ..errors import InputError, NeurofuzzyError

__all__ = ["FitFailedError", "check_outcome", "explained", "measured_motion",
           "require_motion"]

#: plausible mean density of an object (kg/m³): from foam and lung to bone, with room to spare
PLAUSIBLE_DENSITY = (10.0, 2e4)


class FitFailedError(NeurofuzzyError):
    """A fit or diagnosis ran but explains the data worse than a model that never moves."""


def measured_motion(experiments) -> float:
    """RMS distance of the measurements from their frame-0 positions (metres): the error of a
    model that never moves, over what the fit compares (tracked nodes or markers)."""
    total, count = 0.0, 0
    for experiment in experiments:
        observation = experiment.observation
        values = observation.values                    # (T, M, 3), NaN in the gaps
        seen = observation.seen[1:]
        with np.errstate(invalid="ignore"):
            moved = np.where(seen[..., None], values[1:] - values[:1], 0.0)
        total += float(np.sum(moved * moved))
        count += int(seen.sum())
    return math.sqrt(total / count) if count else 0.0


def require_motion(experiments) -> None:
    """Refuse measurements that never move from frame 0: there is nothing to learn from."""
    if measured_motion(experiments) == 0.0:
        files = ", ".join(str(e.source) for e in experiments)
        raise InputError("the measured positions never move from frame 0, so there is "
                         "nothing to fit; check the recording (and its load)", source=files,
                         key="positions")


@contextlib.contextmanager
def explained(what: str, experiments, start_model, substeps):
    """A learner's own error (it diverged, a matrix became singular …) re-raised as a
    :class:`FitFailedError` naming the files and the likely cause; errors about an input
    file pass unchanged."""
    try:
        yield
    except FitFailedError:
        raise
    except NeurofuzzyError as error:
        if isinstance(error, InputError) and error.source is not None:
            raise
        files = ", ".join(str(e.source) for e in experiments)
        cause = _likely_cause(experiments, start_model, start_model, substeps)
        raise FitFailedError(f"{files}: the {what} failed: {error}; {cause}; nothing "
                             "written") from None


def check_outcome(what: str, experiments, start_model, end_model, rms_initial: float,
                  rms_final: float, substeps) -> None:
    """Raise :class:`FitFailedError` when ``rms_final`` is not finite or is larger than the
    measured motion; the message names the experiment files, the numbers and the likely cause.
    """
    motion = measured_motion(experiments)
    if math.isfinite(rms_final) and rms_final <= max(motion, 1e-300):
        return
    files = ", ".join(str(e.source) for e in experiments)
    if not math.isfinite(rms_final):
        how = (f"the simulation diverges (RMS error per marker {rms_initial:.3g} m -> "
               f"{rms_final})")
    else:
        how = (f"RMS error per marker {rms_initial:.3g} m -> {rms_final:.3g} m, worse than a "
               f"model that never moves ({motion:.3g} m)")
    raise FitFailedError(f"{files}: the {what} failed: {how}; "
                         f"{_likely_cause(experiments, start_model, end_model, substeps)}; "
                         "nothing written")


def _likely_cause(experiments, start_model, end_model, substeps) -> str:
    from ..simulation import stability_limit

    experiment = experiments[0]
    steps = substeps if isinstance(substeps, int) and substeps >= 1 else 1
    step = experiment.dt / steps
    for label, model in (("start", start_model), ("fitted", end_model)):
        limit = stability_limit(model).max_step
        if step > limit:
            return (f"likely cause: the time step {step:.3g} s is above the stability limit "
                    f"{limit:.3g} s of the {label} model (its masses are too small or its "
                    "springs too stiff for the data's dt; check dt, the length and mass units, "
                    "or use --substeps)")
    masses = experiment.node_mass if experiment.node_mass is not None else start_model.node_mass
    density = _density(experiment.mesh, float(np.sum(masses)))
    low, high = PLAUSIBLE_DENSITY
    if density is not None and not low <= density <= high:
        return (f"likely cause: the masses ({np.sum(masses):.3g} kg in all) give the object a "
                f"density of {density:.3g} kg/m^3 (tissue: about 1000): masses or length "
                "units are implausible")
    return ("likely causes: a wrong dt or length unit in the data, a start too far from the "
            "data (give --start MODEL.yaml or --rules R --tissue T), or an effect the model "
            "lacks (try neurofuzzy diagnose)")


def _density(mesh, total_mass: float) -> float | None:
    """Mean density of the object: its mass over the volume of its convex hull (None when the
    nodes span no volume)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        volume = ConvexHull(mesh.rest_positions).volume
    except (QhullError, ValueError):
        return None
    return total_mass / volume if volume > 0 else None
