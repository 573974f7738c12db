"""SpringMassModel: regions, tying within regions, files."""

import numpy as np
import pytest

from neurofuzzy.errors import InputError
from neurofuzzy.io import load_model, save_model
from neurofuzzy.mesh import lattice
from neurofuzzy.model import SpringMassModel


def two_region_model():
    mesh = lattice((3, 3, 3), spacing=0.01)
    top = mesh.rest_positions[:, 2] > 0.015
    node_region = top.astype(int)
    spring_region = node_region[mesh.springs[:, 0]]
    model = SpringMassModel.uniform(mesh, stiffness=50.0, damping=0.02, total_mass=0.008)
    return model.replace(region_names=("organ", "tumour"), region_tissues=("liver", "tumour"),
                         node_region=node_region, spring_region=spring_region)


def test_tying_never_crosses_a_region_boundary():
    model = two_region_model().tied("global")
    assert model.n_ties == 2
    for k in range(model.n_ties):
        assert len(np.unique(model.spring_region[model.spring_tie == k])) == 1
    assert two_region_model().tied("groups").n_ties == 4     # edges, diagonals × 2 regions


def test_regions_round_trip_through_model_files(tmp_path):
    model = two_region_model().tied("groups")
    loaded = load_model(save_model(model, tmp_path / "m.yaml"))
    assert loaded.region_names == ("organ", "tumour")
    assert loaded.region_tissues == ("liver", "tumour")
    assert np.array_equal(loaded.spring_region, model.spring_region)
    assert np.array_equal(loaded.node_region, model.node_region)
    assert np.array_equal(loaded.region_springs("tumour"), model.region_springs("tumour"))
    assert "region tumour" in loaded.summary()


def test_bad_regions_are_refused_with_the_key():
    model = two_region_model()
    with pytest.raises(InputError, match="spring_region"):
        model.replace(spring_region=np.full(model.n_springs, 2))
    with pytest.raises(InputError, match="region_names"):
        model.replace(region_names=("a", "a"))
    with pytest.raises(InputError, match="did you mean 'tumour'"):
        model.region_nodes("tumor")
