"""Both cores for the element passes: the step rate and the stiffness matrix's time of Kuhn
blocks at 1 and 2 threads, side by side in one run (:mod:`neurofuzzy.simulation.threads`).

    python benchmarks/threads.py [--cells 6 8 12 20] [--steps 2000] [--sweeps]

For each block (six tetrahedra a cell, bottom fixed, the nodal volumetric form at ν 0.49), the
explicit step rate of St. Venant–Kirchhoff (the specialised passes) and of neo-Hookean with one
Prony term (the general passes with internal variables), and the time of the force with its
stiffness and damping matrices (``neurofuzzy.simulation.tangents``, the static solve's and the
implicit step's Jacobian), each at 1 and 2 threads (:func:`numba.set_num_threads`), best of
five, alternately. Blocks under :data:`~neurofuzzy.simulation.threads.PARALLEL_FROM`
elements stay on one thread by design; their ratio shows what that costs (nothing). Prints
the table and writes ``benchmarks/threads.json``.

With ``--sweeps``, the learners' derivative sweeps of the same blocks beside them: one run of
the forward sensitivities with three columns (E, ν and η of one region, as a per-region fit's
Jacobian) and one adjoint gradient of every element's E, ν and η (as L-BFGS takes it), both
over a push of 20 frames of 1 ms at the data's substeps (JSON key ``sweeps``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neurofuzzy.mesh import from_tetra, kuhn_block  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.simulation import stability_limit, tangents  # noqa: E402
from neurofuzzy.simulation.steppers import NumbaStepper  # noqa: E402
from neurofuzzy.simulation.threads import PARALLEL_FROM, element_threads  # noqa: E402


def _block(cells, law, relaxing):
    points, tets = kuhn_block((cells,) * 3, 0.02 / cells)
    mesh = from_tetra(points, tets).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.49, viscosity=2.0,
                            density=1000.0, law=law)
    if relaxing:
        k = mesh.n_tetrahedra
        model = model.with_elements(relaxation_moduli=[[0.3]] * k,
                                    relaxation_times=[[0.01]] * k)
    return model


def _best(function, repeat=3):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def measure(cells, steps, repeat=5):
    rows = []
    for law, relaxing in (("st-venant-kirchhoff", False), ("neo-hookean", True)):
        model = _block(cells, law, relaxing)
        h = 0.5 * stability_limit(model).max_step
        rng = np.random.default_rng(0)
        p0 = model.mesh.rest_positions.copy()
        moving = p0[:, 2] > 1e-9
        p0[moving] += 1e-4 * rng.normal(size=(moving.sum(), 3))
        row = {"cells": cells, "tetrahedra": model.mesh.n_tetrahedra,
               "law": law + (" + 1 Prony term" if relaxing else "")}
        stepper = NumbaStepper(model, h)

        def run():
            p, v = p0.copy(), np.zeros_like(p0)
            stepper.advance(p, v, None, steps)

        step_s, tangent_s = {1: np.inf, 2: np.inf}, {1: np.inf, 2: np.inf}
        for _ in range(repeat):          # alternately, every timing at its best
            for count in (1, 2):
                numba.set_num_threads(count)
                stepper.advance(p0.copy(), np.zeros_like(p0), None, 2)   # compiled, warm
                step_s[count] = min(step_s[count], _best(run, 1))
                tangents(model, p0, long_time=True)
                tangent_s[count] = min(tangent_s[count],
                                       _best(lambda: tangents(model, p0, long_time=True), 1))
                row[f"threads_{count}"] = element_threads(model.mesh.n_tetrahedra)
        for count in (1, 2):
            row[f"steps_per_s_{count}"] = steps / step_s[count]
            row[f"tangents_s_{count}"] = tangent_s[count]
        row["step_speedup"] = row["steps_per_s_2"] / row["steps_per_s_1"]
        row["tangents_speedup"] = row["tangents_s_1"] / row["tangents_s_2"]
        rows.append(row)
    return rows


def sweeps(cells, repeat=5):
    """The seconds of a Jacobian of three columns and of an adjoint gradient at 1 and 2
    threads, best of ``repeat``, alternately."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.learn import Parameterization, auto_substeps
    from neurofuzzy.learn._sensitivity import Sensitivity

    rows = []
    for law, relaxing in (("st-venant-kirchhoff", False), ("neo-hookean", True)):
        model = _block(cells, law, relaxing)
        rest = model.mesh.rest_positions
        push = np.zeros((model.n_nodes, 3))
        push[rest[:, 2] > rest[:, 2].max() - 1e-9] = (1e-3, 0.0, -3e-3)
        substeps = auto_substeps(model, 1e-3)
        data = simulate_experiment(model, dt=1e-3, n_frames=21, external_forces=push,
                                   substeps=substeps)
        region = Parameterization(model.tied("global"))
        per_element = Parameterization(model.tied("none"))
        forward = Sensitivity(region, model.length_unit)
        backward = Sensitivity(per_element, model.length_unit)
        row = {"cells": cells, "tetrahedra": model.mesh.n_tetrahedra,
               "law": law + (" + 1 Prony term" if relaxing else ""), "substeps": substeps}
        seconds = {(kind, count): np.inf for kind in ("jacobian", "gradient")
                   for count in (1, 2)}
        for _ in range(repeat):
            for count in (1, 2):
                numba.set_num_threads(count)
                jacobian = lambda: forward.run(region.initial(), data, tangents=True,  # noqa
                                               substeps=substeps, threads=count)
                gradient = lambda: backward.gradient(per_element.initial(), data,  # noqa
                                                     substeps=substeps)
                for kind, function in (("jacobian", jacobian), ("gradient", gradient)):
                    function()
                    seconds[kind, count] = min(seconds[kind, count], _best(function, 1))
        for (kind, count), value in seconds.items():
            row[f"{kind}_s_{count}"] = value
        row["jacobian_speedup"] = row["jacobian_s_1"] / row["jacobian_s_2"]
        row["gradient_speedup"] = row["gradient_s_1"] / row["gradient_s_2"]
        rows.append(row)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[6, 8, 12, 20])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--sweeps", action="store_true",
                        help="the learners' derivative sweeps too")
    parser.add_argument("--out", default=str(Path(__file__).with_suffix(".json")))
    args = parser.parse_args(argv)
    if numba.config.NUMBA_NUM_THREADS < 2:
        sys.exit("benchmarks/threads.py needs two numba threads (NUMBA_NUM_THREADS unset or "
                 ">= 2)")
    before = numba.get_num_threads()
    rows = [row for cells in args.cells for row in measure(cells, args.steps)]
    derivative_rows = ([row for cells in args.cells for row in sweeps(cells)] if args.sweeps
                       else [])
    numba.set_num_threads(before)
    print(f"parallel from {PARALLEL_FROM} elements; numba threading layer "
          f"{numba.threading_layer()}")
    print(f"{'tets':>7} {'law':<32} {'steps/s 1':>10} {'2 threads':>10} {'ratio':>6} "
          f"{'K 1 (s)':>8} {'2 (s)':>7} {'ratio':>6}")
    for r in rows:
        print(f"{r['tetrahedra']:>7} {r['law']:<32} {r['steps_per_s_1']:>10.0f} "
              f"{r['steps_per_s_2']:>10.0f} {r['step_speedup']:>6.2f} "
              f"{r['tangents_s_1']:>8.3f} {r['tangents_s_2']:>7.3f} "
              f"{r['tangents_speedup']:>6.2f}")
    if derivative_rows:
        print(f"\n{'tets':>7} {'law':<32} {'J 1 (s)':>8} {'2 (s)':>7} {'ratio':>6} "
              f"{'grad 1 (s)':>10} {'2 (s)':>7} {'ratio':>6}")
    for r in derivative_rows:
        print(f"{r['tetrahedra']:>7} {r['law']:<32} {r['jacobian_s_1']:>8.3f} "
              f"{r['jacobian_s_2']:>7.3f} {r['jacobian_speedup']:>6.2f} "
              f"{r['gradient_s_1']:>10.3f} {r['gradient_s_2']:>7.3f} "
              f"{r['gradient_speedup']:>6.2f}")
    results = {"parallel_from": PARALLEL_FROM, "rows": rows}
    if derivative_rows:
        results["sweeps"] = derivative_rows
    Path(args.out).write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    main()
