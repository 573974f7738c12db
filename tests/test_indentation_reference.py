"""The deep-indentation reference (:mod:`neurofuzzy.validation.nonlinear.indentation`): sfepy's
quadratic tetrahedra and contact term, checked against Hertz at a shallow depth, and the stored
recording (``tests/data/indentation_nu0.45.npz``) reproduced by a coarser solve; its mixed
displacement–pressure form free of the locking of displacement alone at ν 0.499."""

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("sfepy")

from neurofuzzy.errors import InputError  # noqa: E402
from neurofuzzy.validation.indentation import bonded_layer_force, quarter_block  # noqa: E402
from neurofuzzy.validation.nonlinear import NeoHookean  # noqa: E402
from neurofuzzy.validation.nonlinear.indentation import (indent_quarter,  # noqa: E402
                                                          indent_with_sphere)

DATA = Path(__file__).parent / "data"
H = 0.02


def _indent(stored, cells, centres, markers=None, stretch=2.0):
    model, _ = quarter_block(cells, half_width=float(stored["half_width"]), height=H,
                             stretch=stretch)
    return indent_quarter(
        model.mesh,
        material=NeoHookean(float(stored["youngs_modulus"]), float(stored["poisson_ratio"])),
        radius=float(stored["radius"]), centres=centres, markers=markers, penalty=1e9,
        increments=2)


@pytest.mark.slow
def test_the_stored_recording_is_what_sfepy_computes():
    """A 4-cell solve of the recorded indentation lands near the stored finer one: the force
    within 8 % and above it (a coarse mesh is too stiff), the markers within 10 % of their
    largest displacement."""
    stored = np.load(DATA / "indentation_nu0.45.npz")
    coarse = _indent(stored, 4, stored["centres"], stored["markers"])
    ratio = 4 * coarse.force[:, 2] / stored["force"][:, 2]
    assert np.all((ratio > 1.0) & (ratio < 1.08))
    scale = np.abs(stored["displacements"]).max()
    assert np.abs(coarse.displacements - stored["displacements"]).max() < 0.1 * scale


@pytest.mark.slow
def test_a_shallow_press_is_near_the_bonded_layer_closed_form():
    """At 1 % of the height (the contact radius 1.4 mm, 0.07 of the height) sfepy's force is
    near Dimitriadis et al.'s closed form for a bonded layer, within the coarse mesh's 15 %."""
    stored = np.load(DATA / "indentation_nu0.45.npz")
    depth, radius = 0.01 * H, float(stored["radius"])
    got = _indent(stored, 5, [[0, 0, H + radius], [0, 0, H + radius - depth]], stretch=4.0)
    expected = bonded_layer_force(6000.0, 0.45, radius, depth, H)
    assert -4 * got.force[0, 2] == pytest.approx(expected, rel=0.15)


@pytest.mark.slow
def test_the_mixed_form_does_not_lock_where_displacement_alone_does():
    """At ν 0.499 a sphere pressed 1 mm: quadratic tetrahedra of displacement alone give a
    force that falls by more than 10 % from 3 to 4 cells a side (they lock); with the mixed
    pressure it moves by less than 1 %, and the displacement-only force is over 10 % above
    it."""
    material = NeoHookean(6000.0, 0.499)
    forces = {}
    for cells in (3, 4):
        model, _ = quarter_block(cells, half_width=0.02, height=H, stretch=2.0)
        for mixed in (False, True):
            forces[cells, mixed] = indent_quarter(
                model.mesh, material=material, radius=0.01,
                centres=[[0, 0, H + 0.01], [0, 0, H + 0.01 - 1e-3]], penalty=1e9,
                increments=2, mixed=mixed).force[0, 2]
    assert forces[4, False] / forces[3, False] < 0.9
    assert forces[4, True] / forces[3, True] == pytest.approx(1.0, abs=0.01)
    assert forces[4, False] / forces[4, True] > 1.1


def test_bad_arguments_are_refused():
    with pytest.raises(InputError, match="n_steps \\+ 1, 3"):
        indent_with_sphere(np.zeros((4, 3)), np.array([[0, 1, 2, 3]]),
                           material=NeoHookean(6000.0, 0.45), radius=0.01,
                           centres=[[0, 0, 1]], fixed={}, top=0.0, penalty=1e9)
    with pytest.raises(InputError, match="order 2"):
        indent_with_sphere(np.zeros((4, 3)), np.array([[0, 1, 2, 3]]),
                           material=NeoHookean(6000.0, 0.45), radius=0.01,
                           centres=[[0, 0, 1], [0, 0, 0.9]], fixed={}, top=0.0, penalty=1e9,
                           order=1, mixed=True)
