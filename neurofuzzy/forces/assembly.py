"""Node ↔ spring maps of a mesh as sparse matrices: the one assembly object of the package.

For springs ``j = (a, b)`` (``mesh.springs``): :meth:`Incidence.difference` gathers
``x_b - x_a`` per spring and :meth:`Incidence.accumulate` scatters a per-spring force to the
nodes (node a gets ``+f``, node b gets ``-f``, eq. 3.3). Both work on any trailing shape
(``(n, 3)``, ``(n, P, 3)`` …) and on component-major arrays (``(3, n)``, through
:meth:`difference_components` / :meth:`accumulate_components`, the layout of the stepper's
hot loop). One :class:`Incidence` is built per mesh and cached (:func:`incidence`).
"""

from __future__ import annotations

import weakref

import numpy as np
import scipy.sparse as sp

__all__ = ["Incidence", "incidence"]

_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class Incidence:
    """Sparse gather/scatter between the nodes and the springs of a mesh.

    Parameters
    ----------
    springs : (n_springs, 2) int
        Node index pairs ``(a, b)``.
    n_nodes : int
    dtype : numpy dtype
        Of the matrices (float64, or float32 for a float32 stepper).
    """

    def __init__(self, springs: np.ndarray, n_nodes: int, dtype=np.float64):
        self.springs = np.asarray(springs)
        self.n_nodes = int(n_nodes)
        self.n_springs = len(self.springs)
        a, b = self.springs.T
        rows = np.arange(self.n_springs)
        ones = np.ones(self.n_springs, dtype=dtype)
        #: (n_springs, n_nodes): x_b - x_a
        self.gather = sp.csr_matrix((np.r_[-ones, ones], (np.r_[rows, rows], np.r_[a, b])),
                                    shape=(self.n_springs, self.n_nodes))
        #: (n_nodes, n_springs): node a +f, node b -f
        self.scatter = (-self.gather.T).tocsr()

    def with_dtype(self, dtype) -> Incidence:
        """The same maps in another floating-point type."""
        return Incidence(self.springs, self.n_nodes, dtype)

    def difference(self, nodal: np.ndarray) -> np.ndarray:
        """(n_springs, ...) ``x_b - x_a`` of a node-major array (n_nodes, ...)."""
        return _apply(self.gather, nodal)

    def accumulate(self, per_spring: np.ndarray) -> np.ndarray:
        """(n_nodes, ...) net of a per-spring array (n_springs, ...): a gets +, b gets -."""
        return _apply(self.scatter, per_spring)

    def difference_components(self, nodal: np.ndarray) -> np.ndarray:
        """(3, n_springs) from a component-major (3, n_nodes) array."""
        return (self.gather @ nodal.T).T

    def accumulate_components(self, per_spring: np.ndarray) -> np.ndarray:
        """(3, n_nodes) from a component-major (3, n_springs) array."""
        return (self.scatter @ per_spring.T).T

    def grouped(self, group: np.ndarray, n_groups: int) -> sp.csr_matrix:
        """(n_groups · n_nodes, n_springs): :meth:`scatter` into one block of nodes per group,
        so ``(grouped @ f).reshape(n_groups, n_nodes, 3)`` is the net force of every group."""
        a, b = self.springs.T
        rows = np.arange(self.n_springs)
        ones = np.ones(self.n_springs)
        group = np.asarray(group)
        return sp.csr_matrix(
            (np.r_[ones, -ones], (np.r_[group * self.n_nodes + a, group * self.n_nodes + b],
                                  np.r_[rows, rows])),
            shape=(n_groups * self.n_nodes, self.n_springs))

    def group_sums(self, per_spring: np.ndarray, group: np.ndarray,
                   n_groups: int) -> np.ndarray:
        """(n_nodes, n_groups, 3): the net force of each group of springs, from (n_springs, 3)
        (or (n_springs, T, 3) → (n_nodes, n_groups, T, 3) for T samples)."""
        matrix = self.grouped(group, n_groups)
        out = _apply(matrix, per_spring)
        out = out.reshape(n_groups, self.n_nodes, *per_spring.shape[1:])
        return np.moveaxis(out, 0, 1)


def incidence(mesh) -> Incidence:
    """The (cached) :class:`Incidence` of ``mesh``'s springs."""
    found = _CACHE.get(mesh)
    if found is None:
        found = _CACHE[mesh] = Incidence(mesh.springs, mesh.n_nodes)
    return found


def _apply(matrix: sp.csr_matrix, array: np.ndarray) -> np.ndarray:
    """``matrix @ array`` over the first axis, any trailing shape."""
    flat = array.reshape(array.shape[0], -1)
    return np.asarray(matrix @ flat).reshape(matrix.shape[0], *array.shape[1:])
