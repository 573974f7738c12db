"""What an experiment measures, as one linear observation operator: node positions, or
markers embedded anywhere in the object.

Real markers never sit on mesh nodes. An :class:`EmbeddedMarkers` marker lies in the
tetrahedron that contains it at rest and moves with it: its position is the barycentric
combination ``Σ_k w_k p_k`` of the tetrahedron's four corner nodes (the linear element's own
interpolation, so the observation is exact for the element model and first-order accurate for
a spring network's motion). Stacking the weights gives a sparse matrix ``H`` (markers ×
nodes); node observations are the special case of rows with one weight 1.
:class:`Observation` carries ``H`` with the measured values, so the learners, their exact
derivatives (``H`` applied to the forward sensitivities, ``Hᵀ`` to the adjoint's residual
seed) and the error measures have one code path for both.

:func:`embed_points` finds the containing tetrahedron and the weights of points at rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .errors import InputError

__all__ = ["EmbeddedMarkers", "Observation", "embed_points", "remove_offsets",
           "require_motion"]


@dataclass(frozen=True, eq=False)
class EmbeddedMarkers:
    """Markers observed through the nodes of the tetrahedra that contain them.

    Parameters
    ----------
    nodes : (n_markers, 4) int
        Corner nodes of each marker's tetrahedron.
    weights : (n_markers, 4) float
        Barycentric weights (non-negative, each row summing to 1).
    positions : (n_frames, n_markers, 3) float
        Measured marker positions, NaN where a marker was not seen (a gap).
    names : tuple of str
        Marker labels.
    """

    nodes: np.ndarray
    weights: np.ndarray
    positions: np.ndarray
    names: tuple = ()

    def __post_init__(self):
        nodes = np.asarray(self.nodes)
        weights = np.asarray(self.weights, dtype=float)
        positions = np.asarray(self.positions, dtype=float)
        n = len(nodes)
        if nodes.ndim != 2 or nodes.shape[1] != 4 or not np.issubdtype(nodes.dtype, np.integer):
            raise InputError(f"got {nodes.dtype} of shape {nodes.shape}; expected integer "
                             "(n_markers, 4)", key="marker_nodes")
        if weights.shape != (n, 4) or not np.all(np.isfinite(weights)) \
                or np.any(weights < -1e-9) or not np.allclose(weights.sum(axis=1), 1.0):
            raise InputError(f"expected (n_markers, 4) = ({n}, 4) non-negative weights "
                             "summing to 1 per marker", key="marker_weights")
        if positions.ndim != 3 or positions.shape[1:] != (n, 3):
            raise InputError(f"got shape {positions.shape}; expected (n_frames, n_markers, 3)"
                             f" with n_markers = {n}", key="marker_positions")
        if np.isinf(positions).any():
            raise InputError("infinite value; use NaN for a marker that was not seen",
                             key="marker_positions")
        if n == 0:
            raise InputError("no markers", key="marker_positions")
        gaps = ~np.isfinite(positions).all(axis=-1, keepdims=True)
        object.__setattr__(self, "nodes", nodes.astype(np.intp))
        object.__setattr__(self, "weights", weights)
        object.__setattr__(self, "positions", np.where(gaps, np.nan, positions))
        object.__setattr__(self, "names", tuple(str(name) for name in self.names)
                           or tuple(f"M{i}" for i in range(n)))

    @property
    def n_markers(self) -> int:
        return len(self.nodes)

    def operator(self, n_nodes: int) -> sp.csr_matrix:
        """(n_markers, n_nodes) sparse ``H``: marker positions are ``H @ node positions``."""
        if self.nodes.max() >= n_nodes:
            raise InputError(f"marker corner node {int(self.nodes.max())} is not a node of the "
                             f"mesh (0..{n_nodes - 1})", key="marker_nodes")
        rows = np.repeat(np.arange(self.n_markers), 4)
        return sp.csr_matrix((self.weights.ravel(), (rows, self.nodes.ravel())),
                             shape=(self.n_markers, n_nodes))


@dataclass(frozen=True, eq=False)
class Observation:
    """What is measured and how it follows from the node positions.

    Attributes
    ----------
    operator : (n_rows, n_nodes) sparse
        Rows: the tracked nodes (observed, not fixed), or the embedded markers.
    values : (n_frames, n_rows, 3) float
        Measured values (NaN in the gaps).
    seen : (n_frames, n_rows) bool
        Which (frame, row) pairs are measured and count.
    """

    operator: sp.csr_matrix
    values: np.ndarray
    seen: np.ndarray

    @property
    def n_rows(self) -> int:
        return self.operator.shape[0]

    def apply(self, nodal: np.ndarray) -> np.ndarray:
        """``H`` applied to node-major arrays (n_nodes, ...) → (n_rows, ...)."""
        flat = nodal.reshape(nodal.shape[0], -1)
        return np.asarray(self.operator @ flat).reshape((self.n_rows,) + nodal.shape[1:])

    def frames(self, positions: np.ndarray) -> np.ndarray:
        """(n_frames, n_rows, 3) observed values of node trajectories (n_frames, n_nodes, 3)."""
        return np.moveaxis(self.apply(np.moveaxis(positions, 1, 0)), 0, 1)

    def residuals(self, positions: np.ndarray) -> np.ndarray:
        """(n_frames, n_rows, 3): simulated minus measured, zero where not measured."""
        return np.where(self.seen[:, :, None],
                        self.frames(positions) - np.nan_to_num(self.values), 0.0)

    def adjoint(self, rows: np.ndarray) -> np.ndarray:
        """``Hᵀ`` applied to (n_rows, 3) → (n_nodes, 3)."""
        return np.asarray(self.operator.T @ rows)


def remove_offsets(residuals: np.ndarray, seen: np.ndarray,
                   jacobian: np.ndarray | None = None) -> np.ndarray:
    """Residuals with every row's best constant offset taken out: the markers' rest positions
    as nuisance parameters (variable projection).

    A marker's rest position in the model comes from the recording (one noisy frame when the
    load starts at once, a point off the surface …); its error is a constant offset in every
    frame. The offset that fits best is the mean residual of the row over its measured frames,
    whatever the model's parameters, so fitting it is the projection ``P r`` (``P`` removes
    the mean of each row and coordinate over its measured frames); ``P`` does not depend on
    the parameters, so the Jacobian of the projected residuals is ``P J``, and the adjoint's
    seed ``P r`` gives the gradient of ``½ |P r|²``.

    Parameters
    ----------
    residuals : (n_frames, n_rows, 3) float
        Simulated minus measured, zero where not measured.
    seen : (n_frames, n_rows) bool
        Which entries are measured.
    jacobian : (n_frames, n_rows, 3, n_params) float, optional
        Projected in place (entries not measured set to zero).

    Returns
    -------
    (n_frames, n_rows, 3) float
        The projected residuals (zero where not measured).
    """
    count = np.maximum(seen.sum(axis=0), 1)[:, None]                  # (rows, 1)
    offset = np.where(seen[..., None], residuals, 0.0).sum(axis=0) / count
    if jacobian is not None:
        jacobian *= seen[:, :, None, None]
        mean = jacobian.sum(axis=0) / count[:, :, None]               # (rows, 3, n_params)
        for frame, measured in zip(jacobian, seen):                   # no full-size temporary
            frame -= mean * measured[:, None, None]
    return np.where(seen[..., None], residuals - offset[None], 0.0)


def embed_points(mesh, points: np.ndarray, *, tetrahedra: np.ndarray | None = None):
    """The tetrahedron containing each point at rest, its barycentric weights, and how far
    the point lies outside the mesh.

    A point inside (or on) a tetrahedron gets that tetrahedron's exact barycentric weights.
    A point outside every tetrahedron (a surface marker a little off the surface) goes to
    the nearest point of the nearby tetrahedron whose most negative barycentric coordinate
    is the least negative (non-negative weights summing to one, by non-negative least
    squares).

    Parameters
    ----------
    mesh : Mesh
    points : (n_points, 3) float
    tetrahedra : (K, 4) int, optional
        Default ``mesh.tetrahedra``.

    Returns
    -------
    nodes : (n_points, 4) int
    weights : (n_points, 4) float
    distance : (n_points,) float
        Distance from each point to its embedded position (0 inside the mesh).
    """
    tetrahedra = mesh.tetrahedra if tetrahedra is None else tetrahedra
    if tetrahedra is None:
        raise InputError("the mesh has no tetrahedra to embed markers in", key="tetrahedra")
    tetrahedra = np.asarray(tetrahedra)
    points = np.asarray(points, float)
    rest = mesh.rest_positions
    corners = rest[tetrahedra]                                        # (K, 4, 3)
    inverse = np.linalg.inv(np.swapaxes(corners[:, 1:] - corners[:, :1], 1, 2))
    centroids = corners.mean(axis=1)
    candidates = min(len(tetrahedra), 32)
    nodes = np.empty((len(points), 4), np.intp)
    weights = np.empty((len(points), 4))
    for start in range(0, len(points), 256):                          # bounded memory
        chunk = points[start:start + 256]
        near = np.argsort(np.linalg.norm(chunk[:, None] - centroids[None], axis=2),
                          axis=1)[:, :candidates]                     # (C, c)
        local = np.einsum("pcij,pcj->pci", inverse[near], chunk[:, None] - corners[near, 0])
        bary = np.concatenate([1 - local.sum(axis=2, keepdims=True), local], axis=2)
        best = np.argmax(bary.min(axis=2), axis=1)
        chosen = bary[np.arange(len(chunk)), best]
        tets = tetrahedra[near[np.arange(len(chunk)), best]]
        for i in np.flatnonzero(chosen.min(axis=1) < 0):
            chosen[i] = _nearest_weights(rest[tets[i]], chunk[i])
        chosen = np.clip(chosen, 0.0, None)
        chosen /= chosen.sum(axis=1, keepdims=True)
        nodes[start:start + 256] = tets
        weights[start:start + 256] = chosen
    embedded = np.einsum("pk,pkj->pj", weights, rest[nodes])
    return nodes, weights, np.linalg.norm(points - embedded, axis=1)


def _nearest_weights(corners: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Barycentric weights (≥ 0, summing to 1) of the point of a tetrahedron nearest to
    ``point``: ``min |Σ w_k c_k - x|`` with the sum enforced by a heavy extra row."""
    from scipy.optimize import nnls

    scale = float(np.ptp(corners, axis=0).max())
    heavy = 1e3
    matrix = np.vstack([corners.T / scale, np.full((1, 4), heavy)])
    target = np.concatenate([point / scale, [heavy]])
    return nnls(matrix, target)[0]


def require_motion(mesh, observed: np.ndarray, markers, source: str) -> None:
    """Refuse an experiment in which nothing can move, or nothing measured can."""
    free = mesh.free
    if not free.any():
        raise InputError(f"all {mesh.n_nodes} nodes are fixed, so nothing can move; fix only "
                         "the nodes that are held", source=source, key="fixed")
    if markers is not None:
        moves = np.asarray(markers.operator(mesh.n_nodes)[:, free].sum(axis=1)).ravel() > 1e-12
        if not moves.any():
            raise InputError("every marker sits on fixed nodes only, so nothing measured can "
                             "move", source=source, key="marker_nodes")
    elif not (observed & free).any():
        raise InputError("every observed node is fixed, so nothing measured can move; observe "
                         "free nodes", source=source, key="observed")
