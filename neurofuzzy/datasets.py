"""Built-in data: the paper's cube experiment, made with our own simulator.

The paper (section "Example") uses "a simple cube with diagonal springs, consisting of 27 nodes
and 86 springs" whose bottom nodes are fixed, with "a constant force" on "the external node in
the center of the top layer", simulated "for a period of 250 time steps" until the nodes rest.
It does not give its parameter values; ours describe a 2 cm cube of soft tissue in SI units.
"""

from __future__ import annotations

import numpy as np

from .experiment import Experiment, simulate_experiment
from .mesh import Mesh, bottom_layer, kuhn_block, lattice  # noqa: F401  (kuhn_block re-exported)
from .model import Model

__all__ = ["per_spring_cube", "kuhn_block", "CUBE", "paper_cube_mesh", "paper_cube_model", "paper_cube_experiment",
           "top_centre_node", "corner_node", "point_load", "push_and_pull"]

#: Parameters of the built-in cube (SI units): a 2 cm cube of soft tissue (density 1000 kg/m³,
#: 8 g divided equally between the 27 nodes), every spring 50 N/m and 0.02 N·s/m, 0.5 ms frames,
#: and 0.2 N on the top centre node (it sinks by a third of an edge and comes to rest by step 250).
CUBE = {
    "edge_length": 0.01,          # m
    "total_mass": 0.008,          # kg
    "stiffness": 50.0,            # N/m
    "damping": 0.02,              # N·s/m
    "dt": 0.0005,                 # s
    "n_frames": 251,              # frame 0 plus the paper's 250 steps
    "force": (0.0, 0.0, -0.2),    # N on the top centre node
}


def paper_cube_mesh() -> Mesh:
    """The paper's cube: 3×3×3 nodes, 54 edges + 32 body diagonals, bottom layer fixed."""
    return lattice((3, 3, 3), CUBE["edge_length"], diagonals="body").with_fixed(
        where=bottom_layer)


def paper_cube_model(*, stiffness=None, damping=None, total_mass=None, tie="none") -> Model:
    """The cube with the built-in ("true") parameters, or with the ones given."""
    return Model.uniform(
        paper_cube_mesh(),
        stiffness=CUBE["stiffness"] if stiffness is None else stiffness,
        damping=CUBE["damping"] if damping is None else damping,
        total_mass=CUBE["total_mass"] if total_mass is None else total_mass, tie=tie)


def top_centre_node(mesh: Mesh) -> int:
    """Index of the node in the centre of the top face."""
    p = mesh.rest_positions
    centre = np.array([(p[:, 0].min() + p[:, 0].max()) / 2, (p[:, 1].min() + p[:, 1].max()) / 2,
                       p[:, 2].max()])
    return int(np.argmin(np.linalg.norm(p - centre, axis=1)))


def corner_node(mesh: Mesh) -> int:
    """Index of the top corner with the largest x and y."""
    return int(np.argmax(mesh.rest_positions @ np.array([1.0, 1.0, 1.0])))


def point_load(mesh: Mesh, node: int, force) -> np.ndarray:
    """(n_nodes, 3) external forces: ``force`` at ``node``, zero elsewhere."""
    loads = np.zeros((mesh.n_nodes, 3))
    loads[node] = force
    return loads


def push_and_pull(mesh: Mesh) -> list[np.ndarray]:
    """Two load cases that together determine every movable spring of the cube: the paper's
    push on the top centre node and a lateral pull at a top corner."""
    return [point_load(mesh, top_centre_node(mesh), CUBE["force"]),
            point_load(mesh, corner_node(mesh), (0.15, 0.05, 0.0))]


def paper_cube_experiment(model: Model | None = None, *, force=None, node=None,
                          noise: float = 0.0, seed: int = 0, n_frames: int | None = None,
                          substeps: int = 1, source: str = "paper-cube") -> Experiment:
    """Simulate the paper's load case: a constant force on the top centre node from rest.

    Parameters
    ----------
    model : Model, optional
        The true model (default :func:`paper_cube_model`).
    force : (3,) float, optional
        The load (default ``CUBE["force"]``).
    node : int, optional
        The loaded node (default the top centre node).
    noise : float
        Marker noise (standard deviation, metres).
    """
    model = paper_cube_model() if model is None else model
    loads = point_load(model.mesh, top_centre_node(model.mesh) if node is None else node,
                       CUBE["force"] if force is None else force)
    return simulate_experiment(model, dt=CUBE["dt"],
                               n_frames=CUBE["n_frames"] if n_frames is None else n_frames,
                               external_forces=loads, noise=noise, seed=seed,
                               substeps=substeps, source=source)


def per_spring_cube(seed: int = 0, spread: float = 0.3):
    """The cube with every spring's own constants, recorded by a reference integrator.

    Stiffness and viscosity of each spring are drawn uniformly within ``±spread`` of the
    built-in values; the two load cases of :func:`push_and_pull` are integrated with RK4 (10
    substeps per frame), another integrator than the learners'.

    Returns
    -------
    base : Model
        The cube with the built-in (uniform) values: a start model.
    truth : Model
    experiments : list of Experiment
    """
    from .validation.integrators import reference_experiment

    rng = np.random.default_rng(seed)
    base = paper_cube_model()
    truth = base.with_springs(
        stiffness=CUBE["stiffness"] * rng.uniform(1 - spread, 1 + spread, base.n_springs),
        damping=CUBE["damping"] * rng.uniform(1 - spread, 1 + spread, base.n_springs))
    experiments = [reference_experiment(truth, dt=CUBE["dt"], n_frames=CUBE["n_frames"],
                                        external_forces=load, method="rk4", substeps=10)
                   for load in push_and_pull(base.mesh)]
    return base, truth, experiments
