"""The diagnosis of a recording in time whose body a plate moved
(:func:`neurofuzzy.diagnosis.moving.diagnose_moving`, ``neurofuzzy diagnose RAMP.npz``): the
set-up's likely mistakes refitted through BDF2 steps, named where the data need them and
not where they do not."""

import json

import numpy as np
import pytest

from helpers import cli
from neurofuzzy.experiment import Experiment
from neurofuzzy.io import save_experiment, save_model
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points
from neurofuzzy.paths import DrivenPath
from neurofuzzy.simulation.implicit import simulate_implicit

SIZE, DT, FRAMES = 0.02, 0.002, 24


def _ramp(plate: str, law: str) -> tuple[Model, Experiment]:
    """A gel (E 6 kPa, ν 0.45, η 20 Pa·s, ``law``) pressed 15 % by a plate over 20 ms and
    held, the plate bonded (``plate`` "xyz") or slid on (``"z"``); the lab's record takes it
    as bonded: 30 beads with 2 µm noise, the load cell with 1 % of its peak."""
    points, tetrahedra = kuhn_block((2, 2, 2), SIZE / 2)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=6000.0, poisson_ratio=0.45, viscosity=20.0,
                            density=1000.0, law=law)
    top = np.flatnonzero(np.isclose(points[:, 2], SIZE))
    path = np.zeros((FRAMES, 3))
    path[:, 2] = -0.15 * SIZE * np.minimum(np.arange(FRAMES) / 10, 1.0)
    run = simulate_implicit(truth, dt=DT, n_frames=FRAMES, iterations=50, tolerance=1e-12,
                            driven=[DrivenPath(top, path, plate)], scheme="bdf2")
    rng = np.random.default_rng(4)
    nodes, weights, _ = embed_points(mesh, rng.uniform(0.1 * SIZE, 0.9 * SIZE, (30, 3)))
    beads = np.einsum("mk,fmkj->fmj", weights, run.positions[:, nodes])
    beads[1:] += rng.normal(0.0, 2e-6, beads[1:].shape)
    force = run.reactions[:, 0]
    force = force + 0.01 * np.abs(force).max() * rng.normal(size=force.shape)
    return truth, Experiment(mesh=mesh, dt=DT, positions=np.full((FRAMES, mesh.n_nodes, 3),
                                                                 np.nan),
                             observed=np.zeros(mesh.n_nodes, bool),
                             markers=EmbeddedMarkers(nodes, weights, beads),
                             driven=(DrivenPath(top, path, "xyz", "top plate"),),
                             reaction=force)


@pytest.mark.slow
def test_a_slid_plate_and_the_law_are_named_and_the_fit_then_recovers_the_gel(tmp_path):
    """Neo-Hookean gel slid on its plate, modelled as bonded St. Venant–Kirchhoff: the
    diagnosis names the slip first (the larger χ² fall), then the law, and the fit with both
    finds E, ν and η; the misfit falls to the noise. Its report draws both models through the
    recording: the answer's markers at the noise in every frame, the base fit's far above."""
    from neurofuzzy.diagnosis.moving import diagnose_moving
    from neurofuzzy.pipeline.moving import moving_diagnosis_report

    truth, data = _ramp("z", "neo-hookean")
    start = truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0,
                                law="st-venant-kirchhoff")
    found = diagnose_moving(start, data)
    assert found.names == ["plate_slip", "hyperelasticity (neo-hookean)"]
    answer = found.to_dict()
    assert answer["plate"] == "z" and answer["law"] == "neo-hookean"
    assert answer["youngs_modulus"] == pytest.approx(6000.0, rel=0.02)
    assert answer["poisson_ratio"] == pytest.approx(0.45, abs=0.005)
    assert answer["viscosity"] == pytest.approx(20.0, rel=0.05)
    assert found.after.rms_error < 1.5 * np.sqrt(3) * 2e-6 < found.before.rms_error
    assert "plate_slip" in found.summary()

    moving_diagnosis_report(found, data, tmp_path / "diagnosis.html")
    page = (tmp_path / "diagnosis.html").read_text()
    assert page.count("<img") == 3 and "plate_slip" in page and "neo-hookean" in page
    record = json.loads((tmp_path / "diagnosis.json").read_text())
    assert record["answer"] == found.names and record["law_before"] == "st-venant-kirchhoff"
    before = np.asarray(record["marker_rms_per_frame_before"])[1:]
    after = np.asarray(record["marker_rms_per_frame_after"])[1:]
    assert np.all(after < 3 * np.sqrt(3) * 2e-6) and before.max() > 5 * after.max()
    measured = np.asarray(record["measured_force"])[:, 2]
    for key, misfit in (("predicted_force_after", 0.03), ("predicted_force_before", None)):
        off = np.abs(np.asarray(record[key])[:, 2] - measured).max() / np.abs(measured).max()
        assert off < misfit if misfit else off > 0.03, (key, off)


@pytest.mark.slow
def test_the_command_names_nothing_where_the_model_has_what_the_data_need(tmp_path):
    """Bonded neo-Hookean data and a bonded neo-Hookean start: ``diagnose`` answers
    ``none`` (each candidate raises χ²), keeps the fit, and writes the model asked for; a
    report is written (its JSON twin beside it); the time-series diagnosis's options are
    refused by name, nothing written."""
    truth, data = _ramp("xyz", "neo-hookean")
    save_experiment(data, tmp_path / "ramp.npz")
    save_model(truth.with_elements(youngs_modulus=8000.0, poisson_ratio=0.4, viscosity=10.0),
               tmp_path / "model.yaml")
    done = cli("diagnose", tmp_path / "ramp.npz", "--start", tmp_path / "model.yaml",
               "--json", "--quiet", "--out", tmp_path / "fitted.yaml", "--report",
               tmp_path / "report.html")
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout)
    assert answer["answer"] == ["none"] and answer["plate"] == "xyz"
    assert all(fall < 0 for fall in answer["candidates"].values())
    assert answer["youngs_modulus"] == pytest.approx(6000.0, rel=0.02)
    assert (tmp_path / "fitted.yaml").is_file()
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["answer"] == ["none"] and len(report["times"]) == FRAMES
    assert "Answer: <b>none</b>" in (tmp_path / "report.html").read_text()
    for option in (["--localise"], ["--max-time", "5"], ["--window", "10"]):
        refused = cli("diagnose", tmp_path / "ramp.npz", "--start", tmp_path / "model.yaml",
                      *option, "--out", tmp_path / "again.yaml")
        assert refused.returncode == 2 and option[0] in refused.stderr, refused.stderr
        assert "Traceback" not in refused.stderr
        assert not (tmp_path / "again.yaml").exists()
