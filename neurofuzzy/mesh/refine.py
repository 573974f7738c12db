"""Uniform refinement of a tetrahedral mesh: every tetrahedron split into eight.

A node is added at the middle of every edge; each tetrahedron gives its four corner
tetrahedra and splits the octahedron left in the middle along its shortest diagonal (Bey's
red refinement; the children's shapes stay within a bounded number of classes however often
it is applied). The old nodes keep their numbers, the new ones follow in the order of the
mesh's sorted edges, so loads and observations on the old nodes stay where they were. A new
node is fixed when both ends of its edge are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .core import TET_EDGES, Mesh
from .tetra import from_tetra

__all__ = ["Refinement", "refine"]

# the children of tetrahedron (0, 1, 2, 3) in local numbering: corners 0-3, then the edge
# midpoints 4 + k of TET_EDGES[k] = 01, 02, 03, 12, 13, 23
_CORNERS = np.array([[0, 4, 5, 6], [4, 1, 7, 8], [5, 7, 2, 9], [6, 8, 9, 3]])
# the octahedron 4..9 around each of its three diagonals (midpoint pairs of opposite edges)
_DIAGONALS = {(5, 8): [[5, 8, 4, 6], [5, 8, 6, 9], [5, 8, 9, 7], [5, 8, 7, 4]],    # 02-13
              (4, 9): [[4, 9, 5, 7], [4, 9, 7, 8], [4, 9, 8, 6], [4, 9, 6, 5]],    # 01-23
              (6, 7): [[6, 7, 4, 5], [6, 7, 5, 9], [6, 7, 9, 8], [6, 7, 8, 4]]}    # 03-12


@dataclass(frozen=True)
class Refinement:
    """A refined mesh and where it came from.

    Attributes
    ----------
    mesh : Mesh
        The refined mesh (springs on its edges, one group ``"edge"``, fixed nodes as above).
    parent : (8 n_tetrahedra,) int
        The old tetrahedron of every new one.
    edge_nodes : (n_new_nodes, 2) int
        The old nodes at the ends of the edge each new node halves (new node ``n_old + i``).
    """

    mesh: Mesh
    parent: np.ndarray
    edge_nodes: np.ndarray


def refine(mesh: Mesh) -> Refinement:
    """Split every tetrahedron of ``mesh`` into eight (module docstring)."""
    if mesh.tetrahedra is None:
        raise InputError("only a mesh of tetrahedra can be refined (a lattice has none; "
                         "split it with lattice_to_tetra first)", key="tetrahedra")
    tets = mesh.tetrahedra
    n_nodes = mesh.n_nodes
    ends = np.sort(tets[:, TET_EDGES].reshape(-1, 2), axis=1)
    keys, which = np.unique(ends[:, 0] * n_nodes + ends[:, 1], return_inverse=True)
    edge_nodes = np.stack([keys // n_nodes, keys % n_nodes], axis=1)
    rest = mesh.rest_positions
    points = np.concatenate([rest, rest[edge_nodes].mean(axis=1)])
    local = np.concatenate([tets, n_nodes + which.reshape(-1, 6)], axis=1)      # (K, 10)
    corner = [(local[:, child]) for child in _CORNERS]
    middle = np.empty((len(tets), 4, 4), dtype=np.intp)
    lengths = np.stack([np.linalg.norm(points[local[:, a]] - points[local[:, b]], axis=1)
                        for a, b in _DIAGONALS], axis=1)
    shortest = np.argmin(lengths, axis=1)
    for k, children in enumerate(_DIAGONALS.values()):
        chosen = shortest == k
        middle[chosen] = local[chosen][:, np.array(children)]
    children = np.concatenate([np.stack(corner, axis=1), middle], axis=1)     # (K, 8, 4)
    children = _positive(children.reshape(-1, 4), points)
    fine = from_tetra(points, children)
    held = np.zeros(len(points), bool)
    held[mesh.fixed] = True
    held[n_nodes:] = held[edge_nodes].all(axis=1)
    return Refinement(fine.with_fixed(np.flatnonzero(held)), np.repeat(np.arange(len(tets)), 8),
                      edge_nodes)


def _positive(tets: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The tetrahedra with their first two nodes swapped where their volume is negative."""
    corners = points[tets]
    volume = np.einsum("ij,ij->i", np.cross(corners[:, 1] - corners[:, 0],
                                            corners[:, 2] - corners[:, 0]),
                       corners[:, 3] - corners[:, 0])
    flipped = tets.copy()
    flipped[volume < 0, :2] = tets[volume < 0, 1::-1]
    return flipped
