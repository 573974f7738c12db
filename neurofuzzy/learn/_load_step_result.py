"""The outcome of a fit from load steps (:class:`LoadStepFit`), what its summary says and what
its intervals hold."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import Model
from .mesh_check import MeshCheck
from .uncertainty import MESH_ERROR_FACTOR

__all__ = ["LoadStepFit"]


@dataclass(frozen=True)
class LoadStepFit:
    """The outcome of :func:`fit_load_steps` (learned values end in ``_``)."""

    model_: Model
    youngs_modulus_: float
    poisson_ratio_: float
    standard_errors_: dict
    unidentifiable_: tuple
    marker_rms_: float
    force_rms_: float | None
    marker_noise_: float
    force_noise_: float | None
    registration_: np.ndarray
    validation_: dict | None
    iterations_: int
    notes_: tuple
    markers_: np.ndarray | None = None
    reactions_: np.ndarray | None = None
    registered_: np.ndarray | None = None
    fitted_steps_: tuple = ()
    fixed_: tuple = ()
    noise_estimated_: bool = False
    mesh_check_: MeshCheck | None = None
    mesh_check_skipped_: str | None = None

    def interval(self, name: str) -> float | None:
        """The half-width of ``name``'s 95 % interval (its unit): 1.96 times the standard
        error, and, once :func:`~neurofuzzy.learn.load_step_mesh_check.with_mesh_check` has
        run, the mesh's share beside it in quadrature (:data:`MESH_ERROR_FACTOR` times the move
        on the mesh refined once). None where the fit gives no standard error."""
        error = self.standard_errors_.get(name)
        if error is None:
            return None
        move = 0.0
        if self.mesh_check_ is not None and name in self.mesh_check_.values:
            value = self.mesh_check_.values[name]
            move = MESH_ERROR_FACTOR * abs(value["refined"] - value["mesh"])
        return float(1.96 * np.hypot(error, move))

    @property
    def intervals_hold(self) -> str:
        """What the 95 % intervals hold: the noise alone, or the noise and the mesh."""
        check = self.mesh_check_
        if check is None:
            why = self.mesh_check_skipped_ or "no mesh check ran"
            return (f"the noise alone: {why}; a coarse mesh biases E and ν by more than the "
                    "noise may show (with_mesh_check, fit --mesh-check)")
        return check.holds()

    def extrapolated(self, name: str) -> float | None:
        """``name``'s value extrapolated to a mesh fine enough, from the mesh check (None
        without one, or for a value the fit does not move): the fitted value plus
        :data:`MESH_ERROR_FACTOR` times its move on the mesh refined once (Richardson's, for
        an error that halves with the cells' size)."""
        if self.mesh_check_ is None or name not in self.mesh_check_.values:
            return None
        return self.mesh_check_.values[name].get("extrapolated")

    @property
    def marker_scale(self) -> float:
        """The RMS per marker that noise alone gives (m): ``√3`` times the noise of one
        coordinate."""
        return float(np.sqrt(3.0) * (self.marker_noise_ or 0.0))

    def value_lines(self) -> list[str]:
        """E's and ν's lines of :meth:`summary`: each value with its interval, or why it has
        none (fixed, or not identifiable from these data)."""
        lines = []
        for name, value, unit in (("youngs_modulus", self.youngs_modulus_, "Pa"),
                                  ("poisson_ratio", self.poisson_ratio_, "")):
            if name in self.fixed_:
                lines.append(f"  {name:<16} {value:.4g} fixed (the start's: a force curve "
                             "alone cannot separate it from Young's modulus)")
            elif name in self.unidentifiable_:
                lines.append(f"  {name:<16} not identifiable from these data (kept at "
                             f"{value:.4g} {unit}; no word is given for it)".rstrip())
            else:
                half = self.interval(name)
                half = np.nan if half is None else half
                lines.append(f"  {name:<16} {value:.4g} ± {half:.2g} {unit}".rstrip())
        return lines

    def summary(self) -> str:
        """A few lines a person reads: the values, what was not identifiable, the errors."""
        lines = self.value_lines()
        if self.marker_rms_ is not None and self.noise_estimated_:
            lines.append(f"  markers: RMS {self.marker_rms_ * 1e6:.1f} µm per marker; the noise, "
                         f"estimated from these residuals, {self.marker_noise_ * 1e6:.1f} µm per "
                         "coordinate (a model error would look like noise here: compare "
                         "with the scanner's, or run diagnose)")
        elif self.marker_rms_ is not None:
            lines.append(f"  markers: RMS {self.marker_rms_ * 1e6:.1f} µm per marker, "
                         f"{self.marker_rms_ / self.marker_scale:.2f}x the noise "
                         f"({self.marker_noise_ * 1e6:.1f} µm per coordinate)")
        if self.force_rms_ is not None:
            lines.append(f"  load cell: RMS {self.force_rms_:.4g} N (noise estimate "
                         f"{self.force_noise_:.3g} N)")
        if self.validation_ and self.marker_rms_ is not None:
            v = self.validation_
            lines.append(f"  held-out steps {v['steps']}: markers RMS "
                         f"{v['rms_error'] * 1e6:.1f} µm per marker "
                         f"({v['rms_error'] / self.marker_scale:.2f}x the noise)")
        elif self.validation_:
            v = self.validation_
            lines.append(f"  held-out steps {v['steps']}: load cell RMS "
                         f"{v['force_error']:.4g} N")
        lines.append(f"  95 % intervals hold {self.intervals_hold}")
        if self.mesh_check_ is not None:
            lines.append("  extrapolated to a mesh fine enough (the error halving with the "
                         "cells' size): " + ", ".join(
                             f"{name} {value['extrapolated']:.4g}"
                             for name, value in self.mesh_check_.values.items()))
        return "\n".join(lines + [f"  note: {note}" for note in self.notes_])
