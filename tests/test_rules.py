import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from neurofuzzy.datasets import paper_cube_mesh, point_load, top_centre_node
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.io import save_experiment
from neurofuzzy.mesh import lattice
from neurofuzzy.rules import RuleBaseError, initialize, lattice_geometry, load_rules, material_values
from neurofuzzy.rules.membership import HEDGES, apply_hedges, evaluate

ROOT = Path(__file__).resolve().parents[1]
RULES = ROOT / "rules"
SHIPPED = sorted(RULES.glob("*.yaml"))
TISSUES = Path(__file__).parent / "data" / "cube_tissues.yaml"


def cli(*args):
    return subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_rule_base_passes_check(path):
    result = cli("rules", "check", path)
    assert result.returncode == 0, result.stderr
    assert "rules" in result.stdout and "tissues" in result.stdout


def test_shipped_rule_bases_cover_the_organs():
    tissues = {name for path in SHIPPED for name in load_rules(path).tissues}
    assert {"grey_matter", "white_matter", "ventricle_wall", "liver", "kidney", "muscle", "fat",
            "tumour"} <= tissues


def test_words_are_ordered_in_stiffness():
    rules = load_rules(RULES / "soft_tissue.yaml")
    words = ["very soft", "soft", "firm", "hard", "stony"]
    stiffness = rules.infer([{"consistency": w} for w in words])["stiffness"]
    assert np.all(np.diff(stiffness) > 0), dict(zip(words, stiffness))
    soft, not_soft = rules.infer([{"consistency": "soft"}, {"consistency": "not soft"}])["stiffness"]
    assert not_soft > soft


@pytest.mark.parametrize("path", [p for p in SHIPPED if p.stem != "soft_tissue"],
                         ids=lambda p: p.stem)
def test_round_trip_from_words_to_a_model_and_back(path):
    rules = load_rules(path)
    mesh = paper_cube_mesh()
    for tissue, words in rules.tissues.items():
        model, values = initialize(rules, mesh, tissue)
        recovered = material_values(rules, model)
        for name, value in values[tissue].items():
            assert recovered[name] == pytest.approx(value, rel=1e-9), (tissue, name)
        labels = rules.describe(recovered)
        assert all(label.degree >= 0.5 for label in labels.values()), (tissue, labels)
        explained = rules.explain(recovered)
        assert explained["words"] == {k: str(v) for k, v in words.items()}, tissue


def test_vectorised_inference_matches_skfuzzy_control():
    pytest.importorskip("networkx")
    from neurofuzzy.rules.skfuzzy_control import control_infer

    rules = load_rules(RULES / "soft_tissue.yaml")
    rng = np.random.default_rng(0)
    inputs = [dict(zip(rules.inputs, x)) for x in rng.uniform(0.5, 9.5, (40, 3))]
    ours = rules.infer(inputs)
    theirs = control_infer(rules, inputs)
    for name in rules.outputs:
        assert np.allclose(ours[name], theirs[name], rtol=1e-3), name


def test_membership_functions_and_hedges_stay_in_unit_interval(rng):
    grid = np.linspace(-5, 15, 801)
    specs = [("trimf", [0, 3, 7]), ("trapmf", [1, 2, 4, 9]), ("gaussmf", [4, 1.5]),
             ("gbellmf", [2, 3, 5]), ("sigmf", [5, -2]), ("points", [[0, 0], [2, 1], [9, 0.3]])]
    for kind, params in specs:
        mu = evaluate(kind, params, grid, lambda x: np.asarray(x, float))
        assert mu.min() >= 0 and mu.max() <= 1 and mu.max() > 0.5, kind
        for hedges in (["very"], ["not"], ["somewhat", "very"], list(HEDGES)):
            hedged = apply_hedges(mu, hedges)
            assert hedged.min() >= 0 and hedged.max() <= 1
        assert np.all(apply_hedges(mu, ["very"]) <= mu + 1e-15)
        assert np.all(apply_hedges(mu, ["somewhat"]) >= mu - 1e-15)


def test_lattice_springs_from_youngs_modulus_give_that_modulus():
    """A 7x7x7 block under uniaxial load: E and Poisson's ratio of the spring lattice."""
    E, spacing = 5000.0, 0.01
    mesh = lattice((7, 7, 7), spacing)
    geometry = lattice_geometry(mesh)
    from neurofuzzy.simulate import _projected_laplacian

    direction = mesh.rest_positions[mesh.springs[:, 1]] - mesh.rest_positions[mesh.springs[:, 0]]
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    K = _projected_laplacian(mesh.springs, direction, E * geometry.spring_factor,
                             mesh.n_nodes).tocsr()
    z = mesh.rest_positions[:, 2]
    bottom, top = np.isclose(z, 0), np.isclose(z, z.max())
    strain = 1e-3
    displacement = np.zeros(3 * mesh.n_nodes)
    fixed = np.zeros(3 * mesh.n_nodes, bool)
    fixed[3 * np.flatnonzero(bottom) + 2] = True             # bottom: z held, free to slide
    fixed[3 * np.flatnonzero(top) + 2] = True                # top: prescribed z
    displacement[3 * np.flatnonzero(top) + 2] = strain * z.max()
    corner = int(np.flatnonzero(bottom)[0])
    fixed[3 * corner:3 * corner + 2] = True                  # no rigid sliding
    other = int(np.flatnonzero(bottom & np.isclose(mesh.rest_positions[:, 0], 0))[-1])
    fixed[3 * other] = True                                   # no rigid rotation
    free = ~fixed
    rhs = -K[free][:, fixed] @ displacement[fixed]
    displacement[free] = spla.spsolve(K[free][:, free].tocsc(), rhs)
    reaction = (K @ displacement)[3 * np.flatnonzero(top) + 2].sum()
    width = mesh.rest_positions[:, 0].max()
    modulus = reaction / width**2 / strain
    middle = np.isclose(z, 3 * spacing)
    x = mesh.rest_positions[middle, 0]
    ux = displacement[3 * np.flatnonzero(middle)]
    poisson = -np.polyfit(x, ux, 1)[0] / strain
    assert modulus == pytest.approx(E, rel=0.15)
    assert poisson == pytest.approx(0.25, abs=0.05)


def test_end_to_end_firm_data_soft_start_gives_firm_label(tmp_path):
    rules = load_rules(TISSUES)
    mesh = paper_cube_mesh()
    truth, _ = initialize(rules, mesh, "firm_tissue", tie="global")
    load = point_load(mesh, top_centre_node(mesh), (0, 0, -0.01))
    data = save_experiment(simulate_experiment(truth, dt=5e-4, n_frames=251,
                                               external_forces=load), tmp_path / "firm.npz")
    report = tmp_path / "report.html"
    result = cli("fit", data, "--rules", TISSUES, "--tissue", "soft_tissue", "--tie", "global",
                 "--report", report, "--json")
    assert result.returncode == 0, result.stderr
    twin = json.loads(report.with_suffix(".json").read_text())
    stiffness = next(q for q in twin["quantities"] if q["quantity"] == "stiffness")
    assert stiffness["label_before"] == "soft" and stiffness["label_after"] == "firm"
    assert stiffness["changed"] and stiffness["degree_after"] >= 0.5
    assert twin["explained"]["words"]["consistency"] == "firm"
    page = report.read_text()
    assert "soft → firm" in page and page.count("data:image/png;base64") >= 2
    assert np.isfinite(json.loads(result.stdout)["rms_error"])


# -- bad input: FILE:LINE: message, exit 2, all problems at once -------------------------------
BASE = """\
name: test
inputs:
  consistency:
    universe: [0, 10]
    terms:
      soft: {trimf: [0, 0, 5]}
      firm: {trimf: [2, 5, 8]}
outputs:
  stiffness:
    quantity: youngs_modulus
    universe: {min: 100, max: 100000, scale: log, unit: Pa}
    terms:
      soft: {trimf: [100, 1000, 5000]}
      firm: {trimf: [1000, 5000, 20000]}
rules:
  - if: consistency is soft
    then: stiffness is soft
  - if: consistency is firm
    then: stiffness is firm
tissues:
  jelly: {consistency: very soft}
"""

BAD = [
    ("malformed YAML", ("      firm: {trimf: [2, 5, 8]}", "      firm: {trimf: [2, 5, 8]"),
     r":8: malformed YAML"),
    ("unknown term in a tissue", ("{consistency: very soft}", "{consistency: very sotf}"),
     r":21: tissue 'jelly': consistency has no term 'sotf'; did you mean 'soft'\?"),
    ("unknown variable in a tissue", ("{consistency: very soft}", "{consistancy: soft}"),
     r":21: tissue 'jelly': unknown input 'consistancy'; did you mean 'consistency'\?"),
    ("misspelt hedge", ("if: consistency is soft", "if: consistency is vrey soft"),
     r":16: unknown hedge 'vrey'; did you mean 'very'\?"),
    ("impossible parameters", ("firm: {trimf: [2, 5, 8]}", "firm: {trimf: [5, 2, 8]}"),
     r":7: consistency.firm: trimf needs a <= b <= c"),
    ("zero over the universe", ("firm: {trimf: [2, 5, 8]}", "firm: {trimf: [20, 25, 30]}"),
     r":7: consistency.firm: the term is zero over the whole universe"),
    ("undefined variable in a rule", ("if: consistency is firm", "if: hardness is firm"),
     r":18: rule names undefined input variable 'hardness'"),
    ("unknown membership function", ("soft: {trimf: [0, 0, 5]}", "soft: {trimff: [0, 0, 5]}"),
     r":6: consistency.soft: unknown membership function 'trimff'; did you mean 'trimf'\?"),
]


@pytest.mark.parametrize("what, change, message", BAD, ids=[b[0] for b in BAD])
def test_bad_rule_files_name_file_and_line(tmp_path, what, change, message):
    path = tmp_path / "bad.yaml"
    text = BASE.replace(*change)
    assert text != BASE
    path.write_text(text)
    with pytest.raises(Exception) as caught:
        load_rules(path)
    assert caught.type.__name__ in ("RuleBaseError", "InputError")
    import re
    assert re.search(re.escape(str(path)) + message, str(caught.value)), str(caught.value)
    result = cli("rules", "check", path)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert re.search(message, result.stderr)
    assert path.read_text() == text                       # never written over


def test_all_problems_are_reported_at_once(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text(BASE.replace("if: consistency is soft", "if: consistency is vrey soft")
                    .replace("firm: {trimf: [2, 5, 8]}", "firm: {trimf: [5, 2, 8]}")
                    .replace("{consistency: very soft}", "{consistency: very sotf}"))
    with pytest.raises(RuleBaseError) as caught:
        load_rules(path)
    lines = [str(p) for p in caught.value.problems]
    assert len(lines) >= 3
    assert any(":7:" in l for l in lines) and any(":16:" in l for l in lines) \
        and any(":21:" in l for l in lines)
