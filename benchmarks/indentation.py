"""Indentation by a rigid sphere (issue 46): our frictionless penalty contact in the static
solve against closed forms nobody here derived, and Young's modulus fitted from such a curve.

    python benchmarks/indentation.py [--cells 8 12 16] [--ratios 0.3 0.45 0.499]

Part 1, the force: a sphere of radius H/4 pressed 0.5 % of the block's height H = 2 cm into
the middle of a 4 × 4 × 2 cm block bonded to a rigid base (E 6 kPa, St. Venant–Kirchhoff
elements in the nodal volumetric form, a quarter of the block with symmetry planes, cells
shrinking geometrically toward the contact: ``--cells`` a side). The contact radius is then
0.71 mm, 3.5 % of the block's height. Against Hertz's half-space,
``F = 4/3 E/(1-ν²) √R δ^1.5``, and Dimitriadis et al.'s (Biophys. J. 82, 2002, eq. 12)
correction of it for a layer of thickness h bonded to a rigid base, a series in
``χ = √(Rδ)/h`` (+3 to +4 % here); the lateral sides are 28 contact radii away. Also the
penalty's share: the same solve with ten times the penalty.

Part 2, the fit: Hertz's force at 0.25, 0.5, 0.75 and 1 % of the height (with Dimitriadis's
correction, the closed form of this block), fitted for E with ν given (``fit_load_steps`` on
the force alone) on the 12-cell quarter block.

Prints the tables and writes ``benchmarks/indentation.json``.
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
from neurofuzzy.load_steps import DrivenPath, LoadSteps, ToolPath  # noqa: E402
from neurofuzzy.simulation.contact import PENALTY, Sphere, contact_with  # noqa: E402
from neurofuzzy.simulation.static import Driven, equilibrium  # noqa: E402
from neurofuzzy.validation.indentation import (bonded_layer_force, hertz_force,  # noqa: E402
                                               quarter_block)

E, H, R = 6000.0, 0.02, 0.005
HALF_WIDTH, STRETCH = 0.02, 4.5          # the quarter's width (m); cells grow by e^(4.5/n)


def hertz(nu, depth):
    return hertz_force(E, nu, R, depth)


def dimitriadis(nu, depth):
    return bonded_layer_force(E, nu, R, depth, H)


def quarter(cells, nu):
    model, planes = quarter_block(cells, half_width=HALF_WIDTH, height=H, stretch=STRETCH,
                                  youngs_modulus=E, poisson_ratio=nu)
    return model, [nodes for nodes, _ in planes]


def press(model, planes, depth, stiffness="auto"):
    driven = [Driven(nodes, (0, 0, 0), "xy"[k]) for k, nodes in enumerate(planes)]
    contact = contact_with(model, Sphere(R), (0, 0, H + R - depth), stiffness=stiffness)
    start = time.perf_counter()
    found = equilibrium(model, driven=driven, contact=contact, increments=1,
                        tool_start=(0, 0, H + R))
    return {"force": float(-4 * found.contact_force[2]),
            "penetration": contact.penetration(found.positions),
            "touching": int(len(contact.touching(found.positions))),
            "iterations": found.iterations, "seconds": time.perf_counter() - start,
            "stiffness": contact.stiffness}


def forces(cells, ratios):
    rows, depth = [], 0.005 * H
    for nu in ratios:
        for n in cells:
            model, planes = quarter(n, nu)
            row = press(model, planes, depth)
            first = float(np.unique(model.mesh.rest_positions[:, 0])[1])
            rows.append({"nu": nu, "cells": n, "tetrahedra": model.mesh.n_tetrahedra,
                         "first_cell_over_contact_radius": first / np.sqrt(R * depth),
                         **row, "hertz": hertz(nu, depth),
                         "dimitriadis": dimitriadis(nu, depth)})
    return rows


def penalty_share(cells=12, nu=0.45):
    model, planes = quarter(cells, nu)
    plain = press(model, planes, 0.005 * H)
    stiff = press(model, planes, 0.005 * H, stiffness=10 * plain["stiffness"])
    return {"cells": cells, "nu": nu, "penalty": PENALTY, "force": plain["force"],
            "force_ten_times_the_penalty": stiff["force"],
            "change": stiff["force"] / plain["force"] - 1,
            "penetration": plain["penetration"]}


def fit(cells=12, nu=0.45):
    model, planes = quarter(cells, nu)
    depths = np.array([0.0025, 0.005, 0.0075, 0.01]) * H
    reaction = np.zeros((len(depths), 3))
    reaction[:, 2] = -np.array([dimitriadis(nu, d) for d in depths]) / 4   # a quarter
    tool = ToolPath(Sphere(R), np.array([[0, 0, H + R - d] for d in [0.0, *depths]]))
    paths = tuple(DrivenPath(nodes, np.zeros((len(depths), 3)), "xy"[k], f"plane {k}")
                  for k, nodes in enumerate(planes))
    data = LoadSteps(model.mesh, paths, None, reaction, tool=tool)
    start = time.perf_counter()
    fitted = fit_load_steps(model.with_elements(youngs_modulus=3000.0), data,
                            force_noise=1e-3 * np.abs(reaction).max())
    return {"cells": cells, "nu": nu, "depths": depths.tolist(),
            "youngs_modulus": fitted.youngs_modulus_, "E_error": fitted.youngs_modulus_ / E - 1,
            "force_rms_over_largest": fitted.force_rms_ / np.abs(reaction).max(),
            "iterations": fitted.iterations_, "seconds": time.perf_counter() - start}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[8, 12, 16])
    parser.add_argument("--ratios", type=float, nargs="+", default=[0.3, 0.45, 0.499])
    args = parser.parse_args(argv)
    table = forces(args.cells, args.ratios)
    print("sphere R = H/4 pressed 0.5 % of H = 2 cm (contact radius 0.71 mm): force against "
          "closed forms")
    print(f"{'nu':>6} {'cells':>5} {'tets':>6} {'h0/a':>5} {'force (mN)':>10} {'Hertz':>7} "
          f"{'Dimitr.':>8} {'pen. um':>7} {'touch':>5} {'iter':>4} {'s':>6}")
    for row in table:
        print(f"{row['nu']:>6} {row['cells']:>5} {row['tetrahedra']:>6} "
              f"{row['first_cell_over_contact_radius']:>5.2f} {1e3 * row['force']:>10.4f} "
              f"{100 * (row['force'] / row['hertz'] - 1):>+6.1f}% "
              f"{100 * (row['force'] / row['dimitriadis'] - 1):>+7.1f}% "
              f"{1e6 * row['penetration']:>7.3f} {row['touching']:>5} {row['iterations']:>4} "
              f"{row['seconds']:>6.1f}")
    share = penalty_share()
    print(f"\nten times the penalty (12 cells, nu 0.45): the force changes by "
          f"{100 * share['change']:+.2f} % (penetration {1e6 * share['penetration']:.3f} um)")
    fitted = fit()
    print(f"\nE from the closed form's force at 0.25-1 % depth, nu given (12 cells, nu 0.45): "
          f"{fitted['youngs_modulus']:.1f} Pa ({100 * fitted['E_error']:+.1f} %), force RMS "
          f"{100 * fitted['force_rms_over_largest']:.2f} % of the largest, "
          f"{fitted['seconds']:.0f} s")
    out = ROOT / "benchmarks" / "indentation.json"
    out.write_text(json.dumps({"forces": table, "penalty": share, "fit": fitted}, indent=1)
                   + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
