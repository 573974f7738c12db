"""Which parameters the data determine: standard errors and unidentifiable combinations.

From the Jacobian ``J`` of the residuals at the optimum (Gauss–Newton approximation):

- the covariance of the parameters is ``σ² (JᵀJ)⁺`` with ``σ²`` the residual variance, so the
  standard error of a log-parameter is a *relative* standard error of stiffness, viscosity or
  mass;
- a parameter whose column of ``J`` is zero does not influence any observed position (a spring
  whose two end nodes are fixed never stretches; a node that never moves has no inertia to see);
- a direction ``x`` with ``J x ≈ 0`` (a right singular vector with a tiny singular value) is a
  combination of parameters the data cannot pin down: changing them together leaves the
  observed trajectories unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..serialization import json_safe

__all__ = ["Identifiability", "analyse"]

#: Singular values below this fraction of the largest count as zero (after column scaling).
RANK_TOLERANCE = 1e-7
#: Parameters with a larger share in a null direction are listed with it.
NULL_SHARE = 0.2


@dataclass
class Identifiability:
    """Standard errors and unidentifiable parameter combinations of a fit.

    Attributes
    ----------
    std_errors : (n_params,) float
        Standard error of every parameter (NaN when unknown, inf when undetermined).
    unidentifiable : list of dict
        Each ``{"parameters": [...], "springs": [...], "nodes": [...], "why": "..."}``.
    names : list of str
        Parameter names, as in ``std_errors``.
    """

    std_errors: np.ndarray
    unidentifiable: list = field(default_factory=list)
    names: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return json_safe({"std_errors": dict(zip(self.names, self.std_errors)),
                          "unidentifiable": self.unidentifiable})


def analyse(parameters, theta: np.ndarray, jacobian: np.ndarray | None,
            residuals: np.ndarray, n_measured: int | None = None) -> Identifiability:
    """Identifiability of ``parameters`` at ``theta`` (see the module docstring).

    ``n_measured`` is the number of residuals that come from measurements (the others are the
    zeros of gaps); default all.
    """
    names = parameters.names()
    n_params = len(theta)
    found: list[dict] = []
    structural = _structural(parameters, names)
    found += structural
    if jacobian is None:
        return Identifiability(np.full(n_params, np.nan), found, names)

    n_res = jacobian.shape[0] if n_measured is None else n_measured
    dof = max(n_res - n_params, 1)
    sigma2 = float(np.sum(residuals**2)) / dof
    norms = np.linalg.norm(jacobian, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    scaled = jacobian / scale
    _, singular, vt = np.linalg.svd(scaled, full_matrices=False)
    cutoff = RANK_TOLERANCE * (singular[0] if singular.size else 0.0)
    inverse = np.where(singular > cutoff, 1.0 / np.where(singular > cutoff, singular, 1.0), 0.0)
    covariance = (vt.T * inverse**2) @ vt / np.outer(scale, scale)
    std = np.sqrt(np.maximum(np.diag(covariance) * sigma2, 0.0))

    listed = {name for entry in structural for name in entry["parameters"]}
    zero_columns = norms <= cutoff * np.max(scale) if norms.size else np.zeros(0, bool)
    for index in np.flatnonzero(zero_columns):
        std[index] = np.inf
        if names[index] not in listed:
            found.append(_entry(parameters, names, [index],
                                "it does not change any observed position in these "
                                "experiments (the springs or nodes it sets do not move)"))
            listed.add(names[index])
    for k in np.flatnonzero(singular <= cutoff):
        direction = vt[k]
        members = [i for i in np.flatnonzero(np.abs(direction) > NULL_SHARE)
                   if names[i] not in listed]
        if len(members) < 2:
            continue
        for i in members:
            std[i] = np.inf
        found.append(_entry(parameters, names, members,
                            "changing these together (in the proportions "
                            + ", ".join(f"{direction[i]:+.2f}" for i in members)
                            + ") leaves the observed trajectories unchanged; a load case "
                            "that moves them differently (another node, another direction) "
                            "separates them"))
    return Identifiability(std, found, names)


def structurally_unidentifiable(parameters) -> list[int]:
    """Indices of spring parameters whose springs all have both end nodes fixed."""
    mesh = parameters.base.mesh
    tie, n_ties = parameters.tied.tie, parameters.tied.n_ties
    moving = mesh.free[mesh.springs].any(axis=1)
    still = ((np.bincount(tie, minlength=n_ties) > 0)
             & (np.bincount(tie, moving, minlength=n_ties) == 0))      # groups that never move
    return sorted(block.start + int(k) for name in ("log_stiffness", "log_damping")
                  if (block := parameters.blocks.get(name)) is not None
                  for k in np.flatnonzero(still))


def _structural(parameters, names) -> list[dict]:
    """Springs whose both ends are fixed can never be identified."""
    return [_entry(parameters, names, [index],
                   "both end nodes of its spring(s) are fixed, so they never stretch or move "
                   "and exert no force on a moving node")
            for index in structurally_unidentifiable(parameters)]


def _entry(parameters, names, indices, why: str) -> dict:
    springs = sorted({int(j) for i in indices for j in parameters.springs_of(i)})
    nodes = sorted({int(n) for i in indices for n in parameters.nodes_of(i)})
    return {"parameters": [names[i] for i in indices], "springs": springs, "nodes": nodes,
            "why": why}
