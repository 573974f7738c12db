import numpy as np
import pytest
import trimesh

from neurofuzzy.errors import InputError
from neurofuzzy.mesh import (
    Mesh,
    bottom_layer,
    from_surface_tetra,
    from_tetra,
    from_trimesh,
    lattice,
)


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
def _kuhn_cube():
    """The unit cube split into 6 tetrahedra around its body diagonal (0,0,0)-(1,1,1)."""
    corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)
    paths = [(0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0)]
    tetrahedra = []
    for path in paths:
        corner, tet = np.zeros(3, int), [0]
        for axis in path:
            corner[axis] = 1
            tet.append(int(corner @ [4, 2, 1]))
        tetrahedra.append(tet)
    return corners, np.array(tetrahedra)


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
    with pytest.raises(InputError, match="pip install tetgen"):
        from_surface_tetra(box, max_edge=0.5)


def test_surface_nodes_of_a_lattice_and_of_a_tetrahedral_mesh():
    import trimesh

    from neurofuzzy.mesh import from_surface_tetra, surface_nodes

    cube = lattice((3, 3, 3))
    assert np.flatnonzero(~surface_nodes(cube)).tolist() == [13]
    # a block with a corner cut out: the node on the re-entrant corner has all six edge
    # neighbours but is on the surface
    from neurofuzzy.mesh import _cell_lattice

    cells = np.ones((4, 4, 3), bool)
    cells[2:, 2:, 2:] = False
    block = _cell_lattice(cells, np.ones(3), np.zeros(3), "body")
    surface = surface_nodes(block)
    corner = int(np.flatnonzero((block.rest_positions == [2, 2, 2]).all(axis=1))[0])
    edges = block.springs[block.spring_group == 0]
    assert np.count_nonzero(edges == corner) == 6 and surface[corner]
    assert (~surface).sum() == 3 * 3 * 2 - 4          # 18 inner nodes, 4 touch the cut
    tets = from_surface_tetra(trimesh.creation.box(extents=(1, 1, 1)), max_edge=0.3)
    on_faces = np.isclose(np.abs(tets.rest_positions).max(axis=1), 0.5)
    assert np.array_equal(surface_nodes(tets), on_faces)
