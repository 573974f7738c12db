"""Corotational elements (``law="corotational"``): linear elasticity in each element's rotating
frame, SOFA's ``TetrahedronFEMForceField`` with polar rotations, added as one record and one
kernel function. Against its closed forms: the first Piola–Kirchhoff stress ``R (λ tr ε I +
2μ ε)`` with ``F = R U``, ``ε = U - I`` at stretches from 0.2 to 5 and any rotation, and a
block's uniaxial nominal stress ``E (λ - 1)`` at any stretch; and as the exports write it.
Its derivatives, small-strain limit and sweeps are checked with every law by
tests/test_kernels_law.py and tests/test_terms_registry.py."""

import numpy as np
import pytest

import neurofuzzy as nf
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.forces.laws import law_number
from neurofuzzy.kernels.laws import elastic
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model

E, NU = 6000.0, 0.45
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
CO = law_number("corotational")


def _six(M):
    return (M[0, 0], M[1, 1], M[2, 2], M[0, 1], M[0, 2], M[1, 2])


@pytest.mark.parametrize("stretches", [(0.2, 1.0, 1.0), (5.0, 0.6, 1.1), (1.3, 0.8, 1.05)])
def test_the_stress_is_linear_elasticity_in_the_rotating_frame(stretches):
    rng = np.random.default_rng(7)
    for _ in range(4):
        R, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        R *= np.sign(np.linalg.det(R))
        Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        U = Q @ np.diag(stretches) @ Q.T                  # stretch along random axes
        F = R @ U
        strain = U - np.eye(3)
        theta = np.trace(strain)
        s, got_theta = elastic(CO, _six(0.5 * (F.T @ F - np.eye(3))), 2 * MU, LAM * theta, 0.0)
        S = np.array([[s[0], s[3], s[4]], [s[3], s[1], s[5]], [s[4], s[5], s[2]]])
        want = R @ (LAM * theta * np.eye(3) + 2 * MU * strain)
        assert got_theta == pytest.approx(theta, abs=1e-12)
        assert np.allclose(F @ S, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


@pytest.mark.parametrize("stretch", [0.6, 1.5])
def test_a_block_carries_e_times_the_stretch_less_one(stretch):
    """A block stretched homogeneously (axial ``λ``, lateral ``1 - ν (λ - 1)``): the force on
    its end face per reference area is ``E (λ - 1)``, its free sides carry none."""
    mesh = from_tetra(*kuhn_block((2, 2, 2), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=0.0,
                            density=1000.0, law="corotational", volumetric="element")
    lateral = 1 - NU * (stretch - 1)
    rest = mesh.rest_positions
    force = model.elements.force(model, rest @ np.diag([lateral, lateral, stretch]).T,
                                 np.zeros_like(rest))
    top = np.isclose(rest[:, 2], 0.02)
    assert -force[top, 2].sum() / 0.02**2 == pytest.approx(E * (stretch - 1), rel=1e-10)
    side = np.isclose(rest[:, 0], 0.02)
    assert abs(force[side, 0].sum()) < 1e-10 * np.abs(force).max()


def test_sofa_writes_polar_rotations_and_febio_says_it_has_none(tmp_path):
    mesh = from_tetra(*kuhn_block((2, 2, 1), 0.01)).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    model = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=NU, viscosity=2.0,
                            density=1000.0, law="corotational")
    sofa = nf.export(model, to="sofa", path=tmp_path / "t.py")
    text = (tmp_path / "t.py").read_text()
    assert "METHOD = 'polar'" in text
    assert not any("material law" in note or "method 'large'" in note for note in sofa.notes)
    febio = nf.export(model, to="febio", path=tmp_path / "t.feb")
    assert any("no corotational solid" in note for note in febio.notes), febio.notes
    assert 'type="isotropic elastic"' in (tmp_path / "t.feb").read_text()
