"""The elements' laws of the compiled kernels (:mod:`neurofuzzy.kernels.laws`), for every law
of :data:`neurofuzzy.forces.laws.LAWS`: the derivatives generated from the one function by
complex step against central differences of that function (forward) and by the dot-product
test (reverse); ``∂θ/∂G`` is the stress of unit pressure; the law is linear elasticity at small
strain, and the numpy force path's stress (:class:`neurofuzzy.forces.laws.ElementStress`) is
the compiled one with its derivatives."""

import numpy as np
import pytest

from neurofuzzy.forces.laws import (LAWS, STIFFENING_CONSTANT, ElementStress, law_number,
                                   law_numbers, stiffening_slope, stiffens, uniaxial_stress)
from neurofuzzy.errors import InputError
from neurofuzzy.kernels.laws import elastic, stress, stress_jvp, stress_vjp, volumetric


def _inner(a, b):
    """``a : b`` of symmetric matrices given by six entries."""
    a, b = np.asarray(a), np.asarray(b)
    return float(a[:3] @ b[:3] + 2 * a[3:] @ b[3:])


def _full(s):
    return np.array([[s[0], s[3], s[4]], [s[3], s[1], s[5]], [s[4], s[5], s[2]]])


def _six(m):
    return (m[0, 0], m[1, 1], m[2, 2], m[0, 1], m[0, 2], m[1, 2])


LAW_NUMBERS = list(range(len(LAWS)))


@pytest.mark.parametrize("law", LAW_NUMBERS)
@pytest.mark.parametrize("kappa", [0.0, 4e3])
def test_the_generated_derivatives_of_the_law_are_its_derivatives(law, kappa):
    rng = np.random.default_rng(5 + law)
    G, Gd, dG, dGd, LS = (tuple(rng.normal(0, scale, 6)) for scale in (0.1, 2.0, 1.0, 1.0, 1.0))
    shear, rate, pressure, pressure_rate, stiffening = 4e3, 10.0, 700.0, -30.0, 1.3
    d = dict(shear=300.0, rate=2.0, pressure=50.0, pressure_rate=7.0, kappa=1e3,
             stiffening=0.4)
    eps = 1e-6

    def law_at(t):
        move = lambda x, dx: tuple(np.add(x, t * np.asarray(dx)))  # noqa: E731
        return np.array(stress(law, move(G, dG), move(Gd, dGd), shear + t * d["shear"],
                               rate + t * d["rate"], pressure + t * d["pressure"],
                               pressure_rate + t * d["pressure_rate"], kappa + t * d["kappa"],
                               stiffening + t * d["stiffening"]))

    central = (law_at(eps) - law_at(-eps)) / (2 * eps)
    forward = np.array(stress_jvp(law, G, Gd, dG, dGd, shear, rate, pressure, pressure_rate,
                                  kappa, stiffening, d["shear"], d["rate"], d["pressure"],
                                  d["pressure_rate"], d["kappa"], d["stiffening"]))
    assert np.allclose(forward, central, rtol=1e-6, atol=1e-7 * np.abs(central).max())
    LG, LGd, *cotangents = stress_vjp(law, G, Gd, LS, shear, rate, pressure, pressure_rate,
                                      kappa, stiffening)
    # <L_S, dS> = <L_G, dG> + <L_Ġ, dĠ> + Σ l_c dc for every direction
    want = _inner(LS, forward)
    got = (_inner(LG, dG) + _inner(LGd, dGd)
           + sum(l * dc for l, dc in zip(cotangents, d.values())))
    assert got == pytest.approx(want, rel=1e-9)


@pytest.mark.parametrize("law", LAW_NUMBERS)
def test_the_laws_with_a_constant_of_their_own_are_the_ones_named(law):
    """The toolkit reads an element's ``element_stiffening`` (learns it, writes it, says it in
    words) where :data:`STIFFENING_CONSTANT` names its law: exactly the laws whose compiled
    stress depends on it."""
    G, Gd = (0.1, -0.05, 0.08, 0.03, -0.02, 0.04), (0.0,) * 6
    one, other = (np.array(stress(law, G, Gd, 4e3, 0.0, 700.0, 0.0, 0.0, c)) for c in (0.5, 2.0))
    assert (not np.allclose(one, other, rtol=1e-12, atol=0.0)) == (law in STIFFENING_CONSTANT)
    assert stiffens(np.array([law]))[0] == (law in STIFFENING_CONSTANT)


@pytest.mark.parametrize("law", LAW_NUMBERS)
def test_the_volumetric_strain_s_gradient_is_the_stress_of_unit_pressure(law):
    rng = np.random.default_rng(11)
    G = tuple(rng.normal(0, 0.1, 6))
    theta, N = volumetric(law, G)
    eps = 1e-6
    for k in range(6):
        step = np.zeros(6)
        step[k] = eps
        slope = (volumetric(law, tuple(G + step))[0] - volumetric(law, tuple(G - step))[0]) / (
            2 * eps)
        assert slope == pytest.approx(N[k] * (1 if k < 3 else 2), rel=1e-7)
    assert np.allclose(N, elastic(law, G, 0.0, 1.0, 0.7)[0])


@pytest.mark.parametrize("law", LAW_NUMBERS)
@pytest.mark.parametrize("stiffening", [0.0, 5.0])
def test_every_law_is_linear_elasticity_at_small_strain(law, stiffening):
    """``S ≈ 2μ ε + λ tr ε I`` for ``G = ε`` of size 1e-7, whatever the law's stiffening."""
    rng = np.random.default_rng(3)
    eps = tuple(1e-7 * rng.normal(size=6))
    mu, lam = 2e3, 9e3
    theta = volumetric(law, eps)[0]
    S = np.array(elastic(law, eps, 2 * mu, lam * theta, stiffening)[0])
    linear = 2 * mu * np.array(eps) + lam * sum(eps[:3]) * np.array([1, 1, 1, 0, 0, 0])
    assert np.allclose(S, linear, rtol=1e-5, atol=1e-12 * lam)


def _symmetric(rng, shape):
    X = rng.normal(size=shape + (3, 3))
    return 0.5 * (X + np.swapaxes(X, -1, -2))


@pytest.mark.parametrize("law", LAW_NUMBERS)
def test_the_numpy_path_takes_its_stress_from_the_compiled_one(law):
    """``ElementStress`` (the numpy force path's stress) is the compiled ``stress`` written
    once: at 30 % compression and shear its ``S`` and ``θ`` are the kernel's; its forward
    derivative along strain and volumetric-stress changes is the central difference of ``S``,
    its reverse one the adjoint of that (dot-product test), its partials those by the four
    constants; ``∂D/∂c`` (``stiffening_slope``) is the central difference in the law's
    constant; St. Venant–Kirchhoff's partials are ``G``, ``Ġ``, ``I``, ``I`` and its ``N``,
    ``θ`` exactly ``I``, ``tr G``."""
    rng = np.random.default_rng(law)
    F = np.array([[1.0, 0.2, 0.0], [0.05, 1.0, 0.1], [0.0, 0.0, 0.7]])
    G = np.stack([0.5 * (F.T @ F - np.eye(3)), 0.25 * (F.T @ F - np.eye(3))])
    Gd = _symmetric(rng, (2,))
    laws, c = np.array([law, law]), [0.8, 0.8]
    constants = dict(shear=np.array([4e3, 3e3]), shear_rate=np.array([2.0, 1.0]),
                     pressure=np.array([2e3, -1e3]), pressure_rate=np.array([5.0, -3.0]))

    def at(G, Gd, **changed):
        return ElementStress.at(laws, G, Gd, stiffening=c, **{**constants, **changed})

    point = at(G, Gd)
    S = point.stress()
    for e in range(2):
        want = stress(law, _six(G[e]), _six(Gd[e]), *(constants[k][e] for k in (
            "shear", "shear_rate", "pressure", "pressure_rate")), 0.0, c[e])
        assert np.allclose(S[e], _full(want), rtol=1e-12, atol=0)
        assert point.theta[e] == pytest.approx(volumetric(law, _six(G[e]))[0], rel=1e-12)
    dG, dGd = _symmetric(rng, (2, 3)), _symmetric(rng, (2, 3))
    d_pressure, d_pressure_rate = rng.normal(size=(2, 3)) * 1e3, rng.normal(size=(2, 3))
    slope = point.jvp(dG, dGd, d_pressure, d_pressure_rate)
    eps = 1e-6
    for p in range(3):
        def moved(sign):
            return at(G + sign * eps * dG[:, p], Gd + sign * eps * dGd[:, p],
                      pressure=constants["pressure"] + sign * eps * d_pressure[:, p],
                      pressure_rate=constants["pressure_rate"]
                      + sign * eps * d_pressure_rate[:, p]).stress()
        central = (moved(1) - moved(-1)) / (2 * eps)
        assert np.allclose(slope[:, p], central, rtol=1e-6, atol=1e-6 * np.abs(S).max())
    LS = _symmetric(rng, (2,))
    LG, LGd, l_pressure, l_pressure_rate = point.vjp(LS)
    forward = np.einsum("eij,epij->ep", LS, slope)
    backward = (np.einsum("epij,eij->ep", dG, LG) + np.einsum("epij,eij->ep", dGd, LGd)
                + l_pressure[:, None] * d_pressure + l_pressure_rate[:, None] * d_pressure_rate)
    assert np.allclose(forward, backward, rtol=1e-10)
    for name, partial in point.partials().items():
        central = (at(G, Gd, **{name: constants[name] + 1.0}).stress()
                   - at(G, Gd, **{name: constants[name] - 1.0}).stress()) / 2.0
        assert np.allclose(partial, central, rtol=1e-9, atol=1e-12), name
    by_constant = (ElementStress.at(laws[:1], G[:1], Gd[:1], 1.0, 0.0, 0.0, 0.0,
                                    [c[0] + eps]).stress()
                   - ElementStress.at(laws[:1], G[:1], Gd[:1], 1.0, 0.0, 0.0, 0.0,
                                      [c[0] - eps]).stress()) / (2 * eps)
    assert np.allclose(stiffening_slope(laws[:1], G[:1], c[:1]), by_constant,
                       rtol=1e-6, atol=1e-9)
    if LAWS[law] == "st-venant-kirchhoff":
        by, unit = point.partials(), np.broadcast_to(np.eye(3), G.shape)
        for name, want in (("shear", G), ("shear_rate", Gd), ("pressure", unit),
                           ("pressure_rate", unit)):     # complex step: to round-off
            assert np.allclose(by[name], want, rtol=1e-15, atol=1e-15), name
        assert np.array_equal(point.N, np.broadcast_to(np.eye(3), G.shape))
        assert np.array_equal(point.theta, np.trace(G, axis1=1, axis2=2))


def test_the_neo_hookean_law_is_bonet_and_wood_s():
    """``S = μ (I - C⁻¹) + λ ln J C⁻¹`` for ``π = λ ln J`` at J = 0.7 · 1.03."""
    F = np.diag([1.0, 1.03, 0.7])
    C = F.T @ F
    mu, lam = 2e3, 9e3
    G = _six(0.5 * (C - np.eye(3)))
    log_j = np.log(np.linalg.det(F))
    theta = volumetric(law_number("neo-hookean"), G)[0]
    assert theta == pytest.approx(log_j, rel=1e-12)
    S = _full(elastic(law_number("neo-hookean"), G, 2 * mu, lam * theta, 0.0)[0])
    inverse = np.linalg.inv(C)
    assert np.allclose(S, mu * (np.eye(3) - inverse) + lam * log_j * inverse, rtol=1e-12)


@pytest.mark.parametrize("stiffening", [0.0, 1.5])
def test_the_yeoh_law_is_the_reference_yeoh_solid(stiffening):
    """``S`` of the compiled law against the principal stresses ``∂Ψ/∂λᵢ / λᵢ`` of
    :class:`neurofuzzy.validation.nonlinear.Yeoh` (its energy in principal stretches, written
    apart) with ``C₂₀ = c C₁₀``, under 30 % compression with free-ish sides."""
    from neurofuzzy.validation.nonlinear import Yeoh

    E, nu = 5e3, 0.45
    reference = Yeoh.from_youngs(E, nu, c20_ratio=stiffening)
    stretches = np.array([0.7, 1.12, 1.09])
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    law = law_number("yeoh")
    G = _six(np.diag(0.5 * (stretches**2 - 1)))
    theta = volumetric(law, G)[0]
    assert theta == pytest.approx(np.prod(stretches) - 1, rel=1e-12)
    S = _full(elastic(law, G, 2 * mu, lam * theta, stiffening)[0])
    want = reference.principal_nominal_stress(stretches) / stretches
    assert np.allclose(np.diag(S), want, rtol=1e-10)
    assert np.allclose(S - np.diag(np.diag(S)), 0.0)


@pytest.mark.parametrize("size", [0.02, 0.25, 0.5])
def test_the_corotational_law_is_sofa_s_polar_element(size):
    """``P = F S`` of the corotational law is ``R (2μ (U - I) + λ tr(U - I) I)``, the force of
    SOFA's ``TetrahedronFEMForceField`` with ``method="polar"`` (the small-strain stress of
    the element's displacement rotated back, ``f = R K₀ (Rᵀ x - x₀)``), with ``F = R U`` from
    SciPy's polar decomposition, for deformations up to half the size of the element (one
    squeezed to about 40 % of its volume); in uniaxial stress ``E (λ - 1)``, the closed form;
    zero under a rigid rotation."""
    from scipy.linalg import expm, polar

    rng = np.random.default_rng(int(100 * size))
    mu, lam = 2e3, 9e3
    law = law_number("corotational")
    for _ in range(5):
        F = np.eye(3) + size * rng.normal(size=(3, 3))
        if np.linalg.det(F) <= 0.1:
            continue
        R, U = polar(F)
        G = _six(0.5 * (F.T @ F - np.eye(3)))
        theta = volumetric(law, G)[0]
        assert theta == pytest.approx(np.trace(U) - 3, abs=1e-13)
        S = _full(elastic(law, G, 2 * mu, lam * theta, 0.0)[0])
        want = R @ (2 * mu * (U - np.eye(3)) + lam * (np.trace(U) - 3) * np.eye(3))
        assert np.allclose(F @ S, want, rtol=0, atol=1e-11 * np.abs(want).max())
    # pulled or pressed with free sides, its nominal stress is E (λ - 1) at every stretch λ
    stretches = np.array([0.6, 0.8, 1.2, 1.5])
    assert np.allclose(uniaxial_stress("corotational", 6e3, 0.45, stretches),
                       6e3 * (stretches - 1), rtol=1e-8)
    spin = expm(np.array([[0.0, -1.2, 0.4], [1.2, 0.0, -0.7], [-0.4, 0.7, 0.0]]))
    G = _six(0.5 * (spin.T @ spin - np.eye(3)))
    assert np.allclose(elastic(law, G, 2 * mu, lam * volumetric(law, G)[0], 0.0)[0], 0.0,
                       atol=1e-9)


def test_law_names_numbers_and_mistakes():
    assert law_number("Neo-Hookean") == law_number("neo_hookean") == law_number("nh") == 1
    assert law_number("svk") == 0
    assert list(law_numbers(["neo-hookean", "svk", "neo-hookean"], 3)) == [1, 0, 1]
    assert list(law_numbers(None, 2)) == [0, 0]
    with pytest.raises(InputError, match="did you mean 'neo-hookean'"):
        law_number("neo-hooken")
    with pytest.raises(InputError, match=f"expected 0..{len(LAWS) - 1}"):
        law_numbers(np.array([0, len(LAWS)]), 2)
    assert law_number("MR") == law_number("Mooney_Rivlin") == LAWS.index("mooney-rivlin")
    assert law_number("Corotated") == law_number("corot") == LAWS.index("corotational")
    with pytest.raises(InputError, match="one per element"):
        law_numbers(["svk"] * 2, 3)


def test_an_element_squeezed_flat_gives_nan_not_an_exception():
    """``det C = 0``: no neo-Hookean stress exists; both forms return NaN (the run then
    diverges and says so) instead of raising ZeroDivisionError or LinAlgError."""
    flat = (-0.5, 0.0, 0.0, 0.0, 0.0, 0.0)                   # C = diag(0, 1, 1)
    S, theta = elastic(law_number("neo-hookean"), flat, 4e3, 1e3, 0.0)
    assert np.all(np.isnan(S)) and np.isnan(theta)
    theta, N = ElementStress.strains(np.array([1]), _full(flat)[None])
    assert not np.all(np.isfinite(N)) and not np.isfinite(theta[0])
