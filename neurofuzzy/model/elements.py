"""The tetrahedral elements' fields of a :class:`~neurofuzzy.model.SpringMassModel`, checked:
every per-element array of the right shape and within physics, with messages that name the
element, its region and tissue."""

from __future__ import annotations

import numpy as np

from ..errors import InputError, closest_name
from ..forces.laws import law_numbers, stiffening_array
from ..forces.relaxation import relaxation_arrays
from .values import vector

__all__ = ["VOLUMETRIC", "element_values"]

#: How tetrahedral elements form their volumetric stress (:mod:`neurofuzzy.forces.tetrahedra`).
VOLUMETRIC: tuple[str, ...] = ("nodal", "element")


def element_values(model) -> dict:
    """The element fields of ``model`` checked and as arrays (per element: E, ν, η, region,
    tie group, law, Yeoh constant, Prony terms), or ``{}`` for a model without elements.

    Raises
    ------
    InputError
        A field is missing, has the wrong shape or an impossible value; the message names the
        first bad element, its region and tissue.
    """
    keys = ("element_youngs_modulus", "element_poisson_ratio", "element_viscosity")
    given = [getattr(model, key) is not None for key in keys]
    if not any(given):
        return {}
    if not all(given):
        raise InputError("give all three of element_youngs_modulus, element_poisson_ratio "
                         "and element_viscosity, or none", key="element_youngs_modulus")
    n = model.mesh.n_tetrahedra
    if n == 0:
        raise InputError("element parameters need a mesh with tetrahedra",
                         key="element_youngs_modulus")
    out = {key: vector(getattr(model, key), n, key, "n_tetrahedra") for key in keys}
    region = (np.zeros(n, np.intp) if model.element_region is None
              else np.asarray(model.element_region))
    if region.shape != (n,) or not np.issubdtype(region.dtype, np.integer) or (
            region.min() < 0 or region.max() >= len(model.region_names)):
        raise InputError(f"expected ({n},) integers in 0..{len(model.region_names) - 1}, "
                         "one region index per element", key="element_region")
    out["element_region"] = region.astype(np.intp)
    tie = region if model.element_tie is None else np.asarray(model.element_tie)
    if tie.shape != (n,) or not np.issubdtype(tie.dtype, np.integer):
        raise InputError(f"expected ({n},) integers, one tie group per element",
                         key="element_tie")
    out["element_tie"] = np.unique(tie, return_inverse=True)[1].astype(np.intp)
    out["element_law"] = law_numbers(model.element_law, n)
    out["element_stiffening"] = stiffening_array(model.element_stiffening, n)
    out["element_relaxation_moduli"], out["element_relaxation_times"] = relaxation_arrays(
        model.element_relaxation_moduli, model.element_relaxation_times, n)
    if model.element_volumetric not in VOLUMETRIC:
        hint = closest_name(str(model.element_volumetric), VOLUMETRIC)
        raise InputError(f"got {model.element_volumetric!r}; expected one of "
                         f"{list(VOLUMETRIC)}" + (f" (did you mean {hint!r}?)" if hint
                                                  else ""), key="element_volumetric")
    nu = out["element_poisson_ratio"]
    for key, bad, rule in (
            ("element_youngs_modulus", out["element_youngs_modulus"] <= 0,
             "Young's modulus {:g} Pa; it must be positive (Pa)"),
            ("element_poisson_ratio", (nu <= 0) | (nu >= 0.5),
             "Poisson's ratio {:g}; it must lie in (0, 0.5), strictly: 0.5 is a "
             "perfectly incompressible solid, which elements cannot represent"),
            ("element_viscosity", out["element_viscosity"] < 0,
             "viscosity {:g} Pa s; it must not be negative (Pa s)")):
        if np.any(bad):
            first = int(np.flatnonzero(bad)[0])
            more = f" ({int(bad.sum())} elements in all)" if bad.sum() > 1 else ""
            raise InputError(f"element {first}{_where(model, out['element_region'][first])}"
                             " has " + rule.format(out[key][first]) + more, key=key)
    return out


def _where(model, region: int) -> str:
    """" (region 'tumour', tissue 'tumour')" for messages; "" for a one-region model."""
    names = tuple(str(name) for name in model.region_names)
    tissues = tuple(model.region_tissues or (None,) * len(names))
    if len(names) == 1 and tissues[0] is None:
        return ""
    tissue = tissues[region] if region < len(tissues) else None
    return f" (region {names[region]!r}" + (f", tissue {tissue!r})" if tissue else ")")
