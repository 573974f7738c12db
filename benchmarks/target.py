"""A fit for MuJoCo's step against the naive export, on data nobody here simulated (issue 47).

    python benchmarks/target.py [--pitch 0.0075] [--dt 0.016] [--target mujoco|ours]

scikit-fem's probed block (:mod:`neurofuzzy.validation.probed_block`: quadratic tetrahedra,
1 kHz, 20 µm noise) pushed three ways: a load ramped over 100 ms, held and released (fitted);
another ramp to 70 % and release (held out); and the step load of the validation recordings
(it rings). Each is fitted as ``neurofuzzy fit`` does on voxels of ``--pitch``, then
:func:`neurofuzzy.learn.target.fit_for_target` fits E, ν, η for MuJoCo's element and step.
The table gives the markers' RMS error at the step's frames of our model (our step), of the
naive export (the accurate values on MuJoCo's element and step) and of the target fit, on the
fitted recording and on the held-out one; with MuJoCo installed, the naive export run by
MuJoCo itself too. ``--target ours``: the same for our own implicit step on the model's own
element (``benchmarks/target_ours.json``). About 4 minutes; writes ``benchmarks/target.json``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import neurofuzzy as nf  # noqa: E402
from neurofuzzy.experiment import simulate_like  # noqa: E402
from neurofuzzy.learn.target import TARGETS, fit_for_target, rms_at_step  # noqa: E402
from neurofuzzy.simulation.resampling import resampled  # noqa: E402
from neurofuzzy.validation.probed_block import (block_experiment, block_model,  # noqa: E402
                                                probed_block)

FRAMES = 480                # after the 30 frames at rest: 0.51 s in all


def ramp(start, full, release, end, peak=1.0):
    t = np.arange(30 + FRAMES) * 1e-3
    return peak * np.clip((t - start) / (full - start), 0, 1) * (
        1 - np.clip((t - release) / (end - release), 0, 1))


def _mujoco_rms(model, experiment, dt):
    """The naive export run by MuJoCo at ``dt`` (None without MuJoCo)."""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return None
    from neurofuzzy.export.mujoco import mjcf, simulate_mujoco

    text = mjcf(model, experiment=experiment,
                fit={"target": {"simulator": "mujoco", "dt": dt, "integrator": "discrete"}})[0]
    moved = simulate_mujoco(text, experiment)
    steps = resampled(experiment, dt)
    return rms_at_step(None, [steps], [moved])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pitch", type=float, default=0.0075)
    parser.add_argument("--dt", type=float, default=0.016)
    parser.add_argument("--target", choices=sorted(TARGETS), default="mujoco")
    parser.add_argument("--out", default=None,
                        help="default benchmarks/target.json (MuJoCo) or target_ours.json")
    args = parser.parse_args(argv)
    out = Path(args.out or Path(__file__).with_name(
        "target.json" if args.target == "mujoco" else f"target_{args.target}.json"))
    chosen = {key: TARGETS[args.target][key] for key in ("volumetric", "law")
              if TARGETS[args.target][key] is not None}
    start = block_model(pitch=args.pitch)
    cases = {"ramp": (ramp(0.03, 0.13, 0.33, 0.43), ramp(0.03, 0.08, 0.25, 0.40, 0.7)),
             "step": (None, None)}
    rows = []
    for name, (fitted_profile, held_profile) in cases.items():
        print(f"{name}: recording", file=sys.stderr)
        data = block_experiment(probed_block(frames=FRAMES, profile=fitted_profile, seed=0),
                                start.mesh)
        held = (block_experiment(probed_block(frames=FRAMES, profile=held_profile, seed=1),
                                 start.mesh) if held_profile is not None else None)
        accurate = nf.fit(data, start=start, mesh_check=False).model
        aimed = fit_for_target(accurate, data, target=args.target, dt=args.dt)
        row = {"load": name, "own": aimed.own_rms_error, "naive": aimed.naive_rms_error,
               "target": aimed.rms_error, "at_bound": list(aimed.at_bound),
               "naive_in_mujoco": (_mujoco_rms(accurate, data, args.dt)
                                   if args.target == "mujoco" else None),
               "values": {key: float(np.median(getattr(aimed.model.elements, key)))
                          for key in ("youngs_modulus", "poisson_ratio", "viscosity")}}
        if held is not None:
            steps = resampled(held, args.dt)
            k = int(round(args.dt / held.dt))
            row["held_out"] = {
                "own": rms_at_step(None, [steps], [simulate_like(accurate, held, 8)[::k]]),
                "naive": rms_at_step(accurate.with_elements(**chosen), [steps]),
                "target": rms_at_step(aimed.model, [steps])}
        rows.append(row)
    print(f"{TARGETS[args.target]['name']} at {1e3 * args.dt:g} ms, voxels of "
          f"{1e3 * args.pitch:g} mm; markers' RMS (µm), ratio to our model's")
    print(f"{'load':<6} {'ours':>6} {'naive':>14} {'target':>14} {'naive, MuJoCo':>14} "
          f"{'held out: ours / naive / target':>34}")
    for r in rows:
        def cell(value, own):
            return f"{1e6 * value:.1f} ({value / own:.2f}x)"
        mj = "-" if r["naive_in_mujoco"] is None else f"{1e6 * r['naive_in_mujoco']:.1f}"
        held = r.get("held_out")
        held_text = "-" if held is None else (
            f"{1e6 * held['own']:.1f} / {1e6 * held['naive']:.1f} / "
            f"{1e6 * held['target']:.1f} ({held['target'] / held['own']:.2f}x)")
        print(f"{r['load']:<6} {1e6 * r['own']:>6.1f} {cell(r['naive'], r['own']):>14} "
              f"{cell(r['target'], r['own']):>14} {mj:>14} {held_text:>34}")
    out.write_text(json.dumps({"target": args.target, "dt": args.dt, "pitch": args.pitch,
                               "rows": rows}, indent=1) + "\n")


if __name__ == "__main__":
    main()
