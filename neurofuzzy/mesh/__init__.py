"""Topology of a spring-mass network: nodes, springs, spring groups and fixed nodes.

A :class:`Mesh` says what is connected to what and what is held in place; it carries no
physical parameters (those live in :class:`neurofuzzy.model.Model`).

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

The surface: :func:`surface_nodes`, :func:`surface_triangles` and :func:`patch_loads`, the
node loads of a probe pressing on a patch of the surface.

Lattice meshes carry no tetrahedra (``Mesh.tetrahedra is None``); tetrahedral meshes keep
theirs, so :mod:`neurofuzzy.rules` can weigh every spring by the volume of the tetrahedra
around it.
"""

from .core import TET_EDGES, Mesh, bottom_layer, mesh_fingerprint
from .files import MeshFile, read_mesh
from .lattice import LatticeCells, cell_lattice, from_trimesh, lattice, lattice_cells
from .surface import patch_loads, patch_weights, surface_triangles
from .tetra import (from_surface_tetra, from_tetra, kuhn_block, kuhn_tetrahedra, lattice_to_tetra,
                    surface_nodes)

__all__ = ["Mesh", "lattice", "from_trimesh", "cell_lattice", "from_tetra", "from_surface_tetra",
           "surface_nodes", "lattice_cells", "LatticeCells", "bottom_layer", "TET_EDGES",
           "read_mesh", "MeshFile", "lattice_to_tetra", "kuhn_tetrahedra", "kuhn_block", "surface_triangles",
           "patch_loads", "patch_weights", "mesh_fingerprint"]
