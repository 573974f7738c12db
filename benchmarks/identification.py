"""Per-spring identification of the cube against what a practitioner would write.

Every stiffness and viscosity of the paper's cube (172 unknowns) from RK4 data (10 substeps
per frame, another integrator than ours): ``neurofuzzy``'s gradient learner (exact forward
sensitivities, Levenberg–Marquardt, Richardson over two substep levels) with one and with two
load cases, against ``scipy.optimize.least_squares`` with 2-point finite differences on the
plain numpy simulator, at the finer of our two substep levels, from the same start, in the
same run. Also where our time goes: simulations (residuals), sensitivities (Jacobians) and
the solver's linear algebra, from a profile of the fit.

Also one region of 10,368 tetrahedra fitted for E, ν and η, and one adjoint gradient of
every element's E, ν and η of that mesh, compiled and numpy (``bench_large_elements``).

Run on its own:  python benchmarks/identification.py [--skip-fd]
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

from neurofuzzy.datasets import CUBE, per_spring_cube
from neurofuzzy.errors import NeurofuzzyError
from neurofuzzy.learn import GradientLearner, auto_substeps

# the numpy baseline of the ratios is the tests' reference (the package steps by numba only)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import numpy_reference as reference  # noqa: E402


def _errors(fitted, truth, moving):
    stiffness = np.abs(fitted.springs.stiffness / truth.springs.stiffness - 1)[moving]
    damping = np.abs(fitted.springs.damping / truth.springs.damping - 1)[moving]
    return float(np.median(stiffness)), float(np.median(damping))


def _profiled_fit(start, data):
    """The fit, its seconds and the split of its time (s) by what it did."""
    profile = cProfile.Profile()
    began = time.perf_counter()
    profile.enable()
    learner = GradientLearner(substeps="auto").fit(start, data)
    profile.disable()
    seconds = time.perf_counter() - began
    stats = pstats.Stats(profile).stats
    cumulative = {}
    for (filename, _, function), (_, _, _, total, _) in stats.items():
        if filename.endswith("gradient.py") and function in ("_residuals", "_jacobian"):
            cumulative[function] = cumulative.get(function, 0.0) + total
        if filename.endswith("_lm.py") and function == "levenberg_marquardt":
            cumulative["solver"] = cumulative.get("solver", 0.0) + total
    simulation = cumulative.get("_residuals", 0.0)
    sensitivities = cumulative.get("_jacobian", 0.0)
    algebra = max(cumulative.get("solver", 0.0) - simulation - sensitivities, 0.0)
    return learner, seconds, {"simulation": simulation, "sensitivities": sensitivities,
                              "linear_algebra": algebra,
                              "other": max(seconds - simulation - sensitivities - algebra, 0)}


def _finite_differences(start, data, substeps):
    """scipy's least_squares, 2-point finite differences, on log parameters; the plain numpy
    simulator at ``substeps``; returns (model, seconds, simulations)."""
    tracked = data.tracked()
    calls = [0]
    n = start.n_springs

    def model(x):
        return start.with_springs(stiffness=np.exp(x[:n]), damping=np.exp(x[n:]))

    def residuals(x):
        calls[0] += 1
        try:
            run = reference.simulate(model(x), dt=data.dt, n_frames=data.n_frames,
                                     external_forces=data.external_forces, substeps=substeps,
                                     check_stability=False, backend="numpy")
        except NeurofuzzyError:                    # diverged: a cost the solver rejects
            return np.full(int(tracked.sum()) * 3 * (data.n_frames - 1), 1e3)
        error = (run.positions - data.positions)[1:, tracked] / CUBE["edge_length"]
        return np.where(np.isfinite(error), error, 1e3).ravel()

    x0 = np.log(np.concatenate([start.springs.stiffness, start.springs.damping]))
    began = time.perf_counter()
    solution = least_squares(residuals, x0, x_scale="jac")
    return model(solution.x), time.perf_counter() - began, calls[0]


def bench_identification(results, skip_fd=False):
    base, truth, data = per_spring_cube(seed=0)
    start = base.tied("none")
    moving = base.mesh.free[base.mesh.springs].any(axis=1)
    rows, entry = [], {}
    for cases in (1, 2):
        learner, seconds, split = _profiled_fit(start, data[:cases])
        stiffness, damping = _errors(learner.model_, truth, moving)
        entry[f"ours_{cases}"] = {"seconds": seconds, "cycles": learner.n_cycles_,
                                  "substeps": learner.substeps_,
                                  "median_stiffness_error": stiffness,
                                  "median_damping_error": damping, "time_split": split}
        shares = ", ".join(f"{k.replace('_', ' ')} {v:.1f} s" for k, v in split.items())
        rows.append((f"per-spring cube, {cases} load case(s): gradient learner",
                     f"{seconds:.1f} s, {learner.n_cycles_} simulations, median error "
                     f"stiffness {stiffness:.3%}, viscosity {damping:.3%} ({shares})"))
    if not skip_fd:
        substeps = entry["ours_1"]["substeps"]
        fitted, seconds, calls = _finite_differences(start, data[0], substeps)
        stiffness, damping = _errors(fitted, truth, moving)
        ratio = seconds / entry["ours_1"]["seconds"]
        entry["fd_least_squares_1"] = {"seconds": seconds, "simulations": calls,
                                       "substeps": substeps,
                                       "median_stiffness_error": stiffness,
                                       "median_damping_error": damping,
                                       "speedup_of_ours": ratio}
        rows.append(("  least_squares + finite differences, 1 load case",
                     f"{seconds:.0f} s, {calls} simulations at {substeps} substeps, median "
                     f"error stiffness {stiffness:.3%}, viscosity {damping:.3%}; ours "
                     f"{ratio:.1f}x faster"))
    results["identification"] = entry
    return rows


def bench_large_elements(results):
    """E, ν and η of one region of 10,368 tetrahedra (a 3 cm Kuhn block, 2,197 nodes) from
    one load case of our own simulator, every node seen, fitted at the data's own substeps
    from a start 33 % off (target of the speed issue: under 10 s)."""
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.learn import Parameterization
    from neurofuzzy.mesh import from_tetra
    from neurofuzzy.model import Model

    mesh = from_tetra(*kuhn_block((12, 12, 12), 0.0025)).with_fixed(
        where=lambda p: p[:, 2] < 1e-9)

    def block(modulus, ratio, viscosity):
        return Model.continuum(mesh, youngs_modulus=modulus, poisson_ratio=ratio,
                               viscosity=viscosity, density=1050.0)

    top = np.flatnonzero(mesh.rest_positions[:, 2] > mesh.rest_positions[:, 2].max() - 1e-9)
    load = np.zeros((mesh.n_nodes, 3))
    load[top] = np.array([0.002, 0.0, -0.01]) / len(top)
    truth = block(6000.0, 0.45, 2.0)
    substeps = auto_substeps(truth, 1e-3)      # the data's own discretisation, fitted as is
    data = simulate_experiment(truth, dt=1e-3, n_frames=41, external_forces=load,
                               substeps=substeps)
    # the fit as it comes, with the mesh check it runs by default (one Gauss-Newton step on
    # the mesh refined once, 82,944 tetrahedra): its seconds are the check's own, the fit's
    # the rest (the speed target is the fit's)
    began = time.perf_counter()
    learner = GradientLearner(substeps=substeps).fit(block(4000.0, 0.4, 3.0), data)
    seconds = time.perf_counter() - began
    check = learner.mesh_check_
    checking = check.seconds if check is not None else 0.0
    fitted = learner.model_
    found = (float(fitted.elements.youngs_modulus[0]), float(fitted.elements.poisson_ratio[0]),
             float(fitted.elements.viscosity[0]))
    results["large_elements_per_region"] = {
        "tetrahedra": mesh.n_tetrahedra, "nodes": mesh.n_nodes, "seconds": seconds - checking,
        "mesh_check_seconds": checking, "with_mesh_check_seconds": seconds,
        "simulations": learner.n_cycles_, "substeps": learner.substeps_,
        "youngs_modulus": found[0], "poisson_ratio": found[1], "viscosity": found[2]}
    rows = [(f"per-region fit, {mesh.n_tetrahedra} tetrahedra (E, ν, η)",
             f"{seconds - checking:.1f} s, {learner.n_cycles_} simulations; E "
             f"{found[0] / 6000 - 1:+.2%}, ν {found[1]:.4f} (0.45), η {found[2] / 2 - 1:+.1%} "
             "(target 6 s)"),
            ("  its default mesh check (one step on the mesh refined once)",
             f"{checking:.1f} s more" if check is not None
             else f"none: {learner.intervals_hold_}")]
    # per element: one adjoint gradient of every element's E, ν and η, numpy and compiled
    parameters = Parameterization(block(4000.0, 0.4, 3.0).tied("none"))
    theta = parameters.initial()
    times, values = {}, {}
    for backend in ("numba", "numpy"):
        sensitivity = reference.sensitivity(parameters, 0.0025, backend=backend)
        if backend == "numba":                     # loaded from numba's cache once
            sensitivity.gradient(theta, data, substeps=substeps)
        began = time.perf_counter()
        values[backend] = sensitivity.gradient(theta, data, substeps=substeps)[1]
        times[backend] = time.perf_counter() - began
    difference = float(np.abs(values["numba"] - values["numpy"]).max()
                       / np.abs(values["numpy"]).max())
    results["large_elements_gradient"] = {"parameters": parameters.size, **times,
                                          "largest_relative_difference": difference}
    rows.append((f"adjoint gradient, {parameters.size} element parameters",
                 f"compiled {times['numba']:.1f} s, numpy {times['numpy']:.1f} s "
                 f"({times['numpy'] / times['numba']:.0f}x; largest difference "
                 f"{difference:.1e} of the largest entry)"))
    return rows


if __name__ == "__main__":
    found = {}
    rows = bench_identification(found, skip_fd="--skip-fd" in sys.argv)
    for name, value in rows + bench_large_elements(found):
        print(f"{name:<52} {value}", flush=True)
