"""The hand-written element tangent sweep against one generated from the per-element
function by complex step (``benchmarks/generated_sweeps.py``, which times the two): two
derivations of one derivative, to round-off, for every law and both volumetric forms."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from generated_sweeps import measure  # noqa: E402


@pytest.mark.slow
@pytest.mark.parametrize("law", ["st-venant-kirchhoff", "neo-hookean", "yeoh",
                                 "mooney-rivlin", "corotational"])
@pytest.mark.parametrize("form", ["element", "nodal"])
def test_the_hand_written_tangent_sweep_is_the_per_element_functions_derivative(law, form):
    row = measure(2, law, form, repeat=1)
    assert row["forward_difference"] < 1e-12
