"""Lattices of cubic cells: :func:`lattice`, :func:`from_trimesh` (a voxelised closed surface),
and the recovery of the cells of a lattice mesh (:func:`lattice_cells`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from ..errors import InputError
from .core import MAX_CELLS, Mesh, check_cell_count, require_watertight

__all__ = ["lattice", "from_trimesh", "cell_lattice", "LatticeCells", "lattice_cells",
           "Diagonals"]

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
    check_cell_count(float(np.prod([n - 1 for n in shape], dtype=float)), "shape",
                     "use fewer nodes")
    occupied = np.ones(tuple(n - 1 for n in shape), dtype=bool)
    return cell_lattice(occupied, np.broadcast_to(np.asarray(spacing, float), (3,)),
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
    require_watertight(mesh)
    if not (np.isfinite(pitch) and pitch > 0):
        raise InputError(f"got {pitch}; expected a positive length", key="pitch")
    extents = np.asarray(mesh.extents, float)
    smallest = float(np.cbrt(np.prod(extents + 2 * pitch) / MAX_CELLS)) * 1.1
    check_cell_count(float(np.prod(np.floor(extents / pitch) + 2)), "pitch",
                     f"a pitch of {pitch:g} is too fine for a surface of extents "
                     f"{np.round(extents, 6).tolist()}: use at least about {smallest:.3g}")
    try:
        grid = mesh.voxelized(pitch).fill()
    except (ValueError, IndexError, MemoryError) as error:      # trimesh's subdivision
        raise InputError(f"trimesh cannot voxelise the surface at pitch {pitch:g} ({error}); "
                         "check it for degenerate or far-off triangles", key="pitch") from None
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
    return cell_lattice(cells, np.full(3, float(pitch)), origin, diagonals)


def cell_lattice(cells: np.ndarray, spacing: np.ndarray, origin: np.ndarray,
                  diagonals: Diagonals) -> Mesh:
    """The lattice of the cubic cells marked in ``cells`` ((nx, ny, nz) bool, one less than
    the node grid per axis; cell ``(i, j, k)`` has its lower corner at
    ``origin + (i, j, k) * spacing``), with the springs of every marked cell."""
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
