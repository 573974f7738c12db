"""Parameters that are right in the user's simulator: a fit for its element and step
(issue 47, item 2, for MuJoCo, SOFA, and our own implicit step, ``--target ours``).

A model fitted with our explicit step and exported as it is moves differently in a simulator
that steps at 16 ms with an implicit integrator on another element. :func:`fit_for_target`
fits E, ν and η **as the target will use them**: on the target's element (MuJoCo's flex is
the textbook linear tetrahedron of St. Venant–Kirchhoff, :mod:`neurofuzzy.export.mujoco`;
SOFA's ``TetrahedronFEMForceField`` is our ``corotational`` law, :mod:`neurofuzzy.export.sofa`),
by backward Euler steps of the target's step (:func:`~.implicit_fit.fit_implicit`, exact
derivatives), on the recording resampled to that step (every ``k``-th frame; the load
averaged over the ``k`` frames of each step, which keeps its impulse). Its errors are those
of the target's own step, the linearly implicit one of MuJoCo's ``discrete`` integrator
(:func:`~neurofuzzy.simulation.implicit.simulate_implicit`, which reproduces it on this element:
``tests/test_implicit.py``) and of SOFA's ``EulerImplicitSolver`` (one linear solve a step;
not run here: SOFA does not install with pip), beside the naive export's (the accurate fit's
values on the target's element and step) and our own model's at the same frames.

What no fit can do: follow motion faster than the step. A recording that rings (a step load
on a soft block) keeps its ringing in every model stepped at 16 ms; the errors say how much.
The fit is done with the converged step, whose Jacobian is exact; MuJoCo's single Newton
iteration differs from it by a few µm at 16 ms on a 3 cm block.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..experiment import Experiment, simulate_like
from ..model import Model
from ..simulation.implicit import simulate_implicit
from ..simulation.resampling import resampled
from .implicit_fit import fit_implicit

__all__ = ["TARGETS", "TargetFit", "fit_for_target", "rms_at_step", "describe",
           "region_values"]

#: The simulators a fit can target: their element, law and integrator (as written to their
#: files). ``"ours"``: our own implicit step (:func:`~neurofuzzy.simulation.implicit.
#: simulate_implicit`, ``simulate --integrator implicit``) on the model's own element and law
#: (None: kept), for a real-time loop that runs the fitted model at the simulator's step.
TARGETS = {"mujoco": {"volumetric": "element", "law": "st-venant-kirchhoff",
                      "integrator": "discrete", "name": "MuJoCo"},
           "sofa": {"volumetric": "element", "law": "corotational",
                    "integrator": "EulerImplicitSolver", "name": "SOFA"},
           "ours": {"volumetric": None, "law": None, "integrator": "implicit",
                    "name": "our implicit step"}}


@dataclass(frozen=True)
class TargetFit:
    """A fit for a simulator's element and step.

    Attributes
    ----------
    model : Model
        The target's model (its element and law) with the fitted E, ν, η.
    target, integrator : str
    dt : float
        The target's step (s).
    rms_error : float
        Markers (m), the target model at the target's step.
    naive_rms_error : float
        The same for the accurate fit's values on the target's element and step.
    own_rms_error : float
        Our accurate model (our step) at the same frames.
    evaluations : int
    at_bound : tuple of str
        Constants that ended at a bound of the search (:class:`~.implicit_fit.ImplicitFit`):
        at a large step the integrator's own damping can leave η untold.
    accurate : Model, optional
        The accurate fit the target fit started from (its values go into :meth:`record`).
    """

    model: Model
    target: str
    integrator: str
    dt: float
    rms_error: float
    naive_rms_error: float
    own_rms_error: float
    evaluations: int
    at_bound: tuple = ()
    accurate: Model | None = None

    def record(self) -> dict:
        """What the model file keeps (``fit: target:``), read by the export, and the report
        draws: the errors, and per region the values for the target beside the accurate
        fit's (``values``: region → ``{"target": {E, ν, η}, "accurate": {…}}``)."""
        values = {name: {"target": own} for name, own in region_values(self.model).items()}
        if self.accurate is not None:
            for name, own in region_values(self.accurate).items():
                values.setdefault(name, {})["accurate"] = own
        return {"simulator": self.target, "name": TARGETS[self.target]["name"],
                "dt": self.dt, "integrator": self.integrator,
                "rms_error": self.rms_error, "naive_rms_error": self.naive_rms_error,
                "own_rms_error": self.own_rms_error, "at_bound": list(self.at_bound),
                "values": values}


def region_values(model: Model) -> dict:
    """Each region's Young's modulus, Poisson's ratio and viscosity (the mean over its
    elements: one value where a region is one tie group)."""
    elements = model.elements
    region = np.zeros(model.mesh.n_tetrahedra, int) if elements.region is None \
        else np.asarray(elements.region)
    return {name: {key: float(np.mean(np.asarray(getattr(elements, key))[region == k]))
                   for key in ("youngs_modulus", "poisson_ratio", "viscosity")}
            for k, name in enumerate(model.region_names) if np.any(region == k)}


def describe(record: dict) -> str:
    """One line of a :meth:`TargetFit.record` for the command's output."""
    bound = (f"; {', '.join(record['at_bound'])} at the search's bound (not told at this "
             "step)" if record.get("at_bound") else "")
    return (f"for {record.get('name', record['simulator'])} at {1e3 * record['dt']:g} ms "
            f"({record['integrator']}): "
            f"RMS {1e6 * record['rms_error']:.1f} µm per marker; a naive export of the fit "
            f"{1e6 * record['naive_rms_error']:.1f} µm, our model "
            f"{1e6 * record['own_rms_error']:.1f} µm{bound}")


def fit_for_target(model: Model, experiments: Experiment | Sequence[Experiment], *,
                   target: str = "mujoco", dt: float = 0.016, substeps: int | str = "auto",
                   max_evaluations: int = 40) -> TargetFit:
    """Fit ``model``'s E, ν, η for ``target``'s element and step ``dt`` (module docstring).

    Parameters
    ----------
    model : Model
        The accurate fit (its values start the fit and make the naive export): elements
        without springs, effects or Prony terms (refused: the simulators have none); one E,
        ν, η per region.
    experiments : Experiment or sequence of them
        The recordings, at frames a whole number of which make ``dt``.
    target : str
        A key of :data:`TARGETS`.
    dt : float
        The target's step (s).
    substeps : int or "auto"
        Our explicit step's substeps per frame for our own model's error (default: the
        fewest stable ones).
    """
    if target not in TARGETS:
        raise InputError(f"got {target!r}; expected one of {sorted(TARGETS)}", key="--target")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"got {dt}; expected a positive step in seconds", key="--dt")
    if model.elements is None:
        raise InputError("a fit for a simulator's element needs an element model",
                         key="--target")
    if model.n_relaxation_terms:
        raise InputError("the simulators' elements have no Prony relaxation, so values "
                         "fitted with it would not be theirs: fit for the target a model "
                         "without --relaxation", key="--target")
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    chosen = TARGETS[target]
    steps = [resampled(e, dt) for e in experiments]
    naive = model.with_elements(**{key: chosen[key] for key in ("volumetric", "law")
                                   if chosen[key] is not None})
    fitted = fit_implicit(naive, steps, groups=model.elements.region,
                          max_evaluations=max_evaluations)
    own = [simulate_like(model, e, substeps)[::int(round(dt / e.dt))] for e in experiments]
    return TargetFit(model=fitted.model, target=target, integrator=chosen["integrator"],
                     dt=float(dt), rms_error=rms_at_step(fitted.model, steps),
                     naive_rms_error=rms_at_step(naive, steps),
                     own_rms_error=rms_at_step(None, steps, own),
                     evaluations=fitted.evaluations,
                     at_bound=fitted.at_bound, accurate=model)


def rms_at_step(model, experiments, positions=None) -> float:
    """Markers' RMS distance (m), frames 1 onwards, of experiments at a simulator's step
    (:func:`~neurofuzzy.simulation.resampling.resampled`): ``model`` run by backward Euler
    steps with one Newton iteration (MuJoCo's ``discrete``), or the given ``positions`` per
    experiment."""
    total, count = 0.0, 0
    for index, experiment in enumerate(experiments):
        run = positions[index] if positions is not None else simulate_implicit(
            model, dt=experiment.dt, n_frames=experiment.n_frames,
            external_forces=experiment.external_forces,
            initial_positions=experiment.initial_positions()).positions
        difference = experiment.observation.residuals(run)[1:]
        total += float(np.sum(difference * difference))
        count += int(experiment.observation.seen[1:].sum())
    return float(np.sqrt(total / max(count, 1)))
