"""The rule base as a prior (issue 14): per-element and per-spring fits of a tissue with a
hidden 5× stiffer inclusion, with and without the prior, from the same noisy data of our own
simulator. Prints a table and writes JSON (``benchmarks/prior.json``).

    python benchmarks/prior.py                  # both problems, about 10 minutes on 2 cores
    python benchmarks/prior.py --quick          # the element problem only, smaller
    python benchmarks/prior.py --only springs   # one of them (2 minutes)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn import auto_substeps
from neurofuzzy.learn.prior import FuzzyPrior
from neurofuzzy.learn.regions import regions_found
from neurofuzzy.mesh import from_tetra
from neurofuzzy.rules import resolve
from neurofuzzy.tissues import initialize

RULES = resolve("liver")


def _cases(truth, *, noise, frames, dt, force, directions, substeps):
    mesh = truth.mesh
    top = np.flatnonzero(mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9)
    data = []
    for seed, direction in enumerate(directions):
        load = np.zeros((mesh.n_nodes, 3))
        load[top] = np.array(direction) * force / len(top)
        data.append(simulate_experiment(truth, dt=dt, n_frames=frames, external_forces=load,
                                        substeps=substeps, noise=noise, seed=seed))
    return data


def _compare(kind, truth_values, start, data, inside, values_of, **options) -> dict:
    """The same fit without and with the prior: time, median error per item, regions."""
    out = {}
    for name, prior in (("without prior", None), ("with prior", FuzzyPrior(RULES, start))):
        began = time.perf_counter()
        learner = GradientLearner(prior=prior, **options).fit(start, data)
        seconds = time.perf_counter() - began
        fitted = values_of(learner.model_)
        entry = {"seconds": seconds, "simulations": learner.n_cycles_,
                 "median_error": float(np.median(np.abs(fitted / truth_values - 1))),
                 "inclusion_median": float(np.median(fitted[inside])),
                 "rest_median": float(np.median(fitted[~inside])),
                 "inclusion_true": float(np.median(truth_values[inside])),
                 "rest_true": float(np.median(truth_values[~inside])),
                 "rms_error": learner.rms_error_}
        if prior is not None:
            found = regions_found(learner.model_, prior)
            truly = set(np.flatnonzero(inside).tolist())
            entry["prior"] = {k: learner.prior_[k] for k in ("alpha", "noise", "fits", "how")}
            entry["regions"] = [{"size": r["size"], "label": r["label"],
                                 "quantity": r["quantity"], "value": r["value"],
                                 "overlap": len(set(r[kind]) & truly) / len(truly),
                                 "inside": len(set(r[kind]) & truly) / r["size"]}
                                for r in found["regions"]]
        out[name] = entry
    return out


def bench_elements(quick: bool) -> dict:
    """A Kuhn block of 1 cm cells, 5 kPa ("firm" liver), a 5× stiffer block of cells under
    the top; every node recorded, 10 µm noise, three load cases; E, ν, η per element."""
    shape = (3, 3, 2) if quick else (4, 4, 3)
    mesh = from_tetra(*kuhn_block(shape, 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    centres = mesh.rest_positions[mesh.tetrahedra].mean(axis=1)
    top = mesh.rest_positions[:, 2].max()
    low = [0.01, 0.01, top - 0.02 if not quick else top - 0.01]
    high = [0.02 if quick else 0.03, 0.02 if quick else 0.03, top - 0.01 if not quick else top]
    inside = np.all((centres > low) & (centres < high), axis=1)
    base = initialize(RULES, mesh, "liver", elements=True)
    modulus = np.where(inside, 25000.0, 5000.0)
    truth = base.with_elements(youngs_modulus=modulus,
                               viscosity=np.full(mesh.n_tetrahedra, 2.0))
    substeps = auto_substeps(truth, 2e-3)
    data = _cases(truth, noise=1e-5, frames=21, dt=2e-3, force=0.03, substeps=substeps,
                  directions=((0, 0, -1.0), (1.0, 0, 0), (0, 1.0, 0)))
    start = base.tied("none")
    result = _compare("elements", modulus, start, data, inside,
                      lambda m: m.elements.youngs_modulus, substeps=substeps, windows=(),
                      max_iterations=40)
    result.update(tetrahedra=mesh.n_tetrahedra, inclusion=int(inside.sum()),
                  parameters=3 * mesh.n_tetrahedra)
    return result


def bench_springs(quick: bool) -> dict:
    """A voxel block of about 10,000 springs, 1.3× stiffer than the description ("firm"
    liver by the rule base's mapping: the fit must find the level from the data) with a 5×
    stiffer ball of springs again; every node recorded, 10 µm noise, two load cases;
    stiffness and viscosity per spring, L-BFGS with the adjoint, 60 iterations per fit."""
    from neurofuzzy.mesh import lattice

    nodes = (9, 9, 7) if quick else (14, 14, 10)
    mesh = lattice(nodes, spacing=0.004).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    base = initialize(RULES, mesh, "liver", elements=False)
    middle = mesh.rest_positions[mesh.springs].mean(axis=1)
    centre = mesh.rest_positions.max(axis=0) * [0.5, 0.5, 0.7]
    inside = np.linalg.norm(middle - centre, axis=1) < 0.25 * mesh.rest_positions[:, 0].max()
    stiffness = np.where(inside, 5.0, 1.0) * 1.3 * base.springs.stiffness
    truth = base.with_springs(stiffness=stiffness)
    substeps = auto_substeps(truth, 1e-3)
    data = _cases(truth, noise=1e-5, frames=31, dt=1e-3, force=0.05, substeps=substeps,
                  directions=((0, 0, -1.0), (1.0, 0, 0)))
    start = base.tied("none")
    result = _compare("springs", stiffness, start, data, inside,
                      lambda m: m.springs.stiffness, substeps=substeps, windows=(),
                      method="lbfgs", max_iterations=60)
    result.update(springs=mesh.n_springs, inclusion=int(inside.sum()),
                  parameters=2 * mesh.n_springs)
    return result


def _rows(title, result):
    rows = []
    for name in ("without prior", "with prior"):
        entry = result[name]
        text = (f"{entry['seconds']:.0f} s, median error {entry['median_error']:.1%}, "
                f"inclusion {entry['inclusion_median']:.4g} ({entry['inclusion_true']:.4g}) / "
                f"rest {entry['rest_median']:.4g} ({entry['rest_true']:.4g})")
        if "regions" in entry:
            text += f", α {entry['prior']['alpha']:.3g}, regions " + "; ".join(
                f"{r['size']} {r['label']} ({r['quantity']}), overlap {r['overlap']:.0%}, "
                f"inside {r['inside']:.0%}" for r in entry["regions"])
        rows.append((f"{title}, {name}", text))
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--only", choices=("elements", "springs"))
    parser.add_argument("--out", default=str(Path(__file__).with_name("prior.json")))
    args = parser.parse_args(argv)
    results = {"quick": args.quick}
    benches = {"elements": bench_elements, "springs": bench_springs}
    names = [args.only] if args.only else ["elements"] if args.quick else list(benches)
    for name in names:
        bench = benches[name]
        results[name] = result = bench(args.quick)
        size = result.get("tetrahedra", result.get("springs"))
        for row in _rows(f"{size} {name}, inclusion {result['inclusion']}", result):
            print(f"{row[0]:<44} {row[1]}", flush=True)
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
