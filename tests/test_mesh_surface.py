"""The surface of an object and the loads of a probe pressing on a patch of it."""

import numpy as np
import pytest

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.errors import InputError
from neurofuzzy.mesh import from_tetra, lattice, patch_loads, surface_nodes, surface_triangles

BLOCK = (0.04, 0.04, 0.03)


def block(shape=(4, 4, 3), spacing=0.01):
    return from_tetra(*kuhn_block(shape, spacing))


@pytest.mark.parametrize("mesh", [block(), lattice((3, 4, 2), 0.01)],
                         ids=["tetrahedra", "lattice"])
def test_surface_triangles_close_the_object_and_face_outward(mesh):
    faces = surface_triangles(mesh)
    edges = np.sort(faces[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)                                  # closed: no border edges
    corners = mesh.rest_positions[faces]
    area_normal = 0.5 * np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert np.allclose(area_normal.sum(axis=0), 0.0, atol=1e-15)
    extent = np.ptp(mesh.rest_positions, axis=0)
    volume = np.sum(np.einsum("fk,fk->f", corners.mean(axis=1), area_normal)) / 3
    assert volume == pytest.approx(np.prod(extent), rel=1e-12)   # divergence theorem: outward
    assert set(np.unique(faces)) == set(np.flatnonzero(surface_nodes(mesh)))


def test_a_patch_load_adds_up_to_the_force_and_stays_on_the_patch():
    mesh = block()
    centre, force = np.array([0.02, 0.02, 0.03]), np.array([0.01, 0.0, -0.05])
    loads = patch_loads(mesh, centre, 0.01, force)
    assert np.allclose(loads.sum(axis=0), force, rtol=1e-12)
    loaded = np.flatnonzero(np.abs(loads).sum(axis=1) > 0)
    x = mesh.rest_positions[loaded]
    assert np.allclose(x[:, 2], 0.03)                                  # the top face only
    assert np.all(np.linalg.norm(x - centre, axis=1) < 0.01 + 0.01 * np.sqrt(2))
    # symmetric patch, symmetric loads: the load's centre is the probe's centre
    centroid = (loads[:, 2, None] * mesh.rest_positions).sum(axis=0) / loads[:, 2].sum()
    assert np.allclose(centroid[:2], centre[:2], atol=1e-12)


def test_a_patch_of_uniform_pressure_on_a_fine_mesh_is_the_area_weighted_load():
    """The whole top face as the patch: every top node carries its share of the area (the
    consistent load of a uniform traction on linear triangles, area / 3 per corner)."""
    mesh = block((4, 4, 1), 0.01)
    loads = patch_loads(mesh, (0.02, 0.02, 0.01), 1.0, (0.0, 0.0, -1.6))      # all faces
    faces = surface_triangles(mesh)
    corners = mesh.rest_positions[faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)
    expected = np.zeros(mesh.n_nodes)
    np.add.at(expected, faces.ravel(), np.repeat(area / 3, 3))
    assert np.allclose(loads[:, 2], -1.6 * expected / expected.sum())


def test_a_point_load_goes_to_the_surface_point_nearest_to_it():
    mesh = block()
    on_node = patch_loads(mesh, (0.02, 0.02, 0.03), 0.0, (0, 0, -1.0))
    node = np.flatnonzero(np.abs(on_node).sum(axis=1))
    assert len(node) == 1 and np.allclose(mesh.rest_positions[node[0]], (0.02, 0.02, 0.03))
    between = patch_loads(mesh, (0.013, 0.021, 0.0305), 0.0, (0, 0, -1.0))   # just above
    loaded = np.flatnonzero(np.abs(between).sum(axis=1))
    assert len(loaded) == 3 and np.isclose(between[:, 2].sum(), -1.0)
    # the load's centre is the point's projection onto the surface
    centre = (between[:, 2, None] * mesh.rest_positions).sum(axis=0) / between[:, 2].sum()
    assert np.allclose(centre, (0.013, 0.021, 0.03), atol=1e-12)
    with pytest.raises(InputError, match="radius"):
        patch_loads(mesh, (0.02, 0.02, 0.03), -1.0, (0, 0, -1.0))
