"""Stiff inclusions found, located, missed or invented (issue 48, item 4): data of the probed
block from MuJoCo's flex (linear tetrahedra split five to a 2.5 mm cube, 20 µm marker noise),
with a box 2, 5 or 10 times stiffer, of 8 % or 3 % of the volume, under the probe or away from
it, and none; fitted element by element with the rule base as a prior on voxels split six to
a cube (another split and size than the data's), and every region found tested
(:mod:`neurofuzzy.learn.region_test`).

Each row says what the fit kept (:func:`outcome`), and what the true inclusion's elements
would do as the one candidate (the same test): when even they do not shrink the misfit above
the noise 1.5×, no candidate can pass on that mesh, and a miss is the mesh's, not the
search's.

    python benchmarks/inclusions.py                  # 13 data sets on 7.5 mm voxels
    python benchmarks/inclusions.py --pitch 0.01     # the 1 cm voxels
    python benchmarks/inclusions.py --quick          # the 5x, 8 % ones and the homogeneous

Prints a table and writes ``benchmarks/inclusions.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn.prior import FuzzyPrior
from neurofuzzy.learn.region_test import supported_regions
from neurofuzzy.rules import resolve
from neurofuzzy.validation.probed_block import (Inclusion, block_experiment, block_model,
                                                mujoco_block)

HERE = Path(__file__).resolve().parent
#: (low corner, high corner) in m: 2 × 2 × 1 cm (8.3 % of the block) and 1.2 × 1.2 × 1 cm
#: (3.0 %), centred under the probe (x = y = 2 cm) or away from it (x = y = 1 cm).
BOXES = {("8 %", "under"): ((0.01, 0.01, 0.015), (0.03, 0.03, 0.025)),
         ("3 %", "under"): ((0.014, 0.014, 0.015), (0.026, 0.026, 0.025)),
         ("8 %", "away"): ((0.0, 0.0, 0.015), (0.02, 0.02, 0.025)),
         ("3 %", "away"): ((0.004, 0.004, 0.015), (0.016, 0.016, 0.025))}
STIFFER = ("hard", "very_hard")


def case(contrast, size, place, pitch) -> dict:
    inclusion = (None if contrast == 1 else
                 Inclusion.box(*BOXES[(size, place)], contrast=contrast))
    recording = mujoco_block(inclusion=inclusion, noise=20e-6, seed=0)
    start = block_model(pitch=pitch).tied("none")
    experiment = block_experiment(recording, start.mesh)
    began = time.perf_counter()
    fitted = GradientLearner(substeps="auto", prior=FuzzyPrior(
        resolve("liver"), start, tissue="liver")).fit(start, experiment)
    seconds = time.perf_counter() - began
    centres = start.mesh.rest_positions[start.mesh.tetrahedra].mean(axis=1)
    kept = fitted.regions_["regions"]
    row = {"contrast": contrast, "size": size, "place": place, "seconds": seconds,
           "rms_over_noise": fitted.lack_of_fit_.ratio,
           "kept": [{"label": r["label"], "quantity": r["quantity"], "size": r["size"],
                     "centroid_mm": [1e3 * c for c in r["centroid"]],
                     "inside": float(inclusion.inside(centres[r["elements"]]).mean())
                     if inclusion else 0.0} for r in kept],
           "tested": sum(1 for r in fitted.regions_["rejected"]
                         if r["evidence"].get("tested"))}
    if inclusion is None:
        row["outcome"] = "invented" if kept else "none (right)"
        return row
    truly = np.flatnonzero(inclusion.inside(centres))
    best = supported_regions({"regions": [{"elements": truly.tolist(), "label": "truth",
                                           "quantity": "youngs_modulus",
                                           "size": len(truly)}]},
                             fitted.homogeneous_, [experiment])
    evidence = (best["regions"] or best["rejected"])[0]["evidence"]
    row["truth_region"] = {"elements": len(truly), "gap_shrink": evidence["gap_shrink"],
                           "would_pass": evidence["kept"]}
    row["outcome"] = outcome(row, inclusion)
    return row


def outcome(row, inclusion) -> str:
    """``located`` (a kept region harder than described, its centroid inside the box, at
    least half of its elements in it), else ``missed``; ``+ invented`` when a kept region
    lies mostly outside the box."""
    located = any(r["label"] in STIFFER and r["inside"] >= 0.5
                  and inclusion.inside(np.array(r["centroid_mm"]) / 1e3) for r in row["kept"])
    invented = any(r["inside"] < 0.5 for r in row["kept"])
    return ("located" if located else "missed") + (" + invented" if invented else "")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pitch", type=float, default=0.0075, help="voxel size (m)")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", default=str(HERE / "inclusions.json"))
    args = parser.parse_args(argv)
    cases = [(1, None, None)] + [(c, s, p) for s in ("8 %", "3 %") for p in ("under", "away")
                                 for c in (2, 5, 10)]
    if args.quick:
        cases = [(1, None, None), (5, "8 %", "under")]
    rows = []
    print(f"{'inclusion':<26} {'outcome':<16} {'kept':<34} {'truth alone':<18} s",
          flush=True)
    for contrast, size, place in cases:
        row = case(contrast, size, place, args.pitch)
        rows.append(row)
        name = "none" if contrast == 1 else f"{contrast}x, {size}, {place}"
        kept = ", ".join(f"{r['label']} {r['size']} ({r['inside']:.0%} in)"
                         for r in row["kept"]) or "-"
        truth = row.get("truth_region")
        alone = (f"{truth['gap_shrink']:.2g}x " + ("pass" if truth["would_pass"] else "fail")
                 if truth else "")
        print(f"{name:<26} {row['outcome']:<16} {kept:<34} {alone:<18} {row['seconds']:.0f}",
              flush=True)
    Path(args.out).write_text(json.dumps({"pitch": args.pitch, "rows": rows}, indent=1))
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
