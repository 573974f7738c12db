"""Compiled forward sensitivities (numba) of :class:`neurofuzzy.learn.Sensitivity`.

One call runs a whole experiment: every frame and substep of semi-implicit Euler for the
state and its tangents along every parameter direction, with the observation operator
applied at every frame, so no Python runs per time step. The arithmetic is that of the numpy
reference path (:meth:`neurofuzzy.forces.Springs.state_jvp`, ``parameter_templates`` and
:meth:`neurofuzzy.forces.Tetrahedra.state_jvp`, ``parameter_jvp``; tested equal):

- springs ``f = (s x + c ((v_b - v_a)·u) + q x³) u`` (``x = l - L0``; ``s`` with the
  spring inclusions' extra stiffness, ``q = κ / L0²`` the spring stiffening's, a second
  entry of the spring list), parameters ``log s`` and ``log c`` of the spring's tie group
  and the spring effects' coefficients (a CSR per spring, :func:`_spring_tangents`);
- tetrahedral elements of each element's law (:mod:`neurofuzzy.kernels.laws`; module
  :mod:`neurofuzzy.forces.tetrahedra`), parameters ``log E``, ``logit 2ν`` and ``log η`` of
  the element's tie group; the volumetric ``π``, ``π̇`` per element or from the node averages
  (two passes over the elements; :mod:`neurofuzzy.kernels.element_jvp`, on several threads
  for a large model).

Layout for speed: the tangents are ``(N, 3, P)``, parameters last, so the loop over the
parameters of one spring reads and writes contiguous memory without a branch (it vectorises);
an element's 3×3 matrices (F, Ḟ, S and their tangents) are tuples of nine scalars that stay
in registers, as in the simulation kernel (:mod:`neurofuzzy.kernels.stepper`).

Imported only when numba is installed (module-level, ``cache=True``).
"""

import numba
import numpy as np

from .element_jvp import CONTRACT, element_jvp
from .integrator import euler_update
from .springs import partial
from .stepper import _spring


# -- springs -----------------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def _spring_tangents(p, v, tp, tv, a, b, stiffness, damping, rest, cubic, spring_ptr,
                     spring_column, spring_basis, spring_factor, first, force, d_force, work):
    """Spring forces into ``force`` and their tangents into ``d_force`` (N, 3, P), tangent
    ``q`` that of parameter ``first + q``; ``work`` (3, P) holds one spring's tangent
    force. The parameters' derivatives of spring ``j``'s magnitude are the CSR entries
    ``spring_ptr[j] .. spring_ptr[j + 1]``: ``factor · basis`` for parameter ``column``, basis
    0 the stretch ``x``, 1 the closing speed, 2 ``x³`` (:func:`.springs.partial`;
    ``log s`` has the factor ``s``, an inclusion's ``k`` the factor 1, a stiffening's ``κ``
    the factor ``1 / L0²`` of basis 2, ``x³``). ``cubic`` holds the ``q`` of the last
    springs, as in :func:`.stepper._springs`."""
    n_params = tp.shape[2]
    tx, ty, tz = work[0], work[1], work[2]     # the spring's tangent force
    plain = a.shape[0] - cubic.shape[0]        # the last springs' q: cubic
    for j in range(a.shape[0]):
        ia, ib = a[j], b[j]
        ux, uy, uz, length, closing, stretch, magnitude, slope = _spring(
            p, v, ia, ib, stiffness[j], damping[j], rest[j],
            cubic[j - plain] if j >= plain else 0.0, force)
        if n_params == 0:
            continue
        c = damping[j]
        inverse = 1.0 / length
        wx = v[ib, 0] - v[ia, 0]
        wy = v[ib, 1] - v[ia, 1]
        wz = v[ib, 2] - v[ia, 2]
        pax, pay, paz = tp[ia, 0], tp[ia, 1], tp[ia, 2]
        pbx, pby, pbz = tp[ib, 0], tp[ib, 1], tp[ib, 2]
        vax, vay, vaz = tv[ia, 0], tv[ia, 1], tv[ia, 2]
        vbx, vby, vbz = tv[ib, 0], tv[ib, 1], tv[ib, 2]
        for q in range(n_params):
            ddx = pbx[q] - pax[q]
            ddy = pby[q] - pay[q]
            ddz = pbz[q] - paz[q]
            dl = ux * ddx + uy * ddy + uz * ddz
            dux = (ddx - ux * dl) * inverse
            duy = (ddy - uy * dl) * inverse
            duz = (ddz - uz * dl) * inverse
            d_closing = ((vbx[q] - vax[q]) * ux + (vby[q] - vay[q]) * uy
                         + (vbz[q] - vaz[q]) * uz + wx * dux + wy * duy + wz * duz)
            dm = slope * dl + c * d_closing
            tx[q] = dm * ux + magnitude * dux
            ty[q] = dm * uy + magnitude * duy
            tz[q] = dm * uz + magnitude * duz
        # the parameters of the spring's magnitude, outside the vectorised loop
        for entry in range(spring_ptr[j], spring_ptr[j + 1]):
            column = spring_column[entry] - first
            if 0 <= column < n_params:
                extra = spring_factor[entry] * partial(spring_basis[entry], stretch, closing)
                tx[column] += extra * ux
                ty[column] += extra * uy
                tz[column] += extra * uz
        fax, fay, faz = d_force[ia, 0], d_force[ia, 1], d_force[ia, 2]
        fbx, fby, fbz = d_force[ib, 0], d_force[ib, 1], d_force[ib, 2]
        for q in range(n_params):
            fax[q] += tx[q]
            fay[q] += ty[q]
            faz[q] += tz[q]
            fbx[q] -= tx[q]
            fby[q] -= ty[q]
            fbz[q] -= tz[q]


# -- one experiment ----------------------------------------------------------------------------
@numba.njit(cache=True, nogil=True, fastmath=CONTRACT)
def forward(state, springs, elements, relaxation, nodes, run, columns, windows, observation,
            out):
    """Positions (n_frames, N, 3) and columns ``first .. first + width - 1`` of the Jacobian
    (n_frames - 1, rows, 3, P) = H tp / length_unit at every measured (frame, row), 0
    elsewhere (threads given disjoint columns of one array split an experiment's Jacobian),
    into ``out = (positions, jacobian)``. A run of the state alone takes the faster
    :func:`neurofuzzy.kernels.stepper.frames`.

    The model as :meth:`neurofuzzy.learn._compiled.CompiledModel.groups` lays it out:
    ``springs`` (:class:`~neurofuzzy.learn._compiled.Springs`), ``elements``
    (:class:`~neurofuzzy.learn._compiled.Elements`, or None: a model without elements,
    compiled without the element code), ``relaxation = (g, a, columns)`` the Prony terms and
    ``nodes = (W, drag, drag_column, direction, mass_column, unit_mass_force)``. The state
    ``(p, v)`` at frame 0 (changed); ``run = (loads, h, n_frames, substeps, chunks)``
    (``chunks`` the threads of the element passes, :func:`.element_jvp.element_jvp`);
    ``columns = (first, width)``; ``windows = (start_index, start_p, start_v)``, the window
    starting at each frame (-1: none) and the windows' states; ``observation = (rows_start,
    rows_node, rows_weight, seen, scale)``, the observation operator's CSR, the rows seen at
    each frame and one over the length unit.

    Effects: a node drag ``-drag v`` (its coefficient's column ``drag_column``, -1 when not
    learned), constant forces already in ``loads`` with their parameter columns in
    ``direction`` (N, 3, width) (gravity, unmodeled loads; the columns computed);
    inclusions and stiffening of springs are in the springs' ``stiffness`` and ``cubic`` and
    their CSR columns (:func:`_spring_tangents`); inclusions of elements are in the element
    constants and their CSR columns; strain stiffening of the elements is ``kappa`` (its
    column ``kappa_column``). The elements' law constants ``law_constant`` (per element) have
    the columns ``law_constant_column``. Learned node masses: ``mass_column`` (N,) the column
    of each node's ``log m`` (-1 when not learned; empty when no mass is),
    ``unit_mass_force`` (N, 3) the forces proportional to the mass (gravity), which ``W F``
    does not see: ``∂(W F)/∂log m = -W (F - F_unit)``.
    """
    p, v = state
    (a, b, stiffness, damping, rest, cubic, spring_ptr, spring_column, spring_basis,
     spring_factor) = springs
    relax_g, relax_decay, relax_column = relaxation
    weight, drag, drag_column, force_direction, mass_column, unit_mass_force = nodes
    loads, h, n_frames, substeps, chunks = run
    first, width = columns
    start_index, start_p, start_v = windows
    rows_start, rows_node, rows_weight, seen, scale = observation
    positions, jacobian = out
    n_nodes = p.shape[0]
    n_rows = rows_start.shape[0] - 1
    force = np.empty((n_nodes, 3))
    tp = np.zeros((n_nodes, 3, width))
    tv = np.zeros((n_nodes, 3, width))
    d_force = np.empty((n_nodes, 3, width))
    tp_flat = tp.reshape((n_nodes, 3 * width))
    tv_flat = tv.reshape((n_nodes, 3 * width))
    d_force_flat = d_force.reshape((n_nodes, 3 * width))
    work = np.empty((3, width))
    node_strain = np.zeros((n_nodes, 2))
    d_node_strain = np.zeros((n_nodes, width, 2))
    # the relaxation's internal variables and their tangents: from rest, carried over window
    # starts (a window starts from a measured state; the elements' history goes on)
    history = np.zeros((relax_g.shape[0], relax_g.shape[1], 6))
    d_history = np.zeros((relax_g.shape[0], relax_g.shape[1], 6, width))
    # the element passes' threads after the first: their own sums and forces
    others = max(chunks - 1, 0) if elements is not None else 0
    buffers = (np.zeros((others, n_nodes, 2)), np.zeros((others, n_nodes, width, 2)),
               np.zeros((others, n_nodes, 3)), np.zeros((others, n_nodes, 3, width)))
    for t in range(n_frames):
        if start_index[t] >= 0:
            p[:] = start_p[start_index[t]]
            v[:] = start_v[start_index[t]]
            tp[:] = 0.0
            tv[:] = 0.0
            positions[t] = p
            if t > 0:
                jacobian[t - 1, :, :, first:first + width] = 0.0
            continue
        load = loads[min(t - 1, loads.shape[0] - 1)]
        for _ in range(substeps):
            for i in range(n_nodes):
                for k in range(3):
                    force[i, k] = load[i, k] - drag * v[i, k]
                    out, direction, speed = d_force[i, k], force_direction[i, k], tv[i, k]
                    for q in range(width):
                        out[q] = direction[q] - drag * speed[q]
                    if 0 <= drag_column - first < width:
                        out[drag_column - first] -= v[i, k]
            _spring_tangents(p, v, tp, tv, a, b, stiffness, damping, rest, cubic, spring_ptr,
                             spring_column, spring_basis, spring_factor, first, force, d_force,
                             work)
            if elements is not None:   # None: no elements, and no element code compiled
                e = elements.arrays
                element_jvp(p, v, tp, tv, (e.tets, e.inverse_rest, e.volume, e.law,
                                           e.law_constant),
                            (e.shear, e.shear_rate, e.lam, e.lam_rate), e.nodal,
                            (e.node_volume, e.node_lam, e.node_lam_rate, elements.d_node_lam,
                             elements.d_node_lam_rate),
                            (elements.pointer, elements.column, elements.d_shear,
                             elements.d_shear_rate, elements.d_lam, elements.d_lam_rate),
                            elements.kappa, elements.kappa_column, elements.law_constant_column,
                            (relax_g, relax_decay, relax_column, history, d_history), first,
                            node_strain, d_node_strain, force, d_force, buffers)
            for i in range(mass_column.shape[0]):
                c = mass_column[i] - first
                if 0 <= c < width:
                    for k in range(3):
                        d_force[i, k, c] -= force[i, k] - unit_mass_force[i, k]
            euler_update(p, v, force, weight, h)
            # the update is linear: the tangents take the same one, (N, 3, P) seen as (N, 3P)
            euler_update(tp_flat, tv_flat, d_force_flat, weight, h)
        if not np.isfinite(p.sum()):
            # diverged (a trial step too far): the rest is not computed, as in the state's
            # own run (the caller reads the residuals as diverged and never the Jacobian)
            positions[t:] = np.nan
            jacobian[t - 1:, :, :, first:first + width] = 0.0
            return
        positions[t] = p
        for row in range(n_rows):
            out = jacobian[t - 1, row]
            for k in range(3):
                target = out[k]
                for q in range(width):
                    target[first + q] = 0.0
            if not seen[t, row]:
                continue
            for entry in range(rows_start[row], rows_start[row + 1]):
                node = rows_node[entry]
                w = rows_weight[entry] * scale
                for k in range(3):
                    target, source = out[k], tp[node, k]
                    for q in range(width):
                        target[first + q] += w * source[q]
