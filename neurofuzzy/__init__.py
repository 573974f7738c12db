"""neurofuzzy: realistic real-time deformable-tissue models from words and measurements.

The public surface, re-exported here:

- topology: :class:`Mesh`, :func:`lattice`, :func:`from_trimesh`, :func:`from_tetra`,
  :func:`from_surface_tetra`, :func:`bottom_layer`, :func:`surface_nodes`; mesh files:
  :func:`read_mesh`, :class:`MeshFile`
- physics: :class:`SpringMassModel`, :func:`simulate`, :func:`stability_limit`
- data: :class:`Experiment`, :func:`simulate_experiment`, :func:`load_experiment`,
  :func:`save_experiment`, :func:`load_model`, :func:`save_model`
- learning: :class:`PaperLearner`, :class:`GradientLearner`, :func:`rms_error`
- errors: :class:`NeurofuzzyError`, :class:`InputError`, :class:`UnstableTimeStepError`
"""

from importlib import import_module
from typing import TYPE_CHECKING

# name -> module; imported on first use (PEP 562), so ``import neurofuzzy`` and the command
# line start fast and load scipy, trimesh or meshio only when a part needs them
_EXPORTS = {
    "InputError": "errors", "NeurofuzzyError": "errors", "UnstableTimeStepError": "errors",
    "Experiment": "experiment", "simulate_experiment": "experiment",
    "load_experiment": "io", "load_model": "io", "save_experiment": "io", "save_model": "io",
    "GradientLearner": "learn", "PaperLearner": "learn", "rms_error": "learn",
    "Mesh": "mesh", "bottom_layer": "mesh", "from_surface_tetra": "mesh", "from_tetra": "mesh",
    "from_trimesh": "mesh", "lattice": "mesh", "surface_nodes": "mesh",
    "MeshFile": "mesh_files", "read_mesh": "mesh_files",
    "SpringMassModel": "model",
    "Trajectory": "simulate", "simulate": "simulate", "stability_limit": "simulate",
}


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'neurofuzzy' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))


if TYPE_CHECKING:      # for type checkers and IDEs: the same names, imported eagerly
    from .errors import InputError, NeurofuzzyError, UnstableTimeStepError  # noqa: F401
    from .experiment import Experiment, simulate_experiment  # noqa: F401
    from .io import load_experiment, load_model, save_experiment, save_model  # noqa: F401
    from .learn import GradientLearner, PaperLearner, rms_error  # noqa: F401
    from .mesh import (Mesh, bottom_layer, from_surface_tetra, from_tetra,  # noqa: F401
                       from_trimesh, lattice, surface_nodes)
    from .mesh_files import MeshFile, read_mesh  # noqa: F401
    from .model import SpringMassModel  # noqa: F401
    from .simulate import Trajectory, simulate, stability_limit  # noqa: F401

__version__ = "0.1.0"

__all__ = [
    "Mesh", "lattice", "from_trimesh", "from_tetra", "from_surface_tetra", "bottom_layer",
    "surface_nodes",
    "read_mesh", "MeshFile",
    "SpringMassModel", "simulate", "stability_limit", "Trajectory",
    "Experiment", "simulate_experiment", "load_experiment", "save_experiment", "load_model",
    "save_model",
    "PaperLearner", "GradientLearner", "rms_error",
    "NeurofuzzyError", "InputError", "UnstableTimeStepError",
]
