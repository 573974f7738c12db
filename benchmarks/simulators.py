"""Real-time check of the exports: steps per second of MuJoCo running the exported models of the
documentation's examples, beside neurofuzzy's own stepper, measured in the same run.

    python benchmarks/simulators.py            # about a minute on 2 cores
    python benchmarks/simulators.py --quick    # smaller runs, without the 10,368-tetrahedra block

Prints a table and writes benchmarks/simulators.json (or --out PATH). The models:

- the paper's cube of the demo (27 nodes, 86 springs; MuJoCo: spring tendons);
- the continuum block of "The documented pipeline on continuum data" as ``neurofuzzy mesh``
  builds it (4 × 4 × 3 cm, default voxel mesh of 4 mm cells, 1089 nodes), with that
  example's fitted values at ν = 0.45 (E 5945 Pa, ν 0.447, η 1.99 Pa·s), nodal volumetric form;
- the same block with a 5× stiffer spherical inclusion as a second region (two flexes);
- the 10,368-tetrahedra block of benchmarks/run.py section 2b (the real-time target size).

Both simulators step the same time step (the stable step of semi-implicit Euler for the
exported element form, which both run) and record every 10th step, as a real-time simulator
renders; a constant load pushes on the top. One core: OMP_NUM_THREADS=1, MuJoCo's own
single-threaded stepper, the numba kernel without threads. "Real time" is simulated seconds
per wall-clock second (steps/s × time step).
"""

from __future__ import annotations

import argparse
import json
from importlib.metadata import version
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import trimesh  # noqa: E402

import neurofuzzy as nf  # noqa: E402
from neurofuzzy.datasets import kuhn_block, paper_cube_model  # noqa: E402
from neurofuzzy.mesh import lattice_to_tetra, read_mesh  # noqa: E402
from neurofuzzy.simulation import stability_limit  # noqa: E402

# the numpy baseline of the ratios is the tests' reference (the package steps by numba only)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import numpy_reference as reference  # noqa: E402

#: docs/tutorials/springs-or-elements.md, "The documented pipeline on continuum data",
#: ν = 0.45, voxel 4 mm
BLOCK_FIT = {"youngs_modulus": 5945.0, "poisson_ratio": 0.447, "viscosity": 1.99,
             "density": 1050.0}
RECORD_EVERY = 10


def block_mesh(folder: Path):
    """The 4 × 4 × 3 cm block as ``neurofuzzy mesh block.stl --fix-bottom`` builds it."""
    box = trimesh.creation.box(extents=(0.04, 0.04, 0.03))
    box.apply_translation(-box.bounds[0])
    box.export(folder / "block.stl")
    read = read_mesh(folder / "block.stl")
    mesh = lattice_to_tetra(read.mesh, bounds=read.surface_bounds)
    z = mesh.rest_positions[:, 2]
    return mesh.with_fixed(where=lambda p: z <= z.min() + 0.25 * mesh.rest_lengths.min())


def models(folder: Path, quick: bool) -> list[tuple[str, object]]:
    block = nf.Model.continuum(block_mesh(folder), **BLOCK_FIT)
    centre = np.array([0.015, 0.02, 0.02])
    inside = np.linalg.norm(block.mesh.rest_positions[block.mesh.tetrahedra].mean(axis=1)
                            - centre, axis=1) < 0.0075
    node_region = np.zeros(block.n_nodes, int)
    node_region[np.unique(block.mesh.tetrahedra[inside])] = 1
    tumour = block.replace(
        region_names=("block", "inclusion"), region_tissues=(None, None),
        node_region=node_region, terms=(block.elements.replace(
            region=inside.astype(int),
            youngs_modulus=np.where(inside, 5, 1) * block.elements.youngs_modulus),))
    out = [("paper cube, 86 springs", paper_cube_model()),
           (f"continuum block, {block.mesh.n_tetrahedra} tetrahedra", block),
           ("block + stiff inclusion (2 regions)", tumour)]
    if not quick:
        points, tetrahedra = kuhn_block((12, 12, 12), 0.03 / 12)
        mesh = nf.from_tetra(points, tetrahedra).with_fixed(where=nf.bottom_layer)
        out.append(("block, 10,368 tetrahedra", nf.Model.continuum(
            mesh, youngs_modulus=6e3, poisson_ratio=0.45, viscosity=2.0, density=1000.0)))
    return out


def push(model) -> np.ndarray:
    """(n_nodes, 3) N: a push on the top nodes, 1 mN per 10 top nodes."""
    z = model.mesh.rest_positions[:, 2]
    top = np.flatnonzero(z > z.max() - 1e-9)
    load = np.zeros((model.n_nodes, 3))
    load[top, 2] = -1e-4
    return load


def mujoco_rate(path: Path, load: np.ndarray, steps: int) -> float:
    """Steps per second of MuJoCo on an exported file, recording every 10th step."""
    import mujoco

    handle = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(handle)
    bodies = np.array([mujoco.mj_name2id(handle, mujoco.mjtObj.mjOBJ_BODY, f"node{i}")
                       for i in range(len(load))])
    moving = bodies >= 0
    data.xfrc_applied[bodies[moving], :3] = load[moving]
    mujoco.mj_step(handle, data, nstep=RECORD_EVERY)                 # warm up
    best = np.inf
    for _ in range(2):
        recorded = []
        started = time.perf_counter()
        for _ in range(steps // RECORD_EVERY):
            mujoco.mj_step(handle, data, nstep=RECORD_EVERY)
            recorded.append(data.qpos.copy())
        best = min(best, time.perf_counter() - started)
    if not np.all(np.isfinite(recorded[-1])):
        raise RuntimeError(f"{path}: MuJoCo diverged")
    return RECORD_EVERY * (steps // RECORD_EVERY) / best


def ours_rate(model, h: float, load: np.ndarray, steps: int, backend: str) -> float:
    frames = steps // RECORD_EVERY + 1
    reference.simulate(model, dt=RECORD_EVERY * h, n_frames=2, substeps=RECORD_EVERY,
                       external_forces=load, backend=backend, check_stability=False)  # compile
    best = np.inf
    for _ in range(2):
        started = time.perf_counter()
        reference.simulate(model, dt=RECORD_EVERY * h, n_frames=frames,
                           substeps=RECORD_EVERY, external_forces=load, backend=backend,
                           check_stability=False)
        best = min(best, time.perf_counter() - started)
    return RECORD_EVERY * (frames - 1) / best


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs, no 10k block")
    parser.add_argument("--out", default=str(Path(__file__).with_name("simulators.json")))
    args = parser.parse_args(argv)
    import mujoco

    backends = ["numpy", "numba"]
    results = {"quick": args.quick, "mujoco": mujoco.__version__, "numba": version("numba"),
               "models": {}}
    started = time.perf_counter()
    print(f"{'model':<44}{'nodes':>6}{'step (s)':>10}{'MuJoCo':>11}"
          + "".join(f"{'ours ' + b:>12}" for b in backends) + "   steps/s; real time x")
    with tempfile.TemporaryDirectory() as folder:
        for label, model in models(Path(folder), args.quick):
            path = Path(folder) / "model.xml"
            exported = nf.export(model, to="mujoco", path=path)
            text = path.read_text()
            h = float(text.split('timestep="', 1)[1].split('"', 1)[0])
            h = min(h, stability_limit(model).max_step)
            text = text.replace(text.split('timestep="', 1)[1].split('"', 1)[0], repr(h), 1)
            path.write_text(text)
            load = push(model)
            budget = 2.0 if args.quick else 6.0                     # seconds per simulator
            probe = max(int(200 * 10368 / max(model.mesh.n_tetrahedra or 1000, 1000)), 100)
            steps = max(RECORD_EVERY, int(budget * mujoco_rate(path, load, probe) / 3))
            rates = {"mujoco": mujoco_rate(path, load, steps)}
            for backend in backends:
                rates[backend] = ours_rate(model, h, load, min(steps, 20000)
                                           if backend == "numpy" else steps, backend)
            results["models"][label] = {"nodes": model.n_nodes, "time_step_s": h,
                                        "steps_per_s": rates, "notes": list(exported.notes)}
            print(f"{label:<44}{model.n_nodes:>6}{h:>10.3g}{rates['mujoco']:>11,.0f}"
                  + "".join(f"{rates[b]:>12,.0f}" for b in backends)
                  + "   " + ", ".join(f"{k} {rates[k] * h:.2g}" for k in rates), flush=True)
    results["seconds"] = time.perf_counter() - started
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    print(f"\n{results['seconds']:.0f} s; wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
