"""A long recording diagnosed on its first frames, the answer fitted on all of them
(:mod:`neurofuzzy.diagnosis.window`), on noisy embedded-marker data of our own simulator; and
the window's answer thrown out where the frames after it say otherwise."""

import json

import numpy as np
import pytest

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.diagnosis.window import LONG, WINDOW, window_frames
from neurofuzzy.errors import InputError
from neurofuzzy.experiment import rms_error
from helpers import cli
from test_diagnosis_elements import FRAMES, NOISE, block, measured, start

#: the frames of motion the tests diagnose on: a third of the recording
SHOWN = 20


class _Moving:
    """What window_frames reads of an experiment."""

    def __init__(self, frames, onset=30):
        self.n_frames, self.load_onset = frames, onset


def test_auto_windows_only_recordings_long_against_the_window():
    assert window_frames([_Moving(30 + LONG * WINDOW + 1)], "auto") == WINDOW
    assert window_frames([_Moving(30 + LONG * WINDOW)], "auto") is None
    # the longest experiment decides
    assert window_frames([_Moving(100), _Moving(30 + 3 * WINDOW)], "auto") == WINDOW
    assert window_frames([_Moving(401)], "all") is None
    assert window_frames([_Moving(401)], None) is None
    assert window_frames([_Moving(401)], 50) == 50
    assert window_frames([_Moving(401)], np.int64(50)) == 50 == window_frames([_Moving(401)],
                                                                              50.0)
    assert window_frames([_Moving(401)], 371) is None         # the whole motion: no window


@pytest.mark.parametrize("bad", [0, 1, -5, 2.5, float("nan"), "some", True])
def test_a_window_that_is_not_a_number_of_frames_is_refused(bad):
    with pytest.raises(InputError, match="window"):
        window_frames([_Moving(401)], bad)


def test_the_window_answer_is_fitted_on_all_frames():
    """Nothing hidden: the first 20 frames answer none, and the model fitted on all 61 is at
    the noise there; the findings' RMS is the window's, the final model's all the frames'."""
    data = measured(block())
    result = diagnose(start(), data, window=SHOWN, mesh_check=False)
    assert result.names == ["none"]
    assert result.window == {"frames": SHOWN, "of": FRAMES, "held": True, "rediagnosed": False,
                             "rms_before": result.rms_before,
                             "rms_after": result.window["rms_after"]}
    assert "diagnosed on the first 20 of 61 frames, the answer fitted on all" in result.verdict
    # the final model is the fit on all frames: its RMS there is what the diagnosis says
    assert rms_error(result.model_, data, substeps="auto") == pytest.approx(result.rms_after,
                                                                            rel=0.02)
    assert result.rms_after < 1.5 * result.noise_rms
    assert result.lack_of_fit.explained
    assert json.loads(json.dumps(result.to_dict()))["window"]["held"] is True


def test_the_window_answer_is_fitted_on_all_frames_at_the_substeps_given():
    """``substeps`` given as a number: the fit on all frames is made there (no two-step
    confirmation, which is the "auto" fit's)."""
    from neurofuzzy.simulation import stability_limit
    from test_diagnosis_elements import DT

    steps = int(np.ceil(DT / stability_limit(block()).max_step))
    result = diagnose(start(), measured(block()), window=SHOWN, mesh_check=False,
                      substeps=steps)
    assert result.names == ["none"] and result.window["held"] is True
    assert rms_error(result.model_, measured(block()), substeps=steps) == pytest.approx(
        result.rms_after, rel=0.02)


def test_a_window_answer_that_fails_on_all_frames_diagnoses_them_all(capsys):
    """The markers drift by 20 noise sigmas, growing steadily, after the window (a camera
    that slipped): the window is at the noise, all frames are not, so the whole recording
    is diagnosed, and the answer is not none."""
    data = measured(block())
    after = np.clip(np.arange(FRAMES) - SHOWN, 0, None) / (FRAMES - SHOWN)
    drifted = data.markers.positions + (20 * NOISE * after)[:, None, None] * [1.0, 0.0, 0.0]
    data = data.replace(markers=data.markers.__class__(
        nodes=data.markers.nodes, weights=data.markers.weights, positions=drifted))
    result = diagnose(start(), data, window=SHOWN, mesh_check=False, max_effects=1,
                      progress=True)
    said = capsys.readouterr().err
    assert "the first 20 frames' answer does not hold" in said
    assert f"diagnosing all {FRAMES} frames" in said
    assert result.window["held"] is False and result.window["rediagnosed"] is True
    assert result.names != ["none"]
    assert "did not hold on all 61: all diagnosed" in result.verdict


def test_max_time_spent_in_the_window_leaves_the_answer_provisional():
    result = diagnose(start(), measured(block()), window=SHOWN, mesh_check=False,
                      max_time=1e-3)
    assert result.provisional and f"not fitted on all {FRAMES} frames" in result.provisional
    assert result.window["held"] is None
    assert result.verdict.startswith("provisional")


def test_the_command_takes_a_window(tmp_path):
    """``neurofuzzy diagnose --window`` refuses what is not a number of frames, with exit
    status 2 and nothing written."""
    out = tmp_path / "model.yaml"
    for bad in ("lots", "1", "-3"):
        run = cli("diagnose", tmp_path / "missing.npz", "--window", bad, "--out", out)
        assert run.returncode == 2 and "--window" in run.stderr and not out.exists()

