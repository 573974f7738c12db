import json
import subprocess
import sys

import numpy as np
import pytest

from neurofuzzy.cli import main
from neurofuzzy.datasets import CUBE
from neurofuzzy.io import load_model, save_experiment


def run_cli(*args, cwd=None):
    """Run the installed command in a fresh interpreter (as a user would)."""
    return subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


@pytest.fixture(scope="module")
def cube_file(tmp_path_factory, cube_experiment):
    return save_experiment(cube_experiment, tmp_path_factory.mktemp("data") / "cube.npz")


def test_fit_json_has_the_promised_keys(cube_file, tmp_path, capsys):
    out = tmp_path / "fitted.yaml"
    status = main(["fit", str(cube_file), "--tie", "global", "--json", "--out", str(out)])
    assert status == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    for key in ("stiffness", "damping", "node_mass", "rms_error", "rms_error_initial", "cycles",
                "seconds", "std_errors", "unidentifiable"):
        assert key in result, key
    assert len(result["stiffness"]) == 86 and len(result["node_mass"]) == 27
    assert np.allclose(result["stiffness"], CUBE["stiffness"], rtol=1e-6)
    assert np.allclose(result["damping"], CUBE["damping"], rtol=1e-6)
    assert result["rms_error"] < 1e-6 * result["rms_error_initial"] + 1e-15
    assert np.allclose(load_model(out).springs.stiffness, result["stiffness"])
    assert "gradient fit" in captured.err   # progress on stderr, also with --json


def test_fit_paper_method_prints_progress_on_stderr(cube_file, capsys):
    assert main(["fit", str(cube_file), "--method", "paper", "--tie", "global",
                 "--cycles", "3"]) == 0
    captured = capsys.readouterr()
    assert "paper learner: 3/3" in captured.err
    assert "RMS error" in captured.out


def _broken(tmp_path, cube_experiment, **changes):
    arrays = {"rest_positions": cube_experiment.mesh.rest_positions,
              "springs": cube_experiment.mesh.springs.copy(), "dt": cube_experiment.dt,
              "positions": cube_experiment.positions.copy(),
              "fixed": cube_experiment.mesh.fixed,
              "external_forces": cube_experiment.external_forces}
    for key, value in changes.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value(arrays[key]) if callable(value) else value
    path = tmp_path / "bad.npz"
    np.savez(path, **arrays)
    return path


def _inf_at(array):
    array[5, 20, 1] = np.inf
    return array


def _out_of_range(springs):
    springs[7, 0] = 40
    return springs


@pytest.mark.parametrize("changes, message", [
    ({"positions": None}, "positions: required key is missing"),
    ({"positions": lambda p: p[:, :, :2]}, "positions: got shape (251, 27, 2)"),
    ({"positions": _inf_at}, "positions: infinite value at frame 5, node 20"),
    ({"springs": _out_of_range}, "springs: node index 40 is out of range"),
])
def test_bad_input_exits_2_with_one_line_and_no_traceback(tmp_path, cube_experiment, changes,
                                                          message):
    path = _broken(tmp_path, cube_experiment, **changes)
    result = run_cli("fit", path, "--json")
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    assert result.stderr.count("\n") == 1
    assert str(path) in result.stderr and message in result.stderr
    assert result.stdout == ""


def test_unstable_step_exits_2(tmp_path):
    result = run_cli("simulate", "cube", "--dt", "0.01", "--out", tmp_path / "x.npz")
    assert result.returncode == 2
    assert "unstable" in result.stderr and "substeps" in result.stderr
    assert "Traceback" not in result.stderr
    assert not (tmp_path / "x.npz").exists()


def test_simulate_then_fit_round_trip(tmp_path):
    data = tmp_path / "pull.npz"
    result = run_cli("simulate", "cube", "--force", "26", "0.1", "0", "0", "--frames", "120",
                     "--out", data)
    assert result.returncode == 0, result.stderr
    fitted = tmp_path / "fit.yaml"
    result = run_cli("fit", data, "--tie", "groups", "--out", fitted, "--json")
    assert result.returncode == 0, result.stderr
    model = load_model(fitted)
    assert np.allclose(model.springs.stiffness, 50.0, rtol=1e-6)


def test_never_writes_over_an_input(cube_file):
    before = cube_file.read_bytes()
    result = run_cli("fit", cube_file, "--out", cube_file)
    assert result.returncode == 2 and "never writes over its input" in result.stderr
    assert cube_file.read_bytes() == before


@pytest.mark.slow
def _not_json(constant):
    raise ValueError(f"{constant} is not JSON")


def test_demo_writes_table_plot_and_summary(tmp_path):
    result = run_cli("demo", "--out", tmp_path / "demo", "--cycles", "5", "--quiet")
    assert result.returncode == 0, result.stderr
    assert "paper E" in result.stdout
    assert "firm -> hard" in result.stdout and "diagnosis: gravity" in result.stdout
    for name in ("error_per_cycle.png", "table.txt", "summary.json", "report.html",
                 "report.json", "diagnosis.html", "diagnosis.json"):
        assert (tmp_path / "demo" / name).stat().st_size > 0
    page = (tmp_path / "demo" / "diagnosis.html").read_text()
    assert "nothing is marked" in page and "Red:" not in page     # gravity acts everywhere
    summary = json.loads((tmp_path / "demo" / "summary.json").read_text(),
                         parse_constant=_not_json)   # a diverged start is null, not Infinity
    assert {run["experiment"] for run in summary["runs"]} == {1, 2, 3}
    # experiment 3 (jointly learned constants): the gradient learner recovers them (the paper
    # learner needs its 100 cycles, run by the demo itself, not in 5)
    third = next(run for run in summary["runs"]
                 if run["experiment"] == 3 and run["learner"] == "gradient")
    assert third["stiffness_error"] < 0.01 and third["rms_final"] < 1e-3 * third["rms_initial"]


@pytest.mark.slow
def test_fit_tie_groups_on_rk4_data_recovers_groups_within_two_percent(tmp_path):
    from neurofuzzy.datasets import paper_cube_model, point_load, top_centre_node
    from neurofuzzy.validation.integrators import reference_experiment

    truth = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 35.0}, damping=0.02)
    load = point_load(truth.mesh, top_centre_node(truth.mesh), CUBE["force"])
    data = save_experiment(reference_experiment(truth, dt=CUBE["dt"], n_frames=251,
                                                external_forces=load, method="rk4",
                                                substeps=10), tmp_path / "rk4.npz")
    result = run_cli("fit", data, "--tie", "groups", "--json")
    assert result.returncode == 0, result.stderr
    fitted = json.loads(result.stdout)
    groups = truth.mesh.spring_group
    stiffness, damping = np.array(fitted["stiffness"]), np.array(fitted["damping"])
    assert np.allclose(stiffness[groups == 0], 60.0, rtol=0.02)
    assert np.allclose(stiffness[groups == 1], 35.0, rtol=0.02)
    assert np.allclose(damping, 0.02, rtol=0.02)


def test_never_writes_over_the_rule_file(cube_file, tmp_path):
    rules = tmp_path / "r.yaml"
    rules.write_text("name: x\n")
    result = run_cli("fit", cube_file, "--rules", rules, "--tissue", "t", "--out", rules)
    assert result.returncode == 2 and "never writes over its input" in result.stderr
    assert rules.read_text() == "name: x\n"


def test_fit_exports_paraview_files_and_the_report_links_them(cube_experiment, tmp_path,
                                                             capsys):
    import meshio

    short = save_experiment(cube_experiment.replace(positions=cube_experiment.positions[:40]),
                            tmp_path / "cube.npz")
    report = tmp_path / "fit.html"
    status = main(["fit", str(short), "--tie", "global", "--quiet", "--out",
                   str(tmp_path / "fitted.yaml"), "--export", str(tmp_path / "paraview"),
                   "--report", str(report)])
    assert status == 0
    frames = sorted((tmp_path / "paraview").glob("cube_*.vtu"))
    assert len(frames) == 40
    last = meshio.read(frames[-1])
    assert np.allclose(last.point_data["measured"], cube_experiment.positions[39], atol=1e-12)
    text = report.read_text()
    assert 'href="paraview/cube.pvd"' in text and 'href="fitted.yaml"' in text
    assert json.loads(report.with_suffix(".json").read_text())["files"]["ParaView xdmf"] == \
        "paraview/cube.xdmf"


def test_export_command_writes_a_thinned_series(cube_file, tmp_path, capsys):
    from neurofuzzy.datasets import paper_cube_model
    from neurofuzzy.io import save_model

    model = save_model(paper_cube_model(), tmp_path / "cube.yaml")
    assert main(["export", str(model), str(cube_file), "--out", str(tmp_path / "pv"),
                 "--every", "50", "--formats", "vtu"]) == 0
    assert sorted(p.name for p in (tmp_path / "pv").iterdir()) == [
        "neurofuzzy.pvd", *(f"neurofuzzy_{t:04d}.vtu" for t in range(0, 251, 50))]
    assert main(["export", str(model), str(cube_file), "--out", str(tmp_path / "pv"),
                 "--every", "0"]) == 2
    assert "every" in capsys.readouterr().err


def test_mesh_command_builds_a_model_from_a_surface_and_rules(tmp_path, capsys):
    import trimesh

    box = trimesh.creation.box(extents=(0.04, 0.04, 0.02))
    box.export(tmp_path / "box.stl")
    out = tmp_path / "box.yaml"
    assert main(["mesh", str(tmp_path / "box.stl"), "--pitch", "0.01", "--fix-bottom",
                 "--rules", "liver", "--tissue", "liver", "--out", str(out)]) == 0
    model = load_model(out)
    assert model.n_nodes == 5 * 5 * 3 and len(model.mesh.fixed) == 25
    assert np.allclose(model.mesh.rest_positions[model.mesh.fixed, 2], -0.01)
    printed = capsys.readouterr().out
    assert "25 fixed nodes" in printed
    assert "voxel cells of 0.01 m; --pitch P refines or coarsens" in printed
    assert main(["mesh", str(tmp_path / "box.stl"), "--fix-bottom", "--rules", "liver",
                 "--tissue", "liver", "--out", str(tmp_path / "default.yaml")]) == 0
    assert "voxel cells of 0.004 m (default extent / 10)" in capsys.readouterr().out

    open_box = trimesh.Trimesh(box.vertices, box.faces[:-1])     # one face missing
    open_box.export(tmp_path / "open.stl")
    assert main(["mesh", str(tmp_path / "open.stl"), "--pitch", "0.01", "--rules", "liver",
                 "--tissue", "liver", "--out", str(tmp_path / "open.yaml")]) == 2
    err = capsys.readouterr().err
    assert "open.stl" in err and "watertight" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "open.yaml").exists()
    assert main(["mesh", str(tmp_path / "box.stl"), "--pitch", "0.01", "--rules", "liver",
                 "--tissue", "livr", "--out", str(tmp_path / "x.yaml")]) == 2
    assert "liver" in capsys.readouterr().err


def test_fit_refuses_unknown_masses_it_cannot_estimate(cube_experiment, tmp_path, capsys):
    observed = np.ones(27, bool)
    observed[13] = False
    surface = cube_experiment.replace(
        observed=observed, node_mass=None,
        positions=np.where(observed[None, :, None], cube_experiment.positions, np.nan))
    path = save_experiment(surface, tmp_path / "surface.npz")
    assert main(["fit", str(path), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "surface.npz: masses: gives no 'masses'" in err and "--rules" in err


def test_json_fit_reports_progress_on_stderr_in_the_final_rms_definition(tmp_path):
    """--json keeps stdout one JSON object and progress on stderr; the progress RMS carries its
    unit and is the lack-of-fit module's RMS per marker, the one the JSON reports."""
    import re

    data = tmp_path / "noisy.npz"
    assert run_cli("simulate", "cube", "--out", data, "--noise", "1e-5", "--seed", "1",
                   "--frames", "101").returncode == 0
    result = run_cli("fit", data, "--tie", "global", "--json")
    assert result.returncode == 0, result.stderr
    fitted = json.loads(result.stdout)
    shown = re.findall(r"RMS ([0-9.e+-]+) µm per marker", result.stderr)
    assert shown, result.stderr
    assert float(shown[-1]) * 1e-6 == pytest.approx(fitted["rms_error"], rel=5e-3)
    # noise 1e-5 m per coordinate is √3 · 1e-5 m per marker
    assert fitted["rms_error"] == pytest.approx(np.sqrt(3) * 1e-5, rel=0.1)


def test_progress_rms_of_a_free_run_is_that_run_s_not_an_earlier_window_s(tmp_path):
    """Issue 50: a fit the model class cannot follow printed 'RMS 190 µm' on every progress
    line (the best of the first stage's 25-frame windows, restarted from the data) and 297 µm
    in its summary; each line now gives its own stage's RMS."""
    import re

    data = tmp_path / "cube.npz"
    assert run_cli("simulate", "cube", "--out", data).returncode == 0
    result = run_cli("fit", data, "--rules", "brain", "--tissue", "white_matter", "--json")
    assert result.returncode == 0, result.stderr
    fitted = json.loads(result.stdout)
    windows = re.findall(r"window 25 frames, RMS ([0-9.e+-]+) µm", result.stderr)
    free = re.findall(r"window 251 frames, RMS ([0-9.e+-]+) µm", result.stderr)
    assert windows and len(free) >= 2
    assert float(windows[0]) < 0.8 * float(free[0])         # windows restart from the data
    for shown in free:
        assert float(shown) * 1e-6 == pytest.approx(fitted["rms_error"], rel=0.03)


def test_version():
    from neurofuzzy.version import __version__

    result = run_cli("--version")
    assert result.returncode == 0
    assert result.stdout.strip() == f"neurofuzzy {__version__}"


def _options(parser, path=()):
    """(command path, argparse action) of every option of every sub-command."""
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _options(sub, (*path, name))
        elif action.option_strings and not isinstance(
                action, (argparse._HelpAction, argparse._VersionAction)):
            yield path, action


def test_every_option_has_help_naming_its_default():
    """Every option says what it does, and an option with a default says which."""
    from neurofuzzy.cli.parser import build_parser

    options = list(_options(build_parser()))
    assert len(options) > 80
    for path, action in options:
        name = " ".join((*path, action.option_strings[-1]))
        assert action.help, f"no help for {name}"
        assert "DESIGN.md" not in action.help, name    # not in the repository
        has_default = not (action.default is None or action.default is False
                           or action.required)
        if has_default:
            assert "default" in action.help, f"{name}: no default in {action.help!r}"


def test_help_texts_name_units_and_where_formats_are_documented():
    result = run_cli("simulate", "--help")
    assert "DESIGN.md" not in result.stdout and "docs/formats.md" in result.stdout
    assert "newtons" in result.stdout and "default 251" in result.stdout
    import_help = run_cli("import", "--help").stdout
    assert "DESIGN.md" not in import_help and "docs/formats.md" in import_help
    fit_help = " ".join(run_cli("fit", "--help").stdout.split())
    assert "tetrahedral elements" in fit_help


def test_examples_write_only_into_ignored_folders():
    """Every example's default output folder is in .gitignore."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    ignored = set((root / ".gitignore").read_text().split())
    folders = {name for path in (root / "examples").glob("*.py")
               for name in re.findall(r'"([a-z-]+-output)"', path.read_text())}
    assert len(folders) >= 7
    assert {f"{name}/" for name in folders} <= ignored


def test_diagnose_max_time_answers_provisionally(tmp_path, capsys):
    """diagnose --max-time on the cube under a gravity the start does not know: out of time
    after the first fit, the answer so far, marked provisional in the JSON, the verdict and
    on stderr; exit status 0."""
    from neurofuzzy.datasets import paper_cube_experiment, paper_cube_model
    from neurofuzzy.effects import Gravity

    hanging = paper_cube_model().with_effects(Gravity([0.0, 0.0, -9.81]))
    data = save_experiment(paper_cube_experiment(hanging), tmp_path / "hanging.npz")
    status = main(["diagnose", str(data), "--tie", "global", "--max-time", "1e-9", "--json"])
    assert status == 0
    captured = capsys.readouterr()
    result = json.loads(captured.out)
    assert result["provisional"].startswith("stopped after")
    assert result["verdict"].startswith("provisional (stopped after")
    assert "the answer is provisional" in captured.err
