"""Model files (YAML): every key checked (:data:`MODEL_KEYS`), errors with the file, the key
and the line; written atomically, read back exactly."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import yaml

from . import safe_yaml
from ..errors import InputError, closest_name
from ..forces.laws import LAWS
from ..mesh import Mesh
from ..forces import Springs, Tetrahedra, vector
from ..model import Model
from .safe_yaml import kind_of
from .writing import atomic_write

__all__ = ["load_model", "save_model", "model_to_dict", "model_from_dict", "check_model_dict",
           "load_fit_record", "MODEL_KEYS"]

MODEL_FORMAT = "neurofuzzy-model/1"
#: largest model file read (a 24,000-tetrahedron model is 4 MB and loads in 2 s)
MAX_MODEL_FILE_BYTES = 64 * 2**20


def model_to_dict(model: Model) -> dict:
    """Plain-Python (YAML/JSON-ready) description of a model; exact round trip."""
    from ..effects import effect_to_dict

    mesh = model.mesh
    data = {
        "format": MODEL_FORMAT,
        "nodes": {
            "rest_positions": mesh.rest_positions.tolist(),
            "mass": model.node_mass.tolist(),
            "fixed": mesh.fixed.tolist(),
            **({"driven": mesh.driven.tolist()} if mesh.driven.size else {}),
        },
        "springs": {"nodes": mesh.springs.tolist(), "group": mesh.spring_group.tolist(),
                    "group_names": list(mesh.group_names), **_springs_to_dict(model)},
        "effects": [effect_to_dict(effect) for effect in model.effects],
    }
    if len(model.region_names) > 1 or model.region_tissues[0] is not None:
        data["regions"] = {"names": list(model.region_names),
                           "tissues": list(model.region_tissues)}
        data["nodes"]["region"] = model.node_region.tolist()
        if model.springs is not None:
            data["springs"]["region"] = model.springs.region.tolist()
    if mesh.tetrahedra is not None:
        data["tetrahedra"] = mesh.tetrahedra.tolist()
    if model.elements is not None:
        data["elements"] = _elements_to_dict(model.elements)
    return data


def _springs_to_dict(model: Model) -> dict:
    springs = model.springs
    if springs is None:
        # a model without springs (elements): the mesh's springs exert no force
        none = [0.0] * model.n_springs
        return {"stiffness": none, "damping": none}
    return {"stiffness": springs.stiffness.tolist(), "damping": springs.damping.tolist(),
            "rest_length": springs.rest_length.tolist(), "tie": springs.tie.tolist()}


def _elements_to_dict(elements) -> dict:
    data = {"youngs_modulus": elements.youngs_modulus.tolist(),
            "poisson_ratio": elements.poisson_ratio.tolist(),
            "viscosity": elements.viscosity.tolist(), "tie": elements.tie.tolist(),
            "region": elements.region.tolist(), "volumetric": elements.volumetric}
    laws = [LAWS[number] for number in elements.law]
    if any(number != 0 for number in elements.law):
        # one word when every element has the same law, else one per element
        data["law"] = laws[0] if len(set(laws)) == 1 else laws
    if np.any(elements.stiffens):
        # Yeoh's C20/C10 per element (unused on the other laws' elements)
        data["stiffening"] = elements.stiffening.tolist()
    if elements.n_relaxation_terms:
        # Prony terms: one [g, ...] and one [τ, ...] row per element
        data["relaxation_moduli"] = elements.relaxation_moduli.tolist()
        data["relaxation_times"] = elements.relaxation_times.tolist()
    return data


#: the keys of a model file, per section: (required, optional)
MODEL_KEYS = {
    None: (("format", "nodes", "springs"), ("effects", "regions", "tetrahedra", "elements",
                                            "fit", "rules")),
    "nodes": (("rest_positions", "mass"), ("fixed", "region", "driven")),
    "springs": (("nodes", "stiffness", "damping"),
                ("group", "group_names", "rest_length", "tie", "region")),
    "regions": (("names",), ("tissues",)),
    "elements": ((), ("youngs_modulus", "poisson_ratio", "viscosity", "tie", "region",
                      "volumetric", "law", "relaxation_moduli", "relaxation_times",
                      "stiffening")),
}
#: keys whose value is a single word, not a list
_MODEL_SCALAR_KEYS = {("elements", "volumetric")}
#: where an array a model checks (its key) is in the file: (section, key)
_MODEL_FILE_KEY = {
    "rest_positions": ("nodes", "rest_positions"), "node_mass": ("nodes", "mass"),
    "fixed": ("nodes", "fixed"), "driven": ("nodes", "driven"),
    "node_region": ("nodes", "region"),
    "springs": ("springs", "nodes"), "spring_group": ("springs", "group"),
    "group_names": ("springs", "group_names"), "spring_stiffness": ("springs", "stiffness"),
    "spring_damping": ("springs", "damping"), "spring_rest_length": ("springs", "rest_length"),
    "spring_tie": ("springs", "tie"), "spring_region": ("springs", "region"),
    "tetrahedra": (None, "tetrahedra"), "region_names": ("regions", "names"),
    "region_tissues": ("regions", "tissues"), "effects": (None, "effects"),
    **{f"element_{key}": ("elements", key)
       for key in ("youngs_modulus", "poisson_ratio", "viscosity", "tie", "region",
                   "volumetric", "law", "relaxation_moduli", "relaxation_times",
                   "stiffening")},
}


def check_model_dict(data, source: str = "<model>") -> None:
    """Check the layout of a model file's content (sections, keys, lists) before it is used.

    Raises
    ------
    InputError
        Naming the file, the key (``springs.stiffness``) and, for files read by
        :func:`load_model`, its line.
    """
    if not isinstance(data, dict) or data.get("format") != MODEL_FORMAT:
        raise InputError(f"not a neurofuzzy model file (expected 'format: {MODEL_FORMAT}')",
                         source=source, line=_line_of(data, "format"))
    for section, (required, optional) in MODEL_KEYS.items():
        where = data if section is None else data.get(section)
        if where is None and section in ("regions", "elements"):
            continue
        if not isinstance(where, dict):
            keys = ", ".join(f"{k}:" for k in required + optional)
            raise InputError(f"expected a mapping ({keys}), got {kind_of(where)}",
                             source=source, key=section, line=_line_of(data, section))
        for key in where:
            if key not in required + optional:
                hint = closest_name(str(key), required + optional)
                raise InputError("unknown key" + (f"; did you mean {hint!r}?" if hint else
                                                  f"; known: {list(required + optional)}"),
                                 source=source, key=_dotted(section, key),
                                 line=_line_of(where, key))
        for key in required:
            if key not in where:
                raise InputError(f"missing key {key!r}", source=source,
                                 key=section, line=_line_of(data, section))
        for key, value in where.items():
            if section is None and (key in MODEL_KEYS or key == "format"):
                continue
            if section is None and key in ("fit", "rules"):
                if not isinstance(value, dict):
                    what = "the fit's record" if key == "fit" else "the rule file's path, sha256"
                    raise InputError(f"expected a mapping ({what}), got {kind_of(value)}",
                                     source=source, key=key,
                                     line=_line_of(where, key))
                continue
            if (section, key) == ("elements", "law") and isinstance(value, str):
                continue               # one law for every element, or a list of them
            if (section, key) in _MODEL_SCALAR_KEYS:
                if not isinstance(value, str):
                    raise InputError(f"expected a word, got {kind_of(value)}", source=source,
                                     key=_dotted(section, key), line=_line_of(where, key))
                continue
            if value is not None and not isinstance(value, list):
                raise InputError(f"expected a list, got {kind_of(value)}", source=source,
                                 key=_dotted(section, key), line=_line_of(where, key))


def _dotted(section, key) -> str:
    return str(key) if section is None else f"{section}.{key}"


def _line_of(mapping, key) -> int | None:
    """The line of ``key`` in a mapping read by :mod:`neurofuzzy.io.safe_yaml` (else None)."""
    line_of = getattr(mapping, "line_of", None)
    return line_of(key) if line_of is not None else None


def model_from_dict(data: dict, source: str = "<model>") -> Model:
    """Inverse of :func:`model_to_dict`."""
    check_model_dict(data, source)
    try:
        return _model_from_checked_dict(data, source)
    except InputError as error:
        section, key = _MODEL_FILE_KEY.get(error.key, (None, error.key))
        where = data if section is None else data.get(section, {})
        raise InputError(error.detail, source=source, key=_dotted(section, key),
                         line=_line_of(where, key)) from None
    except (TypeError, ValueError) as error:     # numpy on lists of the wrong shape or type
        raise InputError(f"a list holds values of the wrong type or shape ({error})",
                         source=source) from None


def _model_from_checked_dict(data: dict, source: str) -> Model:
    from ..effects import effect_from_dict

    try:
        nodes, springs = data["nodes"], data["springs"]
        mesh = Mesh(rest_positions=nodes["rest_positions"], springs=springs["nodes"],
                    spring_group=springs.get("group"),
                    group_names=tuple(springs.get("group_names", ())),
                    fixed=nodes.get("fixed", []), tetrahedra=data.get("tetrahedra"),
                    driven=nodes.get("driven", []))
        elements = _elements_from_dict(data)
        terms = [] if elements is None else [elements]
        for key in ("stiffness", "damping"):
            # checked even when the springs are idle beside elements: a file whose lists
            # disagree with its springs disagrees with itself
            vector(springs[key], mesh.n_springs, f"spring_{key}", "n_springs")
        if elements is None or np.any(springs["stiffness"]) or np.any(springs["damping"]):
            # (an element model's springs without stiffness and damping are no term)
            terms.insert(0, Springs(
                stiffness=springs["stiffness"], damping=springs["damping"],
                rest_length=springs.get("rest_length"),
                tie=np.asarray(springs["tie"]) if "tie" in springs else None,
                region=np.asarray(springs["region"]) if "region" in springs else None))
        terms += [effect_from_dict(e, source) for e in data.get("effects") or ()]
        return Model(mesh, nodes["mass"], terms, **_regions_from_dict(data, nodes, source))
    except KeyError as error:
        raise InputError(f"missing key {error.args[0]!r}", source=source) from None


def _elements_from_dict(data: dict) -> Tetrahedra | None:
    elements = data.get("elements")
    if elements is None:
        return None
    if not isinstance(elements, dict):
        raise InputError("expected youngs_modulus, poisson_ratio and viscosity lists",
                         key="elements")
    # (a missing E, ν or η: Tetrahedra.bound names it)
    # files written before the nodal volumetric form existed hold per-element elements
    return Tetrahedra(**{key: elements.get(key)
                         for key in ("youngs_modulus", "poisson_ratio", "viscosity", "tie",
                                     "region", "law", "relaxation_moduli", "relaxation_times",
                                     "stiffening")},
                      volumetric=elements.get("volumetric", "element"))


def _regions_from_dict(data: dict, nodes: dict, source: str) -> dict:
    regions = data.get("regions")
    if regions is None:
        return {}
    if not isinstance(regions, dict) or not isinstance(regions.get("names"), list):
        raise InputError("expected 'names: [...]' (and optionally 'tissues: [...]')",
                         source=source, key="regions")
    return {"region_names": tuple(regions["names"]), "region_tissues": regions.get("tissues"),
            "node_region": np.asarray(nodes.get("region", np.zeros(0, int)))}


def save_model(model: Model, path: str | os.PathLike, *,
               fit: dict | None = None, rules: dict | None = None) -> Path:
    """Write ``model`` as YAML (atomically); :func:`load_model` reads it back exactly.

    ``fit`` is the record of the fit that made the model (a JSON-ready mapping: the toolkit
    version, the lack of fit and its verdict, the rule file, …), kept as the file's ``fit:``
    section and read back by :func:`load_fit_record`; ``rules`` the rule file the start values
    came from (``neurofuzzy mesh``: :meth:`~neurofuzzy.rules.RuleBase.provenance`, its path and
    sha256), kept as the ``rules:`` section. The model itself depends on neither.
    """
    path = Path(path)
    data = model_to_dict(model)
    if fit is not None:
        data["fit"] = dict(fit)
    if rules is not None:
        data["rules"] = dict(rules)
    text = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    with atomic_write(path, "w") as handle:
        handle.write("# neurofuzzy model; load with neurofuzzy.io.load_model\n")
        handle.write(text)
    return path


def load_model(path: str | os.PathLike) -> Model:
    """Read a model written by :func:`save_model`.

    Raises
    ------
    InputError
        The file is missing, larger than :data:`MAX_MODEL_FILE_BYTES`, not YAML (see
        :mod:`neurofuzzy.io.safe_yaml`), not laid out as a model file, or holds impossible values;
        the message names the file, the key and the line.
    """
    return model_from_dict(safe_yaml.load(path, max_bytes=MAX_MODEL_FILE_BYTES,
                                          kind="model file"), str(path))


def load_fit_record(path: str | os.PathLike) -> dict | None:
    """The ``fit:`` section of a model file written by ``neurofuzzy fit --out`` (the toolkit
    version, the lack of fit and its verdict, …), or None when the file has none."""
    data = safe_yaml.load(path, max_bytes=MAX_MODEL_FILE_BYTES, kind="model file")
    check_model_dict(data, str(path))
    record = data.get("fit")
    return None if record is None else _plain(record)


def _plain(value):
    """A mapping read by :mod:`neurofuzzy.io.safe_yaml` as plain dicts and lists."""
    if isinstance(value, dict):
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_plain(item) for item in value]
    return value
