"""fit-many under load (issue 49): a cohort of many tiny synthetic specimens on a local
cluster of two single-threaded workers. Measures the throughput, the resident memory of every
worker over the run (sampled every ``--every`` seconds; peak from the kernel's high-water
mark) and of the command's own process, and checks that every specimen is recorded once
(one row of ``results.csv``, one ``fit.json``, fitted by one of the workers).

The specimens are the smallest ``neurofuzzy.batch.synthetic`` makes: 2 x 2 x 2-node lattice
blocks (8 nodes, the bottom four held) of healthy and fibrotic liver, 40 frames, fitted from
the data alone (no rule base: the cheapest fit and report) with one spring constant for the
whole block. Prints a table and writes JSON (``benchmarks/fit_many_load.json``).

    python benchmarks/fit_many_load.py                   # 500 specimens, about 3½ min on 2 cores
    python benchmarks/fit_many_load.py --specimens 40    # a quick look
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from neurofuzzy.batch import fit_many
from neurofuzzy.batch.run import LOCAL_CLUSTER, THREAD_LIMITS
from neurofuzzy.batch.synthetic import synthetic_cohort

MB = 2**20


def _rss() -> int:
    import psutil

    return psutil.Process().memory_info().rss


def _peak_rss() -> int:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024      # KiB on Linux


def cohort(folder: Path, specimens: int, seed: int) -> Path:
    """The synthetic cohort's data and a manifest that fits each from the data alone."""
    made = synthetic_cohort(folder, per_group=specimens // 2, shape=(2, 2, 2), n_frames=40,
                            seed=seed)
    lines = made.manifest.read_text().splitlines()
    manifest = folder / "plain.csv"
    manifest.write_text("id,group,experiments,tie,substeps\n" + "".join(
        f"{ident},{group},{data},{tie},{substeps}\n"
        for ident, group, data, _, _, tie, substeps in (line.split(",") for line in lines[1:])))
    return manifest


def sample(client, out: Path, every: float, samples: list, stop: threading.Event) -> None:
    """(seconds, specimens done, {worker: RSS}) every ``every`` seconds until ``stop``."""
    began = time.perf_counter()
    while not stop.wait(every):
        done = sum(1 for entry in os.scandir(out) if entry.is_dir()
                   and os.path.exists(os.path.join(entry.path, "fit.json"))) \
            if out.exists() else 0
        samples.append((time.perf_counter() - began, done, client.run(_rss)))


def run(specimens: int, workers: int, every: float, seed: int, folder: Path) -> dict:
    import dask
    from dask.distributed import Client, LocalCluster

    manifest = cohort(folder, specimens, seed)
    out = folder / "results"
    samples: list = []
    with dask.config.set(LOCAL_CLUSTER), \
            LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                         dashboard_address=None, silence_logs=logging.CRITICAL,
                         env=THREAD_LIMITS) as cluster, Client(cluster) as client:
        client.run(lambda: __import__("neurofuzzy.batch.task"))     # imports before timing
        start_rss = client.run(_rss)
        stop = threading.Event()
        sampler = threading.Thread(target=sample, args=(client, out, every, samples, stop))
        sampler.start()
        began = time.perf_counter()
        try:
            result = fit_many(manifest, out, scheduler=cluster.scheduler_address)
        finally:
            stop.set()
            sampler.join()
        seconds = time.perf_counter() - began
        end_rss, peak = client.run(_rss), client.run(_peak_rss)
        pids = client.run(os.getpid)
    rows = list(csv.DictReader((out / "results.csv").open()))
    records = [json.loads((out / s.id / "fit.json").read_text()) for s in result.specimens]
    ids = [row["id"] for row in rows]
    workers_seen = {record["worker"].rsplit(":", 1)[1] for record in records}
    check = {"rows": len(rows), "unique_ids": len(set(ids)), "ok": len(result.ok),
             "failed": len(result.failed), "fit_json": len(records),
             "computed": len(result.computed),
             "fitted_by_the_workers": workers_seen <= {str(p) for p in pids.values()},
             "retried": len(result.retried)}
    check["every_specimen_once"] = (check["rows"] == check["unique_ids"] == check["ok"]
                                    == check["fit_json"] == check["computed"] == specimens)
    return {"specimens": specimens, "workers": workers, "seconds": seconds,
            "throughput": specimens / seconds, "check": check,
            "memory": _memory(samples, start_rss, end_rss, peak, specimens),
            "command_peak_rss_mb": _peak_rss() / MB,
            "throughput_by_half": _halves(samples, specimens, seconds)}


def _memory(samples, start_rss, end_rss, peak, specimens) -> dict:
    """Per worker: RSS at the start, after a tenth of the cohort, at the end, the peak, and
    the slope of a line through the samples after the first tenth (MB per 100 specimens)."""
    memory = {}
    for worker in start_rss:
        points = [(done, rss[worker]) for _, done, rss in samples
                  if worker in rss and done >= specimens // 10]
        slope = (np.polyfit([d for d, _ in points], [r for _, r in points], 1)[0] * 100 / MB
                 if len({d for d, _ in points}) > 1 else None)
        memory[worker] = {"start_mb": start_rss[worker] / MB,
                          "tenth_mb": points[0][1] / MB if points else None,
                          "end_mb": end_rss[worker] / MB, "peak_mb": peak[worker] / MB,
                          "slope_mb_per_100": slope}
    return memory


def _halves(samples, specimens, seconds) -> list:
    """Specimens per second in the first and the second half of the cohort."""
    half = next((t for t, done, _ in samples if done >= specimens // 2), None)
    if half is None:
        return []
    return [specimens // 2 / half, (specimens - specimens // 2) / (seconds - half)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specimens", type=int, default=500)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--every", type=float, default=2.0, help="sampling interval (s)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=str(Path(__file__).with_name("fit_many_load.json")))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="neurofuzzy-load-") as folder:
        result = run(args.specimens, args.workers, args.every, args.seed, Path(folder))
    check = result["check"]
    print(f"{result['specimens']} specimens on {result['workers']} workers: "
          f"{result['seconds']:.0f} s, {result['throughput']:.2f} specimens/s"
          + (" (first half {:.2f}, second half {:.2f})".format(*result["throughput_by_half"])
             if result["throughput_by_half"] else ""))
    print(f"recorded: {check['rows']} rows, {check['unique_ids']} ids, {check['fit_json']} "
          f"fit.json, {check['ok']} ok, {check['failed']} failed, {check['retried']} retried; "
          f"every specimen once: {check['every_specimen_once']}")
    print(f"{'worker':<28} {'start MB':>9} {'at 10 %':>9} {'end MB':>9} {'peak MB':>9} "
          f"{'MB/100 specimens':>17}")
    for worker, memory in result["memory"].items():
        slope = memory["slope_mb_per_100"]
        print(f"{worker:<28} {memory['start_mb']:>9.0f} {memory['tenth_mb'] or 0:>9.0f} "
              f"{memory['end_mb']:>9.0f} {memory['peak_mb']:>9.0f} "
              f"{'' if slope is None else f'{slope:+.2f}':>17}")
    print(f"the command's own process: peak {result['command_peak_rss_mb']:.0f} MB")
    Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
