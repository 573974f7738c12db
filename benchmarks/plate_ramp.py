"""A dynamic plate ramp (issue 45): E, ν and η from markers in time and a load cell at 1 kHz,
fitted through implicit steps to data from a solver nobody here wrote.

    python benchmarks/plate_ramp.py [--cells 4] [--ratios 0.45 0.49 0.499] [--no-check]
    python benchmarks/plate_ramp.py --at-truth 4 8 12 [--ratios ...] [--grading 0.8]

The recording (``tests/data/plate_ramp_nu*.npz``, made by ``python -m
neurofuzzy.validation.plate_ramp NU OUT``): FElupe's quadratic tetrahedra in the three-field
form, with Kelvin–Voigt viscosity and inertia integrated by Newmark's average acceleration
(:mod:`neurofuzzy.validation.plate_ramp`). A 2 cm neo-Hookean gel cube (E 6 kPa, η 30 Pa·s,
1000 kg/m³) on a fixed anvil, its top bonded to a plate driven down 18 % in 50 ms along a
quintic smoothstep and held, 121 frames 1 ms apart; 343 beads from the finer of two meshes,
the plate's force extrapolated from both.

The fit, as a lab would have it: every bead with 20 µm noise, embedded where frame 0 saw it,
the load cell's force with 1 % of its peak as noise, the stage's path at the frames; a Kuhn
block of ``--cells`` cells (nodal volumetric form, neo-Hookean) from E 8 kPa, ν 0.4, η 15 Pa·s,
BDF2 steps of 1 ms (:func:`~neurofuzzy.learn.implicit_fit.fit_implicit`, both noises
estimated), then its mesh check (:func:`~neurofuzzy.learn.implicit_mesh_check.
implicit_mesh_check`: refitted on the mesh refined once, each constant extrapolated). Prints
the table and writes ``benchmarks/plate_ramp.json`` (a run replaces the rows of the ν it
measures and keeps the others).

``--at-truth CELLS...`` fits nothing: it runs our model at the recording's own E, ν and η on
each block (BDF2, 1 ms) and prints its plate force over the recording's at chosen frames, and
the force extrapolated (first order in the cell size) from the two finest blocks: whether our
discretisation converges to the reference's solution, and how fast during the ramp (where the
viscous force is a large share) and held (elastic only). JSON key ``at_truth``.

``--grading A`` makes the fit's (or ``--at-truth``'s) blocks finer toward their faces
(:func:`~neurofuzzy.mesh.kuhn_block`'s ``grading``), where the bonded plates' edges put most
of a linear tetrahedron's error; its rows go under keys ending ``_graded<A>``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neurofuzzy.experiment import Experiment  # noqa: E402
from neurofuzzy.learn.implicit_fit import fit_implicit  # noqa: E402
from neurofuzzy.learn.implicit_mesh_check import implicit_mesh_check  # noqa: E402
from neurofuzzy.load_steps import DrivenPath  # noqa: E402
from neurofuzzy.mesh import from_tetra, kuhn_block  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.observation import EmbeddedMarkers, embed_points  # noqa: E402
from neurofuzzy.simulation.implicit import simulate_implicit  # noqa: E402

DATA = ROOT / "tests" / "data"
NAMES = ("youngs_modulus", "poisson_ratio", "viscosity")
START = {"youngs_modulus": 8000.0, "poisson_ratio": 0.4, "viscosity": 15.0}
MARKER_NOISE, FORCE_NOISE = 20e-6, 0.01


def recording(nu: float) -> dict:
    return dict(np.load(DATA / f"plate_ramp_nu{nu}.npz"))


def lab_data(recorded: dict, cells: int, seed: int = 0, start=None, grading=0.0):
    """``(start model, experiment)``: the recording as a lab has it (the model at ``start``'s
    values, :data:`START` by default) on a block of ``cells`` a side, ``grading`` toward its
    faces."""
    size = float(recorded["size"])
    points, tetrahedra = kuhn_block((cells,) * 3, size / cells, grading=grading)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, density=float(recorded["density"]), law="neo-hookean",
                            volumetric="nodal", **(START if start is None else start))
    rng = np.random.default_rng(seed)
    beads = recorded["beads"][None] + np.asarray(recorded["displacements"], float)
    beads = beads + rng.normal(scale=MARKER_NOISE, size=beads.shape)
    nodes, weights, _ = embed_points(mesh, beads[0])
    force = np.asarray(recorded["force"], float)
    reaction = force + FORCE_NOISE * np.abs(force).max() * rng.normal(size=force.shape)
    frames = len(force)
    top = np.flatnonzero(np.isclose(mesh.rest_positions[:, 2], size))
    path = np.zeros((frames, 3))
    path[:, 2] = recorded["plate"]
    experiment = Experiment(mesh=mesh, dt=float(recorded["dt"]),
                            positions=np.full((frames, mesh.n_nodes, 3), np.nan),
                            observed=np.zeros(mesh.n_nodes, bool),
                            markers=EmbeddedMarkers(nodes, weights, beads),
                            driven=(DrivenPath(top, path),), reaction=reaction,
                            source=f"FElupe's plate ramp, nu {recorded['poisson_ratio']}")
    return model, experiment


def fits(ratios, cells, check=True, grading=0.0):
    rows = []
    for nu in ratios:
        recorded = recording(nu)
        truth = {"youngs_modulus": float(recorded["youngs_modulus"]), "poisson_ratio": nu,
                 "viscosity": float(recorded["viscosity"])}
        model, experiment = lab_data(recorded, cells, grading=grading)
        start = time.perf_counter()
        fit = fit_implicit(model, experiment, scheme="bdf2")
        fitted = time.perf_counter() - start
        row = {"nu": nu, "cells": cells, "grading": grading,
               "tetrahedra": model.mesh.n_tetrahedra,
               "fit_seconds": fitted, "evaluations": fit.evaluations, "reason": fit.reason,
               "marker_noise": fit.marker_noise, "force_noise": fit.force_noise,
               "marker_rms": fit.rms_error, "force_rms": fit.force_rms_error,
               "force_peak": float(np.abs(recorded["force"][:, 2]).max())}
        if check:
            fit = implicit_mesh_check(fit, experiment, scheme="bdf2")
            row["check_seconds"] = time.perf_counter() - start - fitted
        for name in NAMES:
            scale = 1.0 if name == "poisson_ratio" else truth[name]
            stages = ({"mesh": fit.values[name][0]} if fit.mesh_check is None else
                      {stage: fit.mesh_check[name][stage][0]
                       for stage in ("mesh", "refined", "extrapolated")})
            row[name] = {stage: float((value - truth[name]) / scale)
                         for stage, value in stages.items()}
        rows.append(row)
        print(f"  nu {nu}: done in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    return rows


FRAMES = (3, 6, 12, 21, 30, 39, 45, 51, 60, 120)


def at_truth(nu: float, cells, grading=0.0) -> dict:
    """Our plate force at the recording's own constants on each block of ``cells``, over the
    recording's, at :data:`FRAMES`; and extrapolated from the two finest blocks."""
    recorded = recording(nu)
    truth = {"youngs_modulus": float(recorded["youngs_modulus"]), "poisson_ratio": nu,
             "viscosity": float(recorded["viscosity"])}
    force = np.asarray(recorded["force"], float)[:, 2]
    ours = {}
    for n in cells:
        model, experiment = lab_data(recorded, n, start=truth, grading=grading)
        run = simulate_implicit(model, dt=experiment.dt, n_frames=len(force), scheme="bdf2",
                                driven=experiment.driven, iterations=50, tolerance=1e-11)
        ours[n] = run.reactions[:, 0, 2]     # the plate on the body, the recording's sign
        print(f"  nu {nu}: {n} cells run", file=sys.stderr)
    coarse, fine = sorted(cells)[-2:]
    ratios = {str(n): [float(ours[n][k] / force[k]) for k in FRAMES] for n in sorted(cells)}
    ratios["extrapolated"] = [float((ours[fine][k] + (ours[fine][k] - ours[coarse][k])
                                     * coarse / (fine - coarse)) / force[k]) for k in FRAMES]
    return {"nu": nu, "grading": grading, "frames": list(FRAMES),
            "force_mN": [float(1e3 * force[k]) for k in FRAMES], "ratio": ratios}


def _truth_table(rows):
    for row in rows:
        print(f"ν {row['nu']}: our plate force at the truth over the recording's")
        print("| frame (ms) | recorded (mN) | " + " | ".join(
            f"{name} cells" if name != "extrapolated" else name for name in row["ratio"])
            + " |")
        print("|---" * (2 + len(row["ratio"])) + "|")
        for i, frame in enumerate(row["frames"]):
            print(f"| {frame} | {row['force_mN'][i]:.1f} | " + " | ".join(
                f"{values[i]:.3f}" for values in row["ratio"].values()) + " |")


def _table(rows):
    print("| ν | cells (tetrahedra) | E: mesh / refined / extrapolated | ν: mesh / refined / "
          "extrapolated | η: mesh / refined / extrapolated | noise found: markers, force | "
          "seconds: fit + check |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        def stages(name, percent):
            return " / ".join(f"{100 * v:+.1f} %" if percent else f"{v:+.4f}"
                              for v in row[name].values())
        print(f"| {row['nu']} | {row['cells']} ({row['tetrahedra']}) | "
              f"{stages('youngs_modulus', True)} | {stages('poisson_ratio', False)} | "
              f"{stages('viscosity', True)} | {1e6 * row['marker_noise']:.1f} µm, "
              f"{100 * row['force_noise'] / row['force_peak']:.2f} % | "
              f"{row['fit_seconds']:.0f} + {row.get('check_seconds', 0.0):.0f} |")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=4)
    parser.add_argument("--ratios", type=float, nargs="+",
                        default=[nu for nu in (0.45, 0.49, 0.499)
                                 if (DATA / f"plate_ramp_nu{nu}.npz").exists()])
    parser.add_argument("--no-check", action="store_true", help="no mesh check")
    parser.add_argument("--grading", type=float, default=0.0,
                        help="blocks finer toward their faces (kuhn_block's grading)")
    parser.add_argument("--at-truth", type=int, nargs="+", metavar="CELLS",
                        help="no fit: our force at the truth on these blocks (module doc)")
    args = parser.parse_args(argv)
    out = ROOT / "benchmarks" / "plate_ramp.json"
    results = json.loads(out.read_text()) if out.exists() else {}
    graded = f"_graded{args.grading:g}" if args.grading else ""
    if args.at_truth:
        if len(args.at_truth) < 2:
            parser.error("--at-truth needs two blocks or more to extrapolate")
        rows = [at_truth(nu, args.at_truth, args.grading) for nu in args.ratios]
        _truth_table(rows)
        results["at_truth" + graded] = rows
        out.write_text(json.dumps(results, indent=1))
        return
    rows = fits(args.ratios, args.cells, check=not args.no_check, grading=args.grading)
    _table(rows)
    key = f"cells_{args.cells}" + ("" if not args.no_check else "_unchecked") + graded
    measured = {row["nu"] for row in rows}       # a run replaces its own ν's rows only
    results[key] = sorted([row for row in results.get(key, []) if row["nu"] not in measured]
                          + rows, key=lambda row: row["nu"])
    out.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
