"""A cohort on Dask: healthy and fibrotic liver specimens fitted by fit-many, against a loop.

The cohort is made with our own simulator (:func:`neurofuzzy.batch.synthetic.synthetic_cohort`):
per group, lattice blocks of the shipped liver rule base's tissue ("liver": firm; and
"fibrotic_liver": hard), each specimen's stiffness and viscosity varied by a seeded
log-normal factor (15 %), pushed on the top centre node and recorded with 5 µm marker noise.
Every fit starts from the expert's words for healthy liver, tied globally.

The same specimens are fitted twice: one after another in this process (the loop a user
would write, calling the very task fit-many runs), and by fit-many on a local Dask cluster
(one single-threaded worker process per core). Both are timed end to end (the cluster's
start and its workers' imports included) and must give the same numbers.

Run:  python examples/cohort.py [OUT_DIR] [--quick]
Writes OUT_DIR/cohort.csv (the manifest), OUT_DIR/data/*.npz, OUT_DIR/results/ (a folder per
specimen and results.csv) and OUT_DIR/cohort.html (+ .json); prints the timings, the speed-up
and the groups' materials and words. Default: 8 specimens of 64 nodes (about a minute on 2
cores); --quick: 4 specimens of 27 nodes.
"""

import json
import os
import sys
import time
from pathlib import Path

import numpy as np

import neurofuzzy as nf
from neurofuzzy.batch import fit_specimen
from neurofuzzy.batch.synthetic import synthetic_cohort


def main(argv):
    quick = "--quick" in argv
    paths = [a for a in argv if not a.startswith("--")]
    out = Path(paths[0] if paths else "cohort-output")
    out.mkdir(parents=True, exist_ok=True)
    shape, frames, per_group = ((3, 3, 3), 100, 2) if quick else ((4, 4, 4), 200, 4)
    made = synthetic_cohort(out, per_group=per_group, shape=shape, n_frames=frames,
                            noise=5e-6, spread=0.15, seed=2026)
    specimens = nf.read_manifest(made.manifest)
    cores = os.cpu_count()
    print(f"cohort: {len(specimens)} specimens ({per_group} healthy, {per_group} fibrotic), "
          f"{np.prod(shape)}-node lattices, {frames} frames, 5 um marker noise")

    load = os.getloadavg()[0]
    started = time.perf_counter()
    serial = {s.id: fit_specimen(s) for s in specimens}
    serial_seconds = time.perf_counter() - started
    failed = [i for i, outcome in serial.items() if outcome["status"] != "ok"]
    if failed:
        raise SystemExit(f"serial fits failed: {failed}")

    started = time.perf_counter()
    cohort = nf.fit_many(made.manifest, out / "results", report=out / "cohort.html",
                         resume=False, progress=not quick)
    parallel_seconds = time.perf_counter() - started
    if cohort.failed:
        raise SystemExit(f"fit-many failed: {cohort.failed}")

    agree = max(float(np.max(np.abs(np.subtract(cohort.records[i]["fit"]["stiffness"],
                                                serial[i]["fit"]["stiffness"]))
                             / np.abs(serial[i]["fit"]["stiffness"]))) for i in serial)
    print(f"serial loop (one specimen after another):  {serial_seconds:6.1f} s")
    print(f"fit-many on a LocalCluster ({cores} workers):  {parallel_seconds:6.1f} s")
    print(f"speed-up: {serial_seconds / parallel_seconds:.2f}x on {cores} cores "
          f"(largest relative difference of the fitted stiffnesses: {agree:.1e})")
    print(f"load average of the machine before the runs: {load:.1f} (other processes "
          "share these cores)")

    print(f"\n{'group':10} {'true E (median)':>16} {'fitted E (median)':>18} {'error':>7}  words")
    twin = json.loads(cohort.report.with_suffix(".json").read_text())
    for group in twin["groups"]:
        ids = [s.id for s in specimens if s.group == group]
        true = np.median([made.truth[i]["youngs_modulus"] for i in ids])
        fitted = np.median([next(iter(cohort.records[i]["fit"]["materials"].values()))
                            ["youngs_modulus"] for i in ids])
        [words] = [w for w in twin["words"]
                   if w["group"] == group and w["quantity"] == "youngs_modulus"]
        counted = ", ".join(f"{w} ({c}/{words['n']})" for w, c in words["words"].items())
        print(f"{group:10} {true:14.0f} Pa {fitted:15.0f} Pa {100 * (fitted / true - 1):+6.2f}%"
              f"  {group}: {counted}")
    for comparison in twin["comparisons"]:
        first, second = comparison["groups"]
        low, high = comparison["interval"]
        print(f"{comparison['quantity']}: {second} - {first} = {comparison['difference']:.4g} "
              f"(95 % bootstrap interval {low:.4g} .. {high:.4g})")
    print(f"\nthe same from the command line:\n  neurofuzzy fit-many {made.manifest} "
          f"--out {out / 'results'} --report {cohort.report}")
    print(f"wrote {cohort.table}, {cohort.report}")


if __name__ == "__main__":
    main(sys.argv[1:])
