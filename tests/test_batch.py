"""fit-many: manifests, Dask tasks, bookkeeping, resume and the cohort report.

The cohort is synthetic (:func:`neurofuzzy.batch.synthetic.synthetic_cohort`: the 27-node
cube of healthy and fibrotic liver, seeded variation and 5 µm marker noise, fits tied
globally at one step per frame, well under a second each) plus one specimen whose experiment
file is corrupt. One local Dask cluster serves these tests; the command reaches it with
``--scheduler``, as it would reach a remote one. They take 15-40 s together (starting worker
processes, a report per specimen), so they are marked slow; the fast suite runs one small
batch on the local cluster fit-many starts itself.
"""

import json
import logging
import os
import shutil
from types import SimpleNamespace

import numpy as np
import pytest
from helpers import cli

from neurofuzzy.batch import (cohort_summary, fit_quality, fit_specimen, median_difference,
                              read_manifest)
from neurofuzzy.batch.synthetic import synthetic_cohort
from neurofuzzy.datasets import paper_cube_experiment, paper_cube_model

BROKEN = "broken,fibrotic,data/broken.npz,liver,liver,global,1\n"


@pytest.fixture(scope="module")
def cohort(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cohort")
    made = synthetic_cohort(folder, per_group=2, seed=7)
    (folder / "data" / "broken.npz").write_bytes(b"this is not a zip archive")
    with open(made.manifest, "a", encoding="utf-8") as handle:
        handle.write(BROKEN)
    return made


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None, silence_logs=logging.ERROR) as started:
        yield started


@pytest.fixture(scope="module")
def first_run(cohort, cluster, tmp_path_factory):
    folder = tmp_path_factory.mktemp("results")
    out, report = folder / "results", folder / "cohort.html"
    result = cli("fit-many", cohort.manifest, "--out", out, "--report", report,
                 "--scheduler", cluster.scheduler_address, "--json")
    return SimpleNamespace(result=result, out=out, report=report,
                           summary=json.loads(result.stdout))


@pytest.mark.slow
def test_every_specimen_is_fitted_on_the_scheduler_and_a_failure_is_recorded(first_run,
                                                                              cohort):
    result, out = first_run.result, first_run.out
    assert result.returncode == 1, result.stderr            # one specimen failed
    assert sorted(first_run.summary["ok"]) == sorted(cohort.truth)
    [failed] = first_run.summary["failed"]
    assert failed["id"] == "broken" and "broken.npz" in failed["error"]
    assert "neurofuzzy: failed: broken:" in result.stderr and "Traceback" not in result.stderr
    error = json.loads((out / "broken" / "error.json").read_text())
    assert error["kind"] == "input" and "traceback" not in error
    assert not (out / "broken" / "fit.json").exists()
    for ident, truth in cohort.truth.items():
        record = json.loads((out / ident / "fit.json").read_text())
        assert record["status"] == "ok" and record["group"] == truth["group"]
        assert int(record["worker"].rsplit(":", 1)[1]) != os.getpid()     # ran on a worker
        for name in ("fitted.yaml", "report.html", "report.json"):
            assert (out / ident / name).stat().st_size > 0, name
        [material] = record["fit"]["materials"].values()
        assert material["youngs_modulus"] == pytest.approx(truth["youngs_modulus"], rel=1e-2)
        assert material["labels"]["youngs_modulus"] == truth["words"]["youngs_modulus"]
        # the fit reaches the marker noise: the ratio is about 1
        assert 0.8 < record["fit"]["quality"]["noise_ratio"] < 1.25


@pytest.mark.slow
def test_the_table_has_a_row_per_specimen_with_materials_and_quality(first_run, cohort):
    import csv

    rows = {row["id"]: row for row in csv.DictReader(open(first_run.out / "results.csv"))}
    assert list(rows) == [*cohort.truth, "broken"]         # the manifest's order
    assert rows["broken"]["status"] == "failed" and "broken.npz" in rows["broken"]["error"]
    for ident, truth in cohort.truth.items():
        row = rows[ident]
        assert row["status"] == "ok" and row["group"] == truth["group"]
        assert float(row["youngs_modulus"]) == pytest.approx(truth["youngs_modulus"], rel=1e-2)
        assert row["youngs_modulus_word"] == truth["words"]["youngs_modulus"]
        assert float(row["rms_error"]) > 0 and float(row["noise_ratio"]) > 0
        assert (first_run.out / row["report"]).is_file()


@pytest.mark.slow
def test_the_cohort_report_has_words_per_group_and_the_bootstrap_comparison(first_run, cohort):
    html = first_run.report.read_text()
    twin = json.loads(first_run.report.with_suffix(".json").read_text())
    assert twin["groups"] == ["healthy", "fibrotic"]
    for group in ("healthy", "fibrotic"):
        expected = {}
        for truth in cohort.truth.values():
            if truth["group"] == group:
                word = truth["words"]["youngs_modulus"]
                expected[word] = expected.get(word, 0) + 1
        [entry] = [w for w in twin["words"]
                   if w["group"] == group and w["quantity"] == "youngs_modulus"]
        assert entry["words"] == expected
        counted = ", ".join(f"{w} ({c}/{entry['n']})" for w, c in entry["words"].items())
        assert f"{group}: {counted}" in html
    [comparison] = [c for c in twin["comparisons"] if c["quantity"] == "youngs_modulus"]
    fitted = {g: [r["youngs_modulus"] for r in twin["specimens"]
                  if r["group"] == g and r["status"] == "ok"] for g in twin["groups"]}
    assert comparison["groups"] == ["healthy", "fibrotic"]
    assert comparison["difference"] == pytest.approx(
        np.median(fitted["fibrotic"]) - np.median(fitted["healthy"]))
    low, high = comparison["interval"]
    assert 0 < low <= comparison["difference"] <= high and comparison["excludes_zero"]
    assert "95 % bootstrap interval" in html and "data:image/png;base64," in html
    for ident in cohort.truth:                          # links to each specimen's report
        assert f'href="results/{ident}/report.html"' in html
    assert "broken" in html.split("Failed specimens")[1]


@pytest.mark.slow
def test_resume_recomputes_nothing_that_finished_and_fits_what_is_missing(first_run, cohort,
                                                                         cluster, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(first_run.out, out)
    kept, lost = list(cohort.truth)[:-1], list(cohort.truth)[-1]
    shutil.rmtree(out / lost)              # as if the run had been interrupted before it
    stamps = {ident: (out / ident / "fit.json").stat().st_mtime_ns for ident in kept}
    refused = cli("fit-many", cohort.manifest, "--out", out, "--scheduler",
                  cluster.scheduler_address)
    assert refused.returncode == 2 and "--resume" in refused.stderr
    result = cli("fit-many", cohort.manifest, "--out", out, "--resume", "--scheduler",
                 cluster.scheduler_address)
    assert result.returncode == 1                       # the broken specimen fails again
    assert f"{len(kept)} of {len(cohort.truth) + 1} specimens already fitted" in result.stderr
    assert "ETA" in result.stderr and "done" in result.stderr
    assert {ident: (out / ident / "fit.json").stat().st_mtime_ns for ident in kept} == stamps
    assert json.loads((out / lost / "fit.json").read_text())["status"] == "ok"

    # a changed input (another tie for one specimen) is fitted again; nothing else is
    changed = cohort.manifest.with_name("changed.csv")
    row = f"{kept[0]},{cohort.truth[kept[0]]['group']},data/{kept[0]}.npz,liver,liver,"
    changed.write_text(cohort.manifest.read_text().replace(row + "global", row + "groups"))
    assert changed.read_text() != cohort.manifest.read_text()
    again = cli("fit-many", changed, "--out", out, "--resume", "--json", "--scheduler",
                cluster.scheduler_address)
    summary = json.loads(again.stdout)
    assert sorted(summary["computed"]) == sorted([kept[0], "broken"])
    assert (out / kept[1] / "fit.json").stat().st_mtime_ns == stamps[kept[1]]


def test_a_local_cluster_is_started_when_no_scheduler_is_given(tmp_path):
    """The fast end-to-end check: two cube specimens started from the data alone (the
    cheapest fit and report), on the local cluster that fit-many starts itself."""
    from neurofuzzy.io import save_experiment

    lines = ["id,group,experiments,tie,substeps"]
    for index, stiffness in enumerate((45.0, 55.0)):
        data = paper_cube_experiment(paper_cube_model(stiffness=stiffness), noise=2e-6,
                                     seed=index, n_frames=80)
        save_experiment(data, tmp_path / f"s{index}.npz")
        lines.append(f"s{index},g{index},s{index}.npz,global,1")
    manifest = _manifest(tmp_path, "\n".join(lines) + "\n")
    result = cli("fit-many", manifest, "--out", tmp_path / "out", "--workers", "1")
    assert result.returncode == 0, result.stderr          # every specimen fitted
    assert "2 specimens: 2 fitted, 0 failed" in result.stdout
    assert "on 1 worker process(es), 1 thread(s) in all" in result.stderr   # as the tutorial says
    assert "2/2 done" in result.stderr
    records = [json.loads((tmp_path / "out" / f"s{i}" / "fit.json").read_text())
               for i in range(2)]
    assert len({r["worker"] for r in records}) == 1                  # one worker process …
    assert records[0]["worker"].rsplit(":", 1)[1] != str(os.getpid())  # … not this one
    for record, stiffness in zip(records, (45.0, 55.0)):
        assert np.allclose(record["fit"]["stiffness"], stiffness, rtol=1e-3)


# -- bad input: exit 2, one line naming the file, nothing written ------------------------------
def _manifest(tmp_path, text, name="cohort.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture
def data_file(tmp_path):
    from neurofuzzy.io import save_experiment

    return save_experiment(paper_cube_experiment(n_frames=30), tmp_path / "a.npz")


@pytest.mark.parametrize("text, message", [
    (None, "cohort.csv: no such file"),
    ("", "cohort.csv: empty file"),
    ("id,group,experiments\n", "cohort.csv: lists no specimens"),
    ("id,grup,experiments\na,x,a.npz\n", "cohort.csv:1: unknown column 'grup'; did you mean "
                                         "'group'?"),
    ("id,group,experiments\na,x,missing.npz\n", "cohort.csv:2: experiments: no such file "
                                                "missing.npz"),
    ("id,group,experiments\na,x,a.npz\na,y,a.npz\n", "cohort.csv:3: id: 'a' is also the id of "
                                                     "line 2"),
    ("id,group,experiments,tie\na,x,a.npz,glob\n", "cohort.csv:2: tie: got 'glob'"),
    ("id,group,experiments\n../a,x,a.npz\n", "cohort.csv:2: id: got '../a'"),
    ("id,group,experiments,rules,tissue\na,x,a.npz,liver,fibrotic\n",
     "cohort.csv:2: tissue: 'fibrotic' is not a tissue of liver; did you mean "
     "'fibrotic_liver'?"),
    ("id,group,experiments\na,,a.npz\n", "cohort.csv:2: group: every specimen needs a group"),
    ("id,group,experiments,prior\na,x,a.npz,banana\n",
     "cohort.csv:2: prior: got 'banana'; expected off, auto or a positive weight"),
    ("id,group,experiments,prior\na,x,a.npz,auto\n", "cohort.csv:2: prior: a prior needs a "
                                                     "rule base"),
    ("id,group,experiments,law\na,x,a.npz,neo-hooke\n",
     "cohort.csv:2: law: unknown material law 'neo-hooke'"),
    ("id,group,experiments,relaxation\na,x,a.npz,0.5:x\n",
     "cohort.csv:2: relaxation: got '0.5:x'; expected a number of Prony terms"),
    ("id,group,experiments,relaxation\na,x,a.npz,4\n",
     "cohort.csv:2: relaxation: got 4 Prony terms; expected 1 to 3"),
    ("id,group,experiments,law,stiffening\na,x,a.npz,yeoh,-1\n",
     "cohort.csv:2: stiffening: got '-1'; expected the law's own constant (Yeoh's C20/C10, "
     "Mooney-Rivlin's C01/C10), a number >= 0"),
    ("id,group,experiments,stiffening\na,x,a.npz,1\n",
     "cohort.csv:2: stiffening: a stiffening is the law's own constant (Yeoh's C20/C10, "
     "Mooney-Rivlin's C01/C10); give law: yeoh or law: mooney-rivlin"),
])
def test_bad_manifests_exit_2_naming_the_file_and_line(tmp_path, data_file, text, message):
    path = tmp_path / "cohort.csv" if text is None else _manifest(tmp_path, text)
    result = cli("fit-many", path, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr and not (tmp_path / "out").exists()


def test_several_manifest_problems_are_reported_together(tmp_path, data_file):
    path = _manifest(tmp_path, "id,group,experiments\na,x,no1.npz\nb,x,a.npz\nc,x,no2.npz\n")
    result = cli("fit-many", path, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert "cohort.csv:2: experiments: no such file no1.npz" in result.stderr
    assert "(and 1 more: line 4: no such file no2.npz" in result.stderr


def test_a_yaml_manifest_with_defaults_is_the_same_as_the_csv(tmp_path, data_file):
    csv_path = _manifest(tmp_path, "# two specimens\nid,group,experiments,rules,tissue,tie\n"
                                   "a,healthy,a.npz; a.npz,liver,liver,global\n"
                                   "b,fibrotic,a.npz,liver,fibrotic_liver,global\n")
    yaml_path = _manifest(tmp_path, "defaults: {rules: liver, tissue: liver, tie: global}\n"
                                    "specimens:\n"
                                    "  - {id: a, group: healthy, experiments: [a.npz, a.npz]}\n"
                                    "  - id: b\n    group: fibrotic\n    experiments: a.npz\n"
                                    "    tissue: fibrotic_liver\n", "cohort.yaml")
    from_csv, from_yaml = read_manifest(csv_path), read_manifest(yaml_path)
    assert [s.id for s in from_yaml] == ["a", "b"] and from_yaml[1].line == 4
    assert len(from_csv[0].experiments) == 2 and len(from_csv[1].experiments) == 1
    assert [s.fingerprint() for s in from_csv] == [s.fingerprint() for s in from_yaml]
    assert from_csv[0].fingerprint() != from_csv[1].fingerprint()      # another tissue
    bad = _manifest(tmp_path, "specimens:\n  - id: a\n    group: x\n    experiment: a.npz\n",
                    "bad.yaml")
    result = cli("fit-many", bad, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert "bad.yaml:4: unknown column 'experiment'; did you mean 'experiments'?" in \
        result.stderr


def test_the_report_twin_never_replaces_a_file_the_user_did_not_name(tmp_path, data_file):
    path = _manifest(tmp_path, "id,group,experiments\na,x,a.npz\n")
    (tmp_path / "cohort.json").write_text('{"mine": true}')
    result = cli("fit-many", path, "--out", tmp_path / "out", "--report",
                 tmp_path / "cohort.html")
    assert result.returncode == 2
    assert f"would replace {tmp_path / 'cohort.json'}" in result.stderr
    assert (tmp_path / "cohort.json").read_text() == '{"mine": true}'
    assert not (tmp_path / "out").exists()
    clash = cli("fit-many", path, "--out", tmp_path / "out", "--workers", "2", "--scheduler",
                "tcp://127.0.0.1:1")
    assert clash.returncode == 2 and "--workers" in clash.stderr


def test_an_unreachable_scheduler_exits_2(tmp_path, data_file, monkeypatch):
    import neurofuzzy.batch.run

    monkeypatch.setattr(neurofuzzy.batch.run, "CONNECT_TIMEOUT", "0.2s")
    path = _manifest(tmp_path, "id,group,experiments\na,x,a.npz\n")
    result = cli("fit-many", path, "--out", tmp_path / "out", "--scheduler", "tcp://127.0.0.1:1")
    assert result.returncode == 2
    assert "--scheduler: cannot reach the Dask scheduler tcp://127.0.0.1:1" in result.stderr


def test_dask_is_imported_only_when_a_batch_runs():
    import subprocess
    import sys

    code = ("import sys, neurofuzzy, neurofuzzy.batch\n"
            "from neurofuzzy.cli.parser import build_parser\n"
            "build_parser().parse_args(['fit-many', 'm.csv', '--out', 'x'])\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


# -- the parts --------------------------------------------------------------------------------
@pytest.mark.slow
def test_a_specimen_asked_to_be_diagnosed_names_the_missing_effect(tmp_path):
    """The cube hangs under gravity its model does not know: the specimen's diagnosis names
    it, writes its report, and the table shows it."""
    import neurofuzzy as nf
    from neurofuzzy.batch.table import table_rows
    from neurofuzzy.io import save_experiment

    hidden = paper_cube_model().with_effects(nf.Gravity([0.0, 0.0, -9.81]))
    save_experiment(paper_cube_experiment(hidden, n_frames=120), tmp_path / "a.npz")
    _manifest(tmp_path, "id,group,experiments,tie,substeps,diagnose\ng1,g,a.npz,global,1,yes\n")
    [specimen] = read_manifest(tmp_path / "cohort.csv")
    outcome = fit_specimen(specimen)
    assert outcome["status"] == "ok", outcome.get("error")
    assert outcome["fit"]["diagnosis"]["effects"] == ["gravity"]
    assert outcome["fit"]["diagnosis"]["rms_after"] < 1e-3 * outcome["fit"]["rms_error"]
    assert {"diagnosis.html", "diagnosis.json"} <= set(outcome["files"])
    [row] = table_rows([specimen], {"g1": {"status": "ok", "fit": outcome["fit"]}})
    assert row["effects"] == "gravity"


def _pressed_block(path, *, n_frames, substeps, noise, **material):
    """A 2×2×1 cm block of elements (E 6 kPa, ν 0.45, η 2 Pa·s, and ``material``'s law or
    relaxation) pressed on its top, saved as an experiment at ``path``; returns its mesh."""
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.io import save_experiment
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    mesh = from_tetra(*kuhn_block((2, 2, 1), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45,
                            viscosity=2.0, density=1050.0, **material)
    top = np.flatnonzero(mesh.rest_positions[:, 2] > 0.01 - 1e-9)
    load = np.zeros((mesh.n_nodes, 3))
    load[top, 2] = -0.03 / len(top)
    save_experiment(simulate_experiment(truth, dt=2e-3, n_frames=n_frames, external_forces=load,
                                        substeps=substeps, noise=noise, seed=0), path)
    return mesh


def test_a_specimen_fitted_element_by_element_uses_the_prior_as_fit_does(tmp_path):
    """tie: none with a rule base takes the prior by default (as ``neurofuzzy fit``), and
    the specimen's summary says where the tissue differs from its description."""
    _pressed_block(tmp_path / "a.npz", n_frames=15, substeps=2, noise=1e-5)
    _manifest(tmp_path, "id,group,experiments,rules,tissue,tie,substeps,cycles,prior\n"
                        "s1,g,a.npz,liver,liver,none,2,5,\ns2,g,a.npz,liver,liver,none,2,5,off\n")
    first, second = (fit_specimen(s) for s in read_manifest(tmp_path / "cohort.csv"))
    assert first["status"] == second["status"] == "ok", first.get("error")
    assert first["fit"]["prior"]["how"] == "discrepancy principle"
    assert "regions_found" in first["fit"] and "firm" in json.dumps(first["fit"]["regions_rest"])
    assert second["fit"]["prior"] is None and "regions_found" not in second["fit"]


def test_a_specimen_takes_the_law_and_relaxation_of_its_row(tmp_path):
    """``law`` and ``relaxation`` columns reach the fit as ``fit --law --relaxation`` do: the
    fitted model of the row is neo-Hookean with a Prony term."""
    mesh = _pressed_block(tmp_path / "a.npz", n_frames=30, substeps=8, noise=1e-6,
                          law="neo-hookean", relaxation=[(0.5, 0.02)])
    _manifest(tmp_path, "id,group,experiments,rules,tissue,tie,law,relaxation,cycles,prior\n"
                        "s1,g,a.npz,liver,liver,global,neo-hookean,0.4:0.03,5,off\n")
    [specimen] = read_manifest(tmp_path / "cohort.csv")
    assert specimen.options["law"] == "neo-hookean" and specimen.options["relaxation"]
    result = fit_specimen(specimen)
    assert result["status"] == "ok", result.get("error")
    assert result["fit"]["material_law"] == "neo-hookean"
    terms = np.asarray(result["fit"]["elements"]["relaxation_moduli"])
    assert terms.shape == (mesh.n_tetrahedra, 1) and np.all(terms > 0)


def test_a_specimen_takes_yeoh_s_law_and_its_stiffening(tmp_path):
    """``law: yeoh`` with ``stiffening`` reaches the fit as ``fit --law yeoh --stiffening``:
    the row's fitted elements are Yeoh's with a fitted C20/C10."""
    mesh = _pressed_block(tmp_path / "a.npz", n_frames=20, substeps=4, noise=1e-6,
                          law="yeoh", stiffening=2.0)
    _manifest(tmp_path, "id,group,experiments,rules,tissue,tie,law,stiffening,cycles,prior\n"
                        "s1,g,a.npz,liver,liver,global,yeoh,1.5,5,off\n")
    [specimen] = read_manifest(tmp_path / "cohort.csv")
    assert specimen.options["stiffening"] == 1.5
    result = fit_specimen(specimen)
    assert result["status"] == "ok", result.get("error")
    assert result["fit"]["material_law"] == "yeoh"
    stiffening = np.asarray(result["fit"]["elements"]["stiffening"])
    assert stiffening.shape == (mesh.n_tetrahedra,) and np.all(stiffening > 0)


def test_median_difference_is_seeded_and_moves_with_a_shift():
    rng = np.random.default_rng(5)
    first, second = rng.normal(10, 2, 9), rng.normal(14, 2, 7)
    difference, low, high = median_difference(first, second, seed=1)
    assert difference == pytest.approx(np.median(second) - np.median(first))
    assert low < difference < high
    assert median_difference(first, second, seed=1) == (difference, low, high)
    assert median_difference(first, second, seed=2) != (difference, low, high)
    shifted = median_difference(first, second + 3.0, seed=1)
    assert np.allclose(shifted, (difference + 3.0, low + 3.0, high + 3.0))
    narrow = median_difference(first, second, seed=1, level=0.5)
    assert low < narrow[1] < narrow[2] < high


def test_fit_quality_finds_the_noise_level():
    truth = paper_cube_model()
    noisy = paper_cube_experiment(truth, noise=3e-6, seed=11, n_frames=120)
    quality = fit_quality(truth, [noisy])
    assert quality["noise_rms"] == pytest.approx(3e-6 * np.sqrt(3), rel=0.1)
    assert quality["noise_ratio"] == pytest.approx(1.0, rel=0.1)
    clean = fit_quality(truth, [paper_cube_experiment(truth, n_frames=120)])
    assert clean["noise_rms"] == 0.0 and clean["noise_ratio"] is None
    wrong = fit_quality(paper_cube_model(stiffness=40.0), [noisy])
    assert wrong["noise_ratio"] > 5


def test_a_specimen_from_marker_recordings_fits_in_process(tmp_path):
    """The task itself (no cluster): markers + forces + a start model, as ``import`` takes."""
    from neurofuzzy.datasets import CUBE, top_centre_node
    from neurofuzzy.io import save_model

    truth = paper_cube_model()
    data = paper_cube_experiment(truth, n_frames=80)
    times = np.arange(data.n_frames) * data.dt
    rows = [f"{t:.6f},{node},{x:.9f},{y:.9f},{z:.9f}"
            for t, frame in zip(times, data.positions) for node, (x, y, z) in enumerate(frame)]
    (tmp_path / "m.csv").write_text("# units: m\ntime,node,x,y,z\n" + "\n".join(rows) + "\n")
    node = top_centre_node(truth.mesh)
    (tmp_path / "f.csv").write_text("time,node,fx,fy,fz\n0," + str(node) + ","
                                    + ",".join(str(f) for f in CUBE["force"]) + "\n")
    save_model(paper_cube_model(stiffness=35.0, damping=0.03), tmp_path / "start.yaml")
    _manifest(tmp_path, "id,group,markers,forces,start,tie,substeps\n"
                        "m1,g,m.csv,f.csv,start.yaml,global,1\n")
    [specimen] = read_manifest(tmp_path / "cohort.csv")
    outcome = fit_specimen(specimen)
    assert outcome["status"] == "ok", outcome.get("error")
    assert np.allclose(outcome["fit"]["stiffness"], CUBE["stiffness"], rtol=1e-4)
    assert outcome["fit"]["experiments"] == ["m.csv"]
    assert {"fitted.yaml", "report.html", "report.json"} <= set(outcome["files"])


def _records_of_three_groups():
    from neurofuzzy.batch.manifest import Specimen

    groups = ["a", "b", "c"]
    specimens = [Specimen(id=f"{g}{i}", group=g) for g in groups for i in range(3)]
    records = {s.id: {"status": "ok", "fit": {"materials": {"object": {
        "youngs_modulus": 1000.0 * (1 + groups.index(s.group)) + int(s.id[1]),
        "poisson_ratio": 0.25, "viscosity": 2.0, "density": 1000.0,
        "labels": {"youngs_modulus": "soft" if s.group == "a" else "firm"}}}}}
        for s in specimens}
    records["c2"] = {"status": "failed", "error": "c2.npz: positions: broken"}
    return specimens, records


def test_the_table_is_also_parquet_when_pyarrow_is_installed(tmp_path):
    pytest.importorskip("pyarrow")
    import pyarrow.parquet

    from neurofuzzy.batch.table import write_table

    specimens, records = _records_of_three_groups()
    write_table(tmp_path / "results.csv", specimens, records)
    table = pyarrow.parquet.read_table(tmp_path / "results.parquet").to_pylist()
    assert [row["id"] for row in table] == [s.id for s in specimens]
    assert table[0]["youngs_modulus"] == 1000.0 and table[-1]["status"] == "failed"


def test_the_summary_compares_every_pair_of_groups_in_manifest_order():
    from neurofuzzy.batch import Cohort

    specimens, records = _records_of_three_groups()
    summary = cohort_summary(Cohort(tuple(specimens), records, (), (), None, None, None, 0.0))
    pairs = [(c["groups"], c["quantity"]) for c in summary["comparisons"]]
    assert pairs == [(["a", "b"], "youngs_modulus"), (["a", "c"], "youngs_modulus"),
                     (["b", "c"], "youngs_modulus")]        # constant quantities left out
    assert summary["comparisons"][0]["difference"] == pytest.approx(1000.0)
    words = {w["group"]: (w["words"], w["n"]) for w in summary["words"]
             if w["quantity"] == "youngs_modulus"}
    assert words == {"a": ({"soft": 3}, 3), "b": ({"firm": 3}, 3), "c": ({"firm": 2}, 2)}
    assert summary["failed"] == [{"id": "c2", "error": "c2.npz: positions: broken"}]
