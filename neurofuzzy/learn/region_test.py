"""Regions the data support: a region found is kept only if it explains the data better than
the homogeneous model does, by more than model error can.

A fit of every element (or spring) with the rule base as a prior (:mod:`.prior`) bends its
values wherever that lowers the misfit. When the homogeneous model (one E, ν and η per region)
stays above the marker noise because of what it misses (a coarse mesh, another
discretisation, an effect), the items bend to absorb that error too, and :func:`regions_found`
turns the bends into "regions" with words (seven of them, on scikit-fem data of a homogeneous
block fitted on 1 cm voxels). So every region found is tested (:func:`supported_regions`),
largest first: the homogeneous model of every region (fitted first, :func:`homogeneous_fit`),
with the regions kept so far and the region's items as one more tie group (its own E, ν and
η, or stiffness and viscosity), is refitted, and the region is kept only when that shrinks
the misfit above the noise at least ``MIN_SHRINK`` times (the diagnosis's rule for adding an
effect) and its likelihood ratio beats the Bayesian information criterion with the residual
of the model without it as the noise (the honest level: model error and marker noise
together). A smaller gain is what any extra freedom buys against model error. A refit that
Gauss–Newton predicts cannot reach that shrink is given up where it is (the learner's
``abandon_above``), since it would be rejected anyway: on scikit-fem data of the 7.5 mm
block with a 5× stiffer sphere, the nine rejected regions were all given up, the first four
(the largest) in 9 s instead of 28 s, and the kept one and every verdict stayed the same.

The prior's weight stays with the discrepancy principle against the marker noise: it is a
search for candidates, and the test decides. (Asking the item-by-item fit to explain the data
no better than the homogeneous model does, the other way to keep model error out, made the
prior so strong on the same data with a 5× stiffer sphere in it that the sphere was no longer
seen; with the test, the sphere is the one region kept, 3.2 mm from its true centre, and the
five others are rejected.)
"""

from __future__ import annotations

import numpy as np

from ..formatting import length_text

__all__ = ["homogeneous_start", "homogeneous_fit", "supported_regions", "MIN_SHRINK",
           "MAX_TESTED"]

#: A region must shrink the misfit above the noise at least this many times.
MIN_SHRINK = 1.5
#: Regions tested, largest first (a refit of a few parameters each).
MAX_TESTED = 10
#: a region's refit stops once the relative change of its cost is below this: its RMS is
#: read to three digits against a shrink of 1.5x (on the 5x-inclusion block, 4.9 s instead of
#: 7.8 s per region, the RMS the same to four digits)
REFIT_TOLERANCE = 1e-4


def homogeneous_start(model):
    """``model`` with one tie group per region (elements) or per spring group and region
    (springs), every group at the median of its items' values."""
    if model.elements is not None and model.springs is None:
        elements = model.elements
        return model.with_term(elements.replace(
            tie=elements.region, **_medians(elements, elements.region,
                                            ("youngs_modulus", "poisson_ratio", "viscosity"))))
    springs = model.tied("groups").springs
    return model.with_term(springs.replace(**_medians(springs, springs.tie,
                                                      ("stiffness", "damping"))))


def _medians(term, groups: np.ndarray, names) -> dict[str, np.ndarray]:
    """Every member's value of the fields ``names`` of ``term`` replaced by the median of its
    group's."""
    values = {}
    for name in names:
        per_item = np.array(getattr(term, name))
        for group in np.unique(groups):
            per_item[groups == group] = np.median(per_item[groups == group])
        values[name] = per_item
    return values


def homogeneous_fit(learner, model, experiments):
    """The homogeneous model of ``model`` (:func:`homogeneous_start`) fitted with
    ``learner``'s options (no prior, no mesh check)."""
    options = {**learner.get_params(), "prior": None, "mesh_check": False, "progress": False}
    return type(learner)(**options).fit(homogeneous_start(model), experiments)


def measured_count(experiments) -> int:
    """The measured values (three per marker and frame after the first) of ``experiments``."""
    return sum(3 * int(e.observation.seen[1:].sum()) for e in experiments)


def verdict(rms0: float, rms1: float, noise: float, count: int, extra: int):
    """``(shrink, bic, keep)`` of a region that takes the RMS per marker from ``rms0`` to
    ``rms1`` with ``extra`` parameters (module docstring): the misfit above the noise must
    shrink ``MIN_SHRINK`` times and the likelihood ratio beat the BIC."""
    gap0 = np.sqrt(max(rms0**2 - noise**2, 0.0))
    gap1 = np.sqrt(max(rms1**2 - noise**2, 0.0))
    shrink = gap0 / gap1 if gap1 > 0 else np.inf
    # likelihood ratio with the residual of the model without it as the variance
    bic = count * np.log(max(rms0, 1e-300) ** 2 / max(rms1, 1e-300) ** 2) \
        - extra * np.log(count)
    return shrink, float(bic), bool(shrink >= MIN_SHRINK and bic > 0)


def supported_regions(found: dict, homogeneous, experiments, *, progress=None) -> dict:
    """``found`` (:func:`~.regions.regions_found`) with every region tested (module
    docstring), largest first, each against the homogeneous fit with the regions kept so far
    (so two regions that describe one inclusion, say a harder E and a lower η over the same
    elements, do not both pass): the kept ones stay in ``"regions"``, the others move to
    ``"rejected"``; each carries ``"evidence"``: the RMS error per marker (m) without and
    with it, the shrink of the misfit above the noise, the BIC gain and whether the refit was
    given up once it could no longer reach ``MIN_SHRINK`` (its RMS is then where it stopped)."""
    current = homogeneous
    noise = homogeneous.lack_of_fit_.noise
    count = measured_count(experiments)
    options = {**homogeneous.get_params(), "progress": False}
    options["tolerance"] = max(options["tolerance"], REFIT_TOLERANCE)
    kept, rejected = [], []
    for index, region in enumerate(found["regions"]):
        if index >= MAX_TESTED:
            region["evidence"] = {"tested": False}
            rejected.append(region)
            continue
        base = current.model_
        items = np.asarray(region.get("elements", region.get("springs")), dtype=int)
        term, extra = (base.elements, 3) if "elements" in region else (base.springs, 2)
        tie = term.tie.copy()
        tie[items] = tie.max() + 1
        model = base.with_term(term.replace(tie=tie))
        rms0 = current.rms_error_
        gap0 = np.sqrt(max(rms0**2 - noise**2, 0.0))
        # the RMS a kept region has to reach: once the refit cannot, it stops (rejected)
        needed = np.sqrt(noise**2 + (gap0 / MIN_SHRINK) ** 2)
        learner = type(homogeneous)(**{**options, "abandon_above": needed})
        refit = learner.fit(model, experiments)
        rms1 = refit.rms_error_
        shrink, bic, keep = verdict(rms0, rms1, noise, count, extra)
        given_up = bool(refit.abandoned_)
        region["evidence"] = {"tested": True, "rms_without": rms0, "rms_with": rms1,
                              "gap_shrink": shrink, "bic_gain": bic, "kept": keep,
                              "given_up": given_up}
        if progress is not None:
            progress(f"region {index + 1} ({region['label']} {region['quantity']}, "
                     f"{region['size']} items): RMS {length_text(rms0)} -> "
                     f"{length_text(rms1)} per marker, the misfit above the noise "
                     + ("vanishes" if np.isinf(shrink) else f"shrinks {shrink:.2g}x")
                     + f": {'kept' if keep else 'model error, not tissue'}"
                     + (f" (given up: it cannot come below {length_text(needed)})"
                        if given_up else ""))
        if keep:
            kept.append(region)
            current = refit
        else:
            rejected.append(region)
    return {**found, "regions": kept, "rejected": rejected}
