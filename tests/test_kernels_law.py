"""The elements' law of the compiled kernels (:mod:`neurofuzzy.kernels.svk`): its derivatives,
generated from the one function by complex step, against central differences of that function
(forward) and by the dot-product test (reverse)."""

import numpy as np
import pytest

from neurofuzzy.kernels.svk import stress, stress_jvp, stress_vjp


def _inner(a, b):
    """``a : b`` of symmetric matrices given by six entries."""
    a, b = np.asarray(a), np.asarray(b)
    return float(a[:3] @ b[:3] + 2 * a[3:] @ b[3:])


@pytest.mark.parametrize("kappa", [0.0, 4e3])
def test_the_generated_derivatives_of_the_law_are_its_derivatives(kappa):
    rng = np.random.default_rng(5)
    G, Gd, dG, dGd, LS = (tuple(rng.normal(0, scale, 6)) for scale in (0.1, 2.0, 1.0, 1.0, 1.0))
    shear, rate, pressure = 4e3, 10.0, 700.0
    d_shear, d_rate, d_pressure = 300.0, 2.0, 50.0
    eps = 1e-6

    def law(t):
        move = lambda x, d: tuple(np.add(x, t * np.asarray(d)))  # noqa: E731
        return np.array(stress(move(G, dG), move(Gd, dGd), shear + t * d_shear,
                               rate + t * d_rate, pressure + t * d_pressure, kappa))

    central = (law(eps) - law(-eps)) / (2 * eps)
    forward = np.array(stress_jvp(G, Gd, dG, dGd, shear, rate, kappa, d_shear, d_rate,
                                  d_pressure))
    assert np.allclose(forward, central, rtol=1e-7, atol=1e-7 * np.abs(central).max())
    LG, LGd, l_shear, l_rate, l_pressure, l_kappa = stress_vjp(G, Gd, LS, shear, rate, kappa)
    # <L_S, dS> = <L_G, dG> + <L_Ġ, dĠ> + Σ l_c dc for every direction
    want = _inner(LS, forward)
    got = (_inner(LG, dG) + _inner(LGd, dGd) + l_shear * d_shear + l_rate * d_rate
           + l_pressure * d_pressure)
    assert got == pytest.approx(want, rel=1e-10)
    # κ's own cotangent: the derivative along dκ = 1 (through shear + 2κ G:G)
    squared = _inner(G, G)
    along_kappa = np.array(stress_jvp(G, Gd, (0.0,) * 6, (0.0,) * 6, shear, rate, kappa,
                                      2 * squared, 0.0, 0.0))
    assert l_kappa == pytest.approx(_inner(LS, along_kappa), rel=1e-10)
