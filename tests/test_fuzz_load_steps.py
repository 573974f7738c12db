"""Property-based fuzzing of the load-step loaders (the file, the scans, the plate): a mutated
valid file either loads or raises our own error naming the file, never anything else; every
array of a load-step file replaced by one of another type or shape likewise."""

import io
import zipfile

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from neurofuzzy.io.load_steps import load_load_steps, save_load_steps
from neurofuzzy.load_steps import DrivenPath, LoadSteps
from neurofuzzy.markers.steps import read_plate, read_step_markers
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.observation import EmbeddedMarkers, embed_points
from test_fuzz_loaders import FAST, loads_or_refuses, mutated_loads_or_refuses, mutations

SCANS = (b"# length units: mm\nstep,marker,x,y,z\n0,a,1,1,1\n0,b,2,3,4\n1,a,1,1,0.9\n"
         b"1,b,2,3,3.8\n2,a,1,1,0.8\n2,b,2,3,nan\n")
PLATE = (b"# length units: mm\n# force units: mN\nstep,dx,dy,dz,fx,fy,fz\n0,0,0,0,0,0,0\n"
         b"1,0,0,-0.1,0,0,-2.5\n2,0,0,-0.2,0,0,-5.1\n")


@pytest.fixture(scope="module")
def steps_file(tmp_path_factory):
    points, tetrahedra = kuhn_block((2, 2, 2), 0.005)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    beads = np.random.default_rng(0).uniform(0.001, 0.009, size=(5, 3))
    nodes, weights, _ = embed_points(mesh, beads)
    scans = np.stack([beads, beads * 0.99, beads * 0.98])
    top = np.flatnonzero(np.isclose(points[:, 2], 0.01))
    data = LoadSteps(mesh, (DrivenPath(top, [[0, 0, -1e-4], [0, 0, -2e-4]]),),
                     EmbeddedMarkers(nodes, weights, scans), np.ones((2, 3)))
    return save_load_steps(data, tmp_path_factory.mktemp("steps") / "steps.npz")


@FAST
@given(data=st.data())
def test_mutated_load_step_files_load_or_raise_our_error(tmp_path, steps_file, data):
    mutated_loads_or_refuses(load_load_steps, tmp_path / "s.npz", steps_file.read_bytes(),
                             data)


@FAST
@given(key=st.sampled_from(["load_steps", "rest_positions", "tetrahedra", "fixed",
                            "marker_positions", "marker_nodes", "marker_weights",
                            "marker_names", "driven_nodes", "driven_set",
                            "driven_displacement", "driven_components", "driven_names",
                            "reaction"]),
       value=st.sampled_from([np.zeros(0), np.array(["x"]), np.full((2, 3), np.nan),
                              np.array([[1.5, -2.0]]), np.arange(7), np.float64(3.0),
                              np.array([True, False]), np.full((4, 4, 4), -1, int)]))
def test_load_step_arrays_of_any_type_or_shape_load_or_raise(tmp_path, steps_file, key,
                                                             value):
    with zipfile.ZipFile(steps_file) as archive:
        arrays = {name[:-4]: np.load(io.BytesIO(archive.read(name)))
                  for name in archive.namelist()}
    arrays[key] = value
    bad = tmp_path / "s.npz"
    np.savez(bad, **arrays)
    loads_or_refuses(load_load_steps, bad)


@FAST
@given(content=mutations(SCANS))
def test_mutated_scans_load_or_raise_our_error(tmp_path, content):
    path = tmp_path / "scans.csv"
    path.write_bytes(content)
    loads_or_refuses(read_step_markers, path)


@FAST
@given(content=mutations(PLATE))
def test_mutated_plate_files_load_or_raise_our_error(tmp_path, content):
    path = tmp_path / "plate.csv"
    path.write_bytes(content)
    loads_or_refuses(lambda p: read_plate(p, n_steps=2), path)
    loads_or_refuses(read_plate, path)
