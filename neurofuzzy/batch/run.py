"""Many specimens at once: :func:`fit_many` runs every specimen of a manifest as one task on
Dask and keeps the books (results folder, table, resume, failures, progress).

Layout of the output folder ``OUT``:

- ``OUT/<id>/fit.json``: the finished fit (``neurofuzzy fit --json``'s object under
  ``"fit"``, with ``quality``), written last, so it marks the specimen as done; beside it
  ``fitted.yaml``, ``report.html`` (+ ``report.json``) and, when asked for, the diagnosis;
- ``OUT/<id>/error.json``: a specimen that failed (its message; a traceback only for what is
  not an input error);
- ``OUT/results.csv``: one row per specimen and material region, rewritten atomically after
  every specimen (``results.parquet`` too when pyarrow is installed);
- ``OUT/fit-many.json``: the manifest the folder was made from (:mod:`.books`), so that
  ``--resume`` never mixes in another cohort;
- ``OUT/fit-many.lock``: the lock of the run writing the folder (:mod:`.lock`): one run at a
  time, a dead run's lock taken over.

Nothing is written before the cluster answers: a refused or unreachable scheduler leaves the
folder as it was. Ids that would collide with these files, inputs that an output would
overwrite, and a folder of another manifest are refused before anything runs.

Every file is written atomically by this process (the workers return their outputs), so an
interrupted batch leaves only finished specimens behind, and ``resume=True`` fits only those
whose ``fit.json`` is missing or was made from other inputs (a fingerprint of the input files'
contents and the options); it first removes the temporary files of writes that never
finished. A worker that dies while it fits a specimen costs that attempt only: the scheduler
runs the task again, at most :data:`RETRIES` times on the local cluster, and a specimen
that kills its worker every time is recorded as failed with the reason. A lost scheduler or
a full disk stops the batch (what finished is kept). Dask is imported here only, when a
batch runs.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..errors import InputError, SchedulerLostError
from ..progress import Progress, note
from .books import RECORD_FORMAT, check_folder, finished, sweep, write_books, write_specimen
from .lock import folder_lock
from .manifest import Specimen, read_manifest
from .table import TABLE_NAME, write_table
from .task import fit_specimen

__all__ = ["fit_many", "Cohort", "THREAD_LIMITS", "RECORD_FORMAT", "RETRIES"]

#: environment of local workers: one thread each for every numerical library, so that
#: ``n`` single-threaded workers use ``n`` cores and no more
THREAD_LIMITS = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
                 "NUMBA_NUM_THREADS": "1"}
#: how long to wait for an existing scheduler
CONNECT_TIMEOUT = "10s"
#: how often the local cluster runs a specimen again after its worker process died (an
#: existing cluster keeps its own ``distributed.scheduler.allowed-failures``, 3 by default)
RETRIES = 2
#: the local cluster's configuration: bounded retries, and one task per worker thread at a time
#: (Dask's default saturation, 1.1, hands a single-threaded worker a second task to hold,
#: which a worker killed by the first takes down with it: an innocent specimen would count a
#: worker death of its own and could be failed with the guilty one); and no statistical
#: profiler on the workers: Dask samples every running task's stack every 10 ms and keeps a
#: call tree per second for the last 1,000 seconds, which grew a worker fitting specimens by
#: about 1 MB per specimen (issue 49; ``benchmarks/fit_many_load.py``)
LOCAL_CLUSTER = {"distributed.scheduler.allowed-failures": RETRIES,
                 "distributed.scheduler.worker-saturation": 1.0,
                 "distributed.worker.profile.enabled": False}


@dataclass(frozen=True)
class Cohort:
    """What :func:`fit_many` did.

    Attributes
    ----------
    specimens : tuple of Specimen
        The manifest's specimens, in its order.
    records : dict
        Specimen id → its record: ``{"id", "group", "status": "ok", "fit": {…}, …}`` or
        ``{"id", "group", "status": "failed", "error", …}``.
    computed : tuple of str
        Ids fitted (or failed) in this run.
    resumed : tuple of str
        Ids whose finished results were kept (``resume=True``).
    out : Path
        The output folder; ``table`` its ``results.csv``; ``report`` the cohort report or None.
    seconds : float
        Wall time.
    retried : dict
        Specimen id → how many worker processes died while fitting it in this run (only the
        specimens that lost one; :data:`RETRIES` bounds the attempts of a local cluster).
    """

    specimens: tuple[Specimen, ...]
    records: dict
    computed: tuple[str, ...]
    resumed: tuple[str, ...]
    out: Path
    table: Path
    report: Path | None
    seconds: float
    retried: dict = field(default_factory=dict)

    @property
    def ok(self) -> list[str]:
        """Ids of the specimens that are fitted."""
        return [s.id for s in self.specimens if self.records[s.id]["status"] == "ok"]

    @property
    def failed(self) -> list[str]:
        """Ids of the specimens that failed."""
        return [s.id for s in self.specimens if self.records[s.id]["status"] == "failed"]

    def to_dict(self) -> dict:
        """JSON-ready summary (the object of ``fit-many --json``)."""
        return {"specimens": len(self.specimens), "ok": self.ok,
                "failed": [{"id": i, "error": self.records[i]["error"]} for i in self.failed],
                "computed": list(self.computed), "resumed": list(self.resumed),
                "out": str(self.out), "table": str(self.table),
                "report": None if self.report is None else str(self.report),
                "retried": dict(self.retried), "seconds": self.seconds}


def fit_many(manifest, out, *, report=None, scheduler: str | None = None,
             workers: int | None = None, resume: bool = False, seed: int = 0,
             progress: bool = False) -> Cohort:
    """Fit every specimen of ``manifest``, each as one task on Dask, and keep the books.

    Parameters
    ----------
    manifest : path
        CSV or YAML (:func:`~neurofuzzy.batch.read_manifest`).
    out : path
        Output folder (see the module docstring); created if needed.
    report : path, optional
        Write the cohort report here (HTML, with a JSON twin;
        :func:`~neurofuzzy.batch.cohort_report`).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://HOST:PORT``); its workers must be able
        to import neurofuzzy and read the input files. Default: a local cluster of
        ``workers`` processes with one thread each.
    workers : int, optional
        Processes of the local cluster (default: the machine's cores).
    resume : bool
        Keep the finished results in ``out`` whose inputs are unchanged; fit the others.
        Without it, an ``out`` holding results of an earlier run is refused.
    seed : int
        Seed of the report's bootstrap.
    progress : bool
        Progress on stderr (done / failed / running, ETA).

    Returns
    -------
    Cohort

    Raises
    ------
    InputError
        A bad manifest, a bad option, an output that would overwrite an input or an earlier
        run's results (without ``resume``), an unreachable scheduler. A specimen that fails
        does not raise: it is recorded, and the others go on.
    FolderInUseError
        Another run holds the folder's lock (:mod:`neurofuzzy.batch.lock`; a stale one is
        taken over).
    SchedulerLostError
        The scheduler stopped during the batch; what finished is kept.
    OSError
        An output could not be written (a full disk); what finished before is kept.
    """
    started = time.perf_counter()
    specimens = read_manifest(manifest)
    out = Path(out)
    report = None if report is None else Path(report)
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise InputError(f"got {workers!r}; expected a positive number of processes",
                         key="--workers")
    if workers is not None and scheduler:
        raise InputError("an existing cluster has its own workers; give --workers only for "
                         "the local cluster", key="--workers")
    with folder_lock(out, manifest, notes=lambda text: note(True, text)):
        cohort = _books_and_run(specimens, manifest, out, report, scheduler, workers, resume,
                                progress)
        if report is not None:
            from .cohort import cohort_report

            cohort = replace(cohort, report=cohort_report(cohort, report, seed=seed))
    return replace(cohort, seconds=time.perf_counter() - started)


def _books_and_run(specimens, manifest, out, report, scheduler, workers, resume,
                   progress) -> Cohort:
    """What :func:`fit_many` does while it holds the folder's lock."""
    check_folder(out, report, manifest, specimens, resume)
    if resume:
        removed = sweep(out, specimens, report)
        if removed:
            note(progress, f"fit-many: removed {len(removed)} half-written file(s) of an "
                           f"interrupted run ({', '.join(p.name for p in removed[:3])}"
                           f"{' …' if len(removed) > 3 else ''})")
    fingerprints = {s.id: s.fingerprint() for s in specimens}
    records = {s.id: finished(out / s.id, fingerprints[s.id]) if resume else None
               for s in specimens}
    resumed = tuple(i for i, record in records.items() if record is not None)
    pending = [s for s in specimens if records[s.id] is None]
    for specimen in specimens:
        if records[specimen.id] is not None:
            records[specimen.id]["group"] = specimen.group       # labels may be renamed
    table = out / TABLE_NAME

    def open_books() -> None:
        """The folder's record of the manifest and the table: written only once the
        cluster answers, so a refused or unreachable one leaves the folder as it was."""
        write_books(out, manifest, specimens)
        write_table(table, specimens, records)
        if resumed:
            note(progress, f"fit-many: {len(resumed)} of {len(specimens)} specimens already "
                           f"fitted in {out} (resumed)")

    retried: dict[str, int] = {}
    if not pending:
        open_books()
    else:
        try:
            _run(pending, fingerprints, records, out, table, specimens, scheduler, workers,
                 progress, len(resumed), open_books, retried)
        except (KeyboardInterrupt, OSError, SchedulerLostError) as error:
            finished_now = sum(record is not None for record in records.values())
            why = "interrupted" if isinstance(error, KeyboardInterrupt) else "stopped"
            note(True, f"fit-many: {why}; the {finished_now} of {len(specimens)} "
                       f"specimens that finished are in {out}: run again with --resume for "
                       "the rest")
            raise
    return Cohort(tuple(specimens), records, tuple(s.id for s in pending), resumed, out,
                  table, None, 0.0, retried)


# -- running ----------------------------------------------------------------------------------
def _run(pending, fingerprints, records, out, table, specimens, scheduler, workers, progress,
         n_resumed, open_books, retried) -> None:
    from dask.distributed import as_completed

    total = len(specimens)
    counter = Progress("fit-many", total, enabled=progress)
    with _client(scheduler, workers) as client:
        open_books()
        threads = sum(client.nthreads().values())
        if not threads:
            note(progress, f"fit-many: the scheduler {scheduler} has no workers yet; the "
                           "specimens wait for some")
        threads = max(threads, 1)
        processes = max(len(client.nthreads()), 1)
        note(progress, f"fit-many: {len(pending)} specimens on {processes} worker "
                       f"process(es), {threads} thread(s) in all"
                       f"{' at ' + scheduler if scheduler else ''}")
        futures = {client.submit(fit_specimen, specimen, pure=False,
                                 key=f"fit-{specimen.id}-{fingerprints[specimen.id][:12]}"):
                   specimen for specimen in pending}
        finished, failed, began = 0, 0, time.perf_counter()
        for future in as_completed(futures):
            specimen = futures[future]
            outcome = _outcome(future, specimen, scheduler)
            lost = _workers_lost(client, future.key)
            if lost:
                retried[specimen.id] = lost
                outcome["retries"] = lost
                note(progress, f"fit-many: {specimen.id}: {lost} worker process(es) died "
                               "while fitting it; "
                               + ("fitted again" if outcome["status"] == "ok" else "not "
                                  "retried again"))
            records[specimen.id] = write_specimen(out / specimen.id, specimen,
                                                  fingerprints[specimen.id], outcome)
            write_table(table, specimens, records)
            future.release()
            finished += 1
            failed += outcome["status"] == "failed"
            left = len(pending) - finished
            eta = (time.perf_counter() - began) / finished * left
            counter.update(n_resumed + finished,
                           f"done, {failed} failed, {min(threads, left)} running, "
                           f"{max(left - threads, 0)} waiting, ETA {eta:.0f} s")
            if outcome["status"] == "failed":
                note(progress, f"fit-many: {specimen.id} failed: {outcome['error']}")


def _outcome(future, specimen: Specimen, scheduler) -> dict:
    """The task's result, or its failure when the worker could not deliver one."""
    from dask.distributed import CancelledError, KilledWorker

    try:
        return future.result()
    except CancelledError:
        # the futures of a client that lost its scheduler are cancelled: no specimen failed
        raise SchedulerLostError(
            f"--scheduler: lost the Dask scheduler{' ' + scheduler if scheduler else ''} (it "
            "stopped or the connection broke) before every specimen was fitted") from None
    except KilledWorker as error:
        # a specimen whose worker died every time it ran (killed, out of memory): the
        # scheduler's bounded retries are spent; recorded as failed with the reason
        return {"id": specimen.id, "status": "failed", "kind": "worker",
                "error": f"its worker process died each time it was fitted (killed, or out "
                         f"of memory; {error})", "seconds": None}
    except Exception as error:  # noqa: BLE001
        # deliberately broad: a worker that lost its connection or could not unpickle the
        # task fails this specimen only; it is recorded and the batch goes on
        return {"id": specimen.id, "status": "failed", "kind": "error",
                "error": f"the worker could not run the fit: {type(error).__name__}: {error}",
                "seconds": None}


def _workers_lost(client, key: str) -> int:
    """How many worker processes died while running the task ``key`` (the scheduler's count
    of the task's retries; 0 when it does not know the task any more)."""
    def suspicious(dask_scheduler, key):
        task = dask_scheduler.tasks.get(key)
        return 0 if task is None else task.suspicious

    try:
        return int(client.run_on_scheduler(suspicious, key=key))
    except (OSError, TimeoutError, ValueError):
        return 0


@contextlib.contextmanager
def _client(scheduler: str | None, workers: int | None):
    """A Dask client of the scheduler at ``scheduler``, or of a new local cluster.

    Dask's own log lines (a worker that died, a lost connection, with their tracebacks) are
    not shown: fit-many reports each in one line of its own.
    """
    import dask
    from dask.distributed import Client, LocalCluster

    loggers = [logging.getLogger("distributed")] + [
        logging.getLogger(name) for name in list(logging.root.manager.loggerDict)
        if name.startswith("distributed.")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:          # dask's configuration gives some their own level
        logger.setLevel(logging.CRITICAL)
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout=CONNECT_TIMEOUT)
            except (OSError, ValueError, TimeoutError) as error:
                raise InputError(f"cannot reach the Dask scheduler {scheduler} ({error})",
                                 key="--scheduler") from None
            with client:
                yield client
            return
        with dask.config.set(LOCAL_CLUSTER), \
                LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1,
                             processes=True, dashboard_address=None,
                             silence_logs=logging.CRITICAL, env=THREAD_LIMITS) as cluster, \
                Client(cluster) as client:
            yield client
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)
