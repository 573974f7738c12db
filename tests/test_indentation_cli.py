"""An indentation test from the command line, as a lab's files arrive: scans of beads in mm at
a few load steps, the indenter's path and load cell per step, ``import --tool --tool-path``
then ``fit``; and each bad input a clear message with exit status 2 and nothing written."""

import json

import numpy as np
import pytest

from helpers import cli, write_c3d_points
from neurofuzzy.io import save_model
from neurofuzzy.load_steps import ToolPath, simulate_load_steps
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points
from neurofuzzy.simulation.contact import Sphere

WIDTH, HEIGHT, RADIUS = 0.02, 0.01, 0.005
DEPTHS = (2e-4, 4e-4, 6e-4)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A gel block (E 6 kPa, ν 0.45) on a fixed base, a sphere pressed into the middle of its
    top: the model file a user meshes (the start: E 3 kPa), the scans, the tool's path with
    its load cell, and the same without the force."""
    folder = tmp_path_factory.mktemp("indentation")
    points, tetrahedra = kuhn_block((6, 6, 3), WIDTH / 6)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=1.0,
                            density=1000.0)
    save_model(truth.with_elements(youngs_modulus=3000.0), folder / "model.yaml")
    centre = np.array([WIDTH / 2, WIDTH / 2, HEIGHT + RADIUS])
    path = centre - np.outer([0.0, *DEPTHS], (0, 0, 1))
    beads = np.random.default_rng(2).uniform((0.2 * WIDTH, 0.2 * WIDTH, 0.2 * HEIGHT),
                                             (0.8 * WIDTH, 0.8 * WIDTH, 0.9 * HEIGHT),
                                             size=(30, 3))
    nodes, weights, _ = embed_points(mesh, beads)
    data = simulate_load_steps(truth, [], EmbeddedMarkers(nodes, weights, np.zeros((4, 30, 3))),
                               marker_noise=2e-6, force_noise=1e-6, seed=4,
                               tool=ToolPath(Sphere(RADIUS), path))
    rows = ["# length units: mm", "step,marker,x,y,z"]
    for step, scan in enumerate(data.markers.positions):
        rows += [f"{step},bead{i},{x * 1e3:.6f},{y * 1e3:.6f},{z * 1e3:.6f}"
                 for i, (x, y, z) in enumerate(scan)]
    (folder / "scans.csv").write_text("\n".join(rows) + "\n")
    tool = ["# length units: mm", "# force units: mN", "step,x,y,z,fx,fy,fz",
            "0," + ",".join(f"{v * 1e3:.6f}" for v in path[0]) + ",0,0,0"]
    tool += [f"{s},"
             + ",".join(f"{v * 1e3:.6f}" for v in path[s]) + ","
             + ",".join(f"{f * 1e3:.6f}" for f in data.reaction[s - 1])
             for s in range(1, 4)]
    (folder / "tool.csv").write_text("\n".join(tool) + "\n")
    (folder / "tool-no-force.csv").write_text("\n".join(
        ["# length units: mm", "step,x,y,z"]
        + [f"{s}," + ",".join(f"{v * 1e3:.6f}" for v in path[s]) for s in range(4)]) + "\n")
    return folder


def _import(lab, tool_file, out, *extra, tool="sphere:R=5mm"):
    return cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--tool", tool,
               "--tool-path", lab / tool_file, "--out", out, *extra)


def test_an_indentation_from_files_fits_e_and_nu_and_says_what_it_cannot(lab, tmp_path):
    """With the load cell: E and ν near the truth; without it: E unidentifiable, no word,
    ν found; the report draws the sphere's force."""
    result = _import(lab, "tool.csv", tmp_path / "pressed.npz", "--json")
    assert result.returncode == 0, result.stderr
    summary = json.loads(result.stdout)
    assert summary["tool"] == "sphere" and summary["load_cell"] and summary["markers"] == 30
    assert summary["depth"] == pytest.approx(6e-4, rel=1e-6)
    fitted = cli("fit", tmp_path / "pressed.npz", "--start", lab / "model.yaml", "--json",
                 "--report", tmp_path / "report.html")
    assert fitted.returncode == 0, fitted.stderr
    values = json.loads(fitted.stdout)
    assert values["youngs_modulus"] == pytest.approx(6000.0, rel=0.02)
    assert values["poisson_ratio"] == pytest.approx(0.45, abs=0.02)
    assert "sphere" in (tmp_path / "report.html").read_text()
    assert _import(lab, "tool-no-force.csv", tmp_path / "shape.npz").returncode == 0
    shape = cli("fit", tmp_path / "shape.npz", "--start", lab / "model.yaml", "--json")
    assert shape.returncode == 0, shape.stderr
    record = json.loads(shape.stdout)
    assert "youngs_modulus" in record["unidentifiable"] and record["youngs_modulus"] is None
    assert record["poisson_ratio"] == pytest.approx(0.45, abs=0.03)
    diagnosed = cli("diagnose", tmp_path / "shape.npz", "--start", lab / "model.yaml",
                    "--json", "--quiet")
    assert diagnosed.returncode == 0, diagnosed.stderr
    answer = json.loads(diagnosed.stdout)        # the diagnosis makes no E up either
    assert "youngs_modulus" in answer["unidentifiable"] and answer["youngs_modulus"] is None


@pytest.mark.parametrize("case, words", [
    ("inside", "starts inside the body"),
    ("jump", "more than its radius"),
    ("no_units", "length unit"),
    ("no_path", "--tool-path is missing"),
    ("bad_kind", "KIND:R=RADIUS"),
    ("with_plate", "take no plate"),
    ("some_quaternion", "names some of qw, qx, qy, qz"),
    ("zero_quaternion", "is zero or not finite"),
])
def test_bad_indentation_input_is_refused_with_exit_2_and_nothing_written(lab, tmp_path, case,
                                                                         words):
    text = (lab / "tool-no-force.csv").read_text().splitlines()
    bad = tmp_path / "bad.csv"
    out = tmp_path / "out.npz"
    if case == "inside":
        bad.write_text("\n".join(text[:2] + ["0,10,10,14"] + text[3:]) + "\n")
    elif case == "jump":
        bad.write_text("\n".join(text[:-1] + ["3,10,10,2"]) + "\n")
    elif case == "no_units":
        bad.write_text("\n".join(text[1:]) + "\n")
    elif case == "some_quaternion":
        bad.write_text("\n".join(text[:1] + [text[1] + ",qw,qx"]
                                 + [row + ",1,0" for row in text[2:]]) + "\n")
    elif case == "zero_quaternion":
        bad.write_text("\n".join(text[:1] + [text[1] + ",qw,qx,qy,qz"]
                                 + [row + (",0,0,0,0" if k == 2 else ",1,0,0,0")
                                    for k, row in enumerate(text[2:])]) + "\n")
    else:
        bad.write_text("\n".join(text) + "\n")
    if case == "no_path":
        result = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--tool",
                     "sphere:R=5mm", "--out", out)
    elif case == "bad_kind":
        result = _import(lab, "tool-no-force.csv", out, tool="cone:R=5mm")
    elif case == "with_plate":
        result = _import(lab, "tool-no-force.csv", out, "--displacements", bad)
    else:
        result = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--tool",
                     "sphere:R=5mm", "--tool-path", bad, "--out", out)
    assert result.returncode == 2, result.stderr
    assert words in result.stderr and "Traceback" not in result.stderr
    assert not out.exists()


def _force_file(lab, folder, rows=None, units="# force units: mN"):
    """``folder / force.csv``: the load cell of ``lab / tool.csv`` in a file of its own
    (``step,fx,fy,fz``), its ``rows`` (default: all of steps 0..3)."""
    lines = (lab / "tool.csv").read_text().splitlines()[3:]
    chosen = [line.split(",") for line in lines]
    chosen = [row for row in chosen if rows is None or int(row[0]) in rows]
    text = [units, "step,fx,fy,fz"] + [",".join([row[0], *row[4:7]]) for row in chosen]
    (folder / "force.csv").write_text("\n".join(line for line in text if line) + "\n")
    return folder / "force.csv"


def test_a_tool_s_load_cell_in_a_file_of_its_own_is_read_as_the_path_s(lab, tmp_path):
    """``--tool-force FORCE.csv`` (``step,fx,fy,fz``, its units line) beside a path with no
    force gives the load-step file the same load cell as the path's own columns; given twice,
    missing a step, without a unit or beside a plate, it is refused (exit 2, nothing
    written)."""
    from neurofuzzy.io.load_steps import load_load_steps

    inline, separate = tmp_path / "inline.npz", tmp_path / "separate.npz"
    assert _import(lab, "tool.csv", inline).returncode == 0
    force = _force_file(lab, tmp_path)
    done = _import(lab, "tool-no-force.csv", separate, "--tool-force", force)
    assert done.returncode == 0, done.stderr
    assert "with the load cell's force" in done.stdout
    np.testing.assert_allclose(load_load_steps(separate).reaction,
                               load_load_steps(inline).reaction, rtol=1e-12)
    out = tmp_path / "refused.npz"
    for extra, words in (
            (("--tool-force", force), "keep one load cell"),
            (("--tool-force", _force_file(lab, tmp_path, rows=(0, 1, 3))),
             "has no row for step(s) [2]")):
        tool = "tool.csv" if words == "keep one load cell" else "tool-no-force.csv"
        result = _import(lab, tool, out, *extra)
        assert result.returncode == 2 and words in result.stderr, result.stderr
        assert "Traceback" not in result.stderr and not out.exists()
    result = _import(lab, "tool-no-force.csv", out, "--tool-force",
                     _force_file(lab, tmp_path, units=""))
    assert result.returncode == 2 and "force units" in result.stderr
    result = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml",
                 "--displacements", lab / "tool-no-force.csv", "--tool-force", force,
                 "--out", out)
    assert result.returncode == 2 and "--tool-force" in result.stderr, result.stderr
    assert "Traceback" not in result.stderr and not out.exists()


def test_a_tracked_punch_s_attitude_is_read_and_kept(lab, tmp_path):
    """A tool path with a tracker's attitude (``qw,qx,qy,qz``, scalar first, here not quite
    unit): the load-step file keeps the normalised quaternions, and the punch's axis turns
    with them (90° about x takes its +z axis to -y)."""
    from scipy.spatial.transform import Rotation

    from neurofuzzy.io.load_steps import load_load_steps

    text = (lab / "tool-no-force.csv").read_text().splitlines()
    half = np.sqrt(0.5)
    tilted = tmp_path / "tilted.csv"
    tilted.write_text("\n".join(text[:1] + [text[1] + ",qw,qx,qy,qz"]
                                + [row + ",1,0,0,0" for row in text[2:4]]
                                + [row + f",{1.01 * half},{1.01 * half},0,0"
                                   for row in text[4:]]) + "\n")
    out = tmp_path / "steps.npz"
    result = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--tool",
                 "punch:R=2mm", "--tool-path", tilted, "--out", out)
    assert result.returncode == 0, result.stderr
    path = load_load_steps(out).tool
    assert np.allclose(np.linalg.norm(path.orientations, axis=1), 1.0)
    assert np.allclose(path.orientations[-1], [half, half, 0, 0])
    assert np.allclose(path.tool_at(1).axis, (0, 0, 1))
    assert np.allclose(path.tool_at(3).axis, (0, -1, 0), atol=1e-12)
    turn = Rotation.from_quat(path.orientations[3], scalar_first=True).as_matrix()
    assert np.allclose(path.tool_at(3).axis, turn @ np.array(path.tool.axis))


def _cluster_c3d(path, tip_path, turns, *, stray=None, hidden=()):
    """A C3D recording (mm, 100 Hz) of four markers fixed to a tool whose reference point
    follows ``tip_path`` (m) while it turns by ``turns`` (Rotations), one frame per step;
    ``stray``: (frame, marker, mm) moved off the rigid body; ``hidden``: (frame, marker)
    not seen."""
    arms = np.array([[0.0, 0.0, 0.03], [0.02, 0.0, 0.035], [0.0, 0.015, 0.04],
                     [-0.01, -0.01, 0.045]])                 # from the tip, at the start
    frames = np.array([1e3 * (turn.apply(arms) + tip) for tip, turn in zip(tip_path, turns)])
    if stray is not None:
        frames[stray[0], stray[1], 0] += stray[2]
    return write_c3d_points(path, ["T1", "T2", "T3", "T4"], frames, 100.0, hidden)


def test_a_tracked_tool_from_a_c3d_rigid_body_without_force(lab, tmp_path):
    """Issue 46: the tool's path as a navigation system gives it, the markers of a rigid body
    fixed to the tool in a C3D file, no force: the sphere's centre follows the cluster's
    rigid motion from the reference frame (to the file's float32 precision), the attitude is
    kept, and the fit finds ν and lists E as unidentifiable with no word."""
    from scipy.spatial.transform import Rotation

    from neurofuzzy.io.load_steps import load_load_steps

    centre = np.array([WIDTH / 2, WIDTH / 2, HEIGHT + RADIUS])
    path = centre - np.outer([0.0, *DEPTHS], (0, 0, 1))
    turns = [Rotation.from_euler("xyz", [3 * k, -2 * k, 5 * k], degrees=True)
             for k in range(4)]
    recording = _cluster_c3d(tmp_path / "probe.c3d", path, turns)
    tip = ",".join(f"{1e3 * v:.6f}" for v in path[0]) + "mm"
    out = tmp_path / "tracked.npz"
    done = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--tool",
               "sphere:R=5mm", "--tool-path", recording, "--tool-frames", "0,1,2,3",
               "--tool-tip", tip, "--out", out)
    assert done.returncode == 0, done.stderr
    assert "no force measured" in done.stdout
    tool = load_load_steps(out).tool
    np.testing.assert_allclose(tool.positions, path, atol=2e-7)
    for turn, quaternion in zip(turns, tool.orientations):
        assert abs(np.dot(turn.as_quat(scalar_first=True), quaternion)) == pytest.approx(
            1.0, abs=1e-9)
    record = json.loads(cli("fit", out, "--start", lab / "model.yaml", "--json",
                            "--no-mesh-check").stdout)
    assert record["youngs_modulus"] is None and "youngs_modulus" in record["unidentifiable"]
    assert record["poisson_ratio"] == pytest.approx(0.45, abs=0.03)


@pytest.mark.parametrize("case, words", [
    ("stray", "stray 1.72 mm (RMS) from one rigid motion"),
    ("hidden", "2 of the tool's markers are seen"),
    ("frames", "so 4 frames are needed"),
    ("no_tip", "needs --tool-frames"),
    ("tip_unit", "expected X,Y,Z with a unit"),
    ("csv_frames", "belongs to a C3D tool path"),
    ("marker", "names no tool marker 'T9'"),
])
def test_bad_c3d_tool_paths_are_refused_with_exit_2(lab, tmp_path, case, words):
    from scipy.spatial.transform import Rotation

    centre = np.array([WIDTH / 2, WIDTH / 2, HEIGHT + RADIUS])
    path = centre - np.outer([0.0, *DEPTHS], (0, 0, 1))
    turns = [Rotation.identity()] * 4
    recording = _cluster_c3d(tmp_path / "probe.c3d", path, turns,
                             stray=(2, 1, 4.0) if case == "stray" else None,
                             hidden=[(3, 0), (3, 1)] if case == "hidden" else ())
    options = {"--tool-path": recording, "--tool-frames": "0,1,2,3",
               "--tool-tip": "10,10,15mm"}
    if case == "frames":
        options["--tool-frames"] = "0,1,2"
    elif case == "no_tip":
        del options["--tool-tip"]
    elif case == "tip_unit":
        options["--tool-tip"] = "10,10,15"
    elif case == "csv_frames":
        options["--tool-path"] = lab / "tool-no-force.csv"
    elif case == "marker":
        options["--tool-markers"] = "T1,T2,T9"
    out = tmp_path / "out.npz"
    result = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--tool",
                 "sphere:R=5mm", *[str(x) for pair in options.items() for x in pair],
                 "--out", out)
    assert result.returncode == 2, result.stderr
    assert words in result.stderr and "Traceback" not in result.stderr
    assert not out.exists()
