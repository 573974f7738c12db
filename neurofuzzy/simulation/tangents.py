"""A model's force and its Jacobians, assembled as sparse matrices: what a Newton solve needs
(the static equilibrium of :mod:`neurofuzzy.simulation.static`; an implicit time step).

Every entry is generated from the per-item functions of :mod:`neurofuzzy.kernels.element` (a
tetrahedron's, a spring's) by complex step, in compiled loops
(:mod:`neurofuzzy.kernels.stiffness`), for every material law, both volumetric forms, Prony
relaxation (its internal variables held), and the effects the kernels compute (constant forces,
a node drag, inclusions and strain stiffening); nothing is written twice.
"""

from __future__ import annotations

import weakref
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..model import Model
from .threads import element_threads

__all__ = ["Tangents", "tangents"]


@dataclass(frozen=True)
class Tangents:
    """A model's force at a state and its Jacobians.

    Attributes
    ----------
    force : (n_nodes, 3) float
        The sum of every force term (springs, elements, effects), without external loads.
    stiffness : (3 n_nodes, 3 n_nodes) scipy.sparse.csr_array or None
        ``K = -∂force/∂positions`` (node-major degrees of freedom: ``3 i + k``); None for
        the force alone (``tangents(matrices=False)``).
    damping : (3 n_nodes, 3 n_nodes) scipy.sparse.csr_array or None
        ``C = -∂force/∂velocities``; None for the force alone or ``tangents(damping=False)``.
    """

    force: np.ndarray
    stiffness: sp.csr_array | None
    damping: sp.csr_array | None


def _element_tangents(p, v, layout, kappa, force, out):
    """:func:`~neurofuzzy.kernels.stiffness.element_tangents` of ``layout = (elements,
    node_strain, relaxation)``, its elements split into runs on threads of their own when the
    model is large (:mod:`.threads`): each run adds its forces into a buffer of its own,
    summed here; the matrices are per element, written once."""
    from ..kernels.stiffness import element_tangents, element_tangents_of, node_pressures

    elements, node_strain, _ = layout
    n_elements = elements.tets.shape[0]
    threads = element_threads(n_elements)
    if threads < 2:
        element_tangents(p, v, *layout, kappa, force, out)
        return
    if elements.nodal:
        node_pressures(p, v, elements, node_strain)
    bounds = [n_elements * c // threads for c in range(threads + 1)]
    buffers = [force] + [np.zeros_like(force) for _ in range(threads - 1)]
    with ThreadPoolExecutor(max_workers=threads) as pool:
        list(pool.map(lambda c: element_tangents_of(p, v, *layout, kappa, buffers[c], out,
                                                    bounds[c], bounds[c + 1]),
                      range(threads)))
    for buffer in buffers[1:]:
        force += buffer


def tangents(model: Model, positions: np.ndarray, velocities: np.ndarray | None = None,
             internal: np.ndarray | None = None, *, long_time: bool = False,
             matrices: bool = True, damping: bool = True) -> Tangents:
    """The force of ``model`` at ``(positions, velocities)`` and its stiffness and damping.

    Parameters
    ----------
    model : Model
        Springs, tetrahedral elements, and the effects the compiled kernels compute (a model
        with another effect is refused).
    positions : (n_nodes, 3) float
    velocities : (n_nodes, 3) float, optional
        Zero by default.
    internal : (n_elements, n_prony_terms, 6) float, optional
        The relaxation's internal variables (zero, the state at rest, by default), held.
    long_time : bool
        The relaxed response: the Prony terms take their long-time value (none of their
        share; a static equilibrium's).
    matrices : bool
        False: the force alone (``stiffness`` and ``damping`` None), at the cost of one
        evaluation per item.
    damping : bool
        False: no damping matrix (``damping`` None), which a static solve does not need (half
        the element matrices' work).
    """
    from .steppers import _prepared

    n = model.n_nodes
    p = np.array(positions, dtype=float, order="C")
    v = np.zeros_like(p) if velocities is None else np.array(velocities, dtype=float, order="C")
    if p.shape != (n, 3) or v.shape != (n, 3):
        raise InputError(f"positions and velocities must have shape ({n}, 3); got {p.shape} "
                         f"and {v.shape}", key="positions")
    prepared = _prepared(model, 1.0, np.dtype(np.float64))
    from ..kernels.stiffness import spring_tangents

    force = prepared.constant - prepared.drag * v
    blocks_k, blocks_c, dofs = [], [], []
    a, b = prepared.springs[:2]
    if len(a):
        K = np.empty((len(a) if matrices else 0, 6, 6))
        C = np.empty_like(K)
        spring_tangents(p, v, prepared.springs, force, K, C)
        if matrices:
            blocks_k.append(K.reshape(len(K), -1))
            blocks_c.append(C.reshape(len(C), -1))
            dofs.append(_dofs(np.stack([a, b], axis=1)))
    extra_k, extra_c = [], []
    if model.elements is not None:
        layout = _element_layout(prepared, internal, long_time)
        k = model.mesh.n_tetrahedra
        K = np.empty((k if matrices else 0, 12, 12))
        C = np.empty((len(K), 12 if damping else 0, 12))
        gradients = np.zeros((k if matrices else 0, 3, 12))
        _element_tangents(p, v, layout, float(prepared.kappa), force, (K, C, gradients))
        if matrices:
            tets = prepared.elements.tets
            blocks_k.append(K.reshape(len(K), -1))
            blocks_c.append(C.reshape(len(C), -1))
            dofs.append(_dofs(tets))
            if prepared.elements.nodal:                     # the nodal volumetric form
                extra_k, extra_c = _nodal_coupling(model.mesh, tets, layout, gradients,
                                                   damping)
    if not matrices:
        return Tangents(force, None, None)
    stiffness_matrix = _assemble(model.mesh, blocks_k, dofs)
    for extra in extra_k:
        stiffness_matrix = stiffness_matrix + extra
    if not damping:
        return Tangents(force, sp.csr_array(stiffness_matrix), None)
    damping_matrix = _assemble(model.mesh, blocks_c, dofs)
    for extra in extra_c:
        damping_matrix = damping_matrix + extra
    if prepared.drag:
        damping_matrix = damping_matrix + prepared.drag * sp.eye_array(3 * n, format="csr")
    return Tangents(force, sp.csr_array(stiffness_matrix), sp.csr_array(damping_matrix))


def _element_layout(prepared, internal, long_time: bool) -> tuple:
    """``(elements, node_strain, relaxation)`` for :func:`_element_tangents`: the model's
    elements with scratch space of their own and their Prony terms ``(g, a, history)`` at the
    internal variables ``internal`` (none: zero), or without the terms (``long_time``)."""
    elements = prepared.elements
    relax_g, decay = prepared.relaxation
    history = np.zeros(relax_g.shape + (6,))
    if long_time:
        relax_g = np.zeros((len(relax_g), 0))
        history = np.zeros((len(relax_g), 0, 6))
    elif internal is not None:
        internal = np.ascontiguousarray(internal, dtype=float)
        if internal.shape != history.shape:
            raise InputError(f"internal variables must have shape {history.shape}; got "
                             f"{internal.shape}", key="internal")
        history = internal
    return elements, np.zeros((len(elements.node_volume), 2)), (relax_g, decay, history)


def _dofs(items: np.ndarray) -> np.ndarray:
    """(n_items, 3 n_corners) degrees of freedom of items of corner nodes (n_items, n_corners)."""
    return (3 * items[:, :, None] + np.arange(3)).reshape(len(items), -1)


#: per mesh (weakly: gone with it), the sparsity pattern of its items' blocks: the learners
#: assemble many models of one mesh
_PATTERNS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class _Pattern:
    """Where each entry of the items' blocks goes in the CSR matrix: ``slot`` (n_entries,)
    into ``data`` of the structure ``indices``, ``indptr``."""

    slot: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray
    shape: tuple

    @classmethod
    def of(cls, rows: np.ndarray, cols: np.ndarray, shape: tuple) -> _Pattern:
        width = shape[1]
        unique, slot = np.unique(rows * width + cols, return_inverse=True)
        indptr = np.searchsorted(unique // width, np.arange(shape[0] + 1))
        return cls(slot.ravel(), (unique % width).astype(np.int32), indptr.astype(np.int32),
                   shape)

    @classmethod
    def of_blocks(cls, n: int, dofs: list) -> _Pattern:
        rows = np.concatenate([np.repeat(d, d.shape[1], axis=1).ravel() for d in dofs])
        cols = np.concatenate([np.tile(d, (1, d.shape[1])).ravel() for d in dofs])
        return cls.of(rows, cols, (3 * n, 3 * n))

    def matrix(self, values: np.ndarray) -> sp.csr_array:
        data = np.bincount(self.slot, weights=values, minlength=len(self.indices))
        return sp.csr_array((data, self.indices, self.indptr), shape=self.shape)


def _assemble(mesh, blocks: list, dofs: list) -> sp.csr_array:
    """The sum of per-item square blocks (n_items, d*d) at their degrees of freedom."""
    n = mesh.n_nodes
    if not blocks:
        return sp.csr_array((3 * n, 3 * n))
    key = tuple(d.shape for d in dofs)
    patterns = _PATTERNS.setdefault(mesh, {})
    if key not in patterns:
        patterns[key] = _Pattern.of_blocks(n, dofs)
    return patterns[key].matrix(np.concatenate([block.ravel() for block in blocks]))


def _nodal_coupling(mesh, tets: np.ndarray, layout: tuple, gradients: np.ndarray,
                    damping: bool = True):
    """The nodal volumetric form's stiffness and damping through its node averages:
    ``A_g diag(Λ/V) Aᵀ + R diag(H/V) Dᵀ`` and ``R diag(H/V) Rᵀ`` with the columns of ``A``,
    ``R``, ``D`` the nodes' ``∂Θ_a/∂x``, ``∂(Σ_e (V_e/4) tr G_e)/∂x`` and ``∂Θ̇_a/∂x``
    (:mod:`neurofuzzy.kernels.stiffness`), and ``A_g`` that of ``A`` with each element's
    share times ``1 + Σᵢ gᵢ`` (its Prony terms carry the volumetric stress too). ``R
    diag(H/V) Dᵀ`` is left out at rest (``D = 0``), the damping without ``damping``."""
    n = mesh.n_nodes
    elements, _, (relax_g, _, _) = layout
    node_volume, node_lam, node_lam_rate = (elements.node_volume, elements.node_lam,
                                            elements.node_lam_rate)
    patterns = _PATTERNS.setdefault(mesh, {})
    if "node averages" not in patterns:                 # (element, corner, 12) entries
        patterns["node averages"] = _Pattern.of(
            np.repeat(_dofs(tets)[:, None, :], 4, axis=1).ravel(),
            np.repeat(tets[:, :, None], 12, axis=2).ravel(), (3 * n, n))
    pattern = patterns["node averages"]

    def columns(which, scale=1.0):
        return pattern.matrix(np.repeat((scale * gradients[:, which])[:, None, :], 4,
                                        axis=1).ravel())

    inside = node_volume > 0
    weight = np.zeros(n)
    weight_rate = np.zeros(n)
    weight[inside] = node_lam[inside] / node_volume[inside]
    weight_rate[inside] = node_lam_rate[inside] / node_volume[inside]
    A = columns(0)
    relaxing = 1.0 + relax_g.sum(axis=1)[:, None]
    stiffness = [(columns(0, relaxing) if np.any(relaxing != 1.0) else A)
                 @ sp.diags_array(weight) @ A.T]
    damping_terms = []
    moving = np.any(gradients[:, 2])
    if np.any(weight_rate) and (damping or moving):
        scaled = columns(1) @ sp.diags_array(weight_rate)
        if moving:
            stiffness.append(scaled @ columns(2).T)
        if damping:
            damping_terms.append(scaled @ columns(1).T)
    return stiffness, damping_terms


def unit_forces(model: Model, positions: np.ndarray,
                groups: np.ndarray | None = None,
                velocities: np.ndarray | None = None, *,
                instantaneous: bool = False) -> np.ndarray:
    """The elements' force per unit of their constants, at rest velocity and long time:
    ``(n_groups, 2, n_nodes, 3)``, ``[g, 0]`` the force of the elements of group ``g`` with
    ``2μ = 1`` and ``λ = 0``, ``[g, 1]`` with ``2μ = 0`` and ``λ = 1`` (Pa⁻¹ · N).

    Every law's stress is linear in ``2μ`` and in ``π = λ θ`` (and the nodal form's node
    averages in the ``λ`` of the elements), so the elements' elastic force is exactly
    ``Σ_g 2μ_g F[g, 0] + λ_g F[g, 1]``: its derivatives by the material constants, from the
    one per-element function. ``groups`` (n_elements,) int: the groups (default one).

    With ``velocities`` (n_nodes, 3), the viscous ones too: ``(n_groups, 4, n_nodes, 3)``,
    ``[g, 2]`` the force with ``2μβ = 1`` and ``[g, 3]`` with ``λβ = 1`` (Pa⁻¹ s⁻¹ · N) at
    those velocities, the Kelvin–Voigt stress being linear in both likewise.

    ``instantaneous``: the elements' Prony terms take their share at once (``S_e`` times
    ``1 + Σᵢ gᵢ``, the internal variables held, as in an implicit step); by default none
    (their long-time value).
    """
    from ..kernels.stiffness import element_tangents
    from .steppers import _prepared

    if model.elements is None:
        raise InputError("the model has no elements", key="model")
    prepared = _prepared(model, 1.0, np.dtype(np.float64))
    elements = prepared.elements
    tets, volume, node_volume = elements.tets, elements.volume, elements.node_volume
    k, n = len(tets), model.n_nodes
    groups = np.zeros(k, np.intp) if groups is None else np.asarray(groups, np.intp)
    if groups.shape != (k,):
        raise InputError(f"groups must have shape ({k},); got {groups.shape}", key="groups")
    p = np.array(positions, dtype=float, order="C")
    zero_v = (np.zeros_like(p) if velocities is None
              else np.array(velocities, dtype=float, order="C"))
    zeros_k, zeros_n = np.zeros(k), np.zeros(n)
    g_terms, decay = prepared.relaxation
    relaxation = ((g_terms, decay, np.zeros(g_terms.shape + (6,))) if instantaneous
                  else (np.zeros((k, 0)), np.zeros((k, 0)), np.zeros((k, 0, 6))))
    nothing = (np.empty((0, 12, 12)), np.empty((0, 12, 12)), np.zeros((0, 3, 12)))
    out = np.zeros((groups.max(initial=-1) + 1, 2 if velocities is None else 4, n, 3))
    for g in range(len(out)):
        member = (groups == g).astype(float)
        corner = np.zeros(n)
        np.add.at(corner, tets, (0.25 * volume * member)[:, None])
        node_lam = np.divide(corner, node_volume, out=np.zeros(n), where=node_volume > 0)
        for which in range(out.shape[1]):       # the one constant set to 1: 2μ, λ, 2μβ, λβ
            unit = [member if which == c else zeros_k for c in range(4)]
            layout = elements._replace(shear=unit[0], lam=unit[1], shear_rate=unit[2],
                                       lam_rate=unit[3],
                                       node_lam=node_lam if which == 1 else zeros_n,
                                       node_lam_rate=node_lam if which == 3 else zeros_n)
            element_tangents(p, zero_v, layout, np.zeros((n, 2)), relaxation, 0.0,
                             out[g, which], nothing)
    return out
