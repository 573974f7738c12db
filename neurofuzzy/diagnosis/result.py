"""What a diagnosis answers: the :class:`Diagnosis`, its :class:`Finding` s, where a found
effect acts (:func:`where`) and how much of a misfit the mesh explains (:func:`mesh_share`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..forces import tetrahedron_geometry
from ..formatting import json_safe
from ..model import Model
from .localise import Localisation

__all__ = ["Diagnosis", "Finding", "where", "mesh_share"]


@dataclass
class Finding:
    """An effect the diagnosis added to the model.

    ``springs`` or ``elements`` and ``nodes`` say where a located effect acts (an inclusion:
    its springs or elements and their nodes; a load: its node), ``centroid`` its centre at
    rest (metres; None for global effects).
    """

    name: str
    confidence: float
    parameters: dict
    springs: list
    nodes: list
    rms_before: float
    rms_after: float
    gap_before: float
    gap_after: float
    runner_up: str
    candidates: list
    elements: list = field(default_factory=list)
    centroid: list | None = None

    def to_dict(self) -> dict:
        out = {"name": self.name, "confidence": self.confidence, "parameters": self.parameters,
               "rms_before": self.rms_before, "rms_after": self.rms_after,
               "gap_before": self.gap_before, "gap_after": self.gap_after,
               "runner_up": self.runner_up}
        for key in ("springs", "elements", "nodes"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        if self.centroid is not None:
            out["centroid"] = self.centroid
        return out


@dataclass
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    effects : list of Finding
        Effects found, in the order found (empty when the answer is ``none``).
    model_ : Model
        The final model, with the effects, refitted.
    rms_before, rms_after : float
        RMS trajectory error of the fitted model without and with the effects.
    noise_rms : float
        RMS error that marker noise alone explains.
    candidates : list of Candidate
        The ranked candidates of the last round (the one that answered ``none``, or the last
        effect's round).
    rounds : list of dict
        Per round: the residuals, ranked candidates, and the RMS before and after.
    localisation : Localisation or None
        With a prior and an inclusion found: the inclusion located element by element (or
        spring by spring) by a fit with the rule base as a prior (:mod:`.localise`).
    lack_of_fit : LackOfFit or None
        The final model's RMS error against the marker noise, with its verdict.
    mesh : dict or None
        When the final model still misses the data: the same model's fit on its mesh refined
        once, by one Gauss–Newton step from the fitted values (``nodes``, ``elements``,
        ``rms``, ``ratio`` to the noise, the share of the misfit above the noise it
        ``explains``, and ``how``).
    provisional : str or None
        Why the answer is provisional (the diagnosis ran out of ``max_time`` with work left:
        what it did not do); None for a complete diagnosis.
    window : dict or None
        A long recording diagnosed on its first frames (:mod:`.window`): ``frames`` of
        ``of``, the window's ``rms_before`` and ``rms_after``, and whether its answer
        ``held`` on all frames (None: not fitted there for want of time) and, when it did not,
        whether the whole recording was ``rediagnosed``. The findings, :attr:`rms_before`
        and :attr:`mesh` are then the window's; :attr:`model_`, :attr:`rms_after`,
        :attr:`noise_rms` and :attr:`lack_of_fit` all the frames' (everything is, once
        ``rediagnosed``). None: all frames.
    """

    effects: list
    model_: Model
    rms_before: float
    rms_after: float
    noise_rms: float
    candidates: list
    rounds: list
    localisation: Localisation | None = None
    lack_of_fit: object = None
    mesh: dict | None = None
    provisional: str | None = None
    window: dict | None = None

    @property
    def unexplained(self) -> bool:
        """Does the final model stay above the noise (:data:`EXPLAINED` times)?"""
        return self.lack_of_fit is not None and not self.lack_of_fit.explained

    @property
    def names(self) -> list[str]:
        """The effects found, or ``["none"]`` when the model explains the data to the noise
        as it is, or ``["unexplained"]`` when it does not and nothing in the catalogue
        helps."""
        found = [finding.name for finding in self.effects]
        return found or (["unexplained"] if self.unexplained else ["none"])

    @property
    def verdict(self) -> str:
        """The answer in words, with the lack of fit of the final model."""
        head = f"provisional ({self.provisional}): " if self.provisional else ""
        return head + self._verdict() + self._window_words()

    def _window_words(self) -> str:
        if self.window is None:
            return ""
        first, total = self.window["frames"], self.window["of"]
        if self.window["rediagnosed"]:
            return (f" (the first {first} frames' answer did not hold on all {total}: all "
                    "diagnosed)")
        return f" (diagnosed on the first {first} of {total} frames" + {
            True: ", the answer fitted on all of them)", None: ")",
            False: "; that answer does not hold on all of them)"}[self.window["held"]]

    def _verdict(self) -> str:
        if self.lack_of_fit is None:
            return ", ".join(self.names)
        found = ", ".join(f.name for f in self.effects)
        if not self.unexplained:
            head = (f"found {found}; " if found else "nothing missing: ")
            return head + self.lack_of_fit.verdict
        text = (f"found {found}, but the misfit is not all explained: " if found else
                "unexplained misfit: nothing in the catalogue explains it; ")
        text += self.lack_of_fit.verdict.replace("; run `neurofuzzy diagnose`", "")
        if self.mesh is not None:
            text += (f". Refined once ({self.mesh['elements']} elements), a step of the same "
                     f"model's fit reaches {self.mesh['ratio']:.2f}x the noise: the mesh explains "
                     f"{self.mesh['explains']:.0%} of the misfit"
                     + (" (a finer mesh is what the model needs)"
                        if self.mesh["explains"] >= 0.5 else ""))
        return text

    def to_dict(self) -> dict:
        """JSON-ready summary (non-finite numbers become None)."""
        return json_safe({
            "effects": [f.to_dict() for f in self.effects], "answer": self.names,
            "rms_before": self.rms_before, "rms_after": self.rms_after,
            "noise_rms": self.noise_rms, "verdict": self.verdict,
            "lack_of_fit": self.lack_of_fit.to_dict() if self.lack_of_fit else None,
            "mesh": self.mesh, "provisional": self.provisional, "window": self.window,
            "candidates": [c.to_dict() for c in self.candidates],
            "rounds": [{"candidates": [c.to_dict() for c in r["candidates"]], "rms": r["rms"],
                        "winner": r["winner"]} for r in self.rounds],
            "localisation": self.localisation.to_dict() if self.localisation else None})


def mesh_share(model, experiments, verdict) -> dict | None:
    """How much of a misfit the mesh explains: the model's fit on its mesh refined once, by
    one Gauss–Newton step from the fitted values
    (:func:`~neurofuzzy.learn.mesh_check.linearised_mesh_check`; the whole refit cost 5 to
    10 times as much and said the same to a few per cent of the RMS)."""
    from ..errors import InputError
    from ..learn import Parameterization
    from ..learn.mesh_check import linearised_mesh_check
    from ..learn.steps import fits_offsets

    # the parameters and marker offsets of the diagnosis's fits (the learner's defaults)
    parameters = Parameterization(model, learn_effects=True)
    try:
        check = linearised_mesh_check(model, experiments, parameters, parameters.initial(),
                                      offsets=fits_offsets("auto", experiments))
    except InputError:
        return None
    if check is None:
        return None
    ratio = check.rms_refined / verdict.noise if verdict.noise > 0 else float("inf")
    excess = max(verdict.ratio**2 - 1.0, 1e-300)
    return {"nodes": check.nodes[1], "elements": check.elements[1],
            "rms": check.rms_refined, "ratio": ratio, "how": check.how,
            "explains": float(np.clip(1.0 - max(ratio**2 - 1.0, 0.0) / excess, 0.0, 1.0))}


def where(model, effect) -> tuple[list[int], list[float] | None]:
    """The nodes a located effect acts on and their centre at rest (metres): an inclusion's
    springs' or elements' nodes, a load's node; ``([], None)`` for a global effect."""
    if len(effect.elements):
        geometry = tetrahedron_geometry(model.mesh)
        corners = model.mesh.rest_positions[geometry.nodes[effect.elements]]
        volume = geometry.volume[effect.elements]
        centre = (corners.mean(axis=1) * volume[:, None]).sum(axis=0) / volume.sum()
        return np.unique(geometry.nodes[effect.elements]).tolist(), centre.tolist()
    if len(effect.springs):
        nodes = np.unique(model.mesh.springs[effect.springs])
    else:
        nodes = effect.nodes
    if not len(nodes):
        return [], None
    return [int(n) for n in nodes], model.mesh.rest_positions[nodes].mean(axis=0).tolist()
