"""A spring network's Poisson's ratio is locked at 1/4: it gets no word (it would read
"compressible" for the expert's "incompressible"), and the report neither describes nor
explains it (issue 50)."""

import json

import neurofuzzy as nf
from neurofuzzy.datasets import paper_cube_mesh, point_load, top_centre_node
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.report import fit_report
from neurofuzzy.rules import load_rules, shipped
from neurofuzzy.tissues import initialize, materials
from neurofuzzy.tissues.values import DENSITY_NOT_LEARNED, LOCKED_POISSON_RATIO


def test_a_spring_networks_locked_poisson_ratio_gets_no_word():
    rules = load_rules(shipped("liver"))
    assert str(rules.tissues["liver"]["compressibility"]) == "incompressible"
    springs = initialize(rules, paper_cube_mesh(), "liver")
    (found,) = materials(springs, rules, "liver").values()
    assert found["poisson_ratio"] == 0.25
    assert "poisson_ratio" not in found["labels"] and found["labels"]["youngs_modulus"] == "firm"
    assert found["notes"] == {"poisson_ratio": LOCKED_POISSON_RATIO}


def test_the_report_of_a_spring_fit_leaves_the_locked_ratio_out(tmp_path):
    rules = load_rules(shipped("liver"))
    mesh = paper_cube_mesh()
    truth = initialize(rules, mesh, "fibrotic_liver").tied("global")
    load = point_load(mesh, top_centre_node(mesh), (0.0, 0.0, -0.05))
    data = simulate_experiment(truth, dt=5e-4, n_frames=60, external_forces=load)
    start = initialize(rules, mesh, "liver").tied("global")
    # five iterations, as they end (the report is what is tested, not the fit)
    outcome = nf.fit(data, start=start, rules=rules,
                     options=nf.FitOptions(cycles=5, checked=False))
    fit_report(outcome, tmp_path / "r.html")
    (region,) = json.loads((tmp_path / "r.json").read_text())["regions"]
    assert "poisson_ratio" not in {row["quantity"] for row in region["quantities"]}
    # the masses were not learned: the density is theirs, said so, and not explained
    assert region["notes"] == {"poisson_ratio": LOCKED_POISSON_RATIO,
                               "density": DENSITY_NOT_LEARNED}
    assert "compressibility" not in region["explained"]["words"]    # decides ν only
    assert "heaviness" not in region["explained"]["words"]          # decides ρ only
    assert "consistency" in region["explained"]["words"]
    assert "locked at 1/4" in (tmp_path / "r.html").read_text()
