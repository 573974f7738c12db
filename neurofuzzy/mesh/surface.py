"""The surface of an object: its triangles, and the node loads of a probe pressing on a patch
of it.

A probe (an indenter, a palpating finger) touches a patch of the surface, not a node. The load
it applies is a traction spread over that patch; the consistent node loads of linear elements
are its integral against the nodes' barycentric (hat) functions, so a model of any resolution
receives the same total force, at the same place, distributed as the continuum would feel it.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .core import Mesh

__all__ = ["surface_triangles", "patch_loads", "patch_weights", "PATCH_QUADRATURE"]

#: Each surface triangle is cut into this many sub-triangles per edge for the patch integral
#: (n² quadrature points): a patch a tenth of a triangle across still receives points.
PATCH_QUADRATURE = 12


def surface_triangles(mesh: Mesh) -> np.ndarray:
    """(n_faces, 3) int: the triangles of the object's surface (faces of a single
    tetrahedron; a lattice is split into its Kuhn tetrahedra first), outward-oriented."""
    if mesh.tetrahedra is None:
        from .tetra import lattice_to_tetra

        mesh = lattice_to_tetra(mesh)
    tetrahedra = np.asarray(mesh.tetrahedra)
    local = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])
    faces = tetrahedra[:, local].reshape(-1, 3)                       # (4K, 3)
    opposite = tetrahedra.reshape(-1)                  # face k of a tetrahedron omits corner k
    _, first, counts = np.unique(np.sort(faces, axis=1), axis=0, return_index=True,
                                 return_counts=True)
    single = first[counts == 1]
    faces = faces[single]
    # orient outward: the fourth corner of the face's tetrahedron lies behind it
    x = mesh.rest_positions
    corners = x[faces]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    apex = x[opposite[single]]
    inward = np.einsum("fk,fk->f", normal, apex - corners[:, 0]) > 0
    faces[inward] = faces[inward][:, [0, 2, 1]]
    return faces


def _face_quadrature(n: int):
    """Barycentric coordinates (n², 3) of the centroids of the n² sub-triangles of a
    triangle's regular subdivision (equal weights)."""
    points = []
    for i in range(n):
        for j in range(n - i):
            points.append(((i + 1 / 3) / n, (j + 1 / 3) / n))          # upward sub-triangle
            if i + j < n - 1:
                points.append(((i + 2 / 3) / n, (j + 2 / 3) / n))      # downward one
    st = np.array(points)
    return np.column_stack([1.0 - st.sum(axis=1), st])


def patch_loads(mesh: Mesh, point, radius: float, force) -> np.ndarray:
    """(n_nodes, 3): consistent node loads of a uniform traction on the surface within
    ``radius`` of ``point`` that adds up to ``force``.

    Parameters
    ----------
    mesh : Mesh
    point : (3,) float
        Where the probe touches (metres; on or near the surface).
    radius : float
        Radius of the contact patch (m); a patch smaller than the surface triangles is
        resolved by sub-triangle quadrature, and ``radius = 0`` puts the whole force at the
        surface point nearest to ``point`` (shared by its triangle's corners in proportion to
        their barycentric weights).
    force : (3,) float
        Total force (N).
    """
    return patch_weights(mesh, point, radius)[:, None] * np.asarray(force, float)


def patch_weights(mesh: Mesh, point, radius: float) -> np.ndarray:
    """(n_nodes,) the share of a probe's force every node takes (summing to 1): the
    consistent loads of :func:`patch_loads` per unit force."""
    point = np.asarray(point, float)
    if not (np.isfinite(radius) and radius >= 0):
        raise InputError(f"got {radius!r}; expected a radius >= 0 (m)", key="radius")
    faces = surface_triangles(mesh)
    corners = mesh.rest_positions[faces]                               # (F, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                         corners[:, 2] - corners[:, 0]), axis=1)
    weights = _face_quadrature(PATCH_QUADRATURE)                       # (Q, 3)
    samples = np.einsum("qk,fkj->fqj", weights, corners)               # (F, Q, 3)
    inside = np.linalg.norm(samples - point, axis=2) <= radius
    shares = np.zeros(mesh.n_nodes)
    if not inside.any():      # a point, or a patch between the quadrature points: the nearest
        from trimesh.triangles import closest_point, points_to_barycentric

        # surface point, shared by its triangle's corners
        nearest = closest_point(corners, np.broadcast_to(point, (len(faces), 3)))
        face = int(np.argmin(np.linalg.norm(nearest - point, axis=1)))
        np.add.at(shares, faces[face],
                  points_to_barycentric(corners[[face]], nearest[[face]])[0])
        return shares
    per_corner = (inside * (area[:, None] / len(weights))) @ weights   # (F, 3)
    np.add.at(shares, faces.ravel(), per_corner.ravel() / per_corner.sum())
    return shares
