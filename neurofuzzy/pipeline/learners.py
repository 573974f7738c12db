"""The choices of one fit as ``neurofuzzy fit`` makes them: the rule base as a prior
(:func:`make_prior`; the learner is :meth:`.options.FitOptions.learner`'s), and what it
reports: the summary of ``--json`` (:func:`fit_summary`) and the fit record a model file keeps
(:func:`fit_record`). Used by :func:`~neurofuzzy.pipeline.fit` (so by the command and by
every specimen of ``fit-many``); the start comes from :func:`~.start.start_model`.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..learn import Learner

__all__ = ["make_prior", "fit_summary", "fit_record"]


def make_prior(start, prior="default", *, tie: str | None = None, method: str = "gradient"):
    """The prior of ``neurofuzzy fit --prior PRIOR``
    (a :class:`~neurofuzzy.learn.prior.FuzzyPrior` or None).

    ``"default"`` is ``"auto"`` for a fit of every spring or element (``tie="none"``) of a
    start with a rule base (``start.rules``), else off; ``"off"``; ``"auto"`` (weight by the
    discrepancy principle) or a weight ``α`` need the rule base. A
    :class:`~neurofuzzy.learn.prior.FuzzyPrior` already made (the diagnosis's, of the rule
    base it was given) is used as it is.
    """
    from ..errors import InputError
    from ..learn.prior import FuzzyPrior, parse_prior

    if isinstance(prior, FuzzyPrior):
        if method != "gradient":
            raise InputError("the paper's learner takes no prior; use the gradient method or "
                             "--prior off", key="prior")
        return prior
    if prior == "default":
        prior = ("auto" if start.rules is not None and tie == "none" and method == "gradient"
                 else "off")
    prior = parse_prior(prior)
    if prior == "off":
        return None
    if start.rules is None:
        raise InputError("a prior needs a rule base (--rules R --tissue T)", key="prior")
    return FuzzyPrior(start.rules, start.model, tissue=start.tissue, weight=prior)


def fit_summary(learner: Learner, start, *, method: str, tie: str,
                experiments: Sequence[str]) -> dict:
    """The JSON object of ``neurofuzzy fit --json`` for a fitted ``learner``.

    ``learner.to_dict()`` plus ``method``, ``tie``, ``start`` (where the start came from),
    ``experiments`` (the files), ``rules`` (the rule file read, with its checksum:
    :meth:`~neurofuzzy.rules.RuleBase.provenance`) when the fit had a rule base and, when the
    start has a rule base or tissues, ``materials``
    (per region E, ν, η, ρ and words; :func:`~neurofuzzy.tissues.materials`), and after a
    fit with a prior ``regions_found`` (:func:`~neurofuzzy.learn.regions.regions_found`),
    ``regions_rest``, ``regions_rejected``, ``regions_power`` (the region test's power on
    these data: :func:`~neurofuzzy.learn.power.detection_limit`) and
    ``regions_found_words``.

    Parameters
    ----------
    learner : Learner
        Fitted.
    start : StartModel
        The start of the fit (:func:`~.start.start_model`).
    method, tie : str
        As given to the fit (``tie`` "model" when the start model's own tying was kept).
    experiments : sequence of str
        The experiment files, for the record.
    """
    result = learner.to_dict()
    result.update(method=method, tie=tie, start=start.to_dict(),
                  experiments=[str(p) for p in experiments])
    if start.rules is not None:
        result["rules"] = start.rules.provenance()
    if learner.model_.elements is not None:
        result["material_law"] = learner.model_.elements.law_names()
    if start.rules is not None or any(start.model.region_tissues):
        from ..tissues import materials
        from ..tissues.values import DENSITY_NOT_LEARNED

        result["materials"] = materials(learner.model_, start.rules, start.tissue)
        if not learner.learn_masses:
            for values in result["materials"].values():   # ρ is the masses', not a finding
                values.setdefault("notes", {})["density"] = DENSITY_NOT_LEARNED
    if getattr(learner, "prior", None) is not None:
        from ..learn.regions import describe_regions, regions_found

        found = learner.regions_ or regions_found(learner.model_, learner.prior)
        result.update(regions_found=found["regions"], regions_rest=found["rest"],
                      regions_rejected=found.get("rejected", []),
                      regions_power=found.get("power"),
                      regions_found_words=describe_regions(found))
    return result


def fit_record(learner: Learner, experiments: Sequence[str], rules=None) -> dict:
    """What a fitted model file keeps of its fit (its ``fit:`` section,
    :func:`~neurofuzzy.io.models.save_model`): the toolkit version, the experiments, the RMS
    error and the lack of fit with its verdict, and the rule file read with its checksum
    (``rules``, when the fit had a rule base)."""
    from ..version import __version__

    record = {"neurofuzzy_version": __version__, "learner": type(learner).__name__,
              "experiments": [str(p) for p in experiments],
              "lack_of_fit": learner.lack_of_fit_.to_dict()}
    if rules is not None:
        record["rules"] = rules.provenance()
    return record
