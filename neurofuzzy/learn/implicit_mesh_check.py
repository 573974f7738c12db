"""How much a fit through implicit steps depends on its mesh: :func:`implicit_mesh_check`.

Linear tetrahedra are stiffer than the continuum by an amount that shrinks with their size, so
a fit of another solver's (or real tissue's) recording puts that into E, ν and η, and the
noise cannot show it: on FElupe's plates the load-step fit's E was 4.5 to 16.6 % low on 4³ to
8³ cells (:mod:`.load_step_mesh_check`). As for the load steps, the fitted model is refined
once (each tetrahedron in eight, :func:`~.mesh_check.refine_model`), the recording with it
(the markers re-embedded at their points, each driven set grown by the new nodes on its
edges, the tool and the load cell as they were), and refitted from the fitted values; each
constant extrapolated to a fine mesh is the fitted value plus
:data:`~.uncertainty.MESH_ERROR_FACTOR` times its move (Richardson, first order).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..experiment import Experiment
from ..progress import Stopwatch
from .implicit_fit import ImplicitFit, fit_implicit
from .mesh_check import refine_experiment, refine_model
from .uncertainty import MESH_ERROR_FACTOR

__all__ = ["implicit_mesh_check"]


def implicit_mesh_check(fit: ImplicitFit, experiments: Experiment | Sequence[Experiment], *,
                        groups: np.ndarray | None = None, **options) -> ImplicitFit:
    """``fit`` (of ``experiments`` by :func:`~.implicit_fit.fit_implicit`) with its
    :attr:`~.implicit_fit.ImplicitFit.mesh_check` (module docstring).

    Parameters
    ----------
    fit : ImplicitFit
    experiments, groups
        As the fit had them.
    **options
        The fit's other options (``substeps``, ``scheme``, ``max_evaluations``,
        ``tolerance``), so the refit weighs the same residuals the same way; the noise is the
        one the fit used (``marker_noise`` and ``force_noise`` given here are set aside).
    """
    watch = Stopwatch()
    options = {k: v for k, v in options.items() if k not in ("marker_noise", "force_noise")}
    experiments = [experiments] if isinstance(experiments, Experiment) else list(experiments)
    fine_model, refinement = refine_model(fit.model)
    fine = [refine_experiment(e, fine_model.mesh, refinement) for e in experiments]
    if groups is not None:
        groups = np.asarray(groups, np.intp)[refinement.parent]
    refit = fit_implicit(fine_model, fine, groups=groups, marker_noise=fit.marker_noise,
                         force_noise=fit.force_noise, **options)
    check = {"elements": (fit.model.mesh.n_tetrahedra, fine_model.mesh.n_tetrahedra),
             "rms_refined": refit.rms_error, "seconds": watch.seconds}
    for name, mesh in fit.values.items():
        refined = np.asarray(refit.values[name])
        ahead = mesh + MESH_ERROR_FACTOR * (refined - mesh)
        check[name] = {"mesh": np.asarray(mesh), "refined": refined,
                       "extrapolated": (np.clip(ahead, 0.0, 0.5) if name == "poisson_ratio"
                                        else ahead)}
    return replace(fit, mesh_check=check)
