"""Load steps from the command line, as a lab's files arrive: scans in mm at a few load steps
(``step,marker,x,y,z``), the plate's displacement and load cell per step, ``import`` then
``fit``; and each bad input a clear message with exit status 2 and nothing written."""

import json

import numpy as np
import pytest

from helpers import cli
from neurofuzzy.io import save_model
from neurofuzzy.load_steps import DrivenPath, simulate_load_steps
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points

SIZE = 0.02
STRAINS = (0.05, 0.125, 0.18)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """A neo-Hookean gel (E 6 kPa, ν 0.45) between bonded plates: the model file a user
    meshes (the start: E 3 kPa, ν 0.3), the scans and the plate file a lab writes."""
    folder = tmp_path_factory.mktemp("lab")
    points, tetrahedra = kuhn_block((3, 3, 3), SIZE / 3)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=1.0,
                            density=1000.0, law="neo-hookean")
    save_model(truth.with_elements(youngs_modulus=3000.0, poisson_ratio=0.3),
               folder / "model.yaml")
    top = np.flatnonzero(np.isclose(points[:, 2], SIZE))
    plate = DrivenPath(top, np.array([[0, 0, -s * SIZE] for s in STRAINS]))
    beads = np.random.default_rng(1).uniform(0.1 * SIZE, 0.9 * SIZE, size=(60, 3))
    nodes, weights, _ = embed_points(mesh, beads)
    data = simulate_load_steps(truth, [plate], EmbeddedMarkers(
        nodes, weights, np.zeros((4, 60, 3))), marker_noise=20e-6, force_noise=1e-3, seed=3)
    rows = ["# length units: mm", "step,marker,x,y,z"]
    for step, scan in enumerate(data.markers.positions):
        rows += [f"{step},bead{i},{x * 1e3:.6f},{y * 1e3:.6f},{z * 1e3:.6f}"
                 for i, (x, y, z) in enumerate(scan)]
    (folder / "scans.csv").write_text("\n".join(rows) + "\n")
    plate_rows = ["# length units: mm", "# force units: mN", "step,dx,dy,dz,fx,fy,fz",
                  "0,0,0,0,0,0,0"]
    plate_rows += [f"{s + 1},0,0,{-strain * SIZE * 1e3:.6f},"
                   + ",".join(f"{f * 1e3:.6f}" for f in data.reaction[s])
                   for s, strain in enumerate(STRAINS)]
    (folder / "plate.csv").write_text("\n".join(plate_rows) + "\n")
    (folder / "plate-no-force.csv").write_text("\n".join(
        ["# length units: mm", "step,dx,dy,dz"]
        + [f"{s + 1},0,0,{-strain * SIZE * 1e3:.6f}" for s, strain in enumerate(STRAINS)])
        + "\n")
    return folder


def _import(lab, plate, out, *extra):
    return cli("import", lab / "scans.csv", "--topology", lab / "model.yaml",
               "--displacements", lab / plate, "--out", out, *extra)


def test_a_compression_test_without_a_load_cell_from_files(lab, tmp_path):
    steps = tmp_path / "steps.npz"
    done = _import(lab, "plate-no-force.csv", steps)
    assert done.returncode == 0, done.stderr
    assert "60 markers at 3 load steps" in done.stdout and "no force" in done.stdout
    fitted = tmp_path / "fitted.yaml"
    done = cli("fit", steps, "--start", lab / "model.yaml", "--validate-on", "3", "--out",
               fitted, "--json", "--rules", "liver", "--tissue", "liver")
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["unidentifiable"] == ["youngs_modulus", "viscosity", "density"]
    assert record["youngs_modulus"] is None
    assert record["poisson_ratio"] == pytest.approx(0.45, abs=0.01)
    assert record["validation"]["steps"] == [3]
    assert record["validation"]["rms_error"] < 1.2 * np.sqrt(3) * 20e-6
    region = next(iter(record["materials"].values()))
    assert region["youngs_modulus"] is None and "youngs_modulus" not in region["labels"]
    assert "poisson_ratio" in region["labels"]
    assert fitted.is_file()
    text = cli("fit", steps, "--start", lab / "model.yaml", "--quiet", "--no-mesh-check")
    assert "not identifiable" in text.stdout and "poisson_ratio" in text.stdout
    assert "95 % intervals hold the noise alone: no mesh check ran" in text.stdout
    assert "extrapolated" not in text.stdout


def test_with_the_load_cell_youngs_modulus_is_fitted_and_reported(lab, tmp_path):
    steps = tmp_path / "steps.npz"
    assert _import(lab, "plate.csv", steps, "--json").returncode == 0
    report = tmp_path / "fit.html"
    record = json.loads(cli("fit", steps, "--start", lab / "model.yaml", "--json", "--quiet",
                            "--report", report, "--validate-on", "2").stdout)
    assert record["unidentifiable"] == ["viscosity", "density"]
    assert record["youngs_modulus"] == pytest.approx(6000.0, rel=0.03)
    assert record["force_rms_error"] < 3e-3
    # the mesh check ran by default (162 tetrahedra, 1,296 refined) and widened the intervals
    check = record["mesh_check"]
    assert check["refined_elements"] == 8 * 162
    assert record["intervals_hold"].startswith("the noise and the mesh: on the mesh refined")
    assert record["intervals"]["youngs_modulus"] > 1.96 * record["standard_errors"][
        "youngs_modulus"]
    assert check["values"]["youngs_modulus"]["mesh"] == pytest.approx(record["youngs_modulus"])
    page = report.read_text()
    twin = json.loads(report.with_suffix(".json").read_text())
    measured, predicted = np.array(twin["measured_force"]), np.array(twin["predicted_force"])
    assert np.abs(predicted - measured).max() < 5e-3          # the curve drawn is the fit's
    assert page.count("<img") == 2 and "held out" in page and "not identifiable" in page
    assert "extrapolated to a fine mesh" in page and "the noise and the mesh" in page
    assert twin["mesh_check"]["refined_elements"] == 8 * 162


def _write(path, lines):
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("case, message", [
    ("plate_steps", "no row for step(s) [3]"),
    ("mixed_columns", "both a 'step' and a 'time' column"),
    ("force_without_unit", "no '# force units: N' line"),
    ("overlap", "overlaps the fixed nodes"),
    ("time_plate", "has a 'time' column"),
])
def test_bad_load_step_input_is_refused_with_exit_2_and_nothing_written(lab, tmp_path, case,
                                                                         message):
    scans, plate, extra = lab / "scans.csv", lab / "plate.csv", []
    if case == "plate_steps":
        plate = _write(tmp_path / "p.csv", ["# length units: mm", "step,dx,dy,dz",
                                            "1,0,0,-1", "2,0,0,-2"])
    elif case == "mixed_columns":
        scans = _write(tmp_path / "s.csv", ["# length units: mm", "step,time,marker,x,y,z",
                                            "0,0,a,1,1,1", "1,1,a,1,1,0.9"])
    elif case == "force_without_unit":
        plate = _write(tmp_path / "p.csv", ["# length units: mm", "step,dx,dy,dz,fx,fy,fz",
                                            "1,0,0,-1,0,0,1", "2,0,0,-2,0,0,2",
                                            "3,0,0,-3,0,0,3"])
    elif case == "overlap":
        extra = ["--up=-z"]         # "up" pointing down: the top face is the fixed bottom
    elif case == "time_plate":
        plate = _write(tmp_path / "p.csv", ["# length units: mm", "time,dx,dy,dz",
                                            "1,0,0,-1"])
    out = tmp_path / "steps.npz"
    done = cli("import", scans, "--topology", lab / "model.yaml", "--displacements", plate,
               "--out", out, *extra)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert not out.exists()


def test_fit_reference_noise_from_the_command_line(lab, tmp_path):
    steps = tmp_path / "steps.npz"
    assert _import(lab, "plate-no-force.csv", steps).returncode == 0
    records = [json.loads(cli("fit", steps, "--start", lab / "model.yaml", "--json", "--quiet",
                              *extra).stdout) for extra in ([], ["--reference-noise"])]
    assert [r["reference_noise"] for r in records] == [False, True]
    # the rest points take up part of each marker's residual
    assert records[1]["marker_rms_error"] < 0.9 * records[0]["marker_rms_error"]
    assert records[1]["poisson_ratio"] == pytest.approx(0.45, abs=0.01)


def test_validate_on_steps_of_a_time_series_names_what_it_takes(lab, tmp_path):
    from neurofuzzy.datasets import paper_cube_experiment
    from neurofuzzy.io import save_experiment

    path = save_experiment(paper_cube_experiment(), tmp_path / "cube.npz")
    done = cli("fit", path, "--validate-on", "2,3")
    assert done.returncode == 2 and "load steps are held out of a load-step file" in done.stderr
    done = cli("fit", path, "--reference-noise")
    assert done.returncode == 2 and "is for a load-step file" in done.stderr


def test_import_drive_markers_drives_their_nodes(lab, tmp_path):
    """``--drive-markers``: beside the plate, or as the whole boundary (no plate file); the
    driving markers are not fitted, and a time recording refuses the option."""
    from neurofuzzy.io.load_steps import load_load_steps

    plain = tmp_path / "plain.npz"
    assert _import(lab, "plate-no-force.csv", plain).returncode == 0
    data = load_load_steps(plain)
    nearest = data.markers.nodes[np.arange(60), np.argmax(data.markers.weights, axis=1)]
    held = set(data.mesh.fixed.tolist()) | set(data.driven[0].nodes.tolist())
    free = [f"bead{i}" for i in range(60) if nearest[i] not in held]
    free = [name for k, name in enumerate(free)
            if nearest[int(name[4:])] not in {nearest[int(n[4:])] for n in free[:k]}][:5]
    steps = tmp_path / "steps.npz"
    done = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml", "--displacements",
               lab / "plate-no-force.csv", "--drive-markers", ",".join(free[:2]), "--out",
               steps, "--json")
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["markers"] == 58 and record["driving_markers"] == free[:2]
    assert [path.name for path in load_load_steps(steps).driven] == [
        "top plate", f"marker {free[0]}", f"marker {free[1]}"]
    alone = tmp_path / "alone.npz"
    done = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml",
               "--drive-markers", ",".join(free), "--out", alone)
    assert done.returncode == 0, done.stderr
    assert "55 markers at 3 load steps, 5 markers drive their nodes" in done.stdout
    assert len(load_load_steps(alone).driven) == 5
    done = cli("import", lab / "scans.csv", "--topology", lab / "model.yaml",
               "--drive-markers", "nobead", "--out", tmp_path / "x.npz")
    assert done.returncode == 2 and "no marker 'nobead'" in done.stderr
    assert not (tmp_path / "x.npz").exists()


def test_the_time_series_diagnosis_options_are_refused_for_load_steps(lab, tmp_path):
    """``--localise``, ``--max-time`` and ``--window`` belong to the diagnosis of time series:
    given for a load-step file, each is refused by name (exit 2, nothing written), not
    ignored."""
    steps = tmp_path / "steps.npz"
    assert _import(lab, "plate.csv", steps).returncode == 0
    out = tmp_path / "diagnosed.yaml"
    for option in (["--localise"], ["--max-time", "5"], ["--window", "all"]):
        done = cli("diagnose", steps, "--start", lab / "model.yaml", *option, "--out", out)
        assert done.returncode == 2 and option[0] in done.stderr, done.stderr
        assert "Traceback" not in done.stderr and not out.exists()


@pytest.mark.slow
def test_diagnose_a_load_step_file(lab, tmp_path):
    """The gel is neo-Hookean, the model file St. Venant–Kirchhoff: at 18 % the diagnosis
    names the law, and the model it writes has it. Its report draws both fits: the answer's
    marker error at no step above the base fit's, its force nearer the load cell's."""
    steps = tmp_path / "steps.npz"
    assert _import(lab, "plate.csv", steps).returncode == 0
    out = tmp_path / "diagnosed.yaml"
    done = cli("diagnose", steps, "--start", lab / "model.yaml", "--law",
               "st-venant-kirchhoff", "--json", "--quiet", "--out", out, "--report",
               tmp_path / "diagnosis.html")
    assert done.returncode == 0, done.stderr
    record = json.loads(done.stdout)
    assert record["answer"] == ["hyperelasticity (neo-hookean)"]
    assert record["rms_after"] < record["rms_before"]
    assert "neo-hookean" in out.read_text()
    page = (tmp_path / "diagnosis.html").read_text()
    assert "Answer: <b>hyperelasticity (neo-hookean)</b>" in page and page.count("<img") == 3
    report = json.loads((tmp_path / "diagnosis.json").read_text())
    assert report["law_before"] == "st-venant-kirchhoff" and report["law"] == "neo-hookean"
    before = np.asarray(report["marker_rms_per_step_before"])
    after = np.asarray(report["marker_rms_per_step_after"])
    assert before.shape == after.shape == (3,) and np.all(after <= before * 1.001)
    measured = np.asarray(report["measured_force"])
    assert (np.abs(np.asarray(report["predicted_force_after"]) - measured).max()
            < np.abs(np.asarray(report["predicted_force_before"]) - measured).max())


def test_a_load_cell_alone_from_the_command_line(lab, tmp_path):
    steps = tmp_path / "force.npz"
    done = cli("import", "--topology", lab / "model.yaml", "--displacements",
               lab / "plate.csv", "--out", steps)
    assert done.returncode == 0, done.stderr
    assert "0 markers at 3 load steps" in done.stdout
    record = json.loads(cli("fit", steps, "--start", lab / "model.yaml", "--json",
                            "--quiet").stdout)
    assert record["poisson_ratio"] == pytest.approx(0.3)          # the start's, held
    assert record["youngs_modulus"] > 0 and record["marker_rms_error"] is None
    assert any("no markers" in note for note in record["notes"])
    done = cli("import", "--topology", lab / "model.yaml", "--displacements",
               lab / "plate-no-force.csv", "--out", tmp_path / "nothing.npz")
    assert done.returncode == 2 and "load cell's force is all there is" in done.stderr
    done = cli("import", "--topology", lab / "model.yaml", "--out", tmp_path / "x.npz")
    assert done.returncode == 2 and "--displacements" in done.stderr


def test_mesh_fixes_the_bottom_along_up(tmp_path):
    """A scan whose up is +y (or -z): --fix-bottom holds the face at the bottom of that
    axis, not z's."""
    import meshio

    from neurofuzzy.io import load_model

    points, tetrahedra = kuhn_block((2, 2, 2), 5.0)
    meshio.write(tmp_path / "gel.vtu", meshio.Mesh(points, [("tetra", tetrahedra)]))
    for up, axis, side in (("y", 1, 0.0), ("-z", 2, 10.0), ("z", 2, 0.0)):
        out = tmp_path / f"model-{axis}-{side}.yaml"
        done = cli("mesh", tmp_path / "gel.vtu", "--scale", "0.001", "--rules", "liver",
                   "--tissue", "liver", "--fix-bottom", f"--up={up}", "--out", out)
        assert done.returncode == 0, done.stderr
        model = load_model(out)
        held = model.mesh.rest_positions[model.mesh.fixed]
        assert len(held) == 9 and np.allclose(held[:, axis], side * 1e-3)


def test_mesh_drive_top_names_the_plate_and_import_drives_it(lab, tmp_path):
    """``mesh --fix-bottom --drive-top`` writes the plate's face into the model file (along
    --up); ``import`` drives that set; a driven set that is also fixed is refused."""
    import meshio

    from neurofuzzy.io import load_model
    from neurofuzzy.io.load_steps import load_load_steps
    from neurofuzzy.mesh import Mesh

    points, tetrahedra = kuhn_block((3, 3, 3), SIZE * 1e3 / 3)
    meshio.write(tmp_path / "gel.vtu", meshio.Mesh(points, [("tetra", tetrahedra)]))
    for up, side in (("z", SIZE), ("-z", 0.0)):
        out = tmp_path / f"model{up}.yaml"
        done = cli("mesh", tmp_path / "gel.vtu", "--scale", "0.001", "--rules", "liver",
                   "--tissue", "liver", "--fix-bottom", "--drive-top", f"--up={up}",
                   "--out", out)
        assert done.returncode == 0, done.stderr
        assert "16 fixed nodes, 16 driven" in done.stdout
        mesh = load_model(out).mesh
        assert len(mesh.driven) == 16
        assert np.allclose(mesh.rest_positions[mesh.driven, 2], side)
        assert np.allclose(mesh.rest_positions[mesh.fixed, 2], SIZE - side)
    # the model's set is what import drives, whatever --up says to import
    model = load_model(tmp_path / "modelz.yaml")
    steps = tmp_path / "steps.npz"
    done = cli("import", lab / "scans.csv", "--topology", tmp_path / "modelz.yaml",
               "--displacements", lab / "plate.csv", "--out", steps, "--up=-z")
    assert done.returncode == 0, done.stderr
    driven = load_load_steps(steps).driven[0].nodes
    assert np.array_equal(np.sort(driven), model.mesh.driven)
    with pytest.raises(Exception, match="driven nodes are also fixed"):
        Mesh(points, load_model(tmp_path / "modelz.yaml").mesh.springs, fixed=[0, 1],
             driven=[1, 2])


@pytest.mark.slow
def test_fit_many_fits_a_cohort_of_compression_tests(lab, tmp_path):
    """Two specimens measured between plates, one with its load cell: fit-many's task fits
    each as ``fit`` does, writes its report, and the results table holds ν for both, E only
    where a force identifies it (no value and no word for the other); the one asked to be
    diagnosed gets the diagnosis's report too, E not identifiable there either."""
    from neurofuzzy.batch import read_manifest
    from neurofuzzy.batch.table import table_rows
    from neurofuzzy.batch.task import fit_specimen

    for name, plate in (("scans", "plate-no-force.csv"), ("cell", "plate.csv")):
        assert _import(lab, plate, tmp_path / f"{name}.npz").returncode == 0
    (tmp_path / "model.yaml").write_bytes((lab / "model.yaml").read_bytes())
    (tmp_path / "cohort.csv").write_text("id,group,experiments,start,rules,tissue,diagnose\n"
                                         "a,gel,scans.npz,model.yaml,liver,liver,true\n"
                                         "b,gel,cell.npz,model.yaml,liver,liver,false\n")
    specimens = read_manifest(tmp_path / "cohort.csv")
    records = {s.id: fit_specimen(s) for s in specimens}
    assert all(r["status"] == "ok" for r in records.values()), records
    assert {"fitted.yaml", "report.html", "report.json"} <= set(records["b"]["files"])
    assert "diagnosis.html" not in records["b"]["files"]
    diagnosis = json.loads(records["a"]["files"]["diagnosis.json"])       # asked for: drawn
    assert diagnosis["answer"] == records["a"]["fit"]["diagnosis"]["effects"]
    assert diagnosis["youngs_modulus"] is None and diagnosis["measured_force"] is None
    page = records["a"]["files"]["diagnosis.html"]
    assert b"not identifiable" in page and b"at the start's E" in page
    rows = {row["id"]: row for row in table_rows(specimens, records)}
    for row in rows.values():
        assert row["poisson_ratio"] == pytest.approx(0.45, abs=0.01)
        assert row["poisson_ratio_word"] is not None and row["rms_error"] < 1e-4
    assert rows["a"]["youngs_modulus"] is None and rows["a"]["youngs_modulus_word"] is None
    assert rows["b"]["youngs_modulus"] == pytest.approx(6000, rel=0.03)
