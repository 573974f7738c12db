"""The Mesh value object: fixed nodes and the checks of its arrays."""

import numpy as np
import pytest

from neurofuzzy.errors import InputError
from neurofuzzy.mesh import Mesh, bottom_layer, lattice


def test_fixed_nodes_by_index_and_by_predicate():
    cube = lattice((3, 3, 3))
    bottom = cube.with_fixed(where=bottom_layer)
    assert len(bottom.fixed) == 9
    assert np.all(cube.rest_positions[bottom.fixed, 2] == 0.0)
    both = cube.with_fixed([26], where=lambda p: p[:, 0] == 0)
    assert 26 in both.fixed and len(both.fixed) == 10
    with pytest.raises(InputError, match="out of range"):
        cube.with_fixed([27])


def test_bad_meshes_are_refused_with_clear_messages():
    with pytest.raises(InputError, match=r"expected \(n_nodes, 3\)"):
        Mesh(np.zeros((4, 2)), np.array([[0, 1]]))
    with pytest.raises(InputError, match="node index 5 is out of range"):
        Mesh(np.eye(3), np.array([[0, 5]]))
    with pytest.raises(InputError, match="itself"):
        Mesh(np.eye(3), np.array([[1, 1]]))
    with pytest.raises(InputError, match="NaN"):
        Mesh(np.array([[0, 0, np.nan], [1, 0, 0]]), np.array([[0, 1]]))


# -- tetrahedral meshes -------------------------------------------------------------------------
