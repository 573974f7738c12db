"""The flat fields of models before terms, deprecated: ``Model(mesh, node_mass=…,
spring_stiffness=…, element_youngs_modulus=…, effects=…)``, ``model.spring_stiffness`` and
``model.replace(element_law=…)`` still work, with a :class:`DeprecationWarning` that names
the spelling to use (``Model(mesh, node_mass, (Springs(stiffness=…), …))``,
``model.springs.stiffness``, ``model.with_elements(law=…)``), read into and out of the model's
:class:`~neurofuzzy.forces.Springs` and :class:`~neurofuzzy.forces.Tetrahedra` terms.

A model without springs (an element model) reads as one whose springs have no stiffness and no
damping; a model without elements has no element fields (None).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import InputError
from ..forces import Springs, Tetrahedra

__all__ = ["FLAT", "DERIVED", "terms_from_fields", "terms_with_fields", "flat_value",
           "deprecated"]

#: flat field → (the term's kind, its field)
FLAT = {
    **{f"spring_{name}": ("springs", name)
       for name in ("stiffness", "damping", "rest_length", "tie", "region")},
    **{f"element_{name}": ("elements", name)
       for name in ("youngs_modulus", "poisson_ratio", "viscosity", "tie", "region",
                    "volumetric", "law", "stiffening", "relaxation_moduli",
                    "relaxation_times")},
}
#: the spelling of each derived value with terms
_DERIVED_NOW = {"has_elements": "model.elements is not None", "n_ties": "model.springs.n_ties",
                "n_element_ties": "model.elements.n_ties",
                "element_stiffens": "model.elements.stiffens",
                "law_names": "model.elements.law_names()"}
#: what models before terms computed from those fields: name → its value on a model
DERIVED = {
    "has_elements": lambda model: model.elements is not None,
    "n_ties": lambda model: 0 if model.springs is None else model.springs.n_ties,
    "n_element_ties": lambda model: 0 if model.elements is None else model.elements.n_ties,
    "element_stiffens": lambda model: (np.zeros(0, bool) if model.elements is None
                                       else model.elements.stiffens),
    "law_names": lambda model: model.elements.law_names,
}
#: the element fields without which there are no elements
_ELEMENT_VALUES = ("element_youngs_modulus", "element_poisson_ratio", "element_viscosity")


def terms_from_fields(mesh, terms: tuple, fields: dict) -> tuple:
    """``terms`` with the springs, elements and effects the flat ``fields`` describe.

    Springs without stiffness and damping beside elements (how element models were written)
    are no term: they exert no force.
    """
    fields = dict(fields)
    effects = tuple(fields.pop("effects", ()) or ())
    unknown = sorted(set(fields) - set(FLAT))
    if unknown:
        raise TypeError(f"Model() got unexpected keyword argument(s) {unknown}")
    if fields:
        deprecated(f"Model({', '.join(f'{key}=' for key in fields)}...)",
                   "give terms: Model(mesh, node_mass, (Springs(stiffness=..., damping=...), "
                   "Tetrahedra(youngs_modulus=..., ...), *effects))")
    by_kind = _by_kind(fields)
    elements = _elements(by_kind["elements"])
    springs = by_kind["springs"]
    if springs:
        if "stiffness" not in springs or "damping" not in springs:
            missing = "spring_stiffness" if "stiffness" not in springs else "spring_damping"
            raise InputError("give both spring_stiffness and spring_damping", key=missing)
        idle = not np.any(springs["stiffness"]) and not np.any(springs["damping"])
        if not (idle and elements is not None):
            terms = terms + (Springs(**springs),)
    if elements is not None:
        terms = terms + (elements,)
    return terms + effects


def terms_with_fields(model, fields: dict) -> tuple:
    """``model``'s terms with the flat ``fields`` changed (a term created when the model had
    none of its kind)."""
    deprecated(f"model.replace({', '.join(f'{key}=' for key in fields)}...)",
               "use model.with_springs(...) or model.with_elements(...) (the terms' own "
               "field names: stiffness, youngs_modulus, law ...)")
    cleared = [key for key in _ELEMENT_VALUES if key in fields and fields[key] is None]
    if cleared:
        if len(cleared) < len(_ELEMENT_VALUES):
            raise InputError("give all three of element_youngs_modulus, element_poisson_ratio "
                             "and element_viscosity, or none", key=cleared[0])
        return tuple(term for term in model.terms if not isinstance(term, Tetrahedra))
    by_kind = _by_kind(fields)
    terms = list(model.terms)
    for kind, cls in (("springs", Springs), ("elements", Tetrahedra)):
        if not by_kind[kind]:
            continue
        term = getattr(model, kind)
        if term is not None:
            terms[terms.index(term)] = term.replace(**by_kind[kind])
        elif kind == "springs":
            values = by_kind[kind]
            if np.any(values.get("stiffness", 0)) or np.any(values.get("damping", 0)):
                zero = np.zeros(model.n_springs)
                terms.append(Springs(**{"stiffness": zero, "damping": zero, **values}))
            # (the tie groups, regions or rest lengths of springs the model does not have,
            # or springs without stiffness and damping: no term)
        else:
            terms.append(_elements(by_kind[kind]))
    return tuple(terms)


def flat_value(model, name: str):
    """``model.<name>`` for a flat field: the term's value, or what a model without that term
    reads as; or a value :data:`DERIVED` from them."""
    if name in DERIVED:
        deprecated(f"model.{name}", f"use {_DERIVED_NOW[name]}")
        return DERIVED[name](model)
    kind, field = FLAT[name]
    deprecated(f"model.{name}", f"use model.{kind}.{field}")
    term = getattr(model, kind)
    if term is not None:
        return getattr(term, field)
    if kind == "elements":
        return "nodal" if field == "volumetric" else None
    n = model.n_springs
    absent = {"stiffness": np.zeros(n), "damping": np.zeros(n),
              "rest_length": model.mesh.rest_lengths, "tie": np.arange(n, dtype=np.intp),
              "region": np.zeros(n, np.intp)}[field]
    absent.setflags(write=False)
    return absent


def _by_kind(fields: dict) -> dict:
    by_kind = {"springs": {}, "elements": {}}
    for key, value in fields.items():
        kind, field = FLAT[key]
        if value is not None or field in ("stiffness", "damping"):
            by_kind[kind][field] = value
    return by_kind


def _elements(values: dict):
    if not any(key.removeprefix("element_") in values for key in _ELEMENT_VALUES):
        return None                    # (a volumetric form or a law alone: no elements)
    # (Tetrahedra.bound names a missing E, ν or η)
    return Tetrahedra(**{"youngs_modulus": None, "poisson_ratio": None, "viscosity": None,
                         **values})


def deprecated(what: str, instead: str) -> None:
    """Warn that ``what`` is a flat field of models before terms (DeprecationWarning, pointing
    at the caller of the model's method)."""
    warnings.warn(f"{what}: a flat field of models before terms, deprecated; {instead}",
                  DeprecationWarning, stacklevel=4)
