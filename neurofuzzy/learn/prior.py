"""The rule base as a prior: the expert's words constrain a fit of many parameters.

A tissue's description ("firm, elastic") infers, for every material quantity, a fuzzy set on
the output's universe before defuzzification (:meth:`RuleBase.tissue_sets`). The prior
replaces each set by the Gaussian with the same centroid ``c`` and spread ``s`` (the set's
standard deviation, in the universe's internal coordinates: decades on log universes), so its
negative log-membership is the smooth quadratic ``½ ((u - c) / s)²`` of the quantity's
internal value ``u``. Every free material parameter (a tie group of springs or elements:
stiffness and viscosity as the E and η they stand for, an element's E, ν and η) gets one such
term from the tissue of its region; a smoothness term ``½ β ((u_a - u_b) / s)²`` joins
neighbouring parameters of one region (elements that share a face, springs that share a
node). By default ``β = 1``: neighbours one spread apart cost what a value one spread from the
description costs. The description alone leaves every item free within its word's width;
the smoothness term makes a fit of thousands of items take its level from the data and keeps
a stiff spot (an inclusion) as a smooth bump where noise alone would scatter the values.

The learner minimises ``½ ‖r‖² + ½ w Σ (prior terms)`` with ``r`` the data residuals in units
of the mean spring length. ``w = α σ²`` with ``σ`` the marker noise in the same units: at
``α = 1`` the prior is a Bayesian one (the set's spread is one standard deviation, the noise
is the data's). ``weight="auto"`` chooses ``α`` by the discrepancy principle (Morozov): the
largest prior weight whose fit still explains the data to the noise level, RMS residual = σ.
The noise level comes from the data (:func:`neurofuzzy.noise.noise_level`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..constants import spring_factor
from ..errors import InputError

__all__ = ["FuzzyPrior", "QuantitySet", "parse_prior", "PRIOR_QUANTITIES"]

#: Parameter block → the material quantity it stands for.
PRIOR_QUANTITIES = {"log_stiffness": "youngs_modulus", "log_damping": "viscosity",
                    "log_youngs_modulus": "youngs_modulus",
                    "logit_poisson_ratio": "poisson_ratio", "log_viscosity": "viscosity"}


@dataclass(frozen=True)
class QuantitySet:
    """A tissue's inferred fuzzy set for one quantity and its Gaussian summary.

    Attributes
    ----------
    quantity, output : str
        The material quantity and the rule base's output variable for it.
    grid, membership : (G,) float
        The set on the output's grid (internal coordinates).
    centre, spread : float
        Centroid and standard deviation of the set (internal coordinates).
    """

    quantity: str
    output: str
    grid: np.ndarray
    membership: np.ndarray
    centre: float
    spread: float


def parse_prior(value) -> float | str:
    """``"off"``, ``"auto"`` or a positive weight ``α`` (from the command line or the API)."""
    if isinstance(value, str) and value in ("off", "auto"):
        return value
    try:
        weight = float(value)
    except (TypeError, ValueError):
        raise InputError(f"got {value!r}; expected off, auto or a positive weight",
                         key="prior") from None
    if not (np.isfinite(weight) and weight > 0):
        raise InputError(f"got {value!r}; expected off, auto or a positive weight",
                         key="prior")
    return weight


class FuzzyPrior:
    """The tissue descriptions of a model's regions as a penalty on its material parameters.

    Parameters
    ----------
    rules : RuleBase
        A loaded rule base (``nf.load_rules(path)``, or ``neurofuzzy.rules.resolve(name)``
        for a shipped one: the learner reads no files).
    model : Model
        Its regions' tissues (``region_tissues``), or ``tissue`` for regions without one.
    tissue : str, optional
    weight : "auto" or float
        ``α`` of the module docstring: ``"auto"`` chooses it by the discrepancy principle;
        a number fixes it (1 = the Bayesian weight).
    smoothness : float
        ``β``, the weight of the neighbour terms relative to the value terms (0: none).
        The default 1 suits per-element and per-spring fits; tied fits have few neighbours.

    Raises
    ------
    InputError
        A region without a tissue; a rule base without a Young's modulus output; a name or
        path instead of a rule base.
    """

    def __init__(self, rules, model, *, tissue: str | None = None, weight="auto",
                 smoothness: float = 1.0):
        if not (hasattr(rules, "outputs") and hasattr(rules, "tissue_sets")):
            raise InputError(f"got {rules!r}; the prior takes a loaded rule base: "
                             "FuzzyPrior(neurofuzzy.rules.resolve(NAME_OR_PATH), model) or "
                             "FuzzyPrior(nf.load_rules(PATH), model)", key="rules")
        self.rules = rules
        self.weight = parse_prior(weight)
        if self.weight == "off":
            raise InputError("a prior cannot be off; pass prior=None instead", key="prior")
        if not (np.isfinite(smoothness) and smoothness >= 0):
            raise InputError(f"got {smoothness!r}; expected a non-negative number",
                             key="smoothness")
        self.smoothness = float(smoothness)
        self.tissues = []
        for index, region in enumerate(model.region_names):
            name = model.region_tissues[index] or tissue
            if not name:
                raise InputError(f"region {region!r} has no tissue; give one (--tissue NAME) "
                                 "for the prior", key="tissue")
            self.tissues.append(name)
        by_quantity = {v.quantity: k for k, v in self.rules.outputs.items() if v.quantity}
        if "youngs_modulus" not in by_quantity:
            raise InputError("the prior needs the rule base's youngs_modulus output",
                             source=self.rules.source, key="outputs")
        #: per region: quantity → QuantitySet
        self.sets: list[dict[str, QuantitySet]] = []
        cache = {}
        for name in self.tissues:
            if name not in cache:
                sets = self.rules.tissue_sets(name)
                cache[name] = {quantity: _summary(quantity, output, self.rules.outputs[output],
                                                  sets[output])
                               for quantity, output in by_quantity.items()
                               if quantity in ("youngs_modulus", "viscosity", "poisson_ratio")}
            self.sets.append(cache[name])
        self.model = model

    # -- the terms for one parameterisation --------------------------------------------------
    def terms(self, parameters) -> PriorTerms:
        """The prior's terms on the parameter vector of ``parameters`` (a
        :class:`~neurofuzzy.learn._parameters.Parameterization` of this prior's model)."""
        return PriorTerms.build(self, parameters)

    def label(self, region: int, quantity: str) -> str:
        """The word the description gives ``quantity`` in ``region`` (its set's centroid)."""
        chosen = self.sets[region][quantity]
        variable = self.rules.outputs[chosen.output]
        return self.rules.describe({chosen.output: float(variable.to_physical(
            chosen.centre))})[chosen.output].term

    def to_dict(self) -> dict:
        return {"tissues": sorted(set(self.tissues)), "smoothness": self.smoothness,
                "sets": {name: {q: {"output": s.output, "centre": s.centre, "spread": s.spread}
                                for q, s in self.sets[i].items()}
                         for i, name in enumerate(self.model.region_names)}}


def _summary(quantity, output, variable, membership) -> QuantitySet:
    grid = variable.grid
    total = float(membership.sum())
    if total <= 0:
        raise InputError(f"no rule fires on {output!r} for the prior", key="rules")
    centre = float((grid * membership).sum() / total)
    spread = float(np.sqrt(((grid - centre) ** 2 * membership).sum() / total))
    spread = max(spread, (grid[1] - grid[0]))
    return QuantitySet(quantity, output, grid, membership, centre, spread)


@dataclass
class PriorTerms:
    """The prior's terms for one parameter vector: ``u = to_internal(x(θ))`` per row.

    Attributes
    ----------
    index : (n_rows,) int
        The parameter of every value row.
    offset : (n_rows,) float
        ``log`` of the fixed factor between the parameter's physical value and the quantity
        (within-group ratios, spring geometry); 0 for ν.
    logit : (n_rows,) bool
        The parameter is ``logit 2ν`` (else a logarithm).
    log_scale : (n_rows,) bool
        The quantity's universe is logarithmic.
    centre, spread : (n_rows,) float
    pairs : (n_pairs, 2) int
        Rows joined by a smoothness term.
    smoothness : float
        ``β``.
    n_params : int

    All terms are at unit weight; the learner multiplies them by ``√w``.
    """

    index: np.ndarray
    offset: np.ndarray
    logit: np.ndarray
    log_scale: np.ndarray
    centre: np.ndarray
    spread: np.ndarray
    pairs: np.ndarray
    smoothness: float
    n_params: int

    @classmethod
    def build(cls, prior: FuzzyPrior, parameters) -> PriorTerms:
        model = parameters.base
        rows = {key: [] for key in ("index", "offset", "logit", "log_scale", "centre",
                                    "spread", "item_group")}
        for name, quantity in PRIOR_QUANTITIES.items():
            block = parameters.blocks.get(name)
            if block is None:
                continue
            if name in ("log_stiffness", "log_damping"):
                tie, region = model.springs.tie, model.springs.region
                offset_items = np.log(parameters.ratio(name) / spring_factor(model))
            else:
                tie, region = model.elements.tie, model.elements.region
                ratio = parameters.ratio(name)          # (ν has no ratios: one per group)
                offset_items = np.log(np.ones(len(tie)) if ratio is None else ratio)
            n_groups = block.stop - block.start
            counts = np.bincount(tie, minlength=n_groups)
            offset = np.bincount(tie, offset_items, n_groups) / np.maximum(counts, 1)
            first = np.full(n_groups, -1)
            first[tie[::-1]] = np.arange(len(tie))[::-1]
            for group in range(n_groups):
                if counts[group] == 0:
                    continue
                chosen = prior.sets[int(region[first[group]])].get(quantity)
                if chosen is None:
                    continue
                variable = prior.rules.outputs[chosen.output]
                rows["index"].append(block.start + group)
                rows["offset"].append(0.0 if name == "logit_poisson_ratio" else offset[group])
                rows["logit"].append(name == "logit_poisson_ratio")
                rows["log_scale"].append(variable.scale == "log")
                rows["centre"].append(chosen.centre)
                rows["spread"].append(chosen.spread)
                rows["item_group"].append((name, int(group)))
        arrays = {key: np.asarray(value) for key, value in rows.items() if key != "item_group"}
        pairs = (_neighbour_pairs(model, parameters, rows["item_group"]) if prior.smoothness > 0
                 else np.zeros((0, 2), dtype=np.intp))
        return cls(index=arrays["index"].astype(np.intp),
                   offset=arrays["offset"].astype(float), logit=arrays["logit"].astype(bool),
                   log_scale=arrays["log_scale"].astype(bool),
                   centre=arrays["centre"].astype(float), spread=arrays["spread"].astype(float),
                   pairs=pairs, smoothness=prior.smoothness, n_params=parameters.size)

    @property
    def n_rows(self) -> int:
        return len(self.index) + len(self.pairs)

    def values(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``u`` (internal value of every row's quantity) and ``du/dθ`` at ``theta``."""
        t = theta[self.index]
        with np.errstate(over="ignore"):
            logistic = 1.0 / (1.0 + np.exp(-t))
        x = np.where(self.logit, 0.5 * logistic, np.exp(np.where(self.logit, 0.0, t)
                                                          + self.offset))
        dx = np.where(self.logit, x * (1.0 - 2.0 * x), x)
        u = np.where(self.log_scale, np.log10(x), x)
        du = np.where(self.log_scale, dx / (x * np.log(10.0)), dx)
        return u, du

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """(n_rows,) ``(u - c) / s`` then ``√β (u_a - u_b) / s`` (unit weight)."""
        u, _ = self.values(theta)
        value_rows = (u - self.centre) / self.spread
        a, b = self.pairs.T if len(self.pairs) else (np.zeros(0, int), np.zeros(0, int))
        pair_rows = (np.sqrt(self.smoothness) * (u[a] - u[b]) / self.spread[a])
        return np.concatenate([value_rows, pair_rows])

    def jacobian(self, theta: np.ndarray) -> sp.csr_matrix:
        """(n_rows, n_params) sparse ``∂ residuals / ∂θ``."""
        _, du = self.values(theta)
        n = len(self.index)
        value = sp.csr_matrix((du / self.spread, (np.arange(n), self.index)),
                              shape=(n, self.n_params))
        if not len(self.pairs):
            return value
        a, b = self.pairs.T
        k = np.arange(len(self.pairs))
        factor = np.sqrt(self.smoothness) / self.spread[a]
        pair = sp.csr_matrix((np.concatenate([factor * du[a], -factor * du[b]]),
                              (np.concatenate([k, k]),
                               np.concatenate([self.index[a], self.index[b]]))),
                             shape=(len(self.pairs), self.n_params))
        return sp.vstack([value, pair]).tocsr()

    def cost(self, theta: np.ndarray) -> float:
        """``½ Σ residuals²`` (unit weight)."""
        r = self.residuals(theta)
        return 0.5 * float(r @ r)

    def gradient(self, theta: np.ndarray) -> np.ndarray:
        """``∂ cost / ∂θ`` (unit weight): ``Jᵀ r`` summed per parameter, without forming
        ``J`` (L-BFGS asks for it every iteration)."""
        _, du = self.values(theta)
        r = self.residuals(theta)
        n = len(self.index)
        per_row = r[:n] / self.spread
        if len(self.pairs):
            a, b = self.pairs.T
            pull = np.sqrt(self.smoothness) * r[n:] / self.spread[a]
            per_row = per_row + np.bincount(a, pull, n) - np.bincount(b, pull, n)
        return np.bincount(self.index, per_row * du, self.n_params)


def _neighbour_pairs(model, parameters, row_keys) -> np.ndarray:
    """Pairs of value rows (``row_keys``: the (block, tie group) of every row) of one
    quantity and one region whose items are neighbours: elements sharing a face, springs
    sharing a node."""
    by_key = {key: i for i, key in enumerate(row_keys)}
    pairs = set()
    for name in PRIOR_QUANTITIES:
        if name not in parameters.blocks:
            continue
        if name in ("log_stiffness", "log_damping"):
            tie, region = model.springs.tie, model.springs.region
            a, b = _springs_sharing_a_node(model.mesh)
        else:
            tie, region = model.elements.tie, model.elements.region
            a, b = _elements_sharing_a_face(model.mesh.tetrahedra)
        same = (region[a] == region[b]) & (tie[a] != tie[b])
        for i, j in zip(tie[a[same]], tie[b[same]]):
            ri, rj = by_key.get((name, int(i))), by_key.get((name, int(j)))
            if ri is not None and rj is not None:
                pairs.add((min(ri, rj), max(ri, rj)))
    return np.array(sorted(pairs), dtype=np.intp).reshape(-1, 2)


def _elements_sharing_a_face(tetrahedra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    faces = np.sort(tetrahedra[:, [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]], axis=2)
    owner = np.repeat(np.arange(len(tetrahedra)), 4)
    flat = faces.reshape(-1, 3)
    order = np.lexsort(flat.T[::-1])
    flat, owner = flat[order], owner[order]
    same = np.all(flat[1:] == flat[:-1], axis=1)
    return owner[:-1][same], owner[1:][same]


def _springs_sharing_a_node(mesh) -> tuple[np.ndarray, np.ndarray]:
    ends = mesh.springs.ravel()
    spring = np.repeat(np.arange(mesh.n_springs), 2)
    order = np.argsort(ends, kind="stable")
    ends, spring = ends[order], spring[order]
    starts = np.flatnonzero(np.r_[True, ends[1:] != ends[:-1]])
    stops = np.r_[starts[1:], len(ends)]
    a, b = [], []
    for start, stop in zip(starts, stops):
        members = spring[start:stop]
        i, j = np.triu_indices(len(members), 1)
        a.append(members[i])
        b.append(members[j])
    return np.concatenate(a), np.concatenate(b)
