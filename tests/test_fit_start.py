"""fit --start MODEL.yaml: a two-tissue organ (liver with a tumour) from ``neurofuzzy mesh
--region`` to per-region learned values and words."""

import json

import numpy as np
import pytest
from helpers import write_gmsh

from neurofuzzy.cli import main
from neurofuzzy.datasets import kuhn_block
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.io import load_model, save_experiment
from neurofuzzy.pipeline import start_model
from neurofuzzy.mesh import read_mesh
from neurofuzzy.rules import load_rules, shipped
from neurofuzzy.tissues import initialize, materials

SPACING = 0.01


def organ_file(path):
    """A 4 × 4 × 3 cm block whose top-centre corner cells are a tumour (Gmsh, named regions)."""
    points, tetrahedra = kuhn_block((4, 4, 3), SPACING)
    centre = points[tetrahedra].mean(axis=1)
    tumour = (np.abs(centre[:, 0] - 0.02) < 0.01) & (np.abs(centre[:, 1] - 0.02) < 0.01) & (
        centre[:, 2] > 0.01)
    return write_gmsh(path, points, tetrahedra, np.where(tumour, 2, 1),
                      {1: "organ", 2: "tumour"})


def hidden_truth(path):
    """The same organ, but the liver is fibrotic (the expert said healthy)."""
    read = read_mesh(path)
    z = read.mesh.rest_positions[:, 2]
    mesh = read.mesh.with_fixed(where=lambda p: z <= z.min() + 0.25 * read.mesh.rest_lengths.min())
    return initialize(load_rules(shipped("liver")), mesh, tetrahedron_regions={
        "fibrotic_liver": read.tetrahedron_regions["organ"],
        "tumour": read.tetrahedron_regions["tumour"]}, elements=False)


@pytest.fixture(scope="module")
def organ(tmp_path_factory):
    folder = tmp_path_factory.mktemp("organ")
    mesh_file = organ_file(folder / "organ.msh")
    assert main(["mesh", str(mesh_file), "--elements", "springs", "--rules", "liver",
                 "--region", "organ=liver",
                 "--region", "tumour=tumour", "--fix-bottom", "--out",
                 str(folder / "organ.yaml")]) == 0
    truth = hidden_truth(mesh_file)
    top = np.flatnonzero(truth.mesh.rest_positions[:, 2] > 0.029)
    centre = top[np.argmin(np.linalg.norm(truth.mesh.rest_positions[top, :2] - 0.02, axis=1))]
    corner = top[np.argmin(np.linalg.norm(truth.mesh.rest_positions[top, :2], axis=1))]
    files = []
    for name, node, force in (("push", centre, (0, 0, -0.05)), ("pull", corner, (0.03, 0, 0))):
        load = np.zeros((truth.n_nodes, 3))
        load[node] = force
        files.append(save_experiment(simulate_experiment(truth, dt=1e-3, n_frames=150,
                                                         external_forces=load, substeps=2),
                                     folder / f"{name}.npz"))
    return folder, truth, files


def test_the_model_file_keeps_regions_tissues_and_ties(organ):
    folder, _, _ = organ
    model = load_model(folder / "organ.yaml")
    assert model.region_names == ("liver", "tumour")
    assert model.region_tissues == ("liver", "tumour")
    assert model.region_nodes("tumour").size > 0 and model.region_springs("tumour").size > 0
    for k in range(model.springs.n_ties):     # tie groups never span two regions
        assert len(np.unique(model.springs.region[model.springs.tie == k])) == 1


@pytest.mark.slow
def test_fit_start_learns_each_region_and_says_it_in_words(organ, capsys):
    folder, truth, files = organ
    status = main(["fit", *map(str, files), "--start", str(folder / "organ.yaml"),
                   "--rules", "liver", "--substeps", "2", "--json", "--quiet", "--report",
                   str(folder / "fit.html"), "--out", str(folder / "fitted.yaml")])
    assert status == 0
    result = json.loads(capsys.readouterr().out)
    assert result["start"]["how"] == "model"
    expected = materials(truth, load_rules(shipped("liver")))
    found = result["materials"]
    assert set(found) == {"liver", "tumour"}
    for region, true_region in (("liver", "fibrotic_liver"), ("tumour", "tumour")):
        assert found[region]["youngs_modulus"] == pytest.approx(
            expected[true_region]["youngs_modulus"], rel=0.05), region
        assert found[region]["labels"] == expected[true_region]["labels"], region
    assert found["liver"]["labels"]["youngs_modulus"] == "hard"
    assert found["tumour"]["labels"]["youngs_modulus"] == "very_hard"
    fitted = load_model(folder / "fitted.yaml")
    assert fitted.region_names == ("liver", "tumour")
    twin = json.loads((folder / "fit.json").read_text())
    assert [r["region"] for r in twin["regions"]] == ["liver", "tumour"]
    words = {r["region"]: {q["quantity"]: q for q in r["quantities"]} for r in twin["regions"]}
    assert words["liver"]["youngs_modulus"]["label_before"] == "firm"
    assert words["liver"]["youngs_modulus"]["label_after"] == "hard"


def test_start_model_is_the_pipelines():
    """Where a fit starts is the pipeline's choice (it reads model files and rule bases); the
    learners' own start is the equation-error estimate. The old spelling says where it went."""
    import neurofuzzy as nf
    import neurofuzzy.learn

    assert nf.start_model is start_model
    with pytest.raises(AttributeError, match="learn.start_model has moved to neurofuzzy"):
        neurofuzzy.learn.start_model
    assert callable(neurofuzzy.learn.estimate_start)


def test_start_model_refuses_a_model_of_another_object(organ):
    folder, _, files = organ
    from neurofuzzy.datasets import paper_cube_model
    from neurofuzzy.errors import InputError
    from neurofuzzy.io import load_experiment

    with pytest.raises(InputError, match="nodes"):
        start_model([load_experiment(files[0])], model=paper_cube_model())
