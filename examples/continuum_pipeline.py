"""The documented pipeline on continuum data: mesh -> import -> fit, as a user runs it.

The data come from a solver nobody here wrote (scikit-fem's linear elasticity on a fine
tetrahedral mesh, 5 mm Kuhn cells, lumped masses, scipy's Radau integrator; see
``springs_or_elements.py``): a 4 x 4 x 3 cm block, E = 6 kPa, Poisson's ratio 0.3 or 0.45,
viscosity 2 Pa s (Rayleigh), bottom held, 0.05 N pushed on the top centre. What a lab would
have: a closed surface of the block (STL), optical markers on its sides and top (every other
surface node of the solver's mesh, so they are *not* on our model's nodes) at 1 kHz with 20 µm
noise per coordinate, and the probe's force at the point where it touched.

Then, with the command line only:

    neurofuzzy mesh block.stl --pitch 0.01 --fix-bottom --rules liver --tissue liver --out m.yaml
    neurofuzzy import markers.csv --topology m.yaml --forces probe.csv --out trial.npz
    neurofuzzy fit trial.npz --start m.yaml --rules liver --json

on voxel-derived meshes (1 cm and 5 mm cells, six tetrahedra each) and, when TetGen is
installed, a TetGen mesh (``--tetra --max-edge 0.006``). The table gives what each recovers and
the words.

Run:  python examples/continuum_pipeline.py [OUT_DIR] [--quick]   (needs scikit-fem;
--quick: nu = 0.45 only, the 1 cm voxel mesh only, a shorter recording)
"""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import neurofuzzy as nf  # noqa: E402
from neurofuzzy.datasets import kuhn_block  # noqa: E402
from springs_or_elements import DT, ETA, FORCE, E, continuum_data  # noqa: E402

NOISE = 20e-6            # m, per coordinate
SIZE = (0.04, 0.04, 0.03)


def write_inputs(out: Path, nu: float, n_frames: int, seed: int = 0) -> int:
    """block.stl, markers.csv (mm) and probe.csv from the solver's motion; returns the
    number of markers."""
    import trimesh

    points, tetrahedra = kuhn_block((8, 8, 6), 0.005)
    solver = nf.from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    data = continuum_data(solver, nu, n_frames)
    surface = nf.surface_nodes(solver) & solver.free
    markers = np.flatnonzero(surface)[::2]
    rng = np.random.default_rng(seed)
    seen = data.positions[:, markers] + rng.normal(0.0, NOISE, (n_frames, len(markers), 3))
    lines = ["# units: mm", "time,marker,x,y,z"]
    for t in range(n_frames):
        lines += [f"{t * DT:.4f},M{m},{1e3 * x:.5f},{1e3 * y:.5f},{1e3 * z:.5f}"
                  for m, (x, y, z) in enumerate(seen[t])]
    (out / "markers.csv").write_text("\n".join(lines) + "\n")
    (out / "probe.csv").write_text("# length units: mm\ntime,x,y,z,fx,fy,fz\n"
                                   f"0,20,20,30,0,0,{-FORCE}\n")
    box = trimesh.creation.box(extents=SIZE)
    box.apply_translation(np.array(SIZE) / 2)
    box.export(out / "block.stl")
    return len(markers)


def pipeline(out: Path, mesh_options: list[str]) -> dict:
    """The three commands; returns fit --json."""
    def run(*args):
        done = subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *args],
                              capture_output=True, text=True, cwd=out)
        if done.returncode != 0:
            raise SystemExit(f"neurofuzzy {' '.join(args)} failed:\n{done.stderr}")
        return done.stdout

    run("mesh", "block.stl", *mesh_options, "--fix-bottom", "--rules", "liver", "--tissue",
        "liver", "--out", "model.yaml")
    run("import", "markers.csv", "--topology", "model.yaml", "--forces", "probe.csv",
        "--out", "trial.npz")
    return json.loads(run("fit", "trial.npz", "--start", "model.yaml", "--rules", "liver",
                          "--json", "--quiet"))


def main(argv):
    started = time.perf_counter()
    quick = "--quick" in argv
    args = [a for a in argv if not a.startswith("--")]
    out = Path(args[0] if args else "continuum-pipeline")
    out.mkdir(parents=True, exist_ok=True)
    meshes = [("vox 1cm", ["--pitch", "0.01"])]
    if not quick:
        meshes.append(("vox 5mm", ["--pitch", "0.005"]))
        try:
            import tetgen  # noqa: F401
            meshes.append(("TetGen", ["--tetra", "--max-edge", "0.006"]))
        except ImportError:
            print("(TetGen not installed: voxel meshes only)", file=sys.stderr)
    ratios = (0.45,) if quick else (0.3, 0.45)
    n_frames = 101 if quick else 201
    header = (f"{'true nu':>7} {'mesh':<7}{'E (Pa)':>8}{'E err':>8}{'nu':>7}{'eta':>7}"
              f"{'eta err':>9}{'RMS/noise':>10}  words (E, nu)")
    rows = []
    for nu in ratios:
        n_markers = write_inputs(out, nu, n_frames)
        for name, options in meshes:
            fitted = pipeline(out, options)
            material = next(iter(fitted["materials"].values()))
            e, ratio, eta = (material[k] for k in ("youngs_modulus", "poisson_ratio",
                                                   "viscosity"))
            labels = material["labels"]
            rows.append(f"{nu:>7.2f} {name:<7}{e:>8.0f}{100 * (e / E - 1):>7.1f}%"
                        f"{ratio:>7.3f}{eta:>7.2f}{100 * (eta / ETA - 1):>8.1f}%"
                        f"{fitted['rms_error'] / (NOISE * np.sqrt(3)):>10.2f}  "
                        f"{labels['youngs_modulus']}, {labels['poisson_ratio']}")
            print(rows[-1], f"  ({n_markers} markers)", file=sys.stderr, flush=True)
    print(header)
    print("\n".join(rows))
    print(f"truth: E = {E:.0f} Pa ('firm'), eta = {ETA} Pa s; RMS/noise = RMS marker error over "
          f"the noise per marker ({1e6 * NOISE * np.sqrt(3):.1f} µm); "
          f"{time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
