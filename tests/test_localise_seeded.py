"""The diagnosis's inclusion seeded by the per-item map (issue 48, item 2): the region found
that covers most of the scan's ball gives it its sign and is refitted beside it, and an
inclusion is dropped when the map finds no region of other stiffness
(neurofuzzy.diagnosis.localise.seeded)."""

from types import SimpleNamespace

import numpy as np

from neurofuzzy.datasets import kuhn_block
from neurofuzzy.diagnosis.localise import Localisation, seeded
from neurofuzzy.diagnosis.refits import _with_candidate
from neurofuzzy.diagnosis.scoring import Candidate
from neurofuzzy.effects import SoftInclusion, StiffInclusion
from neurofuzzy.mesh import from_tetra
from neurofuzzy.model import Model


def _model(modulus=5000.0):
    points, tets = kuhn_block((3, 3, 2), 0.01)
    mesh = from_tetra(points, tets).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=modulus, poisson_ratio=0.45, viscosity=2.0,
                           density=1000.0)


def _evidence(taken=(), initial=(0.0,)):
    """What seeded asks of the evidence: the items found effects hold, a score per effect,
    and the linearised step of a candidate."""
    def score(effects):
        return [Candidate(name=e.name, score=15.0, explained=0.4, effect=e,
                          elements=list(e.elements)) for e in effects]
    return SimpleNamespace(taken_elements=set(taken), score=score,
                           initial_params=lambda effect: np.array(initial, float))


def _map(model, region, modulus, label="very_soft", quantity="youngs_modulus"):
    """A map whose fit left ``region`` at ``modulus`` and the rest where ``model`` is."""
    values = model.elements.youngs_modulus.copy()
    values[region] = modulus
    fitted = model.with_elements(youngs_modulus=values)
    regions = [{"elements": list(region), "quantity": quantity, "label": label,
                "size": len(region)}] if region else []
    return Localisation(regions=regions, rest={}, words="", learner=SimpleNamespace(
        model_=fitted))


def test_the_ball_takes_the_sign_of_the_map_and_its_region_is_refitted_beside_it():
    model = _model()
    region = list(range(20, 44))
    ball = list(range(30, 60))               # half of it in the region, half outside
    scanned = Candidate(name="stiff_inclusion", score=40.0, explained=0.7,
                        effect=StiffInclusion.of_elements(model, ball), elements=ball)
    gravity = Candidate(name="gravity", score=30.0, explained=0.5)
    tried, words = seeded([scanned, gravity], _map(model, region, 1000.0), model, _evidence())
    assert [c.name for c in tried] == ["soft_inclusion", "soft_inclusion", "gravity"]
    assert [sorted(c.elements) for c in tried[:2]] == [ball, region]
    assert all(c.seeded and isinstance(c.effect, SoftInclusion) for c in tried[:2])
    assert words == ["soft_inclusion, as the map's very_soft region of 24 elements says; it "
                     "is refitted beside the scan's ball of 30 (14 in both)"]
    # harder than the rest: stiff, whatever the scan's ball was named
    scanned.name = "soft_inclusion"
    tried, _ = seeded([scanned], _map(model, region, 25000.0, "hard"), model, _evidence())
    assert [c.name for c in tried] == ["stiff_inclusion"] * 2
    # a region of every element is harder or softer than the model fitted
    every = list(range(model.mesh.n_tetrahedra))
    tried, _ = seeded([scanned], _map(model, every, 7000.0, "hard"), model, _evidence())
    assert [c.name for c in tried] == ["stiff_inclusion"] * 2
    # a ball that is the region is refitted once
    tried, _ = seeded([scanned], _map(model, ball, 25000.0, "hard"), model, _evidence())
    assert [sorted(c.elements) for c in tried] == [ball]


def test_no_region_of_other_stiffness_leaves_no_inclusion_to_refit():
    model = _model()
    ball = list(range(30, 60))
    scanned = Candidate(name="stiff_inclusion", score=40.0, explained=0.7,
                        effect=StiffInclusion.of_elements(model, ball), elements=ball)
    gravity = Candidate(name="gravity", score=30.0, explained=0.5)
    tried, words = seeded([scanned, gravity], _map(model, [], 0.0), model, _evidence())
    assert tried == [gravity]
    assert words == ["stiff_inclusion not refitted: the fit of every item with the prior "
                     "finds no region of other stiffness"]
    # a region of viscosity alone is not one of stiffness; one an inclusion found holds is
    # taken
    viscous = _map(model, list(range(20, 44)), 5000.0, "high", quantity="viscosity")
    assert seeded([scanned], viscous, model, _evidence())[0] == []
    stiff = _map(model, list(range(20, 44)), 25000.0, "hard")
    assert seeded([scanned], stiff, model, _evidence(taken=[21]))[0] == []


def test_the_refit_starts_on_the_map_s_side():
    """The linearised step starts the seeded refit when its sign is the map's; against it, the
    refit starts from no extra stiffness (a soft inclusion never starts stiff)."""
    model = _model()
    region = list(range(20, 44))
    soft = Candidate(name="soft_inclusion", score=15.0, explained=0.4, seeded=True,
                     effect=SoftInclusion.of_elements(model, region), elements=region)
    against = _with_candidate(soft, model, _evidence(initial=(800.0,)), [])
    assert against.effects[-1].params.tolist() == [0.0]
    assert soft.name == "soft_inclusion"
    along = _with_candidate(soft, model, _evidence(initial=(-800.0,)), [])
    assert along.effects[-1].params.tolist() == [-800.0]
    # unseeded, the step's sign names it (as before)
    scanned = Candidate(name="stiff_inclusion", score=15.0, explained=0.4,
                        effect=StiffInclusion.of_elements(model, region), elements=region)
    assert _with_candidate(scanned, model, _evidence(initial=(-800.0,)), []).effects[
        -1].name == "soft_inclusion" and scanned.name == "soft_inclusion"
