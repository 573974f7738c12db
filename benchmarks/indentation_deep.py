"""Deep spherical indentation (issue 46): a block pressed to 20 % of its height, the data from
an independent solver, and what our fit recovers from it.

    python benchmarks/indentation_deep.py [--cells 8 10 12] [--nu 0.45]   # about 25 min
    python benchmarks/indentation_deep.py --record --reference-cells 6 8   # sfepy, slow
    python benchmarks/indentation_deep.py --record --nu 0.49 --mixed      # ν ≥ 0.49
    python benchmarks/indentation_deep.py --record --nu 0.499 --mixed --increments 8
    python benchmarks/indentation_deep.py --check-mixed 6      # the mixed form at ν 0.45

The experiment: a 4 × 4 × 2 cm block of neo-Hookean tissue (E 6 kPa) bonded to a rigid base,
a rigid sphere of radius 1 cm pressed into the middle of its top by 1, 2, 3 and 4 mm (5 to
20 % of the height; the contact radius grows to about 8 mm). A load cell reads the sphere's
force, with 1 % noise; 20 markers on the top surface, at 3 to 17 mm from the axis, are
tracked with 20 µm noise.

The reference (``--record``, writes ``tests/data/indentation_nu<ν>.npz``): sfepy's quadratic
tetrahedra and its own contact term (:mod:`neurofuzzy.validation.nonlinear.indentation`) on
a quarter of the block with symmetry planes, on two meshes; the force and the markers are
taken from the finer one, and the coarser one's force is stored beside them
(``force_coarse``, in the JSON ``reference_force_coarse``) as a measure of the reference's
own discretisation error. ``--mixed`` records with the mixed displacement–pressure form
(``formulation`` "mixed" in the file), which does not lock where displacement alone does
(ν 0.49 and above). ``--check-mixed CELLS`` solves ν 0.45 with it and prints its force
beside the displacement-only recording's (JSON ``mixed_check``). The experiment itself is
:data:`neurofuzzy.validation.indentation.DEEP`.

The fit (``fit_load_steps`` on a quarter block of our linear tetrahedra in the nodal form,
``--cells`` a side, graded toward the contact):

1. the force curve and the markers: E and ν;
2. the force curve alone, ν given (the reference's): E;
3. the deepest step held out of fit 1: its force predicted, against the force noise;

and our force at the recording's own E and ν, step by step, against the recording's (the
discretisation's share of what the fits find).

Prints the tables and writes ``benchmarks/indentation_deep.json`` (ν 0.45's fits under
``fits``, another ν's under ``fits_nu<ν>``; a run replaces only its own).
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
from neurofuzzy.load_steps import simulate_load_steps  # noqa: E402
from neurofuzzy.validation.indentation import DEEP  # noqa: E402

DATA = ROOT / "tests" / "data"
E, H = DEEP.youngs_modulus, DEEP.height
PENALTY = 1e9             # sfepy's contact stiffness (Pa/m): 4 um deep at the deepest step


def _sfepy(cells, nu, mixed, *, penalty=PENALTY, increments=4, progress=None):
    """sfepy's solve of :data:`DEEP` on a quarter of ``cells`` a side."""
    from neurofuzzy.validation.nonlinear import NeoHookean
    from neurofuzzy.validation.nonlinear.indentation import indent_quarter

    return indent_quarter(DEEP.quarter(cells)[0].mesh, material=NeoHookean(E, nu),
                          radius=DEEP.radius, centres=DEEP.centres(), markers=DEEP.markers(),
                          penalty=penalty, increments=increments, mixed=mixed,
                          progress=progress)


def record(cells, nu, penalty=PENALTY, increments=4, mixed=False):
    """sfepy's indentation on two meshes: the finer one's force and markers, both forces."""
    runs = []
    for n in cells:
        start = time.perf_counter()
        got = _sfepy(n, nu, mixed, penalty=penalty, increments=increments,
                     progress=lambda message: print(f"  {n} cells: {message}", flush=True))
        runs.append({"cells": n, "got": got, "seconds": time.perf_counter() - start})
        print(f"{n} cells: force (quarter) {got.force[:, 2]} N, deepest penetration "
              f"{got.penetration.max() * 1e6:.2f} um, {got.iterations} iterations, "
              f"{runs[-1]['seconds']:.0f} s", flush=True)
    coarse, fine = runs[0]["got"], runs[-1]["got"]
    out = DATA / f"indentation_nu{nu}.npz"
    np.savez_compressed(out, markers=DEEP.markers(), centres=DEEP.centres(),
                        radius=DEEP.radius, height=H, half_width=DEEP.half_width,
                        youngs_modulus=E, poisson_ratio=nu,
                        force=4 * fine.force, force_coarse=4 * coarse.force,
                        displacements=fine.displacements,
                        displacements_coarse=coarse.displacements,
                        cells=np.array([run["cells"] for run in runs]),
                        penetration=fine.penetration, increments=increments,
                        seconds=np.array([run["seconds"] for run in runs]),
                        formulation="mixed" if mixed else "displacement")
    print(f"wrote {out}")


def check_mixed(cells):
    """The mixed form at ν 0.45 on ``cells`` against the displacement-only recording."""
    recorded = np.load(DATA / "indentation_nu0.45.npz")
    start = time.perf_counter()
    got = _sfepy(cells, 0.45, True)
    force, reference = 4 * got.force[:, 2], recorded["force"][:, 2]
    moved = float(np.abs(got.displacements - recorded["displacements"]).max())
    print(f"mixed, {cells} cells (mN): " + " / ".join(f"{-1e3 * f:.2f}" for f in force)
          + f"; displacement alone, {recorded['cells'][-1]} cells: "
          + " / ".join(f"{-1e3 * f:.2f}" for f in reference)
          + f"; markers apart by at most {1e6 * moved:.1f} um", flush=True)
    return {"cells": cells, "force": force.tolist(), "reference_force": reference.tolist(),
            "reference_cells": recorded["cells"].tolist(), "markers_apart": moved,
            "seconds": time.perf_counter() - start}


def forward(recorded, model, planes):
    """Our quarter block's force at the recording's own E and ν, step by step (the
    recording's experiment simulated on ``model``): the discretisation's share of what the
    fits find."""
    data = DEEP.lab_data(recorded, model, planes)
    run = simulate_load_steps(model, data.driven, data.markers, tool=data.tool)
    return -4 * run.reaction[:, 2]


def fits(cells, nu):
    """The three fits of the module docstring on the recording of ``nu``."""
    recorded = np.load(DATA / f"indentation_nu{nu}.npz")
    model, planes = DEEP.quarter(cells, nu, law="neo-hookean")
    noise = DEEP.force_noise * np.abs(recorded["force"][:, 2]) / 4
    rows = {}
    for name, markers_on, start_nu, held in (("force and markers", True, 0.3, []),
                                             ("force alone, nu given", False, nu, []),
                                             ("deepest step held out", True, 0.3, [4])):
        data = DEEP.lab_data(recorded, model, planes, with_markers=markers_on)
        start = time.perf_counter()
        fit = fit_load_steps(model.with_elements(youngs_modulus=3000.0,
                                                 poisson_ratio=start_nu), data,
                             marker_noise=DEEP.marker_noise if markers_on else None,
                             force_noise=float(noise.mean()), validate_on=held,
                             progress=lambda message: print(f"  {message}", file=sys.stderr))
        row = {"seconds": time.perf_counter() - start, "E": fit.youngs_modulus_,
               "E_error": fit.youngs_modulus_ / E - 1, "nu": fit.poisson_ratio_,
               "nu_error": fit.poisson_ratio_ - nu, "fixed": list(fit.fixed_),
               "unidentifiable": list(fit.unidentifiable_),
               "force_rms_over_noise": fit.force_rms_ / float(noise.mean()),
               "marker_rms_over_noise": (None if fit.marker_rms_ is None
                                         else fit.marker_rms_ / fit.marker_scale)}
        if held:
            row["held_out_force_error_over_noise"] = (fit.validation_["force_error"]
                                                      / float(noise[held[0] - 1]))
        rows[name] = row
        print(f"{name}: E {fit.youngs_modulus_:.0f} Pa ({100 * row['E_error']:+.1f} %), "
              f"nu {fit.poisson_ratio_:.4f} ({row['nu_error']:+.4f}), "
              f"{row['seconds']:.0f} s", flush=True)
    ours = forward(recorded, model, planes)
    print("our force at the truth against the reference's: "
          + ", ".join(f"{100 * (f / -r - 1):+.1f} %" for f, r
                      in zip(ours, recorded["force"][:, 2])), flush=True)
    return {"cells": cells, "tetrahedra": model.mesh.n_tetrahedra, "nu": nu,
            "force_at_the_truth": ours.tolist(),
            "reference_cells": recorded["cells"].tolist(),
            "reference_force": recorded["force"][:, 2].tolist(),
            "reference_force_coarse": recorded["force_coarse"][:, 2].tolist(), "fits": rows}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", action="store_true")
    parser.add_argument("--reference-cells", type=int, nargs=2, default=[6, 8])
    parser.add_argument("--nu", type=float, default=0.45)
    parser.add_argument("--mixed", action="store_true",
                        help="record with displacement and pressure (nearly incompressible)")
    parser.add_argument("--increments", type=int, default=4,
                        help="load increments a step in the recording (more where Newton's "
                             "method stalls: 8 at nu 0.499)")
    parser.add_argument("--cells", type=int, nargs="+", default=[8, 10, 12])
    parser.add_argument("--check-mixed", type=int, metavar="CELLS",
                        help="the mixed form at nu 0.45 against the recording")
    args = parser.parse_args(argv)
    out = ROOT / "benchmarks" / "indentation_deep.json"
    kept = json.loads(out.read_text()) if out.exists() else {}
    if args.check_mixed:
        kept["mixed_check"] = check_mixed(args.check_mixed)
        out.write_text(json.dumps(kept, indent=1) + "\n")
        return
    if args.record:
        record(args.reference_cells, args.nu, increments=args.increments, mixed=args.mixed)
        return
    results = []
    for cells in args.cells:
        print(f"{cells} cells a side:")
        results.append(fits(cells, args.nu))
    print(f"\nsphere R = 1 cm pressed 1-4 mm (5-20 % of H) into E {E:.0f} Pa, nu {args.nu}: "
          "our fit of sfepy's data")
    print(f"{'cells':>5} {'tets':>6} | {'force+markers: E':>16} {'nu':>8} {'s':>4} | "
          f"{'force, nu given: E':>18} | {'held out / noise':>16} | force at the truth")
    for result in results:
        both, alone, held = (result["fits"][name] for name in result["fits"])
        print(f"{result['cells']:>5} {result['tetrahedra']:>6} | "
              f"{100 * both['E_error']:>+15.1f}% {both['nu_error']:>+8.4f} "
              f"{both['seconds']:>4.0f} | {100 * alone['E_error']:>+17.1f}% | "
              f"{held['held_out_force_error_over_noise']:>16.2f} | "
              + " ".join(f"{100 * (f / -r - 1):+.1f}%" for f, r
                         in zip(result["force_at_the_truth"], result["reference_force"])))
    key = "fits" if args.nu == 0.45 else f"fits_nu{args.nu}"    # each ν keeps its own
    out.write_text(json.dumps({**kept, "penalty": PENALTY, key: results}, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
