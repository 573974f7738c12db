"""The bad-input corpus (issue 12): every kind of malformed file and impossible option goes
through the command line in-process and must exit 2 with one line naming the file (FILE:LINE
for YAML) or the option, quickly, with no traceback, and leave nothing behind."""

import io
import json
import time
import zipfile

import numpy as np
import pytest

from neurofuzzy.cli import main
from neurofuzzy.io import save_experiment, save_model
from neurofuzzy.rules import shipped

RULES = shipped("liver").read_text()


# -- helpers ------------------------------------------------------------------------------
def refused(capsys, args, *, names, folder, seconds=10.0, one_line=True):
    """Run ``neurofuzzy ARGS``; assert exit 2, one line naming ``names`` (each a substring of
    the first line), no traceback, nothing new in ``folder`` and a run within ``seconds``.
    A rule base reports all its problems at once, one per line (``one_line=False``)."""
    before = {p.relative_to(folder) for p in folder.rglob("*")}
    started = time.perf_counter()
    status = main([str(a) for a in args])
    took = time.perf_counter() - started
    captured = capsys.readouterr()
    message = captured.err.strip() if one_line else captured.err.strip().splitlines()[0]
    assert status == 2, (status, captured.out[-500:], message)
    assert "Traceback" not in captured.err
    assert message.startswith("neurofuzzy: error: ") and "\n" not in message, message
    for name in ([names] if isinstance(names, str) else names):
        assert name in message, (name, message)
    after = {p.relative_to(folder) for p in folder.rglob("*")}
    assert after == before, f"left behind: {sorted(map(str, after - before))}"
    assert took < seconds, f"took {took:.1f} s"
    return message


@pytest.fixture(scope="module")
def files(tmp_path_factory, cube_model, cube_experiment):
    """A valid experiment and model of the cube, and the liver rule base beside them."""
    folder = tmp_path_factory.mktemp("valid")
    small = cube_experiment.first_frames(40)
    experiment = save_experiment(small, folder / "cube.npz")
    model = save_model(cube_model, folder / "cube.yaml")
    (folder / "soft_tissue.yaml").write_text(shipped("soft_tissue").read_text())
    with np.load(experiment) as archive:
        arrays = {key: archive[key] for key in archive.files}
    return {"folder": folder, "npz": experiment, "model": model, "arrays": arrays,
            "model_text": model.read_text()}


def rule_file(folder, text, name="r.yaml"):
    (folder / "soft_tissue.yaml").write_text(shipped("soft_tissue").read_text())
    path = folder / name
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    return path


def npz(folder, arrays, name="bad.npz", raw=None):
    """An experiment file of ``arrays`` (stored uncompressed), members in ``raw`` as given."""
    path = folder / name
    with zipfile.ZipFile(path, "w") as archive:
        for key, value in arrays.items():
            buffer = io.BytesIO()
            np.save(buffer, value)
            archive.writestr(key + ".npy", buffer.getvalue())
        for key, content in (raw or {}).items():
            archive.writestr(key + ".npy", content)
    return path


BOMB = "".join(f"{chr(97 + i)}: &{chr(97 + i)} [" + ",".join(
    [f"*{chr(96 + i)}"] * 9 if i else ['"lol"'] * 9) + "]\n" for i in range(10))


# -- rule files (YAML: FILE:LINE) ---------------------------------------------------------
@pytest.mark.parametrize("text, line, words", [
    ("extends: soft_tissue.yaml\nrules: 5\n", 2, "rules must be a list"),
    ("extends: soft_tissue.yaml\ntissues: [a, b]\n", 2, "tissues must be a mapping"),
    ("extends: soft_tissue.yaml\nname: !foo bar\n", 2, "unknown tag !foo"),
    ("extends: soft_tissue.yaml\nname: !!python/name:os.system\n", 2, "unknown tag"),
    ("extends: soft_tissue.yaml\nname: !!int abc\n", 2, "not a valid int"),
    ("extends: soft_tissue.yaml\nname: !!timestamp nope\n", 2, "unknown tag !!timestamp"),
    ("extends: soft_tissue.yaml\ntissues: !foo\n  x: {consistency: firm}\n", 2, "unknown tag"),
    ("extends: soft_tissue.yaml\nname: " + "[" * 5000 + "]" * 5000 + "\n", 2, "nested more"),
    ("extends: soft_tissue.yaml\nname: &a [*a]\n", 2, "a cycle"),
    ("extends: soft_tissue.yaml\nname: a\nname: b\n", 3, "duplicate key 'name' (first at "
                                                         "line 2)"),
    (b"extends: soft_tissue.yaml\nname: caf\xe9\n", 2, "not UTF-8"),
    (b"extends: soft_tissue.yaml\nname: a\x00b\n", 2, "U+0000"),
    ("extends: soft_tissue.yaml\n" + BOMB, 9, "expands to more than"),
    ("extends: .\n", 1, "a directory"),
    ("extends: [a]\n", 1, "extends must name a rule file"),
    ("extends: soft_tissue.yaml\ntissues:\n  x: {consistency: -3}\n", 3,
     "consistency = -3 is outside its universe [0, 10]"),
    ("extends: soft_tissue.yaml\ntissues:\n  x: {consistency: .nan}\n", 3, "nan is outside"),
    ("extends: soft_tissue.yaml\ntissues:\n  x: {consistency: .inf}\n", 3, "inf is outside"),
    ("inputs:\n  a:\n    universe: [0, .inf]\n    terms: {lo: {trimf: [0, 1, 2]}}\n", 3,
     "finite numbers"),
    ("extends: soft_tissue.yaml\n---\nname: b\n", 2, "more than one YAML document"),
    ("extends: soft_tissue.yaml\n<<: {name: b}\n", 2, "merge keys"),
])
def test_bad_rule_files_name_file_and_line(tmp_path, capsys, text, line, words):
    path = rule_file(tmp_path, text)
    message = refused(capsys, ["rules", "check", path], names=[f"{path}:{line}:", words],
                      folder=tmp_path, seconds=5, one_line=False)
    assert "Traceback" not in message


def test_alias_bomb_and_huge_rule_files_fail_fast(tmp_path, capsys):
    bomb = rule_file(tmp_path, BOMB, name="bomb.yaml")
    started = time.perf_counter()
    refused(capsys, ["rules", "check", bomb], names=f"{bomb}:", folder=tmp_path, seconds=2)
    assert time.perf_counter() - started < 1.0
    huge = rule_file(tmp_path, RULES + "#" * (5 * 2**20) + "\n", name="huge.yaml")
    refused(capsys, ["rules", "check", huge], names=[str(huge), "at most 1 MB"],
            folder=tmp_path, seconds=2)


def test_a_tissue_outside_its_universe_is_refused_through_the_python_api_too():
    from neurofuzzy.errors import InputError
    from neurofuzzy.rules import load_rules

    rules = load_rules(shipped("liver"))
    with pytest.raises(InputError, match=r"consistency: -3 is outside the universe \[0, 10\]"):
        rules.infer([{"consistency": -3.0}])
    with pytest.raises(InputError, match="nan is outside"):
        rules.infer([{"consistency": float("nan")}])


# -- model files --------------------------------------------------------------------------
def _model_data(text, section, key, value):
    import yaml

    data = yaml.safe_load(text)
    (data if section is None else data[section])[key] = value
    return yaml.safe_dump(data, default_flow_style=None, width=100, sort_keys=False)


@pytest.mark.parametrize("edit, line, words", [
    (lambda t: _model_data(t, None, "nodes", 5), 2, "nodes: expected a mapping"),
    (lambda t: t.replace("  stiffness:", "  stifness:", 1), None,
     "springs.stifness: unknown key; did you mean 'stiffness'?"),
    (lambda t: _model_data(t, "springs", "damping", 0.5), None,
     "springs.damping: expected a list, got the number 0.5"),
    (lambda t: _model_data(t, "springs", "damping", "soft"), None, "expected a list"),
    (lambda t: _model_data(t, "nodes", "mass", [[1, 2]] * 27), None, "nodes.mass"),
    (lambda t: t.replace("format: neurofuzzy-model/1", "format: neurofuzzy-model/1\nformat: x",
                         1), 3, "duplicate key 'format'"),
    (lambda t: t.replace("  mass: [", "  mass: !!python/object:os.system [", 1), None,
     "unknown tag"),
    (lambda t: t.replace("  mass: [", "  mass: [-1, ", 1), None, "nodes.mass"),
    (lambda t: t + "extra: " + "[" * 200 + "]" * 200 + "\n", None, "nested more"),
    (lambda t: t.encode("utf-8").replace(b"format", b"f\xffrmat", 1), 2, "not UTF-8"),
    (lambda t: "format: neurofuzzy-model/1\n" + BOMB, 9, "expands to more than"),
    (lambda t: _model_data(t, None, "effects", [{"name": "hyperelasticity", "params": [1.0]}]),
     None, "hyperelasticity is a change of the elements' material, not a force"),
])
def test_bad_model_files_name_file_key_and_line(tmp_path, capsys, files, edit, line, words):
    path = tmp_path / "model.yaml"
    content = edit(files["model_text"])
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    where = f"{path}:{line}:" if line else f"{path}:"
    refused(capsys, ["simulate", path, "--frames", "5", "--out", tmp_path / "x.npz"],
            names=[where, words], folder=tmp_path)


def test_an_unstable_model_file_is_named(tmp_path, capsys, files):
    refused(capsys, ["simulate", files["model"], "--dt", "0.01", "--out", tmp_path / "x.npz"],
            names=[str(files["model"]), "unstable"], folder=tmp_path)


# -- experiment files ---------------------------------------------------------------------
def _with(arrays, **changes):
    out = dict(arrays)
    for key, value in changes.items():
        if value is None:
            out.pop(key)
        else:
            out[key] = value(out[key]) if callable(value) else value
    return out


def _at(value, index, array):
    array = array.copy()
    array[index] = value
    return array


@pytest.mark.parametrize("changes, raw, words", [
    ({"springs": np.zeros((0, 2), int), "spring_groups": np.zeros(0, int)}, None,
     "springs: no springs"),
    ({"fixed": np.arange(27)}, None, "fixed: all 27 nodes are fixed"),
    ({"observed": lambda o: np.isin(np.arange(27), [0, 3, 6, 9, 12, 15, 18, 21, 24])}, None,
     "observed: every observed node is fixed"),
    ({"positions": lambda p: _at(1e300, (5, 20, 0), p)}, None, "absurdly large"),
    ({"springs": lambda s: np.vstack([s, s[:1, ::-1]]),
      "spring_groups": lambda g: np.r_[g, 0]}, None,
     "springs: spring 86 connects the same two nodes as spring 0"),
    ({}, {"masses": b"\x93NUMPY\x01\x00\x10\x00{'descr': '<f8',,}\n"}, "masses: "),
    ({"dt": None}, {"dt": b"hello raw bytes"}, "dt: "),
    ({"masses": None}, {"masses": b"\x93NUMPY\x01\x00\x40\x00{'descr': '<f8', "     # no }
                                  b"'fortran_order': False, 'shape': (27,), " + b" " * 6 + b"\n"
                                  + np.ones(27).tobytes()},
     "masses: its .npy header is not a closed Python dictionary"),
    ({"masses": None}, {"masses": b"\x93NUMPY\x01\x00v\x00{'descr': '<f8', 'fortran_order': "
                                  b"False, 'shape': (100000000000,), }" + b" " * 50 + b"\n"},
     "truncated or corrupt"),
    ({"masses": np.array([{"a": 1}] * 27, dtype=object)}, None, ""),
    ({"dt": np.array(0.0)}, None, "dt: got 0.0; expected a positive number"),
    ({"dt": np.array(np.nan)}, None, "dt: got nan"),
    ({"tetrahedra": np.array([[0, 1, 2, 3], [3, 2, 1, 0]])}, None,
     "tetrahedron 1 has the same four nodes as tetrahedron 0"),
    ({"tetrahedra": np.array([[0, 1, 2, 3]])}, None, "zero volume"),
])
def test_bad_experiment_files_name_file_and_key(tmp_path, capsys, files, changes, raw, words):
    arrays = _with(files["arrays"], **changes)
    if "masses" in changes and changes["masses"] is not None and \
            getattr(changes["masses"], "dtype", None) == object:
        path = tmp_path / "bad.npz"
        np.savez(path, **arrays)                 # pickled member: refused, never unpickled
    else:
        path = npz(tmp_path, arrays, raw=raw)
    refused(capsys, ["fit", path, "--out", tmp_path / "fit.yaml"], names=[str(path), words],
            folder=tmp_path)


def test_corrupt_deflate_stream_and_truncated_archives(tmp_path, capsys, files):
    good = files["npz"].read_bytes()
    corrupt = bytearray(good)
    for i in range(200, 260):
        corrupt[i] ^= 0xFF
    for name, content in (("deflate.npz", bytes(corrupt)), ("cut.npz", good[:len(good) // 2]),
                          ("empty.npz", b"")):
        path = tmp_path / name
        path.write_bytes(content)
        refused(capsys, ["fit", path], names=str(path), folder=tmp_path)
        path.unlink()


def test_nothing_measured_that_moves_with_markers(tmp_path, capsys, files):
    arrays = dict(files["arrays"])
    frames = arrays["positions"].shape[0]
    fixed = arrays["fixed"]
    arrays.update(marker_positions=np.repeat(arrays["rest_positions"][None, :2], frames, 0),
                  marker_nodes=np.array([fixed[:4], fixed[1:5]]),
                  marker_weights=np.full((2, 4), 0.25), marker_names=np.array(["a", "b"]))
    path = npz(tmp_path, arrays)
    refused(capsys, ["fit", path], names=[str(path), "marker_nodes: every marker sits on fixed"],
            folder=tmp_path)


# -- marker recordings, maps, meshes ------------------------------------------------------
def test_bad_marker_files_and_maps(tmp_path, capsys, files):
    single = tmp_path / "single.csv"
    single.write_text("# units: mm\ntime,marker,x,y,z\n0,A,1,2,3\n0,B,4,5,6\n")
    refused(capsys, ["import", single, "--topology", files["npz"], "--out", tmp_path / "o.npz"],
            names=[f"{single}:4:", "at least two capture times"], folder=tmp_path)
    c3d = tmp_path / "wrong.c3d"
    c3d.write_bytes(b"\x02\x51" + bytes(1022))
    refused(capsys, ["import", c3d, "--topology", files["npz"], "--out", tmp_path / "o.npz"],
            names=[str(c3d), "not a C3D file"], folder=tmp_path)
    markers = tmp_path / "markers.csv"
    markers.write_text("# units: m\ntime,marker,x,y,z\n" + "".join(
        f"{t * 5e-4},M{n},{x},{y},{z}\n" for t in range(3)
        for n, (x, y, z) in enumerate(files["arrays"]["rest_positions"][20:23])))
    for rows, line, words in (("M0,99\n", 2, "node 99 is out of range"),
                              ("M9,20\n", 2, "marker 'M9' is not in"),
                              ("M0,20\nM1,20\n", 3, "both belong to node 20")):
        mapping = tmp_path / "map.csv"
        mapping.write_text("marker,node\n" + rows)
        refused(capsys, ["import", markers, "--topology", files["npz"], "--map", mapping,
                         "--out", tmp_path / "o.npz"], names=[f"{mapping}:{line}:", words],
                folder=tmp_path)
        mapping.unlink()


def test_bad_meshes_and_resource_guards(tmp_path, capsys):
    trimesh = pytest.importorskip("trimesh")
    sphere = tmp_path / "sphere.stl"
    trimesh.creation.icosphere(radius=0.05).export(sphere)
    out = tmp_path / "m.yaml"
    message = refused(capsys, ["mesh", sphere, "--rules", "liver", "--tissue", "liver",
                               "--pitch", "1e-5", "--out", out],
                      names=[str(sphere), "pitch", "1e+12 cells", "GB"], folder=tmp_path,
                      seconds=5)
    assert "use at least about" in message
    refused(capsys, ["mesh", sphere, "--rules", "liver", "--tissue", "liver", "--tetra",
                     "--max-edge", "1e-5", "--out", out], names=["max_edge", "cells"],
            folder=tmp_path, seconds=5)
    garbage = tmp_path / "garbage.vtu"
    garbage.write_bytes(b"<?xml version='1.0'?><VTKFile><Unstr")
    refused(capsys, ["mesh", garbage, "--rules", "liver", "--tissue", "liver", "--out", out],
            names=str(garbage), folder=tmp_path)


# -- options ------------------------------------------------------------------------------
@pytest.mark.parametrize("args, option", [
    (["simulate", "cube", "--dt", "0"], "--dt"),
    (["simulate", "cube", "--dt", "nan"], "--dt"),
    (["simulate", "cube", "--noise", "-1"], "--noise"),
    (["simulate", "cube", "--noise", "nan"], "--noise"),
    (["simulate", "cube", "--frames", "1"], "--frames"),
    (["simulate", "cube", "--seed", "-1"], "--seed"),
    (["simulate", "cube", "--substeps", "0"], "--substeps"),
    (["simulate", "cube", "--substeps", "1000000"], "--substeps"),
    (["simulate", "cube", "--force", "5", "nan", "0", "0"], "--force"),
    (["fit", "NPZ", "--cycles", "0", "--method", "paper"], "--cycles"),
    (["fit", "NPZ", "--cycles", "-5"], "--cycles"),
    (["fit", "NPZ", "--learning-rate", "nan", "--method", "paper"], "--learning-rate"),
    (["fit", "NPZ", "--substeps", "-2"], "--substeps"),
    (["diagnose", "NPZ", "--max-effects", "-1"], "--max-effects"),
    (["diagnose", "NPZ", "--max-time", "0"], "--max-time"),
    (["diagnose", "NPZ", "--max-time", "nan"], "--max-time"),
    (["import", "x.csv", "--topology", "NPZ", "--dt", "0"], "--dt"),
    (["import", "x.csv", "--topology", "NPZ", "--force-spread", "0"], "--force-spread"),
    (["export", "MODEL", "--every", "0"], "--every"),
    (["mesh", "x.stl", "--rules", "liver", "--tissue", "liver", "--pitch", "0"], "--pitch"),
    (["mesh", "x.stl", "--rules", "liver", "--tissue", "liver", "--pitch", "nan"], "--pitch"),
    (["mesh", "x.stl", "--rules", "liver", "--tissue", "liver", "--scale", "-1"], "--scale"),
    (["demo", "--cycles", "-5"], "--cycles"),
])
def test_impossible_options_are_refused_never_replaced(tmp_path, capsys, files, args, option):
    args = [{"NPZ": files["npz"], "MODEL": files["model"]}.get(a, a) for a in args]
    args += ["--out", tmp_path / ("demo" if args[0] == "demo" else "out.x")]
    refused(capsys, args, names=option, folder=tmp_path)


# -- fits that fail -----------------------------------------------------------------------
@pytest.mark.parametrize("change, words", [
    ({"dt": lambda dt: dt * 100}, "learning diverged"),
    ({"masses": lambda m: m * 1e-6}, "above the stability limit"),
])
def test_a_fit_that_fails_says_why_and_writes_nothing(tmp_path, capsys, files, change, words):
    path = npz(tmp_path, _with(files["arrays"], **change), name="trial.npz")
    refused(capsys, ["fit", path, "--method", "paper", "--cycles", "2", "--quiet", "--out",
                     tmp_path / "new" / "fit.yaml", "--report", tmp_path / "fit.html"],
            names=[str(path), "the fit failed", words, "likely cause", "nothing written"],
            folder=tmp_path, seconds=30)


# -- outputs ------------------------------------------------------------------------------
def test_a_report_twin_never_replaces_a_file_the_user_did_not_name(tmp_path, capsys, files):
    twin = tmp_path / "fit.json"
    twin.write_text("the output of fit --json, say")
    refused(capsys, ["fit", files["npz"], "--report", tmp_path / "fit.html", "--json"],
            names=[str(twin), "not a report's JSON twin"], folder=tmp_path)
    assert twin.read_text() == "the output of fit --json, say"


def test_the_twin_of_an_earlier_report_is_replaced(tmp_path, capsys, files):
    report = tmp_path / "fit.html"
    for _ in range(2):
        assert main(["fit", str(files["npz"]), "--tie", "global", "--report", str(report),
                     "--quiet"]) == 0
    twin = json.loads(report.with_suffix(".json").read_text())
    assert twin["generator"].startswith("neurofuzzy report")
    capsys.readouterr()


def test_outputs_are_published_together_or_not_at_all(tmp_path, capsys, files, monkeypatch):
    import importlib

    # the package (``neurofuzzy.export`` as an attribute is the function nf.export)
    exporters = importlib.import_module("neurofuzzy.export")

    def broken(*args, **kwargs):
        from neurofuzzy.errors import InputError

        raise InputError("disk full (simulated)", source="paraview")

    monkeypatch.setattr(exporters, "export_paraview", broken)
    refused(capsys, ["fit", files["npz"], "--tie", "global", "--out", tmp_path / "a" / "f.yaml",
                     "--report", tmp_path / "b" / "r.html", "--export", tmp_path / "pv",
                     "--quiet"], names="disk full", folder=tmp_path)
    monkeypatch.undo()
    assert main(["fit", str(files["npz"]), "--tie", "global", "--out", str(tmp_path / "f.yaml"),
                 "--report", str(tmp_path / "r.html"), "--export", str(tmp_path / "pv"),
                 "--quiet"]) == 0
    names = sorted(p.name for p in tmp_path.rglob("*"))
    assert not [n for n in names if n.startswith(".")], names
    assert {"f.yaml", "r.html", "r.json", "cube.pvd"} <= set(names)
    assert '<a href="f.yaml">' in (tmp_path / "r.html").read_text()
    capsys.readouterr()


def test_two_outputs_on_one_path_are_refused(tmp_path, capsys, files):
    refused(capsys, ["fit", files["npz"], "--out", tmp_path / "x.json", "--report",
                     tmp_path / "x.html"], names=["x.json", "name the same path"],
            folder=tmp_path)
