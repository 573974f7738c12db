"""What every learner shares: the estimator conventions and the tied parameterisation."""

from __future__ import annotations

import numpy as np

from ..forces.springs import spring_constants

__all__ = ["Learner"]


class Learner:
    """Base of the learners, after scikit-learn's estimator conventions: ``__init__`` only
    stores options (keyword-only), ``fit(model, experiments)`` validates, works and returns
    ``self``, and results end in ``_``.

    Attributes set by ``fit`` (one meaning per name across learners)
    ------------------------------------------------------------------
    model_ : Model
        The fitted model.
    history_ : (n_cycles,) float ndarray
        The paper's error ``E`` (eq. 2.2: ``½ Σ |p - o|²`` over frames and measured nodes,
        lengths in mean rest spring lengths) after every cycle.
    rms_error_initial_, rms_error_ : float
        :func:`~neurofuzzy.experiment.rms_error` (metres, per marker) of the start and the
        fitted model.
    lack_of_fit_ : LackOfFit
        The fitted model's RMS error against the marker noise, with a verdict in words
        (:mod:`neurofuzzy.learn.lack_of_fit`).
    n_cycles_ : int
        Complete passes over the training data (simulations) the fit used.
    substeps_ : int
        Integration steps per frame with which ``model_`` reproduces the data.
    seconds_ : float
        Wall time of ``fit``.
    """

    #: what one entry of ``history_`` is, for plots ("cycle", "simulation of the data")
    cycle_name = "cycle"

    def get_params(self) -> dict:
        """The options given to ``__init__``, by name."""
        return {name: getattr(self, name) for name in self._option_names()}

    def set_params(self, **options) -> Learner:
        """Change options (as ``__init__`` would take them); returns ``self``."""
        known = self._option_names()
        for name, value in options.items():
            if name not in known:
                from ..errors import InputError, closest_name

                hint = closest_name(name, known)
                raise InputError(f"{type(self).__name__} has no option {name!r}"
                                 + (f"; did you mean {hint!r}?" if hint else ""), key=name)
            setattr(self, name, value)
        return self

    @classmethod
    def _option_names(cls) -> list[str]:
        import inspect

        return [name for name, parameter in inspect.signature(cls.__init__).parameters.items()
                if parameter.kind == parameter.KEYWORD_ONLY]

    def __repr__(self) -> str:
        import inspect

        defaults = {name: parameter.default for name, parameter
                    in inspect.signature(type(self).__init__).parameters.items()}
        changed = [f"{name}={value!r}" for name, value in self.get_params().items()
                   if not _same(value, defaults.get(name))]
        return f"{type(self).__name__}({', '.join(changed)})"

    def to_dict(self) -> dict:
        """JSON-ready summary of the fitted model and the fit."""
        model = self.model_
        elements = {}
        if model.elements is not None:
            term = model.elements
            elements = {"elements": {"youngs_modulus": term.youngs_modulus.tolist(),
                                     "poisson_ratio": term.poisson_ratio.tolist(),
                                     "viscosity": term.viscosity.tolist()}}
            if term.n_relaxation_terms:           # Prony terms, per element: [g, ...], [τ, ...]
                elements["elements"].update(relaxation_moduli=term.relaxation_moduli.tolist(),
                                            relaxation_times=term.relaxation_times.tolist())
            if np.any(term.stiffens):             # Yeoh's C20/C10, per element
                elements["elements"].update(stiffening=term.stiffening.tolist())
        return {
            **elements,
            # the springs' constants (none for an element model: zeros, as before terms)
            "stiffness": spring_constants(model)[0].tolist(),
            "damping": spring_constants(model)[1].tolist(),
            "node_mass": model.node_mass.tolist(),
            "effects": [{"name": e.name, "parameters": e.params.tolist()} for e in model.effects],
            "rms_error": self.rms_error_,
            "rms_error_initial": self.rms_error_initial_,
            "cycles": self.n_cycles_,
            "substeps": self.substeps_,
            "seconds": self.seconds_,
            "history": self.history_.tolist(),
            "lack_of_fit": self.lack_of_fit_.to_dict(),
        }


def _same(value, default) -> bool:
    try:
        return bool(value == default)
    except (TypeError, ValueError):
        return False
