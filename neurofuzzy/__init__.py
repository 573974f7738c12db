"""neurofuzzy: realistic real-time deformable-tissue models from words and measurements.

The whole pipeline, re-exported here (``import neurofuzzy as nf``):

- topology: :class:`Mesh`, :func:`lattice`, :func:`from_trimesh`, :func:`from_tetra`,
  :func:`from_surface_tetra`, :func:`bottom_layer`, :func:`surface_nodes`; mesh files:
  :func:`read_mesh`, :class:`MeshFile`
- physics: :class:`Model` (a mesh, node masses and force terms), the force terms
  (:class:`ForceTerm`, :class:`Springs`, :class:`Tetrahedra`) and effects (:class:`Effect`, :class:`Gravity`, :class:`NodeDrag`,
  :class:`StiffInclusion`, :class:`SoftInclusion`, :class:`NonlinearStiffening`,
  :class:`UnmodeledLoad`, :data:`EFFECTS`), :func:`simulate`, :class:`Trajectory`, :class:`State`,
  :func:`stability_limit`, :func:`reference_simulate`
- data: :class:`Experiment`, :func:`simulate_experiment`, :func:`reference_experiment`,
  :func:`check_experiments`, :func:`simulate_like`, :func:`rms_error`,
  :func:`load_experiment`, :func:`save_experiment`, :func:`load_model`, :func:`save_model`;
  marker recordings: :func:`read_markers`, :func:`markers_to_experiment`; markers between
  nodes: :class:`EmbeddedMarkers`, :class:`Observation`, :func:`embed_points`; scans at
  load steps of a compression test: :class:`LoadSteps`, :class:`DrivenPath`,
  :func:`simulate_load_steps`, :func:`load_load_steps`, :func:`save_load_steps`, one static
  equilibrium :func:`equilibrium` (:class:`Driven`)
- learning: :func:`start_model` (:class:`StartModel`), :func:`estimate_start`,
  :class:`PaperLearner`, :class:`GradientLearner`, the rule base as a prior
  :class:`FuzzyPrior`; the one fit pipeline of Python, the command
  and fit-many: :func:`fit` (:class:`FitOptions`, :class:`FitOutcome`,
  :class:`FitFailedError`); E and ν from
  load steps: :func:`fit_load_steps`, how far they move on the mesh refined once
  :func:`load_step_mesh_check`
- words: :func:`load_rules`, :func:`shipped_rules`, :func:`initialize`,
  :func:`material_values`, :func:`materials`
- diagnosis: :func:`diagnose` (:class:`Diagnosis`), from measured data with the fit's start
  and checks :func:`diagnose_data` (:class:`DiagnosedData`), of load steps
  :func:`diagnose_load_steps`, of a plate or tool moved in time :func:`diagnose_moving`
- many specimens: :func:`fit_many` (:class:`Cohort`) on Dask, :func:`read_manifest`,
  :func:`cohort_report`
- output: :func:`fit_report`, :func:`diagnosis_report`, :func:`load_steps_report`,
  :func:`export` (MuJoCo, SOFA, FEBio, ParaView), :func:`export_paraview`
- the rule studio in the browser: :func:`studio` (``pip install 'neurofuzzy[studio]'``)
- errors: :class:`NeurofuzzyError`, :class:`InputError`, :class:`UnstableTimeStepError`

No exported name is also the name of a submodule (the modules are ``simulation``,
``diagnosis``, …), so ``nf.simulate`` is the function whatever was imported before. The one
exception, ``export`` (the function, and the package ``neurofuzzy.export`` of the exporters),
is bound at import: the package is imported with ``neurofuzzy`` (it is light) and the name
set to the function, so no later import of the package replaces it.
"""

from typing import TYPE_CHECKING

from .lazy import lazy

# name -> module; imported on first use (PEP 562), so ``import neurofuzzy`` and the command
# line start fast and load scipy, trimesh or meshio only when a part needs them
_EXPORTS = {
    "InputError": "errors", "NeurofuzzyError": "errors", "UnstableTimeStepError": "errors",
    "Mesh": "mesh", "bottom_layer": "mesh", "from_surface_tetra": "mesh", "from_tetra": "mesh",
    "from_trimesh": "mesh", "lattice": "mesh", "surface_nodes": "mesh",
    "MeshFile": "mesh", "read_mesh": "mesh",
    "Model": "model",
    "ForceTerm": "forces", "Springs": "forces", "Tetrahedra": "forces",
    "Effect": "effects", "EFFECTS": "effects", "Gravity": "effects", "NodeDrag": "effects",
    "StiffInclusion": "effects", "SoftInclusion": "effects",
    "NonlinearStiffening": "effects", "UnmodeledLoad": "effects",
    "Trajectory": "simulation", "State": "simulation", "simulate": "simulation",
    "stability_limit": "simulation", "equilibrium": "simulation", "Driven": "simulation",
    "LoadSteps": "load_steps", "DrivenPath": "load_steps",
    "simulate_load_steps": "load_steps", "load_load_steps": "io", "save_load_steps": "io",
    "fit_load_steps": "learn.load_step_fit", "diagnose_load_steps": "diagnosis.load_steps",
    "diagnose_moving": "diagnosis.moving",
    "load_step_mesh_check": "learn.load_step_mesh_check",
    "load_steps_report": "report.load_steps",
    "reference_simulate": "validation.integrators",
    "reference_experiment": "validation.integrators",
    "Experiment": "experiment", "simulate_experiment": "experiment",
    "check_experiments": "experiment", "simulate_like": "experiment", "rms_error": "experiment",
    "load_experiment": "io", "load_model": "io", "save_experiment": "io", "save_model": "io",
    "read_markers": "markers", "markers_to_experiment": "markers",
    "EmbeddedMarkers": "observation", "Observation": "observation",
    "embed_points": "observation",
    "GradientLearner": "learn", "PaperLearner": "learn", "start_model": "pipeline",
    "StartModel": "learn", "estimate_start": "learn", "FuzzyPrior": "learn.prior",
    "fit": "pipeline", "FitOptions": "pipeline", "FitOutcome": "pipeline",
    "FitFailedError": "pipeline",
    "load_rules": "rules", "shipped_rules": "rules",
    "initialize": "tissues", "material_values": "tissues", "materials": "tissues",
    "diagnose": "diagnosis", "Diagnosis": "diagnosis", "diagnose_data": "diagnosis",
    "DiagnosedData": "diagnosis",
    "fit_many": "batch", "Cohort": "batch", "read_manifest": "batch", "cohort_report": "batch",
    "fit_report": "report", "diagnosis_report": "report",
    "export_paraview": "export", "export": "export",
    "studio": "rulestudio",
}
# names whose object has another name in its module
_ALIASES = {"shipped_rules": "shipped", "load_step_mesh_check": "with_mesh_check"}


__getattr__, __dir__ = lazy(__name__, _EXPORTS, _ALIASES)


if TYPE_CHECKING:      # for type checkers and IDEs: the same names, imported eagerly
    from .batch import Cohort, cohort_report, fit_many, read_manifest  # noqa: F401
    from .diagnosis import DiagnosedData, Diagnosis, diagnose, diagnose_data  # noqa: F401
    from .effects import (EFFECTS, Effect, Gravity, NodeDrag,  # noqa: F401
                          NonlinearStiffening, SoftInclusion, StiffInclusion, UnmodeledLoad)
    from .errors import InputError, NeurofuzzyError, UnstableTimeStepError  # noqa: F401
    from .experiment import (Experiment, check_experiments, rms_error,  # noqa: F401
                             simulate_experiment, simulate_like)
    from .export import export, export_paraview  # noqa: F401
    from .forces import ForceTerm, Springs, Tetrahedra  # noqa: F401
    from .io import load_experiment, load_model, save_experiment, save_model  # noqa: F401
    from .learn import GradientLearner, PaperLearner, StartModel, estimate_start  # noqa: F401
    from .markers import markers_to_experiment, read_markers  # noqa: F401
    from .mesh import (Mesh, bottom_layer, from_surface_tetra, from_tetra,  # noqa: F401
                       from_trimesh, lattice, surface_nodes)
    from .mesh import MeshFile, read_mesh  # noqa: F401
    from .model import Model  # noqa: F401
    from .observation import EmbeddedMarkers, Observation, embed_points  # noqa: F401
    from .pipeline import (FitFailedError, FitOptions, FitOutcome, fit,  # noqa: F401
                           start_model)
    from .validation.integrators import reference_experiment, reference_simulate  # noqa: F401
    from .report import diagnosis_report, fit_report  # noqa: F401
    from .rules import load_rules  # noqa: F401
    from .rules import shipped as shipped_rules  # noqa: F401
    from .tissues import initialize, material_values, materials  # noqa: F401
    from .rulestudio import studio  # noqa: F401
    from .simulation import State, Trajectory, simulate, stability_limit  # noqa: F401
    from .simulation import Driven, equilibrium  # noqa: F401
    from .load_steps import DrivenPath, LoadSteps, simulate_load_steps  # noqa: F401
    from .io import load_load_steps, save_load_steps  # noqa: F401
    from .learn.load_step_fit import fit_load_steps  # noqa: F401
    from .learn.load_step_mesh_check import with_mesh_check as load_step_mesh_check  # noqa
    from .diagnosis.load_steps import diagnose_load_steps  # noqa: F401
    from .diagnosis.moving import diagnose_moving  # noqa: F401
    from .report.load_steps import load_steps_report  # noqa: F401

from .version import __version__  # noqa: E402, F401  (the package's version, public)

# the function, set over the package of the same name (see the module docstring)
from .export import export  # noqa: E402, F401

__all__ = sorted(_EXPORTS)
