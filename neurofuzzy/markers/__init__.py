"""Optical marker recordings → experiments: CSV and C3D readers, marker-to-node matching,
resampling to the model's step, applied forces.

A recording is a :class:`MarkerData`: marker names, capture times and positions (NaN where a
marker was not seen). :func:`markers_to_experiment` attaches the markers to nodes of a mesh and
writes them into an :class:`~neurofuzzy.experiment.Experiment` of the DESIGN.md contract: the
nodes with markers are ``observed``, the others are not, and every frame in which a marker was
not seen (occlusion, a dropped capture frame) is a gap, NaN, that the learners treat as "not
measured then". Nothing is interpolated across a gap.

File formats
------------
Marker CSV
    Columns ``time,marker,x,y,z`` (header required; ``node`` instead of ``marker`` names the
    node directly). One row per marker and capture frame; a missing row or an empty/``nan``
    coordinate is a marker not seen. The length unit must be stated, either in a comment line
    ``# units: mm`` (m, cm or mm) or with ``units=`` (both, differently, is refused);
    coordinates are converted to metres. Time in seconds, unless ``# time units: ms``.
C3D
    Read with the ``c3d`` package (pure Python). The unit comes from ``POINT:UNITS`` (a
    ``units=`` that differs is refused), the rate from the header; points with a negative
    residual are "not seen". Times start at 0 s at the file's first frame (force CSV times
    count from there).
Map CSV
    Columns ``marker,node``: which node each marker is attached to. Without a map, each marker
    goes to the node nearest to its first seen position, and must lie within ``max_distance``.
Force CSV
    Columns ``time,node,fx,fy,fz``. A node's force holds from its row's time until the next
    row of that node (zero before its first row); :func:`write_node_forces` writes the file
    with a ``# mesh:`` line naming the mesh it was made for, and it is refused on another.
    Or, recommended, ``time,x,y,z,fx,fy,fz`` (and optional ``probe`` and ``radius``
    columns): a probe's force at a point, which goes to the nearest surface node (or is
    shared by the ``force_spread`` nearest, or spread over the contact radius); the points'
    unit is stated in a line ``# length units: mm``. Forces in newtons unless
    ``# force units: mN``, times in seconds unless ``# time units: ms``. See
    :func:`read_forces` for what is refused.
"""

from .attach import MarkerImport, match_markers, markers_to_experiment
from .forces import write_node_forces
from .readers import (LENGTH_UNITS, MarkerData, read_c3d, read_forces, read_marker_csv,
                      read_marker_map, read_markers)

__all__ = ["MarkerData", "MarkerImport", "read_markers", "read_marker_csv", "read_c3d",
           "read_marker_map", "read_forces", "write_node_forces", "match_markers",
           "markers_to_experiment", "LENGTH_UNITS"]
