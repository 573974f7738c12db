"""The diagnosis on continuum data: a plain block, hidden gravity, a hidden stiff inclusion.

The data come from the solver nobody here wrote that ``continuum_pipeline.py`` uses
(scikit-fem's quadratic tetrahedra, 5 mm Kuhn cells, consistent mass, Newmark): the same soft
block (4 x 4 x 3 cm, E = 6 kPa, Poisson's ratio 0.45, viscosity 2 Pa s, density 1050 kg/m3,
bottom held, a 0.05 N probe with a 1 cm contact radius on the top centre) and the same 148
markers with 20 µm noise at 1 kHz, in three versions:

- ``plain``: nothing else acts (the answer should be ``none``);
- ``gravity``: the block is let go at frame 0 under its own weight as the probe touches, and
  nobody tells the model (the answer should be ``gravity``, |g| near 9.81 m/s2);
- ``inclusion``: a sphere of radius 7.5 mm at (15, 20, 20) mm is 5 times stiffer (the answer
  should be ``stiff_inclusion`` with a centroid inside that sphere).

Then, with the command line only:

    neurofuzzy mesh block.stl --pitch P --fix-bottom --rules liver --tissue liver --out m.yaml
    neurofuzzy import markers.csv --topology m.yaml --forces probe.csv --out trial.npz
    neurofuzzy diagnose trial.npz --rules liver --tissue liver --json

Run:  python examples/continuum_diagnosis.py [OUT_DIR] [--case plain|gravity|inclusion]
      [--pitch METRES] [--frames N]   (needs scikit-fem; default: all three cases, 6 mm voxel
      cells, 101 frames after the probe touches)
"""

import json
import sys
import time
from pathlib import Path

import numpy as np

from continuum_pipeline import DT, E, ETA, FORCE, PROBE, RADIUS, REST, RHO
from continuum_pipeline import command, marker_points, write_recording
from neurofuzzy.extras import require_in_script
from neurofuzzy.validation.continuum import ContinuumSolver
from neurofuzzy.datasets import kuhn_block

CENTRE, INCLUSION_RADIUS, CONTRAST = np.array([0.015, 0.02, 0.02]), 0.0075, 5.0
POISSON_RATIO = 0.45
CASES = ("plain", "gravity", "inclusion")


def motion(case: str, n_frames: int, points: np.ndarray) -> tuple[np.ndarray, int]:
    """(marker displacements (n_frames, n_points, 3), the frame the probe touches)."""
    def modulus(x):
        inside = np.linalg.norm(x - CENTRE, axis=1) <= INCLUSION_RADIUS
        return np.where(inside, CONTRAST * E, E)

    solver = ContinuumSolver(*kuhn_block((8, 8, 6), 0.005),
                             youngs_modulus=modulus if case == "inclusion" else E,
                             poisson_ratio=POISSON_RATIO, viscosity=ETA, density=RHO,
                             fixed=lambda x: x[2] < 1e-9)
    touch = 0 if case == "gravity" else REST   # let go under gravity as the probe touches
    load = solver.probe_load(PROBE, RADIUS, (0.0, 0.0, -FORCE))
    if case == "gravity":
        load = load + solver.gravity_load((0.0, 0.0, -9.81))
    loads = np.zeros((n_frames, len(load)))
    loads[touch:] = load
    return solver.at(solver.dynamic(loads, dt=DT, n_frames=n_frames), points), touch


def write_inputs(out: Path, case: str, n_frames: int, seed: int = 1) -> float:
    """block.stl, markers.csv (mm), probe.csv; returns the peak motion (m)."""
    points = marker_points()
    moved, touch = motion(case, n_frames, points)
    write_recording(out, points, moved, touch, seed)
    return float(np.abs(moved).max())


def diagnose(out: Path, pitch: float) -> dict:
    """mesh -> import -> diagnose --json, as a user runs them."""
    def run(*args):
        return command(out, *args)

    run("mesh", "block.stl", "--pitch", str(pitch), "--fix-bottom", "--rules", "liver",
        "--tissue", "liver", "--out", "model.yaml")
    run("import", "markers.csv", "--topology", "model.yaml", "--forces", "probe.csv",
        "--out", "trial.npz")
    return json.loads(run("diagnose", "trial.npz", "--rules", "liver", "--tissue", "liver",
                          "--json", "--quiet"))


def describe(case: str, result: dict) -> str:
    """One line: the answer and, for what it found, where and how much."""
    words = []
    for effect in result["effects"]:
        text = effect["name"]
        if effect["name"] == "gravity":
            g = np.array([effect["parameters"][k] for k in ("gx", "gy", "gz")])
            text += f" |g| = {np.linalg.norm(g):.2f} m/s2"
        if "centroid" in effect:
            centroid = np.array(effect["centroid"])
            distance = np.linalg.norm(centroid - CENTRE)
            inside = "inside" if distance <= INCLUSION_RADIUS else "outside"
            text += (f" at ({', '.join(f'{1e3 * c:.1f}' for c in centroid)}) mm, "
                     f"{1e3 * distance:.1f} mm from the true centre ({inside}), "
                     f"{len(effect.get('elements', effect.get('springs', [])))} elements")
        words.append(text)
    return "; ".join(words) or "none"


def main(argv):
    require_in_script("validation", "examples/continuum_diagnosis.py (scikit-fem's solver "
                      "makes its data)")
    values = {argv[i + 1] for i, a in enumerate(argv[:-1]) if a.startswith("--")}
    out = Path(next((a for a in argv if not a.startswith("--") and a not in values),
                    "continuum-diagnosis-output"))
    cases = [argv[argv.index("--case") + 1]] if "--case" in argv else list(CASES)
    pitch = float(argv[argv.index("--pitch") + 1]) if "--pitch" in argv else 0.006
    if any(case not in CASES for case in cases):
        raise SystemExit(f"--case takes one of {', '.join(CASES)}")
    n_frames = REST + (int(argv[argv.index("--frames") + 1]) if "--frames" in argv else 101)
    print(f"{'case':<10}{'peak (um)':>10}{'RMS before':>11}{'after':>8}{'noise':>8}"
          f"{'time':>7}  answer")
    for case in cases:
        folder = out / case
        folder.mkdir(parents=True, exist_ok=True)
        peak = write_inputs(folder, case, n_frames)
        started = time.perf_counter()
        result = diagnose(folder, pitch)
        seconds = time.perf_counter() - started
        (folder / "diagnosis.json").write_text(json.dumps(result, indent=1))
        print(f"{case:<10}{1e6 * peak:>10.0f}{1e6 * result['rms_before']:>11.1f}"
              f"{1e6 * result['rms_after']:>8.1f}{1e6 * result['noise_rms']:>8.1f}"
              f"{seconds:>6.0f}s  {describe(case, result)}", flush=True)
    print(f"(RMS marker errors in um; truth: E = {E:.0f} Pa, eta = {ETA} Pa s, "
          f"{1e3 * PROBE[2]:.0f} mm tall block, voxel cells of {1e3 * pitch:g} mm)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
