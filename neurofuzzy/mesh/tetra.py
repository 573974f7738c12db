"""Tetrahedral meshes: springs on the edges of tetrahedra (:func:`from_tetra`), TetGen
tetrahedralisation of a closed surface (:func:`from_surface_tetra`), and the surface nodes of a
mesh (:func:`surface_nodes`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import InputError
from .core import (MAX_CELLS, TET_EDGES, Mesh, as_float_array, as_index_array, check_cell_count,
                   check_range, require_watertight)
from .lattice import lattice_cells

__all__ = ["from_tetra", "from_surface_tetra", "surface_nodes", "lattice_to_tetra",
           "kuhn_tetrahedra", "kuhn_block"]


def from_tetra(points, tetrahedra, *, cell_region=None,
               region_names: Mapping[int, str] | None = None) -> Mesh:
    """A spring network on the edges of a tetrahedral mesh.

    Nodes are the points that belong to some tetrahedron (renumbered in the order of their
    index in ``points``; points in no tetrahedron are dropped). Springs are the unique
    tetrahedron edges, ``(a, b)`` with ``a < b``, sorted. The tetrahedra are kept on the mesh
    (``Mesh.tetrahedra``, in the new node numbering).

    Parameters
    ----------
    points : (n_points, 3) float
        Point coordinates.
    tetrahedra : (n_tets, 4) int
        Point indices of every tetrahedron.
    cell_region : (n_tets,) int, optional
        Region id of every tetrahedron (e.g. Gmsh physical tags). A spring whose every
        containing tetrahedron lies in region ``r`` goes to the spring group of ``r``; a spring
        shared by tetrahedra of different regions goes to the group ``"interface"``.
    region_names : dict of int → str, optional
        Group name of a region id (default ``"region{r}"``).

    Returns
    -------
    Mesh
        Without ``cell_region`` every spring is in one group ``"edge"``. With it, the groups
        are the regions in increasing id that own at least one spring, then ``"interface"``
        (if any spring is shared).
    """
    points = as_float_array(points, "points")
    if points.ndim != 2 or points.shape[1] != 3:
        raise InputError(f"got shape {points.shape}; expected (n_points, 3)", key="points")
    tetrahedra = as_index_array(tetrahedra, "tetrahedra")
    if tetrahedra.ndim != 2 or tetrahedra.shape[1] != 4 or len(tetrahedra) == 0:
        raise InputError(f"got shape {tetrahedra.shape}; expected (n_tets, 4) with n_tets >= 1",
                         key="tetrahedra")
    check_range(tetrahedra, len(points), "tetrahedra")
    used, local = np.unique(tetrahedra, return_inverse=True)
    local = local.reshape(tetrahedra.shape)
    n_nodes = len(used)
    edges = np.sort(local[:, TET_EDGES].reshape(-1, 2), axis=1)     # (6 n_tets, 2)
    keys, edge_spring = np.unique(edges[:, 0] * n_nodes + edges[:, 1], return_inverse=True)
    springs = np.stack([keys // n_nodes, keys % n_nodes], axis=1)
    if cell_region is None:
        spring_group = np.zeros(len(springs), dtype=np.intp)
        group_names: tuple[str, ...] = ("edge",)
    else:
        region = as_index_array(cell_region, "cell_region")
        if region.shape != (len(tetrahedra),):
            raise InputError(f"got shape {region.shape}; expected ({len(tetrahedra)},), one "
                             "region id per tetrahedron", key="cell_region")
        edge_region = np.repeat(region, len(TET_EDGES))
        lowest = np.full(len(springs), region.max())
        highest = np.full(len(springs), region.min())
        np.minimum.at(lowest, edge_spring, edge_region)
        np.maximum.at(highest, edge_spring, edge_region)
        shared = lowest != highest
        owners = np.unique(lowest[~shared])
        spring_group = np.searchsorted(owners, lowest)
        spring_group[shared] = len(owners)
        names = dict(region_names or {})
        group_names = tuple(str(names.get(int(r), f"region{int(r)}")) for r in owners)
        if shared.any():
            group_names += ("interface",)
        if len(set(group_names)) < len(group_names):
            raise InputError(f"region names must differ from each other and from 'interface'; "
                             f"got {list(group_names)}", key="region_names")
    return Mesh(rest_positions=points[used], springs=springs, spring_group=spring_group,
                group_names=group_names, tetrahedra=local)


def from_surface_tetra(surface, *, max_edge: float | None = None, quality: bool = True) -> Mesh:
    """Tetrahedralise a closed surface with TetGen and put springs on the tetrahedron edges.

    Needs the optional ``tetgen`` package (``pip install tetgen``; it installs with numpy
    only). The surface vertices are kept as nodes; TetGen adds points inside (and, with
    ``quality``, on the surface) as needed.

    Parameters
    ----------
    surface : trimesh.Trimesh
        A watertight triangle surface.
    max_edge : float, optional
        Target edge length, in the surface's length unit. TetGen bounds the volume of every
        tetrahedron by that of a regular tetrahedron with this edge, ``max_edge³ / (6√2)``, so
        edge lengths scatter around it (for a box: median 0.9, 90th percentile 1.1, largest
        1.4 × ``max_edge``). Default: no volume bound (the coarsest mesh TetGen's quality
        criterion allows).
    quality : bool
        Let TetGen add points to bound the radius-edge ratio of every tetrahedron (TetGen's
        ``-q``; default ratio 2). Without it, slivers are likely.

    Returns
    -------
    Mesh
        As :func:`from_tetra` without regions: one spring group ``"edge"``.
    """
    require_watertight(surface)
    options: dict = {"quality": bool(quality)}
    if max_edge is not None:
        if not (np.isfinite(max_edge) and max_edge > 0):
            raise InputError(f"got {max_edge}; expected a positive length", key="max_edge")
        options.update(maxvolume=float(max_edge) ** 3 / (6.0 * np.sqrt(2.0)), fixedvolume=True)
        volume = abs(float(surface.volume))
        check_cell_count(volume / options["maxvolume"], "max_edge",
                         f"a max_edge of {max_edge:g} is too fine for a volume of {volume:.3g}: "
                         "use at least about "
                         f"{np.cbrt(volume * 6.0 * np.sqrt(2.0) / MAX_CELLS) * 1.1:.3g}")
    from ..extras import require

    # fails early (tetgen runs in a child process): "… pip install 'neurofuzzy[tetra]'"
    require("tetra", "tetrahedral meshing (method 'tetra'; or the voxel lattice, from_trimesh)")
    vertices = np.asarray(surface.vertices, dtype=np.float64)
    faces = np.asarray(surface.faces, dtype=np.int32)
    # TetGen aborts the whole process (not just raises) on some bad surfaces, e.g.
    # self-intersecting ones; a child process keeps the caller alive and lets us say why.
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    from concurrent.futures.process import BrokenProcessPool

    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    try:
        with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context(method)) as pool:
            nodes, elements = pool.submit(_tetgen, vertices, faces, options).result()
    except (RuntimeError, BrokenProcessPool) as error:
        why = "it crashed" if isinstance(error, BrokenProcessPool) else str(error)
        raise InputError(f"TetGen could not tetrahedralise the surface ({why}); check it "
                         "for self-intersections, e.g. with trimesh or pymeshfix",
                         key="mesh") from None
    return from_tetra(nodes, elements)


def _tetgen(vertices: np.ndarray, faces: np.ndarray, options: dict):
    import tetgen

    return tuple(tetgen.TetGen(vertices, faces).tetrahedralize(**options)[:2])


def surface_nodes(mesh: Mesh) -> np.ndarray:
    """(n_nodes,) bool: nodes on the surface of the object, where optical markers can sit.

    Tetrahedral meshes: the corners of faces that belong to a single tetrahedron. Lattices:
    nodes that are a corner of fewer than eight complete cells.
    """
    if mesh.tetrahedra is not None:
        faces = np.sort(mesh.tetrahedra[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]]
                        .reshape(-1, 3), axis=1)
        unique, counts = np.unique(faces, axis=0, return_counts=True)
        surface = np.zeros(mesh.n_nodes, dtype=bool)
        surface[unique[counts == 1].ravel()] = True
        return surface
    cells = lattice_cells(mesh)
    if cells is None:
        raise InputError("the surface of a mesh is known for lattices and tetrahedral meshes; "
                         "this mesh is neither", key="mesh")
    return cells.cells_per_node() < 8


#: The six orders in which a cube's Kuhn tetrahedra step along the axes from corner (0,0,0)
#: to (1,1,1); every tetrahedron contains that diagonal, and neighbouring cubes split their
#: shared faces the same way (a conforming mesh).
KUHN_PATHS = ((0, 1, 2), (0, 2, 1), (1, 0, 2), (1, 2, 0), (2, 0, 1), (2, 1, 0))


def kuhn_tetrahedra(lower: np.ndarray, node_of) -> np.ndarray:
    """(6 n_cells, 4) int: the Kuhn tetrahedra of the cells whose lower corners are ``lower``
    ((n_cells, 3) int grid indices); ``node_of(corners)`` maps (n, 3) grid indices to nodes."""
    tetrahedra = []
    for path in KUHN_PATHS:
        corner, tet = lower.copy(), [node_of(lower)]
        for axis in path:
            corner = corner.copy()
            corner[:, axis] += 1
            tet.append(node_of(corner))
        tetrahedra.append(np.stack(tet, axis=1))
    return np.concatenate(tetrahedra)


def lattice_to_tetra(mesh: Mesh, *, bounds=None) -> Mesh:
    """A lattice mesh (:func:`~neurofuzzy.mesh.lattice`, :func:`~neurofuzzy.mesh.from_trimesh`)
    with every complete cubic cell split into its six Kuhn tetrahedra: the same nodes and
    fixed nodes, springs on the tetrahedron edges (:func:`from_tetra`), ready for tetrahedral
    elements.

    ``bounds`` ((2, 3): lower and upper corner), for example the bounding box of the surface
    a voxel lattice came from (:attr:`MeshFile.surface_bounds`): the nodes are stretched per
    axis so that the mesh spans it. A voxel lattice's boundary lies up to half a cell off the
    surface (a 3 cm block at 4 mm cells comes out 3.2 cm tall); elements take its true size
    (the cells become slightly rectangular, which tetrahedra do not mind).
    """
    cells = lattice_cells(mesh)
    if cells is None or not cells.cells.any():
        raise InputError("only a lattice of cubic cells can be split into tetrahedra; this "
                         "mesh is not one", key="mesh")
    lookup = np.full(cells.index.max(axis=0) + 1, -1, dtype=np.intp)
    lookup[tuple(cells.index.T)] = np.arange(mesh.n_nodes)
    tetrahedra = kuhn_tetrahedra(np.argwhere(cells.cells), lambda c: lookup[tuple(c.T)])
    points = mesh.rest_positions
    if bounds is not None:
        bounds = np.asarray(bounds, float)
        low, high = points.min(axis=0), points.max(axis=0)
        points = bounds[0] + (points - low) * (bounds[1] - bounds[0]) / (high - low)
    split = from_tetra(points, tetrahedra)
    if split.n_nodes != mesh.n_nodes:
        raise InputError(f"{mesh.n_nodes - split.n_nodes} node(s) belong to no complete cell",
                         key="mesh")
    return split.with_fixed(mesh.fixed)


def kuhn_block(shape, spacing: float = 1.0, *,
               grading=0.0) -> tuple[np.ndarray, np.ndarray]:
    """A conforming tetrahedral block: ``shape`` cubic cells per axis, each split into the six
    Kuhn tetrahedra around its (0,0,0)–(1,1,1) diagonal.

    ``grading`` (``a``, one for all axes or one per axis, ``0 <= a < 1``) makes the cells
    finer toward the block's faces and coarser in its middle, the block's size unchanged: a
    node at the fraction ``ξ`` of an axis moves to ``ξ - a sin(2πξ) / (2π)``, so the cells at
    the faces are ``1 - a`` and those in the middle ``1 + a`` times the uniform size (every
    cell stays a box, so every tetrahedron stays positive). Where plates are bonded to the top
    and bottom faces, the edges they make with the free sides are singular, and most of a
    linear tetrahedron's error there is at those edges: on a 2 cm gel cube between bonded
    plates, 12 cells a side, ``grading=0.8`` takes the plate force's error against a converged
    reference from 6.8 % to 2.7 % at ν 0.499 and 5 % strain, with the same 10,368 tetrahedra
    (``benchmarks/load_steps.py``).

    Returns
    -------
    points : (n_nodes, 3) float
        Grid nodes, ``spacing`` apart (before grading), the block's corner at the origin.
    tetrahedra : (6 · n_cells, 4) int
    """
    shape = tuple(int(n) for n in shape)
    node_shape = tuple(n + 1 for n in shape)
    grid = np.argwhere(np.ones(node_shape, bool)).astype(float)
    grading = np.broadcast_to(np.asarray(grading, float), (3,))
    if not np.all((grading >= 0) & (grading < 1)):
        raise InputError(f"grading must be at least 0 and below 1 on every axis, not "
                         f"{grading.tolist()}", key="grading")
    points = grid * spacing
    if grading.any():
        fraction = grid / np.maximum(np.array(shape, float), 1)
        graded = fraction - grading * np.sin(2 * np.pi * fraction) / (2 * np.pi)
        points = graded * np.array(shape, float) * spacing
    tetrahedra = kuhn_tetrahedra(np.argwhere(np.ones(shape, bool)),
                                 lambda corners: np.ravel_multi_index(corners.T, node_shape))
    return points, tetrahedra
