"""How much a fit from load steps depends on its mesh: :func:`with_mesh_check`.

A fit from load steps reads the tissue through linear tetrahedra, which are stiffer than the
continuum by an amount that shrinks with their size; the fit puts that into E (low, to give
the measured force) and ν, and the standard errors cannot see it: on FElupe's converged data
of a gel compressed between bonded plates, a 4³-cell block gives E 13 to 17 % low where the
noise's 95 % interval is ±3 %. The time fits' mesh check (:mod:`.mesh_check`) answers the
same question for marker trajectories; this is its counterpart for load steps. The fitted
model is refined once (every tetrahedron split into eight,
:func:`~.mesh_check.refine_model`), its load steps with it (:func:`refine_load_steps`: the
markers re-embedded at the same points, every driven set grown by the new nodes on its
edges, the tool and the load cell as they were), and refitted from the fitted values, by one
Levenberg–Marquardt step (``how="step"``, the default: two equilibria with their derivatives
on the refined mesh) or to convergence (``"refit"``). How far E and ν move is the estimate
of the error left on the fitted mesh; the fit's 95 % intervals add
:data:`~.uncertainty.MESH_ERROR_FACTOR` times it to the noise's, in quadrature
(:meth:`~._load_step_result.LoadStepFit.interval`), and say that they do.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ..errors import InputError
from ..progress import Stopwatch
from ._load_step_result import LoadStepFit
from .load_step_fit import PARAMETERS, fit_load_steps
from .mesh_check import MeshCheck, grown_paths, reembedded, refine_model
from .uncertainty import MESH_ERROR_FACTOR

__all__ = ["with_mesh_check", "refine_load_steps", "HOW", "AUTO_TETRAHEDRA"]

#: ``how="auto"`` runs the step where the refined mesh has at most this many tetrahedra. Its
#: price grows faster than the fit's: on FElupe's plates, three load steps (two fitted), the
#: step on 3,072 refined tetrahedra took 1.4 to 3.6 s after fits of 0.3 to 0.9 s, on 10,368
#: 9 to 28 s after 0.9 to 2.6 s, on 24,576 56 to 160 s after 3 to 9 s (benchmarks/
#: load_steps.py, the machine shared); beyond this, ``--mesh-check`` asks for it
AUTO_TETRAHEDRA = 12_000

#: what :func:`with_mesh_check` runs on the refined mesh, by its ``how``
HOW = {"step": "one Levenberg-Marquardt step of the refit on the mesh refined once (each "
               "tetrahedron in eight), from the fitted values",
       "refit": "refit on the mesh refined once (each tetrahedron in eight)"}


def refine_load_steps(data, refined_mesh, refinement):
    """``data`` (:class:`~neurofuzzy.load_steps.LoadSteps`) on ``refined_mesh``
    (``refinement``'s): the markers re-embedded at their points at rest, each driven set with
    the new nodes halving its own edges (a plate's face stays whole), the fixed nodes as
    :func:`~neurofuzzy.mesh.refine` holds them, the tool and the load cell unchanged."""
    driven = grown_paths(data.driven, data.mesh.n_nodes, refinement)
    return replace(data, mesh=refined_mesh, driven=driven,
                   markers=reembedded(data.markers, data.mesh, refined_mesh))


def with_mesh_check(fit: LoadStepFit, data, *, how: str = "step", register: bool = True,
                    reference_noise: bool = False, validate_on: Sequence[int] = (),
                    progress: Callable[[str], None] | None = None) -> LoadStepFit:
    """``fit`` (of ``data``, by :func:`~.load_step_fit.fit_load_steps`) with its mesh check
    (module docstring): :attr:`~._load_step_result.LoadStepFit.mesh_check_` set, its
    intervals widened by the mesh's share.

    Parameters
    ----------
    fit : LoadStepFit
    data : LoadSteps
        What ``fit`` was fitted to.
    how : {"step", "refit", "auto"}
        One Levenberg–Marquardt step on the refined mesh (about two equilibria of it per load
        step), or the whole refit; ``"auto"``: the step where the refined mesh has at most
        :data:`AUTO_TETRAHEDRA` tetrahedra, else none (the fit returned with
        ``mesh_check_skipped_`` saying why).
    register, reference_noise, validate_on
        As the fit had them, so the refit weighs the same residuals.
    progress : callable, optional
        Told of the refit's iterations.
    """
    if how not in (*HOW, "auto"):
        raise InputError(f"got {how!r}; expected 'auto' or one of "
                         f"{', '.join(map(repr, HOW))}", key="mesh_check")
    if how == "auto":
        refined = 8 * fit.model_.mesh.n_tetrahedra
        if refined > AUTO_TETRAHEDRA:
            return replace(fit, mesh_check_skipped_=(
                f"the mesh refined once would have {refined} tetrahedra, more than the "
                f"{AUTO_TETRAHEDRA} checked by default (the check then costs ten to twenty "
                "fits; --mesh-check runs it)"))
        how = "step"
    watch = Stopwatch()
    fine_model, refinement = refine_model(fit.model_)
    fine_data = refine_load_steps(data, fine_model.mesh, refinement)
    say = None if progress is None else (lambda text: progress(f"  mesh check:{text}"))
    refit = fit_load_steps(fine_model, fine_data, marker_noise=fit.marker_noise_,
                           force_noise=fit.force_noise_, register=register,
                           reference_noise=reference_noise, validate_on=validate_on,
                           max_iterations=1 if how == "step" else 30, progress=say)
    moving = [name for name in PARAMETERS
              if name not in fit.unidentifiable_ and name not in fit.fixed_]
    values = {}
    for name in moving:
        mesh, refined = float(getattr(fit, name + "_")), float(getattr(refit, name + "_"))
        ahead = mesh + MESH_ERROR_FACTOR * (refined - mesh)
        values[name] = {"mesh": mesh, "refined": refined,
                        "extrapolated": ahead if name == "youngs_modulus"
                        else float(np.clip(ahead, 0.0, 0.5))}
    theta = np.array([_parameter(name, values[name]["mesh"]) for name in moving])
    theta_refined = np.array([_parameter(name, values[name]["refined"]) for name in moving])
    check = MeshCheck(names=moving, theta=theta, theta_refined=theta_refined,
                      change=np.abs(theta_refined - theta),
                      nodes=(fit.model_.n_nodes, fine_model.n_nodes),
                      elements=(fit.model_.mesh.n_tetrahedra, fine_model.mesh.n_tetrahedra),
                      rms_refined=refit.marker_rms_, seconds=watch.seconds, values=values,
                      how=HOW[how])
    return replace(fit, mesh_check_=check)


def _parameter(name: str, value: float) -> float:
    """The fit's own parameter of a value: log E, logit 2ν."""
    return float(np.log(value) if name == "youngs_modulus" else np.log(value / (0.5 - value)))
