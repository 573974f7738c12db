"""Run ``neurofuzzy fit-many`` with one fault injected (issue 49); used by
``tests/test_batch_faults.py`` as ``python tests/faults.py FAULT ARGUMENT -- fit-many …``.

Faults (each patches the library in this process only; nothing of it ships):

- ``kill-between N``: the process kills itself (SIGKILL) once N specimens are recorded (and
  the table written), as the next specimen's result arrives;
- ``kill-in-table N``: the process kills itself halfway through its N-th write of
  ``results.csv`` (half the table flushed to the temporary file);
- ``kill-worker-once ID``: the worker fitting specimen ID kills itself the first time (a file
  beside the manifest, ``ID.killed``, remembers it);
- ``kill-worker-always ID``: every worker that fits specimen ID kills itself;
- ``slow SECONDS``: every fit waits SECONDS first (to kill something while a batch runs).

The task functions are defined in ``__main__``, so Dask's cloudpickle sends them to the
workers by value.
"""

import os
import signal
import sys
from pathlib import Path


def kill_worker(specimen, ident, always, real):
    marker = Path(specimen.source).parent / f"{specimen.id}.killed"
    if specimen.id == ident and (always or not marker.exists()):
        marker.touch()
        os.kill(os.getpid(), signal.SIGKILL)
    return real(specimen)


def slow(specimen, seconds, real):
    import time

    time.sleep(seconds)
    return real(specimen)


def main(fault: str, argument: str, args: list[str]) -> int:
    import functools

    import neurofuzzy.batch.run as run
    import neurofuzzy.batch.table as table
    from neurofuzzy.batch.task import fit_specimen
    from neurofuzzy.cli import main as cli

    if fault == "kill-between":
        calls = {"n": 0}
        write_specimen = run.write_specimen

        def killing_write_specimen(*args, **kwargs):
            if calls["n"] == int(argument):
                os.kill(os.getpid(), signal.SIGKILL)
            calls["n"] += 1
            return write_specimen(*args, **kwargs)

        run.write_specimen = killing_write_specimen
    elif fault == "kill-in-table":
        calls = {"n": 0}
        atomic_write = table.atomic_write

        class HalfThenKill:
            def __init__(self, handle):
                self.handle = handle

            def write(self, text):
                self.handle.write(text[:len(text) // 2])
                self.handle.flush()
                os.fsync(self.handle.fileno())
                os.kill(os.getpid(), signal.SIGKILL)

        def killing_atomic_write(path, mode="wb"):
            import contextlib

            @contextlib.contextmanager
            def opened():
                with atomic_write(path, mode) as handle:
                    calls["n"] += Path(path).name == "results.csv"
                    yield HalfThenKill(handle) if calls["n"] == int(argument) and \
                        Path(path).name == "results.csv" else handle
            return opened()

        table.atomic_write = killing_atomic_write
    elif fault in ("kill-worker-once", "kill-worker-always"):
        run.fit_specimen = functools.partial(kill_worker, ident=argument,
                                             always=fault.endswith("always"), real=fit_specimen)
    elif fault == "slow":
        run.fit_specimen = functools.partial(slow, seconds=float(argument), real=fit_specimen)
    else:
        raise SystemExit(f"unknown fault {fault}")
    return cli(args)


if __name__ == "__main__":
    separator = sys.argv.index("--")
    sys.exit(main(sys.argv[1], sys.argv[2], sys.argv[separator + 1:]))
