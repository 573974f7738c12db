"""The rule studio's server API (Starlette's test client, no browser): state, edits with
validation, the tissue and its block, fit results, saving, and the security checks."""

import json
import shutil
import warnings
from pathlib import Path

import pytest
from helpers import cli

pytest.importorskip("starlette")
pytest.importorskip("httpx")

with warnings.catch_warnings():       # Starlette >= 1.9 prefers httpx2; httpx still works
    warnings.simplefilter("ignore")
    from starlette.testclient import TestClient  # noqa: E402

from neurofuzzy.rules import load_rules  # noqa: E402
from neurofuzzy.rulestudio.app import StudioState, create_app  # noqa: E402
from neurofuzzy.rulestudio.fits import find_results  # noqa: E402
from neurofuzzy.rulestudio.tissue import default_force  # noqa: E402

RULES = Path(__file__).resolve().parents[1] / "rules"
LOCAL = "http://127.0.0.1:8765"


@pytest.fixture
def folder(tmp_path):
    for name in ("liver.yaml", "soft_tissue.yaml"):
        shutil.copy(RULES / name, tmp_path / name)
    return tmp_path


@pytest.fixture
def client(folder):
    state = StudioState(folder, folder / "liver.yaml")
    return TestClient(create_app(state), base_url=LOCAL)


def modulus(client, tissue="liver"):
    view = client.get("/api/tissue", params={"name": tissue}).json()
    return next(o for o in view["outputs"] if o["quantity"] == "youngs_modulus")


def test_state_lists_variables_rules_tissues_with_their_files_and_lines(client):
    state = client.get("/api/state").json()
    assert state["file"] == "liver.yaml" and state["chain"] == ["liver.yaml", "soft_tissue.yaml"]
    assert state["valid"] and state["problems"] == [] and not state["dirty"]
    consistency = next(v for v in state["variables"] if v["name"] == "consistency")
    assert consistency["file"] == "soft_tissue.yaml" and not consistency["own"]
    assert [t["name"] for t in consistency["terms"]] == ["soft", "firm", "hard", "stony"]
    modulus_variable = next(v for v in state["variables"] if v["name"] == "youngs_modulus")
    assert modulus_variable["universe"] == {"low": 100, "high": 300000, "scale": "log"}
    assert modulus_variable["unit"] == "Pa"
    assert [t["name"] for t in state["tissues"]] == ["liver", "fibrotic_liver", "tumour"]
    assert all(t["own"] and t["file"] == "liver.yaml" for t in state["tissues"])
    # the shared rules of soft_tissue.yaml: E (4), η (3), density (3), relaxation (6),
    # stiffening (3) and ν (3)
    assert len(state["rules"]) == 22 and not state["rules"][0]["own"]


def test_the_tissue_in_values_units_words_and_fired_rules(client):
    view = client.get("/api/tissue", params={"name": "liver"}).json()
    values = {o["quantity"]: o for o in view["outputs"]}
    assert values["youngs_modulus"]["unit"] == "Pa" and values["youngs_modulus"]["term"] == "firm"
    assert 3000 < values["youngs_modulus"]["value"] < 8000
    assert values["density"]["unit"] == "kg/m^3" and values["viscosity"]["unit"] == "Pa s"
    assert abs(sum(values["youngs_modulus"]["degrees"].values()) - 1.0) < 0.2
    fired = {r["text"]: r["strength"] for r in view["rules"]}
    assert fired["if consistency is firm then youngs_modulus is firm"] == pytest.approx(1.0)
    assert fired["if consistency is stony then youngs_modulus is very_hard"] == 0
    assert client.get("/api/tissue", params={"name": "livr"}).json()["error"].endswith(
        "did you mean 'liver'?")


def test_dragging_a_breakpoint_lowers_e_and_the_block_sinks_deeper(client):
    before = modulus(client)["value"]
    block = client.post("/api/block", json={"tissue": "liver"}).json()
    force = block["probe"]["force"]
    assert force == default_force(block["material"]["youngs_modulus"])
    assert block["seconds"] < 1.0 and len(block["positions"]) == len(block["time"])
    response = client.post("/api/edit", json={"edit": {
        "op": "set_term", "role": "output", "variable": "youngs_modulus", "term": "firm",
        "kind": "trimf", "params": [1500, 2500, 15000]}})
    assert response.status_code == 200 and response.json()["dirty"]
    assert modulus(client)["value"] < 0.9 * before
    softer = client.post("/api/block", json={"tissue": "liver", "force": force}).json()
    assert max(softer["depth"]) > 1.05 * max(block["depth"])
    assert softer["material"]["youngs_modulus"] < block["material"]["youngs_modulus"]


def test_an_error_is_reported_with_its_line_and_the_tissue_waits(client, folder):
    response = client.post("/api/edit", json={"edit": {
        "op": "set_tissue", "tissue": "liver", "variable": "consistency", "words": "frim"}})
    state = response.json()
    (problem,) = state["problems"]
    assert problem["file"] == "liver.yaml" and problem["line"] == 5
    assert "has no term 'frim'; did you mean 'firm'?" in problem["message"]
    assert not state["valid"]
    assert client.get("/api/tissue", params={"name": "liver"}).status_code == 409
    refused = client.post("/api/save", json={})
    assert refused.status_code == 400 and "not saved" in refused.json()["error"]
    assert (folder / "liver.yaml").read_text() == (RULES / "liver.yaml").read_text()
    fixed = client.post("/api/undo", json={}).json()
    assert fixed["valid"] and not fixed["dirty"] and fixed["can_redo"]


def test_an_edit_that_cannot_be_written_names_its_line(client):
    client.post("/api/edit", json={"edit": {"op": "add_rule", "text": "if heaviness is heavy "
                                                                     "then density is heavy"}})
    response = client.post("/api/edit", json={"edit": {"op": "set_rule", "index": 0,
                                                       "text": "heaviness is heavy"}})
    assert response.status_code == 400
    body = response.json()
    assert "if CONDITION then CONCLUSION" in body["error"] and body["line"] == 9


def test_save_round_trip_keeps_comments_and_loads(client, folder):
    client.post("/api/edit", json={"edit": {
        "op": "set_term", "role": "output", "variable": "youngs_modulus", "term": "firm",
        "kind": "trimf", "params": [1500, 3000, 15000]}})
    saved = client.post("/api/save", json={}).json()
    assert saved["saved"] == "liver.yaml" and not saved["state"]["dirty"]
    text = (folder / "liver.yaml").read_text()
    original = (RULES / "liver.yaml").read_text()
    assert text.startswith(original)                 # every original line, in order
    assert "# liver: MR elastography shear 2.2 kPa" in text
    assert load_rules(folder / "liver.yaml").outputs["youngs_modulus"].terms["firm"].params \
        == [1500, 3000, 15000]
    assert cli("rules", "check", folder / "liver.yaml").returncode == 0
    as_new = client.post("/api/save", json={"name": "../escape.yaml"})
    assert as_new.status_code == 400 and "refused" in as_new.json()["error"]


def fit_result(tissue="liver", modulus=9000.0):
    return {"materials": {"object": {"youngs_modulus": modulus, "poisson_ratio": 0.45,
                                     "viscosity": 3.0, "density": 1050.0, "tissue": tissue,
                                     "labels": {"youngs_modulus": "firm"}}}}


def test_fit_results_from_a_file_a_cohort_folder_and_an_upload(client, folder):
    (folder / "fit.json").write_text(json.dumps(fit_result()))
    for index, (group, value) in enumerate([("healthy", 5000.0), ("fibrotic", 30000.0)]):
        (folder / "cohort" / f"s{index}").mkdir(parents=True)
        (folder / "cohort" / f"s{index}" / "fit.json").write_text(json.dumps(
            {"format": 1, "id": f"s{index}", "group": group, "status": "ok",
             "fit": fit_result("liver", value)}))
    assert find_results(folder) == ["fit.json", "cohort/"]
    assert client.get("/api/fits").json()["results"] == ["fit.json", "cohort/"]
    one = client.post("/api/fit", json={"path": "fit.json"}).json()["fit"]
    (entry,) = one["entries"]
    row = next(r for r in entry["rows"] if r["quantity"] == "youngs_modulus")
    assert row["learned"] == 9000 and row["before"] == "firm" and row["after"] in ("firm",
                                                                                  "hard")
    assert 3000 < row["start"] < 8000
    cohort = client.post("/api/fit", json={"path": "cohort/"}).json()["fit"]
    words = {e["label"]: next(r["after"] for r in e["rows"] if r["quantity"] ==
                              "youngs_modulus") for e in cohort["entries"]}
    assert words == {"s0": "firm", "s1": "hard"}
    uploaded = client.post("/api/fit", json={"name": "mine.json",
                                             "content": fit_result(modulus=2000.0)}).json()
    assert uploaded["fit"]["source"] == "mine.json"
    for path in ("../fit.json", "/etc/passwd"):
        refused = client.post("/api/fit", json={"path": path})
        assert refused.status_code == 400 and "refused" in refused.json()["error"]
    assert "no 'materials'" in client.post("/api/fit", json={"content": {"a": 1}}).json()[
        "error"]


def test_localhost_only_unless_a_token_is_given(folder):
    local = TestClient(create_app(StudioState(folder, folder / "liver.yaml")), base_url=LOCAL)
    assert local.get("/api/state").status_code == 200
    assert local.get("/api/state", headers={"Host": "evil.example:8765"}).status_code == 403
    assert local.get("/", headers={"Host": "localhost:8765"}).status_code == 200
    assert local.post("/api/undo", json={}, headers={"Origin": "http://evil.example"}
                      ).status_code == 403
    assert local.post("/api/undo", content=b"{}", headers={"Content-Type": "text/plain"}
                      ).status_code == 415
    assert local.put("/api/state").status_code == 403
    secured = TestClient(create_app(StudioState(folder, folder / "liver.yaml", token="s3cret")),
                         base_url="http://192.0.2.1:8765")
    assert secured.get("/api/state").status_code == 403
    assert secured.get("/api/state", headers={"X-Studio-Token": "wrong"}).status_code == 403
    assert secured.get("/static/app.js").status_code == 403
    assert secured.get("/api/state", headers={"X-Studio-Token": "s3cret"}).status_code == 200
    page = secured.get("/", params={"token": "s3cret"})       # sets the cookie
    assert page.status_code == 200 and "script-src 'self'" in page.headers[
        "content-security-policy"]
    assert secured.get("/api/state").status_code == 200          # by the cookie


def test_the_page_runs_no_code_from_data():
    static = Path(__file__).resolve().parents[1] / "neurofuzzy" / "rulestudio" / "static"
    scripts = "".join(p.read_text() for p in static.glob("*.js"))
    for forbidden in ("eval(", "new Function", "innerHTML", "outerHTML", "insertAdjacentHTML",
                      "document.write"):
        assert forbidden not in scripts, forbidden
    assert "<script>" not in (static / "index.html").read_text()


def test_without_a_file_the_page_offers_the_folders_rule_files(folder):
    client = TestClient(create_app(StudioState(folder)), base_url=LOCAL)
    state = client.get("/api/state").json()
    assert state["file"] is None and state["files"] == ["liver.yaml", "soft_tissue.yaml"]
    assert client.post("/api/open", json={"name": "../liver.yaml"}).status_code == 400
    assert client.post("/api/open", json={"name": "liver.yaml"}).json()["file"] == "liver.yaml"


def test_the_command_refuses_bad_input_with_status_2(tmp_path, monkeypatch):
    assert "no such rule file" in cli("studio", tmp_path / "none.yaml", "--no-browser").stderr
    assert cli("studio", "--port", "70000").returncode == 2
    bad = tmp_path / "bad.yaml"
    bad.write_text("a: [1\n")
    result = cli("studio", bad, "--no-browser")
    assert result.returncode == 2 and "bad.yaml:2: malformed YAML" in result.stderr
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "uvicorn" else real(name, *a))
    result = cli("studio", RULES / "liver.yaml", "--no-browser")
    assert result.returncode == 2 and "pip install 'neurofuzzy[studio]'" in result.stderr
