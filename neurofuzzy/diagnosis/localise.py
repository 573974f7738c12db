"""An inclusion located item by item: after the diagnosis names a stiff or soft inclusion (a
block of elements, or springs), every element (or spring) of the start model is fitted with
the rule base as a prior (:mod:`neurofuzzy.learn.prior`) and the **regions found**
(:mod:`neurofuzzy.learn.regions`) say, in the expert's words, where the tissue differs from its
description: a second, finer localisation beside the diagnosis's own block, and a check of it
(``overlap``: the share of the diagnosis's inclusion inside the regions found).

With the rule base as a prior the map comes first: once an inclusion is among the candidates
the diagnosis will refit, the map is made, and the region found that covers most of the
residual scan's ball gives the inclusion its sign and a second candidate (:func:`seeded`): a
lump that the map finds harder than its description is ranked and refitted as
``stiff_inclusion``, never soft, both as the scan's ball and as the region grown over the
map, and the better refit wins. A map that finds no region of other stiffness leaves no
inclusion to refit: the misfit that the candidate would absorb is not the tissue's (hidden
gravity on a coarse mesh leaves the mesh's own error, which a free inclusion fits a little).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import item_values
from ..effects import SoftInclusion, StiffInclusion
from ..learn.regions import describe_regions, regions_found
from .refits import fitted
from .scoring import INCLUSIONS

__all__ = ["Localisation", "localise", "seeded", "INCLUSIONS"]


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
        The fitted learner of the per-item fit with the prior (``model_``, ``prior``, ``prior_``).
    overlap : list of float
        Per inclusion the diagnosis found (in its order): the share of its elements (springs)
        that lie in a region found.
    """

    regions: list
    rest: dict
    words: str
    learner: object
    overlap: list = field(default_factory=list)

    def covering(self, findings) -> Localisation:
        """Itself with the share of each finding's elements (springs) that the regions found
        cover (``overlap``)."""
        kind = _kind(self.learner.model_)
        covered = [i for entry in self.regions for i in entry[kind]]
        self.overlap = [float(np.isin(getattr(f, kind), covered).mean())
                        if len(getattr(f, kind)) else 0.0 for f in findings]
        return self

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
    start = model.replace(effects=tuple(e for e in model.effects
                                        if e.name not in INCLUSIONS)).tied("none")
    learner = fitted(start, experiments, prior=prior, substeps=substeps, progress=progress)
    found = learner.regions_ or regions_found(learner.model_, prior)
    located = Localisation(regions=found["regions"], rest=found["rest"],
                           words=describe_regions(found), learner=learner)
    return located.covering(findings)


def _kind(model) -> str:
    return "elements" if model.elements is not None else "springs"


def _of_stiffness(region: dict) -> bool:
    """Does the region found stand for other stiffness (Young's modulus, alone or with the
    other quantities of the same items)?"""
    return "youngs_modulus" in [region["quantity"]] + [a["quantity"]
                                                       for a in region.get("also", [])]


def seeded(tried, located: Localisation, model, evidence) -> tuple[list, list[str]]:
    """The candidates to refit with every inclusion given the sign of the map ``located``
    and its region beside the scan's ball: the region found of other stiffness that covers
    most of the ball (the largest, when none does) says harder or softer, and both the ball
    and that region, so signed and rescored by ``evidence``, are refitted (the better refit
    wins, as between any candidates). An inclusion with no such region (or only regions of
    inclusions already found) is dropped. ``(candidates, what was done in words)``.

    Both, because neither wins everywhere: on the 5x sphere of
    ``tests/test_lack_of_fit_continuum.py`` (7.5 mm voxels) the ball of 107 elements holds
    all 40 of the sphere's, 2.5 mm off its centre, and its refit leaves 14.3 µm per marker;
    the map's region of 29 holds 15 of them, 3.2 mm off, and leaves 15.4 µm. On the block of
    ``tests/test_prior.py`` the region is the six stiff elements, of which the ball held two.
    """
    kind = _kind(model)
    taken = set(getattr(evidence, f"taken_{kind}"))
    regions = [r for r in located.regions if _of_stiffness(r) and not taken & set(r[kind])]
    values = item_values(located.learner.model_)[1]["youngs_modulus"]
    out, words = [], []
    for candidate in tried:
        if candidate.name not in INCLUSIONS:
            out.append(candidate)
            continue
        if not regions:
            words.append(f"{candidate.name} not refitted: the fit of every item with the "
                         "prior finds no region of other stiffness")
            continue
        ball = set(getattr(candidate, kind))
        region = max(regions, key=lambda r: (len(ball & set(r[kind])), r["size"]))
        items = set(region[kind])
        inside = np.zeros(len(values), bool)
        inside[region[kind]] = True
        # harder or softer than the rest (a region of every item: than the model fitted)
        rest = (values[~inside] if not inside.all()
                else item_values(model)[1]["youngs_modulus"])
        cls = (StiffInclusion if np.median(values[inside]) > np.median(rest)
               else SoftInclusion)
        both = [ball] + ([items] if items != ball else [])
        signed = evidence.score([_inclusion(cls, model, sorted(each), kind) for each in both])
        for entry in signed:
            entry.seeded = True
        out.extend(signed)
        words.append(f"{cls.name}, as the map's {region['label']} region of "
                     f"{region['size']} {kind} says; it is refitted beside the scan's ball "
                     f"of {len(ball)} ({len(ball & items)} in both)")
    return out, words


def _inclusion(cls, model, items, kind):
    if kind == "elements":
        return cls.of_elements(model, items)
    return cls.for_model(model, [0.0], springs=items)
