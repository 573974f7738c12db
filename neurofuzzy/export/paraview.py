"""Results out to ParaView: a model with its simulated and measured trajectories.

Two forms, both written through `meshio <https://github.com/nschloe/meshio>`_ (imported only
when :func:`export_paraview` runs):

``vtu``
    ``{stem}.pvd``, a ParaView collection, plus one ``{stem}_{frame:04d}.vtu`` per frame. The
    points of every frame are the *simulated* positions, so the animation plays as soon as the
    ``.pvd`` is opened, with no filter.
``xdmf``
    One ``{stem}.xdmf`` time series with the values inline (XML, no HDF5 file, no h5py). Its
    points are the *rest* positions; apply **Warp By Vector** with ``displacement_simulated``
    (scale factor 1) to see the motion, or with ``displacement_measured`` to see the markers.

Both carry the same arrays per frame (NaN wherever a node is not measured):

========================== ============ =========================================================
point data                 shape        meaning
========================== ============ =========================================================
``simulated``              (N, 3) float simulated position
``measured``               (N, 3) float measured position; NaN where the node is not measured
                                        at that frame (unobserved node, or a gap)
``error``                  (N,) float   ``|simulated - measured|``; NaN where not measured
``displacement_simulated`` (N, 3) float simulated position minus rest position
``displacement_measured``  (N, 3) float measured position minus rest position; NaN where
                                        not measured
``observed``               (N,) int32   1 where the node is measured at that frame, else 0
``fixed``                  (N,) int32   1 for nodes held in place
``mass``                   (N,) float   node mass
``external_force``         (N, 3) float applied load acting from this frame to the next
========================== ============ =========================================================

========================== ============ =========================================================
cell data (one per spring) shape        meaning
========================== ============ =========================================================
``stiffness``              (S,) float   spring constant ``s``
``damping``                (S,) float   viscosity ``c``
``rest_length``            (S,) float   rest length ``L0``
``spring_group``           (S,) int32   index into ``model.mesh.group_names``
``strain``                 (S,) float   ``(l - L0) / L0`` of the simulated frame
``strain_measured``        (S,) float   the same from the measured positions; NaN unless both
                                        ends are measured at that frame
========================== ============ =========================================================

Springs are ``line`` cells. A mesh with tetrahedra (an optional ``mesh.tetrahedra``,
(n_tets, 4) int) adds them to the ``.vtu`` files as ``tetra`` cells, whose spring arrays hold
NaN (``spring_group`` -1); the ``.xdmf`` holds the springs only, because meshio 5.3 cannot write
a mixed line/tetra topology to XDMF.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..forces.springs import spring_constants
from ..errors import InputError, closest_name

__all__ = ["FORMATS", "export_paraview"]

#: The output forms :func:`export_paraview` knows.
FORMATS: tuple[str, ...] = ("vtu", "xdmf")


def export_paraview(directory: str | os.PathLike, model, experiment=None, *, simulated=None,
                    dt: float | None = None, every: int = 1, substeps: int | str = 1,
                    stem: str = "neurofuzzy",
                    formats: Sequence[str] = FORMATS,
                    comment: str | None = None) -> dict[str, Path | list[Path]]:
    """Write a model and its trajectories as ParaView time series (VTU + PVD, XDMF).

    Parameters
    ----------
    directory : path
        Where the files go; created if missing.
    model : Model
        Topology and parameters (stiffness, damping, rest length per spring; mass per node).
    experiment : Experiment, optional
        The measurement: ``positions`` (n_frames, n_nodes, 3) with NaN where a node is not
        measured, ``dt`` and ``external_forces``. It sets the frames and their times
        ``t * dt``.
    simulated : (n_frames, n_nodes, 3) float or Trajectory, optional
        The model's simulated positions. Default: with an experiment, the model run freely under
        the experiment's load from its initial state (as the learners do, with ``substeps``
        steps per frame); without one, a single frame at rest.
    dt : float, optional
        Time between frames when there is no experiment (a Trajectory brings its own ``dt``).
        Needed for more than one frame without an experiment; must agree with the experiment's
        when both are given.
    every : int
        Keep every ``every``-th frame (0, every, 2·every, …); the file names and times keep the
        original frame numbers.
    substeps : int or "auto"
        Integration steps per frame for the default simulation (``"auto"``: the fewest
        stable ones).
    stem : str
        Base name of the files (a plain file name, no directory).
    formats : sequence of {"vtu", "xdmf"}
        Which forms to write.
    comment : str, optional
        Text put as an XML comment at the top of the ``.pvd`` and ``.xdmf`` (the fitted
        values and the lack of fit, as :func:`neurofuzzy.export.export` writes them).

    Returns
    -------
    dict
        Keys only for the forms written: ``"pvd"`` -> Path of ``{stem}.pvd``, ``"vtu"`` ->
        list of Path, one ``.vtu`` per written frame in time order, ``"xdmf"`` -> Path of
        ``{stem}.xdmf``.

    Raises
    ------
    InputError
        A shape, option or name that does not fit, or an output name taken by a directory.
    ImportError
        meshio is not installed.

    Notes
    -----
    Nothing is left half-written: every file goes to a temporary directory inside
    ``directory`` and is moved into place (``os.replace``) only when all were written; on an
    error the temporary directory is removed (and ``directory`` too if this call created it
    and it is empty) and the error re-raised. Only our own names are replaced:
    ``{stem}.pvd``, ``{stem}.xdmf`` and ``{stem}_NNNN.vtu``; frame files of an earlier export
    of the same stem that the new one does not have are removed, so the directory holds one
    consistent series.

    In ParaView: open ``{stem}.pvd``, Apply, press play; colour the springs by ``strain`` or
    ``stiffness`` and the nodes by ``error`` (a Tube filter thickens the springs). For the
    ``.xdmf`` (Xdmf3 reader) add Warp By Vector with ``displacement_simulated``.
    """
    formats = _check_formats(formats)
    stem = _check_stem(stem)
    if isinstance(every, bool) or not isinstance(every, (int, np.integer)) or every < 1:
        raise InputError(f"got {every!r}; expected a positive integer", key="every")
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise InputError("exists and is not a directory", source=str(directory))

    frames = _frames(model, experiment, simulated, dt, substeps)
    keep = np.arange(0, frames.positions.shape[0], int(every))
    series = _series(model, experiment, frames, keep)
    width = max(4, len(str(frames.positions.shape[0] - 1)))
    vtu_names = [f"{stem}_{index:0{width}d}.vtu" for index in keep]
    targets = (vtu_names + [f"{stem}.pvd"] if "vtu" in formats else []) \
        + ([f"{stem}.xdmf"] if "xdmf" in formats else [])
    for name in targets:
        if (directory / name).is_dir():
            raise InputError(f"{name!r} is a directory; choose another stem or directory",
                             source=str(directory))

    import meshio   # a dependency of neurofuzzy; imported here to keep start-up light

    created = not directory.exists()
    directory.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{stem}.", suffix=".export", dir=directory))
    try:
        if "vtu" in formats:
            for k, name in enumerate(vtu_names):
                _write_vtu(meshio, staging / name, series, k)
            _write_pvd(staging / f"{stem}.pvd", vtu_names, series["times"], comment)
        if "xdmf" in formats:
            _write_xdmf(meshio, staging / f"{stem}.xdmf", series, comment)
        # frames first, the files that point at them last
        for name in targets:
            os.replace(staging / name, directory / name)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if created:
            with contextlib.suppress(OSError):      # not empty: someone else wrote there
                directory.rmdir()
        raise
    staging.rmdir()

    written: dict[str, Path | list[Path]] = {}
    if "vtu" in formats:
        _remove_stale_frames(directory, stem, set(vtu_names))
        written["pvd"] = directory / f"{stem}.pvd"
        written["vtu"] = [directory / name for name in vtu_names]
    if "xdmf" in formats:
        written["xdmf"] = directory / f"{stem}.xdmf"
    return written


# -- input ----------------------------------------------------------------------------------
class _Frames:
    """Simulated positions (n_frames, n_nodes, 3) and the time between frames."""

    def __init__(self, positions: np.ndarray, dt: float):
        self.positions = positions
        self.dt = dt


def _check_formats(formats) -> tuple[str, ...]:
    if isinstance(formats, str):
        formats = (formats,)
    formats = tuple(formats)
    if not formats:
        raise InputError(f"no format given; expected some of {list(FORMATS)}", key="formats")
    for name in formats:
        if name not in FORMATS:
            hint = closest_name(str(name), FORMATS)
            raise InputError(f"unknown format {name!r}"
                             + (f"; did you mean {hint!r}?" if hint else "")
                             + f" (known: {list(FORMATS)})", key="formats")
    return formats


def _check_stem(stem) -> str:
    stem = str(stem)
    if (not stem or stem in (".", "..") or stem.startswith(".") or Path(stem).name != stem
            or "/" in stem or "\\" in stem):
        raise InputError(f"got {stem!r}; expected a plain file name without directory, "
                         "e.g. 'cube'", key="stem")
    return stem


def _frames(model, experiment, simulated, dt, substeps) -> _Frames:
    """Check the inputs against each other and return the simulated frames."""
    n_nodes = model.n_nodes
    if experiment is not None:
        from ..experiment import check_experiments

        check_experiments(model, experiment)
    trajectory_dt = None
    if simulated is not None and hasattr(simulated, "positions") and hasattr(simulated, "dt"):
        trajectory_dt = float(simulated.dt)
        simulated = simulated.positions
    given = [(value, what) for value, what in ((dt, "dt"), (trajectory_dt, "simulated.dt"))
             if value is not None]
    if experiment is not None:
        for value, what in given:
            if not np.isclose(float(value), experiment.dt, rtol=1e-9, atol=0.0):
                raise InputError(f"{value} differs from the experiment's dt {experiment.dt}",
                                 key=what)
        frame_dt = experiment.dt
    else:
        frame_dt = float(given[0][0]) if given else None
    if frame_dt is not None and not (np.isfinite(frame_dt) and frame_dt > 0):
        raise InputError(f"got {frame_dt}; expected a positive time step", key="dt")

    if simulated is None:
        if experiment is None:
            return _Frames(np.array(model.mesh.rest_positions, dtype=float)[None], frame_dt or 1.0)
        from ..experiment import simulate_like

        return _Frames(simulate_like(model, experiment, substeps), frame_dt)

    try:
        positions = np.array(simulated, dtype=float)
    except (TypeError, ValueError):
        raise InputError("expected numbers", key="simulated") from None
    if experiment is not None:
        expected = (experiment.n_frames, n_nodes, 3)
        if positions.shape != expected:
            raise InputError(f"got shape {positions.shape}; expected (n_frames, n_nodes, 3) = "
                             f"{expected}, the experiment's frames", key="simulated")
    elif positions.ndim != 3 or positions.shape[1:] != (n_nodes, 3) or len(positions) < 1:
        raise InputError(f"got shape {positions.shape}; expected (n_frames, n_nodes, 3) = "
                         f"(n_frames, {n_nodes}, 3)", key="simulated")
    if not np.all(np.isfinite(positions)):
        frame = int(np.argmax(~np.isfinite(positions).all(axis=(1, 2))))
        raise InputError(f"contains NaN or infinite values (first at frame {frame}); a diverged "
                         "simulation cannot be shown", key="simulated")
    if frame_dt is None:
        if len(positions) > 1:
            raise InputError(f"{len(positions)} frames and no time step; pass dt= (or an "
                             "experiment, or a Trajectory)", key="dt")
        frame_dt = 1.0
    return _Frames(positions, frame_dt)


# -- arrays ---------------------------------------------------------------------------------
def _series(model, experiment, frames: _Frames, keep: np.ndarray) -> dict:
    """Every array written, for the kept frames (leading axis n_kept where per frame)."""
    mesh = model.mesh
    rest = np.asarray(mesh.rest_positions, dtype=float)
    simulated = frames.positions[keep]                                  # (K, N, 3)
    n_kept, n_nodes = simulated.shape[:2]
    if experiment is not None:
        raw = experiment.positions[keep]
        seen = np.asarray(experiment.observed, bool)[None, :] & np.isfinite(raw).all(axis=-1)
        measured = np.where(seen[..., None], raw, np.nan)
        forces = np.array(experiment.forces_per_frame()[keep], dtype=float)
    else:
        seen = np.zeros((n_kept, n_nodes), dtype=bool)
        measured = np.full_like(simulated, np.nan)
        forces = np.zeros_like(simulated)
    fixed = np.zeros(n_nodes, dtype=np.int32)
    fixed[mesh.fixed] = 1

    a, b = np.asarray(mesh.springs).T
    stiffness, damping, rest_length = (np.asarray(values, dtype=float)
                                       for values in spring_constants(model))

    def strain(positions):                                              # (K, S)
        length = np.linalg.norm(positions[:, b] - positions[:, a], axis=-1)
        return (length - rest_length) / rest_length

    tetrahedra = getattr(mesh, "tetrahedra", None)
    tetrahedra = (None if tetrahedra is None or len(tetrahedra) == 0
                  else np.asarray(tetrahedra, dtype=np.int64).reshape(-1, 4))
    return {
        "times": keep * frames.dt,
        "rest": rest,
        "springs": np.asarray(mesh.springs, dtype=np.int64),
        "tetrahedra": tetrahedra,
        "point_static": {"fixed": fixed,
                         "mass": np.asarray(model.node_mass, dtype=float)},
        "point_frames": {
            "simulated": simulated,
            "measured": measured,
            "error": np.linalg.norm(simulated - measured, axis=-1),
            "displacement_simulated": simulated - rest,
            "displacement_measured": measured - rest,
            "observed": seen.astype(np.int32),
            "external_force": forces,
        },
        "cell_static": {"stiffness": stiffness, "damping": damping,
                        "rest_length": rest_length,
                        "spring_group": np.asarray(mesh.spring_group, dtype=np.int32)},
        "cell_frames": {"strain": strain(simulated),
                        "strain_measured": strain(measured)},
    }


def _point_data(series: dict, k: int) -> dict[str, np.ndarray]:
    data = {name: np.ascontiguousarray(values[k])
            for name, values in series["point_frames"].items()}
    data.update(series["point_static"])
    return data


def _spring_data(series: dict, k: int) -> dict[str, np.ndarray]:
    data = dict(series["cell_static"])
    data.update({name: np.ascontiguousarray(values[k])
                 for name, values in series["cell_frames"].items()})
    return data


# -- writers --------------------------------------------------------------------------------
def _write_vtu(meshio, path: Path, series: dict, k: int) -> None:
    cells = [("line", series["springs"])]
    cell_data = {name: [values] for name, values in _spring_data(series, k).items()}
    tetrahedra = series["tetrahedra"]
    if tetrahedra is not None:
        cells.append(("tetra", tetrahedra))
        for values in cell_data.values():
            fill = -1 if np.issubdtype(values[0].dtype, np.integer) else np.nan
            values.append(np.full(len(tetrahedra), fill, dtype=values[0].dtype))
    mesh = meshio.Mesh(series["point_frames"]["simulated"][k], cells,
                       point_data=_point_data(series, k), cell_data=cell_data)
    meshio.write(path, mesh, file_format="vtu")


def _xml_comment(comment: str | None) -> str:
    """``comment`` as an XML comment line block (``--`` is not allowed inside one)."""
    return "" if not comment else "<!--\n" + comment.replace("--", "- -") + "\n-->\n"


def _write_pvd(path: Path, files: Sequence[str], times: np.ndarray,
               comment: str | None = None) -> None:
    rows = "".join(f'    <DataSet timestep="{float(t)!r}" group="" part="0" '
                   f'file={quoteattr(name)}/>\n' for name, t in zip(files, times))
    text = ('<?xml version="1.0"?>\n' + _xml_comment(comment)
            + '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
            "  <Collection>\n" + rows + "  </Collection>\n</VTKFile>\n")
    path.write_text(text, encoding="utf-8")


def _text_writer(meshio):
    """meshio's XDMF time-series writer with its arrays written as the shortest text that
    reads back exactly (Python's ``repr``) instead of through ``numpy.savetxt``, which
    formats each number in Python with a ``%`` format (25 s of a 35 s profiled export of 131
    frames of a 4,800-tetrahedron block; the export took 28 s, now 10 s, and its XDMF file
    shrank from 120 MB to 70 MB). The file holds the same numbers."""
    class Writer(meshio.xdmf.TimeSeriesWriter):
        def numpy_to_xml_string(self, data):
            return "\n".join(map(repr, np.asarray(data).ravel().tolist())) + "\n"

    return Writer


def _write_xdmf(meshio, path: Path, series: dict, comment: str | None = None) -> None:
    with _text_writer(meshio)(path, data_format="XML") as writer:
        writer.write_points_cells(series["rest"], [("line", series["springs"])])
        for k, t in enumerate(series["times"]):
            writer.write_data(float(t), point_data=_point_data(series, k),
                              cell_data={name: [values]
                                         for name, values in _spring_data(series, k).items()})
    if comment:
        text = path.read_text(encoding="utf-8")
        end = text.index("?>") + 2 if text.startswith("<?xml") else 0
        path.write_text(text[:end] + "\n" + _xml_comment(comment) + text[end:].lstrip("\n"),
                        encoding="utf-8")


def _remove_stale_frames(directory: Path, stem: str, keep: set[str]) -> None:
    """Remove ``{stem}_NNNN.vtu`` files an earlier export left that the new series lacks."""
    pattern = re.compile(re.escape(stem) + r"_\d{4,}\.vtu")
    for path in directory.iterdir():
        if pattern.fullmatch(path.name) and path.name not in keep and path.is_file():
            path.unlink()
