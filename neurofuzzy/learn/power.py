"""What the region test can find here: the smallest stiff lump it would keep at this noise and
on this mesh, from a simulated check.

A region found by the prior is kept only when freeing it shrinks the homogeneous model's
misfit above the noise ``MIN_SHRINK`` times (:mod:`.region_test`). Whether a lump of a given
size could pass depends on the noise, the mesh's own misfit, the markers and where the lump
lies, so the toolkit measures it on the user's data: a lump ``CONTRAST`` times stiffer than
the homogeneous fit, made of the elements nearest a place until they fill a share of the
volume (``FRACTIONS``), is simulated with the fitted homogeneous model at ``PLACES_PER_SIDE``³
places, and its signature (the change of the markers' track) is added to the measured data.
The homogeneous model refitted to those data leaves the residual ``r - P⊥ s`` (``r`` its
residual, ``s`` the signature, ``P⊥`` the projection off its own parameters' Jacobian: the
part of the lump the homogeneous values cannot absorb, one Gauss–Newton step), and freeing
the lump takes the misfit back to where it was; so the lump is kept when the misfit above
the noise grows by ``MIN_SHRINK`` and the Bayesian information criterion agrees, the region
test's two conditions. One simulation per lump and place, no refit.

The statement is a best case for the test (the lump's region given whole, its values
recovered exactly) and a worst case for the place (a lump far from the markers and the loads
is not seen at all); it says at how many of the places each size would be kept.
"""

from __future__ import annotations

import numpy as np

from .region_test import MIN_SHRINK, measured_count, verdict

__all__ = ["detection_limit", "describe_power", "LumpCheck", "CONTRAST", "FRACTIONS", "PLACES_PER_SIDE"]

#: How much stiffer (Young's modulus) the simulated lump is than the homogeneous fit.
CONTRAST = 5.0
#: The lumps' sizes, as shares of the object's volume.
FRACTIONS = (0.01, 0.03, 0.08, 0.2)
#: Places per side of the elements' bounding box where each lump is put.
PLACES_PER_SIDE = 3


def detection_limit(homogeneous, experiments, *, contrast: float = CONTRAST,
                    fractions=FRACTIONS, places_per_side: int = PLACES_PER_SIDE) -> dict | None:
    """The region test's power on these data (module docstring): for each share of the volume
    in ``fractions``, at how many places a lump ``contrast`` times stiffer would be kept.

    ``homogeneous`` is the fitted homogeneous learner (:func:`~.region_test.homogeneous_fit`).
    Returns ``{"contrast", "places", "sizes": [{"fraction", "elements", "kept", "of"}],
    "smallest", "how"}`` (``smallest``: the least share kept at some place, or None), or None
    for a spring network (its regions are springs, not volumes)."""
    from ..forces import tetrahedron_geometry

    model = homogeneous.model_
    if model.elements is None or model.springs is not None:
        return None
    check = LumpCheck(homogeneous, experiments)
    geometry = tetrahedron_geometry(model.mesh)
    centroids = model.mesh.rest_positions[geometry.nodes].mean(axis=1)
    low, high = centroids.min(axis=0), centroids.max(axis=0)
    places = [low + (high - low) * (np.array(index) + 0.5) / places_per_side
              for index in np.ndindex(*(places_per_side,) * 3)]
    order = [np.argsort(np.linalg.norm(centroids - place, axis=1)) for place in places]
    share = geometry.volume / geometry.volume.sum()
    sizes = []
    for fraction in fractions:
        kept, counts, seen = 0, [], set()
        for nearest in order:
            members = np.sort(nearest[:int(np.searchsorted(np.cumsum(share[nearest]),
                                                           fraction)) + 1])
            if members.tobytes() in seen:     # a small object: two places, one lump
                continue
            seen.add(members.tobytes())
            verdict = check.kept(members, contrast)
            if verdict is not None:           # None: the lump's simulation diverged
                counts.append(members.size)
                kept += verdict
        sizes.append({"fraction": float(fraction),
                      "elements": int(np.median(counts)) if counts else 0,
                      "kept": int(kept), "of": len(counts)})
    found = [size["fraction"] for size in sizes if size["kept"]]
    return {"contrast": float(contrast), "places": len(places), "sizes": sizes,
            "smallest": min(found) if found else None,
            "how": (f"a lump {contrast:g}x stiffer than the homogeneous fit, simulated at "
                    f"{len(places)} places and added to the data; kept when the homogeneous "
                    f"model's misfit above the noise grows {MIN_SHRINK:g}x without it (one "
                    "Gauss-Newton step) and the BIC agrees")}


class LumpCheck:
    """Whether the region test would keep a given lump in these data (module docstring): the
    homogeneous fit's residual and the directions its own values can absorb, computed once;
    :meth:`kept` costs one simulation."""

    def __init__(self, homogeneous, experiments):
        from scipy.linalg import orth

        from . import _passes as passes
        from ._parameters import Parameterization
        from ._sensitivity import Sensitivity

        self.homogeneous, self.experiments = homogeneous, list(experiments)
        model = homogeneous.model_
        self.unit, self.steps = model.length_unit, homogeneous.substeps_
        parameters = Parameterization(model, learn_effects=homogeneous.learn_effects)
        sensitivity = Sensitivity(parameters, self.unit, offsets=homogeneous.offsets_)
        jacobian, self.runs = passes.jacobian(sensitivity, self.experiments,
                                              parameters.initial(), [(0,)] * len(experiments),
                                              self.steps)
        self.residual = passes.stacked(self.runs)
        self.basis = orth(jacobian)               # what the homogeneous values absorb
        self.noise = homogeneous.lack_of_fit_.noise
        self.rms = passes.per_marker(float(self.residual @ self.residual), self.runs,
                                     self.unit)
        self.count = measured_count(experiments)
        self._sensitivity, self._bases = sensitivity, {self.steps: self.residual}
        self._theta = parameters.initial()

    def _base(self, steps: int) -> np.ndarray:
        """The homogeneous fit's residual at ``steps`` steps per frame."""
        from . import _passes as passes

        if steps not in self._bases:
            self._bases[steps] = passes.stacked([self._sensitivity.run(
                self._theta, e, substeps=steps) for e in self.experiments])
        return self._bases[steps]

    def kept(self, members, contrast: float) -> bool | None:
        """Whether the elements ``members`` ``contrast`` times stiffer, added to the data,
        would pass the region test (None when their simulation diverges)."""
        from . import _passes as passes
        from ._parameters import Parameterization
        from ._sensitivity import Sensitivity
        from .steps import auto_substeps

        model, learner = self.homogeneous.model_, self.homogeneous
        elements = model.elements
        modulus = np.array(elements.youngs_modulus, float)
        modulus[members] *= contrast
        tie = np.array(elements.tie).copy()
        tie[members] = tie.max() + 1
        lump = Parameterization(model.with_term(elements.replace(youngs_modulus=modulus,
                                                                 tie=tie)),
                                learn_effects=learner.learn_effects)
        sensitivity = Sensitivity(lump, self.unit, offsets=learner.offsets_)
        # a stiffer lump may need more steps per frame to stay stable: then both runs take them
        steps = max([self.steps] + [auto_substeps(lump.model(lump.initial()), e.dt)
                                    for e in self.experiments])
        with np.errstate(all="ignore"):
            signature = passes.stacked([sensitivity.run(lump.initial(), e, substeps=steps)
                                        for e in self.experiments]) - self._base(steps)
        if not np.all(np.abs(signature) < passes.DIVERGED / 2):      # also NaN
            return None
        # the data gain the lump's signature; the homogeneous refit absorbs its part along
        # its own directions and leaves the rest
        left = self.residual - (signature - self.basis @ (self.basis.T @ signature))
        rms = passes.per_marker(float(left @ left), self.runs, self.unit)
        # the region test's verdict: the homogeneous model of these data (rms) against it
        # with the lump's elements freed (back to the fit's own residual)
        return verdict(rms, self.rms, self.noise, self.count, extra=3)[2]


def describe_power(power: dict | None) -> str:
    """The power in words: "a lump 5x stiffer than the tissue would be kept at 0 of 27 places
    at 1 % of the volume, 4 of 27 at 3 %, …"."""
    if not power:
        return ""
    parts = [f"{size['kept']} of {size['of']} places at {100 * size['fraction']:g} % of the "
             f"volume ({size['elements']} elements)" for size in power["sizes"]]
    smallest = (f"none up to {100 * power['sizes'][-1]['fraction']:g} % of the volume"
                if power["smallest"] is None else f"{100 * power['smallest']:g} % of the volume")
    return (f"the region test's power here: a lump {power['contrast']:g}x stiffer would be "
            f"kept at " + ", ".join(parts) + f" (the smallest found: {smallest})")
