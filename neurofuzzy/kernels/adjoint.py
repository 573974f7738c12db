"""Compiled discrete adjoint (numba) of :meth:`neurofuzzy.learn.Sensitivity.gradient` for
models of springs and tetrahedral elements: two calls per experiment, no Python per time step.

:func:`neurofuzzy.kernels.stepper.frames` (the driver of every forward run) runs
semi-implicit Euler over the frames and keeps the state at the start of every substep;
:func:`pull_back` runs the adjoint backwards over those states and sums, per
spring, ``λ · ∂F`` by its magnitude's bases (``x``, the closing speed, ``x³``), and per
element ``λ · ∂F`` by its four constants (shear ``2μ``, its rate ``2μβ``, ``λ`` and ``λβ``;
for the nodal volumetric form by the node averages of the last two). The caller turns them
into the gradient by the parameters with the forward kernel's CSR (``log s``, ``log c`` per
tie group, the spring effects' coefficients; for elements the same derivatives of the
constants as the forward kernel). The arithmetic is that of the numpy reference path
(:meth:`neurofuzzy.forces.Springs.vjp`, :func:`~neurofuzzy.forces.central.central_vjp`,
:meth:`neurofuzzy.forces.Tetrahedra.state_vjp` and ``parameter_vjp``; tested equal):
springs ``f = (s x + c ((v_b - v_a)·u) + q x³) u`` (``x = l - L0``, the spring effects'
extra stiffness in ``s``, their stiffening ``q = κ / L0²``), elements of each element's law
(:mod:`neurofuzzy.kernels.laws`; their part, on several threads for a large model, in
:mod:`neurofuzzy.kernels.element_vjp`), a node drag ``-drag v`` and constant loads.

Imported only when numba is installed (module-level, ``cache=True``).
"""

import numba
import numpy as np

from .element_vjp import element_vjp
from .integrator import euler_update_transpose
from .springs import CLOSING, CUBIC, STRETCH, partial
from .stepper import spring_state


@numba.njit(cache=True, nogil=True)
def pull_back(springs, elements, relaxation, nodes, run, start_index, kept, frame_adjoint,
              out):
    """The backward sweep: ``frame_adjoint[t]`` (n_frames, N, 3) is ``∂L/∂p(t)``.

    The model as :meth:`neurofuzzy.learn._compiled.CompiledModel.groups` lays it out (as for
    :func:`.sensitivity.forward`; ``elements`` None: a model without elements, which numba
    compiles without the element code, since it prunes a branch on an argument that is
    None); ``run = (h, n_frames, substeps, chunks)``; ``start_index`` the window starting at
    each frame (-1: none); ``kept = (states_p, states_v, states_r, states_f)`` what the
    forward sweep kept of every substep (:meth:`~neurofuzzy.learn._compiled.CompiledModel.frames`).

    Into ``out = (d_springs, d_elements, g_relax, g_mass, g_load, g_terms)``: adds
    ``Σ λ_F · ∂F/∂s_j``, ``Σ λ_F · ∂F/∂c_j`` and (when ``d_springs`` has a third row)
    ``Σ λ_F · ∂F/∂κ_j`` to ``d_springs[:, j]`` (the bases of
    :func:`.sensitivity._spring_tangents`; ``cubic`` the ``q`` of the last springs) over
    every substep (``λ_F = h W λ_v'``, the cotangent of the step's force), and those
    of the element constants to ``d_elements`` and of the Prony terms' ``log g``, ``log τ``
    to ``g_relax`` (n_elements, K, 2) (see :func:`.element_vjp.element_vjp`, on ``chunks``
    threads; the internal variables'
    cotangents run on across window starts, as their values do forwards). With the forces
    ``states_f`` of the forward sweep (learned masses), ``Σ λ_F · ∂(W F)/∂log m / W`` into
    ``g_mass`` (N,): ``-λ_F · (F - F_unit)``, ``unit_mass_force`` the forces proportional to
    the mass (gravity), which ``W F`` does not see. The effects' cotangents: ``Σ λ_F`` per
    node into ``g_load`` (N, 3; a constant force's direction takes it, empty when none is
    learned), ``Σ λ_F · ∂F/∂drag = -Σ λ_F · v`` into ``g_terms[0]`` (when ``g_load`` is not
    empty) and the elements' ``Σ λ_F · ∂F/∂κ`` into ``g_terms[1]``."""
    a, b, stiffness, damping, rest, cubic = (springs.a, springs.b, springs.stiffness,
                                             springs.damping, springs.rest, springs.cubic)
    relax_g, relax_decay = relaxation[0], relaxation[1]
    weight, drag, unit_mass_force = nodes[0], nodes[1], nodes[5]
    h, n_frames, substeps, chunks = run
    states_p, states_v, states_r, states_f = kept
    d_springs, d_elements, g_relax, g_mass, g_load, g_terms = out
    n_nodes = frame_adjoint.shape[1]
    effects = g_load.shape[0] > 0
    cubic_basis = d_springs.shape[0] > 2
    plain = a.shape[0] - cubic.shape[0]        # the last springs' q: cubic
    node_strain = np.zeros((n_nodes, 2))
    node_adjoint = np.zeros((n_nodes, 2))
    lam_p = np.zeros((n_nodes, 3))
    lam_v = np.zeros((n_nodes, 3))
    lam_force = np.empty((n_nodes, 3))
    lam_history = np.zeros((relax_g.shape[0], relax_g.shape[1], 6))
    d_p = np.empty((n_nodes, 3))
    d_v = np.empty((n_nodes, 3))
    # the element passes' threads after the first: their own sums and cotangents
    others = max(chunks - 1, 0) if elements is not None else 0
    buffers = (np.zeros((others, n_nodes, 2)), np.zeros((others, n_nodes, 2)),
               np.zeros((others, n_nodes, 3)), np.zeros((others, n_nodes, 3)))
    step = (n_frames - 1) * substeps
    for t in range(n_frames - 1, 0, -1):
        if start_index[t] >= 0:
            lam_p[:] = 0.0
            lam_v[:] = 0.0
            step -= substeps
            continue
        for i in range(n_nodes):
            for k in range(3):
                lam_p[i, k] += frame_adjoint[t, i, k]
        for _ in range(substeps):
            step -= 1
            p = states_p[step]
            v = states_v[step]
            # p' = p + h v', v' = v + h W F: the new velocity's cotangent, then the force's
            euler_update_transpose(lam_p, lam_v, weight, h, lam_force)
            if states_f.shape[0]:
                force = states_f[step]
                for i in range(n_nodes):
                    for k in range(3):
                        g_mass[i] -= lam_force[i, k] * (force[i, k] - unit_mass_force[i, k])
            for i in range(n_nodes):
                for k in range(3):
                    d_p[i, k] = 0.0
                    d_v[i, k] = -drag * lam_force[i, k]
            if effects:                # the constant forces' and the drag's parameters
                for i in range(n_nodes):
                    for k in range(3):
                        g_load[i, k] += lam_force[i, k]
                        g_terms[0] -= lam_force[i, k] * v[i, k]
            for j in range(a.shape[0]):
                ia, ib = a[j], b[j]
                ux, uy, uz, length, closing, stretch, magnitude, slope = spring_state(
                    p, v, ia, ib, stiffness[j], damping[j], rest[j],
                    cubic[j - plain] if j >= plain else 0.0)
                wx = v[ib, 0] - v[ia, 0]
                wy = v[ib, 1] - v[ia, 1]
                wz = v[ib, 2] - v[ia, 2]
                # node a gets +f, node b -f: the cotangent of f is λ_a - λ_b
                fx = lam_force[ia, 0] - lam_force[ib, 0]
                fy = lam_force[ia, 1] - lam_force[ib, 1]
                fz = lam_force[ia, 2] - lam_force[ib, 2]
                along = ux * fx + uy * fy + uz * fz
                d_springs[0, j] += partial(STRETCH, stretch, closing) * along
                d_springs[1, j] += partial(CLOSING, stretch, closing) * along
                if cubic_basis:                  # a learned stiffening
                    d_springs[2, j] += partial(CUBIC, stretch, closing) * along
                # central_vjp with ∂m/∂l = slope, ∂m/∂c = c
                ratio = magnitude / length
                rate = damping[j] * along / length
                lx = slope * along * ux + ratio * (fx - along * ux) + rate * (wx - closing * ux)
                ly = slope * along * uy + ratio * (fy - along * uy) + rate * (wy - closing * uy)
                lz = slope * along * uz + ratio * (fz - along * uz) + rate * (wz - closing * uz)
                cv = damping[j] * along
                # d = p_b - p_a: node b gets +λ_d, node a -λ_d
                d_p[ia, 0] -= lx
                d_p[ia, 1] -= ly
                d_p[ia, 2] -= lz
                d_p[ib, 0] += lx
                d_p[ib, 1] += ly
                d_p[ib, 2] += lz
                d_v[ia, 0] -= cv * ux
                d_v[ia, 1] -= cv * uy
                d_v[ia, 2] -= cv * uz
                d_v[ib, 0] += cv * ux
                d_v[ib, 1] += cv * uy
                d_v[ib, 2] += cv * uz
            if elements is not None:   # None: no elements, and no element code compiled
                element_vjp(p, v, elements.arrays, elements.kappa, lam_force, d_p, d_v,
                            d_elements, g_terms, node_strain, node_adjoint,
                            (relax_g, relax_decay, states_r[step], lam_history, g_relax),
                            buffers)
            for i in range(n_nodes):
                for k in range(3):
                    lam_p[i, k] += d_p[i, k]
                    lam_v[i, k] += d_v[i, k]
