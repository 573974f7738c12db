"""Compiled inner loops (numba) of :class:`neurofuzzy.simulation.steppers.NumbaStepper`.

Module-level so that ``cache=True`` keeps the machine code between runs. The springs'
arithmetic is that of :class:`neurofuzzy.forces.Springs` (tested equal); the elements' forces
are :mod:`neurofuzzy.kernels.element_forces`; the update is
:func:`neurofuzzy.kernels.integrator.euler_update`. :func:`frames` drives :func:`advance`
over the frames of a run, for :func:`neurofuzzy.simulate` and the learners.
"""

import numba
import numpy as np

from .element_forces import element_forces
from .integrator import euler_update
from .springs import magnitude


@numba.njit(cache=True, nogil=True, inline="always")
def spring_state(p, v, ia, ib, stiffness, damping, rest, cubic):
    """The spring force of paper eqs. 3.4–3.6 with the spring effects' strain stiffening,
    once for every sweep: direction ``u``, length ``l``, closing speed ``(v_b - v_a)·u``,
    stretch ``x = l - L0``, the magnitude ``m`` and its length derivative
    (:func:`neurofuzzy.kernels.springs.magnitude`), as ``(ux, uy, uz, length, closing,
    stretch, magnitude, slope)``: ``stiffness`` holds the spring inclusions' extra
    stiffness, ``cubic`` the stiffening's ``q = κ / L0²`` (0 for none)."""
    dx = p[ib, 0] - p[ia, 0]
    dy = p[ib, 1] - p[ia, 1]
    dz = p[ib, 2] - p[ia, 2]
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    ux, uy, uz = dx / length, dy / length, dz / length
    closing = ((v[ib, 0] - v[ia, 0]) * ux + (v[ib, 1] - v[ia, 1]) * uy
               + (v[ib, 2] - v[ia, 2]) * uz)
    stretch = length - rest
    value, slope = magnitude(stiffness, damping, cubic, stretch, closing)
    return ux, uy, uz, length, closing, stretch, value, slope


@numba.njit(cache=True, nogil=True, inline="always")
def _spring(p, v, ia, ib, stiffness, damping, rest, cubic, force):
    """One spring's force ``m u`` (:func:`spring_state`) added to ``force`` (node a +,
    node b -); returns :func:`spring_state`'s values."""
    ux, uy, uz, length, closing, stretch, magnitude, slope = spring_state(
        p, v, ia, ib, stiffness, damping, rest, cubic)
    fx, fy, fz = magnitude * ux, magnitude * uy, magnitude * uz
    force[ia, 0] += fx
    force[ia, 1] += fy
    force[ia, 2] += fz
    force[ib, 0] -= fx
    force[ib, 1] -= fy
    force[ib, 2] -= fz
    return ux, uy, uz, length, closing, stretch, magnitude, slope


@numba.njit(cache=True, nogil=True)
def _springs(p, v, a, b, stiffness, damping, rest, cubic, force):
    """Every spring's force added to ``force`` (:func:`_spring`); ``cubic`` holds the ``q``
    of the last ``len(cubic)`` springs (the second force along each spring that stiffens,
    :func:`neurofuzzy.effects.compiled.spring_entries`), the others' ``q = 0`` is compiled
    in (reading ``q`` for every spring costs 6–13 % of the rate)."""
    plain = a.shape[0] - cubic.shape[0]
    for j in range(plain):
        _spring(p, v, a[j], b[j], stiffness[j], damping[j], rest[j], 0.0, force)
    for j in range(plain, a.shape[0]):
        _spring(p, v, a[j], b[j], stiffness[j], damping[j], rest[j], cubic[j - plain], force)


@numba.njit(cache=True, nogil=True)
def advance(state, springs, elements, relaxation, terms, load, h, n_steps, scratch):
    """``n_steps`` steps of ``h`` from ``state = (p, v)`` (in place) under ``load`` (N, 3).
    The model as :class:`neurofuzzy.simulation.steppers.NumbaStepper` lays it out: ``springs
    = (a, b, stiffness, damping, rest, cubic)``; ``elements`` (``ElementArrays``), None for a
    model without them (numba prunes a branch on an argument that is None: no element code
    compiled); ``relaxation = (g, a, history)`` (:mod:`.element_forces`); ``terms = (W, drag,
    kappa)``: inverse masses (0 at fixed nodes), a node drag ``-drag v``, the elements' strain
    stiffening. ``scratch = (force, node_strain, buffers)``: ``force`` is left holding the last
    step's; ``buffers`` None for one thread, else the element passes' per-thread scratch."""
    p, v = state
    a, b, stiffness, damping, rest, cubic = springs
    weight, drag, kappa = terms
    force, node_strain, buffers = scratch
    n_nodes = p.shape[0]
    for _ in range(n_steps):
        for i in range(n_nodes):
            for k in range(3):
                force[i, k] = load[i, k]
        if drag != 0.0:                # most models have none (2 % of the cube's step rate)
            for i in range(n_nodes):
                for k in range(3):
                    force[i, k] -= drag * v[i, k]
        _springs(p, v, a, b, stiffness, damping, rest, cubic, force)
        if elements is not None:       # None: no elements, and no element code compiled
            element_forces(p, v, elements, node_strain, relaxation, kappa, force, buffers)
        euler_update(p, v, force, weight, h)


@numba.njit(cache=True, nogil=True)
def frames(state, springs, elements, relaxation, terms, run, windows, out, kept, scratch):
    """The frames of a run, ``substeps`` steps of :func:`advance` each (the model's groups and
    ``scratch`` as there): the one driver of the forward run of :func:`neurofuzzy.simulate`
    and of the adjoint's forward sweep (:mod:`neurofuzzy.kernels.adjoint`).

    ``run = (loads, h, n_frames, substeps)``: ``loads[t - 1]`` acts from frame ``t - 1`` to
    ``t`` (the last load on). ``out = (positions, velocities)``: the positions (and, when
    ``velocities`` is not empty, velocities) of every frame (n_frames, N, 3), NaN from where
    the run leaves the finite numbers. The internal variables are carried through. Without
    elements (None) the demo's first run compiles for 30 s instead of 137 s.

    ``windows = (start_index, start_p, start_v)``, ``start_index`` (n_frames,) int, empty
    for one run from ``state``: frames ``t`` with ``start_index[t] >= 0`` start a window from
    the state ``start_p``, ``start_v`` of that index (the learners' windows; frame 0 is
    always one); the internal variables go on. ``kept = (states_p, states_v, states_r,
    states_f)``: ``states_p``, ``states_v`` ((n_frames - 1) substeps, N, 3; empty: none
    kept) receive the state at the start of every substep in time order (a window's first
    frame's left unset), ``states_r`` the internal variables there and ``states_f`` (when
    not empty) every substep's force: what the adjoint's backward sweep runs over.
    """
    p, v = state
    loads, h, n_frames, substeps = run
    start_index, start_p, start_v = windows
    positions, velocities = out
    states_p, states_v, states_r, states_f = kept
    relax_g, history = relaxation[0], relaxation[2]
    force = scratch[0]
    windowed = start_index.shape[0] > 0
    keep = states_p.shape[0] > 0
    step = 0
    for t in range(n_frames):
        if windowed and start_index[t] >= 0:
            p[:] = start_p[start_index[t]]
            v[:] = start_v[start_index[t]]
            if t > 0:
                step += substeps
        elif t > 0:
            load = loads[min(t - 1, loads.shape[0] - 1)]
            # substeps at once, or (keeping every substep's state) one at a time
            at_once = 1 if keep else substeps
            for _ in range(substeps // at_once):
                if keep:
                    states_p[step] = p
                    states_v[step] = v
                    if relax_g.shape[1]:
                        states_r[step] = history
                advance(state, springs, elements, relaxation, terms, load, h, at_once,
                        scratch)
                if states_f.shape[0]:               # (kept only with the states)
                    states_f[step] = force          # the step's force (advance leaves it)
                step += 1
            if not np.isfinite(p.sum()):
                positions[t:] = np.nan
                if velocities.shape[0]:
                    velocities[t:] = np.nan
                return
        positions[t] = p
        if velocities.shape[0]:
            velocities[t] = v
