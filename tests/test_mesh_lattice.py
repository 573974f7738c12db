"""Lattices of cubic cells: the paper's cube and voxelised surfaces."""

import numpy as np
import pytest
import trimesh

from neurofuzzy.errors import InputError
from neurofuzzy.mesh import from_trimesh, lattice


def _pairs(mesh):
    return {tuple(sorted(map(tuple, np.round(mesh.rest_positions[s], 9)))) for s in mesh.springs}


def test_paper_cube_has_27_nodes_and_86_springs():
    cube = lattice((3, 3, 3))
    assert cube.n_nodes == 27
    assert cube.n_springs == 86
    assert cube.group_names == ("edge", "diagonal")
    assert np.bincount(cube.spring_group).tolist() == [54, 32]
    lengths = cube.rest_lengths
    assert np.allclose(lengths[cube.spring_group == 0], 1.0)
    assert np.allclose(lengths[cube.spring_group == 1], np.sqrt(3.0))


def test_springs_are_unique_and_diagonals_lie_in_cells():
    cube = lattice((3, 4, 2), spacing=0.5, diagonals="both")
    assert len({tuple(sorted(s)) for s in cube.springs.tolist()}) == cube.n_springs
    cells = 2 * 3 * 1
    assert np.bincount(cube.spring_group).tolist() == [
        2 * 4 * 2 + 3 * 3 * 2 + 3 * 4 * 1,   # edges along x, y, z
        4 * cells,                           # body diagonals
        2 * (2 * 3 * 2 + 2 * 1 * 4 + 3 * 1 * 3)]  # 2 per face: xy, xz, yz faces
    assert lattice((3, 3, 3), diagonals="none").n_springs == 54
    assert lattice((3, 3, 3), diagonals="face").n_springs == 54 + 72


def test_from_trimesh_box_gives_the_lattice():
    box = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    voxel = from_trimesh(box, pitch=1.0)
    expected = lattice((3, 3, 3), 1.0, origin=(-1.0, -1.0, -1.0))
    assert voxel.n_nodes == 27 and voxel.n_springs == 86
    assert _pairs(voxel) == _pairs(expected)


def test_from_trimesh_icosphere_fills_the_ball():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    mesh = from_trimesh(sphere, pitch=0.25)
    radius = np.linalg.norm(mesh.rest_positions, axis=1)
    assert radius.max() <= 1.0 + 0.25 * np.sqrt(3) / 2 + 1e-9
    # nodes fill the ball: about its volume over the cell volume, surface voxels included
    assert 0.8 * (4 / 3 * np.pi / 0.25**3) < mesh.n_nodes < 2.0 * (4 / 3 * np.pi / 0.25**3)
    assert np.allclose(np.unique(np.round(mesh.rest_lengths, 9)), [0.25, 0.25 * np.sqrt(3)])
    # every node belongs to a complete cell, so it has at least 3 edges and 1 diagonal
    degree = np.bincount(mesh.springs.ravel(), minlength=mesh.n_nodes)
    assert degree.min() >= 4


def test_from_trimesh_rejects_open_surfaces():
    box = trimesh.creation.box()
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2])
    with pytest.raises(InputError, match="watertight"):
        from_trimesh(open_box, pitch=0.1)
