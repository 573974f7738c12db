"""fit-many when the machine misbehaves (issue 49): workers killed mid-specimen, the command
killed between two specimens and halfway through writing ``results.csv``, the scheduler
killed, the disk full while a specimen's files are written, two runs on one folder.

After each fault nothing half-written is read as a result, ``--resume`` finishes the cohort,
and the results folder and the cohort report equal an uninterrupted run's, to the bit: the
fits are deterministic, and only what records the run itself differs (``seconds``,
``worker``, ``finished``, ``retries``). Faults are injected by ``tests/faults.py``, which runs
the command with one part of the library patched; the cohort is four 27-node cubes fitted in
about a second each, on one local cluster shared by the tests (the command reaches it with
``--scheduler``) unless the fault is the scheduler's. Together about two to three minutes,
so they are slow tests.
"""

import csv
import errno
import json
import logging
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import cli

from neurofuzzy.batch.table import COLUMNS

pytestmark = pytest.mark.slow

FAULTS = Path(__file__).with_name("faults.py")
#: what records the run rather than the result (wall time, the worker, the clock, retries)
VOLATILE = ("seconds", "worker", "finished", "retries")
IDS = ("s0", "s1", "s2", "s3")


@pytest.fixture(scope="module")
def cohort(tmp_path_factory):
    from neurofuzzy.datasets import paper_cube_experiment, paper_cube_model
    from neurofuzzy.io import save_experiment

    folder = tmp_path_factory.mktemp("cohort")
    lines = ["id,group,experiments,tie,substeps"]
    for index, stiffness in enumerate((40.0, 45.0, 50.0, 55.0)):
        data = paper_cube_experiment(paper_cube_model(stiffness=stiffness), noise=2e-6,
                                     seed=index, n_frames=40)
        save_experiment(data, folder / f"s{index}.npz")
        lines.append(f"s{index},{'ab'[index % 2]},s{index}.npz,global,1")
    (folder / "cohort.csv").write_text("\n".join(lines) + "\n")
    return folder / "cohort.csv"


@pytest.fixture(scope="module")
def cluster():
    import dask
    from dask.distributed import LocalCluster

    from neurofuzzy.batch.run import LOCAL_CLUSTER

    with dask.config.set(LOCAL_CLUSTER), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                         dashboard_address=None, silence_logs=logging.CRITICAL) as started:
        yield started


def _args(cohort, run, cluster):
    return ["fit-many", cohort, "--out", run / "results", "--report", run / "cohort.html",
            *(["--scheduler", cluster.scheduler_address] if cluster else [])]


@pytest.fixture(scope="module")
def reference(cohort, cluster, tmp_path_factory):
    """The uninterrupted run (its folder and report, what may differ taken out)."""
    run = tmp_path_factory.mktemp("reference") / "run"
    result = cli(*_args(cohort, run, cluster))
    assert result.returncode == 0, result.stderr
    return _final(run)


def _stable(value):
    if isinstance(value, dict):
        return {k: _stable(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [_stable(v) for v in value]
    return value


def _final(run: Path) -> dict:
    """Every file of a run (the results folder and the cohort report): JSON and the table
    without what records the run itself, the rest as bytes."""
    files = {}
    for path in sorted(run.rglob("*")):
        if not path.is_file():
            continue
        name = path.relative_to(run).as_posix()
        if path.name == "results.csv":
            rows = list(csv.DictReader(path.open()))
            files[name] = [{k: v for k, v in row.items() if k not in VOLATILE} for row in rows]
        elif path.suffix == ".json":
            files[name] = _stable(json.loads(path.read_text()))
        else:
            files[name] = path.read_bytes()
    return files


def _nothing_half_written_is_a_result(run: Path, reference: dict) -> list[str]:
    """What an interrupted folder holds under its final names is whole: the table parses with
    every column, a specimen is ``ok`` there only with its ``fit.json``, and every finished
    specimen's files equal the uninterrupted run's. Returns the finished ids."""
    out = run / "results"
    with (out / "results.csv").open() as handle:
        rows = list(csv.reader(handle))
    assert rows[0] == list(COLUMNS) and all(len(row) == len(COLUMNS) for row in rows)
    assert [row[0] for row in rows[1:]] == list(IDS)
    done = [ident for ident in IDS if (out / ident / "fit.json").exists()]
    for row in rows[1:]:
        assert row[2] in ("ok", "waiting") and (row[2] == "ok") <= (row[0] in done), row
    for ident in done:
        record = json.loads((out / ident / "fit.json").read_text())
        assert record["status"] == "ok"
        for name in record["files"]:
            key = f"results/{ident}/{name}"
            assert _final(run)[key] == reference[key], key
    return done


def _resume(cohort, run, cluster) -> str:
    result = cli(*_args(cohort, run, cluster), "--resume")
    assert result.returncode == 0, result.stderr
    leftovers = [p.name for p in run.rglob(".*.tmp")]
    assert not leftovers and not (run / "results" / "fit-many.lock").exists(), leftovers
    return result.stderr


def _faulty(fault, argument, cohort, run, cluster, **kwargs):
    return subprocess.run([sys.executable, FAULTS, fault, str(argument), "--",
                           *map(str, _args(cohort, run, cluster))], capture_output=True,
                          text=True, timeout=300, **kwargs)


@pytest.mark.parametrize("fault, argument", [("kill-between", 2), ("kill-in-table", 3)])
def test_the_command_killed_between_specimens_or_writing_the_table_resumes_to_the_same(
        cohort, cluster, reference, tmp_path, fault, argument):
    run = tmp_path / "run"
    killed = _faulty(fault, argument, cohort, run, cluster)
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    done = _nothing_half_written_is_a_result(run, reference)
    assert len(done) == 2, done             # the third table is the second specimen's
    if fault == "kill-in-table":
        [partial] = (run / "results").glob(".results.csv.*.tmp")    # half a table, never read
        assert partial.stat().st_size > 0
    lock = json.loads((run / "results" / "fit-many.lock").read_text())     # left by the dead
    stderr = _resume(cohort, run, cluster)
    assert f"took over the stale lock of a run that ended without releasing it (pid " \
           f"{lock['pid']} on {lock['host']}" in stderr and "no longer running" in stderr
    assert "2 of 4 specimens already fitted" in stderr
    if fault == "kill-in-table":
        assert "removed 1 half-written file(s) of an interrupted run (.results.csv." in stderr
    assert _final(run) == reference


def test_a_worker_killed_mid_specimen_is_retried_and_the_result_is_the_same(
        cohort, cluster, reference, tmp_path):
    run = tmp_path / "run"
    result = _faulty("kill-worker-once", "s1", cohort, run, cluster)
    assert result.returncode == 0, result.stderr
    assert (cohort.parent / "s1.killed").exists()
    (cohort.parent / "s1.killed").unlink()
    assert "fit-many: s1: 1 worker process(es) died while fitting it; fitted again" in \
        result.stderr and "Traceback" not in result.stderr
    record = json.loads((run / "results" / "s1" / "fit.json").read_text())
    assert record["status"] == "ok" and record["retries"] == 1
    assert _final(run) == reference


def test_a_specimen_that_kills_its_worker_every_time_fails_with_the_reason(
        cohort, cluster, reference, tmp_path):
    """Retries are bounded (the scheduler's allowed failures: 2 here, as the local cluster
    fit-many starts): the specimen is recorded as failed and the others are fitted."""
    run = tmp_path / "run"
    result = _faulty("kill-worker-always", "s2", cohort, run, cluster)
    (cohort.parent / "s2.killed").unlink()
    assert result.returncode == 1, result.stderr
    error = json.loads((run / "results" / "s2" / "error.json").read_text())
    assert error["kind"] == "worker" and error["retries"] == 3
    assert error["error"].startswith("its worker process died each time it was fitted")
    assert "fit-many: s2: 3 worker process(es) died while fitting it; not retried again" in \
        result.stderr
    assert "neurofuzzy: failed: s2: its worker process died each time" in result.stderr
    assert "Traceback" not in result.stderr
    rows = {row["id"]: row for row in csv.DictReader((run / "results" / "results.csv").open())}
    assert rows["s2"]["status"] == "failed" and "died each time" in rows["s2"]["error"]
    final = _final(run)
    for ident in ("s0", "s1", "s3"):
        assert final[f"results/{ident}/fit.json"] == reference[f"results/{ident}/fit.json"]
    _resume(cohort, run, cluster)                       # the fault gone, it is fitted
    assert _final(run) == reference


def test_the_scheduler_killed_stops_the_batch_and_resume_finishes_it(
        cohort, cluster, reference, tmp_path):
    run = tmp_path / "run"
    started = []
    try:
        started.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--scheduler-file",
             tmp_path / "scheduler.json", "--no-dashboard", "--port", "0"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        _wait_for(lambda: '"address"' in _text(tmp_path / "scheduler.json"))
        address = json.loads((tmp_path / "scheduler.json").read_text())["address"]
        started.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
             "--no-dashboard"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        command = subprocess.Popen(
            [sys.executable, FAULTS, "slow", "0.5", "--", *map(str, _args(cohort, run, None)),
             "--scheduler", address], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            text=True)
        started.append(command)
        _wait_for(lambda: (run / "results" / "s0" / "fit.json").exists())
        os.kill(started[0].pid, signal.SIGKILL)
        _, stderr = command.communicate(timeout=120)
    finally:
        for process in started:
            process.kill()
            process.wait()
    assert command.returncode == 2, stderr
    assert f"neurofuzzy: error: --scheduler: lost the Dask scheduler {address}" in stderr
    assert "run again with --resume for the rest" in stderr and "Traceback" not in stderr
    assert not list((run / "results").glob("*/error.json"))     # no specimen blamed
    _nothing_half_written_is_a_result(run, reference)
    assert not (run / "results" / "fit-many.lock").exists()      # released as it stopped
    _resume(cohort, run, cluster)
    assert _final(run) == reference


def _text(path):
    return path.read_text() if path.exists() else ""


def _wait_for(condition, seconds=120.0):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.05)


class FullDisk:
    """``atomic_write`` of the books and the table with ``free`` bytes left on the disk: the
    write that crosses it writes what fits and raises ENOSPC, as a full disk does."""

    def __init__(self, free: int):
        self.free = free

    def wrap(self, real):
        import contextlib

        @contextlib.contextmanager
        def atomic_write(path, mode="wb"):
            with real(path, mode) as handle:
                yield Filling(handle, self)
        return atomic_write


class Filling:
    def __init__(self, handle, disk):
        self.handle, self.disk = handle, disk

    def write(self, data):
        if len(data) > self.disk.free:
            self.handle.write(data[:self.disk.free])
            self.disk.free = 0
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))     # as write() raises it
        self.disk.free -= len(data)
        return self.handle.write(data)

    def __getattr__(self, name):
        return getattr(self.handle, name)


@pytest.mark.parametrize("share", [0.02, 0.5])
def test_a_full_disk_stops_the_batch_and_resume_finishes_it(cohort, cluster, reference,
                                                            tmp_path, monkeypatch, share):
    """The disk fills while a specimen's files are written (2 % of the run's bytes: the
    first specimen's; 50 %: a later one's)."""
    import neurofuzzy.batch.books
    import neurofuzzy.batch.table

    run = tmp_path / "run"
    total = sum(len(v) if isinstance(v, bytes) else len(json.dumps(v))
                for k, v in reference.items() if k.startswith("results/"))
    disk = FullDisk(int(total * share))
    for module in (neurofuzzy.batch.books, neurofuzzy.batch.table):
        monkeypatch.setattr(module, "atomic_write", disk.wrap(module.atomic_write))
    full = cli(*_args(cohort, run, cluster))
    assert full.returncode == 2, full.stderr
    [message] = [line for line in full.stderr.splitlines() if line.startswith("neurofuzzy:")]
    assert "No space left on device" in message and f"{run / 'results'}/" in message
    assert ".tmp" not in message                     # the file the user knows is named
    assert "run again with --resume for the rest" in full.stderr
    monkeypatch.undo()
    assert not list(run.rglob(".*.tmp"))             # the partial file went with the error
    assert not (run / "results" / "fit-many.lock").exists()
    _nothing_half_written_is_a_result(run, reference)
    _resume(cohort, run, cluster)
    assert _final(run) == reference


def test_a_second_run_on_the_folder_is_refused_while_the_first_runs(cohort, cluster,
                                                                    reference, tmp_path):
    run = tmp_path / "run"
    first = subprocess.Popen([sys.executable, FAULTS, "slow", "0.5", "--",
                              *map(str, _args(cohort, run, cluster))],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        _wait_for(lambda: (run / "results" / "fit-many.json").exists())
        for resume in ([], ["--resume"]):
            second = cli(*_args(cohort, run, cluster), *resume)
            assert second.returncode == 2, second.stderr
            assert second.stderr.strip().splitlines() == [
                f"neurofuzzy: error: {run / 'results'}: --out: another fit-many is writing "
                f"this results folder (pid {first.pid} on {socket.gethostname()}, started "
                f"{json.loads((run / 'results' / 'fit-many.lock').read_text())['started']}, "
                f"manifest {cohort}); wait for it to finish, or choose another --out"]
        _, stderr = first.communicate(timeout=120)
    finally:
        first.kill()
        first.wait()
    assert first.returncode == 0, stderr
    assert _final(run) == reference


def _profiling(dask_worker):
    """Whether a worker samples its tasks' stacks, and how many call trees it keeps."""
    return "profile" in dask_worker.periodic_callbacks, len(dask_worker.profile_history)


def test_the_local_cluster_keeps_no_profile_of_the_fits():
    # Dask's statistical profiler kept a call tree per second of every fit for the last
    # 1,000 seconds: about 1 MB per specimen on each worker (issue 49's memory growth)
    from neurofuzzy.batch.run import _client

    with _client(None, 1) as client:
        assert client.submit(sum, [1, 2], pure=False).result() == 3
        assert list(client.run(_profiling).values()) == [(False, 0)]
