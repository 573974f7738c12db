"""A large-strain *dynamic* reference for compression between plates: the cube of
:mod:`.plates` (FElupe's three-field quadratic tetrahedra, the coupled neo-Hookean law), now
with inertia and Kelvin–Voigt viscosity, its top plate driven down a smooth ramp and held.

What is whose. FElupe (Dutzler, https://github.com/adtzlr/felupe) builds the mesh, the fields
(displacement P2, pressure and volume ratio P1: :class:`~felupe.ThreeFieldVariation` of
:class:`~felupe.NeoHookeCompressible`, exactly as :func:`.plates.compress_between_plates`),
the elastic residual and tangent, the mass matrix (:meth:`felupe.SolidBody.assemble.mass`)
and the deformation gradient at the quadrature points, and assembles the viscous force and
tangent (:class:`felupe.IntegralForm`) from the stress written here. FElupe has no dynamics
driver: the time stepping (average-acceleration Newmark, Newton's method at each step) is
written in this module.

The path. The bottom face ``z = 0`` is held; the top face is bonded to its plate (``x, y``
held) and moved down by ``w(t) = -depth · s(min(t / ramp_time, 1))`` with the quintic
smoothstep ``s(τ) = τ³ (10 - 15 τ + 6 τ²)`` (no velocity or acceleration at either end),
then held (:func:`plate_path`). The driven degrees of freedom take the path's exact
displacement, velocity and acceleration at every step, not Newmark's recursion.

The equations. With ``h = dt / substeps``, every step solves, on all degrees of freedom but
the held and driven ones (the free displacements and all the pressure and volume-ratio ones),
``R(x) = f_solid(x) + [f_visc + M a, 0, 0] = 0`` with ``a = 4/h² (u - uₙ - h vₙ) - aₙ``, by
Newton's method to ``|R_free| ≤ 1e-10 (|R_held| + 1e-4 (λ + 2μ) size²)``; then
``v = vₙ + h/2 (aₙ + a)``. The Jacobian (FElupe's elastic tangent, ``4/h² M`` and the exact
viscous tangent) is factorised afresh only when an iteration fails to cut the residual
fourfold, and reused otherwise, across steps too: a modified Newton, converging to the same
solution at a fraction of the factorisations.

Kelvin–Voigt viscosity is our elements' form (as in :mod:`.nonlinear.solver`): the viscous
second Piola–Kirchhoff stress is the small-strain elastic stress of the Green strain rate
times η/E, ``S_v = η/E (2μ Ė + λ tr Ė I)``, ``P_v = F S_v``, with the trapezoid's rate
``Ė = 2/h (E - Eₙ) - Ėₙ`` (``E = (FᵀF - I)/2`` of the displacement field at each quadrature
point, computed from ``∇u``; ``Eₙ, Ėₙ`` kept from the last converged step). Its tangent is
exact: ``A_iJkL = δ_ik S_v,JL + 2/h η/E F_iI ℂ₀_IJKL F_kK``. The viscous stress is not in the
three-field form: as ν → 0.5 its bulk part ``η λ/E tr Ė`` grows without bound, and at finite
strain ``tr Ė`` is not zero in an isochoric motion, so at ν = 0.499 it dominates the force
during the ramp.

The mass is FElupe's consistent mass, assembled on the same quadratic tetrahedra with an exact
(order-5) quadrature rule: the region's own 4-point rule integrates ``N_a N_b`` (degree 4) only
approximately and leaves the mass matrix singular.

The force. The plate's force on the body is the full residual (elastic, viscous and inertial)
summed over the top face's points: at rest it is FElupe's :func:`felupe.tools.force`, the sign
of :mod:`.plates` (compression: negative ``z``).

Needs the ``validation`` extra (``pip install 'neurofuzzy[validation]'``, FElupe ≥ 11.3).
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Integral

import numpy as np

from ..errors import InputError
from ..extras import require
from .plates import SIZE, YOUNGS, _bead_values, beads, converged_force

__all__ = ["PlateRamp", "plate_path", "ramp_between_plates", "record"]

#: Newton's tolerance on the free residual, relative to the plate's reaction
TOLERANCE = 1e-10
#: Newton iterations a step may take
MAX_ITERATIONS = 30
#: the Jacobian's factors are reused while each iteration cuts the residual this much
SLOW = 0.25


@dataclass(frozen=True)
class PlateRamp:
    """What the dynamic reference computed: the beads and the plate's force at each frame.

    Attributes
    ----------
    times : (n_frames,) float
        The frames' times ``k · dt`` (s), from 0.
    displacements : (n_frames, n_points, 3) float
        Each bead's displacement from rest at each frame (m); zero at frame 0.
    force : (n_frames, 3) float
        The total force the plate exerts on the body at each frame (N): elastic, viscous and
        inertial; compression is negative ``z``.
    cells : int
        Cells a side of the reference mesh (six quadratic tetrahedra each).
    """

    times: np.ndarray
    displacements: np.ndarray
    force: np.ndarray
    cells: int


def plate_path(t, depth: float, ramp_time: float):
    """The plate's displacement, velocity and acceleration (``z``, m, m/s, m/s²) at times
    ``t``: a quintic smoothstep down to ``-depth`` over ``ramp_time``, then held.

    Parameters
    ----------
    t : float or array of float
        Times (s); before 0 the plate is at rest at 0.
    depth, ramp_time : float
        How far the plate goes down (m) and in what time (s).

    Returns
    -------
    w, dw, ddw : float or ndarray
        ``-depth s(τ)``, ``-depth s'(τ) / ramp_time`` and ``-depth s''(τ) / ramp_time²`` with
        ``τ = clip(t / ramp_time, 0, 1)`` and ``s(τ) = τ³ (10 - 15 τ + 6 τ²)``.
    """
    if not ramp_time > 0:
        raise InputError(f"must be positive, got {ramp_time}", key="ramp_time")
    tau = np.clip(np.asarray(t, float) / ramp_time, 0.0, 1.0)
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)
    ds = 30 * tau**2 * (1 - tau) ** 2
    dds = 60 * tau * (1 - tau) * (1 - 2 * tau)
    return -depth * s, -depth * ds / ramp_time, -depth * dds / ramp_time**2


class _KelvinVoigt:
    """The viscous stress ``P_v = F η/E ℂ₀ : Ė`` at the quadrature points, its force and
    tangent assembled by FElupe, and the committed state ``(Eₙ, Ėₙ)``."""

    def __init__(self, fem, field, coefficient: float, mu: float, lam: float):
        self.fem, self.field, self.coefficient = fem, field, coefficient
        self.mu, self.lam = mu, lam
        self.u = fem.FieldContainer([field[0]])
        shape = field[0].extract(grad=True).shape                  # (3, 3, q, cells)
        self.identity = np.eye(3).reshape(3, 3, 1, 1)
        self.strain, self.rate = np.zeros(shape), np.zeros(shape)
        self.trial = None

    def _evaluate(self, h: float):
        """Deformation gradient, Green strain and its rate, viscous 2nd PK stress."""
        grad_u = self.field[0].extract(grad=True, add_identity=False)
        gradient = grad_u + self.identity                              # F
        # E = (H + Hᵀ + HᵀH) / 2 of H = ∇u, not (FᵀF - I) / 2: no cancellation at rest
        strain = 0.5 * (grad_u + np.einsum("IJqc->JIqc", grad_u)
                        + np.einsum("kIqc,kJqc->IJqc", grad_u, grad_u))
        rate = 2.0 / h * (strain - self.strain) - self.rate
        trace = np.einsum("IIqc->qc", rate)
        stress = self.coefficient * (2 * self.mu * rate + self.lam * trace * self.identity)
        self.trial = strain, rate
        return gradient, stress

    def force(self, h: float) -> np.ndarray:
        """The viscous force on the displacement degrees of freedom (3 per point)."""
        gradient, stress = self._evaluate(h)
        first = np.einsum("iIqc,IJqc->iJqc", gradient, stress)
        form = self.fem.IntegralForm(fun=[first], v=self.u, dV=self.field.region.dV,
                                     grad_v=[True])
        return form.assemble().toarray().ravel()

    def tangent(self, h: float):
        """``∂f_visc/∂u``: the exact tangent of :meth:`force` (sparse, 3 per point)."""
        gradient, stress = self._evaluate(h)
        eye = np.eye(3)
        stiff = 2.0 / h * self.coefficient
        left = np.einsum("iIqc,kIqc->ikqc", gradient, gradient)       # F Fᵀ
        hessian = (np.einsum("ik,JLqc->iJkLqc", eye, stress)
                   + stiff * (self.lam * np.einsum("iJqc,kLqc->iJkLqc", gradient, gradient)
                              + self.mu * np.einsum("ikqc,JL->iJkLqc", left, eye)
                              + self.mu * np.einsum("iLqc,kJqc->iJkLqc", gradient, gradient)))
        form = self.fem.IntegralForm(fun=[hessian], v=self.u, u=self.u,
                                     dV=self.field.region.dV, grad_v=[True], grad_u=[True])
        return form.assemble()

    def commit(self):
        """Keep the converged step's strain and rate."""
        self.strain, self.rate = self.trial


def _check(points, size, youngs_modulus, poisson_ratio, viscosity, density, depth,
           ramp_time, dt, n_frames, substeps, cells) -> np.ndarray:
    """Refuse bad arguments (:class:`InputError`); the beads as an (n, 3) array."""
    for key, value in (("size", size), ("youngs_modulus", youngs_modulus),
                       ("density", density), ("depth", depth), ("ramp_time", ramp_time),
                       ("dt", dt)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"must be positive, got {value}", key=key)
    if not -1.0 < poisson_ratio < 0.5:
        raise InputError(f"must lie in (-1, 0.5), got {poisson_ratio}", key="poisson_ratio")
    if not (np.isfinite(viscosity) and viscosity >= 0):
        raise InputError(f"must be zero or positive, got {viscosity}", key="viscosity")
    if depth >= size:
        raise InputError(f"must be less than the cube's size {size}, got {depth}",
                         key="depth")
    for key, value, least in (("n_frames", n_frames, 2), ("substeps", substeps, 1),
                              ("cells", cells, 1)):
        if not isinstance(value, Integral) or isinstance(value, bool) or value < least:
            raise InputError(f"must be an integer ≥ {least}, got {value!r}", key=key)
    points = np.asarray(points, float)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise InputError(f"must be an (n, 3) array of finite positions, got shape "
                         f"{points.shape}", key="points")
    return points


def ramp_between_plates(points, *, size: float, youngs_modulus: float, poisson_ratio: float,
                        viscosity: float, density: float, depth: float, ramp_time: float,
                        dt: float, n_frames: int, substeps: int = 4,
                        cells: int = 6) -> PlateRamp:
    """Drive the plate down :func:`plate_path` and record the beads and its force at each
    frame ``t = k · dt`` (module docstring: the equations, the path, the force's sign).

    Parameters
    ----------
    points : (n, 3) float
        Bead positions at rest (m), inside the cube ``[0, size]³``.
    size, youngs_modulus, poisson_ratio : float
        The cube's side (m) and the neo-Hookean solid's small-strain E (Pa) and ν.
    viscosity : float
        Kelvin–Voigt η (Pa·s); 0 for none.
    density : float
        kg/m³.
    depth, ramp_time : float
        The plate's travel (m, less than ``size``) and the ramp's duration (s).
    dt : float
        Time between frames (s).
    n_frames : int
        Frames recorded, the first at rest at ``t = 0``.
    substeps : int
        Newmark steps per frame.
    cells : int
        Cells a side (six quadratic tetrahedra each).

    Returns
    -------
    PlateRamp
    """
    points = _check(points, size, youngs_modulus, poisson_ratio, viscosity, density, depth,
                    ramp_time, dt, n_frames, substeps, cells)
    require("validation", "the large-strain dynamic plate reference (FElupe)")
    import felupe as fem
    from scipy.sparse.linalg import splu
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    mesh = fem.Cube(b=(size,) * 3, n=cells + 1).triangulate().add_midpoints_edges()
    field = fem.FieldsMixed(fem.RegionQuadraticTetra(mesh), n=3)
    umat = fem.ThreeFieldVariation(fem.NeoHookeCompressible(mu=mu, lmbda=lam))
    solid = fem.SolidBody(umat, field)
    exact = fem.RegionQuadraticTetra(mesh, quadrature=fem.TetrahedronQuadrature(order=5))
    mass = fem.SolidBody(umat, fem.FieldContainer([fem.Field(exact, dim=3)]),
                         density=density).assemble.mass().tocsr()
    viscous = _KelvinVoigt(fem, field, viscosity / youngs_modulus, mu, lam)

    # the mixed vector: displacements (point-major, 3 per point), then p, then J
    n_u = field[0].values.size
    x = np.concatenate([f.values.ravel() for f in field.fields])
    z = mesh.points[:, 2]
    top = np.isclose(z, size)
    held = np.zeros(x.size, bool)
    held[:n_u] = np.repeat(np.isclose(z, 0.0) | top, 3)
    driven = 3 * np.flatnonzero(top) + 2
    free = ~held
    floor = 1e-4 * (lam + 2 * mu) * size**2     # round-off must not stall the first steps

    h = dt / substeps
    u, v, a = np.zeros(n_u), np.zeros(n_u), np.zeros(n_u)
    held_u, factors = held[:n_u], None

    def residual(vector):
        """R at ``vector`` (the field and the viscous trial state set to it), and ``a``."""
        for f, part in zip(field.fields, np.split(vector, field.offsets)):
            f.values[:] = part.reshape(f.values.shape)
        acceleration = 4.0 / h**2 * (vector[:n_u] - u - h * v) - a
        acceleration[held_u] = 0.0
        acceleration[driven] = a_driven
        out = solid.assemble.vector(field).toarray().ravel()
        out[:n_u] += mass @ acceleration
        if viscosity > 0:
            out[:n_u] += viscous.force(h)
        return out, acceleration

    def factorise():
        """The Jacobian at the last :func:`residual`'s point, on the free dofs, factorised."""
        extra = 4.0 / h**2 * mass
        if viscosity > 0:
            extra = extra + viscous.tangent(h)
        extra = extra.tocsr()
        extra.resize((x.size, x.size))
        jacobian = (solid.assemble.matrix(field) + extra).tocsr()[free][:, free].tocsc()
        return splu(jacobian, permc_spec="MMD_AT_PLUS_A")

    times = dt * np.arange(n_frames)
    displacements = np.zeros((n_frames, len(points), 3))
    displacements[0] = _bead_values(mesh, np.zeros((mesh.npoints, 3)), points)
    force = np.zeros((n_frames, 3))
    for frame in range(1, n_frames):
        for step in range(1, substeps + 1):
            t = times[frame - 1] + step * h
            x[:n_u] = u + h * v + 0.25 * h * h * a      # predictor: a unchanged; 0 if held
            x[driven], v_driven, a_driven = plate_path(t, depth, ramp_time)
            fresh, last = False, None                     # last: an iterate, its |R_free|
            for iteration in range(MAX_ITERATIONS + 1):
                r, a_new = residual(x)
                norm = np.linalg.norm(r[free]) if np.all(np.isfinite(r)) else np.inf
                if norm <= TOLERANCE * (np.linalg.norm(r[held]) + floor):
                    break
                if iteration == MAX_ITERATIONS or (norm == np.inf and (fresh or last is None)):
                    raise InputError(f"Newton's method did not converge at frame {frame} "
                                     "(an element may have turned inside out); take smaller "
                                     "steps", key="substeps")
                if last is not None and norm > SLOW * last[1]:   # slow: fresh factors
                    if norm > last[1] and not fresh:    # the old ones made it worse: undo
                        x[:] = last[0]
                        r, a_new = residual(x)
                        norm = last[1]
                    factors = None
                if factors is None:
                    factors, fresh = factorise(), True
                last = x.copy(), norm
                x[free] -= factors.solve(r[free])
            v_new = v + 0.5 * h * (a + a_new)
            v_new[held_u] = 0.0
            v_new[driven] = v_driven
            u, v, a = x[:n_u].copy(), v_new, a_new
            if viscosity > 0:
                viscous.commit()
        force[frame] = r[:n_u].reshape(-1, 3)[top].sum(axis=0)
        displacements[frame] = _bead_values(mesh, u.reshape(-1, 3), points)
    return PlateRamp(times, displacements, force, cells)


#: The recorded ramp: the 2 cm cube of :mod:`.plates` (E = 6 kPa, its 343 beads), η = 30 Pa·s,
#: 1000 kg/m³, driven down 18 % in 50 ms and held; 121 frames 1 ms apart, 4 steps a frame.
RAMP = dict(size=SIZE, youngs_modulus=YOUNGS, viscosity=30.0, density=1000.0,
            depth=0.18 * SIZE, ramp_time=0.05, dt=1e-3, n_frames=121, substeps=4)


def record(poisson_ratio: float, path, cells=(6, 8)) -> dict:
    """Run the recorded ramp on two meshes and store it (compressed ``.npz``): the beads at
    rest, their displacements on the finer mesh (float32: 0.1 nm at these strains), the
    plate's path at the frames, its force on each mesh and extrapolated
    (:func:`.plates.converged_force`)."""
    points = beads()
    coarse, fine = (ramp_between_plates(points, poisson_ratio=poisson_ratio, cells=n, **RAMP)
                    for n in cells)
    data = {**RAMP, "beads": points, "poisson_ratio": poisson_ratio, "times": fine.times,
            "plate": plate_path(fine.times, RAMP["depth"], RAMP["ramp_time"])[0],
            "displacements": fine.displacements.astype(np.float32),
            "force": converged_force(coarse, fine),
            "force_coarse": coarse.force, "force_fine": fine.force, "cells": np.array(cells)}
    np.savez_compressed(path, **data)
    return data


if __name__ == "__main__":          # python -m neurofuzzy.validation.plate_ramp NU OUT.npz
    import sys

    record(float(sys.argv[1]), sys.argv[2])
