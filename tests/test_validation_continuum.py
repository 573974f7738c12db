"""Our tetrahedral elements against the continuum as scikit-fem's quadratic tetrahedra solve it
(:class:`~neurofuzzy.validation.continuum.ContinuumSolver`): the nodal volumetric form does not
lock, and both forms converge under refinement. The reference itself is checked against
closed forms first."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.mesh import from_tetra, patch_loads
from neurofuzzy.model import Model
from neurofuzzy.observation import embed_points

pytest.importorskip("skfem")
from neurofuzzy.validation.continuum import ContinuumSolver  # noqa: E402

E, RHO = 6000.0, 1000.0
PROBE, RADIUS, FORCE = (0.02, 0.02, 0.03), 0.01, (0.0, 0.0, -0.05)


def bottom(x):
    return x[2] < 1e-9


def markers():
    """Points on the block's top (off the probe) and sides."""
    g = np.linspace(0.0025, 0.0375, 8)
    gz = np.linspace(0.0025, 0.0275, 6)
    points = [(x, y, 0.03) for x in g for y in g if np.hypot(x - 0.02, y - 0.02) > RADIUS]
    for side in (0.0, 0.04):
        points += [(x, side, z) for x in g for z in gz] + [(side, y, z) for y in g for z in gz]
    return np.array(points)


def our_static(shape, spacing, poisson_ratio, volumetric, points):
    mesh = from_tetra(*kuhn_block(shape, spacing)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=poisson_ratio,
                            viscosity=1.0, density=RHO, volumetric=volumetric)
    stiffness, _ = model.elements.rest_matrices(model)
    free = np.setdiff1d(np.arange(3 * mesh.n_nodes),
                        (3 * mesh.fixed[:, None] + np.arange(3)).ravel())
    loads = patch_loads(mesh, PROBE, RADIUS, FORCE).ravel()
    u = np.zeros(3 * mesh.n_nodes)
    u[free] = spla.spsolve(stiffness[free][:, free].tocsc(), loads[free])
    nodes, weights, _ = embed_points(mesh, points)
    return np.einsum("mk,mkj->mj", weights, u.reshape(-1, 3)[nodes])


def relative_error(found, reference):
    return float(np.sqrt(np.sum((found - reference) ** 2) / np.sum(reference**2)))


def test_the_reference_is_exact_for_uniaxial_stress_and_a_column_under_its_weight():
    """A bar pulled by a uniform traction on its end stretches by σL/E (ν = 0, so the held
    base does not constrain it) and, with ν = 0.3, contracts by ν σ/E far from the base; a
    column hanging under its own weight stretches by ρ g (L s - s²/2) / E: quadratic
    elements are exact for these linear and quadratic fields."""
    points, tetrahedra = kuhn_block((2, 2, 4), 0.01)            # 2 x 2 x 4 cm
    bar = ContinuumSolver(points, tetrahedra, youngs_modulus=E, poisson_ratio=0.0,
                          viscosity=1.0, density=RHO, fixed=bottom)
    stress = 100.0
    load = bar.surface_load((0, 0, stress * 0.02 * 0.02), lambda x: x[2] > 0.04 - 1e-9)
    stretch = bar.at(bar.static(load), [[0.01, 0.01, 0.04], [0.0, 0.0, 0.02]])
    assert stretch[:, 2] == pytest.approx([stress * 0.04 / E, stress * 0.02 / E], rel=1e-6)
    assert np.abs(stretch[:, :2]).max() < 1e-9 * stretch[0, 2]
    nu = 0.3                     # lateral contraction where nothing holds it: far from the base
    free_bar = ContinuumSolver(points, tetrahedra, youngs_modulus=E, poisson_ratio=nu,
                               viscosity=1.0, density=RHO, fixed=bottom)
    side = free_bar.at(free_bar.static(load), [[0.02, 0.01, 0.035]])[0]
    assert side[0] == pytest.approx(-nu * stress / E * 0.01, rel=0.05)
    hanging = ContinuumSolver(points, tetrahedra, youngs_modulus=E, poisson_ratio=0.0,
                              viscosity=1.0, density=RHO, fixed=lambda x: x[2] > 0.04 - 1e-9)
    weight = hanging.gravity_load((0, 0, -9.81))
    assert weight.sum() == pytest.approx(-9.81 * RHO * 0.02 * 0.02 * 0.04, rel=1e-10)
    sag = hanging.at(hanging.static(weight), [[0.01, 0.01, 0.0], [0.01, 0.01, 0.02]])[:, 2]
    # u(s) = -ρ g (L s - s²/2) / E with s measured down from the held top
    expected = [-RHO * 9.81 * (0.04 * s - s * s / 2) / E for s in (0.04, 0.02)]
    assert sag == pytest.approx(expected, rel=1e-6)


def test_the_reference_dynamics_settle_at_its_statics_and_converge_in_time():
    points, tetrahedra = kuhn_block((2, 2, 2), 0.01)
    solver = ContinuumSolver(points, tetrahedra, youngs_modulus=E, poisson_ratio=0.45,
                             viscosity=50.0, density=RHO, fixed=bottom, order=1)
    load = solver.probe_load((0.01, 0.01, 0.02), 0.006, FORCE)
    static = solver.at(solver.static(load), [[0.01, 0.01, 0.02]])
    coarse = solver.at(solver.dynamic(load, dt=2e-3, n_frames=200, substeps=2),
                       [[0.01, 0.01, 0.02]])
    fine = solver.at(solver.dynamic(load, dt=2e-3, n_frames=200, substeps=8),
                     [[0.01, 0.01, 0.02]])
    assert fine[-1] == pytest.approx(static, rel=1e-3)             # settled (heavily damped)
    assert np.abs(fine[:40] - coarse[:40]).max() < 0.02 * np.abs(static).max()


@pytest.mark.parametrize("poisson_ratio", [0.45, 0.49])
def test_nodal_volumetric_form_does_not_lock(poisson_ratio):
    """On the same 1 cm mesh, nearly incompressible: the per-element form is far too stiff
    (it locks), the nodal form is not, against quadratic tetrahedra on that mesh."""
    points = markers()
    shape, spacing = (4, 4, 3), 0.01
    solver = ContinuumSolver(*kuhn_block(shape, spacing), youngs_modulus=E,
                             poisson_ratio=poisson_ratio, viscosity=1.0, density=RHO,
                             fixed=bottom)
    reference = solver.at(solver.static(solver.probe_load(PROBE, RADIUS, FORCE)), points)
    errors = {form: relative_error(our_static(shape, spacing, poisson_ratio, form, points),
                                   reference) for form in ("element", "nodal")}
    assert errors["nodal"] < 0.6 * errors["element"], errors
    compliance = {form: float(np.sum(our_static(shape, spacing, poisson_ratio, form, points)
                                     * reference) / np.sum(reference**2))
                  for form in ("element", "nodal")}
    assert compliance["element"] < compliance["nodal"]              # locking: too stiff


@pytest.mark.slow
@pytest.mark.parametrize("poisson_ratio", [0.3, 0.45, 0.49])
def test_both_forms_converge_to_the_continuum_and_nodal_converges_faster(poisson_ratio):
    points = markers()
    solver = ContinuumSolver(*kuhn_block((8, 8, 6), 0.005), youngs_modulus=E,
                             poisson_ratio=poisson_ratio, viscosity=1.0, density=RHO,
                             fixed=bottom)
    reference = solver.at(solver.static(solver.probe_load(PROBE, RADIUS, FORCE)), points)
    errors = {(form, spacing): relative_error(
        our_static(tuple(int(round(n * 0.01 / spacing)) for n in (4, 4, 3)), spacing,
                   poisson_ratio, form, points), reference)
        for form in ("element", "nodal") for spacing in (0.01, 0.005)}
    for form in ("element", "nodal"):
        assert errors[form, 0.005] < 0.75 * errors[form, 0.01], errors
    assert errors["nodal", 0.005] < errors["element", 0.005], errors
    assert errors["nodal", 0.005] < 0.13, errors
