"""Markers on a mesh: which node each marker follows, resampling to the model's step, and the
experiment that results."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, closest_name
from ..experiment import Experiment
from ..mesh import Mesh
from ..observation import EmbeddedMarkers, embed_points
from .readers import TIME_TOLERANCE, MarkerData, read_forces

__all__ = ["MarkerImport", "match_markers", "markers_to_experiment"]


@dataclass(frozen=True)
class MarkerImport:
    """Result of :func:`markers_to_experiment`.

    Attributes
    ----------
    experiment : Experiment
        Frame 0 is the first capture at which every matched marker is seen (earlier frames are
        dropped). Embedded markers (the default) are the experiment's ``markers``; a marker
        attached to a node has its constant offset from the node at frame 0 removed, so the
        node starts at its rest position.
    summary : dict
        ``markers``, ``attach`` ("embed" or "node"), ``unmatched`` (markers left out by the
        map), ``dt``, ``frames``, ``dropped_leading_frames``, ``gaps`` (fraction of missing
        (frame, marker) values), ``capture_period``; node attachment: ``nodes``; embedding:
        ``rest_frames``, ``max_distance_outside`` (m), ``offset_markers``.
    """

    experiment: Experiment
    summary: dict


def match_markers(markers: MarkerData, mesh: Mesh, *, mapping: dict[str, int] | None = None,
                  max_distance: float | None = None) -> dict[str, int]:
    """Marker name → node index.

    With ``mapping`` (e.g. from :func:`read_marker_map`) the map is checked and used; markers
    it leaves out are dropped. A ``node`` CSV maps each marker to its node. Otherwise each
    marker goes to the node nearest to its first seen position; it must lie within
    ``max_distance`` (default: half the shortest spring), and no two markers may share a node.
    """
    source = markers.source
    n_nodes = mesh.n_nodes
    if markers.by_node and mapping is None:
        mapping = {name: int(name) for name in markers.names}
    if mapping is not None:
        for name, node in mapping.items():
            if name not in markers.names:
                hint = closest_name(name, markers.names)
                raise InputError(f"the map names marker {name!r}, which the recording does not "
                                 "have" + (f"; did you mean {hint!r}?" if hint else ""),
                                 source=source)
            if not 0 <= node < n_nodes:
                raise InputError(f"marker {name!r} is mapped to node {node}; the model has "
                                 f"{n_nodes} nodes (0..{n_nodes - 1})", source=source)
        _no_shared_nodes(mapping, source)
        return dict(mapping)
    limit = 0.5 * float(np.min(mesh.rest_lengths)) if max_distance is None else max_distance
    first = _first_seen(markers)
    distance = np.linalg.norm(first[:, None, :] - mesh.rest_positions[None, :, :], axis=2)
    nearest = np.argmin(distance, axis=1)
    gap = distance[np.arange(markers.n_markers), nearest]
    far = np.flatnonzero(~(gap <= limit))
    if far.size:
        worst = far[np.argmax(gap[far])]
        raise InputError(f"{far.size} marker(s) lie farther than {limit:.3g} m from every node, "
                         f"e.g. {markers.names[worst]!r} at {gap[worst]:.3g} m from node "
                         f"{nearest[worst]}; check the units and the coordinate frame, or give "
                         "a map file (marker,node) or a larger --max-distance (Python: "
                         "max_distance)", source=source)
    mapping = {name: int(node) for name, node in zip(markers.names, nearest)}
    _no_shared_nodes(mapping, source)
    return mapping


def markers_to_experiment(markers: MarkerData, mesh: Mesh, *, dt: float | None = None,
                          mapping: dict[str, int] | None = None,
                          max_distance: float | None = None,
                          forces: str | os.PathLike | np.ndarray | None = None,
                          node_mass: np.ndarray | None = None,
                          source: str | None = None, force_spread: int = 1,
                          probe_radius: float | None = None,
                          attach: str = "auto") -> MarkerImport:
    """An experiment from a marker recording on ``mesh``.

    Parameters
    ----------
    markers : MarkerData
    mesh : Mesh
        The model's topology; its rest positions are in the recording's coordinate frame.
    dt : float, optional
        The model's step, the spacing of the experiment's frames (default: the capture's
        frame period). Frames are resampled to it: a frame on a capture time takes that
        capture; a frame between two consecutive captures in which the marker was seen is
        linearly interpolated; anything else (a marker not seen, a dropped capture frame, a
        frame between captures more than one period apart) is a gap. Upsampling gives
        piecewise-linear motion: prefer the capture rate with ``substeps`` in the fit.
    mapping, max_distance
        As in :func:`match_markers` (node attachment). When embedding, ``max_distance`` is
        how far outside the mesh a marker may lie (default: half the shortest spring).
    forces : path or (n_frames, n_nodes, 3) array, optional
        A force CSV (:func:`read_forces`) or forces at the experiment's frames.
    node_mass : (n_nodes,) float, optional
        Known node masses.
    force_spread : int
        Surface nodes sharing each point force of a ``time,x,y,z,fx,fy,fz`` force CSV.
    probe_radius : float, optional
        Contact radius (m) of the probes of such a CSV without a ``radius`` column: each
        force becomes a uniform traction on the surface within it
        (:func:`~neurofuzzy.markers.read_forces`).
    attach : {"auto", "embed", "node"}
        ``"embed"``: every marker is embedded in the tetrahedron that contains it at rest and
        observed by barycentric interpolation of its four nodes
        (:class:`~neurofuzzy.observation.EmbeddedMarkers`; lattices without tetrahedra are
        split into Kuhn tetrahedra for this). ``"node"``: each marker follows one node
        (nearest, or ``mapping``), its frame-0 offset removed. ``"auto"``: ``"node"`` for a
        ``time,node,…`` recording or with a ``mapping``, else ``"embed"`` where the mesh
        allows it.

    Returns
    -------
    MarkerImport
        The experiment and a summary of the import.
    """
    if attach not in ("auto", "embed", "node"):
        raise InputError(f"got {attach!r}; expected auto, embed or node", key="attach")
    tetrahedra = None
    if attach != "node" and mapping is None and not markers.by_node:
        tetrahedra = _embedding_tetrahedra(mesh, required=attach == "embed")
    if tetrahedra is None:
        mapping = match_markers(markers, mesh, mapping=mapping, max_distance=max_distance)
        names = list(mapping)
    else:
        names = list(markers.names)
    columns = [markers.names.index(name) for name in names]
    capture = markers.positions[:, columns]                  # (T_capture, K, 3)
    seen = np.isfinite(capture).all(axis=2)
    complete = np.flatnonzero(seen.all(axis=1))
    if complete.size == 0:
        raise InputError("no capture frame sees every matched marker, so the initial state is "
                         "unknown; map fewer markers or repair the recording",
                         source=markers.source)
    first = int(complete[0])
    times = markers.times[first:] - markers.times[first]
    capture = capture[first:]
    period = markers.frame_period
    if dt is None:
        dt = period
    if not (dt is not None and math.isfinite(dt) and dt > 0):
        raise InputError(f"the time step {dt} is not a positive number; give dt", key="dt")
    n_frames = int(math.floor(times[-1] / dt * (1 + TIME_TOLERANCE) + TIME_TOLERANCE)) + 1
    if n_frames < 2:
        raise InputError(f"the recording spans {times[-1]:.3g} s, less than one step of "
                         f"{dt:.3g} s", source=markers.source)
    resampled = _resample(times, capture, np.arange(n_frames) * dt, period)
    if isinstance(forces, (str, os.PathLike)):
        forces = read_forces(forces, mesh=mesh, spread=force_spread, radius=probe_radius,
                             times=np.arange(n_frames) * dt + markers.times[first])
    positions = np.full((n_frames, mesh.n_nodes, 3), np.nan)
    observed = np.zeros(mesh.n_nodes, dtype=bool)
    summary = {"markers": len(names), "dt": float(dt), "frames": n_frames,
               "capture_period": period, "dropped_leading_frames": first,
               "start_time": float(markers.times[first]),
               "unmatched": [n for n in markers.names if n not in names]}
    embedded = None
    if tetrahedra is None:
        nodes = np.array([mapping[name] for name in names], dtype=np.intp)
        # attach each marker to its node: remove its offset at frame 0
        positions[:, nodes] = resampled + (mesh.rest_positions[nodes] - resampled[0])[None]
        observed[nodes] = True
        summary.update(attach="node", nodes=nodes.tolist())
    else:
        embedded, details = _embed(markers, names, resampled, mesh, tetrahedra, forces,
                                   max_distance)
        summary.update(attach="embed", **details)
    experiment = Experiment(mesh=mesh, dt=float(dt), positions=positions,
                            external_forces=forces, observed=observed, node_mass=node_mass,
                            source=source or markers.source, markers=embedded)
    measured = (np.isfinite(embedded.positions).all(axis=-1) if embedded is not None
                else experiment.measured()[:, observed])
    summary["gaps"] = float(1.0 - measured.mean())
    return MarkerImport(experiment, summary)


#: A marker farther outside the mesh than this fraction of the shortest spring carries a
#: constant offset (estimated from the frames at rest); closer ones are embedded as measured.
OFFSET_FRACTION = 0.1


def _embedding_tetrahedra(mesh: Mesh, required: bool):
    """The mesh's tetrahedra, a lattice's Kuhn split, or None (node attachment)."""
    if mesh.tetrahedra is not None:
        return mesh.tetrahedra
    from ..mesh import lattice_to_tetra

    try:
        return lattice_to_tetra(mesh).tetrahedra
    except InputError:
        if required:
            raise InputError("markers can be embedded only in a mesh with tetrahedra or a "
                             "lattice of cubic cells", key="attach") from None
        return None


def _embed(markers, names, resampled, mesh, tetrahedra, forces, max_distance):
    """Embedded markers and a summary. Each marker's rest position is its mean over the
    frames before the load starts (frame 0 alone when it starts at once); markers that lie
    outside the mesh by more than :data:`OFFSET_FRACTION` of the shortest spring keep that
    constant offset, estimated from those rest frames, the others none."""
    rest_frames = 1
    if forces is not None:
        loads = np.broadcast_to(forces, (len(resampled),) + np.shape(forces)[-2:])
        moving = np.flatnonzero(np.abs(loads).max(axis=(1, 2)) > 0)
        rest_frames = max(1, int(moving[0]) + 1 if moving.size else len(resampled))
    rest_point = np.nanmean(resampled[:rest_frames], axis=0)
    nodes, weights, distance = embed_points(mesh, rest_point, tetrahedra=tetrahedra)
    shortest = float(np.min(mesh.rest_lengths))
    limit = 0.5 * shortest if max_distance is None else max_distance
    far = np.flatnonzero(~(distance <= limit))
    if far.size:
        worst = far[np.argmax(distance[far])]
        raise InputError(f"{far.size} marker(s) lie farther than {limit:.3g} m outside the "
                         f"mesh, e.g. {names[worst]!r} at {distance[worst]:.3g} m; check the "
                         "units and the coordinate frame, or give a larger --max-distance "
                         "(Python: max_distance)",
                         source=markers.source)
    offset = np.where((distance > OFFSET_FRACTION * shortest)[:, None],
                      np.einsum("mk,mkj->mj", weights, mesh.rest_positions[nodes]) - rest_point,
                      0.0)
    embedded = EmbeddedMarkers(nodes=nodes, weights=weights, positions=resampled + offset,
                               names=tuple(names))
    return embedded, {"rest_frames": rest_frames,
                      "max_distance_outside": float(distance.max()),
                      "offset_markers": int(np.count_nonzero(offset.any(axis=1)))}


def _resample(times: np.ndarray, values: np.ndarray, targets: np.ndarray,
              period: float) -> np.ndarray:
    """Values (T, K, 3) with NaN gaps at ``targets``: exact on capture times, linear between
    two consecutive captures (no dropped frame between them) that both saw the marker."""
    tolerance = TIME_TOLERANCE * period
    right = np.clip(np.searchsorted(times, targets - tolerance), 0, len(times) - 1)
    on_frame = np.abs(times[right] - targets) <= tolerance
    left = np.clip(right - 1, 0, len(times) - 1)
    out = np.where(on_frame[:, None, None], values[right], np.nan)
    between = ~on_frame & (right > 0)
    consecutive = (times[right] - times[left]) <= 1.5 * period
    weight = np.where(between, (targets - times[left]) / np.where(between, times[right]
                                                                   - times[left], 1.0), 0.0)
    interpolated = (values[left] * (1 - weight)[:, None, None]
                    + values[right] * weight[:, None, None])     # NaN if either end is a gap
    use = between & consecutive
    out[use] = interpolated[use]
    return out


def _first_seen(markers: MarkerData) -> np.ndarray:
    """(n_markers, 3): each marker's first seen position."""
    seen = np.isfinite(markers.positions).all(axis=2)
    never = np.flatnonzero(~seen.any(axis=0))
    if never.size:
        raise InputError(f"marker {markers.names[never[0]]!r} is never seen",
                         source=markers.source)
    first = np.argmax(seen, axis=0)
    return markers.positions[first, np.arange(markers.n_markers)]


def _no_shared_nodes(mapping: dict[str, int], source: str) -> None:
    by_node: dict[int, str] = {}
    for name, node in mapping.items():
        if node in by_node:
            raise InputError(f"markers {by_node[node]!r} and {name!r} both belong to node "
                             f"{node}; give a map file (marker,node) that attaches each marker "
                             "to its own node", source=source)
        by_node[node] = name
