"""The large-strain plate reference (:mod:`neurofuzzy.validation.plates`): FElupe's three-field
quadratic tetrahedra, read at the beads, checked against the uniaxial closed form, and the
stored recordings (``tests/data/plates_nu*.npz``) reproduced by a coarser solve."""

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("felupe")

from neurofuzzy.errors import InputError  # noqa: E402
from neurofuzzy.validation.nonlinear.closed_forms import uniaxial_stress  # noqa: E402
from neurofuzzy.validation.nonlinear.materials import NeoHookean  # noqa: E402
from neurofuzzy.validation.plates import (SIZE, STRAINS, YOUNGS, beads,  # noqa: E402
                                          compress_between_plates, converged_force)

DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize("nu", [0.45, 0.499])
def test_sliding_plates_give_the_uniaxial_closed_form(nu):
    """Frictionless plates: the cube deforms homogeneously, so the beads move by the closed
    form's stretches and the plate's force is its nominal stress times the area, to the
    solver's tolerance (the force's sign: the plate pushes down)."""
    points = np.random.default_rng(1).uniform(0, SIZE, size=(30, 3))
    got = compress_between_plates(points, size=SIZE, youngs_modulus=YOUNGS, poisson_ratio=nu,
                                  strains=[0.1, 0.2], cells=2, plates="sliding")
    exact = uniaxial_stress(NeoHookean(YOUNGS, nu), np.array([0.9, 0.8]))
    for k, strain in enumerate([0.1, 0.2]):
        lateral = exact.lateral_stretch[k] - 1
        expected = points * np.array([lateral, lateral, -strain])
        assert np.abs(got.displacements[k] - expected).max() < 1e-12
        assert got.force[k, 2] == pytest.approx(exact.nominal_stress[k] * SIZE**2, rel=1e-9)
        assert got.force[k, 2] < 0


@pytest.mark.parametrize("nu", [0.45, 0.49, 0.499])
def test_the_stored_recordings_are_what_felupe_computes(nu):
    """A 3-cell solve of the recorded experiment lands near the stored 6/8-cell recording:
    beads within 4 % of their largest displacement (1 % in RMS), the force within 8 % of the
    extrapolated one and above it (the force converges from above); the stored extrapolation
    is
    :func:`converged_force` of the stored meshes' forces."""
    stored = np.load(DATA / f"plates_nu{nu}.npz")
    assert np.array_equal(stored["beads"], beads())
    coarse = compress_between_plates(stored["beads"], size=SIZE, youngs_modulus=YOUNGS,
                                     poisson_ratio=nu, strains=STRAINS, cells=3)
    scale = np.abs(stored["displacements"]).max()
    difference = coarse.displacements - stored["displacements"]
    assert np.abs(difference).max() < 0.04 * scale
    assert np.sqrt(np.mean(difference**2)) < 0.01 * scale
    ratio = coarse.force[:, 2] / stored["force"][:, 2]
    assert np.all((ratio > 1.0) & (ratio < 1.08))
    assert np.all(np.abs(stored["force_fine"][:, 2]) < np.abs(stored["force_coarse"][:, 2]))
    fine, rough = (type(coarse)(None, stored[key], int(n)) for key, n
                   in zip(("force_fine", "force_coarse"), stored["cells"][::-1]))
    assert np.allclose(converged_force(rough, fine), stored["force"])


def test_bad_arguments_are_refused():
    with pytest.raises(InputError, match="increasing positive"):
        compress_between_plates(beads(3), size=SIZE, youngs_modulus=YOUNGS,
                                poisson_ratio=0.45, strains=[0.1, 0.05])
    with pytest.raises(InputError, match="'bonded' or 'sliding'"):
        compress_between_plates(beads(3), size=SIZE, youngs_modulus=YOUNGS,
                                poisson_ratio=0.45, strains=[0.1], plates="glued")
    with pytest.raises(InputError, match="outside the block"):
        compress_between_plates(np.array([[0.5, 0.5, 2.0]]) * SIZE, size=SIZE,
                                youngs_modulus=YOUNGS, poisson_ratio=0.45, strains=[0.1],
                                cells=1)
