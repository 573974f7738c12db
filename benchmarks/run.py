"""Speed and accuracy benchmarks; every ratio is measured side by side in the same run.

    python benchmarks/run.py            # full (a few minutes on 2 cores)
    python benchmarks/run.py --quick    # under a minute

Prints a table and writes benchmarks/results.json (or --out PATH). Sections:

1. force accumulation: np.bincount vs np.add.at vs a sparse incidence matrix (10k springs);
2. simulation: spring-steps per second from 100 to 100,000 springs, numpy and numba backends,
   and the step rate at 10,000 springs (target: 2,000 steps/s on one core), recording every
   10th step as a real-time simulator renders;
2b. tetrahedral elements: steps per second at 288, 10,368 (and 48,000) tetrahedra, numpy and
   numba (target: 1,000 steps/s at 10,000 tetrahedra on one core with numba);
2c. every material law at 10,368 tetrahedra with numba, as a ratio to SVK's time (target < 2x);
3. fitting the cube's tied constants to 0.1 %: the paper's learner, scipy's least_squares with
   finite differences on our simulator, and ours (from the same start, and as `neurofuzzy fit`
   runs it, with the equation-error start);
4. (per-spring identification of the cube: section 6)
5. per-spring fit of a 10,000-spring mesh built with from_trimesh (target < 60 s), peak memory;
   per-region fit of the same mesh (one stiffness and viscosity per spring group; < 10 s);
6. per-spring identification against scipy's least_squares with finite differences, one and two
   load cases, and where the time goes; a per-region fit of 10,368 tetrahedra
   (benchmarks/identification.py; full run only);
7. ``diagnose`` on 100 nodes (springs and tetrahedra), 400 frames (full run only).
"""

from __future__ import annotations

import argparse
import json
from importlib.metadata import version
import os
import resource
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")          # one core, as the targets state

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import trimesh  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from neurofuzzy import simulate  # noqa: E402
from neurofuzzy.datasets import (CUBE, kuhn_block, paper_cube_experiment,  # noqa: E402
                                 paper_cube_model)
from neurofuzzy.experiment import simulate_experiment  # noqa: E402
from neurofuzzy.learn import GradientLearner, PaperLearner, estimate_start  # noqa: E402
from neurofuzzy.mesh import bottom_layer, from_tetra, from_trimesh, lattice  # noqa: E402
from neurofuzzy.forces import Springs  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.simulation import stability_limit  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
from identification import bench_identification, bench_large_elements  # noqa: E402

# the numpy baseline of the ratios is the tests' reference (the package steps by numba only)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import numpy_reference as reference  # noqa: E402


def timed(function, repeat=1):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        value = function()
        best = min(best, time.perf_counter() - start)
    return best, value


def per_call(function, seconds=0.5):
    function()
    count, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        function()
        count += 1
    return (time.perf_counter() - start) / count


# -- 1. accumulation ------------------------------------------------------------------------
def bench_accumulation(results):
    mesh = lattice((12, 12, 12))
    a, b = mesh.springs.T
    n, s = mesh.n_nodes, mesh.n_springs
    force = np.random.default_rng(0).normal(size=(s, 3))
    incidence = sp.csr_matrix((np.r_[np.ones(s), -np.ones(s)], (np.r_[a, b], np.r_[np.arange(s),
                               np.arange(s)])), shape=(n, s))

    def bincount():
        return np.stack([np.bincount(a, force[:, k], n) - np.bincount(b, force[:, k], n)
                         for k in range(3)], axis=1)

    def add_at():
        out = np.zeros((n, 3))
        np.add.at(out, a, force)
        np.add.at(out, b, -force)
        return out

    def sparse():
        return incidence @ force

    assert np.allclose(bincount(), add_at()) and np.allclose(bincount(), sparse())
    times = {name: per_call(f) * 1e6 for name, f in
             (("bincount", bincount), ("add.at", add_at), ("sparse", sparse))}
    results["accumulate_us_10k_springs"] = times
    rows = [(f"accumulate 10k springs: {k}", f"{v:.0f} us") for k, v in times.items()]
    rows.append(("  fastest", min(times, key=times.get)))
    return rows


# -- 2. simulation --------------------------------------------------------------------------
def bench_simulation(results, quick):
    shapes = [(3, 3, 3), (6, 6, 5), (12, 12, 12), (20, 20, 21)]
    if not quick:
        shapes.append((26, 26, 26))
    backends = ["numpy", "numba"]
    rows, table = [], {}
    for shape in shapes:
        mesh = lattice(shape, 0.01).with_fixed(where=bottom_layer)
        model = Model.uniform(mesh, stiffness=50.0, damping=0.02, node_mass=3e-4)
        load = np.zeros((mesh.n_nodes, 3))
        load[-1] = (0, 0, -0.1)
        # a real-time simulator records (renders) every few steps: 10 steps per frame here
        frames = max(int(np.clip(2e6 / mesh.n_springs, 5, 500)) // (4 if quick else 1), 2)
        steps = 10 * frames
        for backend in backends:
            if backend == "numba":
                simulate(model, dt=5e-4, n_frames=2, external_forces=load)
            seconds, _ = timed(lambda: reference.simulate(
                model, dt=5e-3, n_frames=frames + 1, substeps=10, external_forces=load,
                backend=backend, check_stability=False),
                               repeat=2)
            rate = steps / seconds
            table.setdefault(backend, {})[mesh.n_springs] = rate * mesh.n_springs
            rows.append((f"simulate {mesh.n_springs:>6} springs ({backend})",
                         f"{rate:,.0f} steps/s, "
                         f"{rate * mesh.n_springs / 1e6:.1f} M spring-steps/s"))
            if shape == (12, 12, 12):
                results[f"sim_steps_per_s_10k_springs_{backend}"] = rate
    results["sim_spring_steps_per_s"] = {b: {str(k): v for k, v in d.items()}
                                         for b, d in table.items()}
    best = max(results[k] for k in results if k.startswith("sim_steps_per_s_10k_springs_"))
    results["sim_steps_per_s_10k_springs"] = best
    rows.append(("step rate at 10k springs (best backend)",
                 f"{best:,.0f} steps/s (target 2,000)"))
    return rows


def bench_elements(results, quick):
    """Step rate of tetrahedral-element models (SVK + Kelvin–Voigt), numpy and numba."""
    shapes = [(4, 4, 3), (12, 12, 12)] + ([] if quick else [(20, 20, 20)])
    backends = ["numpy", "numba"]
    rows, table = [], {}
    for shape in shapes:
        points, tetrahedra = kuhn_block(shape, 0.03 / max(shape))
        mesh = from_tetra(points, tetrahedra).with_fixed(where=bottom_layer)
        model = Model.continuum(mesh, youngs_modulus=6e3, poisson_ratio=0.45,
                                viscosity=2.0, density=1000.0)
        load = np.zeros((mesh.n_nodes, 3))
        load[-1] = (0, 0, -1e-3)
        h = stability_limit(model).max_step
        for backend in backends:
            steps = 100 if backend == "numpy" else 2000
            steps = max(steps * 10368 // mesh.n_tetrahedra // (4 if quick else 1), 20)
            if backend == "numba":
                simulate(model, dt=h, n_frames=2, external_forces=load)
            seconds, _ = timed(lambda: reference.simulate(
                model, dt=10 * h, n_frames=steps // 10 + 1, substeps=10, external_forces=load,
                backend=backend, check_stability=False),
                               repeat=2)
            rate = 10 * (steps // 10) / seconds
            table.setdefault(backend, {})[mesh.n_tetrahedra] = rate
            rows.append((f"simulate {mesh.n_tetrahedra:>6} tetrahedra ({backend})",
                         f"{rate:,.0f} steps/s, "
                         f"{rate * mesh.n_tetrahedra / 1e6:.2f} M element-steps/s"))
    results["sim_element_steps_per_s"] = {b: {str(k): v for k, v in d.items()}
                                          for b, d in table.items()}
    at_10k = {b: d[10368] for b, d in table.items()}
    results["sim_steps_per_s_10k_tetrahedra"] = max(at_10k.values())
    rows.append(("step rate at 10,368 tetrahedra (best backend)",
                 f"{max(at_10k.values()):,.0f} steps/s (target 1,000 with numba)"))
    if "numba" in at_10k:
        rows.append(("  numba / numpy at 10,368 tetrahedra",
                     f"{at_10k['numba'] / at_10k['numpy']:.1f}x"))
    return rows


def bench_laws(results, quick):
    """Step rate of each material law (:data:`neurofuzzy.forces.laws.LAWS`) and of SVK with a
    Prony term at 10,368 tetrahedra with numba, measured alternately in the same run, as a
    ratio to SVK's (target: every law within 2x of SVK)."""
    from neurofuzzy.forces.laws import LAWS

    points, tetrahedra = kuhn_block((12, 12, 12), 0.03 / 12)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=bottom_layer)
    models = {law: Model.continuum(mesh, youngs_modulus=6e3, poisson_ratio=0.45,
                                   viscosity=2.0, density=1000.0, law=law)
              for law in LAWS}
    # SVK with one Prony term (internal variables per element; stiffer at once by 1 + g, so
    # the step below is stable for it too)
    models["st-venant-kirchhoff + 1 Prony term"] = models[LAWS[0]].with_elements(
        relaxation_moduli=[0.5], relaxation_times=[0.05])
    load = np.zeros((mesh.n_nodes, 3))
    load[-1] = (0, 0, -1e-3)
    h = stability_limit(models["st-venant-kirchhoff + 1 Prony term"]).max_step
    steps = 500 if quick else 2000
    best = {}
    for _ in range(2 if quick else 3):          # alternate the laws: the machine's drift is shared
        for law, model in models.items():
            simulate(model, dt=h, n_frames=2, external_forces=load)
            seconds, _ = timed(lambda: simulate(model, dt=10 * h, n_frames=steps // 10 + 1,
                                                substeps=10, external_forces=load,
                                                check_stability=False))
            best[law] = max(best.get(law, 0.0), 10 * (steps // 10) / seconds)
    results["law_steps_per_s_10k_tetrahedra"] = best
    rows = []
    for law, rate in best.items():
        ratio = best[LAWS[0]] / rate
        rows.append((f"simulate 10,368 tetrahedra, {law} (numba)",
                     f"{rate:,.0f} steps/s, {ratio:.2f}x SVK's time (target < 2x)"))
    return rows


# -- 3. tied constants of the cube ----------------------------------------------------------
def bench_tied_fit(results):
    truth = paper_cube_model()
    data = paper_cube_experiment(truth)
    start = paper_cube_model(stiffness=1.5 * CUBE["stiffness"], damping=1.5 * CUBE["damping"],
                             tie="global")

    def accurate(model):
        return (abs(model.springs.stiffness[0] / CUBE["stiffness"] - 1) < 1e-3
                and abs(model.springs.damping[0] / CUBE["damping"] - 1) < 1e-3)

    # paper's learner: one cycle at a time (its state is the weights) to find the cycle count
    model, paper_cycles = start, None
    for cycle in range(1, 301):
        model = PaperLearner(learning_rate=0.1, cycles=1).fit(model, data).model_
        if accurate(model):
            paper_cycles = cycle
            break
    paper_time, paper = timed(lambda: PaperLearner(learning_rate=0.1, cycles=paper_cycles or 300)
                              .fit(start, data))

    # scipy least_squares, 2-point finite differences, on our simulator
    tracked = data.tracked()
    calls = [0]

    def residuals(x):
        calls[0] += 1
        trial = start.with_springs(stiffness=np.full(86, np.exp(x[0])),
                                   damping=np.full(86, np.exp(x[1])))
        try:
            run = simulate(trial, dt=data.dt, n_frames=data.n_frames,
                           external_forces=data.external_forces, check_stability=False)
        except ValueError:
            return np.full(int(tracked.sum()) * 3 * (data.n_frames - 1), 1e3)
        return ((run.positions - data.positions)[1:, tracked] / CUBE["edge_length"]).ravel()

    x0 = np.log([start.springs.stiffness[0], start.springs.damping[0]])
    fd_time, solution = timed(lambda: least_squares(residuals, x0))
    fd_model = start.with_springs(stiffness=np.full(86, np.exp(solution.x[0])),
                                  damping=np.full(86, np.exp(solution.x[1])))

    ours_time, ours = timed(lambda: GradientLearner().fit(start, data))

    def pipeline():
        estimated = estimate_start(start, data).model
        return GradientLearner(windows=()).fit(estimated, data)

    pipe_time, pipe = timed(pipeline)
    for name, model in (("paper", paper.model_), ("fd", fd_model), ("ours", ours.model_),
                        ("pipeline", pipe.model_)):
        assert accurate(model), name
    results.update({
        "fit_cycles_paper": paper_cycles, "fit_seconds_paper": paper_time,
        "fit_cycles_fd_lsq": calls[0], "fit_seconds_fd_lsq": fd_time,
        "fit_cycles_gradient": ours.n_cycles_, "fit_seconds_gradient": ours_time,
        "fit_cycles_pipeline": pipe.n_cycles_ + 1, "fit_seconds_pipeline": pipe_time,
        "fit_speedup_vs_fd_lsq": fd_time / ours_time,
        "fit_speedup_vs_fd_lsq_pipeline": fd_time / pipe_time,
        "fit_accuracy": {name: {"stiffness": abs(m.springs.stiffness[0] / 50 - 1),
                                "damping": abs(m.springs.damping[0] / 0.02 - 1)}
                         for name, m in (("paper", paper.model_), ("fd_lsq", fd_model),
                                         ("gradient", ours.model_), ("pipeline", pipe.model_))},
    })
    return [
        ("tied cube fit to 0.1 %: paper's learner", f"{paper_cycles} cycles, {paper_time:.2f} s"),
        ("  least_squares + finite differences", f"{calls[0]} simulations, {fd_time:.2f} s"),
        ("  gradient learner, same start", f"{ours.n_cycles_} cycles, {ours_time:.2f} s "
                                           f"({fd_time / ours_time:.2f}x vs FD)"),
        ("  gradient + equation-error start", f"{pipe.n_cycles_ + 1} cycles, {pipe_time:.2f} s "
                                              f"({fd_time / pipe_time:.1f}x vs FD)"),
    ]


# -- 5. per-spring fit of a 10k-spring mesh --------------------------------------------------
def _large_fit(quick):
    """Section 5's fits (run in a fresh process, so that its peak RSS is the fit's own and
    not that of the earlier sections' largest meshes)."""
    surface = trimesh.creation.capsule(height=0.04, radius=0.02)
    mesh = from_trimesh(surface, pitch=0.0039 if not quick else 0.007)
    mesh = mesh.with_fixed(where=bottom_layer)
    rng = np.random.default_rng(1)
    truth = Model(mesh, np.full(mesh.n_nodes, 1e-4),
                  (Springs(stiffness=50 * rng.uniform(0.8, 1.2, mesh.n_springs),
                           damping=np.full(mesh.n_springs, 0.05)),))
    top = np.flatnonzero(mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9)
    frames = 60 if not quick else 30
    loads = []
    for direction in ((0, 0, -1.0), (1.0, 0, 0)):
        load = np.zeros((mesh.n_nodes, 3))
        load[top] = np.array(direction) * 0.5 / len(top)
        loads.append(load)

    def record(model):
        return [simulate_experiment(model, dt=2e-4, n_frames=frames, external_forces=load,
                                    substeps="auto") for load in loads]

    data = record(truth)
    start = truth.with_springs(stiffness=np.full(mesh.n_springs, 50.0))
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    learner = GradientLearner(method="lbfgs", windows=(), max_iterations=60 if not quick else 15,
                              substeps=1)
    seconds, learner = timed(lambda: learner.fit(start, data))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    error_before = np.median(np.abs(start.springs.stiffness / truth.springs.stiffness - 1))
    error_after = np.median(np.abs(learner.model_.springs.stiffness / truth.springs.stiffness - 1))
    per_spring = {"springs": mesh.n_springs, "nodes": mesh.n_nodes,
                  "parameters": 2 * mesh.n_springs, "seconds": seconds,
                  "cycles": learner.n_cycles_, "peak_rss_mb": peak, "rss_before_mb": rss_before,
                  "rms_initial": learner.rms_error_initial_, "rms_final": learner.rms_error_,
                  "median_stiffness_error_start": float(error_before),
                  "median_stiffness_error_end": float(error_after)}
    # per region: one stiffness and one viscosity per spring group (4 parameters), LM
    uniform = truth.with_springs(stiffness=np.full(mesh.n_springs, 50.0))
    start = uniform.with_springs(stiffness=np.full(mesh.n_springs, 35.0),
                                 damping=np.full(mesh.n_springs, 0.08)).tied("groups")
    seconds, learner = timed(lambda: GradientLearner(substeps="auto").fit(start,
                                                                          record(uniform)))
    per_region = {"springs": mesh.n_springs, "load_cases": len(loads),
                  "parameters": len(learner.parameter_names_), "seconds": seconds,
                  "cycles": learner.n_cycles_,
                  "max_stiffness_error": float(np.max(np.abs(
                      learner.model_.springs.stiffness / 50.0 - 1)))}
    return per_spring, per_region


def bench_large_fit(results, quick):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        per_spring, per_region = pool.submit(_large_fit, quick).result()
    results["large_fit"], results["large_fit_per_region"] = per_spring, per_region
    return [(f"per-spring fit, {per_spring['springs']} springs (from_trimesh), L-BFGS",
             f"{per_spring['seconds']:.1f} s, {per_spring['cycles']} cycles, peak RSS "
             f"{per_spring['peak_rss_mb']:.0f} MB (a fresh process), RMS "
             f"{per_spring['rms_initial']:.2e} -> {per_spring['rms_final']:.2e} m, median "
             f"stiffness error {per_spring['median_stiffness_error_start']:.1%} -> "
             f"{per_spring['median_stiffness_error_end']:.1%}"),
            (f"per-region fit, {per_region['springs']} springs, {per_region['load_cases']} "
             "load cases, LM",
             f"{per_region['seconds']:.1f} s, {per_region['parameters']} parameters, "
             f"{per_region['cycles']} cycles, largest stiffness error "
             f"{per_region['max_stiffness_error']:.1e} (target 10 s)")]


# -- 7. diagnosis of a model of about 100 nodes, 400 frames -----------------------------------
def bench_diagnose(results):
    """``diagnose`` on 100 nodes (427 springs, or 288 tetrahedra), 400 frames of noisy data:
    nothing hidden, and hidden gravity (issue 13's target: under a minute)."""
    from neurofuzzy.diagnosis import diagnose
    from neurofuzzy.effects import Gravity
    from neurofuzzy.learn import auto_substeps

    springs = lattice((5, 5, 4), spacing=0.01).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    spring_truth = Model(springs, np.full(springs.n_nodes, 1e-3),
                         (Springs(stiffness=np.full(springs.n_springs, 50.0),
                                  damping=np.full(springs.n_springs, 0.05)),))
    tetra = from_tetra(*kuhn_block((4, 4, 3), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)

    def continuum(modulus):
        return Model.continuum(tetra, youngs_modulus=modulus, poisson_ratio=0.3,
                               viscosity=2.0, density=1050.0)

    cases = [(f"{springs.n_springs} springs", spring_truth,
              spring_truth.with_springs(stiffness=np.full(springs.n_springs, 35.0))
              .tied("global"), 0.2, 4, 1e-6),
             (f"{tetra.n_tetrahedra} tetrahedra", continuum(6000.0), continuum(4200.0), 0.05,
              None, 5e-6)]
    rows, table = [], {}
    for label, truth, start, force, substeps, noise in cases:
        substeps = substeps or auto_substeps(truth, 1e-3)
        top = np.flatnonzero(truth.mesh.rest_positions[:, 2]
                             > truth.mesh.rest_positions[:, 2].max() - 1e-9)
        load = np.zeros((truth.n_nodes, 3))
        load[top, 2] = -force / len(top)
        for hidden in ("nothing", "gravity"):
            model = truth if hidden == "nothing" else truth.with_effects(
                Gravity([0.0, 0.0, -9.81]))
            data = simulate_experiment(model, dt=1e-3, n_frames=400, external_forces=load,
                                       substeps=substeps, noise=noise, seed=0)
            seconds, result = timed(lambda: diagnose(start, data))
            table[f"{label}, {hidden}"] = {"seconds": seconds, "answer": result.names}
            rows.append((f"diagnose, 100 nodes, {label}, 400 frames, {hidden} hidden",
                         f"{seconds:.1f} s, answer {', '.join(result.names)}"))
    results["diagnose_100_nodes"] = table
    return rows


def one_thread(section):
    """The rows of ``section`` with numba's element passes on one thread: the step-rate
    targets are per core (both cores: ``benchmarks/threads.py``)."""
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        return list(section())
    finally:
        numba.set_num_threads(before)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller problems, under a minute")
    parser.add_argument("--out", default=str(Path(__file__).with_name("results.json")))
    args = parser.parse_args(argv)
    results = {"quick": args.quick, "numba": version("numba")}
    rows = []
    started = time.perf_counter()
    sections = [lambda: bench_accumulation(results),
                lambda: one_thread(lambda: bench_simulation(results, args.quick)),
                lambda: one_thread(lambda: bench_elements(results, args.quick)),
                lambda: one_thread(lambda: bench_laws(results, args.quick)),
                lambda: bench_tied_fit(results)]
    sections.append(lambda: bench_large_fit(results, args.quick))
    if not args.quick:
        sections.append(lambda: bench_identification(results))
        sections.append(lambda: bench_large_elements(results))
        sections.append(lambda: bench_diagnose(results))
    for section in sections:
        for row in section():
            rows.append(row)
            print(f"{row[0]:<52} {row[1]}", flush=True)
    results["seconds"] = time.perf_counter() - started
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    print(f"\n{results['seconds']:.0f} s; wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
