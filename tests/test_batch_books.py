"""fit-many never leaves a folder it cannot resume (issue 28): ids that would collide with the
folder's own files are refused at the check, nothing is written before the cluster answers,
``--resume`` refuses a folder made from another manifest, and an input is never an output.

The bookkeeping is what is tested here, so the fit of each specimen is replaced by a stub
returning at once, on an in-process cluster (threads) that starts in under a second; the real
fits on a real cluster are tested in ``test_batch.py``."""

import logging

import pytest
from helpers import cli

from neurofuzzy.datasets import paper_cube_experiment
from neurofuzzy.io import save_experiment


def _snapshot(folder):
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else None
            for p in sorted(folder.rglob("*"))} if folder.exists() else None


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    folder = tmp_path_factory.mktemp("data")
    save_experiment(paper_cube_experiment(n_frames=20), folder / "a.npz")
    save_experiment(paper_cube_experiment(n_frames=21), folder / "b.npz")
    return folder


def _manifest(folder, rows, name="cohort.csv", header="id,group,experiments,tie"):
    path = folder / name
    path.write_text(header + "\n" + "".join(row + "\n" for row in rows))
    return path


@pytest.mark.parametrize("rows, report, words", [
    (["results.csv,x,a.npz,global"], None, "cohort.csv:2: id: 'results.csv' is the name of a "
                                           "file fit-many keeps"),
    (["s1,x,a.npz,global", "FIT-MANY.JSON,x,a.npz,global"], None,
     "cohort.csv:3: id: 'FIT-MANY.JSON' is the name of a file"),
    (["fit-many.lock,x,a.npz,global"], None, "cohort.csv:2: id: 'fit-many.lock' is the name "
                                             "of a file fit-many keeps"),
    (["s1,x,a.npz,global", "S1,y,a.npz,global"], None,
     "cohort.csv:3: id: 'S1' and 's1' (line 2) differ only in letter case"),
    (["cohort.html,x,a.npz,global"], "out/cohort.html",
     "cohort.csv:2: id: 'cohort.html' is the name of the cohort report"),
    (["s1,x,a.npz,global"], "out/fit-many.html", "would replace the batch's own fit-many.json"),
    (["s1,x,a.npz,global"], "out/s1/report.html", "is a file fit-many writes itself"),
    (["s1,x,a.npz,global,inf"], None, "cohort.csv:2: dt: got 'inf'; expected a positive "
                                      "number of seconds"),
])
def test_ids_and_reports_that_collide_with_the_folder_are_refused_at_the_check(
        data, tmp_path, rows, report, words):
    (tmp_path / "a.npz").write_bytes((data / "a.npz").read_bytes())
    header = "id,group,experiments,tie" + (",dt" if rows[0].count(",") == 4 else "")
    manifest = _manifest(tmp_path, rows, header=header)
    before = _snapshot(tmp_path)
    result = cli("fit-many", manifest, "--out", tmp_path / "out",
                 *(["--report", tmp_path / report] if report else []))
    assert result.returncode == 2, result.stderr
    assert words in result.stderr and len(result.stderr.strip().splitlines()) == 1, \
        result.stderr
    assert _snapshot(tmp_path) == before


def test_the_row_and_the_marker_file_must_agree_on_the_unit(data, tmp_path):
    (tmp_path / "start.yaml").write_text("placeholder: the unit check comes first\n")
    (tmp_path / "m.csv").write_text("# units: mm\ntime,node,x,y,z\n0,1,0,0,0\n0.001,1,0,0,0\n")
    manifest = _manifest(tmp_path, ["s1,x,m.csv,start.yaml,m"],
                         header="id,group,markers,start,units")
    result = cli("fit-many", manifest, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert ("cohort.csv:2: units: markers m.csv: " in result.stderr and "the length unit is "
            "given twice, differently: '# units: mm' (line 1) and m (the manifest's units)"
            in result.stderr), result.stderr


def test_an_unreachable_scheduler_leaves_the_folder_as_it_was(data, tmp_path, monkeypatch):
    import neurofuzzy.batch.run

    monkeypatch.setattr(neurofuzzy.batch.run, "CONNECT_TIMEOUT", "0.2s")
    manifest = _manifest(data, ["s1,x,a.npz,global"], name="one.csv")
    fresh = cli("fit-many", manifest, "--out", tmp_path / "new", "--scheduler",
                "tcp://127.0.0.1:1")
    assert fresh.returncode == 2 and "cannot reach the Dask scheduler" in fresh.stderr
    assert not (tmp_path / "new").exists()
    earlier = tmp_path / "earlier"
    earlier.mkdir()
    (earlier / "results.csv").write_text("id,group,status\ns1,x,failed\n")
    before = _snapshot(earlier)
    again = cli("fit-many", manifest, "--out", earlier, "--resume", "--scheduler",
                "tcp://127.0.0.1:1")
    assert again.returncode == 2 and _snapshot(earlier) == before
    plain = cli("fit-many", manifest, "--out", earlier)            # still refused as before
    assert plain.returncode == 2 and "--resume" in plain.stderr


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                      dashboard_address=None, silence_logs=logging.ERROR) as started:
        yield started


@pytest.fixture
def stub(monkeypatch, tmp_path):
    """Every specimen "fits" at once; ``stub()`` lists the ids fitted since the last call (the
    task may run on a copy of this function, so it leaves a file per fit)."""
    import neurofuzzy.batch.run

    log = tmp_path / "fitted"
    log.mkdir()

    def fit_specimen(specimen):
        (log / f"{specimen.id}.{len(list(log.iterdir()))}").touch()
        return {"id": specimen.id, "status": "ok", "fit": {"rms_error": 1e-6},
                "files": {"fitted.yaml": b"stub\n"}, "seconds": 0.0, "worker": "stub"}

    def fitted():
        names = sorted(p.name.split(".")[0] for p in log.iterdir())
        for p in log.iterdir():
            p.unlink()
        return names

    monkeypatch.setattr(neurofuzzy.batch.run, "fit_specimen", fit_specimen)
    return fitted


def test_resume_refuses_a_folder_made_from_another_manifest(data, tmp_path, cluster, stub):
    """Cohort A's folder: resuming it with cohort B (other ids, or the same ids on other
    files) is refused and changes nothing; A itself, or A with one option changed (another
    file), resumes and fits only what changed."""
    other = tmp_path / "other"
    other.mkdir()
    (other / "a.npz").write_bytes((data / "b.npz").read_bytes())
    cohort_a = _manifest(data, ["s1,x,a.npz,global", "s2,y,b.npz,global"], name="a.csv")
    out = tmp_path / "results"
    scheduler = ["--scheduler", cluster.scheduler_address]
    assert cli("fit-many", cohort_a, "--out", out, *scheduler).returncode == 0
    assert stub() == ["s1", "s2"] and (out / "fit-many.json").exists()
    before = _snapshot(out)
    for manifest in (_manifest(data, ["t1,x,a.npz,global"], name="b.csv"),
                     _manifest(other, ["s1,x,a.npz,global", "s2,y,a.npz,global"],
                               name="a.csv")):
        result = cli("fit-many", manifest, "--out", out, "--resume", *scheduler)
        assert result.returncode == 2, result.stderr
        assert f"results: --resume: was made from another manifest ({cohort_a})" in \
            result.stderr and len(result.stderr.strip().splitlines()) == 1, result.stderr
        assert _snapshot(out) == before
    assert cli("fit-many", cohort_a, "--out", out, "--resume", *scheduler).returncode == 0
    assert stub() == []
    changed = _manifest(data, ["s1,x,a.npz,groups", "s2,y,b.npz,global", "s3,z,a.npz,global"],
                        name="changed.csv")
    result = cli("fit-many", changed, "--out", out, "--resume", *scheduler)
    assert result.returncode == 0, result.stderr
    assert stub() == ["s1", "s3"]


def test_an_input_inside_the_results_folder_is_never_an_output(data, tmp_path):
    out = tmp_path / "out"
    (out / "s1").mkdir(parents=True)
    (out / "s1" / "fitted.yaml").write_text("the user's own start model\n")
    (out / "s1" / "a.npz").write_bytes((data / "a.npz").read_bytes())
    manifest = _manifest(tmp_path, ["s1,x,out/s1/a.npz,out/s1/fitted.yaml"],
                         header="id,group,experiments,start")
    before = _snapshot(tmp_path)
    result = cli("fit-many", manifest, "--out", out)
    assert result.returncode == 2
    assert "fitted.yaml: --out: is an input of the batch (specimen s1)" in result.stderr
    assert _snapshot(tmp_path) == before


# -- one run per results folder (issue 49) ------------------------------------------------------
def _dead_pid():
    import subprocess
    import sys

    process = subprocess.Popen([sys.executable, "-c", "pass"])
    process.wait()
    return process.pid


def test_a_live_run_s_lock_refuses_a_second_run_naming_its_owner(data, tmp_path, cluster,
                                                                 stub):
    import os
    import socket

    from neurofuzzy.batch.lock import folder_lock

    manifest = _manifest(data, ["s1,x,a.npz,global"], name="one.csv")
    out = tmp_path / "results"
    scheduler = ["--scheduler", cluster.scheduler_address]
    with folder_lock(out, manifest):                 # another run, alive (this process)
        before = _snapshot(out)
        for resume in ([], ["--resume"]):
            result = cli("fit-many", manifest, "--out", out, *resume, *scheduler)
            assert result.returncode == 2
            [line] = result.stderr.strip().splitlines()
            assert line.startswith(f"neurofuzzy: error: {out}: --out: another fit-many is "
                                   f"writing this results folder (pid {os.getpid()} on "
                                   f"{socket.gethostname()}, started "), line
            assert line.endswith(f"manifest {manifest}); wait for it to finish, or choose "
                                 "another --out"), line
            assert _snapshot(out) == before and stub() == []
    assert not out.exists()                  # the lock's folder was made for it and is gone
    assert cli("fit-many", manifest, "--out", out, *scheduler).returncode == 0
    assert stub() == ["s1"] and not (out / "fit-many.lock").exists()


def test_a_stale_lock_of_a_dead_run_is_reported_and_taken_over(data, tmp_path, cluster, stub):
    import json
    import socket

    manifest = _manifest(data, ["s1,x,a.npz,global"], name="one.csv")
    out = tmp_path / "results"
    out.mkdir()
    pid = _dead_pid()
    (out / "fit-many.lock").write_text(json.dumps(
        {"host": socket.gethostname(), "pid": pid, "started": "2026-11-27T03:00:00+0000",
         "manifest": str(manifest)}))
    result = cli("fit-many", manifest, "--out", out, "--scheduler", cluster.scheduler_address)
    assert result.returncode == 0, result.stderr
    assert (f"fit-many: took over the stale lock of a run that ended without releasing it (pid "
            f"{pid} on {socket.gethostname()}, started 2026-11-27T03:00:00+0000, manifest "
            f"{manifest}: no longer running)") in result.stderr
    assert stub() == ["s1"] and not (out / "fit-many.lock").exists()


def test_a_lock_left_by_another_host_is_refused_with_the_file_to_remove(data, tmp_path,
                                                                        cluster, stub):
    import json

    manifest = _manifest(data, ["s1,x,a.npz,global"], name="one.csv")
    out = tmp_path / "results"
    out.mkdir()
    lock = out / "fit-many.lock"
    lock.write_text(json.dumps({"host": "node-17", "pid": 4242, "started": "yesterday",
                                "manifest": "/elsewhere/cohort.csv"}))
    before = _snapshot(out)
    result = cli("fit-many", manifest, "--out", out, "--scheduler", cluster.scheduler_address)
    assert result.returncode == 2
    assert ("was locked by a fit-many on another host (pid 4242 on node-17, started yesterday, "
            f"manifest /elsewhere/cohort.csv), which cannot be checked from "
            f"") in result.stderr and f"if that run is over, delete {lock} and run again" in \
        result.stderr
    assert _snapshot(out) == before and stub() == []
