"""Reference integrators of the continuous spring-mass equations, to validate our discrete model.

Our simulator *is* the paper's discrete network (semi-implicit Euler, one step per frame), so
data made with it fits that network exactly. Real measurements come from continuous physics.
These integrators solve the same forces as :mod:`neurofuzzy.simulation` with different schemes,
at a finer step, and produce data a fitter has never seen the discretisation of:

- ``method="rk4"``: classical fixed-step Runge–Kutta with ``substeps`` steps per frame;
- any :func:`scipy.integrate.solve_ivp` method name (``"DOP853"``, ``"Radau"`` …): adaptive, to
  ``rtol``/``atol``.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import InputError
from ..experiment import Experiment, model_truth
from ..model import Model
from ..simulation import Trajectory, internal_forces

__all__ = ["reference_simulate", "reference_experiment"]


def reference_simulate(model: Model, *, dt: float, n_frames: int,
                       external_forces: np.ndarray | None = None, method: str = "rk4",
                       substeps: int = 10, rtol: float = 1e-10, atol: float = 1e-13) -> Trajectory:
    """Integrate ``M p'' = F(p, p') + f_ext`` from rest and sample it every ``dt``.

    Parameters
    ----------
    model : Model
    dt, n_frames : float, int
        Frame spacing and count (frame 0 is the rest state).
    external_forces : (n_nodes, 3) or (n_frames, n_nodes, 3) float, optional
        Piecewise-constant load, as in :func:`neurofuzzy.simulation.simulate`.
    method : str
        ``"rk4"`` or a :func:`scipy.integrate.solve_ivp` method.
    substeps : int
        RK4 steps per frame.
    rtol, atol : float
        Tolerances of the adaptive methods.
    """
    n_nodes = model.n_nodes
    loads = np.zeros((n_frames, n_nodes, 3)) if external_forces is None else \
        np.broadcast_to(np.asarray(external_forces, float), (n_frames, n_nodes, 3))
    weight = model.node_inverse_mass[:, None]

    def acceleration(p, v, load):
        return weight * (internal_forces(model, p, v) + load)

    p = np.array(model.mesh.rest_positions, dtype=float)
    v = np.zeros_like(p)
    positions = np.empty((n_frames, n_nodes, 3))
    velocities = np.empty((n_frames, n_nodes, 3))
    positions[0], velocities[0] = p, v
    for t in range(1, n_frames):
        load = loads[t - 1]
        if method == "rk4":
            h = dt / substeps
            for _ in range(substeps):
                k1p, k1v = v, acceleration(p, v, load)
                k2p, k2v = v + 0.5 * h * k1v, acceleration(p + 0.5 * h * k1p, v + 0.5 * h * k1v, load)
                k3p, k3v = v + 0.5 * h * k2v, acceleration(p + 0.5 * h * k2p, v + 0.5 * h * k2v, load)
                k4p, k4v = v + h * k3v, acceleration(p + h * k3p, v + h * k3v, load)
                p = p + h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p)
                v = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        else:
            def rhs(_, y):
                q, w = y[:3 * n_nodes].reshape(n_nodes, 3), y[3 * n_nodes:].reshape(n_nodes, 3)
                return np.concatenate([w.ravel(), acceleration(q, w, load).ravel()])
            try:
                solution = solve_ivp(rhs, (0.0, dt), np.concatenate([p.ravel(), v.ravel()]),
                                     method=method, rtol=rtol, atol=atol)
            except ValueError as error:
                raise InputError(str(error), key="method") from None
            y = solution.y[:, -1]
            p, v = y[:3 * n_nodes].reshape(n_nodes, 3), y[3 * n_nodes:].reshape(n_nodes, 3)
        positions[t], velocities[t] = p, v
    return Trajectory(positions=positions, velocities=velocities, dt=float(dt), substeps=substeps)


def reference_experiment(model: Model, *, dt: float, n_frames: int,
                         external_forces: np.ndarray | None = None, method: str = "rk4",
                         substeps: int = 10, source: str = "<reference>") -> Experiment:
    """Like :func:`neurofuzzy.experiment.simulate_experiment`, made by a reference integrator."""
    trajectory = reference_simulate(model, dt=dt, n_frames=n_frames,
                                    external_forces=external_forces, method=method,
                                    substeps=substeps)
    return Experiment(mesh=model.mesh, dt=dt, positions=trajectory.positions,
                      external_forces=external_forces, node_mass=model.node_mass,
                      truth=model_truth(model), source=source)
