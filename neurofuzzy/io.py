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
import zlib
from pathlib import Path

import numpy as np
import yaml

from . import safe_yaml
from .errors import InputError, closest_name
from .experiment import Experiment
from .mesh import Mesh
from .model import SpringMassModel
from .safe_yaml import kind_of

__all__ = ["load_experiment", "save_experiment", "load_model", "save_model", "atomic_write"]

REQUIRED_KEYS = ("rest_positions", "springs", "dt", "positions")
#: embedded markers (:class:`~neurofuzzy.observation.EmbeddedMarkers`): all or none
MARKER_KEYS = ("marker_positions", "marker_nodes", "marker_weights", "marker_names")
OPTIONAL_KEYS = ("fixed", "external_forces", "observed", "masses", "spring_groups",
                 "group_names", "tetrahedra", *MARKER_KEYS)
MODEL_FORMAT = "neurofuzzy-model/1"
#: most bytes the arrays of one experiment file may hold uncompressed
MAX_EXPERIMENT_BYTES = 2 * 2**30
#: largest model file read (a 24,000-tetrahedron model is 4 MB and loads in 2 s)
MAX_MODEL_FILE_BYTES = 64 * 2**20


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
    data = read_npz(path)
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


def read_npz(path: str | os.PathLike, *, max_bytes: int | None = None) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` file, read member by member without trusting it.

    Every member must be a ``.npy`` array of plain (non-object) values whose header agrees
    with its size; the members together may hold at most ``max_bytes`` (default
    :data:`MAX_EXPERIMENT_BYTES`) uncompressed, checked before anything is decompressed.
    Whatever zipfile, zlib or numpy's format reader raise on a broken file becomes an
    :class:`InputError` naming the file and the member.
    """
    source = str(path)
    limit = MAX_EXPERIMENT_BYTES if max_bytes is None else max_bytes
    path = Path(path)
    if not path.exists():
        raise InputError("no such file", source=source)
    if path.is_dir():
        raise InputError("is a directory, not an experiment file", source=source)
    key = None
    try:
        with open(path, "rb") as handle:
            if handle.read(4) != b"PK\x03\x04":
                raise InputError("not a readable .npz experiment file (not a zip archive)",
                                 source=source)
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            total = sum(member.file_size for member in members)
            if total > limit:
                raise InputError(f"its arrays hold {total / 2**30:.2f} GB uncompressed; the "
                                 f"limit is {limit / 2**30:.2f} GB (split the recording into "
                                 "several experiment files)", source=source)
            data = {}
            for member in members:
                key = member.filename[:-4] if member.filename.endswith(".npy") \
                    else member.filename
                if key in data:
                    raise InputError("appears twice in the archive", source=source, key=key)
                with archive.open(member) as handle:
                    data[key] = _read_npy(handle, member.file_size)
            return data
    except InputError as error:
        raise InputError(error.detail, source=source, key=error.key or key) from None
    except PermissionError as error:
        raise InputError(f"cannot read the file ({error.strerror})", source=source) from None
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, SyntaxError,
            TypeError, KeyError, NotImplementedError, RuntimeError, OverflowError,
            MemoryError) as error:
        # a corrupt archive, deflate stream or .npy header, or an encrypted member
        what = f"member {key!r} is" if key is not None else "it is"
        raise InputError(f"not a readable .npz experiment file: {what} corrupt or not a "
                         f".npy array ({type(error).__name__}: {error})", source=source,
                         key=key) from None


def _read_npy(handle, size: int) -> np.ndarray:
    """One ``.npy`` member of ``size`` bytes; its header must agree with its size."""
    version = np.lib.format.read_magic(handle)
    if version == (1, 0):
        shape, fortran, dtype = np.lib.format.read_array_header_1_0(handle)
    elif version in ((2, 0), (3, 0)):
        shape, fortran, dtype = np.lib.format.read_array_header_2_0(handle)
    else:
        raise InputError(f"unsupported .npy format version {version}")
    if dtype.hasobject:
        raise InputError("holds Python objects, which neurofuzzy will not unpickle; store "
                         "plain numeric arrays")
    count = int(np.prod(shape, dtype=object))
    nbytes = count * dtype.itemsize
    if nbytes > size:
        raise InputError(f"its header promises {shape} {dtype} ({nbytes} bytes) but the "
                         f"member holds {size} bytes: truncated or corrupt")
    buffer = bytearray(handle.read(nbytes))
    if len(buffer) != nbytes:
        raise InputError(f"truncated: {len(buffer)} of {nbytes} bytes")
    return np.frombuffer(buffer, dtype=dtype, count=count).reshape(
        shape, order="F" if fortran else "C")


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


#: the keys of a model file, per section: (required, optional)
MODEL_KEYS = {
    None: (("format", "nodes", "springs"), ("effects", "regions", "tetrahedra", "elements")),
    "nodes": (("rest_positions", "mass"), ("fixed", "region")),
    "springs": (("nodes", "stiffness", "damping"),
                ("group", "group_names", "rest_length", "tie", "region")),
    "regions": (("names",), ("tissues",)),
    "elements": ((), ("youngs_modulus", "poisson_ratio", "viscosity", "tie", "region",
                      "volumetric")),
}
#: keys whose value is a single word, not a list
_MODEL_SCALAR_KEYS = {("elements", "volumetric")}
#: where an array a model checks (its key) is in the file: (section, key)
_MODEL_FILE_KEY = {
    "rest_positions": ("nodes", "rest_positions"), "node_mass": ("nodes", "mass"),
    "fixed": ("nodes", "fixed"), "node_region": ("nodes", "region"),
    "springs": ("springs", "nodes"), "spring_group": ("springs", "group"),
    "group_names": ("springs", "group_names"), "spring_stiffness": ("springs", "stiffness"),
    "spring_damping": ("springs", "damping"), "spring_rest_length": ("springs", "rest_length"),
    "spring_tie": ("springs", "tie"), "spring_region": ("springs", "region"),
    "tetrahedra": (None, "tetrahedra"), "region_names": ("regions", "names"),
    "region_tissues": ("regions", "tissues"), "effects": (None, "effects"),
    **{f"element_{key}": ("elements", key)
       for key in ("youngs_modulus", "poisson_ratio", "viscosity", "tie", "region",
                   "volumetric")},
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
    """The line of ``key`` in a mapping read by :mod:`neurofuzzy.safe_yaml` (else None)."""
    line_of = getattr(mapping, "line_of", None)
    return line_of(key) if line_of is not None else None


def model_from_dict(data: dict, source: str = "<model>") -> SpringMassModel:
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


def _model_from_checked_dict(data: dict, source: str) -> SpringMassModel:
    from .effects import effect_from_dict

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
    """Read a model written by :func:`save_model`.

    Raises
    ------
    InputError
        The file is missing, larger than :data:`MAX_MODEL_FILE_BYTES`, not YAML (see
        :mod:`neurofuzzy.safe_yaml`), not laid out as a model file, or holds impossible values;
        the message names the file, the key and the line.
    """
    return model_from_dict(safe_yaml.load(path, max_bytes=MAX_MODEL_FILE_BYTES,
                                          kind="model file"), str(path))
