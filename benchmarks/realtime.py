"""The real-time factor at a simulator's step (issue 47, item 3): simulated seconds per wall
second, ours beside MuJoCo's on the same model.

    python benchmarks/realtime.py [--cells 6 12 20] [--steps 30]

For each Kuhn block (a 2 cm cube of ``cells``³ cells, six tetrahedra a cell, bottom fixed,
St. Venant–Kirchhoff at ν 0.45 in the textbook element form, which is MuJoCo's flex), pushed
on its top:

- **explicit**, at the stable step (``stability_limit``): our compiled stepper (numba, every
  thread) and MuJoCo's ``Euler``;
- **implicit**, at 16 ms (graphics) and 1 ms (haptics): our backward Euler with one Newton
  iteration (:func:`neurofuzzy.simulation.implicit.simulate_implicit`, the step of MuJoCo's
  ``discrete`` integrator, which it reproduces: ``tests/test_implicit.py``) and MuJoCo's
  ``discrete``.

A factor above 1 is faster than real time. Each timing is the best of three after a warm-up;
the explicit runs take ``--explicit-steps`` steps, the implicit ones ``--steps``. Prints the
table and writes ``benchmarks/realtime.json``.
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
from neurofuzzy.export.mujoco import mjcf  # noqa: E402
from neurofuzzy.mesh import from_tetra, kuhn_block  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.simulation import simulate, stability_limit  # noqa: E402
from neurofuzzy.simulation.implicit import simulate_implicit  # noqa: E402

STEPS = {"16 ms": 0.016, "1 ms": 0.001}


def _block(cells):
    points, tets = kuhn_block((cells,) * 3, 0.02 / cells)
    mesh = from_tetra(points, tets).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=2.0,
                            density=1000.0, volumetric="element")
    rest = mesh.rest_positions
    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    load = np.zeros((model.n_nodes, 3))
    load[top] = (0.01 / len(top), 0.0, -0.05 / len(top))
    return model, load


def _best(function, repeat=3):
    function()                                     # warm: compiled, factorised, cached
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def _mujoco(model, load, h, integrator, steps):
    """Seconds for ``steps`` MuJoCo steps of ``h`` with ``integrator``, or None without
    MuJoCo."""
    try:
        import mujoco
    except ImportError:
        return None
    experiment = Experiment(mesh=model.mesh, dt=h, external_forces=np.stack([load] * 2),
                            positions=np.stack([model.mesh.rest_positions] * 2))
    text = mjcf(model, experiment=experiment, substeps=1)[0]
    handle = mujoco.MjModel.from_xml_string(
        text.replace('integrator="Euler"', f'integrator="{integrator}"'))
    data = mujoco.MjData(handle)
    bodies = [mujoco.mj_name2id(handle, mujoco.mjtObj.mjOBJ_BODY, f"node{i}")
              for i in range(model.n_nodes)]
    moving = [b for b in bodies if b >= 0]
    data.xfrc_applied[moving, :3] = load[[i for i, b in enumerate(bodies) if b >= 0]]

    def run():
        mujoco.mj_step(handle, data, nstep=steps)

    return _best(run)


def measure(cells, steps, explicit_steps):
    model, load = _block(cells)
    h_stable = stability_limit(model).max_step
    row = {"cells": cells, "tetrahedra": model.mesh.n_tetrahedra, "nodes": model.n_nodes,
           "stable_step_s": h_stable}
    seconds = _best(lambda: simulate(model, dt=h_stable * explicit_steps, n_frames=2,
                                     external_forces=load, substeps=explicit_steps))
    row["explicit_ours"] = h_stable * explicit_steps / seconds
    mujoco_seconds = _mujoco(model, load, h_stable, "Euler", explicit_steps)
    row["explicit_mujoco"] = (None if mujoco_seconds is None
                              else h_stable * explicit_steps / mujoco_seconds)
    for name, h in STEPS.items():
        seconds = _best(lambda: simulate_implicit(model, dt=h, n_frames=steps + 1,
                                                  external_forces=load))
        row[f"implicit_ours_{name}"] = h * steps / seconds
        mujoco_seconds = _mujoco(model, load, h, "discrete", steps)
        row[f"implicit_mujoco_{name}"] = (None if mujoco_seconds is None
                                          else h * steps / mujoco_seconds)
    return row


def _factor(value):
    return "-" if value is None else f"{value:.3g}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[6, 12, 20])
    parser.add_argument("--steps", type=int, default=30)
    parser.add_argument("--explicit-steps", type=int, default=2000)
    parser.add_argument("--out", default=str(Path(__file__).with_suffix(".json")))
    args = parser.parse_args(argv)
    rows = []
    for cells in args.cells:
        rows.append(measure(cells, args.steps, args.explicit_steps))
        r = rows[-1]
        print(f"{r['tetrahedra']} tetrahedra done", file=sys.stderr)
    print("real-time factor (simulated s per wall s; > 1 is faster than real time)")
    print(f"{'tets':>7} {'stable step':>11} {'explicit ours':>13} {'MuJoCo':>7} "
          f"{'16 ms ours':>10} {'MuJoCo':>7} {'1 ms ours':>9} {'MuJoCo':>7}")
    for r in rows:
        print(f"{r['tetrahedra']:>7} {1e3 * r['stable_step_s']:>9.3f}ms "
              f"{_factor(r['explicit_ours']):>13} {_factor(r['explicit_mujoco']):>7} "
              f"{_factor(r['implicit_ours_16 ms']):>10} "
              f"{_factor(r['implicit_mujoco_16 ms']):>7} "
              f"{_factor(r['implicit_ours_1 ms']):>9} {_factor(r['implicit_mujoco_1 ms']):>7}")
    Path(args.out).write_text(json.dumps({"rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
