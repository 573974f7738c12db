"""SOFA: a SofaPython3 scene (``createScene(root)``) of the model.

Components and data fields as SOFA v24.12 and later define them (their ``initData`` names,
read from the sources of ``sofa-framework/sofa``; ``tests/test_export_formats.py`` runs the
scene's ``createScene`` on a stand-in for SOFA's root node and checks every component, field
and plugin against a table taken from those sources):

- ``EulerImplicitSolver`` with ``rayleighStiffness`` β = η/E and ``CGLinearSolver``;
- ``TetrahedronSetTopologyContainer`` (``position``, ``tetrahedra``) or, for spring networks,
  ``EdgeSetTopologyContainer`` (``position``, ``edges``), with their geometry algorithms;
- ``MechanicalObject`` (``position``), ``DiagonalMass`` (``vertexMass``: our lumped node
  masses), ``FixedProjectiveConstraint`` (``indices``);
- ``TetrahedronFEMForceField`` (``method="polar"``: corotational linear elasticity with the
  rotation of each element's polar decomposition, our ``corotational`` law, exactly) with
  ``youngModulus`` and ``poissonRatio`` per element (both vectors since v24.12; a single
  value when they are uniform, which older versions read too);
- ``SpringForceField`` with ``spring="i j stiffness damping rest_length …"`` (per spring);
- the experiment's load as a ``ConstantForceField`` on the loaded nodes whose ``forces`` a
  ``Sofa.Core.Controller`` sets at the start of every step from the frame's row, held for a
  frame as our stepper holds it.

What SOFA does differently: its tetrahedron is corotational linear elasticity, our
``corotational`` law (``--law corotational``; other laws are written as it, equal at small
strain, and the notes measure how far they part), and the textbook per-element one (our
``Tetrahedra(volumetric="element")``); the
Rayleigh damping factor is one per solver, so regions with different η/E share their
volume-weighted mean; the implicit Euler integrator damps numerically where our semi-implicit
Euler does not. The scene was not run here (SOFA is not installable with pip).
"""

from __future__ import annotations

import json

import numpy as np

from ..forces.springs import spring_constants
from .base import load_components, prepare, time_step
from .metadata import (header_lines, law_note, metadata, relaxation_note,
                       volumetric_note)

__all__ = ["scene", "PLUGINS"]

#: The SOFA module (``RequiredPlugin``) of every component the scene may create, from the
#: layout of the SOFA sources (``Sofa/Component/<Module>/src/...``); ``DefaultAnimationLoop``
#: is part of SOFA's core.
PLUGINS = {
    "EulerImplicitSolver": "Sofa.Component.ODESolver.Backward",
    "CGLinearSolver": "Sofa.Component.LinearSolver.Iterative",
    "TetrahedronSetTopologyContainer": "Sofa.Component.Topology.Container.Dynamic",
    "TetrahedronSetGeometryAlgorithms": "Sofa.Component.Topology.Container.Dynamic",
    "EdgeSetTopologyContainer": "Sofa.Component.Topology.Container.Dynamic",
    "EdgeSetGeometryAlgorithms": "Sofa.Component.Topology.Container.Dynamic",
    "MechanicalObject": "Sofa.Component.StateContainer",
    "DiagonalMass": "Sofa.Component.Mass",
    "FixedProjectiveConstraint": "Sofa.Component.Constraint.Projective",
    "TetrahedronFEMForceField": "Sofa.Component.SolidMechanics.FEM.Elastic",
    "SpringForceField": "Sofa.Component.SolidMechanics.Spring",
    "ConstantForceField": "Sofa.Component.MechanicalLoad",
}


def _array(values, digits: bool = True) -> str:
    """A nested Python list literal of ``values`` (floats exact by ``repr``)."""
    values = np.asarray(values)
    return json.dumps(values.tolist() if digits else values.astype(int).tolist())


def scene(model, *, experiment=None, fit: dict | None = None, substeps="auto",
          max_materials: int = 256) -> tuple[str, list[str]]:
    """The SofaPython3 scene text of ``model`` and the notes on what it could not express.

    Parameters are those of :func:`neurofuzzy.export.mujoco.mjcf` (``max_materials`` is
    unused: SOFA takes a Young's modulus and Poisson's ratio per element).
    """
    prepared = prepare(model)
    runs = prepared.model
    if runs.elements is not None:
        runs = runs.with_elements(volumetric="element")
    aimed = (fit or {}).get("target") or {}
    notes = list(prepared.notes)
    if aimed.get("simulator") == "sofa":              # fitted for SOFA's element and step
        h, steps = float(aimed["dt"]), None
        notes.append(f"time step {h:g} s: E, nu and eta were fitted for SOFA's implicit Euler "
                     "step and corotational element at it (fit --target sofa); run it at "
                     "that step")
    else:
        h, steps = time_step(runs, experiment, substeps)
    if prepared.node_drag:
        notes.append("node_drag is not exported: SOFA's Rayleigh mass damping is "
                     "proportional to each node's mass, the drag is not")
    for note in (volumetric_note(prepared.model, "SOFA", experiment, steps),
                 law_note(prepared.model, "SOFA", "TetrahedronFEMForceField (corotational "
                          "linear elasticity, method 'polar')", experiment, steps,
                          native="corotational"),
                 relaxation_note(prepared.model, "SOFA", experiment, steps)):
        if note:
            notes.append(note)
    mesh = runs.mesh
    elements = runs.elements is not None
    stiffness, damping, rest_length = spring_constants(runs)
    beta = 0.0
    if elements:
        from ..forces import tetrahedron_geometry

        volume = tetrahedron_geometry(mesh).volume
        ratio = runs.elements.viscosity / runs.elements.youngs_modulus
        beta = float(volume @ ratio / volume.sum())
        if not np.allclose(ratio, beta, rtol=1e-9, atol=0):
            notes.append(f"Rayleigh stiffness damping is one value per solver in SOFA: the "
                         f"elements' eta/E ({ratio.min():.4g} .. {ratio.max():.4g} s) merged "
                         f"into their volume-weighted mean {beta:.6g} s")
        if beta > 0 and np.any(stiffness > 0):
            notes.append("the solver's Rayleigh damping also damps the springs (beta times "
                         "their stiffness), which neurofuzzy does not")
    springs = np.flatnonzero((stiffness > 0) | (damping > 0))
    load_nodes, load = _load(prepared, experiment)

    block = metadata(model, target="sofa", fit=fit, notes=notes, experiment=experiment,
                     time_step=h, steps=steps)
    header = header_lines(model, target="sofa", fit=fit, notes=notes, experiment=experiment,
                          time_step=h, steps=steps)
    used = ["EulerImplicitSolver", "CGLinearSolver", "MechanicalObject", "DiagonalMass",
            "TetrahedronSetTopologyContainer" if elements else "EdgeSetTopologyContainer"]
    used += ["FixedProjectiveConstraint"] if len(mesh.fixed) else []
    used += ["TetrahedronFEMForceField"] if elements else []
    used += ["SpringForceField"] if springs.size else []
    used += ["ConstantForceField"] if load_nodes.size else []
    plugins = sorted({PLUGINS[name] for name in used})
    spring_rows = np.column_stack([mesh.springs[springs], stiffness[springs], damping[springs],
                                   rest_length[springs]])
    spring_text = " ".join(f"{int(a)} {int(b)} {k!r} {c!r} {rest!r}"
                           for a, b, k, c, rest in spring_rows.tolist())
    frame_dt = experiment.dt if experiment is not None else h
    lines = ['"""A SofaPython3 scene of a neurofuzzy model: runSofa tissue.py',
             "", *header, '"""', "",
             f"NEUROFUZZY = json.loads({json.dumps(json.dumps(block))})",
             f"TIME_STEP = {h!r}              # s",
             f"GRAVITY = {_array(prepared.gravity)}   # m/s^2",
             f"PLUGINS = {json.dumps(plugins)}",
             f"POSITIONS = {_array(mesh.rest_positions)}   # m",
             f"NODE_MASS = {_array(runs.node_mass)}   # kg",
             f"FIXED = {_array(mesh.fixed, False)}"]
    if elements:
        lines += [f"TETRAHEDRA = {_array(mesh.tetrahedra, False)}",
                  f"YOUNGS_MODULUS = {_uniform_or_list(runs.elements.youngs_modulus)}   # Pa",
                  f"POISSON_RATIO = {_uniform_or_list(runs.elements.poisson_ratio)}",
                  f"RAYLEIGH_STIFFNESS = {beta!r}   # s, eta / E",
                  f"REGION_NAMES = {json.dumps(list(runs.region_names))}",
                  f"ELEMENT_REGION = {_array(runs.elements.region, False)}   # index into "
                  "REGION_NAMES (information: SOFA takes E and nu per element)"]
    else:
        lines += [f"EDGES = {_array(mesh.springs, False)}", "RAYLEIGH_STIFFNESS = 0.0"]
    lines += [f'SPRINGS = "{spring_text}"   # i j stiffness (N/m) damping (N s/m) rest length (m)',
              f"LOAD_NODES = {_array(load_nodes, False)}",
              f"LOAD = {_array(load)}   # N, per frame and loaded node",
              f"FRAME_DT = {frame_dt!r}   # s, each row of LOAD is held for one frame",
              "", _SCENE_CODE]
    lines.insert(lines.index('"""', 1) + 1, "\nimport json")
    return "\n".join(lines), notes


def _uniform_or_list(values: np.ndarray) -> str:
    if np.allclose(values, values[0], rtol=1e-12, atol=0):
        return repr(float(values[0]))
    return _array(values)


def _load(prepared, experiment) -> tuple[np.ndarray, np.ndarray]:
    """The loaded nodes and the load (n_frames, n_loaded, 3) N held frame by frame."""
    constant = prepared.constant_load
    if experiment is None:
        forces = constant[None]
    else:
        forces = experiment.forces_per_frame() + constant[None]
    curves, patterns = load_components(forces)
    nodes = np.flatnonzero(np.any(patterns != 0, axis=(0, 2))) if len(patterns) else \
        np.zeros(0, int)
    return nodes, forces[:, nodes]


_SCENE_CODE = '''
def createScene(root):
    """The tissue under the recorded load (SofaPython3 calls this with the root node)."""
    root.dt = TIME_STEP
    root.gravity = GRAVITY
    root.addObject("RequiredPlugin", pluginName=PLUGINS)
    root.addObject("DefaultAnimationLoop")
    tissue = root.addChild("tissue")
    tissue.addObject("EulerImplicitSolver", rayleighStiffness=RAYLEIGH_STIFFNESS,
                     rayleighMass=0.0)
    tissue.addObject("CGLinearSolver", iterations=1000, tolerance=1e-12, threshold=1e-30)
    if "TETRAHEDRA" in globals():
        tissue.addObject("TetrahedronSetTopologyContainer", name="topology",
                         position=POSITIONS, tetrahedra=TETRAHEDRA)
        tissue.addObject("TetrahedronSetGeometryAlgorithms", template="Vec3d")
    else:
        tissue.addObject("EdgeSetTopologyContainer", name="topology", position=POSITIONS,
                         edges=EDGES)
        tissue.addObject("EdgeSetGeometryAlgorithms", template="Vec3d")
    tissue.addObject("MechanicalObject", name="dofs", template="Vec3d", position=POSITIONS)
    tissue.addObject("DiagonalMass", vertexMass=NODE_MASS)
    if FIXED:
        tissue.addObject("FixedProjectiveConstraint", indices=FIXED)
    if "TETRAHEDRA" in globals():
        tissue.addObject("TetrahedronFEMForceField", name="elements", method="polar",
                         youngModulus=YOUNGS_MODULUS, poissonRatio=POISSON_RATIO)
    if SPRINGS:
        tissue.addObject("SpringForceField", name="springs", spring=SPRINGS)
    if LOAD_NODES:
        load = tissue.addObject("ConstantForceField", name="load", indices=LOAD_NODES,
                                forces=LOAD[0])
        root.addObject(_load_curve(root, load))
    return root


def _load_curve(root, load):
    """A controller that holds row t of LOAD from frame t to t + 1; a step longer than a frame
    (a file fitted for SOFA's step) takes the mean of its frames' rows, as the fit did."""
    import Sofa.Core

    frames = max(1, int(round(TIME_STEP / FRAME_DT)))

    class LoadCurve(Sofa.Core.Controller):
        def onAnimateBeginEvent(self, event):
            frame = min(int(root.time.value / FRAME_DT + 1e-9), len(LOAD) - 1)
            rows = LOAD[frame:frame + frames]
            load.forces.value = [[sum(row[node][k] for row in rows) / len(rows)
                                  for k in range(3)] for node in range(len(rows[0]))]

    return LoadCurve(name="loadCurve")
'''
