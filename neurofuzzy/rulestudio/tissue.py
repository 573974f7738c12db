"""A tissue as the rule base makes it: its material values with units and words, the rules
that fired and how strongly (:func:`tissue_view`), and a block of it poked by a probe
(:func:`poke`): tetrahedral elements with the inferred E, ν, η and density, simulated by
:func:`neurofuzzy.simulate`, pushed and released."""

from __future__ import annotations

import functools
import math
import time

import numpy as np

from ..errors import InputError, UnstableTimeStepError
from ..rules import RuleBase
from ..tissues import initialize
from .view import QUANTITY_UNITS

__all__ = ["tissue_view", "poke", "BLOCK", "default_force"]

#: the poked block: 3 × 3 × 2 cells of 1 cm (48 nodes, 108 tetrahedra), bottom held; a probe
#: of radius 6 mm on the top centre pushes for 75 ms (ramped over 20 ms) and lets go; 150 ms
#: in 60 frames
BLOCK = {"cells": (3, 3, 2), "spacing": 0.01, "radius": 0.006, "dt": 0.0025, "frames": 60,
         "ramp_frames": 8, "push_frames": 30}
#: most integration steps per frame of the preview (a stiffer block is refused, not slow)
MAX_SUBSTEPS = 200
_SAMPLES = 101


def tissue_view(rules: RuleBase, tissue: str) -> dict:
    """The inferred values of ``tissue`` with units, each output's words and degrees, its
    fuzzy set before defuzzification, and every rule's firing strength.

    Raises
    ------
    InputError
        An unknown tissue, or no rule fires for one of its outputs.
    """
    values = rules.tissue(tissue)
    labels = rules.describe(values)
    sets = rules.tissue_sets(tissue)
    strengths = rules.rule_strengths([rules.tissues[tissue]])[:, 0]
    outputs = []
    for name, value in values.items():
        variable = rules.outputs[name]
        grid = variable.grid
        samples = np.linspace(grid[0], grid[-1], _SAMPLES)
        outputs.append({
            "name": name, "quantity": variable.quantity, "value": value,
            "unit": variable.unit or QUANTITY_UNITS.get(str(variable.quantity), ""),
            "term": labels[name].term, "degree": labels[name].degree,
            "degrees": labels[name].degrees,
            "set": {"low": float(grid[0]), "high": float(grid[-1]),
                    "values": np.round(np.interp(samples, grid, sets[name]), 4).tolist()}})
    return {"tissue": tissue,
            "words": {k: str(v) for k, v in rules.tissues[tissue].items()},
            "defaults": {k: str(v) for k, v in
                         rules.defaults_taken(rules.tissues[tissue]).items()},
            "outputs": outputs,
            "rules": [{"position": i, "text": rule.text, "line": rule.line,
                       "weight": rule.weight, "strength": float(s)}
                      for i, (rule, s) in enumerate(zip(rules.rules, strengths))]}


@functools.lru_cache(maxsize=1)
def _mesh():
    from ..datasets import kuhn_block
    from ..mesh import bottom_layer, from_tetra

    points, tetrahedra = kuhn_block(BLOCK["cells"], BLOCK["spacing"])
    return from_tetra(points, tetrahedra).with_fixed(where=bottom_layer)


def default_force(youngs_modulus: float) -> float:
    """A probe force (N) that presses a block of this modulus by about a tenth of its height,
    rounded to one significant digit."""
    force = 2.5e-5 * youngs_modulus
    digits = math.floor(math.log10(force))
    return round(force, -digits)


def poke(rules: RuleBase, tissue: str, force: float | None = None) -> dict:
    """Simulate the block of ``tissue`` pushed by the probe with ``force`` newtons (default
    :func:`default_force` of its modulus) and released.

    Returns
    -------
    dict
        ``time`` (n_frames,) s; ``depth`` (n_frames,) m, how far the probe's patch sank;
        ``positions`` (n_frames, n_nodes, 3) m; ``triangles`` (n_faces, 3) of the surface;
        ``fixed`` node indices; ``probe`` (point, radius, force, frames pushed); ``material``
        (E, ν, η, density of the elements, and ``relaxation_modulus`` Σg and
        ``relaxation_time`` τ when the tissue's words make it relax); ``substeps``,
        ``seconds``, ``warning``.
    """
    from ..mesh import patch_weights, surface_triangles
    from ..simulation import simulate, stability_limit

    started = time.perf_counter()
    mesh = _mesh()
    model = initialize(rules, mesh, tissue, elements=True)
    material = {"youngs_modulus": float(model.elements.youngs_modulus[0]),
                "poisson_ratio": float(model.elements.poisson_ratio[0]),
                "viscosity": float(model.elements.viscosity[0]),
                "density": float(model.node_mass.sum() / np.prod(
                    np.ptp(mesh.rest_positions, axis=0)))}
    if model.n_relaxation_terms:              # a tissue whose words say it relaxes
        material.update(relaxation_modulus=float(model.elements.relaxation_moduli[0].sum()),
                        relaxation_time=float(model.elements.relaxation_times[0, 0]))
    if force is None:
        force = default_force(material["youngs_modulus"])
    force = float(force)
    if not (math.isfinite(force) and 0 < force <= 100):
        raise InputError(f"got {force!r}; expected a probe force in (0, 100] N", key="force")
    rest = mesh.rest_positions
    top = rest[:, 2].max()
    point = np.array([np.ptp(rest[:, 0]) / 2, np.ptp(rest[:, 1]) / 2, top])
    weights = patch_weights(mesh, point, BLOCK["radius"])
    n = BLOCK["frames"]
    ramp = np.clip(np.arange(n) / BLOCK["ramp_frames"], 0.0, 1.0)
    ramp[BLOCK["push_frames"]:] = 0.0
    loads = ramp[:, None, None] * (weights[:, None] * np.array([0.0, 0.0, -force]))[None]
    limit = stability_limit(model)
    substeps = max(1, math.ceil(BLOCK["dt"] / limit.max_step))
    if substeps > MAX_SUBSTEPS:
        raise InputError(f"this tissue is too stiff or too viscous for the live block "
                         f"(E = {material['youngs_modulus']:.3g} Pa, η = "
                         f"{material['viscosity']:.3g} Pa s would need {substeps} steps per "
                         "frame)", key="block")
    warning = None
    try:
        # the compiled kernels (8-10 ms a poke; the first in a process loads them, 0.3 s):
        # every law, and a tissue whose words make it relax (its internal variables)
        trajectory = simulate(model, dt=BLOCK["dt"], n_frames=n, external_forces=loads,
                              substeps=substeps,
                              check_stability=False)      # substeps chosen from the limit above
        positions = trajectory.positions
    except UnstableTimeStepError:
        raise InputError(f"the block collapsed under {force:g} N (the elements turned inside "
                         "out); lower the probe force", key="block") from None
    depth = -(positions[:, :, 2] - rest[None, :, 2]) @ weights
    height = np.ptp(rest[:, 2])
    if depth.max() > 0.5 * height:
        warning = (f"the probe sinks {depth.max() * 1000:.1f} mm into a "
                   f"{height * 1000:.0f} mm block: beyond what linear elements describe; "
                   "lower the force")
    return {"time": (np.arange(n) * BLOCK["dt"]).tolist(),
            "depth": np.round(depth, 9).tolist(),
            "positions": np.round(positions, 7).tolist(),
            "triangles": surface_triangles(mesh).tolist(),
            "fixed": np.flatnonzero(mesh.fixed).tolist(),
            "probe": {"point": point.tolist(), "radius": BLOCK["radius"], "force": force,
                      "push_until": BLOCK["push_frames"] * BLOCK["dt"]},
            "material": material, "substeps": substeps, "tissue": tissue,
            "seconds": time.perf_counter() - started, "warning": warning}
