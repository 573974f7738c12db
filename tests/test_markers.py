"""Marker recordings (CSV, C3D) → experiments, and `neurofuzzy import`.

The recordings are written by the tests from the cube simulated with our own simulator, so the
imported experiment can be compared with the truth.
"""

import json

import numpy as np
import pytest

from helpers import write_c3d_points

from neurofuzzy.cli import main
from neurofuzzy.datasets import CUBE, paper_cube_experiment, paper_cube_model
from neurofuzzy.errors import InputError
from neurofuzzy.io import load_experiment, save_model
from neurofuzzy.learn import GradientLearner
from neurofuzzy.markers import (MarkerImport, markers_to_experiment, read_c3d, read_forces, read_marker_csv,
                                read_marker_map, read_markers)

SURFACE = [n for n in range(27) if n != 13]



def attach(*args, **options):
    """``markers_to_experiment`` as (experiment, summary), checking the result type; markers
    follow nodes (``attach="node"``) unless said otherwise, so that positions can be
    compared node by node."""
    result = markers_to_experiment(*args, **{"attach": "node", **options})
    assert isinstance(result, MarkerImport)
    return result.experiment, result.summary

def write_marker_csv(path, experiment, nodes=SURFACE, *, unit="mm", header=True, gaps=None,
                     times=None, offset=(0.0, 0.0, 0.0), name="M{}"):
    """One row per seen marker and frame; ``gaps`` (T, N) bool leaves rows out."""
    scale = {"m": 1.0, "mm": 1e3, "cm": 1e2}[unit]
    times = np.arange(experiment.n_frames) * experiment.dt if times is None else times
    lines = [f"# units: {unit}"] if header else []
    lines.append("time,marker,x,y,z")
    for t, time in enumerate(times):
        for node in nodes:
            if gaps is not None and gaps[t, node]:
                continue
            x, y, z = (experiment.positions[t, node] + offset) * scale
            lines.append(f"{time:.9f},{name.format(node)},{x:.9f},{y:.9f},{z:.9f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def write_c3d(path, experiment, nodes=SURFACE, *, rate=None, invisible=()):
    return write_c3d_points(path, [f"M{n}" for n in nodes],
                            experiment.positions[:, nodes] * 1e3,
                            rate or 1.0 / experiment.dt, invisible)


@pytest.fixture(scope="module")
def truth():
    return paper_cube_model()


@pytest.fixture(scope="module")
def recording(truth):
    return paper_cube_experiment(truth)


def test_csv_markers_become_the_experiment_they_were_recorded_from(tmp_path, truth, recording):
    path = write_marker_csv(tmp_path / "markers.csv", recording)
    markers = read_markers(path)
    assert markers.n_markers == 26 and markers.positions.shape == (251, 26, 3)
    assert markers.frame_period == pytest.approx(CUBE["dt"])
    experiment, summary = attach(markers, truth.mesh)
    assert summary["nodes"] == SURFACE and summary["gaps"] == 0.0
    assert experiment.observed.sum() == 26 and not experiment.observed[13]
    assert np.all(np.isnan(experiment.positions[:, 13]))
    assert np.allclose(experiment.positions[:, SURFACE], recording.positions[:, SURFACE],
                       atol=1e-11)


def test_units_come_from_the_header_or_the_flag_and_must_be_stated(tmp_path, recording):
    in_cm = read_marker_csv(write_marker_csv(tmp_path / "cm.csv", recording, unit="cm"))
    in_m = read_marker_csv(write_marker_csv(tmp_path / "m.csv", recording, unit="m",
                                            header=False), units="m")
    assert np.allclose(in_cm.positions, in_m.positions, atol=2e-9)   # 9 decimals in metres
    bare = write_marker_csv(tmp_path / "bare.csv", recording, header=False)
    with pytest.raises(InputError, match=r"bare.csv: the length unit is not stated"):
        read_marker_csv(bare)
    with pytest.raises(InputError, match=r"unknown length unit 'inch'"):
        read_marker_csv(bare, units="inch")


def test_gaps_and_dropped_frames_stay_gaps(tmp_path, truth, recording):
    rng = np.random.default_rng(7)
    gaps = rng.random((251, 27)) < 0.05
    gaps[0] = False
    gaps[120] = True                            # a dropped capture frame: no rows at all
    path = write_marker_csv(tmp_path / "gappy.csv", recording, gaps=gaps)
    experiment, summary = attach(read_markers(path), truth.mesh)
    measured = experiment.measured()
    assert np.array_equal(measured[:, SURFACE], ~gaps[:, SURFACE])
    assert not measured[120].any()
    assert summary["gaps"] == pytest.approx(gaps[:, SURFACE].mean())
    # the frame after the dropped one is not interpolated from its neighbours either
    assert np.allclose(experiment.positions[measured], recording.positions[measured],
                       atol=1e-11)


def test_resampling_to_the_models_step(tmp_path, truth, recording):
    gaps = np.zeros((251, 27), bool)
    gaps[101, 26] = True
    markers = read_markers(write_marker_csv(tmp_path / "m.csv", recording, gaps=gaps))
    coarse, summary = attach(markers, truth.mesh, dt=2 * CUBE["dt"])
    assert summary["frames"] == 126
    assert np.allclose(coarse.positions[:, SURFACE], recording.positions[::2, SURFACE],
                       atol=1e-11)
    fine, _ = attach(markers, truth.mesh, dt=CUBE["dt"] / 2)
    assert fine.n_frames == 501
    middle = 0.5 * (recording.positions[10, 26] + recording.positions[11, 26])
    assert np.allclose(fine.positions[21, 26], middle, atol=1e-11)
    # frames 100.5 and 101.5 would need the missing capture 101: gaps, not interpolations
    assert np.all(np.isnan(fine.positions[[201, 202, 203], 26]))
    assert np.all(np.isfinite(fine.positions[[200, 204], 26]))


def test_c3d_markers_match_the_csv(tmp_path, truth, recording):
    c3d_file = write_c3d(tmp_path / "m.c3d", recording, invisible=[(30, 4)])
    from_c3d = read_c3d(c3d_file)
    assert from_c3d.names == tuple(f"M{n}" for n in SURFACE)
    assert from_c3d.frame_period == pytest.approx(CUBE["dt"])
    experiment, summary = attach(from_c3d, truth.mesh)
    node = SURFACE[4]
    assert not experiment.measured()[30, node] and experiment.measured()[31, node]
    ok = experiment.measured()
    # C3D stores float32 millimetres: agreement to ~1e-7 of the coordinates
    assert np.allclose(experiment.positions[ok], recording.positions[ok], atol=2e-9)


def test_a_truncated_c3d_file_is_refused(tmp_path, recording):
    good = write_c3d(tmp_path / "good.c3d", recording)
    data = good.read_bytes()
    for name, cut in (("half.c3d", len(data) // 2), ("header.c3d", 300)):
        broken = tmp_path / name
        broken.write_bytes(data[:cut])
        with pytest.raises(InputError, match=name):
            read_c3d(broken)


def test_markers_are_attached_to_their_nodes(tmp_path, truth, recording):
    """A marker glued 1 mm beside its node: the node's trajectory is the marker's minus the
    offset at frame 0."""
    offset = np.array([0.001, 0.0, 0.0])
    markers = read_markers(write_marker_csv(tmp_path / "o.csv", recording, offset=offset))
    experiment, summary = attach(markers, truth.mesh)
    assert summary["nodes"] == SURFACE
    assert np.allclose(experiment.positions[:, SURFACE], recording.positions[:, SURFACE],
                       atol=1e-11)


def test_markers_far_from_every_node_are_refused(tmp_path, truth, recording):
    markers = read_markers(write_marker_csv(tmp_path / "far.csv", recording,
                                            offset=(0.004, 0.0, 0.0), unit="mm"))
    with pytest.raises(InputError, match=r"far.csv: 26 marker\(s\) lie farther than 0.003 m "
                                         r"from every node"):
        markers_to_experiment(markers, truth.mesh, max_distance=0.003, attach="node")
    with pytest.raises(InputError, match=r"far.csv: 9 marker\(s\) lie farther than 0.003 m "
                                         r"outside the mesh"):      # the +x face's nine
        markers_to_experiment(markers, truth.mesh, max_distance=0.003)


def test_a_map_file_attaches_markers_explicitly(tmp_path, truth, recording):
    # markers named after letters, mapped by a file; one marker is left out of the map
    names = {node: f"L{chr(65 + i)}" for i, node in enumerate(SURFACE)}
    path = tmp_path / "letters.csv"
    write_marker_csv(path, recording, name="{}")
    text = path.read_text()
    for node in sorted(SURFACE, reverse=True):      # 26 before 2, so replacements stay exact
        text = text.replace(f",{node},", f",{names[node]},")
    path.write_text(text)
    map_file = tmp_path / "map.csv"
    map_file.write_text("marker,node\n" + "".join(f"{names[n]},{n}\n" for n in SURFACE[:-1]))
    mapping = read_marker_map(map_file)
    experiment, summary = attach(read_markers(path), truth.mesh, mapping=mapping)
    assert summary["unmatched"] == [names[26]]
    assert experiment.observed.sum() == 25
    assert np.allclose(experiment.positions[:, SURFACE[:-1]],
                       recording.positions[:, SURFACE[:-1]], atol=1e-11)
    map_file.write_text("marker,node\nLZZ,3\n")
    with pytest.raises(InputError, match=r"does not have; did you mean"):
        markers_to_experiment(read_markers(path), truth.mesh,
                              mapping=read_marker_map(map_file))


def test_forces_hold_until_the_next_row_of_their_node(tmp_path):
    path = tmp_path / "forces.csv"
    path.write_text("time,node,fx,fy,fz\n0.0,22,0,0,-0.2\n0.002,22,0,0,0\n0.001,5,0.1,0,0\n")
    forces = read_forces(path, n_nodes=27, times=np.arange(6) * 0.0005)
    assert np.allclose(forces[:4, 22], [0, 0, -0.2]) and np.allclose(forces[4:, 22], 0.0)
    assert np.allclose(forces[:2, 5], 0.0) and np.allclose(forces[2:, 5], [0.1, 0, 0])
    assert np.count_nonzero(np.abs(forces).sum(axis=2)) == 4 + 4
    path.write_text("time,node,fx,fy,fz\n0.0,99,0,0,-0.2\n")
    with pytest.raises(InputError, match=r"forces.csv:2: node '99' is not a node index"):
        read_forces(path, n_nodes=27, times=np.arange(6) * 0.0005)


def test_forces_at_a_point_go_to_the_nearest_surface_nodes(tmp_path, truth):
    """A probe's force at a point (mm) reaches the nearest surface node, or is shared by the
    nearest few; a probe's next row replaces its previous one; far points are refused."""
    mesh = truth.mesh
    top = int(np.argmax(paper_cube_experiment(truth).external_forces[:, 2] != 0))  # top centre
    x, y, z = 1e3 * (mesh.rest_positions[top] + [1e-4, 0, 5e-4])     # near, slightly above
    path = tmp_path / "probe.csv"
    path.write_text(f"# length units: mm\ntime,x,y,z,fx,fy,fz\n0.0,{x},{y},{z},0,0,-0.2\n"
                    f"0.001,{x},{y},{z},0,0,-0.1\n")
    times = np.arange(6) * 0.0005
    forces = read_forces(path, mesh=mesh, times=times)
    assert np.allclose(forces[:2, top], [0, 0, -0.2]) and np.allclose(forces[2:, top],
                                                                        [0, 0, -0.1])
    assert np.count_nonzero(np.abs(forces).sum(axis=2)) == 6          # one node, every frame
    shared = read_forces(path, mesh=mesh, times=times, spread=5)
    assert np.allclose(shared.sum(axis=1)[:2], [0, 0, -0.2])           # the force is kept
    assert np.count_nonzero(np.abs(shared[0]).sum(axis=1)) == 5
    assert shared[0, top, 2] < shared[0].sum(axis=0)[2] / 5            # nearest gets the most
    assert 13 not in np.flatnonzero(np.abs(shared[0]).sum(axis=1))    # never the inner node
    # two probes; a probe that moves stops pushing where it was
    corner = int(np.argmax(mesh.rest_positions.sum(axis=1)))        # a free top corner
    cx, cy, cz = mesh.rest_positions[corner]
    path.write_text(f"# length units: m\ntime,probe,x,y,z,fx,fy,fz\n"
                    f"0,a,{x / 1e3},{y / 1e3},{z / 1e3},0,0,-0.2\n"
                    f"0,b,{cx},{cy},{cz},0.1,0,0\n"
                    f"0.001,a,{cx},{cy},{cz},0,0,-0.3\n")
    moved = read_forces(path, mesh=mesh, times=times)
    assert np.allclose(moved[:2, top], [0, 0, -0.2]) and np.allclose(moved[2:, top], 0)
    assert np.allclose(moved[:2, corner], [0.1, 0, 0])
    assert np.allclose(moved[2:, corner], [0.1, 0, -0.3])
    for text, message in [
            (f"time,x,y,z,fx,fy,fz\n0,{x},{y},{z},0,0,1\n", "length units: mm"),
            (f"# length units: m\ntime,x,y,z,fx,fy,fz\n0,{x},{y},{z},0,0,1\n",
             r"probe.csv:3: the point .* farther than the longest edge"),
            (f"# length units: mm\ntime,x,y,fx,fy,fz\n0,{x},{y},0,0,1\n", "missing column 'z'")]:
        path.write_text(text)
        with pytest.raises(InputError, match=message):
            read_forces(path, mesh=mesh, times=times)


def test_a_probe_with_a_contact_radius_presses_on_a_patch(tmp_path, truth):
    """A radius (column in the file's unit, or the option in metres) spreads the force as a
    uniform traction over the surface within it: the consistent loads of patch_loads, the
    same whichever way the radius is given; a bad radius names the line."""
    from neurofuzzy.mesh import patch_loads

    mesh = truth.mesh
    point = mesh.rest_positions[22] + [0.002, -0.001, 0.0]          # on the top, off a node
    x, y, z = 1e3 * point
    path = tmp_path / "probe.csv"
    path.write_text(f"# length units: mm\ntime,x,y,z,fx,fy,fz,radius\n"
                    f"0.0,{x},{y},{z},0,0,-0.2,6\n")
    times = np.arange(4) * 0.0005
    forces = read_forces(path, mesh=mesh, times=times)
    expected = patch_loads(mesh, point, 0.006, (0, 0, -0.2))
    assert np.allclose(forces, expected[None]) and np.count_nonzero(expected[:, 2]) > 3
    path.write_text(f"# length units: mm\ntime,x,y,z,fx,fy,fz\n0.0,{x},{y},{z},0,0,-0.2\n")
    assert np.allclose(read_forces(path, mesh=mesh, times=times, radius=0.006), forces)
    path.write_text(f"# length units: mm\ntime,x,y,z,fx,fy,fz,radius\n"
                    f"0.0,{x},{y},{z},0,0,-0.2,-1\n")
    with pytest.raises(InputError, match=r"probe.csv:3: radius '-1'"):
        read_forces(path, mesh=mesh, times=times)


@pytest.mark.parametrize("text, message", [
    ("# units: mm\ntime,marker,x,y\n0,M1,1,2\n", r"missing column 'z'"),
    ("# units: mm\ntime,marker,x,y,z\n0,M1,1,2\n", r":3: 4 values; the header has 5"),
    ("# units: mm\ntime,marker,x,y,z\n0,M1,1,two,3\n", r":3: y is 'two'"),
    ("# units: mm\ntime,marker,x,y,z\n0,M1,1,2,3\n0,M1,1,2,3\n", r":4: marker 'M1' appears "
                                                             r"twice"),
    ("", r"empty file"),
])
def test_bad_marker_csv_names_file_and_line(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=r"bad.csv.*" + message):
        read_marker_csv(path)


# -- the command ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def files(tmp_path_factory, truth, recording):
    folder = tmp_path_factory.mktemp("import")
    model = save_model(truth, folder / "cube.yaml")
    gaps = np.random.default_rng(1).random((251, 27)) < 0.05
    gaps[0] = False
    markers = write_marker_csv(folder / "markers.csv", recording, gaps=gaps)
    forces = folder / "forces.csv"
    top = int(np.argmax(recording.external_forces[:, 2] != 0))
    forces.write_text(f"time,node,fx,fy,fz\n0.0,{top},0,0,{CUBE['force'][2]}\n")
    return {"model": model, "markers": markers, "forces": forces, "folder": folder}


@pytest.mark.parametrize("force_file", ["node", "point", "point, radius 0"])
def test_import_then_fit_recovers_the_cube(files, tmp_path, capsys, force_file, truth):
    forces = files["forces"]
    options = []
    if force_file.startswith("point"):        # where the probe touched (cm), not which node
        top = int(files["forces"].read_text().splitlines()[1].split(",")[1])
        x, y, z = 100 * truth.mesh.rest_positions[top]
        forces = tmp_path / "probe.csv"
        forces.write_text(f"# length units: cm\ntime,x,y,z,fx,fy,fz\n"
                          f"0.0,{x + 0.02},{y - 0.01},{z + 0.01},0,0,{CUBE['force'][2]}\n")
    if force_file.endswith("radius 0"):     # the nearest surface point: exactly the node
        forces.write_text(f"# length units: cm\ntime,x,y,z,fx,fy,fz\n"
                          f"0.0,{x},{y},{z + 0.01},0,0,{CUBE['force'][2]}\n")
        options = ["--probe-radius", "0"]
    out = tmp_path / "imported.npz"
    status = main(["import", str(files["markers"]), "--topology", str(files["model"]),
                   "--forces", str(forces), "--out", str(out), "--json", *options])
    assert status == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["markers"] == 26 and summary["frames"] == 251
    assert summary["attach"] == "embed" and summary["offset_markers"] == 0
    experiment = load_experiment(out)
    assert experiment.markers.n_markers == 26 and experiment.node_mass is not None
    start = paper_cube_model(stiffness=70.0, damping=0.03, tie="global")
    learner = GradientLearner(substeps=1).fit(start, experiment)
    assert learner.model_.springs.stiffness[0] == pytest.approx(CUBE["stiffness"], rel=1e-5)
    assert learner.model_.springs.damping[0] == pytest.approx(CUBE["damping"], rel=1e-4)


@pytest.mark.parametrize("problem, message", [
    ("missing column", "missing column 'z'"),
    ("far markers", "farther than"),
    ("truncated c3d", "truncated C3D file"),
    ("no units", "the length unit is not stated"),
    ("out is input", "never writes over its input"),
    ("unknown topology", "expected a model (.yaml) or an experiment file (.npz)"),
])
def test_import_bad_input_exits_2_and_writes_nothing(files, recording, tmp_path, capsys,
                                                     problem, message):
    markers, topology = files["markers"], files["model"]
    out = tmp_path / "out.npz"
    extra = []
    if problem == "missing column":
        markers = tmp_path / "cols.csv"
        markers.write_text("# units: mm\ntime,marker,x,y\n0,M1,1,2\n")
    elif problem == "far markers":
        markers = write_marker_csv(tmp_path / "far.csv", recording, offset=(0.05, 0.0, 0.0))
    elif problem == "truncated c3d":
        good = write_c3d(tmp_path / "good.c3d", recording).read_bytes()
        markers = tmp_path / "cut.c3d"
        markers.write_bytes(good[: len(good) // 2])
    elif problem == "no units":
        markers = write_marker_csv(tmp_path / "bare.csv", recording, header=False)
    elif problem == "out is input":
        out = topology
    elif problem == "unknown topology":
        topology = files["forces"]
    before = topology.read_bytes()
    status = main(["import", str(markers), "--topology", str(topology), "--out", str(out),
                   *extra])
    captured = capsys.readouterr()
    assert status == 2
    assert message in captured.err and "Traceback" not in captured.err
    assert len(captured.err.strip().splitlines()) == 1
    assert topology.read_bytes() == before
    assert problem == "out is input" or not out.exists()


def test_import_a_c3d_recording(files, recording, tmp_path, capsys):
    c3d_file = write_c3d(tmp_path / "trial.c3d", recording, invisible=[(50, 0), (51, 0)])
    out = tmp_path / "trial.npz"
    assert main(["import", str(c3d_file), "--topology", str(files["model"]), "--forces",
                 str(files["forces"]), "--out", str(out), "--attach", "node"]) == 0
    assert "26 markers on nodes of 27, 251 frames" in capsys.readouterr().out
    experiment = load_experiment(out)
    assert not experiment.measured()[50:52, SURFACE[0]].any()
    assert np.allclose(experiment.forces_per_frame(), recording.forces_per_frame())
