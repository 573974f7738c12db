"""Material values and words per region of a model (:func:`materials`): the physics of the
values is :mod:`neurofuzzy.constants` (whichever term carries the material,
:func:`~neurofuzzy.constants.quantities`), the words the rule base's (used through its
methods)."""

from __future__ import annotations

from ..constants import quantities, region_quantities
from ..model import Model

__all__ = ["materials", "material_values", "LOCKED_POISSON_RATIO", "DENSITY_NOT_LEARNED"]

#: what ``materials`` reports of a region (the terms may say more; all of it gets words)
_REPORTED = ("youngs_modulus", "poisson_ratio", "viscosity", "density")

#: why a spring network's ν gets no word (its 1/4 would read "compressible" whatever the
#: expert said)
LOCKED_POISSON_RATIO = ("locked at 1/4 by the spring network whatever the words say; neither "
                        "learned nor described (tetrahedral elements learn it)")

#: why a fitted model's density is no finding of the fit when the masses were not learned
#: (``fit --json``'s materials and the report say it beside the value and its word)
DENSITY_NOT_LEARNED = ("not learned: the node masses the fit started from (the experiment's "
                       "when it gives them, else the words'), read as a density")


def materials(model: Model, rules=None, tissue: str | None = None) -> dict:
    """The material values every region of ``model`` stands for, with words.

    Returns ``{region: {"youngs_modulus": Pa, "poisson_ratio": ..., "viscosity": Pa·s,
    "density": kg/m³, "tissue": str or None, "labels": {quantity: word}}}`` (the form of
    ``fit --json``'s ``"materials"``). For spring models, E, η and ρ are what the spring
    constants, viscosities and masses correspond to (:mod:`neurofuzzy.constants.springs`) and
    ν is the 1/4 the springs are locked to; for element models they are the elements' own
    values (medians over the region), with their relaxation and stiffening where they have
    them. ``labels`` (with ``rules``) are the rule base's words for each quantity but a spring
    network's locked ν, which ``notes`` explains (:data:`LOCKED_POISSON_RATIO`) instead of
    calling incompressible tissue "compressible".
    """
    out = {}
    for index, region in enumerate(model.region_names):
        found = region_quantities(model, index)
        if found is None:
            continue
        values = {key: value for key, value in found.items()
                  if key in _REPORTED or model.elements is not None}
        values["tissue"] = model.region_tissues[index] or tissue
        if rules is not None:
            values["labels"] = {rules.outputs[name].quantity: label.term
                                for name, label in rules.describe(_by_output(rules, found))
                                .items()}
            if model.elements is None:
                values["labels"].pop("poisson_ratio", None)
                values["notes"] = {"poisson_ratio": LOCKED_POISSON_RATIO}
        out[region] = values
    return out


def material_values(rules, model: Model, springs=None, nodes=None, elements=None) -> dict:
    """The material quantities a model's parameters stand for, per output variable of
    ``rules``.

    Spring models: medians over the given springs and nodes (default all; springs with both
    ends fixed are left out, their values are never learned); Poisson's ratio is the 1/4 a
    spring network is locked to. Element models: the elements' own E, ν, η (medians over
    ``elements``, default all) and the density of their lumped masses.
    """
    return _by_output(rules, quantities(model, springs=springs, nodes=nodes,
                                        elements=elements))


def _by_output(rules, by_quantity: dict) -> dict:
    return {name: by_quantity[variable.quantity] for name, variable in rules.outputs.items()
            if variable.quantity in by_quantity}
