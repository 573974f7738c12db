"""A plate ramped in time from the command line, as a lab's files arrive: markers in mm at
the cameras' rate (``time,marker,x,y,z``), the stage's place and the load cell at their own
faster rate (``time,dx,dy,dz,fx,fy,fz``), ``import`` then ``fit`` through implicit steps;
each bad plate file a clear message with exit status 2 and nothing written."""

import json

import numpy as np
import pytest

from helpers import cli
from neurofuzzy.io import save_model
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import embed_points
from neurofuzzy.paths import DrivenPath
from neurofuzzy.simulation.implicit import simulate_implicit

SIZE, DT, FRAMES = 0.02, 0.002, 40


def _path(t):
    """The plate 10 % down over 40 ms, then held (m)."""
    return -0.1 * SIZE * np.minimum(np.asarray(t) / 0.04, 1.0)


def _gel(folder, cells, cell):
    """The viscous gel (E 6 kPa, ν 0.45, η 20 Pa·s, neo-Hookean) on ``cells`` of side
    ``cell``, held at its bottom; its start (E 8 kPa, ν 0.4, η 10) written to
    ``folder / model.yaml``."""
    points, tetrahedra = kuhn_block(cells, cell)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=20.0,
                            density=1000.0, law="neo-hookean")
    save_model(truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0),
               folder / "model.yaml")
    return truth


def _write_beads(folder, mesh, beads, positions, noise, rng):
    """``folder / beads.csv``: ``beads`` (m, at rest) embedded in ``mesh`` and moved with its
    nodes' ``positions`` (one row per 2 ms frame), with ``noise`` (m), in mm."""
    nodes, weights, _ = embed_points(mesh, beads)
    seen = np.einsum("mk,fmkj->fmj", weights, positions[:, nodes])
    seen[1:] += rng.normal(0.0, noise, seen[1:].shape)
    rows = ["# length units: mm", "time,marker,x,y,z"]
    for frame, scan in enumerate(seen):
        rows += [f"{frame * DT:.4f},bead{i},{x * 1e3:.6f},{y * 1e3:.6f},{z * 1e3:.6f}"
                 for i, (x, y, z) in enumerate(scan)]
    (folder / "beads.csv").write_text("\n".join(rows) + "\n")


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A viscous gel (E 6 kPa, ν 0.45, η 20 Pa·s) on a fixed anvil, its top bonded to a plate
    ramped down: the model file (the start: E 8 kPa, ν 0.4, η 10), 30 beads every 2 ms with
    2 µm noise, the plate and its load cell every 1 ms with 1 % noise."""
    folder = tmp_path_factory.mktemp("ramp")
    truth = _gel(folder, (2, 2, 2), SIZE / 2)
    points, mesh = truth.mesh.rest_positions, truth.mesh
    top = np.flatnonzero(np.isclose(points[:, 2], SIZE))
    fine = 2 * FRAMES - 1                        # the stage's 1 ms samples
    times = np.arange(fine) * DT / 2
    path = np.zeros((fine, 3))
    path[:, 2] = _path(times)
    run = simulate_implicit(truth, dt=DT / 2, n_frames=fine, iterations=50, tolerance=1e-12,
                            driven=[DrivenPath(top, path)], scheme="bdf2")
    rng = np.random.default_rng(4)
    beads = rng.uniform(0.2 * SIZE, 0.8 * SIZE, (30, 3))
    _write_beads(folder, mesh, beads, run.positions[::2], 2e-6, rng)
    force = run.reactions[:, 0]
    force = force + 0.01 * np.abs(force).max() * rng.normal(size=force.shape)
    plate = ["# length units: mm", "# force units: mN", "time,dx,dy,dz,fx,fy,fz"]
    plate += [f"{t:.4f},0,0,{z * 1e3:.6f}," + ",".join(f"{f * 1e3:.6f}" for f in forces)
              for t, z, forces in zip(times, path[:, 2], force)]
    (folder / "plate.csv").write_text("\n".join(plate) + "\n")
    return folder


@pytest.mark.slow
def test_a_ramped_plate_with_a_load_cell_is_fitted_from_its_files(lab, tmp_path):
    """E, ν and η of the gel from the files, through BDF2 steps of 1 ms (two a frame: the
    steps the data were made with; with one a frame, 2 ms, E came out 5.6 % high, the
    larger step's own error)."""
    recording = tmp_path / "ramp.npz"
    done = cli("import", lab / "beads.csv", "--topology", lab / "model.yaml",
               "--displacements", lab / "plate.csv", "--out", recording)
    assert done.returncode == 0, done.stderr
    assert "30 markers" in done.stdout and "with the load cell's force" in done.stdout
    fitted, report = tmp_path / "fitted.yaml", tmp_path / "fit.html"
    done = cli("fit", recording, "--start", lab / "model.yaml", "--json", "--quiet",
               "--substeps", "2", "--out", fitted, "--report", report)
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["kind"] == "moving boundaries"
    assert record["youngs_modulus"] == pytest.approx(6000.0, rel=0.03)
    assert record["poisson_ratio"] == pytest.approx(0.45, abs=0.01)
    assert record["viscosity"] == pytest.approx(20.0, rel=0.1)
    assert record["noise_estimated"] == ["markers", "force"]
    assert record["marker_noise"] == pytest.approx(2e-6, rel=0.3)
    assert fitted.is_file()
    # the mesh check ran by default (48 tetrahedra, 384 refined) and the report draws the fit
    check = record["mesh_check"]
    assert check["elements"] == [48, 384]
    assert check["youngs_modulus"]["mesh"] == pytest.approx(record["youngs_modulus"])
    assert "extrapolated to a fine mesh" in report.read_text()
    twin = json.loads(report.with_suffix(".json").read_text())
    measured, predicted = np.array(twin["measured_force"]), np.array(twin["predicted_force"])
    assert np.abs(predicted - measured).max() < 4 * record["force_noise"]   # the fit's curve
    assert twin["youngs_modulus"] == pytest.approx(record["youngs_modulus"], rel=1e-6)
    assert report.read_text().count("<img") == 2


@pytest.mark.slow
def test_a_relaxing_gel_s_ramp_and_hold_is_fitted_from_its_files(tmp_path):
    """The stress-relaxation test labs run: the plate ramped and held on a gel with a Prony
    term (g 1, τ 20 ms), the load cell relaxing while the plate holds. From a model file with
    that term and E, ν, η off, ``fit`` through BDF2 steps (their derivatives carry the
    internal variables') returns E, ν and η (measured: +0.13 %, -0.00004, +0.4 %); the
    fitted file keeps the term."""
    truth = _gel(tmp_path, (2, 2, 2), SIZE / 2).with_elements(relaxation_moduli=[1.0],
                                                              relaxation_times=[0.02])
    save_model(truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0),
               tmp_path / "model.yaml")
    points, mesh = truth.mesh.rest_positions, truth.mesh
    top = np.flatnonzero(np.isclose(points[:, 2], SIZE))
    times = np.arange(FRAMES) * DT
    path = np.zeros((FRAMES, 3))
    path[:, 2] = _path(times)
    run = simulate_implicit(truth, dt=DT, n_frames=FRAMES, iterations=50, tolerance=1e-12,
                            driven=[DrivenPath(top, path)], scheme="bdf2")
    rng = np.random.default_rng(5)
    _write_beads(tmp_path, mesh, rng.uniform(0.2 * SIZE, 0.8 * SIZE, (30, 3)), run.positions,
                 2e-6, rng)
    force = run.reactions[:, 0]
    assert abs(force[-1, 2]) < 0.8 * np.abs(force[:, 2]).max()      # it relaxed, held
    force = force + 0.01 * np.abs(force).max() * rng.normal(size=force.shape)
    plate = ["# length units: mm", "# force units: mN", "time,dx,dy,dz,fx,fy,fz"]
    plate += [f"{t:.4f},0,0,{z * 1e3:.6f}," + ",".join(f"{f * 1e3:.6f}" for f in forces)
              for t, z, forces in zip(times, path[:, 2], force)]
    (tmp_path / "plate.csv").write_text("\n".join(plate) + "\n")
    recording = tmp_path / "ramp.npz"
    done = cli("import", tmp_path / "beads.csv", "--topology", tmp_path / "model.yaml",
               "--displacements", tmp_path / "plate.csv", "--out", recording)
    assert done.returncode == 0, done.stderr
    fitted = tmp_path / "fitted.yaml"
    done = cli("fit", recording, "--start", tmp_path / "model.yaml", "--json", "--quiet",
               "--no-mesh-check", "--out", fitted)
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["youngs_modulus"] == pytest.approx(6000.0, rel=0.01)
    assert record["poisson_ratio"] == pytest.approx(0.45, abs=0.005)
    assert record["viscosity"] == pytest.approx(20.0, rel=0.05)
    assert "relaxation_moduli" in fitted.read_text()


@pytest.mark.parametrize("plate, words", [
    ("# length units: mm\ntime,dx,dy,dz\n0,0,0,0\n0.05,0,0,-1\n", "the plate's place is "
     "needed at every frame"),
    ("# length units: mm\nstep,dx,dy,dz\n0,0,0,0\n1,0,0,-1\n", "has a 'step' column"),
    ("time,dx,dy,dz\n0,0,0,0\n0.1,0,0,-1\n", "states no length unit"),
    ("# length units: mm\ntime,dx,dy,dz,fx,fy,fz\n0,0,0,0,0,0,0\n0.1,0,0,-1,0,0,1\n",
     "no '# force units: N' line"),
    ("# length units: mm\ntime,dx,dy,dz\n0,0,0,0\n0,0,0,-1\n0.1,0,0,-1\n",
     "the times must increase"),
])
def test_a_bad_plate_file_in_time_is_refused(lab, tmp_path, plate, words):
    (tmp_path / "plate.csv").write_text(plate)
    out = tmp_path / "ramp.npz"
    done = cli("import", lab / "beads.csv", "--topology", lab / "model.yaml",
               "--displacements", tmp_path / "plate.csv", "--out", out)
    assert done.returncode == 2 and words in done.stderr, done.stderr
    assert "Traceback" not in done.stderr and not out.exists()


@pytest.fixture(scope="module")
def pressed(tmp_path_factory):
    """The gel (4 × 4 × 2 cells, 1 cm high) pressed 1.5 mm by a sphere of 5 mm radius along
    a path in time, 30 frames 2 ms apart: the model file (the start: E 8 kPa, ν 0.4, η 10),
    40 beads with 1 µm noise, the tool's path with its load cell (1 % noise)."""
    from neurofuzzy.paths import ToolPath
    from neurofuzzy.simulation.contact import Sphere

    folder = tmp_path_factory.mktemp("pressed")
    truth = _gel(folder, (4, 4, 2), SIZE / 4)
    mesh = truth.mesh
    frames = 30
    centre = np.array([SIZE / 2, SIZE / 2, SIZE / 2 + 0.005])
    path = centre + np.minimum(np.arange(frames) / 15, 1.0)[:, None] * (0, 0, -1.5e-3)
    run = simulate_implicit(truth, dt=DT, n_frames=frames, tolerance=1e-12, scheme="bdf2",
                            tool=ToolPath(Sphere(0.005), path))
    rng = np.random.default_rng(6)
    beads = rng.uniform(0.1 * SIZE, 0.9 * SIZE, (40, 3)) * (1, 1, 0.5)
    _write_beads(folder, mesh, beads, run.positions, 1e-6, rng)
    force = run.tool_forces + 0.01 * np.abs(run.tool_forces).max() * rng.normal(
        size=(frames, 3))
    lines = ["# length units: mm", "# force units: mN", "time,x,y,z,fx,fy,fz"]
    lines += [f"{k * DT:.4f}," + ",".join(f"{c * 1e3:.6f}" for c in (*path[k], *force[k]))
              for k in range(frames)]
    (folder / "tool.csv").write_text("\n".join(lines) + "\n")
    return folder


@pytest.mark.slow
def test_a_sphere_pressed_in_time_is_fitted_from_its_files(pressed, tmp_path):
    """``import … --tool sphere:R=5mm --tool-path TOOL.csv`` of a recording in time, then
    ``fit``: E, ν and η of the gel within 3 %, 0.01 and 10 % (its own data, BDF2 steps of the
    frames' 2 ms as they were made)."""
    recording = tmp_path / "pressed.npz"
    done = cli("import", pressed / "beads.csv", "--topology", pressed / "model.yaml",
               "--tool", "sphere:R=5mm", "--tool-path", pressed / "tool.csv", "--out",
               recording)
    assert done.returncode == 0, done.stderr
    assert "the sphere follows" in done.stdout and "load cell" in done.stdout
    done = cli("fit", recording, "--start", pressed / "model.yaml", "--json", "--quiet",
               "--no-mesh-check")
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["youngs_modulus"] == pytest.approx(6000.0, rel=0.03)
    assert record["poisson_ratio"] == pytest.approx(0.45, abs=0.01)
    assert record["viscosity"] == pytest.approx(20.0, rel=0.1)


@pytest.mark.parametrize("options, words", [
    (("--tool", "sphere:R=5mm"), "--tool-path is missing"),
    (("--tool", "sphere:R=5mm", "--tool-path", "tool.c3d"), "in time give time,x,y,z"),
    (("--tool", "sphere:R=5mm", "--tool-path", "tool.csv", "--displacements", "tool.csv"),
     "a plate or by a tool, one of them"),
])
def test_bad_tool_options_in_time_are_refused(pressed, tmp_path, options, words):
    out = tmp_path / "pressed.npz"
    options = [pressed / o if o.startswith("tool.") else o for o in options]
    done = cli("import", pressed / "beads.csv", "--topology", pressed / "model.yaml",
               *options, "--out", out)
    assert done.returncode == 2 and words in done.stderr, done.stderr
    assert not out.exists()


def test_a_tool_s_load_cell_in_time_in_a_file_of_its_own(pressed, tmp_path):
    """``--tool-force FORCE.csv`` in time (``time,fx,fy,fz``, sampled at twice the frames'
    rate, from 1 ms before the first frame): read at the frames as the path's own columns
    are; a file that ends before the last frame, or the option without a tool, is refused."""
    from neurofuzzy.io import load_experiment

    rows = [line.split(",") for line in (pressed / "tool.csv").read_text().splitlines()[3:]]
    times = np.array([float(row[0]) for row in rows])
    force = np.array([[float(v) for v in row[4:7]] for row in rows])
    fine = np.arange(-0.001, times[-1] + 1e-9, DT / 2)
    samples = np.stack([np.interp(fine, times, force[:, k]) for k in range(3)], axis=1)
    lines = ["# force units: mN", "time,fx,fy,fz"] + [
        f"{t:.4f}," + ",".join(f"{f:.6f}" for f in values) for t, values in zip(fine, samples)]
    (tmp_path / "force.csv").write_text("\n".join(lines) + "\n")
    path = tmp_path / "path.csv"
    path.write_text("\n".join(["# length units: mm", "time,x,y,z"]
                              + [",".join(row[:4]) for row in rows]) + "\n")
    made = {}
    for name, options in (("inline", ["--tool-path", pressed / "tool.csv"]),
                          ("separate", ["--tool-path", path, "--tool-force",
                                        tmp_path / "force.csv"])):
        made[name] = tmp_path / f"{name}.npz"
        done = cli("import", pressed / "beads.csv", "--topology", pressed / "model.yaml",
                   "--tool", "sphere:R=5mm", *options, "--out", made[name])
        assert done.returncode == 0, done.stderr
    np.testing.assert_allclose(load_experiment(made["separate"]).reaction,
                               load_experiment(made["inline"]).reaction, atol=1e-9)
    (tmp_path / "short.csv").write_text("\n".join(lines[:-4]) + "\n")
    out = tmp_path / "refused.npz"
    for options, words in (
            (["--tool", "sphere:R=5mm", "--tool-path", path, "--tool-force",
              tmp_path / "short.csv"], "needed at every frame"),
            (["--tool-force", tmp_path / "force.csv"], "give the tool too")):
        done = cli("import", pressed / "beads.csv", "--topology", pressed / "model.yaml",
                   *options, "--out", out)
        assert done.returncode == 2 and words in done.stderr, done.stderr
        assert "Traceback" not in done.stderr and not out.exists()


@pytest.mark.slow
def test_fit_many_fits_and_diagnoses_a_ramped_plate_through_implicit_steps(lab, tmp_path):
    """A cohort with a plate ramped in time: fit-many's task fits it as ``fit`` does
    (through BDF2 steps, the mesh check, the report drawing the load cell), its row holds E,
    ν and η, and ``diagnose: true`` diagnoses it in time (the gel's own model: nothing
    named) and writes the diagnosis's report beside the fit's."""
    from neurofuzzy.batch import read_manifest
    from neurofuzzy.batch.table import table_rows
    from neurofuzzy.batch.task import fit_specimen

    done = cli("import", lab / "beads.csv", "--topology", lab / "model.yaml",
               "--displacements", lab / "plate.csv", "--out", tmp_path / "ramp.npz")
    assert done.returncode == 0, done.stderr
    (tmp_path / "model.yaml").write_bytes((lab / "model.yaml").read_bytes())
    (tmp_path / "cohort.csv").write_text("id,group,experiments,start,substeps,diagnose\n"
                                         "a,gel,ramp.npz,model.yaml,2,true\n")
    specimens = read_manifest(tmp_path / "cohort.csv")
    records = {s.id: fit_specimen(s) for s in specimens}
    assert records["a"]["status"] == "ok", records["a"]
    fit = records["a"]["fit"]
    assert fit["kind"] == "moving boundaries" and fit["mesh_check"]["elements"] == [48, 384]
    assert fit["diagnosis"]["effects"] == ["none"]
    assert {"fitted.yaml", "report.html", "report.json", "diagnosis.html",
            "diagnosis.json"} <= set(records["a"]["files"])
    assert b"specimen a (gel)" in records["a"]["files"]["diagnosis.html"]
    assert json.loads(records["a"]["files"]["diagnosis.json"])["answer"] == ["none"]
    assert b"load cell" in records["a"]["files"]["report.html"]
    row = next(row for row in table_rows(specimens, records) if row["id"] == "a")
    assert row["youngs_modulus"] == pytest.approx(6000.0, rel=0.03)
    assert row["poisson_ratio"] == pytest.approx(0.45, abs=0.01)
    assert row["viscosity"] == pytest.approx(20.0, rel=0.1)
    assert row["rms_error"] < 1e-5 and row["effects"] == "none"
