"""MuJoCo (MJCF): the model as point-mass bodies, tetrahedral flexes and spring tendons, and a
runner that simulates an exported file under an experiment's load (:func:`simulate_mujoco`).

Every node that moves is a body ``node{i}`` with its mass and three slide joints (MuJoCo's
``flexcomp`` gives every point the same mass; our lumped masses differ, so the bodies are
written out). Fixed nodes are vertices of the world body. Elements become ``<flex dim="3">``
with ``<elasticity young poisson damping>``: MuJoCo's flex elasticity is St. Venant–Kirchhoff
on linear tetrahedra, its force a quadratic form in the edges' squared-length changes
(``engine_passive.c``, ``mj_flexPassiveStretch``; the metric from ``user_mesh.cc``,
``ComputeStiffness``) that equals our textbook element (``Tetrahedra(volumetric="element")``) to
round-off, and its ``damping`` the Rayleigh factor β = η/E applied to the rate of the
squared lengths, as our Kelvin–Voigt viscosity is; the rate is a backward difference over one
time step, ``(l² - (l - l̇ h)²) / h = 2 l l̇ - h l̇²``, so damping differs from ours by the
second-order term ``h l̇²``. MuJoCo's default integrator (``Euler``, without joint damping)
is semi-implicit Euler, as ours.

One flex has one material. Regions (and elements of a region with different values) become
one flex each, all sharing the node bodies, so every element keeps its own E, ν, β up to
``max_materials`` flexes (beyond that, elements are binned: see
:func:`~neurofuzzy.export.base.material_groups`). Flexes collide with ordinary geoms
(``contype=2 conaffinity=1``) but not with each other, since flexes of neighbouring regions
share vertices; self-collision is off (our models have no self-contact).

Springs with stiffness or damping become spatial tendons between sites on the node bodies,
with the spring's own stiffness, damping and rest length (a tendon's force is
``-s (l - L0) - c l̇`` along it, the paper's spring).
"""

from __future__ import annotations

import json
import os
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import InputError
from ..forces.springs import spring_constants
from .base import material_groups, prepare, time_step
from .metadata import (header_lines, law_note, metadata, relaxation_note,
                       volumetric_note)

__all__ = ["mjcf", "simulate_mujoco"]

#: The flexes' collision bits: they collide with default geoms (contype 1, conaffinity 1),
#: not with each other.
FLEX_CONTYPE, FLEX_CONAFFINITY = 2, 1


def _numbers(values) -> str:
    return " ".join(map(repr, np.asarray(values, dtype=float).ravel().tolist()))


def mjcf(model, *, experiment=None, fit: dict | None = None, substeps="auto",
         name: str = "tissue", max_materials: int = 256) -> tuple[str, list[str]]:
    """The MJCF text of ``model`` and the notes on what it could not express.

    Parameters
    ----------
    model : Model
    experiment : Experiment, optional
        Sets the time step (``experiment.dt / substeps``) and lets the header measure what
        the volumetric form changes.
    fit : dict, optional
        The model file's fit record (its lack of fit goes into the header). A record of a fit
        for MuJoCo (``fit --target mujoco``, its ``target``) sets the time step and
        integrator it was fitted for.
    substeps : int or "auto"
        Steps per frame of the experiment (``"auto"``: the fewest stable ones).
    name : str
        The MJCF model name.
    max_materials : int
        Most flexes (distinct element materials) written.

    Returns
    -------
    text : str
    notes : list of str
    """
    prepared = prepare(model)
    runs = prepared.model
    if runs.elements is not None:
        runs = runs.with_elements(volumetric="element")
    aimed = (fit or {}).get("target") or {}
    notes = list(prepared.notes)
    if aimed.get("simulator") == "mujoco":            # fitted for MuJoCo's element and step
        h, steps, integrator = float(aimed["dt"]), None, str(aimed["integrator"])
        notes.append(f"time step {h:g} s and the {integrator} integrator: E, nu and eta were "
                     "fitted for them (fit --target mujoco); run it at that step")
    else:
        (h, steps), integrator = time_step(runs, experiment, substeps), "Euler"
    if np.any(prepared.constant_load):
        notes.append("unmodeled_load: MJCF holds no constant force; apply it with "
                     "data.xfrc_applied (see simulate_mujoco)")
    for note in (volumetric_note(prepared.model, "MuJoCo", experiment, steps),
                 law_note(prepared.model, "MuJoCo", "flex elasticity (linear St. Venant-"
                          "Kirchhoff tetrahedra)", experiment, steps),
                 relaxation_note(prepared.model, "MuJoCo", experiment, steps)):
        if note:
            notes.append(note)
    groups = []
    if runs.elements is not None:
        groups, merged = material_groups(runs, max_materials)
        notes += merged
        notes.append(f"{len(groups)} flex(es), one per region and material; a flex has one "
                     "material in MuJoCo")
    if prepared.node_drag:
        notes.append("node_drag is joint damping on the slide joints, which MuJoCo's Euler "
                     "integrator treats implicitly (ours explicitly)")

    mesh = runs.mesh
    rest = np.asarray(mesh.rest_positions, dtype=float)
    fixed = np.zeros(runs.n_nodes, bool)
    fixed[mesh.fixed] = True
    spring_stiffness, spring_damping, spring_rest = spring_constants(runs)
    springs = np.flatnonzero((spring_stiffness > 0) | (spring_damping > 0))
    with_site = np.zeros(runs.n_nodes, bool)
    with_site[mesh.springs[springs].ravel()] = True

    block = metadata(model, target="mujoco", fit=fit, notes=notes, experiment=experiment,
                     time_step=h, steps=steps)
    comment = "\n".join(header_lines(model, target="mujoco", fit=fit, notes=notes,
                                     experiment=experiment, time_step=h, steps=steps))
    out = [f"<mujoco model={quoteattr(name)}>",
           "<!--\n" + comment.replace("--", "- -") + "\n-->",
           f'  <option timestep="{h!r}" integrator="{integrator}" '
           f'gravity="{_numbers(prepared.gravity)}"/>',
           "  <custom>",
           f"    <text name=\"neurofuzzy\" data={quoteattr(json.dumps(block))}/>",
           "  </custom>",
           "  <worldbody>"]
    out += [f'    <site name="node{i}" pos="{_numbers(rest[i])}"/>'
            for i in np.flatnonzero(fixed & with_site)]
    inertia = repr(float(np.max(runs.node_mass)) * 1e-6)   # unused by slide joints; must be > 0
    drag = f' damping="{prepared.node_drag!r}"' if prepared.node_drag else ""
    for i in np.flatnonzero(~fixed):
        joints = "".join(f'<joint name="node{i}_{axis}" type="slide" axis="{vector}"{drag}/>'
                         for axis, vector in (("x", "1 0 0"), ("y", "0 1 0"), ("z", "0 0 1")))
        site = f'<site name="node{i}"/>' if with_site[i] else ""
        out.append(f'    <body name="node{i}" pos="{_numbers(rest[i])}"><inertial pos="0 0 0" '
                   f'mass="{float(runs.node_mass[i])!r}" diaginertia="{inertia} {inertia} '
                   f'{inertia}"/>{joints}{site}</body>')
    out.append("  </worldbody>")
    if groups:
        radius = 0.05 * float(np.median(mesh.rest_lengths))
        out.append("  <deformable>")
        for group in groups:
            out.append(_flex(group, mesh.tetrahedra, rest, fixed, radius))
        out.append("  </deformable>")
    if springs.size:
        width = 0.02 * float(np.median(mesh.rest_lengths))
        out.append("  <tendon>")
        for j in springs:
            a, b = mesh.springs[j]
            stiffness, damping, rest = (float(spring_stiffness[j]), float(spring_damping[j]),
                                        float(spring_rest[j]))
            out.append(f'    <spatial name="spring{j}" stiffness="{stiffness!r}" '
                       f'damping="{damping!r}" springlength="{rest!r}" width="{width!r}">'
                       f'<site site="node{a}"/><site site="node{b}"/></spatial>')
        out.append("  </tendon>")
    out.append("</mujoco>")
    return "\n".join(out) + "\n", notes


def _flex(group, tetrahedra, rest, fixed, radius) -> str:
    corners = np.asarray(tetrahedra)[group.elements]                  # (n, 4) global nodes
    vertices, local = np.unique(corners, return_inverse=True)
    bodies = " ".join("world" if fixed[v] else f"node{v}" for v in vertices)
    coordinates = np.where(fixed[vertices, None], rest[vertices], 0.0)
    return (f'    <flex name={quoteattr(group.name)} dim="3" radius="{radius!r}" '
            f'body="{bodies}" vertex="{_numbers(coordinates)}" '
            f'element="{" ".join(map(str, local.ravel().tolist()))}">'
            f'<contact contype="{FLEX_CONTYPE}" conaffinity="{FLEX_CONAFFINITY}" '
            f'selfcollide="none"/>'
            f'<elasticity young="{group.youngs_modulus!r}" poisson="{group.poisson_ratio!r}" '
            f'damping="{group.damping_time!r}"/></flex>')


def simulate_mujoco(mjcf_file, experiment, *, constant_load=None) -> np.ndarray:
    """Run an exported MJCF under an experiment's load, frame by frame, in MuJoCo.

    Parameters
    ----------
    mjcf_file : path or str
        A file written by :func:`neurofuzzy.export` (``to="mujoco"``), or its text.
    experiment : Experiment
        The load (``external_forces``, applied to the node bodies through
        ``data.xfrc_applied``, held for a frame as our stepper holds it), the initial
        positions and the frame spacing ``dt``, a whole multiple of the file's time step, or
        a whole fraction of it (a file fitted for a simulator's step, ``fit --target``): then
        one step per ``k`` frames under their mean load, as
        :func:`neurofuzzy.simulation.resampling.resampled` takes them.
    constant_load : (n_nodes, 3) float, optional
        N, added to the load at every frame (an ``unmodeled_load`` effect).

    Returns
    -------
    (n_frames, n_nodes, 3) float
        Node positions at every frame (at every ``k``-th frame for a step of ``k`` frames);
        fixed nodes stay at their rest positions.
    """
    from ..extras import require

    require("export", "simulate_mujoco (MuJoCo runs the file)")
    import mujoco

    text = str(mjcf_file)
    if text.lstrip().startswith("<"):
        handle = mujoco.MjModel.from_xml_string(text)
    else:
        handle = mujoco.MjModel.from_xml_path(os.fspath(mjcf_file))
    data = mujoco.MjData(handle)
    frames_per_step = handle.opt.timestep / experiment.dt
    if round(frames_per_step) > 1 and abs(frames_per_step - round(frames_per_step)) \
            <= 1e-6 * frames_per_step:
        from ..simulation.resampling import resampled

        experiment = resampled(experiment, experiment.dt * round(frames_per_step))
    steps = experiment.dt / handle.opt.timestep
    if abs(steps - round(steps)) > 1e-6 * steps:
        raise InputError(f"the experiment's frame spacing {experiment.dt} s is not a whole "
                         f"number of the model's time step {handle.opt.timestep} s; export "
                         "the model with this experiment", key="dt")
    steps = int(round(steps))
    n_nodes = experiment.n_nodes
    bodies = np.array([mujoco.mj_name2id(handle, mujoco.mjtObj.mjOBJ_BODY, f"node{i}")
                       for i in range(n_nodes)])
    moving = np.flatnonzero(bodies >= 0)
    if moving.size != handle.nbody - 1:
        raise InputError(f"the model has {handle.nbody - 1} bodies, the experiment "
                         f"{moving.size} moving nodes; export the model of this experiment",
                         key="rest_positions")
    address = handle.jnt_qposadr[handle.body_jntadr[bodies[moving]]]
    qpos = (address[:, None] + np.arange(3)).ravel()
    dofs = (handle.jnt_dofadr[handle.body_jntadr[bodies[moving]]][:, None] + np.arange(3)).ravel()
    rest = np.asarray(experiment.mesh.rest_positions, dtype=float)
    data.qpos[qpos] = (experiment.initial_positions()[moving] - rest[moving]).ravel()
    data.qvel[dofs] = 0.0
    forces = experiment.forces_per_frame()
    if constant_load is not None:
        forces = forces + np.asarray(constant_load, dtype=float)[None]
    positions = np.repeat(rest[None], experiment.n_frames, axis=0)
    positions[0] = experiment.initial_positions()
    for frame in range(1, experiment.n_frames):
        data.xfrc_applied[bodies[moving], :3] = forces[frame - 1, moving]
        mujoco.mj_step(handle, data, nstep=steps)
        positions[frame, moving] = rest[moving] + data.qpos[qpos].reshape(-1, 3)
    return positions
