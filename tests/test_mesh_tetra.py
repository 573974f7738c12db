"""Tetrahedral meshes: springs on tetrahedron edges, TetGen, surface nodes."""

import numpy as np
import pytest
import trimesh

from neurofuzzy.errors import InputError
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.mesh import (Mesh, bottom_layer, from_surface_tetra, from_tetra, lattice,
                             surface_nodes)


def _kuhn_cube():
    """The unit cube split into 6 tetrahedra around its body diagonal (0,0,0)-(1,1,1)."""
    return kuhn_block((1, 1, 1))


def _tet_volumes(mesh):
    corners = mesh.rest_positions[mesh.tetrahedra]
    return np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])) / 6


def test_from_tetra_springs_are_the_unique_tetrahedron_edges():
    points, tetrahedra = _kuhn_cube()
    mesh = from_tetra(np.vstack([points, [[5.0, 5.0, 5.0]]]), tetrahedra)   # 1 unused point
    assert mesh.n_nodes == 8 and mesh.n_tetrahedra == 6
    # 12 cube edges + one diagonal on each of the 6 faces + the body diagonal
    assert mesh.n_springs == 12 + 6 + 1
    assert mesh.group_names == ("edge",) and np.all(mesh.spring_group == 0)
    assert np.all(mesh.springs[:, 0] < mesh.springs[:, 1])
    assert len({tuple(s) for s in mesh.springs.tolist()}) == mesh.n_springs
    assert np.allclose(np.sort(np.unique(np.round(mesh.rest_lengths, 12))),
                       [1.0, np.sqrt(2), np.sqrt(3)])
    assert _tet_volumes(mesh).sum() == pytest.approx(1.0)
    edges = {tuple(sorted(e)) for tet in mesh.tetrahedra.tolist()
             for e in [(tet[i], tet[j]) for i in range(4) for j in range(i + 1, 4)]}
    assert edges == {tuple(s) for s in mesh.springs.tolist()}


def test_from_tetra_groups_springs_by_region_with_an_interface():
    # two tetrahedra sharing the face (1, 2, 3)
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], float)
    tetrahedra = np.array([[0, 1, 2, 3], [4, 1, 2, 3]])
    mesh = from_tetra(points, tetrahedra, cell_region=[7, 3], region_names={7: "tumour"})
    assert mesh.group_names == ("region3", "tumour", "interface")
    counts = dict(zip(mesh.group_names, np.bincount(mesh.spring_group)))
    assert counts == {"region3": 3, "tumour": 3, "interface": 3}
    interface = mesh.springs[mesh.spring_group == mesh.group_index("interface")]
    assert {tuple(s) for s in interface.tolist()} == {(1, 2), (1, 3), (2, 3)}
    one_region = from_tetra(points, tetrahedra, cell_region=[2, 2])
    assert one_region.group_names == ("region2",) and one_region.n_springs == 9
    with pytest.raises(InputError, match=r"cell_region: got shape \(3,\); expected \(2,\)"):
        from_tetra(points, tetrahedra, cell_region=[1, 2, 3])
    with pytest.raises(InputError, match="region names must differ"):
        from_tetra(points, tetrahedra, cell_region=[1, 2], region_names={1: "a", 2: "a"})


def test_tetrahedra_are_validated_and_read_only():
    points, tetrahedra = _kuhn_cube()
    mesh = from_tetra(points, tetrahedra)
    with pytest.raises(ValueError, match="read-only"):
        mesh.tetrahedra[0, 0] = 1
    assert np.array_equal(mesh.with_fixed(where=bottom_layer).tetrahedra, mesh.tetrahedra)
    assert lattice((3, 3, 3)).tetrahedra is None and lattice((3, 3, 3)).n_tetrahedra == 0
    springs = mesh.springs
    with pytest.raises(InputError, match=r"tetrahedra: got shape \(6, 3\); expected \(n_tets, 4\)"):
        Mesh(points, springs, tetrahedra=tetrahedra[:, :3])
    with pytest.raises(InputError, match="tetrahedra: node index 8 is out of range"):
        Mesh(points, springs, tetrahedra=np.array([[0, 1, 2, 8]]))
    with pytest.raises(InputError, match=r"tetrahedron 0 repeats a node: \[0, 1, 1, 3\]"):
        Mesh(points, springs, tetrahedra=np.array([[0, 1, 1, 3]]))
    with pytest.raises(InputError, match="tetrahedra: expected integer indices"):
        Mesh(points, springs, tetrahedra=np.array([[0, 1, 2, 3.5]]))
    with pytest.raises(InputError, match="points: got shape"):
        from_tetra(points[:, :2], tetrahedra)


def test_from_surface_tetra_fills_the_closed_surface():
    pytest.importorskip("tetgen")
    box = trimesh.creation.box(extents=(2.0, 1.0, 1.0))
    coarse = from_surface_tetra(box, max_edge=0.5)
    fine = from_surface_tetra(box, max_edge=0.25)
    for mesh in (coarse, fine):
        assert _tet_volumes(mesh).sum() == pytest.approx(box.volume, rel=1e-9)
        assert _tet_volumes(mesh).min() > 0
        assert np.all(np.abs(mesh.rest_positions) <= np.array([1, 0.5, 0.5]) + 1e-12)
        # every box corner is a node
        assert all(np.any(np.all(np.isclose(mesh.rest_positions, v), axis=1))
                   for v in box.vertices)
        assert mesh.group_names == ("edge",)
    # a regular tetrahedron of edge 0.25 has volume 0.25³/(6√2): the box holds >= 2 / that
    assert fine.n_tetrahedra >= box.volume / (0.25**3 / (6 * np.sqrt(2)))
    assert fine.n_nodes > 4 * coarse.n_nodes
    assert np.median(fine.rest_lengths) < 0.25 < fine.rest_lengths.max() < 2 * 0.25


def test_from_surface_tetra_refuses_open_surfaces_and_explains_a_missing_tetgen(monkeypatch):
    box = trimesh.creation.box()
    open_box = trimesh.Trimesh(box.vertices, box.faces[:-2])
    with pytest.raises(InputError, match="watertight"):
        from_surface_tetra(open_box, max_edge=0.5)
    with pytest.raises(InputError, match="max_edge: got -1"):
        from_surface_tetra(box, max_edge=-1)
    monkeypatch.setitem(__import__("sys").modules, "tetgen", None)    # import fails
    with pytest.raises(InputError, match=r"pip install 'neurofuzzy\[tetra\]'"):
        from_surface_tetra(box, max_edge=0.5)


def test_surface_nodes_of_a_lattice_and_of_a_tetrahedral_mesh():
    cube = lattice((3, 3, 3))
    assert np.flatnonzero(~surface_nodes(cube)).tolist() == [13]
    # a block with a corner cut out: the node on the re-entrant corner has all six edge
    # neighbours but is on the surface
    from neurofuzzy.mesh import cell_lattice

    cells = np.ones((4, 4, 3), bool)
    cells[2:, 2:, 2:] = False
    block = cell_lattice(cells, np.ones(3), np.zeros(3), "body")
    surface = surface_nodes(block)
    corner = int(np.flatnonzero((block.rest_positions == [2, 2, 2]).all(axis=1))[0])
    edges = block.springs[block.spring_group == 0]
    assert np.count_nonzero(edges == corner) == 6 and surface[corner]
    assert (~surface).sum() == 3 * 3 * 2 - 4          # 18 inner nodes, 4 touch the cut
    tets = from_surface_tetra(trimesh.creation.box(extents=(1, 1, 1)), max_edge=0.3)
    on_faces = np.isclose(np.abs(tets.rest_positions).max(axis=1), 0.5)
    assert np.array_equal(surface_nodes(tets), on_faces)


def test_a_lattice_splits_into_conforming_kuhn_tetrahedra():
    from neurofuzzy.mesh import lattice_to_tetra

    cube = lattice((3, 3, 3), 0.01).with_fixed(where=bottom_layer)
    split = lattice_to_tetra(cube)
    assert split.n_nodes == 27 and split.n_tetrahedra == 8 * 6
    assert np.array_equal(split.rest_positions, cube.rest_positions)
    assert np.array_equal(split.fixed, cube.fixed)
    assert _tet_volumes(split).sum() == pytest.approx(0.02**3)
    faces = np.sort(split.tetrahedra[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]]
                    .reshape(-1, 3), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    assert set(counts.tolist()) == {1, 2}                  # conforming: inner faces shared once
    assert (counts == 1).sum() == 6 * 4 * 2                # 6 faces x 4 squares x 2 triangles
    with pytest.raises(InputError, match="only a lattice of cubic cells"):
        lattice_to_tetra(from_tetra([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2, 3]]))


def test_mesh_command_builds_elements_on_a_voxelised_surface(tmp_path):
    from helpers import cli

    from neurofuzzy.io import load_model

    trimesh.creation.box(extents=(0.03, 0.03, 0.03)).export(tmp_path / "box.stl")
    result = cli("mesh", tmp_path / "box.stl", "--pitch", "0.01", "--rules", "liver",
                 "--tissue", "liver", "--elements", "tetra", "--fix-bottom",
                 "--out", tmp_path / "box.yaml")
    assert result.returncode == 0, result.stderr
    from neurofuzzy.mesh import lattice_cells, read_mesh

    model = load_model(tmp_path / "box.yaml")
    cells = int(lattice_cells(read_mesh(tmp_path / "box.stl", pitch=0.01).mesh).cells.sum())
    assert model.elements is not None and model.mesh.n_tetrahedra == 6 * cells
    assert model.springs is None and len(model.mesh.fixed) > 0


def test_voxel_elements_take_the_surface_true_size(tmp_path):
    """A 4 x 4 x 3 cm block at 4 mm cells voxelises 3.2 cm tall; split into elements it is
    stretched onto the surface's bounding box (the volume is the block's)."""
    from helpers import cli

    from neurofuzzy.io import load_model
    from neurofuzzy.mesh import lattice_to_tetra, read_mesh

    box = trimesh.creation.box(extents=(0.04, 0.04, 0.03))
    box.apply_translation((0.02, 0.02, 0.015))
    box.export(tmp_path / "block.stl")
    read = read_mesh(tmp_path / "block.stl", pitch=0.004)
    assert np.allclose(read.surface_bounds, [[0, 0, 0], [0.04, 0.04, 0.03]])
    lattice_extent = np.ptp(read.mesh.rest_positions, axis=0)
    assert abs(lattice_extent[2] - 0.03) > 0.001                     # the voxels' own size
    split = lattice_to_tetra(read.mesh, bounds=read.surface_bounds)
    assert np.allclose(split.rest_positions.min(axis=0), 0, atol=1e-12)
    assert np.allclose(split.rest_positions.max(axis=0), (0.04, 0.04, 0.03))
    assert _tet_volumes(split).sum() == pytest.approx(0.04 * 0.04 * 0.03)
    result = cli("mesh", tmp_path / "block.stl", "--pitch", "0.004", "--rules", "liver",
                 "--tissue", "liver", "--fix-bottom", "--out", tmp_path / "block.yaml")
    assert result.returncode == 0, result.stderr
    assert np.allclose(np.ptp(load_model(tmp_path / "block.yaml").mesh.rest_positions, axis=0),
                       (0.04, 0.04, 0.03))
