"""Springs or elements, on continuum data made by a solver nobody here wrote.

The data: a soft block (4 x 4 x 3 cm, E = 6 kPa, Poisson's ratio 0.3 or 0.45, viscosity
2 Pa s as Rayleigh stiffness-proportional damping, density 1000 kg/m3, bottom held) pushed by
0.05 N on its top centre. The motion is linear elasticity assembled by scikit-fem (its P1
tetrahedra, its stiffness matrix), with lumped masses, integrated by scipy's Radau solver and
recorded at 1 kHz on every node.

The fits: the same mesh as tetrahedral elements (E, nu, eta learned, start 3 kPa / 0.35 /
1 Pa s) and as a spring network on its edges (van Gelder's springs from E, one shared
stiffness and viscosity learned; its Poisson's ratio is locked at 1/4), both with the gradient
learner and continuous-physics substeps. The table says what each recovers.

Run:  python examples/springs_or_elements.py [--quick]   (needs scikit-fem: pip install
'neurofuzzy[validation]'; --quick: one Poisson's ratio, a shorter recording)
"""

import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

import neurofuzzy as nf
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.extras import require_in_script
from neurofuzzy.constants import tetra_geometry

E, ETA, RHO, FORCE, DT = 6000.0, 2.0, 1000.0, 0.05, 1e-3


def continuum_data(mesh, poisson_ratio, n_frames):
    """The block's motion by scikit-fem's linear elasticity and scipy's Radau integrator."""
    import skfem
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    points = mesh.rest_positions
    fem = skfem.MeshTet(points.T.copy(), mesh.tetrahedra.T.copy())
    basis = skfem.Basis(fem, skfem.ElementVector(skfem.ElementTetP1()))
    stiffness = skfem.asm(linear_elasticity(*lame_parameters(E, poisson_ratio)), basis)
    dofs = basis.nodal_dofs.T                                  # (n_nodes, 3) skfem dof numbers
    volume = tetra_volumes(mesh)
    lumped = np.bincount(mesh.tetrahedra.ravel(), np.repeat(RHO * volume / 4, 4), mesh.n_nodes)
    mass = np.empty(stiffness.shape[0])
    mass[dofs.ravel()] = np.repeat(lumped, 3)
    load = np.zeros(stiffness.shape[0])
    top = top_centre(mesh)
    load[dofs[top, 2]] = -FORCE
    free = np.setdiff1d(np.arange(stiffness.shape[0]), dofs[mesh.fixed].ravel())
    K = stiffness[free][:, free].tocsc()
    C = (ETA / E) * K                                          # Rayleigh: eta / E times K
    m, f = mass[free], load[free]
    n = len(free)

    def rhs(_, y):
        u, v = y[:n], y[n:]
        return np.concatenate([v, (f - K @ u - C @ v) / m])

    def jac(_, y):
        import scipy.sparse as sp

        inverse = sp.diags(1.0 / m)
        return sp.bmat([[None, sp.identity(n)], [-inverse @ K, -inverse @ C]]).tocsc()

    times = np.arange(n_frames) * DT
    solution = solve_ivp(rhs, (0, times[-1]), np.zeros(2 * n), method="Radau", t_eval=times,
                         jac=jac, rtol=1e-9, atol=1e-13)
    displacement = np.zeros((n_frames, stiffness.shape[0]))
    displacement[:, free] = solution.y[:n].T
    positions = points[None] + displacement[:, dofs]
    forces = np.zeros((mesh.n_nodes, 3))
    forces[top, 2] = -FORCE
    return nf.Experiment(mesh=mesh, dt=DT, positions=positions, external_forces=forces,
                         node_mass=lumped, source=f"scikit-fem, nu = {poisson_ratio}")


def tetra_volumes(mesh):
    corners = mesh.rest_positions[mesh.tetrahedra]
    return np.abs(np.linalg.det(corners[:, 1:] - corners[:, :1])) / 6


def top_centre(mesh):
    points = mesh.rest_positions
    top = np.flatnonzero(np.isclose(points[:, 2], points[:, 2].max()))
    centre = points[top, :2].mean(axis=0)
    return int(top[np.argmin(np.linalg.norm(points[top, :2] - centre, axis=1))])


def fit_elements(mesh, data):
    # the data are scikit-fem's linear tetrahedra on this very mesh: the textbook per-element
    # volumetric form is their exact discretisation
    start = nf.Model.continuum(mesh, youngs_modulus=3000.0, poisson_ratio=0.35,
                               viscosity=1.0, density=RHO, volumetric="element")
    learner = nf.fit(data, start=start).learner          # the checked fit of `neurofuzzy fit`
    model = learner.model_
    return (float(np.median(model.elements.youngs_modulus)),
            float(np.median(model.elements.poisson_ratio)),
            float(np.median(model.elements.viscosity)), learner)


def fit_springs(mesh, data):
    factor = tetra_geometry(mesh).spring_factor                # k = E * factor (van Gelder)
    start = nf.Model(mesh, data.node_mass,
                     (nf.Springs(stiffness=3000.0 * factor, damping=1.0 * factor),)
                     ).tied("global")
    learner = nf.fit(data, start=start).learner          # the checked fit of `neurofuzzy fit`
    model = learner.model_
    return (float(np.median(model.springs.stiffness / factor)), 0.25,
            float(np.median(model.springs.damping / factor)), learner)


def main(argv):
    require_in_script("validation", "examples/springs_or_elements.py (scikit-fem assembles "
                      "its data)")
    started = time.perf_counter()
    quick = "--quick" in argv
    points, tetrahedra = kuhn_block((4, 4, 3), 0.01)
    mesh = nf.from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    ratios = (0.45,) if quick else (0.3, 0.45)
    n_frames = 101 if quick else 201
    print(f"block: {mesh.n_nodes} nodes, {mesh.n_tetrahedra} tetrahedra, {mesh.n_springs} "
          f"edges; {n_frames} frames at {1 / DT:.0f} Hz")
    header = (f"{'true nu':>8} {'model':<9}{'E (Pa)':>9}{'E error':>9}{'nu':>7}{'eta (Pa s)':>11}"
              f"{'eta error':>10}{'RMS (um)':>10}")
    rows = []
    for nu in ratios:
        data = continuum_data(mesh, nu, n_frames)
        motion = 1e6 * np.abs(data.positions - data.positions[0]).max()
        for name, fit in (("elements", fit_elements), ("springs", fit_springs)):
            e, ratio, eta, learner = fit(mesh, data)
            rows.append(f"{nu:>8.2f} {name:<9}{e:>9.0f}{100 * (e / E - 1):>8.1f}%{ratio:>7.3f}"
                        f"{eta:>11.3f}{100 * (eta / ETA - 1):>9.1f}%"
                        f"{1e6 * learner.rms_error_:>10.2f}")
            print(rows[-1], f"  (peak motion {motion:.0f} um, {learner.seconds_:.0f} s)",
                  file=sys.stderr)
    print(header)
    print("\n".join(rows))
    print(f"truth: E = {E:.0f} Pa, eta = {ETA} Pa s ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
