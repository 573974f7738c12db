"""neurofuzzy: realistic real-time deformable-tissue models from words and measurements.

The public surface, re-exported here:

- topology: :class:`Mesh`, :func:`lattice`, :func:`from_trimesh`, :func:`from_tetra`,
  :func:`from_surface_tetra`, :func:`bottom_layer`; mesh files: :func:`read_mesh`,
  :class:`MeshFile`
- physics: :class:`SpringMassModel`, :func:`simulate`, :func:`stability_limit`
- data: :class:`Experiment`, :func:`simulate_experiment`, :func:`load_experiment`,
  :func:`save_experiment`, :func:`load_model`, :func:`save_model`
- learning: :class:`PaperLearner`, :class:`GradientLearner`, :func:`rms_error`
- errors: :class:`NeurofuzzyError`, :class:`InputError`, :class:`UnstableTimeStepError`
"""

from .errors import InputError, NeurofuzzyError, UnstableTimeStepError
from .experiment import Experiment, simulate_experiment
from .io import load_experiment, load_model, save_experiment, save_model
from .learn import GradientLearner, PaperLearner, rms_error
from .mesh import Mesh, bottom_layer, from_surface_tetra, from_tetra, from_trimesh, lattice
from .mesh_files import MeshFile, read_mesh
from .model import SpringMassModel
from .simulate import Trajectory, simulate, stability_limit

__version__ = "0.1.0"

__all__ = [
    "Mesh", "lattice", "from_trimesh", "from_tetra", "from_surface_tetra", "bottom_layer",
    "read_mesh", "MeshFile",
    "SpringMassModel", "simulate", "stability_limit", "Trajectory",
    "Experiment", "simulate_experiment", "load_experiment", "save_experiment", "load_model",
    "save_model",
    "PaperLearner", "GradientLearner", "rms_error",
    "NeurofuzzyError", "InputError", "UnstableTimeStepError",
]
