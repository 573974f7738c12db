"""The region test's power, checked against the test itself (issue 48, item 1).

The power check (:mod:`neurofuzzy.learn.power`) predicts from homogeneous data whether the
region test would keep a stiff lump, without a refit: the lump is simulated with the
homogeneous fit and its signature added to the data. Here it is checked against what the
test did on data that really hold the lump: ``benchmarks/inclusions.json``'s "truth alone"
rows (MuJoCo flex data of the probed block with a box 2, 5 or 10 times stiffer, of 8 % or 3 %
of the volume, under the probe or away from it, 20 µm noise, fitted on 7.5 mm voxels; the
region test given the box's own elements). The check runs on the homogeneous data set of the
same solver, noise and mesh, with the same boxes.

    python benchmarks/power.py            # about 15 s after the kernels compiled

Prints a table and writes ``benchmarks/power.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn.power import LumpCheck, describe_power, detection_limit
from neurofuzzy.learn.region_test import homogeneous_fit
from neurofuzzy.validation.probed_block import (Inclusion, block_experiment, block_model,
                                                mujoco_block)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from inclusions import BOXES  # noqa: E402


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", default=str(HERE / "power.json"))
    args = parser.parse_args(argv)
    source = json.loads((HERE / "inclusions.json").read_text())
    if source["pitch"] != 0.0075:
        sys.exit("benchmarks/power.py: inclusions.json holds another pitch than 7.5 mm; rerun "
                 "python benchmarks/inclusions.py")
    start = block_model(pitch=source["pitch"]).tied("none")
    experiment = block_experiment(mujoco_block(inclusion=None, noise=20e-6, seed=0),
                                  start.mesh)
    began = time.perf_counter()
    homogeneous = homogeneous_fit(GradientLearner(substeps="auto"), start, [experiment])
    fitted = time.perf_counter() - began
    began = time.perf_counter()
    power = detection_limit(homogeneous, [experiment])
    seconds = time.perf_counter() - began
    check = LumpCheck(homogeneous, [experiment])
    centres = start.mesh.rest_positions[start.mesh.tetrahedra].mean(axis=1)
    rows = []
    for row in source["rows"]:
        if row["contrast"] == 1:
            continue
        box = Inclusion.box(*BOXES[(row["size"], row["place"])], contrast=row["contrast"])
        members = np.flatnonzero(box.inside(centres))
        rows.append({"contrast": row["contrast"], "size": row["size"], "place": row["place"],
                     "check": check.kept(members, row["contrast"]),
                     "test": row["truth_region"]["would_pass"],
                     "test_shrink": row["truth_region"]["gap_shrink"]})
    agree = sum(r["check"] == r["test"] for r in rows)
    print(f"homogeneous fit {fitted:.1f} s, {homogeneous.lack_of_fit_.ratio:.2f}x the noise; "
          f"the power check {seconds:.1f} s")
    print(describe_power(power))
    print(f"\n{'contrast':>8} {'size':>5} {'place':>6} {'check':>6} {'test':>6} {'shrink':>7}")
    for r in rows:
        print(f"{r['contrast']:>7g}x {r['size']:>5} {r['place']:>6} "
              f"{'kept' if r['check'] else 'no':>6} {'kept' if r['test'] else 'no':>6} "
              f"{r['test_shrink']:>6.2f}x")
    print(f"\nthe check says what the test did in {agree} of {len(rows)} cases")
    Path(args.json).write_text(json.dumps(
        {"power": power, "seconds": seconds, "rows": rows, "agree": agree}, indent=1) + "\n")


if __name__ == "__main__":
    main()
