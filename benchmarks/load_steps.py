"""Compression between plates: how our elements lock (or not) as ν → 0.5 against scikit-fem's
quadratic tetrahedra, and how long a fit from load steps takes as the mesh grows.

    python benchmarks/load_steps.py [--cells 4 6 8] [--reference-cells 8] [--fit-cells 4 6 8]

Part 1, locking: a 2 cm cube on a fixed anvil, the top plate bonded and moved down 1 %; the
plate's force over ``E A ε`` (what frictionless plates would read) for ν 0.45, 0.49, 0.499,
by our linear tetrahedra in the nodal volumetric form (the default) and in the element form
(one volume constraint per tetrahedron), and by scikit-fem's quadratic tetrahedra (linear
elasticity; the reference, on ``--reference-cells`` cells a side). Part 2, speed: the seconds
of ``fit_load_steps`` (three load steps, 125 markers, with and without a load cell) on
Kuhn blocks of 4³ to 8³ cells. Prints both tables and writes ``benchmarks/load_steps.json``.
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

from neurofuzzy.learn.load_step_fit import fit_load_steps  # noqa: E402
from neurofuzzy.load_steps import DrivenPath, LoadSteps, simulate_load_steps  # noqa: E402
from neurofuzzy.mesh import from_tetra, kuhn_block  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.observation import EmbeddedMarkers, embed_points  # noqa: E402
from neurofuzzy.simulation.static import Driven, equilibrium  # noqa: E402

SIZE, E, STRAIN = 0.02, 6000.0, 0.01
RATIOS = (0.45, 0.49, 0.499)


def _model(cells, nu, volumetric="nodal", law="st-venant-kirchhoff"):
    points, tetrahedra = kuhn_block((cells,) * 3, SIZE / cells)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=nu, viscosity=1.0,
                           density=1000.0, volumetric=volumetric, law=law)


def _top(model):
    return np.flatnonzero(np.isclose(model.mesh.rest_positions[:, 2], SIZE))


def locking(cells, reference_cells):
    from neurofuzzy.validation.continuum import ContinuumSolver

    rows = []
    uniaxial = E * SIZE**2 * STRAIN
    for nu in RATIOS:
        points, tetrahedra = kuhn_block((reference_cells,) * 3, SIZE / reference_cells)
        start = time.perf_counter()
        solver = ContinuumSolver(points, tetrahedra, youngs_modulus=E, poisson_ratio=nu,
                                 viscosity=1.0, density=1000.0, fixed=lambda x: x[2] < 1e-9)
        _, force = solver.displaced(lambda x: x[2] > SIZE - 1e-9, (0, 0, -STRAIN * SIZE))
        reference = -force[2] / uniaxial
        rows.append({"nu": nu, "element": f"P2 (scikit-fem) {reference_cells}^3",
                     "ratio": reference, "error": 0.0,
                     "seconds": time.perf_counter() - start})
        for volumetric in ("nodal", "element"):
            for n in cells:
                model = _model(n, nu, volumetric)
                top = _top(model)
                start = time.perf_counter()
                result = equilibrium(model, driven=Driven(top, (0, 0, -STRAIN * SIZE)))
                ratio = -result.reaction_on(top)[2] / uniaxial
                rows.append({"nu": nu, "element": f"P1 {volumetric} {n}^3", "ratio": ratio,
                             "error": ratio / reference - 1,
                             "seconds": time.perf_counter() - start})
    return rows


def speed(cells):
    rows = []
    strains = (0.05, 0.125, 0.18)
    for n in cells:
        truth = _model(n, 0.45, law="neo-hookean")
        beads = np.random.default_rng(1).uniform(0.1 * SIZE, 0.9 * SIZE, size=(125, 3))
        nodes, weights, _ = embed_points(truth.mesh, beads)
        plate = DrivenPath(_top(truth), np.array([[0, 0, -s * SIZE] for s in strains]))
        data = simulate_load_steps(truth, [plate], EmbeddedMarkers(
            nodes, weights, np.zeros((4, 125, 3))), marker_noise=20e-6, force_noise=1e-3)
        start_model = truth.with_elements(youngs_modulus=3000.0, poisson_ratio=0.3)
        for force in (False, True):
            steps = data if force else LoadSteps(data.mesh, data.driven, data.markers, None)
            start = time.perf_counter()
            fit = fit_load_steps(start_model, steps)
            rows.append({"tetrahedra": truth.mesh.n_tetrahedra, "load_cell": force,
                         "seconds": time.perf_counter() - start,
                         "iterations": fit.iterations_,
                         "nu_error": fit.poisson_ratio_ - 0.45,
                         "E_error": None if "youngs_modulus" in fit.unidentifiable_
                         else fit.youngs_modulus_ / E - 1})
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[4, 6, 8])
    parser.add_argument("--reference-cells", type=int, default=8)
    parser.add_argument("--fit-cells", type=int, nargs="+", default=[4, 6, 8])
    args = parser.parse_args(argv)
    table = locking(args.cells, args.reference_cells)
    print("bonded compression 1 %: plate force / (E A eps)")
    print(f"{'nu':>6}  {'element':<24} {'ratio':>7} {'vs P2':>8} {'s':>6}")
    for row in table:
        print(f"{row['nu']:>6}  {row['element']:<24} {row['ratio']:>7.4f} "
              f"{100 * row['error']:>7.1f}% {row['seconds']:>6.2f}")
    timing = speed(args.fit_cells)
    print("\nfit from 3 load steps (neo-Hookean gel, nu 0.45, 125 markers, 20 um noise)")
    print(f"{'tetrahedra':>10} {'load cell':>9} {'s':>7} {'iter':>5} {'nu err':>8} {'E err':>7}")
    for row in timing:
        e = "unid." if row["E_error"] is None else f"{100 * row['E_error']:.1f}%"
        print(f"{row['tetrahedra']:>10} {str(row['load_cell']):>9} {row['seconds']:>7.1f} "
              f"{row['iterations']:>5} {row['nu_error']:>8.4f} {e:>7}")
    out = ROOT / "benchmarks" / "load_steps.json"
    out.write_text(json.dumps({"locking": table, "fit": timing}, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
