"""Continuum data from a solver nobody here wrote: scikit-fem's quadratic tetrahedra.

Our element models are validated, and the documentation's accuracy figures measured, against motion
that does not come from our own simulator. :class:`ContinuumSolver` assembles linear
elastodynamics on a tetrahedral mesh with scikit-fem (quadratic ``P2`` tetrahedra by default:
ten nodes each, far closer to the continuum than our linear elements on the same mesh, and
free of volumetric locking at the Poisson's ratios of soft tissue), with a consistent mass
matrix and Kelvin–Voigt viscosity (a Rayleigh stiffness-proportional damping,
``C = K(η)``: the viscous stress is the elastic one of the strain rate times ``η / E``), and
integrates it with the average-acceleration Newmark scheme (trapezoidal, implicit,
second-order, unconditionally stable; one sparse LU factorisation).

Loads: a probe pressing on a patch of the surface (a uniform traction over the boundary
within a radius of the point) and gravity (``ρ g`` per volume). Motion is sampled anywhere
in the mesh (markers) through scikit-fem's own interpolation.

Needs scikit-fem (``pip install 'neurofuzzy[validation]'``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InputError

__all__ = ["ContinuumSolver"]

PerElement = float | np.ndarray | Callable[[np.ndarray], np.ndarray]


def _skfem():
    from ..extras import require

    require("validation", "the continuum reference (scikit-fem's solver)")
    import skfem

    return skfem


class ContinuumSolver:
    """Linear elastodynamics of a tetrahedral mesh, by scikit-fem.

    Parameters
    ----------
    points : (n_points, 3) float
        Mesh vertices (m).
    tetrahedra : (n_tetrahedra, 4) int
    youngs_modulus, viscosity, density : float, (n_tetrahedra,) float or callable
        Per element (a callable gets the (n_tetrahedra, 3) centroids), in Pa, Pa·s, kg/m³.
    poisson_ratio : float
    fixed : callable
        ``fixed(x)`` with ``x`` of shape (3, n): True where the boundary is held (evaluated
        on boundary facets, e.g. ``lambda x: x[2] < 1e-9``).
    order : {1, 2}
        Linear or quadratic tetrahedra.
    """

    def __init__(self, points, tetrahedra, *, youngs_modulus: PerElement,
                 poisson_ratio: float, viscosity: PerElement, density: PerElement,
                 fixed: Callable, order: int = 2):
        skfem = _skfem()
        from skfem.helpers import ddot, div, dot, sym_grad

        points = np.asarray(points, float)
        tetrahedra = np.asarray(tetrahedra)
        self.mesh = skfem.MeshTet(points.T.copy(), tetrahedra.T.copy())
        element = {1: skfem.ElementTetP1, 2: skfem.ElementTetP2}[order]()
        self.element = skfem.ElementVector(element)
        self.basis = skfem.Basis(self.mesh, self.element, intorder=2 * order)
        centroids = points[tetrahedra].mean(axis=1)
        n_qp = self.basis.X.shape[-1]

        def field(value):
            values = value(centroids) if callable(value) else value
            values = np.broadcast_to(np.asarray(values, float), (len(tetrahedra),))
            return np.repeat(values[:, None], n_qp, axis=1)

        a = poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
        b = 0.5 / (1 + poisson_ratio)

        @skfem.BilinearForm
        def elasticity(u, v, w):
            return (w.modulus * a * div(u) * div(v)
                    + 2 * w.modulus * b * ddot(sym_grad(u), sym_grad(v)))

        @skfem.BilinearForm
        def inertia(u, v, w):
            return w.density * dot(u, v)

        self.stiffness = skfem.asm(elasticity, self.basis, modulus=field(youngs_modulus))
        self.damping = skfem.asm(elasticity, self.basis, modulus=field(viscosity))
        self.mass = skfem.asm(inertia, self.basis, density=field(density))
        self._density = field(density)
        held = self.basis.get_dofs(self.mesh.facets_satisfying(fixed)).all()
        self.free = np.setdiff1d(np.arange(self.basis.N), held)

    # -- loads --------------------------------------------------------------------------------
    def probe_load(self, point, radius: float, force) -> np.ndarray:
        """(n_dofs,): a uniform traction on the boundary within ``radius`` of ``point`` that
        adds up to ``force`` (N): a probe pressing on a patch."""
        point = np.asarray(point, float)
        return self.surface_load(
            force, lambda x: np.sum((x - point[:, None, None]) ** 2, axis=0) <= radius**2)

    def surface_load(self, force, where: Callable) -> np.ndarray:
        """(n_dofs,): a uniform traction on the boundary where ``where(x)`` holds (``x`` of
        shape (3, ...) at the facets' quadrature points) that adds up to ``force`` (N)."""
        skfem = _skfem()
        from skfem.helpers import dot

        force = np.asarray(force, float)
        boundary = skfem.FacetBasis(self.mesh, self.element,
                                    facets=self.mesh.boundary_facets(), intorder=10)

        @skfem.LinearForm
        def traction(v, w):
            return where(w.x) * dot(force[:, None, None] * np.ones_like(w.x), v)

        @skfem.Functional
        def area(w):
            return 1.0 * where(w.x)

        patch = float(skfem.asm(area, boundary))
        if patch <= 0:
            raise InputError("the load's patch contains no boundary", key="where")
        return skfem.asm(traction, boundary) / patch

    def gravity_load(self, gravity) -> np.ndarray:
        """(n_dofs,): the weight ``ρ g`` of the object (``gravity`` in m/s²)."""
        skfem = _skfem()
        from skfem.helpers import dot

        g = np.asarray(gravity, float)

        @skfem.LinearForm
        def weight(v, w):
            return w.density * dot(g[:, None, None] * np.ones_like(w.x), v)

        return skfem.asm(weight, self.basis, density=self._density)

    # -- solutions ----------------------------------------------------------------------------
    def static(self, load: np.ndarray) -> np.ndarray:
        """(n_dofs,) displacement in equilibrium with ``load``."""
        free = self.free
        u = np.zeros(self.basis.N)
        u[free] = spla.spsolve(self.stiffness[free][:, free].tocsc(), load[free])
        return u

    def displaced(self, where: Callable, displacement) -> tuple[np.ndarray, np.ndarray]:
        """The equilibrium with the boundary where ``where(x)`` holds (a bonded plate) moved
        by ``displacement`` (3,) m and the fixed boundary at rest: ``(u, reaction)``, the
        displacement (n_dofs,) and the total force (3,) N the plate exerts on the body."""
        skfem = _skfem()
        shift = np.asarray(displacement, float)
        plate = self.basis.get_dofs(self.mesh.facets_satisfying(where)).all()
        held = np.union1d(np.setdiff1d(np.arange(self.basis.N), self.free), plate)
        # the dofs' components: a constant field is interpolated exactly by Lagrange elements
        component = np.stack([self.basis.project(
            lambda x, k=k: np.stack([np.full(x.shape[1:], float(k == j)) for j in range(3)]))
            for k in range(3)])
        u = np.zeros(self.basis.N)
        u[plate] = (shift[:, None] * component[:, plate]).sum(axis=0)
        free = np.setdiff1d(np.arange(self.basis.N), held)
        K = self.stiffness
        u[free] = spla.spsolve(K[free][:, free].tocsc(), -(K[free][:, held] @ u[held]))
        force = K @ u
        return u, np.array([force[plate] @ component[k, plate] for k in range(3)])

    def dynamic(self, load, *, dt: float, n_frames: int, substeps: int = 10) -> np.ndarray:
        """(n_frames, n_dofs) displacement from rest: average-acceleration Newmark with
        ``substeps`` steps per frame.

        ``load`` is (n_dofs,) (held from t = 0) or (n_frames, n_dofs), ``load[t]`` acting
        from frame t to t + 1 (as in our experiments).
        """
        free = self.free
        loads = np.asarray(load, float)
        loads = np.broadcast_to(loads, (n_frames, self.basis.N))[:, free]
        K = self.stiffness[free][:, free].tocsc()
        C = self.damping[free][:, free].tocsc()
        M = self.mass[free][:, free].tocsc()
        h = dt / substeps
        # the effective matrix is symmetric: a minimum-degree ordering of its pattern fills
        # in a fifth less than SuperLU's default and each solve is as much faster
        effective = spla.splu(sp.csc_matrix(M + 0.5 * h * C + 0.25 * h * h * K),
                              permc_spec="MMD_AT_PLUS_A")
        u = np.zeros(len(free))
        v = np.zeros(len(free))
        out = np.zeros((n_frames, self.basis.N))
        # a block at rest under no load stays at rest: frames before the first load are 0
        loaded = np.flatnonzero(np.any(loads != 0.0, axis=1))
        first = int(loaded[0]) if len(loaded) else n_frames
        a = spla.splu(M).solve(loads[0]) if first == 0 else np.zeros(len(free))
        for t in range(first + 1, n_frames):
            f = loads[t - 1]
            for _ in range(substeps):
                u_guess = u + h * v + 0.25 * h * h * a
                v_guess = v + 0.5 * h * a
                a = effective.solve(f - C @ v_guess - K @ u_guess)
                u = u_guess + 0.25 * h * h * a
                v = v_guess + 0.5 * h * a
            out[t, free] = u
        return out

    def at(self, displacement: np.ndarray, points) -> np.ndarray:
        """Displacement (…, n_points, 3) at ``points`` (n_points, 3) for displacements
        (…, n_dofs)."""
        probes = self.basis.probes(np.asarray(points, float).T.copy())
        flat = np.asarray(displacement).reshape(-1, self.basis.N)
        values = (probes @ flat.T).T.reshape(len(flat), 3, -1)
        return np.swapaxes(values, 1, 2).reshape(*np.shape(displacement)[:-1], -1, 3)
