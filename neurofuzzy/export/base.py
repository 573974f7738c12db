"""What every simulator export shares: the model as a simulator can take it (effects folded in
or set aside), element materials grouped, region densities, the load decomposed into load
curves, the time step.

A simulator holds fewer kinds of things than our models: one material per flex (MuJoCo) or per
part (FEBio), no per-node drag, no strain stiffening. :func:`prepare` turns a model into what
the exporters write and lists, in words, everything it changed or set aside; those sentences
go into the exported file's header (:mod:`neurofuzzy.export.metadata`) and onto the command
line.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..forces import Springs
from ..forces.springs import spring_constants
from ..forces.laws import LAWS

__all__ = ["Exported", "Prepared", "MaterialGroup", "prepare", "material_groups",
           "region_densities", "load_components", "time_step"]

#: Relative size below which a singular value of the load history is round-off.
LOAD_RANK_TOLERANCE = 1e-12


@dataclass(frozen=True)
class Exported:
    """The outcome of :func:`neurofuzzy.export.export`.

    Attributes
    ----------
    target : str
        ``"mujoco"``, ``"sofa"``, ``"febio"`` or ``"vtu"``.
    path : Path
        The file to open in the simulator (the ``.pvd`` for ``vtu``).
    files : tuple of Path
        Every file written.
    notes : tuple of str
        What the target could not express and what was merged or approximated, one sentence
        each (also in the file's header).
    """

    target: str
    path: Path
    files: tuple[Path, ...]
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class Prepared:
    """A model as simulators take it.

    Attributes
    ----------
    model : Model
        The model without effects; inclusions folded into the spring stiffness or the
        elements' Young's modulus.
    gravity : (3,) float
        m/s², from a ``gravity`` effect (zero without).
    node_drag : float
        N·s/m per node, from a ``node_drag`` effect (zero without).
    constant_load : (n_nodes, 3) float
        N, from ``unmodeled_load`` effects.
    notes : list of str
        What was folded, and which effects no simulator here can take.
    """

    model: object
    gravity: np.ndarray
    node_drag: float
    constant_load: np.ndarray
    notes: list = field(default_factory=list)


def prepare(model) -> Prepared:
    """Fold a model's effects into what simulators can take (see :class:`Prepared`)."""
    gravity, drag = np.zeros(3), 0.0
    load = np.zeros((model.n_nodes, 3))
    stiffness = np.array(spring_constants(model)[0], dtype=float)
    modulus = (None if model.elements is None
               else np.array(model.elements.youngs_modulus, dtype=float))
    notes = []
    for effect in model.effects:
        name, params = effect.name, np.asarray(effect.params, float)
        if name == "gravity":
            gravity = gravity + params
        elif name == "node_drag":
            drag += float(params[0])
        elif name == "unmodeled_load":
            load[effect.options["node"]] += params
        elif name in ("stiff_inclusion", "soft_inclusion") and "elements" in effect.options:
            elements = np.asarray(effect.options["elements"], int)
            modulus[elements] += params[0]
            nu = model.elements.poisson_ratio[elements]
            exact = np.allclose(nu, effect.options["poisson_ratio"], rtol=1e-9, atol=0)
            notes.append(f"{name} of {len(elements)} elements folded into their Young's "
                         f"modulus (E + {params[0]:.4g} Pa)" + (
                             "" if exact else f"; its Poisson's ratio "
                             f"{effect.options['poisson_ratio']:.3f} is replaced by the "
                             "elements' own (an approximation)"))
        elif name in ("stiff_inclusion", "soft_inclusion"):
            springs = np.asarray(effect.options.get("springs", np.arange(model.n_springs)), int)
            groups = np.asarray(effect.options["groups"], int)
            coefficient = np.zeros(max(int(model.mesh.spring_group.max(initial=0)),
                                       int(groups.max(initial=0))) + 1)
            coefficient[groups] = params
            stiffness[springs] += coefficient[model.mesh.spring_group[springs]]
            notes.append(f"{name} of {len(springs)} springs folded into their stiffness")
        else:
            notes.append(f"effect {effect.equation()} is not exported: none of the "
                         "simulators has this force")
    if np.any(stiffness < 0) or (modulus is not None and np.any(modulus <= 0)):
        notes.append("a soft inclusion made some stiffness non-positive; clipped to zero")
        stiffness = np.maximum(stiffness, 0.0)
        if modulus is not None:
            modulus = np.maximum(modulus, 1e-12 * float(np.max(modulus)))
    terms = []
    if model.springs is not None or np.any(stiffness):   # (spring inclusions of an element model)
        springs = model.springs or Springs(stiffness=0.0, damping=0.0)
        terms.append(springs.replace(stiffness=stiffness))
    if modulus is not None:
        terms.append(model.elements.replace(youngs_modulus=modulus))
    return Prepared(model.replace(terms=tuple(terms)), gravity, drag, load, notes)


@dataclass(frozen=True)
class MaterialGroup:
    """Elements of one region that a simulator gives one material.

    Attributes
    ----------
    name : str
        The region's name, with ``_1``, ``_2``, … when the region is split.
    region : int
        Index into ``model.region_names``.
    elements : (n,) int
        Element indices.
    youngs_modulus, poisson_ratio : float
        E (Pa) and ν of the group (its elements' own, or their volume-weighted mean when
        merged).
    damping_time : float
        ``β = η / E`` (s), the stiffness-proportional (Rayleigh) damping.
    law : int
        The elements' material law (:data:`neurofuzzy.forces.laws.LAWS`); a group never mixes
        laws.
    relaxation : tuple of (g, τ)
        The elements' Prony terms (:mod:`neurofuzzy.forces.relaxation`; empty: none).
    stiffening : float
        Yeoh's ``C₂₀/C₁₀`` of Yeoh elements (0 for the other laws).
    """

    name: str
    region: int
    elements: np.ndarray
    youngs_modulus: float
    poisson_ratio: float
    damping_time: float
    law: int = 0
    relaxation: tuple = ()
    stiffening: float = 0.0


def material_groups(model, max_groups: int = 256) -> tuple[list[MaterialGroup], list[str]]:
    """The elements grouped by region and material (E, ν, β = η/E), at most ``max_groups``.

    Elements of one region with equal values share a group; when a region has more distinct
    values than it is allotted (``max_groups`` shared by the regions in proportion to their
    distinct values, at least one each), its elements are binned by quantiles of log E and
    each bin takes the volume-weighted mean of E, ν and β. Returns the groups and notes
    saying what was merged and by how much the values moved.
    """
    from ..forces import tetrahedron_geometry

    volume = tetrahedron_geometry(model.mesh).volume
    # E, ν, β, then the Prony terms' g and τ and Yeoh's C20/C10 (grouped alike: equal values
    # share a group)
    values = np.column_stack([model.elements.youngs_modulus, model.elements.poisson_ratio,
                              model.elements.viscosity / model.elements.youngs_modulus,
                              model.elements.relaxation_moduli, model.elements.relaxation_times,
                              np.where(model.elements.stiffens, model.elements.stiffening,
                                       0.0)])
    terms = model.n_relaxation_terms
    rounded = _significant(values, 12)         # equal values, up to the last bits, share
    # the parts to group: each region, split by law when it holds several (never mixed)
    laws = [np.unique(model.elements.law[model.elements.region == r])
            for r in range(len(model.region_names))]
    parts_of = [(r, law, np.flatnonzero((model.elements.region == r)
                                        & (model.elements.law == law)))
                for r in range(len(model.region_names)) for law in laws[r]]
    regions = [elements for _, _, elements in parts_of]
    distinct = [len(np.unique(rounded[e], axis=0)) if len(e) else 0 for e in regions]
    budget = _allot(distinct, max_groups)
    groups, notes = [], []
    for index, elements in enumerate(regions):
        r, law = parts_of[index][:2]
        label = model.region_names[r] + (f"_{LAWS[int(law)]}" if len(laws[r]) > 1 else "")
        if len(elements) == 0:
            continue
        if distinct[index] <= budget[index]:
            _, inverse = np.unique(rounded[elements], axis=0, return_inverse=True)
            bins = inverse.ravel()
        else:
            order = np.argsort(values[elements, 0], kind="stable")
            bins = np.empty(len(elements), int)
            bins[order] = np.arange(len(elements)) * budget[index] // len(elements)
        parts = [elements[bins == b] for b in np.unique(bins)]
        moved = np.zeros(3)
        for k, part in enumerate(parts):
            weight = volume[part] / volume[part].sum()
            mean = (values[part[0]] if distinct[index] <= budget[index]   # the elements' own
                    else weight @ values[part])
            moved = np.maximum(moved, np.max(np.abs(values[part, :3] - mean[:3]), axis=0)
                               / np.array([mean[0], 1.0, max(mean[2], 1e-300)]))
            name = label + (f"_{k + 1}" if len(parts) > 1 else "")
            relaxation = tuple((float(mean[3 + k]), float(mean[3 + terms + k]))
                               for k in range(terms))
            groups.append(MaterialGroup(name, r, part, float(mean[0]), float(mean[1]),
                                        float(mean[2]), int(law), relaxation, float(mean[-1])))
        if distinct[index] > budget[index]:
            notes.append(f"region {label!r}: {distinct[index]} distinct element "
                         f"materials merged into {len(parts)} groups by quantiles of E (largest "
                         f"change: E {100 * moved[0]:.2g} %, Poisson's ratio {moved[1]:.3g}, "
                         f"damping time {100 * moved[2]:.2g} %)")
    return groups, notes


def _significant(values: np.ndarray, digits: int) -> np.ndarray:
    """``values`` rounded to ``digits`` significant digits."""
    scale = 10.0 ** np.floor(np.log10(np.where(values == 0, 1.0, np.abs(values))))
    return np.round(values / scale, digits - 1) * scale


def _allot(distinct: list[int], total: int) -> list[int]:
    """Groups per region: all their distinct materials if they fit, else shares of ``total``."""
    if sum(distinct) <= total:
        return list(distinct)
    present = sum(1 for d in distinct if d)
    spare = max(total - present, 0)
    weights = np.array(distinct, float) / max(sum(distinct), 1)
    return [min(d, 1 + int(spare * w)) if d else 0 for d, w in zip(distinct, weights)]


def region_densities(model) -> tuple[np.ndarray, float]:
    """Density per region (kg/m³) whose lumped masses best match the node masses.

    Every node carries a quarter of each of its tetrahedra's mass (as
    :meth:`~neurofuzzy.model.Model.continuum` builds them), so the node masses are
    linear in the regions' densities; they are solved for by least squares. Returns the
    densities (n_regions,) and the largest relative difference between a node's mass and the
    mass the densities give it (0 for models built from densities).
    """
    import scipy.sparse as sp

    from ..forces import tetrahedron_geometry

    geometry = tetrahedron_geometry(model.mesh)
    n_regions = len(model.region_names)
    corner_region = np.repeat(model.elements.region, 4)
    per_corner = sp.csr_matrix((np.repeat(geometry.volume / 4, 4),
                                (np.arange(corner_region.size), corner_region)),
                               shape=(corner_region.size, n_regions))
    design = (geometry.node_of_corner @ per_corner).toarray()             # (N, R)
    used = design.any(axis=0)
    density = np.zeros(n_regions)
    density[used] = np.linalg.lstsq(design[:, used], model.node_mass, rcond=None)[0]
    density = _significant(np.maximum(density, 0.0), 12)      # 1050, not 1050.0000000000007
    lumped = design @ density
    return density, float(np.max(np.abs(lumped - model.node_mass) / model.node_mass))


def load_components(forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A load history as a few spatial patterns, each scaled by its own load curve.

    Parameters
    ----------
    forces : (n_frames, n_nodes, 3) float
        N; ``forces[t]`` acts from frame ``t`` to ``t + 1``.

    Returns
    -------
    curves : (n_components, n_frames) float
        Dimensionless, largest absolute value 1.
    patterns : (n_components, n_nodes, 3) float
        N; ``forces[t] = Σ_k curves[k, t] patterns[k]`` to round-off (a singular value
        decomposition keeping every component above :data:`LOAD_RANK_TOLERANCE` of the
        largest). A probe pressing with a time profile is one component.
    """
    n_frames, n_nodes, _ = forces.shape
    flat = forces.reshape(n_frames, -1)
    if not np.any(flat):
        return np.zeros((0, n_frames)), np.zeros((0, n_nodes, 3))
    # one pattern scaled in time (a probe pressing with a profile): the strongest frame itself,
    # so that the pattern and the curve hold the recorded numbers exactly
    strongest = flat[np.argmax(np.einsum("ij,ij->i", flat, flat))]
    curve = flat @ strongest / (strongest @ strongest)
    if np.allclose(np.outer(curve, strongest), flat, rtol=0,
                   atol=LOAD_RANK_TOLERANCE * np.abs(strongest).max()):
        return curve[None], strongest.reshape(1, n_nodes, 3)
    left, singular, right = np.linalg.svd(flat, full_matrices=False)
    keep = singular > LOAD_RANK_TOLERANCE * singular[0]
    curves = left[:, keep].T * singular[keep, None]                     # (K, T)
    patterns = right[keep]                                              # (K, 3N)
    scale = np.max(np.abs(curves), axis=1)
    sign = np.sign(curves[np.arange(len(curves)), np.argmax(np.abs(curves), axis=1)])
    curves = curves / (scale * sign)[:, None]
    patterns = patterns * (scale * sign)[:, None]
    return curves, patterns.reshape(-1, n_nodes, 3)


def time_step(model, experiment=None, substeps="auto") -> tuple[float, int | None]:
    """The simulator's time step (s) and the steps per frame of ``experiment``.

    With an experiment: ``experiment.dt / substeps`` (``"auto"``: the fewest substeps that
    are stable for ``model``, as :func:`neurofuzzy.simulate` picks them). Without one: the
    stability bound of ``model`` (with its safety factor) rounded down to two significant
    digits, and None.
    """
    from ..simulation import check_substeps, required_substeps, stability_limit

    if experiment is not None:
        steps = check_substeps(substeps)
        steps = required_substeps(model, experiment.dt) if steps == "auto" else int(steps)
        return experiment.dt / steps, steps
    bound = stability_limit(model).max_step
    if not np.isfinite(bound):
        return 1e-3, None
    digits = 10.0 ** (np.floor(np.log10(bound)) - 1)
    return float(np.floor(bound / digits) * digits), None
