"""The static equilibrium (neurofuzzy.simulation.static) against closed forms and against
scikit-fem's linear elasticity, and the Jacobians it runs on where the registry cannot reach
(relaxation's internal variables)."""

import numpy as np
import pytest
from scipy.optimize import brentq

from neurofuzzy.errors import InputError
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.simulation.static import ConvergenceError, Driven, equilibrium
from neurofuzzy.simulation.tangents import tangents

E = 6000.0
SIZE = 0.02          # the block's edge (m)


def _block(nu, law="st-venant-kirchhoff", volumetric="nodal", cells=3, fixed=False):
    points, tetrahedra = kuhn_block((cells, cells, cells), SIZE / cells)
    mesh = from_tetra(points, tetrahedra)
    if fixed:
        mesh = mesh.with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=nu, viscosity=3.0,
                           density=1000.0, volumetric=volumetric, law=law)


def _face(model, axis, value):
    return np.flatnonzero(np.isclose(model.mesh.rest_positions[:, axis], value))


def _sliding_compression(model, strain, increments=1):
    """Frictionless plates on the bottom and top faces, symmetry planes x = 0 and y = 0: a
    homogeneous uniaxial compression, which linear tetrahedra reproduce exactly (the patch
    test) whatever the law and volumetric form."""
    top = _face(model, 2, SIZE)
    driven = [Driven(_face(model, 2, 0.0), (0, 0, 0), "z"),
              Driven(top, (0, 0, -strain * SIZE), "z"),
              Driven(_face(model, 0, 0.0), (0, 0, 0), "x"),
              Driven(_face(model, 1, 0.0), (0, 0, 0), "y")]
    return top, equilibrium(model, driven=driven, increments=increments)


@pytest.mark.parametrize("volumetric", ["nodal", "element"])
@pytest.mark.parametrize("nu", [0.3, 0.45, 0.499])
def test_uniaxial_compression_of_st_venant_kirchhoff_is_its_closed_form(volumetric, nu):
    """SVK between frictionless plates: ``G₁₁ = -ν G₃₃``, ``S₃₃ = E G₃₃``, so the plate's
    force is ``A λ₃ E (λ₃² - 1)/2`` and the lateral stretch ``√(1 - 2ν G₃₃)``, exactly, at
    any strain (here 10 %)."""
    model = _block(nu, volumetric=volumetric)
    strain = 0.1
    top, result = _sliding_compression(model, strain, increments=2)
    stretch = 1.0 - strain
    g33 = 0.5 * (stretch**2 - 1.0)
    force = SIZE**2 * stretch * E * g33
    assert result.reaction_on(top)[2] == pytest.approx(force, rel=1e-7)
    lateral = np.sqrt(1.0 - 2.0 * nu * g33)
    rest = model.mesh.rest_positions
    np.testing.assert_allclose(result.positions[:, :2], rest[:, :2] * lateral, atol=1e-10)
    np.testing.assert_allclose(result.positions[:, 2], rest[:, 2] * stretch, atol=1e-10)
    assert result.residual <= 1e-8 * abs(force)


def test_uniaxial_compression_of_neo_hookean_is_its_closed_form():
    """The coupled neo-Hookean solid (``S = μ (I - C⁻¹) + λ ln J C⁻¹``) compressed by 25 %:
    the lateral stretch solves ``S₁₁ = 0`` (brentq here, from the energy written in this
    test), and the plate's force is ``A λ₃ S₃₃``."""
    nu = 0.45
    model = _block(nu, law="neo-hookean")
    strain = 0.25
    top, result = _sliding_compression(model, strain, increments=3)
    mu, lam = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    s3 = 1.0 - strain

    def lateral_stress(s1):
        log_j = np.log(s1 * s1 * s3)
        return mu * (1 - 1 / s1**2) + lam * log_j / s1**2

    s1 = brentq(lateral_stress, 0.9, 1.5)
    s33 = mu * (1 - 1 / s3**2) + lam * np.log(s1 * s1 * s3) / s3**2
    assert result.reaction_on(top)[2] == pytest.approx(SIZE**2 * s3 * s33, rel=1e-7)
    x = result.positions[:, 0] / np.maximum(model.mesh.rest_positions[:, 0], 1e-12)
    np.testing.assert_allclose(x[model.mesh.rest_positions[:, 0] > 0], s1, rtol=1e-8)


def _skfem_bonded(model, nu, displacement):
    """scikit-fem's linear elasticity on the same linear tetrahedra, bottom face fixed, top
    face moved by ``displacement`` (3,): the displacement field (n_nodes, 3)."""
    skfem = pytest.importorskip("skfem")
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    rest = model.mesh.rest_positions
    mesh = skfem.MeshTet(rest.T.copy(), np.asarray(model.mesh.tetrahedra).T.copy())
    basis = skfem.Basis(mesh, skfem.ElementVector(skfem.ElementTetP1()))
    K = skfem.asm(linear_elasticity(*lame_parameters(E, nu)), basis)
    dofs = basis.nodal_dofs                                   # (3, n_nodes)
    u = np.zeros(basis.N)
    bottom, top = _face(model, 2, 0.0), _face(model, 2, SIZE)
    for k in range(3):
        u[dofs[k, top]] = displacement[k]
    held = np.concatenate([dofs[:, bottom].ravel(), dofs[:, top].ravel()])
    u = skfem.solve(*skfem.condense(K, np.zeros(basis.N), x=u, D=held))
    return np.stack([u[dofs[k]] for k in range(3)], axis=1)


@pytest.mark.parametrize("nu", [0.3, 0.45])
def test_bonded_compression_at_small_strain_is_scikit_fems_linear_elasticity(nu):
    """Between bonded plates (no closed form) at 0.01 % strain, the element volumetric form
    is scikit-fem's linear tetrahedron: the displacement fields agree to the geometric
    nonlinearity (about the strain) and not better than that by chance."""
    model = _block(nu, volumetric="element", cells=3, fixed=True)
    shift = np.array([0.0, 0.0, -1e-4 * SIZE])
    top = _face(model, 2, SIZE)
    result = equilibrium(model, driven=Driven(top, shift))
    ours = result.positions - model.mesh.rest_positions
    reference = _skfem_bonded(model, nu, shift)
    error = np.abs(ours - reference).max() / np.abs(reference).max()
    assert error < 1e-3
    lateral = np.abs(reference[:, :2]).max()
    assert lateral > 1e-3 * np.abs(shift).max()           # the plates do hold the bulge


def test_locking_the_nodal_form_is_softer_than_the_element_form_at_nu_0499():
    """Bonded plates at ν = 0.499: linear tetrahedra with one volume constraint each lock
    (far too stiff); the nodal volumetric form does not (its force here is within a few
    percent of the incompressible limit's order, the element form's several times that)."""
    shift = np.array([0.0, 0.0, -0.01 * SIZE])
    forces = {}
    for volumetric in ("nodal", "element"):
        model = _block(0.499, volumetric=volumetric, cells=4, fixed=True)
        top = _face(model, 2, SIZE)
        forces[volumetric] = -equilibrium(model, driven=Driven(top, shift)).reaction_on(top)[2]
    uniaxial = E * SIZE**2 * 0.01              # frictionless plates: E A ε
    assert uniaxial < forces["nodal"] < 2.0 * uniaxial
    assert forces["element"] > 2.0 * forces["nodal"]


def test_a_block_graded_toward_its_faces_keeps_its_size_and_refines_its_faces():
    """``kuhn_block(grading=a)``: the same nodes and tetrahedra, the block's size unchanged,
    every tetrahedron positive, the cells at the faces ``1 - a`` and in the middle ``1 + a``
    times the uniform size (at the ends of the cells' sizes; a cell of ``1/8`` of the side
    has the mean ``1 ∓ a sinc``)."""
    uniform, tetrahedra = kuhn_block((8, 8, 8), SIZE / 8)
    graded, same = kuhn_block((8, 8, 8), SIZE / 8, grading=0.8)
    assert np.array_equal(same, tetrahedra)
    assert np.allclose(graded.min(axis=0), 0) and np.allclose(graded.max(axis=0), SIZE)
    edges = graded[tetrahedra[:, 1:]] - graded[tetrahedra[:, :1]]
    assert np.all(np.linalg.det(edges) != 0)
    assert np.all(np.sign(np.linalg.det(edges)) == np.sign(np.linalg.det(
        uniform[tetrahedra[:, 1:]] - uniform[tetrahedra[:, :1]])))
    levels = np.unique(graded[:, 2])
    cell = SIZE / 8
    mean = np.sin(np.pi / 4) / (np.pi / 4)
    assert levels[1] == pytest.approx((1 - 0.8 * mean) * cell, rel=1e-9)
    assert levels[5] - levels[4] == pytest.approx((1 + 0.8 * mean) * cell, rel=1e-9)
    with pytest.raises(InputError, match="grading"):
        kuhn_block((2, 2, 2), grading=1.0)


def test_grading_toward_bonded_plates_halves_the_error_against_felupe():
    """Bonded plates at ν = 0.499, 5 % strain: the plate force of the nodal form on 6 cells a
    side against FElupe's converged three-field reference (``tests/data``): 17 % too stiff
    uniform, about half that graded toward the faces (the bonded edges are singular)."""
    pytest.importorskip("felupe")
    from pathlib import Path
    recorded = np.load(Path(__file__).parent / "data" / "plates_nu0.499.npz")
    reference = -recorded["force"][0, 2]
    errors = {}
    for grading in (0.0, 0.8):
        points, tetrahedra = kuhn_block((6, 6, 6), SIZE / 6, grading=grading)
        mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
        model = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=0.499, viscosity=3.0,
                                density=1000.0, law="neo-hookean")
        top = _face(model, 2, SIZE)
        shift = (0.0, 0.0, -recorded["strains"][0] * SIZE)
        force = -equilibrium(model, driven=Driven(top, shift), increments=2).reaction_on(top)[2]
        errors[grading] = force / reference - 1
    assert 0.12 < errors[0.0] < 0.22
    assert 0.0 < errors[0.8] < 0.6 * errors[0.0]


def test_prony_terms_take_their_long_time_value_in_equilibrium():
    """A relaxing model's equilibrium is that of its long-time modulus (the Prony terms
    relaxed), and its instantaneous stiffness is ``1 + Σ g`` times that at rest."""
    model = _block(0.3, volumetric="element")
    relaxing = Model.continuum(model.mesh, youngs_modulus=E, poisson_ratio=0.3,
                               viscosity=3.0, density=1000.0, volumetric="element",
                               relaxation=[(0.5, 0.05)])
    top, plain = _sliding_compression(model, 0.05)
    _, relaxed = _sliding_compression(relaxing, 0.05)
    np.testing.assert_allclose(relaxed.positions, plain.positions, atol=1e-12)
    rest = model.mesh.rest_positions
    instant = tangents(relaxing, rest).stiffness.toarray()
    np.testing.assert_allclose(instant, 1.5 * tangents(model, rest).stiffness.toarray(),
                               atol=1e-9 * np.abs(instant).max())


def test_the_force_with_internal_variables_is_the_steppers():
    """With Prony terms' internal variables held, the force is the compiled stepper's, and
    the stiffness its central differences."""
    from neurofuzzy.simulation.steppers import NumbaStepper

    model = Model.continuum(_block(0.4).mesh, youngs_modulus=E, poisson_ratio=0.4,
                            viscosity=3.0, density=1000.0, law="neo-hookean",
                            relaxation=[(0.5, 0.05), (0.3, 0.5)])
    rng = np.random.default_rng(4)
    history = rng.normal(scale=50.0, size=(model.mesh.n_tetrahedra, 2, 6))

    def stepper_force(p, v):
        stepper = NumbaStepper(model, 0.0)
        stepper.history[...] = history
        stepper.advance(p.copy(), v.copy(), None, 1)
        return stepper.force.copy()

    p = model.mesh.rest_positions + 1e-3 * rng.normal(size=(model.n_nodes, 3))
    v = 0.01 * rng.normal(size=(model.n_nodes, 3))
    result = tangents(model, p, v, history)
    np.testing.assert_allclose(result.force, stepper_force(p, v), rtol=0,
                               atol=1e-10 * np.abs(result.force).max())
    dp = 1e-3 * rng.normal(size=p.shape)
    eps = 1e-6
    difference = (stepper_force(p + eps * dp, v) - stepper_force(p - eps * dp, v)) / (2 * eps)
    got = -(result.stiffness @ dp.ravel()).reshape(-1, 3)
    assert np.abs(got - difference).max() <= 1e-6 * np.abs(difference).max()


def test_the_stiffness_without_damping_is_the_same_at_rest_and_moving():
    """``damping=False`` (the static solve's) leaves the damping out and the stiffness as it
    is: with the nodal form's viscous coupling at a moving state, and at rest."""
    model = Model.continuum(_block(0.45).mesh, youngs_modulus=E, poisson_ratio=0.45,
                            viscosity=3.0, density=1000.0, law="neo-hookean")
    rng = np.random.default_rng(5)
    p = model.mesh.rest_positions + 1e-3 * rng.normal(size=(model.n_nodes, 3))
    for v in (np.zeros_like(p), 0.01 * rng.normal(size=p.shape)):
        full, stiffness_only = tangents(model, p, v), tangents(model, p, v, damping=False)
        assert stiffness_only.damping is None and full.damping is not None
        np.testing.assert_array_equal(stiffness_only.force, full.force)
        assert abs(stiffness_only.stiffness - full.stiffness).max() <= (
            1e-12 * abs(full.stiffness).max())


def test_bad_boundaries_are_refused_with_what_is_wrong():
    model = _block(0.3, fixed=True)
    top = _face(model, 2, SIZE)
    with pytest.raises(InputError, match="non-empty"):
        equilibrium(model, driven=Driven(np.array([], int), (0, 0, 0)))
    with pytest.raises(InputError, match="held twice"):
        equilibrium(model, driven=Driven(model.mesh.fixed[:2], (0, 0, 0)))
    with pytest.raises(InputError, match="out of range"):
        equilibrium(model, driven=Driven(np.array([model.n_nodes]), (0, 0, 0)))
    with pytest.raises(InputError, match="'xyz'"):
        equilibrium(model, driven=Driven(top, (0, 0, 0), "w"))
    with pytest.raises(InputError, match="not finite"):
        equilibrium(model, driven=Driven(top, (0, 0, np.nan)))
    with pytest.raises(InputError, match="load"):
        equilibrium(model, load=np.zeros((3, 3)))
    with pytest.raises(InputError, match="start must be finite positions"):
        equilibrium(model, start=np.full((model.n_nodes, 3), np.nan))


def test_an_increment_too_large_says_to_take_more():
    """SVK squeezed by 80 % at once collapses (its energy falls back to zero): Newton gives
    up with a message that names the remedy."""
    model = _block(0.3, fixed=True)
    top = _face(model, 2, SIZE)
    with pytest.raises(ConvergenceError, match="more increments"):
        equilibrium(model, driven=Driven(top, (0.3 * SIZE, 0, -0.8 * SIZE)),
                    max_iterations=6)


def test_a_spring_network_under_gravity_and_a_load_balances_them():
    """The paper's cube of springs with gravity and a push on its top: the supports' reaction
    balances the weight and the load (force balance), and the equilibrium is one the
    dynamics settle to (a long damped run ends there)."""
    from neurofuzzy.datasets import paper_cube_model, top_centre_node
    from neurofuzzy.effects import EFFECTS
    from neurofuzzy.simulation import simulate

    model = paper_cube_model().with_effects(
        EFFECTS["gravity"](params=np.array([0.0, 0.0, -9.81])))
    load = np.zeros((model.n_nodes, 3))
    load[top_centre_node(model.mesh)] = (0.02, 0.0, -0.1)
    result = equilibrium(model, load=load)
    weight = model.node_mass.sum() * 9.81        # the supports carry their own nodes too
    np.testing.assert_allclose(result.reaction.sum(axis=0), [-0.02, 0.0, 0.1 + weight],
                               atol=1e-9)
    settled = simulate(model, dt=0.01, n_frames=400, external_forces=load,
                       substeps="auto").positions[-1]
    assert np.abs(settled - result.positions).max() < 1e-3 * np.abs(
        result.positions - model.mesh.rest_positions).max()


def test_a_kept_factorisation_gives_the_same_equilibrium_in_fewer_factorisations(monkeypatch):
    """``factor``: the equilibrium at nearby parameters solved with a kept factorisation as
    GMRES's preconditioner is the one a fresh solve finds, with no new factorisation; one of
    another size (another set of held nodes) is ignored, not an error."""
    import neurofuzzy.simulation.static as static

    model = _block(0.45, law="neo-hookean", fixed=True)
    top = _face(model, 2, SIZE)
    plate = Driven(top, (0, 0, -0.1 * SIZE))
    first = equilibrium(model, driven=plate, increments=2)
    nearby = model.with_elements(youngs_modulus=1.05 * E, poisson_ratio=0.46)
    fresh = equilibrium(nearby, driven=plate, start=first.positions)
    count = []
    factor = static._factor
    monkeypatch.setattr(static, "_factor", lambda m: count.append(1) or factor(m))
    kept = equilibrium(nearby, driven=plate, start=first.positions, factor=first.factor)
    assert not count
    assert np.abs(kept.positions - fresh.positions).max() < 1e-9 * SIZE
    other = equilibrium(nearby, driven=Driven(top, (0, 0, -0.1 * SIZE), "z"),
                        start=first.positions, factor=first.factor)
    assert count and np.isfinite(other.positions).all()
