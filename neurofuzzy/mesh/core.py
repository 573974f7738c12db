"""The :class:`Mesh` value object (nodes, springs, spring groups, fixed nodes, tetrahedra) and
the input checks every builder shares."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import InputError

__all__ = ["Mesh", "TET_EDGES", "bottom_layer", "mesh_fingerprint"]

#: The six edges of a tetrahedron, as pairs of its local vertex indices.
TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


@dataclass(frozen=True, eq=False)
class Mesh:
    """Nodes, springs and constraints of a spring-mass network.

    Parameters
    ----------
    rest_positions : (n_nodes, 3) float
        Node positions of the undeformed object.
    springs : (n_springs, 2) int
        Node index pairs ``(a, b)``; the spring pulls ``a`` towards ``b`` when stretched.
    spring_group : (n_springs,) int, optional
        Group index of every spring (default: all in group 0). Groups share parameters when a
        model is tied by group.
    group_names : sequence of str, optional
        Name of every group index (default ``"group0"``, ``"group1"``, …).
    fixed : (n_fixed,) int, optional
        Nodes held at their rest positions.
    tetrahedra : (n_tets, 4) int, optional
        The volume cells of a tetrahedral mesh (node indices, four distinct per row); ``None``
        for lattices and other meshes without tetrahedra. The springs need not be exactly the
        tetrahedron edges, but rule-based parameters (:mod:`neurofuzzy.rules`) need every
        spring to be an edge of some tetrahedron.
    """

    rest_positions: np.ndarray
    springs: np.ndarray
    spring_group: np.ndarray | None = None
    group_names: tuple[str, ...] = ()
    fixed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    tetrahedra: np.ndarray | None = None
    driven: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))

    def __post_init__(self):
        positions = as_float_array(self.rest_positions, "rest_positions")
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise InputError(f"got shape {positions.shape}; expected (n_nodes, 3)",
                             key="rest_positions")
        n_nodes = positions.shape[0]
        if n_nodes == 0:
            raise InputError("no nodes; expected (n_nodes, 3) positions", key="rest_positions")
        check_coordinates(positions, "rest_positions")
        springs = as_index_array(self.springs, "springs")
        if springs.ndim != 2 or springs.shape[1] != 2:
            raise InputError(f"got shape {springs.shape}; expected (n_springs, 2)", key="springs")
        if len(springs) == 0:
            raise InputError("no springs: nothing connects the nodes; expected (n_springs, 2) "
                             "node pairs (the edges of the mesh)", key="springs")
        check_range(springs, n_nodes, "springs")
        check_unique_rows(springs, "springs", "spring", "connects the same two nodes as")
        if np.any(springs[:, 0] == springs[:, 1]):
            bad = int(np.flatnonzero(springs[:, 0] == springs[:, 1])[0])
            raise InputError(f"spring {bad} connects node {springs[bad, 0]} to itself",
                             key="springs")
        lengths = np.linalg.norm(positions[springs[:, 1]] - positions[springs[:, 0]], axis=1)
        if np.any(lengths <= 0):
            bad = int(np.flatnonzero(lengths <= 0)[0])
            raise InputError(f"spring {bad} has zero rest length (its two nodes coincide)",
                             key="springs")
        if self.spring_group is None:
            groups = np.zeros(len(springs), dtype=np.intp)
        else:
            groups = as_index_array(self.spring_group, "spring_group")
            if groups.shape != (len(springs),):
                raise InputError(f"got shape {groups.shape}; expected ({len(springs)},), one "
                                 "group index per spring", key="spring_group")
            if np.any(groups < 0):
                raise InputError("group indices must be >= 0", key="spring_group")
        n_groups = int(groups.max()) + 1 if len(groups) else 0
        names = tuple(self.group_names)
        if not names:
            names = tuple(f"group{g}" for g in range(n_groups))
        elif len(names) < n_groups:
            raise InputError(f"{len(names)} names for {n_groups} groups", key="group_names")
        fixed = np.unique(as_index_array(self.fixed, "fixed").ravel())
        check_range(fixed, n_nodes, "fixed")
        driven = np.unique(as_index_array(self.driven, "driven").ravel())
        check_range(driven, n_nodes, "driven")
        both = np.intersect1d(fixed, driven)
        if both.size:
            raise InputError(f"{both.size} driven nodes are also fixed (e.g. node {both[0]}): "
                             "a node is either held at rest or moved by the stage",
                             key="driven")
        tetrahedra = None
        if self.tetrahedra is not None:
            tetrahedra = check_tetrahedra(self.tetrahedra, n_nodes, positions)
        for name, value in (("rest_positions", positions), ("springs", springs),
                            ("spring_group", groups), ("group_names", names), ("fixed", fixed),
                            ("tetrahedra", tetrahedra), ("driven", driven)):
            object.__setattr__(self, name, value)
        for array in (positions, springs, groups, fixed, tetrahedra, driven):
            if array is not None:
                array.setflags(write=False)

    @property
    def n_nodes(self) -> int:
        return self.rest_positions.shape[0]

    @property
    def n_springs(self) -> int:
        return self.springs.shape[0]

    @property
    def n_groups(self) -> int:
        return len(self.group_names)

    @property
    def rest_lengths(self) -> np.ndarray:
        """(n_springs,) float: spring lengths in the rest configuration."""
        a, b = self.springs.T
        return np.linalg.norm(self.rest_positions[b] - self.rest_positions[a], axis=1)

    @property
    def n_tetrahedra(self) -> int:
        """Number of tetrahedra (0 for a mesh without them)."""
        return 0 if self.tetrahedra is None else self.tetrahedra.shape[0]

    @property
    def free(self) -> np.ndarray:
        """(n_nodes,) bool: True for nodes that are not fixed."""
        mask = np.ones(self.n_nodes, dtype=bool)
        mask[self.fixed] = False
        return mask

    def with_fixed(self, nodes: Sequence[int] | np.ndarray | None = None, *,
                   where: Callable[[np.ndarray], np.ndarray] | None = None) -> Mesh:
        """Return a copy with the given nodes fixed (replacing any earlier choice).

        Parameters
        ----------
        nodes : sequence of int, optional
            Node indices to fix.
        where : callable, optional
            Predicate on the rest positions, ``where(rest_positions) -> (n_nodes,) bool``;
            e.g. ``bottom_layer`` or ``lambda p: p[:, 2] < 0.1``. Combined with ``nodes``.
        """
        chosen = np.zeros(self.n_nodes, dtype=bool)
        if nodes is not None:
            index = as_index_array(nodes, "nodes").ravel()
            check_range(index, self.n_nodes, "nodes")
            chosen[index] = True
        if where is not None:
            mask = np.asarray(where(self.rest_positions))
            if mask.shape != (self.n_nodes,) or mask.dtype != bool:
                raise InputError(f"the predicate returned {mask.dtype} of shape {mask.shape}; "
                                 f"expected bool of shape ({self.n_nodes},)", key="where")
            chosen |= mask
        return replace(self, fixed=np.flatnonzero(chosen))

    def with_driven(self, nodes: Sequence[int] | np.ndarray) -> Mesh:
        """Return a copy whose driven set (the nodes a stage moves) is ``nodes``."""
        return replace(self, driven=nodes)

    def group_index(self, name: str) -> int:
        """Index of the spring group called ``name``."""
        if name not in self.group_names:
            raise InputError(f"no spring group {name!r}; groups are {list(self.group_names)}")
        return self.group_names.index(name)


def mesh_fingerprint(mesh: Mesh) -> str:
    """A short fingerprint of the node numbering of ``mesh``: ``"27 nodes 3f5c…"`` (the node
    count and 16 hex digits of a SHA-256 of the rest positions rounded to 0.1 µm).

    Files that name nodes by number (node-numbered force CSVs) carry it, so that they are
    refused on another mesh, whose node ``k`` is elsewhere (re-meshing renumbers nodes).
    """
    import hashlib

    quantised = np.round(np.asarray(mesh.rest_positions, float) * 1e7).astype("<i8")
    digest = hashlib.sha256(quantised.tobytes()).hexdigest()[:16]
    return f"{mesh.n_nodes} nodes {digest}"


def bottom_layer(rest_positions: np.ndarray, axis: int = 2, tol: float = 1e-9) -> np.ndarray:
    """Predicate for :meth:`Mesh.with_fixed`: nodes at the lowest coordinate along ``axis``."""
    coordinate = rest_positions[:, axis]
    span = float(np.ptp(coordinate)) or 1.0
    return coordinate <= coordinate.min() + tol * span


def as_float_array(value, key: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise InputError(f"expected numbers ({error})", key=key) from None
    if not np.all(np.isfinite(array)):
        raise InputError("contains NaN or infinite values", key=key)
    return array


def as_index_array(value, key: str) -> np.ndarray:
    try:
        array = np.array(value)
    except ValueError:          # ragged nested lists
        raise InputError("expected a rectangular array of integer indices (rows of equal "
                         "length)", key=key) from None
    if array.size == 0:
        return array.astype(np.intp).reshape(array.shape)
    if array.dtype == bool or not np.issubdtype(array.dtype, np.integer):
        if np.issubdtype(array.dtype, np.floating) and np.all(np.mod(array, 1) == 0):
            return array.astype(np.intp)
        raise InputError(f"expected integer indices, got dtype {array.dtype}", key=key)
    return array.astype(np.intp)


def check_range(index: np.ndarray, n_nodes: int, key: str) -> None:
    if index.size and (index.min() < 0 or index.max() >= n_nodes):
        bad = index[(index < 0) | (index >= n_nodes)].ravel()[0]
        raise InputError(f"node index {int(bad)} is out of range; the mesh has {n_nodes} nodes "
                         f"(valid 0..{n_nodes - 1})", key=key)


def check_tetrahedra(value, n_nodes: int, positions: np.ndarray | None = None) -> np.ndarray:
    """(n_tets, 4) node indices: in range, four distinct nodes per row, no tetrahedron twice
    and, given the ``positions``, none flat (zero volume)."""
    tetrahedra = as_index_array(value, "tetrahedra")
    if tetrahedra.ndim != 2 or tetrahedra.shape[1] != 4:
        raise InputError(f"got shape {tetrahedra.shape}; expected (n_tets, 4)", key="tetrahedra")
    check_range(tetrahedra, n_nodes, "tetrahedra")
    corners = np.sort(tetrahedra, axis=1)
    repeated = np.any(corners[:, 1:] == corners[:, :-1], axis=1)
    if repeated.any():
        bad = int(np.flatnonzero(repeated)[0])
        raise InputError(f"tetrahedron {bad} repeats a node: {tetrahedra[bad].tolist()}; "
                         "expected four distinct nodes", key="tetrahedra")
    check_unique_rows(tetrahedra, "tetrahedra", "tetrahedron", "has the same four nodes as")
    if positions is not None and len(tetrahedra):
        points = positions[tetrahedra]                          # (n_tets, 4, 3)
        edges = points[:, 1:] - points[:, :1]
        volume = np.abs(np.linalg.det(edges)) / 6.0
        size = np.max(np.abs(points - points.mean(axis=1, keepdims=True)), axis=(1, 2))
        flat = volume <= 1e-12 * size**3 / 6.0
        if flat.any():
            bad = int(np.flatnonzero(flat)[0])
            raise InputError(f"tetrahedron {bad} (nodes {tetrahedra[bad].tolist()}) has zero "
                             "volume: its four nodes lie in one plane; remove it or fix the "
                             "positions", key="tetrahedra")
    return tetrahedra


#: most cells (voxels or tetrahedra) a mesh builder makes: a 126³ lattice; the simulator's
#: step rate is about 2,000 steps/s at 10,000 springs, so far larger objects are unusable
MAX_CELLS = 2_000_000
#: memory of a mesh per cell, roughly (nodes, springs, groups and the builders' temporaries)
BYTES_PER_CELL = 400


def check_cell_count(count: float, key: str, hint: str) -> None:
    """Refuse to build a mesh of ``count`` cells above :data:`MAX_CELLS` (checked before
    anything is allocated), naming the number, the memory it would take and ``hint``."""
    if not count <= MAX_CELLS:
        raise InputError(f"would make {count:.3g} cells (about {count * BYTES_PER_CELL / 1e9:.3g}"
                         f" GB) where at most {MAX_CELLS:.3g} are allowed; {hint}", key=key)


#: largest coordinate accepted (metres): beyond it a file is in other units or corrupt
MAX_COORDINATE = 1e6


def check_coordinates(values: np.ndarray, key: str) -> None:
    """Refuse finite coordinates beyond :data:`MAX_COORDINATE` (their squares would overflow
    long before a simulation could use them); NaN and infinity are left to the caller."""
    large = np.isfinite(values) & (np.abs(np.nan_to_num(values)) > MAX_COORDINATE)
    if large.any():
        where = tuple(int(i) for i in np.argwhere(large)[0])
        raise InputError(f"coordinate {values[where]:g} at index {list(where)} is absurdly "
                         f"large (beyond {MAX_COORDINATE:g} m); positions are in metres",
                         key=key)


def check_unique_rows(index: np.ndarray, key: str, what: str, same: str) -> None:
    """Refuse a row of node indices that repeats an earlier one (in any order)."""
    rows = np.sort(index, axis=1)
    _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
    repeat = np.flatnonzero(first[inverse.ravel()] != np.arange(len(rows)))
    if repeat.size:
        bad = int(repeat[0])
        raise InputError(f"{what} {bad} {same} {what} {int(first[inverse.ravel()[bad]])} "
                         f"({index[bad].tolist()}); list each once", key=key)


def require_watertight(mesh) -> None:
    if not getattr(mesh, "is_watertight", False):
        raise InputError("the surface is not watertight (closed), so its inside is undefined; "
                         "repair it first, e.g. with trimesh.repair.fill_holes", key="mesh")
