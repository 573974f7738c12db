"""An inclusion located item by item: after the diagnosis names a stiff or soft inclusion (a
block of elements, or springs), every element (or spring) of the start model is fitted with
the rule base as a prior (:mod:`neurofuzzy.learn.prior`) and the **regions found**
(:mod:`neurofuzzy.learn.regions`) say, in the expert's words, where the tissue differs from its
description: a second, finer localisation beside the diagnosis's own block, and a check of it
(``overlap``: the share of the diagnosis's inclusion inside the regions found).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..learn import GradientLearner
from ..learn.regions import describe_regions, regions_found

__all__ = ["Localisation", "localise", "INCLUSIONS"]

#: The diagnosis's effects that the regions found can localise.
INCLUSIONS = ("stiff_inclusion", "soft_inclusion")


@dataclass
class Localisation:
    """Result of :func:`localise`.

    Attributes
    ----------
    regions : list of dict
        The regions found (:func:`~neurofuzzy.learn.regions.regions_found`).
    rest : dict
        The rest of the tissue, per region and quantity: median value and word.
    words : str
        Both in words (:func:`~neurofuzzy.learn.regions.describe_regions`).
    learner : GradientLearner
        The per-item fit with the prior (``model_``, ``prior``, ``prior_``).
    overlap : list of float
        Per inclusion the diagnosis found (in its order): the share of its elements (springs)
        that lie in a region found.
    """

    regions: list
    rest: dict
    words: str
    learner: GradientLearner
    overlap: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"regions_found": self.regions, "regions_rest": self.rest, "words": self.words,
                "overlap": self.overlap, "prior": self.learner.prior_,
                "rms_error": self.learner.rms_error_}


def localise(model, experiments, prior, *, findings=(), substeps="auto",
             progress: bool = False) -> Localisation:
    """Fit every element (or spring) of ``model`` (its effects left out) with ``prior`` and
    group where the fit leaves the description into regions found.

    Parameters
    ----------
    model : Model
        The diagnosis's start model (regions and tissues as the prior knows them).
    experiments : sequence of Experiment
    prior : FuzzyPrior
        The rule base as a prior (its weight ``"auto"`` or given).
    findings : sequence of Finding
        The diagnosis's inclusions, to report how much of each the regions found cover.
    substeps : int or "auto"
    progress : bool
        Progress of the fit on stderr.
    """
    start = model.replace(effects=()).tied("none")
    learner = GradientLearner(substeps=substeps, prior=prior, progress=progress)
    learner.fit(start, experiments)
    found = learner.regions_ or regions_found(learner.model_, prior)
    kind = "elements" if learner.model_.elements is not None else "springs"
    covered = [i for entry in found["regions"] for i in entry[kind]]
    overlap = [float(np.isin(getattr(finding, kind), covered).mean())
               if len(getattr(finding, kind)) else 0.0 for finding in findings]
    return Localisation(regions=found["regions"], rest=found["rest"],
                        words=describe_regions(found), overlap=overlap, learner=learner)
