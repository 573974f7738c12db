"""Experiment files (``.npz``, the contract of DESIGN.md) and model files (YAML).

Every reader validates what it reads and raises :class:`~neurofuzzy.errors.InputError` naming
the file and the key. Every writer writes atomically (a temporary file in the target folder,
then a rename), so a failure never leaves a half-written file behind.
"""

from __future__ import annotations

import contextlib
import io as _io
import os
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import yaml

from .errors import InputError, closest_name
from .experiment import Experiment
from .mesh import Mesh
from .model import SpringMassModel

__all__ = ["load_experiment", "save_experiment", "load_model", "save_model", "atomic_write"]

REQUIRED_KEYS = ("rest_positions", "springs", "dt", "positions")
#: embedded markers (:class:`~neurofuzzy.observation.EmbeddedMarkers`): all or none
MARKER_KEYS = ("marker_positions", "marker_nodes", "marker_weights", "marker_names")
OPTIONAL_KEYS = ("fixed", "external_forces", "observed", "masses", "spring_groups",
                 "group_names", "tetrahedra", *MARKER_KEYS)
MODEL_FORMAT = "neurofuzzy-model/1"


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb"):
    """Open a temporary file beside ``path``; on success rename it onto ``path``.

    Use as ``with atomic_write(path) as handle: ...``. On an exception the temporary file is
    removed and ``path`` is left as it was.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)         # mkstemp makes 0600; outputs are ordinary files
    try:
        with os.fdopen(fd, mode) as handle:
            yield handle
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        raise


def load_experiment(path: str | os.PathLike) -> Experiment:
    """Read and validate an experiment file (see DESIGN.md, "Experiment file").

    Raises
    ------
    InputError
        The file is missing or unreadable, a required key is absent, a key is unknown, or a
        value has the wrong shape, type or range. The message names the file and the key.
    """
    source = str(path)
    try:
        with open(path, "rb") as handle:
            if handle.read(4) != b"PK\x03\x04":
                raise InputError("not a readable .npz experiment file (not a zip archive)",
                                 source=source)
        with np.load(path, allow_pickle=False) as archive:
            data = {key: archive[key] for key in archive.files}
    except FileNotFoundError:
        raise InputError("no such file", source=source) from None
    except IsADirectoryError:
        raise InputError("is a directory, not an experiment file", source=source) from None
    except (zipfile.BadZipFile, OSError, EOFError) as error:
        raise InputError(f"not a readable .npz experiment file ({error})",
                         source=source) from None
    except ValueError as error:  # object arrays need pickle, which we refuse
        raise InputError(f"holds arrays we will not unpickle ({error}); store plain numeric "
                         "arrays", source=source) from None

    known = REQUIRED_KEYS + OPTIONAL_KEYS
    for key in data:
        if key not in known and not key.startswith("true_"):
            hint = closest_name(key, known)
            raise InputError("unknown key" + (f"; did you mean {hint!r}?" if hint else
                                              f"; known keys are {list(known)} and true_*"),
                             source=source, key=key)
    for key in REQUIRED_KEYS:
        if key not in data:
            raise InputError(f"required key is missing (the file has {sorted(data)})",
                             source=source, key=key)

    def check(key, make):
        try:
            return make()
        except InputError as error:
            raise InputError(error.detail, source=source, key=error.key or key) from None

    group_names = ()
    if "group_names" in data:
        names = data["group_names"]
        if names.ndim != 1 or names.dtype.kind not in "US":
            raise InputError("expected a 1-D array of strings", source=source,
                             key="group_names")
        group_names = tuple(str(n) for n in names)
    for key in ("rest_positions", "springs", "fixed", "spring_groups", "tetrahedra"):
        if key in data and data[key].dtype.kind not in "iuf":
            raise InputError(f"expected numbers, got dtype {data[key].dtype}", source=source,
                             key=key)
    for key in ("springs", "tetrahedra"):
        if key in data and data[key].dtype.kind == "f":
            raise InputError(f"expected integer node indices, got dtype {data[key].dtype}",
                             source=source, key=key)
    mesh = check("springs", lambda: Mesh(rest_positions=data["rest_positions"],
                                         springs=data["springs"],
                                         spring_group=data.get("spring_groups"),
                                         group_names=group_names,
                                         fixed=data.get("fixed", np.zeros(0, dtype=np.intp)),
                                         tetrahedra=data.get("tetrahedra")))
    truth = {key: value for key, value in data.items() if key.startswith("true_")}
    markers = check("marker_positions", lambda: _markers(data))
    return Experiment(mesh=mesh, dt=data["dt"], positions=data["positions"],
                      external_forces=data.get("external_forces"),
                      observed=data.get("observed"), node_mass=data.get("masses"), truth=truth,
                      source=source, markers=markers)


def _markers(data: dict):
    """The embedded markers of an experiment file, or None."""
    from .observation import EmbeddedMarkers

    present = [key for key in MARKER_KEYS if key in data]
    if not present:
        return None
    missing = [key for key in MARKER_KEYS[:3] if key not in data]
    if missing:
        raise InputError(f"embedded markers need {', '.join(MARKER_KEYS[:3])}; "
                         f"{', '.join(missing)} missing", key=missing[0])
    if data["marker_nodes"].dtype.kind not in "iu":
        raise InputError(f"expected integer node indices, got dtype "
                         f"{data['marker_nodes'].dtype}", key="marker_nodes")
    for key in ("marker_positions", "marker_weights"):
        if data[key].dtype.kind not in "iuf":
            raise InputError(f"expected numbers, got dtype {data[key].dtype}", key=key)
    names = data.get("marker_names", np.zeros(0, str))
    if names.ndim != 1 or (names.size and names.dtype.kind not in "US"):
        raise InputError("expected a 1-D array of strings", key="marker_names")
    return EmbeddedMarkers(nodes=data["marker_nodes"], weights=data["marker_weights"],
                           positions=data["marker_positions"],
                           names=tuple(str(name) for name in names))


def save_experiment(experiment: Experiment, path: str | os.PathLike) -> Path:
    """Write ``experiment`` as an ``.npz`` file (atomically); returns the path."""
    path = Path(path)
    mesh = experiment.mesh
    data = {
        "rest_positions": mesh.rest_positions,
        "springs": mesh.springs,
        "dt": np.float64(experiment.dt),
        "positions": experiment.positions,
        "fixed": mesh.fixed,
        "observed": experiment.observed,
        "spring_groups": mesh.spring_group,
        "group_names": np.array(mesh.group_names, dtype=str),
    }
    if mesh.tetrahedra is not None:
        data["tetrahedra"] = mesh.tetrahedra
    if experiment.external_forces is not None:
        data["external_forces"] = experiment.external_forces
    if experiment.node_mass is not None:
        data["masses"] = experiment.node_mass
    if experiment.markers is not None:
        markers = experiment.markers
        data.update(marker_positions=markers.positions, marker_nodes=markers.nodes,
                    marker_weights=markers.weights,
                    marker_names=np.array(markers.names, dtype=str))
    for key, value in experiment.truth.items():
        data[key if key.startswith("true_") else f"true_{key}"] = np.asarray(value)
    buffer = _io.BytesIO()
    np.savez_compressed(buffer, **data)
    with atomic_write(path) as handle:
        handle.write(buffer.getvalue())
    return path


# -- model files ----------------------------------------------------------------------------
def model_to_dict(model: SpringMassModel) -> dict:
    """Plain-Python (YAML/JSON-ready) description of a model; exact round trip."""
    from .effects import effect_to_dict

    mesh = model.mesh
    data = {
        "format": MODEL_FORMAT,
        "nodes": {
            "rest_positions": mesh.rest_positions.tolist(),
            "mass": model.node_mass.tolist(),
            "fixed": mesh.fixed.tolist(),
        },
        "springs": {
            "nodes": mesh.springs.tolist(),
            "group": mesh.spring_group.tolist(),
            "group_names": list(mesh.group_names),
            "stiffness": model.spring_stiffness.tolist(),
            "damping": model.spring_damping.tolist(),
            "rest_length": model.spring_rest_length.tolist(),
            "tie": model.spring_tie.tolist(),
        },
        "effects": [effect_to_dict(effect) for effect in model.effects],
    }
    if len(model.region_names) > 1 or model.region_tissues[0] is not None:
        data["regions"] = {"names": list(model.region_names),
                           "tissues": list(model.region_tissues)}
        data["nodes"]["region"] = model.node_region.tolist()
        data["springs"]["region"] = model.spring_region.tolist()
    if mesh.tetrahedra is not None:
        data["tetrahedra"] = mesh.tetrahedra.tolist()
    if model.has_elements:
        data["elements"] = {"youngs_modulus": model.element_youngs_modulus.tolist(),
                            "poisson_ratio": model.element_poisson_ratio.tolist(),
                            "viscosity": model.element_viscosity.tolist(),
                            "tie": model.element_tie.tolist(),
                            "region": model.element_region.tolist(),
                            "volumetric": model.element_volumetric}
    return data


def model_from_dict(data: dict, source: str = "<model>") -> SpringMassModel:
    """Inverse of :func:`model_to_dict`."""
    from .effects import effect_from_dict

    if not isinstance(data, dict) or data.get("format") != MODEL_FORMAT:
        raise InputError(f"not a neurofuzzy model file (expected 'format: {MODEL_FORMAT}')",
                         source=source)
    try:
        nodes, springs = data["nodes"], data["springs"]
        mesh = Mesh(rest_positions=nodes["rest_positions"], springs=springs["nodes"],
                    spring_group=springs.get("group"),
                    group_names=tuple(springs.get("group_names", ())),
                    fixed=nodes.get("fixed", []), tetrahedra=data.get("tetrahedra"))
        return SpringMassModel(
            mesh, node_mass=nodes["mass"], spring_stiffness=springs["stiffness"],
            spring_damping=springs["damping"], spring_rest_length=springs.get("rest_length"),
            spring_tie=np.asarray(springs["tie"]) if "tie" in springs else None,
            effects=tuple(effect_from_dict(e, source) for e in data.get("effects") or ()),
            **_regions_from_dict(data, nodes, springs, source), **_elements_from_dict(data))
    except KeyError as error:
        raise InputError(f"missing key {error.args[0]!r}", source=source) from None
    except InputError as error:
        raise InputError(error.detail, source=source, key=error.key) from None


def _elements_from_dict(data: dict) -> dict:
    elements = data.get("elements")
    if elements is None:
        return {}
    if not isinstance(elements, dict):
        raise InputError("expected youngs_modulus, poisson_ratio and viscosity lists",
                         key="elements")
    values = {f"element_{key}": elements.get(key)
              for key in ("youngs_modulus", "poisson_ratio", "viscosity", "tie", "region")}
    # files written before the nodal volumetric form existed hold per-element elements
    values["element_volumetric"] = elements.get("volumetric", "element")
    return values


def _regions_from_dict(data: dict, nodes: dict, springs: dict, source: str) -> dict:
    regions = data.get("regions")
    if regions is None:
        return {}
    if not isinstance(regions, dict) or not isinstance(regions.get("names"), list):
        raise InputError("expected 'names: [...]' (and optionally 'tissues: [...]')",
                         source=source, key="regions")
    return {"region_names": tuple(regions["names"]), "region_tissues": regions.get("tissues"),
            "spring_region": np.asarray(springs.get("region", np.zeros(0, int))),
            "node_region": np.asarray(nodes.get("region", np.zeros(0, int)))}


def save_model(model: SpringMassModel, path: str | os.PathLike) -> Path:
    """Write ``model`` as YAML (atomically); :func:`load_model` reads it back exactly."""
    path = Path(path)
    text = yaml.safe_dump(model_to_dict(model), sort_keys=False, default_flow_style=None,
                          width=100)
    with atomic_write(path, "w") as handle:
        handle.write("# neurofuzzy spring-mass model; load with neurofuzzy.io.load_model\n")
        handle.write(text)
    return path


def load_model(path: str | os.PathLike) -> SpringMassModel:
    """Read a model written by :func:`save_model`."""
    source = str(path)
    try:
        with open(path, encoding="utf-8") as handle:
            data = yaml.safe_load(handle)
    except FileNotFoundError:
        raise InputError("no such file", source=source) from None
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(error, "problem", None) or str(error)
        raise InputError(f"malformed YAML: {problem}", source=source, line=line) from None
    return model_from_dict(data, source)
