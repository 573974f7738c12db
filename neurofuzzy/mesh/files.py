"""Mesh files in: closed surfaces and tetrahedral volume meshes become spring networks.

:func:`read_mesh` reads

- a **surface** that trimesh reads (``.stl .obj .ply .glb .gltf .off``) and fills it with a
  voxel lattice (:func:`~neurofuzzy.mesh.from_trimesh`) or with tetrahedra
  (:func:`~neurofuzzy.mesh.from_surface_tetra`, needs the ``tetgen`` package);
- a **volume mesh** that meshio reads (``.vtu .vtk .msh .xdmf .xmf .mesh .inp``) and takes its
  tetrahedra as they are (:func:`~neurofuzzy.mesh.from_tetra`), with the regions the file
  assigns to its cells (Gmsh physical groups, Medit references, ``CellEntityIds``, or a cell
  array named ``region`` or ``tissue``).

The regions of a :class:`MeshFile` are node masks and tetrahedron masks; either can be handed
to :func:`neurofuzzy.initialize` once they are named after tissues
(:meth:`MeshFile.tissue_regions`). Tetrahedron masks are exact at interfaces. trimesh, meshio and tetgen are imported only when a file
needs them. Every failure is an :class:`~neurofuzzy.errors.InputError` naming the file.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from ..errors import InputError
from .core import Mesh
from .lattice import from_trimesh
from .tetra import from_surface_tetra, from_tetra

__all__ = ["MeshFile", "read_mesh", "SURFACE_SUFFIXES", "VOLUME_SUFFIXES", "REGION_KEYS"]

#: Surface formats, read with ``trimesh.load(path, force="mesh")``.
SURFACE_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")
#: Volume formats → the meshio reader module that reads them. (meshio's own ``meshio.read``
#: is not used: on a file it cannot parse it prints the error and calls ``sys.exit``.)
_VOLUME_READERS = {".vtu": "vtu", ".vtk": "vtk", ".msh": "gmsh", ".xdmf": "xdmf",
                   ".xmf": "xdmf", ".mesh": "medit", ".inp": "abaqus"}
VOLUME_SUFFIXES = tuple(_VOLUME_READERS)
#: Cell-data arrays that hold region ids, in order of preference ("region" and "tissue" match
#: in any letter case).
REGION_KEYS = ("gmsh:physical", "medit:ref", "CellEntityIds", "region", "tissue")
#: Default resolution of a surface: the lattice pitch is the largest extent of its bounding box
#: divided by this…
DEFAULT_DIVISIONS = 10
#: …and TetGen's target edge this factor times that: its quality meshes hold many more, smaller
#: tetrahedra than the target suggests (a 4 x 4 x 3 cm block: 776 nodes at a 6 mm target, like
#: the 1,089 of the 4 mm lattice; 2,329 at 4 mm).
TETRA_EDGE_FACTOR = 1.5

Method = Literal["voxel", "tetra"]


@dataclass(frozen=True, eq=False)
class MeshFile:
    """A mesh read from a file, with its named regions.

    Parameters
    ----------
    mesh : Mesh
        The spring network (``mesh.tetrahedra`` is set unless it is a voxel lattice).
    regions : dict of str → (n_nodes,) bool
        Region name → the nodes it owns, in increasing region id. The masks do not overlap: a
        node on an interface belongs to the region with the lowest id among its tetrahedra.
        Empty when the file assigns no regions (and for every surface file).
    source : str
        The path the mesh was read from.
    tetrahedron_regions : dict of str → (n_tetrahedra,) bool
        Region name → its tetrahedra (``mesh.tetrahedra`` rows); same names and order as
        ``regions``. They partition the tetrahedra.
    surface_bounds : (2, 3) float or None
        The bounding box of the surface a voxel lattice was made from (its boundary lies up to
        half a cell off the surface; :func:`~neurofuzzy.mesh.lattice_to_tetra` can stretch
        the split lattice onto it).
    """

    mesh: Mesh
    regions: dict[str, np.ndarray]
    source: str
    tetrahedron_regions: dict[str, np.ndarray] = field(default_factory=dict)
    surface_bounds: np.ndarray | None = None

    def tissue_regions(self, tissue_of: Mapping[str, str], *,
                       of: Literal["nodes", "tetrahedra"] = "nodes") -> dict[str, np.ndarray]:
        """Rename regions to tissues, for :func:`neurofuzzy.initialize`.

        Parameters
        ----------
        tissue_of : dict of region name → tissue name
            Regions left out take the default ``tissue`` of :func:`~neurofuzzy.tissues.initialize`;
            several regions may map to the same tissue (their masks are joined).
        of : {"nodes", "tetrahedra"}
            Node masks, for ``initialize(..., regions=...)``, or tetrahedron masks, for
            ``initialize(..., tetrahedron_regions=...)``.

        Returns
        -------
        dict of tissue name → (n_nodes,) or (n_tetrahedra,) bool
        """
        if of not in ("nodes", "tetrahedra"):
            raise InputError(f"got {of!r}; expected 'nodes' or 'tetrahedra'", key="of")
        masks = self.regions if of == "nodes" else self.tetrahedron_regions
        unknown = [name for name in tissue_of if name not in masks]
        if unknown:
            raise InputError(f"no region {unknown[0]!r}; the regions are {list(masks)}",
                             source=self.source, key="regions")
        tissues: dict[str, np.ndarray] = {}
        for region, tissue in tissue_of.items():
            joined = tissues.get(tissue, np.zeros(masks[region].shape, bool))
            tissues[tissue] = joined | masks[region]
        return tissues


def read_mesh(path: str | os.PathLike, *, pitch: float | None = None,
              max_edge: float | None = None, method: Method = "voxel") -> MeshFile:
    """Read a surface or volume mesh file as a spring network.

    Parameters
    ----------
    path : str or path
        A surface (``.stl .obj .ply .glb .gltf .off``) or a volume mesh
        (``.vtu .vtk .msh .xdmf .xmf .mesh .inp``), chosen by the file suffix.
    pitch : float, optional
        Surfaces with ``method="voxel"``: the lattice spacing. Default: the largest extent of
        the surface's bounding box / 10 (a lattice about 10 cells across).
    max_edge : float, optional
        Surfaces with ``method="tetra"``: the target tetrahedron edge length (see
        :func:`~neurofuzzy.mesh.from_surface_tetra`). Default: largest extent / 10.
    method : {"voxel", "tetra"}
        How a surface is filled: a lattice of cubic cells with body diagonals, or TetGen
        tetrahedra. Volume meshes are used as they are and ignore it.

    Returns
    -------
    MeshFile
        The mesh, its regions (volume meshes with region ids in their cell data; empty
        otherwise) and the path. Quadratic tetrahedra (``tetra10``) keep their four corners.

    Raises
    ------
    InputError
        The file is missing, has an unknown suffix, cannot be parsed (truncated or corrupt),
        is a surface that is not closed, or is a volume file without tetrahedra; ``pitch`` or
        ``max_edge`` do not fit the file or method. The message names the file.
    """
    source = str(path)
    path = Path(path)
    if not path.exists():
        raise InputError("no such file", source=source)
    if path.is_dir():
        raise InputError("is a directory, not a mesh file", source=source)
    if method not in ("voxel", "tetra"):
        raise InputError(f"got {method!r}; expected 'voxel' or 'tetra'", source=source,
                         key="method")
    suffix = path.suffix.lower()
    if suffix in SURFACE_SUFFIXES:
        mesh, bounds = _read_surface(path, source, pitch=pitch, max_edge=max_edge,
                                     method=method)
        return MeshFile(mesh=mesh, regions={}, source=source,
                        surface_bounds=bounds if method == "voxel" else None)
    if suffix in _VOLUME_READERS:
        for key, value in (("pitch", pitch), ("max_edge", max_edge)):
            if value is not None:
                raise InputError(f"a volume mesh is used as it is; {key} applies only to "
                                 f"surface files ({', '.join(SURFACE_SUFFIXES)})",
                                 source=source, key=key)
        return _read_volume(path, source, _VOLUME_READERS[suffix])
    raise InputError(f"unknown mesh file type {suffix or '(no suffix)'!r}; supported are "
                     f"surfaces {' '.join(SURFACE_SUFFIXES)} and volume meshes "
                     f"{' '.join(VOLUME_SUFFIXES)}", source=source)


def _read_surface(path: Path, source: str, *, pitch, max_edge, method: Method):
    """The mesh of a surface file, and the surface's bounding box (2, 3)."""
    wrong = ("max_edge", max_edge) if method == "voxel" else ("pitch", pitch)
    if wrong[1] is not None:
        raise InputError(f"does not apply to method={method!r}; the voxel lattice takes "
                         "pitch, the tetrahedral mesh (method='tetra') max_edge", source=source,
                         key=wrong[0])
    if path.suffix.lower() == ".stl":
        _check_binary_stl_length(path, source)
    import trimesh

    try:
        surface = trimesh.load(str(path), force="mesh")
    except (ValueError, OSError, KeyError, IndexError, EOFError, TypeError, AttributeError,
            struct.error, zlib.error, OverflowError, MemoryError, AssertionError) as error:
        raise InputError(f"not a readable {path.suffix} surface, perhaps truncated or corrupt "
                         f"({_describe(error)})", source=source) from None
    except ImportError as error:        # trimesh imports some parsers' helpers on demand
        raise InputError(f"trimesh needs an optional package to read this file ({error}); "
                         "install it or save the surface as binary STL or PLY",
                         source=source) from None
    if not isinstance(surface, trimesh.Trimesh) or len(surface.faces) == 0:
        raise InputError("contains no triangles; expected a closed triangle surface",
                         source=source)
    size = float(np.max(surface.extents))
    bounds = np.array(surface.bounds, float)
    try:
        if method == "voxel":
            return from_trimesh(surface, pitch if pitch is not None
                                else size / DEFAULT_DIVISIONS), bounds
        return from_surface_tetra(surface, max_edge=max_edge if max_edge is not None
                                  else TETRA_EDGE_FACTOR * size / DEFAULT_DIVISIONS), bounds
    except InputError as error:
        raise InputError(error.detail, source=source, key=error.key) from None


def _check_binary_stl_length(path: Path, source: str) -> None:
    """A binary STL states its triangle count; a shorter file was cut off.

    (trimesh would fall back to its ASCII parser and fail with an unrelated message.)
    """
    with open(path, "rb") as handle:
        head = handle.read(84)
    if head.lstrip()[:5].lower() == b"solid" or len(head) == 0:
        return                                          # ASCII STL (or empty: no triangles)
    size = path.stat().st_size
    count = int.from_bytes(head[80:84], "little") if len(head) == 84 else None
    if count is None or size < 84 + 50 * count:
        expected = "at least 84" if count is None else f"{84 + 50 * count}"
        raise InputError(f"truncated binary STL: the header promises "
                         f"{'?' if count is None else count} triangles "
                         f"({expected} bytes) but the file has {size} bytes", source=source)


def _read_volume(path: Path, source: str, reader: str) -> MeshFile:
    try:
        import meshio
    except ImportError:
        raise InputError("reading volume meshes needs meshio: pip install meshio",
                         source=source) from None
    _CorruptionError = _meshio_corruption_error(meshio)
    try:
        data = getattr(meshio, reader).read(str(path))
    except ImportError as error:        # e.g. XDMF with HDF5 data needs h5py
        raise InputError(f"meshio needs an optional package to read {path.suffix} files "
                         f"({error})", source=source) from None
    # meshio's readers report a malformed file as ReadError, but a truncated one often as the
    # numpy/parsing error it runs into (ValueError, IndexError, KeyError) and the legacy VTK
    # reader as an AssertionError on the file content.
    except (meshio.ReadError, _CorruptionError, ValueError, OSError, KeyError, IndexError,
            EOFError, AssertionError, TypeError, AttributeError, SyntaxError, struct.error,
            zlib.error, OverflowError, MemoryError) as error:
        raise InputError(f"not a readable {reader} file, perhaps truncated or corrupt "
                         f"({_describe(error)})", source=source) from None
    blocks = [i for i, block in enumerate(data.cells) if block.type in ("tetra", "tetra10")]
    if not blocks or sum(len(data.cells[i].data) for i in blocks) == 0:
        found = sorted({block.type for block in data.cells if len(block.data)})
        raise InputError(f"has no tetrahedra (found {', '.join(found) or 'no cells'}); "
                         "neurofuzzy needs a volume mesh — mesh the volume (e.g. gmsh -3), or "
                         "read a closed surface (.stl, .obj, .ply) with method='tetra' or "
                         "'voxel'", source=source)
    tetrahedra = np.concatenate([np.asarray(data.cells[i].data)[:, :4] for i in blocks])
    key = next((k for k in REGION_KEYS[:3] if k in data.cell_data), None) or next(
        (k for k in data.cell_data if k.lower() in REGION_KEYS[3:]), None)
    region = names = None
    if key is not None:
        region = np.concatenate([np.asarray(data.cell_data[key][i]).reshape(-1)
                                 for i in blocks])
        if len(region) != len(tetrahedra):
            raise InputError(f"cell data {key!r} has {len(region)} values for "
                             f"{len(tetrahedra)} tetrahedra; expected one per cell",
                             source=source, key=key)
        names = _volume_names(data.field_data)
    try:
        mesh = from_tetra(data.points, tetrahedra, cell_region=region, region_names=names)
    except InputError as error:
        raise InputError(error.detail, source=source, key=error.key) from None
    if region is None:
        return MeshFile(mesh=mesh, regions={}, source=source)
    nodes, cells = _region_masks(mesh, np.asarray(region).astype(np.intp), names)
    return MeshFile(mesh=mesh, regions=nodes, source=source, tetrahedron_regions=cells)


def _volume_names(field_data: dict) -> dict[int, str]:
    """Gmsh physical names of volumes: meshio's ``field_data`` maps name → [tag, dimension]."""
    names = {}
    for name, value in field_data.items():
        value = np.asarray(value).ravel()
        if value.size >= 2 and np.issubdtype(value.dtype, np.number) and int(value[1]) == 3:
            names[int(value[0])] = str(name)
    return names


def _region_masks(mesh: Mesh, region: np.ndarray,
                  names: dict) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Node and tetrahedron masks per region id, in increasing id; a node goes to the lowest
    region id among its tetrahedra."""
    node_region = np.full(mesh.n_nodes, region.max())
    np.minimum.at(node_region, mesh.tetrahedra.ravel(), np.repeat(region, 4))
    nodes, tetrahedra = {}, {}
    for r in np.unique(region):
        name = str(names.get(int(r), f"region{int(r)}"))
        nodes[name], tetrahedra[name] = node_region == r, region == r
        nodes[name].setflags(write=False)
        tetrahedra[name].setflags(write=False)
    return nodes, tetrahedra


def _meshio_corruption_error(meshio) -> type:
    """meshio's CorruptionError (a bad VTU array) is not exported and not a ReadError."""
    return getattr(getattr(meshio, "_exceptions", None), "CorruptionError", meshio.ReadError)


def _describe(error: BaseException) -> str:
    return f"{type(error).__name__}: {error}" if str(error) else type(error).__name__
