"""Which parameters the data determine: standard errors and unidentifiable combinations.

From the Jacobian ``J`` of the residuals at the optimum (Gauss–Newton approximation):

- the covariance of the parameters is ``σ² (JᵀJ)⁺`` with ``σ²`` the residual variance, so the
  standard error of a log-parameter is a *relative* standard error of stiffness, viscosity or
  mass. That assumes independent residuals, which holds only when the model explains the
  data to the noise. A model that misses something leaves errors that are smooth in time and
  space, so the residuals of one marker, and of one frame, are correlated and the data hold
  far less independent information than their number says. The standard errors are
  therefore also computed with the **two-way cluster-robust sandwich** (Cameron, Gelbach &
  Miller 2011): ``(JᵀJ)⁺ B (JᵀJ)⁺`` with ``B = Σ_markers g gᵀ + Σ_frames g gᵀ - Σ_values
  g gᵀ``, ``g`` the score ``Jᵀ r`` summed over one marker's whole recording, one frame's
  markers, or one value; a residual correlated along a marker's track or across a frame
  widens it, independent noise gives back ``σ² (JᵀJ)⁺``. The larger of the two is reported
  (it needs more markers and frames than parameters; otherwise the plain one stands);
- a parameter whose column of ``J`` is zero does not influence any observed position (a spring
  whose two end nodes are fixed never stretches; a node that never moves has no inertia to see);
- a direction ``x`` with ``J x ≈ 0`` (a right singular vector with a tiny singular value) is a
  combination of parameters the data cannot pin down: changing them together leaves the
  observed trajectories unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..formatting import json_safe

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
    robust : bool
        Whether the cluster-robust sandwich entered ``std_errors``.
    """

    std_errors: np.ndarray
    unidentifiable: list = field(default_factory=list)
    names: list = field(default_factory=list)
    robust: bool = False

    def to_dict(self) -> dict:
        return json_safe({"std_errors": dict(zip(self.names, self.std_errors)),
                          "std_errors_how": ("the larger of the plain Gauss-Newton and the "
                                             "two-way cluster-robust (markers, frames) "
                                             "sandwich estimate" if self.robust else
                                             "Gauss-Newton with independent residuals"),
                          "unidentifiable": self.unidentifiable})


def analyse(parameters, theta: np.ndarray, jacobian: np.ndarray | None,
            residuals: np.ndarray, n_measured: int | None = None,
            shapes=None, n_nuisance: int = 0) -> Identifiability:
    """Identifiability of ``parameters`` at ``theta`` (see the module docstring).

    ``n_measured`` is the number of residuals that come from measurements (the others are the
    zeros of gaps); default all. ``shapes`` are the ``(n_frames, n_rows)`` of the
    experiments whose residuals (frame, row, coordinate, in this order) open ``residuals``
    and ``jacobian``, for the cluster-robust standard errors (rows after them, a prior's,
    count only in ``JᵀJ``); ``n_nuisance`` parameters fitted besides ``theta`` (the markers'
    offsets) take their share of the degrees of freedom.
    """
    names = parameters.names()
    n_params = len(theta)
    found: list[dict] = []
    structural = _structural(parameters, names)
    found += structural
    if jacobian is None or not (np.all(np.isfinite(residuals))
                                and np.all(np.isfinite(jacobian))):
        return Identifiability(np.full(n_params, np.nan), found, names)   # or diverged

    n_res = jacobian.shape[0] if n_measured is None else n_measured
    dof = max(n_res - n_params - n_nuisance, 1)
    sigma2 = float(np.sum(residuals**2)) / dof
    norms = np.linalg.norm(jacobian, axis=0)
    scale = np.where(norms > 0, norms, 1.0)
    scaled = jacobian / scale
    _, singular, vt = np.linalg.svd(scaled, full_matrices=False)
    cutoff = RANK_TOLERANCE * (singular[0] if singular.size else 0.0)
    inverse = np.where(singular > cutoff, 1.0 / np.where(singular > cutoff, singular, 1.0), 0.0)
    covariance = (vt.T * inverse**2) @ vt / np.outer(scale, scale)
    std = np.sqrt(np.maximum(np.diag(covariance) * sigma2, 0.0))
    robust = None
    if shapes:
        meat = cluster_meat(jacobian, residuals, shapes)
        if meat is not None:
            robust = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", covariance, meat,
                                                  covariance), 0.0))
            std = np.maximum(std, robust)

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
    return Identifiability(std, found, names, robust=robust is not None)


def cluster_meat(jacobian: np.ndarray, residuals: np.ndarray, shapes) -> np.ndarray | None:
    """``B`` of the two-way cluster-robust sandwich (module docstring): scores summed per
    marker (row) and per frame of every experiment, minus the per-value scores; None when
    there are fewer markers or frames than twice the parameters (too few clusters)."""
    n_params = jacobian.shape[1]
    n_rows = sum(rows for _, rows in shapes)
    n_frames = sum(frames for frames, _ in shapes)
    if min(n_rows, n_frames) < 2 * n_params:
        return None
    meat = np.zeros((n_params, n_params))
    start = 0
    by_marker, by_frame = [], []
    for frames, rows in shapes:
        stop = start + 3 * frames * rows
        block = jacobian[start:stop].reshape(frames, rows, 3, n_params)
        r = residuals[start:stop].reshape(frames, rows, 3)
        score = block * r[..., None]                                   # (T, R, 3, P)
        by_marker.append(score.sum(axis=(0, 2)))
        by_frame.append(score.sum(axis=(1, 2)))
        flat = score.reshape(-1, n_params)
        meat -= flat.T @ flat
        start = stop
    for groups in (np.concatenate(by_marker), np.concatenate(by_frame)):
        meat += len(groups) / max(len(groups) - 1, 1) * (groups.T @ groups)
    values, vectors = np.linalg.eigh(meat)                 # two-way sums can lose definiteness
    return (vectors * np.maximum(values, 0.0)) @ vectors.T


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
