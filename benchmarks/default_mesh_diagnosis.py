"""Issue 48's done-when for the diagnosis, on the default mesh: MuJoCo flex data of the probed
block (2.5 mm cubes split in five, 20 µm marker noise) with a 5× stiffer box of 8 % of the
volume under the probe, with hidden gravity, or with nothing, each diagnosed on what
``neurofuzzy mesh`` builds (4 mm voxels split six to a cube, 4,800 tetrahedra) from the
homogeneous model tied globally, as ``neurofuzzy diagnose`` does.

    python benchmarks/default_mesh_diagnosis.py                 # all three, about 45 minutes
    python benchmarks/default_mesh_diagnosis.py --only gravity
    python benchmarks/default_mesh_diagnosis.py --prior     # with the rule base as a prior
    python benchmarks/default_mesh_diagnosis.py --prior --pitch 0.0075 \
        --json benchmarks/default_mesh_diagnosis_prior_7.5mm.json      # 7.5 mm voxels

With ``--prior`` (``diagnose --rules liver --tissue liver --localise``) an inclusion that is a
candidate is first given the region and sign of the per-element map, or dropped when the map
finds no region of other stiffness (issue 48, item 2); the rows then also say what the map
found.

Prints each answer and writes ``benchmarks/default_mesh_diagnosis.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.learn.prior import FuzzyPrior
from neurofuzzy.rules import resolve
from neurofuzzy.validation.probed_block import (Inclusion, block_experiment, block_model,
                                                mujoco_block)

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from inclusions import BOXES  # noqa: E402

CASES = {"inclusion": {"inclusion": Inclusion.box(*BOXES[("8 %", "under")], contrast=5.0)},
         "gravity": {"gravity": True, "rest_frames": 0},
         "nothing": {}}


def case(name: str, prior: bool = False, pitch: float | None = None) -> dict:
    start = block_model(pitch=pitch)
    experiment = block_experiment(mujoco_block(noise=20e-6, seed=0, **CASES[name]), start.mesh)
    model = start.tied("global")
    began = time.perf_counter()
    result = diagnose(model, experiment, progress=True,
                      prior=FuzzyPrior(resolve("liver"), model, tissue="liver") if prior
                      else None)
    row = {"case": name, "prior": prior, "pitch": pitch, "answer": result.names,
           "verdict": result.verdict,
           "seconds": time.perf_counter() - began,
           "effects": [{"name": e.name, "centroid": e.centroid, "parameters": e.parameters,
                        "elements": len(e.elements)} for e in result.effects],
           "seeded": [c.name for c in result.candidates if c.seeded]}
    inclusion = CASES[name].get("inclusion")
    if inclusion is not None:
        centre = np.array(inclusion.centre)
        row["distance_mm"] = [1e3 * float(np.linalg.norm(np.array(e.centroid) - centre))
                              for e in result.effects if e.centroid is not None]
    if result.localisation is not None:
        row["map"] = result.localisation.words
    print(f"{name}: {result.names} in {row['seconds']:.0f} s: {result.verdict}", flush=True)
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=list(CASES))
    parser.add_argument("--prior", action="store_true",
                        help="with the rule base as a prior (diagnose --localise)")
    parser.add_argument("--pitch", type=float, default=None,
                        help="voxel size (m; default: the default mesh's 4 mm)")
    parser.add_argument("--json", default=None, help="default: benchmarks/"
                        "default_mesh_diagnosis.json (_prior.json with --prior)")
    args = parser.parse_args(argv)
    if args.json is None:
        args.json = str(HERE / ("default_mesh_diagnosis_prior.json" if args.prior
                                else "default_mesh_diagnosis.json"))
    rows = [case(name, args.prior, args.pitch)
            for name in ([args.only] if args.only else CASES)]
    Path(args.json).write_text(json.dumps(rows, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
