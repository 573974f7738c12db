"""Topology of a spring-mass network: nodes, springs, spring groups and fixed nodes.

A :class:`Mesh` says what is connected to what and what is held in place; it carries no
physical parameters (those live in :class:`neurofuzzy.model.SpringMassModel`).

Builders
--------
lattice
    A regular grid of cubic cells with lattice edges and, optionally, body and face diagonals.
    ``lattice((3, 3, 3))`` is the paper's cube: 27 nodes, 54 edges + 32 body diagonals.
from_trimesh
    Voxelise a closed triangle surface (a :class:`trimesh.Trimesh`) and build the same kind of
    lattice from the cells that lie inside it.
from_tetra
    The edges of a tetrahedral mesh (points and tetrahedra, e.g. read with meshio), with one
    spring group per region of tetrahedra and a group ``"interface"`` between regions.
from_surface_tetra
    Tetrahedralise a closed triangle surface with TetGen (the optional ``tetgen`` package) and
    build the springs as :func:`from_tetra` does.

Lattice meshes carry no tetrahedra (``Mesh.tetrahedra is None``); tetrahedral meshes keep
theirs, so :mod:`neurofuzzy.rules` can weigh every spring by the volume of the tetrahedra
around it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from .errors import InputError

__all__ = ["Mesh", "lattice", "from_trimesh", "from_tetra", "from_surface_tetra",
           "surface_nodes", "lattice_cells", "LatticeCells",
           "bottom_layer"]

Diagonals = Literal["none", "body", "face", "both"]

#: Offsets (in grid steps) from a node to its neighbour, per spring group; each unordered pair
#: of nodes appears exactly once.
_OFFSETS: dict[str, np.ndarray] = {
    "edge": np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]]),
    "diagonal": np.array([[1, 1, 1], [1, 1, -1], [1, -1, 1], [1, -1, -1]]),
    "face_diagonal": np.array([[1, 1, 0], [1, -1, 0], [1, 0, 1], [1, 0, -1], [0, 1, 1], [0, 1, -1]]),
}
_GROUPS_FOR: dict[str, tuple[str, ...]] = {
    "none": ("edge",),
    "body": ("edge", "diagonal"),
    "face": ("edge", "face_diagonal"),
    "both": ("edge", "diagonal", "face_diagonal"),
}
#: The six edges of a tetrahedron, as pairs of its local vertex indices.
_TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]])


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

    def __post_init__(self):
        positions = _as_float_array(self.rest_positions, "rest_positions")
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise InputError(f"got shape {positions.shape}; expected (n_nodes, 3)",
                             key="rest_positions")
        n_nodes = positions.shape[0]
        springs = _as_index_array(self.springs, "springs")
        if springs.ndim != 2 or springs.shape[1] != 2:
            raise InputError(f"got shape {springs.shape}; expected (n_springs, 2)", key="springs")
        _check_range(springs, n_nodes, "springs")
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
            groups = _as_index_array(self.spring_group, "spring_group")
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
        fixed = np.unique(_as_index_array(self.fixed, "fixed").ravel())
        _check_range(fixed, n_nodes, "fixed")
        tetrahedra = None
        if self.tetrahedra is not None:
            tetrahedra = _check_tetrahedra(self.tetrahedra, n_nodes)
        for name, value in (("rest_positions", positions), ("springs", springs),
                            ("spring_group", groups), ("group_names", names), ("fixed", fixed),
                            ("tetrahedra", tetrahedra)):
            object.__setattr__(self, name, value)
        for array in (positions, springs, groups, fixed, tetrahedra):
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
            index = _as_index_array(nodes, "nodes").ravel()
            _check_range(index, self.n_nodes, "nodes")
            chosen[index] = True
        if where is not None:
            mask = np.asarray(where(self.rest_positions))
            if mask.shape != (self.n_nodes,) or mask.dtype != bool:
                raise InputError(f"the predicate returned {mask.dtype} of shape {mask.shape}; "
                                 f"expected bool of shape ({self.n_nodes},)", key="where")
            chosen |= mask
        return replace(self, fixed=np.flatnonzero(chosen))

    def group_index(self, name: str) -> int:
        """Index of the spring group called ``name``."""
        if name not in self.group_names:
            raise InputError(f"no spring group {name!r}; groups are {list(self.group_names)}")
        return self.group_names.index(name)


@dataclass(frozen=True)
class LatticeCells:
    """The cubic cells of a lattice mesh (:func:`lattice`, :func:`from_trimesh`).

    Parameters
    ----------
    index : (n_nodes, 3) int
        Grid index of every node.
    cells : (nx, ny, nz) bool
        Complete cells (all eight corners are nodes), by the grid index of their lower corner.
    spacing : float
    """

    index: np.ndarray
    cells: np.ndarray
    spacing: float

    def cells_per_node(self) -> np.ndarray:
        """(n_nodes,) int: complete cells each node is a corner of (8 inside the body)."""
        counts = np.zeros(len(self.index), dtype=int)
        for shift in np.ndindex(2, 2, 2):
            corner = self.index - np.array(shift)
            inside = np.all((corner >= 0) & (corner < np.array(self.cells.shape)), axis=1)
            counts[inside] += self.cells[tuple(corner[inside].T)]
        return counts


def lattice_cells(mesh: Mesh) -> LatticeCells | None:
    """Recover the cubic cells of a lattice mesh; ``None`` if its nodes are not on a cubic
    grid whose spacing is the shortest spring."""
    positions = mesh.rest_positions
    spacing = float(np.min(mesh.rest_lengths))
    index = np.rint((positions - positions.min(axis=0)) / spacing).astype(int)
    if not np.allclose(positions.min(axis=0) + index * spacing, positions, atol=1e-6 * spacing):
        return None
    occupied = np.zeros(index.max(axis=0) + 2, dtype=bool)
    occupied[tuple(index.T)] = True
    cells = (occupied[:-1, :-1, :-1] & occupied[1:, :-1, :-1] & occupied[:-1, 1:, :-1]
             & occupied[:-1, :-1, 1:] & occupied[1:, 1:, :-1] & occupied[1:, :-1, 1:]
             & occupied[:-1, 1:, 1:] & occupied[1:, 1:, 1:])
    return LatticeCells(index, cells, spacing)


def surface_nodes(mesh: Mesh) -> np.ndarray:
    """(n_nodes,) bool: nodes on the surface of the object, where optical markers can sit.

    Tetrahedral meshes: the corners of faces that belong to a single tetrahedron. Lattices:
    nodes that are a corner of fewer than eight complete cells.
    """
    if mesh.tetrahedra is not None:
        faces = np.sort(mesh.tetrahedra[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]]
                        .reshape(-1, 3), axis=1)
        unique, counts = np.unique(faces, axis=0, return_counts=True)
        surface = np.zeros(mesh.n_nodes, dtype=bool)
        surface[unique[counts == 1].ravel()] = True
        return surface
    cells = lattice_cells(mesh)
    if cells is None:
        raise InputError("the surface of a mesh is known for lattices and tetrahedral meshes; "
                         "this mesh is neither", key="mesh")
    return cells.cells_per_node() < 8


def bottom_layer(rest_positions: np.ndarray, axis: int = 2, tol: float = 1e-9) -> np.ndarray:
    """Predicate for :meth:`Mesh.with_fixed`: nodes at the lowest coordinate along ``axis``."""
    coordinate = rest_positions[:, axis]
    span = float(np.ptp(coordinate)) or 1.0
    return coordinate <= coordinate.min() + tol * span


def lattice(shape: Sequence[int], spacing: float | Sequence[float] = 1.0, *,
            diagonals: Diagonals = "body", origin: Sequence[float] = (0.0, 0.0, 0.0)) -> Mesh:
    """A regular lattice of cubic cells.

    Parameters
    ----------
    shape : (3,) int
        Number of nodes along x, y and z (each >= 2).
    spacing : float or (3,) float
        Distance between neighbouring nodes.
    diagonals : {"body", "face", "both", "none"}
        Which cell diagonals become springs besides the lattice edges: the 4 body diagonals of
        every cell (group ``"diagonal"``), the 2 diagonals of every cell face (group
        ``"face_diagonal"``), both, or none.
    origin : (3,) float
        Position of node 0.

    Returns
    -------
    Mesh
        Nodes numbered in C order of their grid index ``(i, j, k)``; group ``"edge"`` first.
        ``lattice((3, 3, 3))`` gives the paper's cube: 27 nodes, 54 edges, 32 body diagonals.
    """
    shape = tuple(int(n) for n in shape)
    if len(shape) != 3 or min(shape) < 2:
        raise InputError(f"got {shape}; expected three node counts, each >= 2", key="shape")
    occupied = np.ones(tuple(n - 1 for n in shape), dtype=bool)
    return _cell_lattice(occupied, np.broadcast_to(np.asarray(spacing, float), (3,)),
                         np.asarray(origin, float), diagonals)


def from_trimesh(mesh, pitch: float, *, diagonals: Diagonals = "body") -> Mesh:
    """Voxelise a closed surface into a lattice of cubic cells.

    Nodes are the centres of the voxels that trimesh marks as filled (surface and interior,
    ``mesh.voxelized(pitch).fill()``); springs are those of the cubic cells whose eight corner
    voxels are all filled, exactly as in :func:`lattice`. Voxels that belong to no complete cell
    are dropped, so every node carries at least one full cell.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        A watertight triangle surface.
    pitch : float
        Lattice spacing, in the mesh's length unit.
    diagonals : {"body", "face", "both", "none"}
        As in :func:`lattice`.
    """
    _require_watertight(mesh)
    if not (np.isfinite(pitch) and pitch > 0):
        raise InputError(f"got {pitch}; expected a positive length", key="pitch")
    grid = mesh.voxelized(pitch).fill()
    corners = np.asarray(grid.matrix, dtype=bool)
    origin = np.asarray(grid.transform[:3, 3], float)
    if min(corners.shape) < 2:
        raise InputError(f"pitch {pitch} is too coarse for a surface of extents "
                         f"{np.round(mesh.extents, 6).tolist()}; no complete cell fits inside",
                         key="pitch")
    cells = (corners[:-1, :-1, :-1] & corners[1:, :-1, :-1] & corners[:-1, 1:, :-1]
             & corners[:-1, :-1, 1:] & corners[1:, 1:, :-1] & corners[1:, :-1, 1:]
             & corners[:-1, 1:, 1:] & corners[1:, 1:, 1:])
    if not cells.any():
        raise InputError(f"pitch {pitch} is too coarse: no complete cell fits inside the surface",
                         key="pitch")
    return _cell_lattice(cells, np.full(3, float(pitch)), origin, diagonals)


def from_tetra(points, tetrahedra, *, cell_region=None,
               region_names: Mapping[int, str] | None = None) -> Mesh:
    """A spring network on the edges of a tetrahedral mesh.

    Nodes are the points that belong to some tetrahedron (renumbered in the order of their
    index in ``points``; points in no tetrahedron are dropped). Springs are the unique
    tetrahedron edges, ``(a, b)`` with ``a < b``, sorted. The tetrahedra are kept on the mesh
    (``Mesh.tetrahedra``, in the new node numbering).

    Parameters
    ----------
    points : (n_points, 3) float
        Point coordinates.
    tetrahedra : (n_tets, 4) int
        Point indices of every tetrahedron.
    cell_region : (n_tets,) int, optional
        Region id of every tetrahedron (e.g. Gmsh physical tags). A spring whose every
        containing tetrahedron lies in region ``r`` goes to the spring group of ``r``; a spring
        shared by tetrahedra of different regions goes to the group ``"interface"``.
    region_names : dict of int → str, optional
        Group name of a region id (default ``"region{r}"``).

    Returns
    -------
    Mesh
        Without ``cell_region`` every spring is in one group ``"edge"``. With it, the groups
        are the regions in increasing id that own at least one spring, then ``"interface"``
        (if any spring is shared).
    """
    points = _as_float_array(points, "points")
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"got shape {points.shape}; expected (n_points, 3)", key="points")
    tetrahedra = _as_index_array(tetrahedra, "tetrahedra")
    if tetrahedra.ndim != 2 or tetrahedra.shape[1] != 4 or len(tetrahedra) == 0:
        raise InputError(f"got shape {tetrahedra.shape}; expected (n_tets, 4) with n_tets >= 1",
                         key="tetrahedra")
    _check_range(tetrahedra, len(points), "tetrahedra")
    used, local = np.unique(tetrahedra, return_inverse=True)
    local = local.reshape(tetrahedra.shape)
    n_nodes = len(used)
    edges = np.sort(local[:, _TET_EDGES].reshape(-1, 2), axis=1)     # (6 n_tets, 2)
    keys, edge_spring = np.unique(edges[:, 0] * n_nodes + edges[:, 1], return_inverse=True)
    springs = np.stack([keys // n_nodes, keys % n_nodes], axis=1)
    if cell_region is None:
        spring_group = np.zeros(len(springs), dtype=np.intp)
        group_names: tuple[str, ...] = ("edge",)
    else:
        region = _as_index_array(cell_region, "cell_region")
        if region.shape != (len(tetrahedra),):
            raise InputError(f"got shape {region.shape}; expected ({len(tetrahedra)},), one "
                             "region id per tetrahedron", key="cell_region")
        edge_region = np.repeat(region, len(_TET_EDGES))
        lowest = np.full(len(springs), region.max())
        highest = np.full(len(springs), region.min())
        np.minimum.at(lowest, edge_spring, edge_region)
        np.maximum.at(highest, edge_spring, edge_region)
        shared = lowest != highest
        owners = np.unique(lowest[~shared])
        spring_group = np.searchsorted(owners, lowest)
        spring_group[shared] = len(owners)
        names = dict(region_names or {})
        group_names = tuple(str(names.get(int(r), f"region{int(r)}")) for r in owners)
        if shared.any():
            group_names += ("interface",)
        if len(set(group_names)) < len(group_names):
            raise InputError(f"region names must differ from each other and from 'interface'; "
                             f"got {list(group_names)}", key="region_names")
    return Mesh(rest_positions=points[used], springs=springs, spring_group=spring_group,
                group_names=group_names, tetrahedra=local)


def from_surface_tetra(surface, *, max_edge: float | None = None, quality: bool = True) -> Mesh:
    """Tetrahedralise a closed surface with TetGen and put springs on the tetrahedron edges.

    Needs the optional ``tetgen`` package (``pip install tetgen``; it installs with numpy
    only). The surface vertices are kept as nodes; TetGen adds points inside (and, with
    ``quality``, on the surface) as needed.

    Parameters
    ----------
    surface : trimesh.Trimesh
        A watertight triangle surface.
    max_edge : float, optional
        Target edge length, in the surface's length unit. TetGen bounds the volume of every
        tetrahedron by that of a regular tetrahedron with this edge, ``max_edge³ / (6√2)``, so
        edge lengths scatter around it (for a box: median 0.9, 90th percentile 1.1, largest
        1.4 × ``max_edge``). Default: no volume bound (the coarsest mesh TetGen's quality
        criterion allows).
    quality : bool
        Let TetGen add points to bound the radius-edge ratio of every tetrahedron (TetGen's
        ``-q``; default ratio 2). Without it, slivers are likely.

    Returns
    -------
    Mesh
        As :func:`from_tetra` without regions: one spring group ``"edge"``.
    """
    _require_watertight(surface)
    options: dict = {"quality": bool(quality)}
    if max_edge is not None:
        if not (np.isfinite(max_edge) and max_edge > 0):
            raise InputError(f"got {max_edge}; expected a positive length", key="max_edge")
        options.update(maxvolume=float(max_edge) ** 3 / (6.0 * np.sqrt(2.0)), fixedvolume=True)
    try:
        import tetgen
    except ImportError:
        raise InputError("tetrahedral meshing needs the optional tetgen package: "
                         "pip install tetgen, or neurofuzzy[tetra] (or use the voxel lattice, "
                         "from_trimesh)",
                         key="method") from None
    del tetgen                          # imported to fail early; it runs in a child process
    vertices = np.asarray(surface.vertices, dtype=np.float64)
    faces = np.asarray(surface.faces, dtype=np.int32)
    # TetGen aborts the whole process (not just raises) on some bad surfaces, e.g.
    # self-intersecting ones; a child process keeps the caller alive and lets us say why.
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    try:
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context(method)) as pool:
            nodes, elements = pool.submit(_tetgen, vertices, faces, options).result()
    except (RuntimeError, BrokenProcessPool) as error:
        why = "it crashed" if isinstance(error, BrokenProcessPool) else str(error)
        raise InputError(f"TetGen could not tetrahedralise the surface ({why}); check it "
                         "for self-intersections, e.g. with trimesh or pymeshfix",
                         key="mesh") from None
    return from_tetra(nodes, elements)


def _tetgen(vertices: np.ndarray, faces: np.ndarray, options: dict):
    import tetgen

    return tuple(tetgen.TetGen(vertices, faces).tetrahedralize(**options)[:2])


def _cell_lattice(cells: np.ndarray, spacing: np.ndarray, origin: np.ndarray,
                  diagonals: Diagonals) -> Mesh:
    """Springs of all complete cells ``cells`` (bool, one less than the node grid per axis)."""
    if diagonals not in _GROUPS_FOR:
        raise InputError(f"got {diagonals!r}; expected one of {list(_GROUPS_FOR)}",
                         key="diagonals")
    node_shape = tuple(n + 1 for n in cells.shape)
    # A spring with offset o starting at node n exists when some complete cell contains both
    # ends: the cell's lower corner is n - k for k in {0,1}^3 with k_i = 0 wherever o_i != 0
    # and (o_i = -1 → k_i = 1 on that axis).
    padded = np.pad(cells, 1)
    pairs, groups = [], []
    for group_index, group in enumerate(_GROUPS_FOR[diagonals]):
        for offset in _OFFSETS[group]:
            exists = np.zeros(node_shape, dtype=bool)
            free_axes = [axis for axis in range(3) if offset[axis] == 0]
            for shift in np.ndindex(*(2,) * len(free_axes)):
                lower = np.zeros(3, dtype=int)            # lower cell corner relative to n
                for axis in range(3):
                    if offset[axis] < 0:
                        lower[axis] = -1
                for axis, s in zip(free_axes, shift):
                    lower[axis] = -s
                start = lower + 1                        # +1 for the padding
                exists |= padded[start[0]:start[0] + node_shape[0],
                                 start[1]:start[1] + node_shape[1],
                                 start[2]:start[2] + node_shape[2]]
            a = np.argwhere(exists)
            b = a + offset
            pairs.append(np.stack([np.ravel_multi_index(a.T, node_shape),
                                   np.ravel_multi_index(b.T, node_shape)], axis=1))
            groups.append(np.full(len(a), group_index))
    springs = np.concatenate(pairs)
    spring_group = np.concatenate(groups)
    used = np.unique(springs)
    renumber = np.full(int(np.prod(node_shape)), -1)
    renumber[used] = np.arange(len(used))
    grid_index = np.stack(np.unravel_index(used, node_shape), axis=1)
    return Mesh(rest_positions=origin + grid_index * spacing,
                springs=renumber[springs], spring_group=spring_group,
                group_names=_GROUPS_FOR[diagonals])


def _as_float_array(value, key: str) -> np.ndarray:
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise InputError(f"expected numbers ({error})", key=key) from None
    if not np.all(np.isfinite(array)):
        raise InputError("contains NaN or infinite values", key=key)
    return array


def _as_index_array(value, key: str) -> np.ndarray:
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


def _check_range(index: np.ndarray, n_nodes: int, key: str) -> None:
    if index.size and (index.min() < 0 or index.max() >= n_nodes):
        bad = index[(index < 0) | (index >= n_nodes)].ravel()[0]
        raise InputError(f"node index {int(bad)} is out of range; the mesh has {n_nodes} nodes "
                         f"(valid 0..{n_nodes - 1})", key=key)


def _require_watertight(mesh) -> None:
    if not getattr(mesh, "is_watertight", False):
        raise InputError("the surface is not watertight (closed), so its inside is undefined; "
                         "repair it first, e.g. with trimesh.repair.fill_holes", key="mesh")


def _check_tetrahedra(value, n_nodes: int) -> np.ndarray:
    tetrahedra = _as_index_array(value, "tetrahedra")
    if tetrahedra.ndim != 2 or tetrahedra.shape[1] != 4:
        raise InputError(f"got shape {tetrahedra.shape}; expected (n_tets, 4)", key="tetrahedra")
    _check_range(tetrahedra, n_nodes, "tetrahedra")
    corners = np.sort(tetrahedra, axis=1)
    repeated = np.any(corners[:, 1:] == corners[:, :-1], axis=1)
    if repeated.any():
        bad = int(np.flatnonzero(repeated)[0])
        raise InputError(f"tetrahedron {bad} repeats a node: {tetrahedra[bad].tolist()}; "
                         "expected four distinct nodes", key="tetrahedra")
    return tetrahedra
