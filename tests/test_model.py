"""Model: regions, tying within regions, files."""

import numpy as np
import pytest

from neurofuzzy.errors import InputError
from neurofuzzy.io import load_model, save_model
from neurofuzzy.mesh import lattice
from neurofuzzy.model import Model


def two_region_model():
    mesh = lattice((3, 3, 3), spacing=0.01)
    top = mesh.rest_positions[:, 2] > 0.015
    node_region = top.astype(int)
    spring_region = node_region[mesh.springs[:, 0]]
    model = Model.uniform(mesh, stiffness=50.0, damping=0.02, total_mass=0.008)
    return model.replace(region_names=("organ", "tumour"), region_tissues=("liver", "tumour"),
                         node_region=node_region,
                         terms=(model.springs.replace(region=spring_region),))


def test_tying_never_crosses_a_region_boundary():
    model = two_region_model().tied("global")
    assert model.springs.n_ties == 2
    for k in range(model.springs.n_ties):
        assert len(np.unique(model.springs.region[model.springs.tie == k])) == 1
    assert two_region_model().tied("groups").springs.n_ties == 4   # edges, diagonals, 2 regions


def test_regions_round_trip_through_model_files(tmp_path):
    model = two_region_model().tied("groups")
    loaded = load_model(save_model(model, tmp_path / "m.yaml"))
    assert loaded.region_names == ("organ", "tumour")
    assert loaded.region_tissues == ("liver", "tumour")
    assert np.array_equal(loaded.springs.region, model.springs.region)
    assert np.array_equal(loaded.node_region, model.node_region)
    assert np.array_equal(loaded.region_springs("tumour"), model.region_springs("tumour"))
    assert "region tumour" in loaded.summary()


def test_bad_regions_are_refused_with_the_key():
    model = two_region_model()
    with pytest.raises(InputError, match="spring_region"):
        model.with_springs(region=np.full(model.n_springs, 2))
    with pytest.raises(InputError, match="region_names"):
        model.replace(region_names=("a", "a"))
    with pytest.raises(InputError, match="did you mean 'tumour'"):
        model.region_nodes("tumor")


# -- a model is a mesh, node masses and a tuple of terms -----------------------------------------
def _block():
    from neurofuzzy.datasets import kuhn_block
    from neurofuzzy.mesh import from_tetra

    points, tetrahedra = kuhn_block((2, 1, 1))
    return from_tetra(points * 0.01, tetrahedra).with_fixed(where=lambda p: p[:, 2] == 0)


def test_a_spring_network_and_an_element_model_are_one_class_with_other_terms():
    from neurofuzzy.effects import Gravity
    from neurofuzzy.forces import Springs, Tetrahedra

    mesh = _block()
    gravity = Gravity([0.0, 0.0, -9.81])
    springs = Springs(stiffness=30.0, damping=0.01)
    elements = Tetrahedra(youngs_modulus=5e3, poisson_ratio=0.4, viscosity=1.0)
    # given in any order, kept as springs, elements, effects
    both = Model(mesh, 1e-3, (gravity, elements, springs))
    assert [type(t) for t in both.terms] == [Springs, Tetrahedra, Gravity]
    assert both.effects == (gravity,) and both.force_terms == both.terms
    network = Model(mesh, 1e-3, (springs,))
    solid = Model.continuum(mesh, youngs_modulus=5e3, poisson_ratio=0.4, viscosity=1.0,
                            density=1000.0)
    assert type(network) is type(solid) is Model
    assert network.elements is None and solid.springs is None
    # each term owns its values, as read-only arrays of the mesh's sizes
    assert network.springs.stiffness.shape == (mesh.n_springs,)
    assert not network.springs.stiffness.flags.writeable
    assert solid.elements.youngs_modulus.shape == (mesh.n_tetrahedra,)
    assert np.all(solid.elements.tie == 0) and solid.elements.law_names() == "st-venant-kirchhoff"
    # a copy keeps the terms it does not change, unchecked again
    heavier = solid.replace(node_mass=2 * solid.node_mass)
    assert heavier.elements is solid.elements
    softer = solid.with_elements(youngs_modulus=2e3)
    assert np.all(softer.elements.youngs_modulus == 2e3) and softer.mesh is solid.mesh
    with pytest.raises(InputError, match="springs: this model has no springs"):
        solid.with_springs(stiffness=1.0)
    with pytest.raises(InputError, match="at most one Springs"):
        Model(mesh, 1e-3, (springs, springs))
    with pytest.raises(InputError, match="every term of a model is a ForceTerm"):
        Model(mesh, 1e-3, (springs, object()))
    with pytest.raises(InputError, match="spring_stiffness: must not be negative"):
        Model(mesh, 1e-3, (Springs(stiffness=-1.0, damping=0.0),))


def test_the_flat_fields_and_the_old_name_of_models_before_terms_are_gone():
    """Issue 44 removed the deprecated spellings (``Model(mesh, spring_stiffness=…)``,
    ``model.spring_damping``, ``SpringMassModel``); model files keep their format (``neurofuzzy-model/1``, the same
    sections before and after terms) and load as they did (tests/test_io.py)."""
    import neurofuzzy as nf
    from neurofuzzy import model as model_package

    mesh = lattice((2, 2, 2))
    with pytest.raises(TypeError):
        Model(mesh, node_mass=0.1, spring_stiffness=np.arange(1.0, 17.0))
    with pytest.raises(AttributeError):
        Model.uniform(mesh, stiffness=1.0, damping=0.5, total_mass=1.0).spring_damping
    for package in (nf, model_package):
        with pytest.raises(AttributeError):
            package.SpringMassModel


def test_an_element_model_file_with_idle_springs_loads_without_a_springs_term(tmp_path):
    """Element models were written with the mesh's springs at zero stiffness and damping (and
    still are): such springs exert no force, and the model read back has no springs term."""
    solid = Model.continuum(_block(), youngs_modulus=5e3, poisson_ratio=0.4, viscosity=1.0,
                            density=1000.0)
    path = save_model(solid, tmp_path / "solid.yaml")
    import yaml

    springs = yaml.safe_load(path.read_text())["springs"]
    assert springs["stiffness"] == springs["damping"] == [0.0] * solid.n_springs
    loaded = load_model(path)
    assert loaded.springs is None
    assert np.array_equal(loaded.elements.youngs_modulus, solid.elements.youngs_modulus)


def test_a_model_carries_one_drag_and_one_stiffening_of_its_elements_and_compiled_effects():
    """The kernels hold one node drag and one κ of the elements: a second is refused with
    what to do; stiffenings of separate spring groups, or gravity twice, are fine. An effect
    class that does not write itself into the kernels' arrays cannot be made, so no model
    is stepped without its force."""
    from neurofuzzy.effects import Effect, Gravity, NodeDrag, NonlinearStiffening
    from neurofuzzy.mesh import from_tetra, kuhn_block

    block = Model.continuum(from_tetra(*kuhn_block((2, 2, 2), 0.01)), youngs_modulus=3e3,
                            poisson_ratio=0.3, viscosity=1.0, density=1000.0)
    with pytest.raises(InputError, match="a model carries one node_drag; two add up"):
        block.with_effects(NodeDrag([1.0]), NodeDrag([2.0]))
    with pytest.raises(InputError, match="one nonlinear_stiffening on elements"):
        block.with_effects(NonlinearStiffening([1e3], on="elements"),
                           NonlinearStiffening([2e3], on="elements"))
    twice = block.with_effects(Gravity([0, 0, -9.81]), Gravity([0, 0, -1.0]), NodeDrag([1.0]))
    assert len(twice.effects) == 3

    class Unknown(Effect):
        name = "unknown_force"
        _labels = ("a",)

        def force(self, model, positions, velocities):
            return np.zeros_like(positions)

        def parameter_jacobian(self, model, positions, velocities):
            return np.zeros((len(positions), 1, 3))

    with pytest.raises(TypeError, match="abstract method.*compile"):
        Unknown([1.0])
