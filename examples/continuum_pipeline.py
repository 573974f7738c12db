"""The documented pipeline on continuum data: mesh -> import -> fit, as a user runs it.

The data come from a solver nobody here wrote: scikit-fem's quadratic tetrahedra
(:class:`neurofuzzy.validation.continuum.ContinuumSolver`, 5 mm Kuhn cells, ten nodes per
tetrahedron, consistent mass, Newmark integration at a tenth of the frame step) for a soft
block of 4 x 4 x 3 cm: E = 6 kPa, Poisson's ratio 0.3 or 0.45, viscosity 2 Pa s
(Kelvin-Voigt, a Rayleigh stiffness-proportional damping), density 1050 kg/m3, bottom held,
pushed by a 0.05 N probe with a 1 cm contact radius on the top centre after 30 ms at rest.
What a lab would have: a closed surface of the block (STL), optical markers on the top and
two sides (a 5 mm grid; none under the probe, which hides them) at 1 kHz with 20 µm noise per
coordinate (the frames before the probe touches give each marker's rest position), and the
probe's force at the point and time it touched, with its contact radius.

Then, with the command line only:

    neurofuzzy mesh block.stl [--tetra] --fix-bottom --rules liver --tissue liver --out m.yaml
    neurofuzzy import markers.csv --topology m.yaml --forces probe.csv --out trial.npz
    neurofuzzy fit trial.npz --rules liver --tissue liver --out fitted.yaml --json

on the default voxel mesh (4 mm cells split into tetrahedra), a coarse 1 cm one, and, when
TetGen is installed, TetGen's default mesh; then the paper's spring network
(``--elements springs``) on the same voxel and TetGen meshes, whose E, nu and eta are those its
spring constants stand for (nu locked at 1/4). The table gives what each recovers and the
words. The last fitted model stays in OUT_DIR/fitted.yaml (with the record of its fit), ready
for ``neurofuzzy export fitted.yaml trial.npz --to mujoco|sofa|febio|vtu``.

Run:  python examples/continuum_pipeline.py [OUT_DIR] [--quick] [--data-only]   (needs
scikit-fem: pip install 'neurofuzzy[validation]';
--quick: nu = 0.45 only, the default voxel mesh only, a shorter recording;
--data-only: write block.stl, markers.csv and probe.csv and stop, for a user to run the three
commands)
"""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from neurofuzzy.extras import require_in_script
from neurofuzzy.validation.continuum import ContinuumSolver
from neurofuzzy.datasets import kuhn_block

E, ETA, RHO = 6000.0, 2.0, 1050.0      # Pa, Pa s, kg/m3
FORCE, RADIUS, DT = 0.05, 0.01, 1e-3   # N, m, s
REST = 30                              # frames recorded before the probe touches
NOISE = 20e-6                          # m, per coordinate
SIZE = (0.04, 0.04, 0.03)
PROBE = (0.02, 0.02, 0.03)


def marker_points() -> np.ndarray:
    """A 5 mm grid on the top (off the probe's patch) and on the sides x = 0 and y = 0."""
    grid = np.arange(0.0025, 0.04, 0.005)
    heights = np.arange(0.0025, 0.03, 0.005)
    top = [(x, y, SIZE[2]) for x in grid for y in grid
           if np.hypot(x - PROBE[0], y - PROBE[1]) > RADIUS]
    sides = ([(x, 0.0, z) for x in grid for z in heights]
             + [(0.0, y, z) for y in grid for z in heights])
    return np.array(top + sides)


def continuum_motion(poisson_ratio: float, n_frames: int, points: np.ndarray) -> np.ndarray:
    """(n_frames, n_points, 3) marker displacements by the reference solver."""
    solver = ContinuumSolver(*kuhn_block((8, 8, 6), 0.005), youngs_modulus=E,
                             poisson_ratio=poisson_ratio, viscosity=ETA, density=RHO,
                             fixed=lambda x: x[2] < 1e-9)
    load = solver.probe_load(PROBE, RADIUS, (0.0, 0.0, -FORCE))
    loads = np.zeros((n_frames, len(load)))
    loads[REST:] = load                                  # the probe touches at frame REST
    return solver.at(solver.dynamic(loads, dt=DT, n_frames=n_frames), points)


def write_inputs(out: Path, poisson_ratio: float, n_frames: int, seed: int = 0) -> dict:
    """block.stl, markers.csv (mm) and probe.csv; returns the motion's size."""
    points = marker_points()
    motion = continuum_motion(poisson_ratio, n_frames, points)
    write_recording(out, points, motion, REST, seed)
    return {"markers": len(points), "peak": float(np.abs(motion).max()),
            "rms": float(np.sqrt(np.mean(np.sum(motion**2, axis=-1))))}


def write_recording(out: Path, points, motion, touch: int, seed: int) -> None:
    """What the lab has: markers.csv (mm, ``motion`` plus noise), probe.csv (the probe's
    point, force and contact radius from frame ``touch``) and the block's surface."""
    import trimesh

    seen = points[None] + motion + np.random.default_rng(seed).normal(0.0, NOISE, motion.shape)
    lines = ["# units: mm", "time,marker,x,y,z"]
    for t in range(len(motion)):
        lines += [f"{t * DT:.4f},M{m},{1e3 * x:.5f},{1e3 * y:.5f},{1e3 * z:.5f}"
                  for m, (x, y, z) in enumerate(seen[t])]
    (out / "markers.csv").write_text("\n".join(lines) + "\n")
    (out / "probe.csv").write_text(
        "# length units: mm\ntime,x,y,z,fx,fy,fz,radius\n"
        f"{touch * DT:g},{1e3 * PROBE[0]:g},{1e3 * PROBE[1]:g},{1e3 * PROBE[2]:g},0,0,"
        f"{-FORCE},{1e3 * RADIUS:g}\n")
    box = trimesh.creation.box(extents=SIZE)
    box.apply_translation(np.array(SIZE) / 2)
    box.export(out / "block.stl")


def command(out: Path, *args) -> str:
    """``neurofuzzy ARGS`` in ``out``, as a user types it; its standard output."""
    done = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *args],
                          capture_output=True, text=True, cwd=out)
    if done.returncode != 0:
        raise SystemExit(f"neurofuzzy {' '.join(args)} failed:\n{done.stderr}")
    return done.stdout


def pipeline(out: Path, mesh_options: list[str]) -> tuple[dict, str]:
    """The three commands; returns fit --json and the model's one-line size. ``fit
    --rules`` builds its own start on the experiment's mesh (elements where it has
    tetrahedra), so a spring network is asked for again there."""
    def run(*args):
        return command(out, *args)

    summary = run("mesh", "block.stl", *mesh_options, "--fix-bottom", "--rules", "liver",
                  "--tissue", "liver", "--out", "model.yaml").splitlines()[0]
    run("import", "markers.csv", "--topology", "model.yaml", "--forces", "probe.csv",
        "--out", "trial.npz")
    springs = ["--elements", "springs"] if "springs" in mesh_options else []
    # the table gives the values recovered, not their intervals: no mesh check (which would
    # double each element fit's time on the default mesh)
    fitted = json.loads(run("fit", "trial.npz", "--rules", "liver", "--tissue", "liver",
                            *springs, "--no-mesh-check", "--out", "fitted.yaml", "--json",
                            "--quiet"))
    return fitted, summary


def main(argv):
    require_in_script("validation", "examples/continuum_pipeline.py (scikit-fem's solver "
                      "makes its data)")
    started = time.perf_counter()
    quick, data_only = "--quick" in argv, "--data-only" in argv
    args = [a for a in argv if not a.startswith("--")]
    out = Path(args[0] if args else "continuum-pipeline-output")
    out.mkdir(parents=True, exist_ok=True)
    meshes = [("voxel", [])]
    if not quick:
        meshes.append(("vox 1cm", ["--pitch", "0.01"]))
        try:
            import tetgen  # noqa: F401
            meshes.append(("TetGen", ["--tetra"]))
        except ImportError:
            print("(TetGen not installed: voxel meshes only)", file=sys.stderr)
        meshes += [(f"{name} springs", options + ["--elements", "springs"])
                   for name, options in list(meshes) if name != "vox 1cm"]
    ratios = (0.45,) if quick else (0.3, 0.45)
    n_frames = REST + (101 if quick else 201)
    header = (f"{'true nu':>7} {'mesh':<15}{'nodes':>6}{'E (Pa)':>8}{'E err':>7}{'nu':>7}"
              f"{'eta':>6}{'eta err':>8}{'RMS/noise':>10}{'time':>6}  words (E, nu, eta)")
    rows = []
    for nu in ratios:
        motion = write_inputs(out, nu, n_frames)
        print(f"nu = {nu}: {motion['markers']} markers, peak motion "
              f"{1e6 * motion['peak']:.0f} um, RMS {1e6 * motion['rms']:.0f} um",
              file=sys.stderr, flush=True)
        if data_only:
            print(f"wrote {out / 'block.stl'}, {out / 'markers.csv'} and {out / 'probe.csv'} "
                  f"(nu = {nu}; {time.perf_counter() - started:.0f} s)")
            return 0
        for name, options in meshes:
            fitted, summary = pipeline(out, options)
            material = next(iter(fitted["materials"].values()))
            e, ratio, eta = (material[k] for k in ("youngs_modulus", "poisson_ratio",
                                                   "viscosity"))
            labels = material["labels"]
            nodes = summary.split(":")[1].split("nodes")[0].strip()
            rows.append(f"{nu:>7.2f} {name:<15}{nodes:>6}{e:>8.0f}{100 * (e / E - 1):>6.1f}%"
                        f"{ratio:>7.3f}{eta:>6.2f}{100 * (eta / ETA - 1):>7.1f}%"
                        f"{fitted['rms_error'] / (NOISE * np.sqrt(3)):>10.2f}"
                        f"{fitted['seconds']:>5.0f}s  {labels['youngs_modulus']}, "
                        f"{labels.get('poisson_ratio', 'nu locked')}, {labels['viscosity']}")
            print(rows[-1], file=sys.stderr, flush=True)
    print(header)
    print("\n".join(rows))
    print(f"truth: E = {E:.0f} Pa, eta = {ETA} Pa s; RMS/noise = RMS marker error over the "
          f"noise per marker ({1e6 * NOISE * np.sqrt(3):.1f} um); "
          f"{time.perf_counter() - started:.0f} s in all")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
