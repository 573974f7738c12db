"""Every kind of force term, checked the same way and without naming it: the springs, the
tetrahedral elements (both volumetric forms) and every registered effect
(:func:`neurofuzzy.effects.term_kinds`). A new term that registers itself is checked here
with no new test: its force's state derivatives (forward tangent and adjoint) and its
parameter derivatives (both directions) against central differences of its force, and, where
the compiled kernels compute it, their forward sensitivities against the numpy reference. The
element models hold every material law (:data:`neurofuzzy.forces.laws.LAWS`), so a new law is
checked here too.

Each kind gives its own examples (:meth:`examples`) on a small spring network and a small
element model, both with jittered nodes and random constants so that no symmetry hides an
error.
"""

import numpy as np
import pytest

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.effects import term_kinds
from neurofuzzy.experiment import simulate_experiment
from neurofuzzy.forces.laws import LAWS
from neurofuzzy.learn import Parameterization
from neurofuzzy.mesh import from_tetra, lattice
from neurofuzzy.forces import Springs
from neurofuzzy.model import Model
from neurofuzzy.errors import InputError

import numpy_reference as reference

EPS = 1e-6          # relative step of the central differences
RTOL = 1e-6         # what central differences of a smooth force reach at EPS


def _spring_model():
    rng = np.random.default_rng(11)
    mesh = lattice((3, 3, 2), 0.01).with_fixed(np.arange(3))
    return Model(mesh, rng.uniform(1e-4, 3e-4, mesh.n_nodes),
                 (Springs(stiffness=rng.uniform(20, 60, mesh.n_springs),
                          damping=rng.uniform(0.005, 0.02, mesh.n_springs)),))


def _element_model(volumetric, law="st-venant-kirchhoff"):
    rng = np.random.default_rng(12)
    points, tetrahedra = kuhn_block((2, 2, 1), 0.01)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    k = mesh.n_tetrahedra
    laws = rng.permutation(np.arange(k) % len(LAWS)) if law == "mixed" else law
    return Model.continuum(mesh, youngs_modulus=rng.uniform(3e3, 9e3, k),
                           poisson_ratio=rng.uniform(0.2, 0.45, k),
                           viscosity=rng.uniform(1, 5, k), density=1000.0,
                           volumetric=volumetric, law=laws)


#: the element models: both volumetric forms, and every material law (one model with every
#: law of :data:`neurofuzzy.forces.laws.LAWS` side by side, in each form)
MODELS = {"springs": _spring_model(), "elements (nodal)": _element_model("nodal"),
          "elements (element)": _element_model("element"),
          "elements (every law, nodal)": _element_model("nodal", "mixed"),
          "elements (every law, element)": _element_model("element", "mixed")}


def _examples():
    cases = []
    for kind_name, kind in sorted(term_kinds().items()):
        for model_name, model in MODELS.items():
            for index, (example_model, term) in enumerate(kind.examples(model)):
                cases.append(pytest.param(example_model, term,
                                          id=f"{kind_name}-{model_name}-{index}"))
    return cases


EXAMPLES = _examples()


def _with_term(model, term):
    return model if term in model.force_terms else model.with_effects(term)


#: every kind of term is one the compiled kernels compute (the switches of the material,
#: ``hyperelasticity`` and ``relaxation``, are no force terms: not in :func:`term_kinds`)
COMPILED_EXAMPLES = EXAMPLES


def _state(model, seed=0):
    """A deformed, moving state: 5 % of the mesh size in positions, a speed likewise."""
    rng = np.random.default_rng(seed)
    size = np.ptp(model.mesh.rest_positions, axis=0).max()
    p = model.mesh.rest_positions + 0.05 * size * rng.normal(size=(model.n_nodes, 3))
    v = 0.5 * size * rng.normal(size=(model.n_nodes, 3))
    return p, v


def _close(got, want):
    scale = max(np.abs(want).max(), 1e-300)
    assert np.abs(got - want).max() <= RTOL * scale, (np.abs(got - want).max(), scale)


def test_every_kind_of_term_gives_examples_on_springs_or_elements():
    for name, kind in term_kinds().items():
        assert any(kind.examples(model) for model in MODELS.values()), name
    assert {"springs", "tetrahedra", "gravity", "node_drag"} <= set(term_kinds())


@pytest.mark.parametrize("model, term", EXAMPLES)
def test_state_tangent_and_adjoint_match_central_differences(model, term):
    p, v = _state(model)
    rng = np.random.default_rng(1)
    size = np.ptp(model.mesh.rest_positions, axis=0).max()
    dp = size * rng.normal(size=(model.n_nodes, 3))
    dv = size * rng.normal(size=(model.n_nodes, 3))
    # forward tangent (one direction in p and v at once)
    tangent = term.state_jvp(model, p, v, dp[:, None], dv[:, None])[:, 0]
    central = (term.force(model, p + EPS * dp, v + EPS * dv)
               - term.force(model, p - EPS * dp, v - EPS * dv)) / (2 * EPS)
    _close(tangent, central)
    # adjoint: <λ, J d> = <Jᵀ λ, d> for the p and v parts separately
    cotangent = rng.normal(size=(model.n_nodes, 3))
    lam_p, lam_v = term.state_vjp(model, p, v, cotangent)
    zero = np.zeros_like(dp)[:, None]
    for d, pulled, args in ((dp, lam_p, (dp[:, None], zero)), (dv, lam_v, (zero, dv[:, None]))):
        forward = term.state_jvp(model, p, v, *args)[:, 0]
        want = float(np.sum(cotangent * forward))
        assert float(np.sum(pulled * d)) == pytest.approx(want, rel=1e-9, abs=1e-12 * max(
            np.abs(cotangent).max() * np.abs(forward).max(), 1e-300))


@pytest.mark.parametrize("model, term", EXAMPLES)
def test_parameter_tangent_and_adjoint_match_central_differences(model, term):
    p, v = _state(model, seed=2)
    values = term.parameter_values(model)
    assert values, "every term owns at least one parameter"
    rng = np.random.default_rng(3)
    directions = {name: value * rng.uniform(0.5, 1.5, value.shape) + 1e-3 * (value == 0)
                  for name, value in values.items()}
    tangent = term.parameter_jvp(model, p, v, {name: d[:, None] for name, d in
                                               directions.items()})[:, 0]

    def force_at(step):
        changed, changed_term = term.with_parameter_values(
            model, {name: values[name] + step * directions[name] for name in values})
        return changed_term.force(changed, p, v)

    central = (force_at(EPS) - force_at(-EPS)) / (2 * EPS)
    _close(tangent, central)
    cotangent = rng.normal(size=(model.n_nodes, 3))
    pulled = term.parameter_vjp(model, p, v, cotangent)
    assert set(pulled) == set(values)
    want = float(np.sum(cotangent * tangent))
    got = sum(float(np.sum(pulled[name] * directions[name])) for name in values)
    assert got == pytest.approx(want, rel=1e-9, abs=1e-12 * np.abs(cotangent).max()
                                * np.abs(tangent).max())


def test_the_compiled_kernels_compute_every_term():
    """Every kind of term a model can carry is one the kernels compute: an effect writes
    itself into their arrays (``Effect.compile``, abstract: an effect class without it cannot
    be made), and one that writes nothing fails here rather than drop out of the comparisons
    below unnoticed. The switches of the material are catalogue entries, no force terms, and
    a model refuses them by name."""
    from neurofuzzy.effects import EFFECTS, MaterialSwitch
    from neurofuzzy.effects.compiled import KernelEffects
    from neurofuzzy.forces import Springs, Tetrahedra

    for case in EXAMPLES:
        model, term = case.values
        if not isinstance(term, (Springs, Tetrahedra)):
            with_term = _with_term(model, term)
            assert with_term.effects[-1] is term
            plain = KernelEffects(with_term.replace(effects=()))
            written = KernelEffects(with_term)
            assert any(not np.array_equal(getattr(plain, slot), getattr(written, slot))
                       for slot in ("constant", "drag", "kappa", "stretch", "cubic")) or any(
                not np.array_equal(plain.element[key], written.element[key])
                for key in plain.element), term.name
    switches = {name for name, kind in EFFECTS.items() if issubclass(kind, MaterialSwitch)}
    assert switches == {"hyperelasticity", "relaxation"}
    assert not switches & set(term_kinds())
    model = MODELS["elements (element)"]
    for name in switches:
        with pytest.raises(InputError, match=f"{name} is a change of the elements' material"):
            model.with_effects(EFFECTS[name]([1.0]))


def _compiled_case(model, term):
    """``(parameters, data, θ)`` of ``model`` with ``term`` learned, six frames under a load
    on the last node (a term the kernels compute)."""
    with_term = _with_term(model, term)
    parameters = Parameterization(with_term)
    load = np.zeros((with_term.n_nodes, 3))
    load[-1] = (0.0, 0.0, -0.01)
    data = simulate_experiment(with_term, dt=2e-4, n_frames=6, external_forces=load,
                               substeps="auto")
    theta = parameters.initial() + 0.01
    return parameters, data, theta


@pytest.mark.parametrize("model, term", COMPILED_EXAMPLES)
def test_the_compiled_sensitivities_equal_the_reference_wherever_they_run(model, term):
    """Where the compiled kernels compute a model with this term (springs, elements and the
    effects they know), they compute what the numpy reference computes."""
    parameters, data, theta = _compiled_case(model, term)
    runs = [reference.sensitivity(parameters, 0.01, backend=backend).run(theta, data, substeps=2,
                                                               tangents=True)
            for backend in ("numpy", "numba")]
    assert np.allclose(runs[1].positions, runs[0].positions, rtol=0, atol=1e-14)
    scale = np.abs(runs[0].jacobian).max()
    assert np.abs(runs[1].jacobian - runs[0].jacobian).max() <= 1e-11 * scale


@pytest.mark.parametrize("model, term", COMPILED_EXAMPLES)
def test_the_compiled_adjoint_equals_the_reference_wherever_it_runs(model, term):
    """Where the compiled kernels compute a model with this term, its adjoint's cost and
    gradient (every parameter, the term's own learned) are the numpy adjoint's."""
    parameters, data, theta = _compiled_case(model, term)
    sensitivities = [reference.sensitivity(parameters, 0.01, backend=backend)
                     for backend in ("numpy", "numba")]
    numpy_path, compiled = (s.gradient(theta, data, substeps=2) for s in sensitivities)
    assert compiled[0] == pytest.approx(numpy_path[0], rel=1e-10)
    for name, block in parameters.blocks.items():   # each block to its own scale (κ: 1e-18)
        want, got = numpy_path[1][block.slice], compiled[1][block.slice]
        limit = 1e-9 * np.abs(want).max()
        if name == "log_stiffening":
            # the laws' own constant acts at fourth order in the strain (Yeoh) or not at all
            # at small strain (Mooney-Rivlin): its gradient is 1e-6 to 1e-10 of the others',
            # so the round-off of the whole gradient's sums sets its floor
            limit += 1e-14 * np.abs(numpy_path[1]).max()
        assert np.abs(got - want).max() <= limit, name
    assert np.abs(numpy_path[1]).max() > 0


@pytest.mark.parametrize("model, term", COMPILED_EXAMPLES)
def test_the_stiffness_and_damping_matrices_are_the_force_derivatives(model, term):
    """The assembled stiffness ``-∂F/∂p`` and damping ``-∂F/∂v`` (generated from each
    item's one per-item function, :mod:`neurofuzzy.kernels.element`) of every compiled term
    are central differences of the model's force, and the force they come with is the
    model's (the numpy reference)."""
    from neurofuzzy.simulation import internal_forces
    from neurofuzzy.simulation.tangents import tangents

    with_term = _with_term(model, term)
    p, v = _state(with_term)
    result = tangents(with_term, p, v)
    _close(result.force, internal_forces(with_term, p, v))
    rng = np.random.default_rng(2)
    size = np.ptp(with_term.mesh.rest_positions, axis=0).max()
    dx = size * rng.normal(size=p.shape)
    for matrix, moved in ((result.stiffness, lambda s: (p + s * dx, v)),
                          (result.damping, lambda s: (p, v + s * dx))):
        difference = (internal_forces(with_term, *moved(EPS))
                      - internal_forces(with_term, *moved(-EPS))) / (2 * EPS)
        got = -(matrix @ dx.ravel()).reshape(-1, 3)
        assert np.abs(got - difference).max() <= 1e-6 * max(np.abs(difference).max(),
                                                             1e-300), term.name
