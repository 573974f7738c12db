"""What the toolkit says when its model cannot fit the data (issue 25): continuum data of the
probed block from solvers nobody here wrote (scikit-fem's quadratic tetrahedra; MuJoCo's flex
of linear tetrahedra split five to a cube), fitted on meshes a user would build (voxels of
1 cm and 7.5 mm split six to a cube, TetGen), as the tables of docs/lack-of-fit.md report them.

``validation``: per dataset, the homogeneous fit with the mesh check (RMS against the noise,
errors of E, ν and η, whether the 95 % intervals hold them), the diagnosis's answer and the
per-element fit with the prior (regions kept). ``calibration``: over many datasets (two
solvers, ν 0.3 and 0.45, 5 and 20 µm noise, two noise seeds, three meshes), how often the
nominal 95 % intervals hold the truth: with the mesh check's one Gauss–Newton step (the
default of ``--mesh-check``), with the whole refit's, and with the standard errors alone.
Prints tables and writes JSON (``benchmarks/lack_of_fit.json``).

    python benchmarks/lack_of_fit.py                    # both, about an hour on 2 cores
    python benchmarks/lack_of_fit.py --only calibration
    python benchmarks/lack_of_fit.py --only validation --quick
    python benchmarks/lack_of_fit.py --only calibration --meshes "vox 1 cm" "vox 7.5 mm"
    python benchmarks/lack_of_fit.py --only calibration --meshes "vox 4 mm (default)" --no-refit
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
import time
from pathlib import Path

import numpy as np

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.learn import GradientLearner
from neurofuzzy.learn.prior import FuzzyPrior
from neurofuzzy.rules import resolve
from neurofuzzy.validation.probed_block import (BLOCK, Inclusion, block_experiment, block_model,
                                       mujoco_block, probed_block)

TRUE = {"youngs_modulus": BLOCK["youngs_modulus"], "viscosity": BLOCK["viscosity"]}
MESHES = {"vox 1 cm": {"pitch": 0.01}, "vox 7.5 mm": {"pitch": 0.0075},
          "TetGen 8 mm": {"tetgen": True, "max_edge": 0.008},
          # what neurofuzzy mesh builds (the extent / 10: 4 mm voxels, 4,800 tetrahedra)
          "vox 4 mm (default)": {}}


@functools.lru_cache(maxsize=None)
def recording(solver, nu, hidden, noise, seed, cell):
    """One dataset (cached: the calibration reuses its motion across meshes)."""
    options = {"poisson_ratio": nu, "noise": noise, "seed": seed,
               "inclusion": Inclusion() if hidden == "inclusion" else None,
               "gravity": hidden == "gravity"}
    if hidden == "gravity":
        options["rest_frames"] = 0
    if solver == "scikit-fem":
        return probed_block(**options, cell=cell)
    return mujoco_block(**options, cell=cell)


@functools.lru_cache(maxsize=None)
def start_model(mesh):
    return block_model(**MESHES[mesh])


def homogeneous(data, mesh, nu, refit: bool = True) -> dict:
    """The homogeneous fit with the mesh check (one Gauss-Newton step on the refined mesh,
    the default), and beside it the whole refit's check (unless not ``refit``) and the
    standard errors alone: lack of fit, errors, intervals and whether each holds the truth."""
    from neurofuzzy.learn import Parameterization
    from neurofuzzy.learn.mesh_check import mesh_check
    from neurofuzzy.learn.uncertainty import MESH_ERROR_FACTOR, intervals

    start = start_model(mesh)
    experiment = block_experiment(data, start.mesh)
    began = time.perf_counter()
    fitted = GradientLearner(substeps="auto").fit(start.tied("global"), experiment)
    seconds = time.perf_counter() - began - fitted.mesh_check_.seconds
    parameters = Parameterization(fitted.model_)
    theta = parameters.initial()
    kinds = {"covered": fitted.intervals_,
             "covered_without_mesh_check": intervals(parameters, theta, fitted.std_errors_)}
    whole = mesh_check(fitted, [experiment], parameters, theta) if refit else None
    if whole is not None:
        spread = np.sqrt(fitted.std_errors_**2 + (MESH_ERROR_FACTOR * whole.change) ** 2)
        kinds["covered_refit"] = intervals(parameters, theta, spread)
    values = {"youngs_modulus": float(fitted.model_.elements.youngs_modulus[0]),
              "poisson_ratio": float(fitted.model_.elements.poisson_ratio[0]),
              "viscosity": float(fitted.model_.elements.viscosity[0])}
    truth = {**TRUE, "poisson_ratio": nu}
    step = fitted.mesh_check_
    out = {"ratio": fitted.lack_of_fit_.ratio, "explained": fitted.lack_of_fit_.explained,
           "values": values, "seconds": seconds, "step_seconds": step.seconds,
           "refit_seconds": whole.seconds if whole else None,
           "step_untrusted": "too far" in step.how, "step_change": step.change.tolist(),
           "refit_change": whole.change.tolist() if whole else None,
           "intervals": {}, **{kind: {} for kind in kinds}}
    for quantity, value in values.items():
        name = f"{quantity}[all elements]"
        out["intervals"][quantity] = fitted.intervals_[name]
        for kind, bounds in kinds.items():
            low, high = bounds[name]
            out[kind][quantity] = bool(low <= truth[quantity] <= high)
        out.setdefault("errors", {})[quantity] = (value - truth[quantity]
                                                  if quantity == "poisson_ratio"
                                                  else value / truth[quantity] - 1.0)
    return out


def diagnosis(data, mesh) -> dict:
    start = start_model(mesh).tied("global")
    experiment = block_experiment(data, start.mesh)
    began = time.perf_counter()
    result = diagnose(start, experiment)
    out = {"answer": result.names, "ratio_after": result.lack_of_fit.ratio,
           "seconds": time.perf_counter() - began,
           "mesh_explains": result.mesh["explains"] if result.mesh else None}
    for finding in result.effects:
        if finding.centroid is not None:
            out["distance_mm"] = 1e3 * float(np.linalg.norm(np.array(finding.centroid)
                                                            - Inclusion().centre))
        if finding.name == "gravity":
            out["g"] = float(np.linalg.norm([finding.parameters[k] for k in ("gx", "gy", "gz")]))
    return out


def prior_fit(data, mesh) -> dict:
    start = start_model(mesh).tied("none")
    experiment = block_experiment(data, start.mesh)
    began = time.perf_counter()
    prior = FuzzyPrior(resolve("liver"), start, tissue="liver")
    fitted = GradientLearner(substeps="auto", prior=prior).fit(start, experiment)
    kept = fitted.regions_["regions"]
    return {"regions": [{"label": r["label"], "quantity": r["quantity"], "size": r["size"],
                         "distance_mm": 1e3 * float(np.linalg.norm(np.array(r["centroid"])
                                                                   - Inclusion().centre))}
                        for r in kept],
            "rejected": len([r for r in fitted.regions_["rejected"]
                             if r["evidence"].get("tested")]),
            "seconds": time.perf_counter() - began}


VALIDATION = [  # (solver, cell of the data's mesh, nu, hidden, noise, fitted mesh)
    ("scikit-fem", 0.005, 0.45, "nothing", 5e-6, "vox 7.5 mm"),
    ("scikit-fem", 0.005, 0.30, "nothing", 5e-6, "vox 7.5 mm"),
    ("scikit-fem", 0.005, 0.45, "nothing", 20e-6, "TetGen 8 mm"),
    ("scikit-fem", 0.005, 0.45, "inclusion", 5e-6, "vox 7.5 mm"),
    ("scikit-fem", 0.005, 0.45, "gravity", 20e-6, "vox 1 cm"),
    ("MuJoCo", 0.0025, 0.45, "nothing", 5e-6, "vox 7.5 mm"),
    ("MuJoCo", 0.01, 0.45, "nothing", 5e-6, "vox 1 cm"),
    ("MuJoCo", 0.005, 0.45, "inclusion", 5e-6, "vox 7.5 mm"),
    ("MuJoCo", 0.005, 0.45, "gravity", 20e-6, "vox 1 cm"),
]


def validation(quick: bool) -> list:
    rows = []
    cases = VALIDATION[:2] + VALIDATION[3:4] if quick else VALIDATION
    for solver, cell, nu, hidden, noise, mesh in cases:
        data = recording(solver, nu, hidden, noise, 0, cell)
        row = {"solver": solver, "cell": cell, "nu": nu, "hidden": hidden, "noise": noise,
               "mesh": mesh}
        if hidden != "gravity":
            row["fit"] = homogeneous(data, mesh, nu)
        row["diagnosis"] = diagnosis(data, mesh)
        if hidden != "gravity":
            row["prior"] = prior_fit(data, mesh)
        rows.append(row)
        print(_validation_line(row), flush=True)
    return rows


def _validation_line(row) -> str:
    fit, found = row.get("fit"), row.get("prior")
    text = (f"{row['solver']:<10} {1e3 * row['cell']:>4.1f} mm  nu {row['nu']:.2f} "
            f"{row['hidden']:<9} {1e6 * row['noise']:>3.0f} um  {row['mesh']:<12}")
    if fit:
        e = fit["errors"]
        covered = "".join("y" if fit["covered"][q] else "n"
                          for q in ("youngs_modulus", "poisson_ratio", "viscosity"))
        text += (f" RMS/noise {fit['ratio']:.2f}  E {100 * e['youngs_modulus']:+.1f}%  "
                 f"nu {e['poisson_ratio']:+.3f}  eta {100 * e['viscosity']:+.1f}%  "
                 f"in 95% (E nu eta): {covered}")
    d = row["diagnosis"]
    text += f"  diagnosis: {', '.join(d['answer'])}"
    if "distance_mm" in d:
        text += f" ({d['distance_mm']:.1f} mm off)"
    if "g" in d:
        text += f" (|g| {d['g']:.2f})"
    if d.get("mesh_explains") is not None:
        text += f" (mesh explains {100 * d['mesh_explains']:.0f}%)"
    if found:
        regions = "; ".join(f"{r['label']} {r['quantity']} {r['size']} el, "
                            f"{r['distance_mm']:.1f} mm off" for r in found["regions"])
        text += f"  regions: {regions or 'none'} ({found['rejected']} rejected)"
    return text


def calibration(quick: bool, meshes=None, refit: bool = True) -> dict:
    rows = []
    solvers = [("scikit-fem", 0.005)] + ([] if quick else [("MuJoCo", 0.005)])
    meshes = meshes or ["vox 1 cm", "vox 7.5 mm"] + ([] if quick else ["TetGen 8 mm"])
    for solver, cell in solvers:
        for nu in (0.3, 0.45):
            for noise in (5e-6, 20e-6):
                for seed in ((0,) if quick else (0, 1)):
                    data = recording(solver, nu, "nothing", noise, seed, cell)
                    for mesh in meshes:
                        fit = homogeneous(data, mesh, nu, refit)
                        rows.append({"solver": solver, "nu": nu, "noise": noise,
                                     "seed": seed, "mesh": mesh, **fit})
                        print(f"{solver:<10} nu {nu:.2f} {1e6 * noise:>3.0f} um seed {seed} "
                              f"{mesh:<12} RMS/noise {fit['ratio']:.2f} "
                              f"covered {fit['covered']} with the refit "
                              f"{fit.get('covered_refit', '-')} without the mesh check "
                              f"{fit['covered_without_mesh_check']} (fit {fit['seconds']:.0f} s,"
                              f" step {fit['step_seconds']:.0f} s, refit "
                              f"{fit['refit_seconds'] or 0:.0f} s)",
                              flush=True)
    summary = {}
    for key in ("covered", "covered_refit", "covered_without_mesh_check"):
        if key not in rows[0]:
            continue
        hits = [row[key][q] for row in rows for q in row[key]]
        summary[key] = {"covered": int(np.sum(hits)), "of": len(hits),
                        "share": float(np.mean(hits))}
        for quantity in ("youngs_modulus", "poisson_ratio", "viscosity"):
            values = [row[key][quantity] for row in rows]
            summary[key][quantity] = float(np.mean(values))
    print(f"nominal 95 % intervals hold the truth in {100 * summary['covered']['share']:.0f} % "
          f"of {summary['covered']['of']} cases (the whole refit's check: "
          f"{100 * summary.get('covered_refit', {}).get('share', np.nan):.0f} %; the standard "
          f"errors alone: "
          f"{100 * summary['covered_without_mesh_check']['share']:.0f} %)", flush=True)
    return {"rows": rows, "summary": summary}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", choices=("validation", "calibration"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--meshes", nargs="+", choices=list(MESHES),
                        help="calibration: only these fitted meshes (default: all three)")
    parser.add_argument("--no-refit", action="store_true",
                        help="calibration: without the whole refit's check beside the step "
                             "(sixteen fits each on the default mesh)")
    parser.add_argument("--json", default=str(Path(__file__).with_name("lack_of_fit.json")))
    args = parser.parse_args(argv)
    started = time.perf_counter()
    path = Path(args.json)
    results = json.loads(path.read_text()) if path.exists() else {}
    if args.only in (None, "validation"):
        results["validation"] = validation(args.quick)
    if args.only in (None, "calibration"):
        # a subset of the meshes is kept beside the whole calibration, not over it
        key = "calibration" if not args.meshes else "calibration " + ", ".join(args.meshes)
        results[key] = calibration(args.quick, args.meshes, refit=not args.no_refit)
    results["seconds"] = time.perf_counter() - started
    path.write_text(json.dumps(results, indent=1, default=str))
    print(f"wrote {path} ({results['seconds']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
