"""The block every exported file carries: the fitted values per region with their units, the
lack of fit and its verdict, the toolkit version, the experiment, and what the target could
not express. As text lines (for a comment) and as a JSON-ready mapping (for a metadata
field)."""

from __future__ import annotations

import numpy as np

__all__ = ["metadata", "header_lines", "fit_lines", "volumetric_note", "NOT_RECORDED"]

NOT_RECORDED = "lack of fit: not recorded"


def _value(values: np.ndarray, unit: str) -> str:
    lo, hi = float(np.min(values)), float(np.max(values))
    if np.isclose(lo, hi, rtol=1e-9, atol=0):
        return f"{lo:.6g} {unit}".rstrip()
    return f"{float(np.median(values)):.6g} {unit} (median; {lo:.4g} .. {hi:.4g})".replace(
        "  (", " (")


def region_values(model) -> dict:
    """``{region: {quantity: value}}`` in SI units: medians of the elements (E, ν, η, β) or
    springs (stiffness, damping) of each region, its node mass and its counts."""
    out = {}
    for index, name in enumerate(model.region_names):
        nodes = model.node_region == index
        entry = {"tissue": model.region_tissues[index], "nodes": int(nodes.sum()),
                 "node_mass_kg": float(model.node_mass[nodes].sum())}
        if model.elements is not None:
            chosen = model.elements.region == index
            E, nu, eta = (model.elements.youngs_modulus[chosen],
                          model.elements.poisson_ratio[chosen], model.elements.viscosity[chosen])
            if chosen.any():
                entry.update(elements=int(chosen.sum()),
                             youngs_modulus_Pa=float(np.median(E)),
                             poisson_ratio=float(np.median(nu)),
                             viscosity_Pa_s=float(np.median(eta)),
                             damping_time_s=float(np.median(eta / E)))
        springs = _region_springs(model, index)
        if springs is not None:
            entry.update(springs=int(springs.sum()),
                         stiffness_N_per_m=float(np.median(model.springs.stiffness[springs])),
                         damping_N_s_per_m=float(np.median(model.springs.damping[springs])))
        out[name] = entry
    return out


def _region_springs(model, index: int) -> np.ndarray | None:
    """(n_springs,) bool: the springs of region ``index``, when the model has springs there
    that pull or damp (None otherwise)."""
    springs = model.springs
    if springs is None:
        return None
    chosen = springs.region == index
    if chosen.any() and (np.any(springs.stiffness[chosen]) or np.any(springs.damping[chosen])):
        return chosen
    return None


def _region_lines(model) -> list[str]:
    lines = []
    for index, name in enumerate(model.region_names):
        tissue = model.region_tissues[index]
        nodes = model.node_region == index
        head = f"region {name}" + (f" ({tissue})" if tissue and tissue != name else "")
        parts = [f"{int(nodes.sum())} nodes, mass {model.node_mass[nodes].sum():.6g} kg"]
        if model.elements is not None:
            chosen = model.elements.region == index
            if chosen.any():
                E = model.elements.youngs_modulus[chosen]
                eta = model.elements.viscosity[chosen]
                parts += [f"{int(chosen.sum())} tetrahedra",
                          f"Young's modulus E = {_value(E, 'Pa')}",
                          f"Poisson's ratio = {_value(model.elements.poisson_ratio[chosen], '')}",
                          f"viscosity eta = {_value(eta, 'Pa s')}",
                          f"damping time eta/E = {_value(eta / E, 's')}"]
        springs = _region_springs(model, index)
        if springs is not None:
            parts += [f"{int(springs.sum())} springs",
                      f"stiffness = {_value(model.springs.stiffness[springs], 'N/m')}",
                      f"damping = {_value(model.springs.damping[springs], 'N s/m')}"]
        lines.append(f"{head}: " + "; ".join(parts))
    return lines


def fit_lines(fit: dict | None) -> list[str]:
    """The fit record of a model file (``fit:``) in words; :data:`NOT_RECORDED` without one."""
    if not fit:
        return [NOT_RECORDED]
    lack = fit.get("lack_of_fit") or {}
    if not isinstance(lack, dict) or not lack:
        lines = [NOT_RECORDED]
    else:
        numbers = []
        for key, label in (("rms", "RMS error"), ("noise", "marker noise")):
            value = lack.get(key)
            if isinstance(value, (int, float)) and np.isfinite(value):
                numbers.append(f"{label} {value:.4g} m per marker")
        ratio = lack.get("ratio")
        if isinstance(ratio, (int, float)):
            numbers.append(f"ratio {ratio:.3g}")
        verdict = lack.get("verdict") or "no verdict recorded"
        lines = [f"lack of fit: {verdict}" + (f" ({', '.join(numbers)})" if numbers else "")]
    who = [f"{key} {fit[key]}" for key in ("learner", "neurofuzzy_version") if fit.get(key)]
    if fit.get("experiments"):
        who.append("experiments " + ", ".join(str(e) for e in fit["experiments"]))
    rules = fit.get("rules")
    if isinstance(rules, dict) and rules.get("path"):
        who.append(f"rules {rules['path']} (sha256 {str(rules.get('sha256'))[:8]}…)")
    if who:
        lines.append("fitted by " + "; ".join(who))
    return lines


def volumetric_note(model, target: str, experiment=None, steps: int | None = None) -> str | None:
    """What running a model with the nodal volumetric form as textbook elements changes.

    Every target's tetrahedron is the textbook one (``Tetrahedra(volumetric="element")``). For a
    model with the nodal form the note says so and, with an experiment, measures it: both
    forms simulated by our own stepper under the experiment's load, the RMS distance of the
    free nodes over all frames and the peak motion.
    """
    if model.elements is None or model.elements.volumetric != "nodal":
        return None
    text = (f"{target}'s tetrahedra are the textbook linear element (our "
            "volumetric='element'); this model was fitted with the nodal volumetric "
            "form (averaged over the tetrahedra around each node), which is softer for nearly "
            "incompressible tissue")
    return text + _measured(model, model.with_elements(volumetric="element"), "forms",
                            experiment, steps)


def law_note(model, target: str, element: str, experiment=None,
             steps: int | None = None, native: str = "st-venant-kirchhoff") -> str | None:
    """What running a model whose elements are not of the ``native`` law of a target's
    ``element`` (St. Venant–Kirchhoff for MuJoCo's flex, ``corotational`` for SOFA's
    tetrahedron) as that element changes: said, and with an experiment measured as in
    :func:`volumetric_note` (both laws simulated by our own stepper under its load)."""
    from ..forces.laws import law_number

    number = law_number(native)
    if model.elements is None or not np.any(model.elements.law != number):
        return None
    text = (f"the elements' material law ({model.elements.law_names()}) is written as {target}'s "
            f"{element}: the same E, nu and eta at small strain, not at large strain")
    return text + _measured(model, model.with_elements(law=number), "laws", experiment, steps)


def relaxation_note(model, target: str, experiment=None, steps: int | None = None) -> str | None:
    """What dropping the elements' Prony relaxation changes (``target`` has no such element):
    said, and measured as in :func:`law_note`."""
    if model.elements is None or not model.n_relaxation_terms:
        return None
    text = (f"the elements relax ({model.n_relaxation_terms} Prony term(s), relative modulus "
            f"{float(model.elements.relaxation_moduli.sum(axis=1).max()):.3g} at most), which "
            f"{target}'s elements cannot: written at their long-term E, so they are softer at "
            "first than the fitted model and do not creep")
    return text + _measured(model, model.with_elements(relaxation_moduli=None,
                                                       relaxation_times=None),
                            "models", experiment, steps)


def _measured(model, other, what: str, experiment, steps: int | None) -> str:
    """"; on … the two {what} differ by … m RMS per node (… % of the peak motion)": ``model``
    and ``other`` simulated by our own stepper under ``experiment``'s load (the RMS distance of
    the free nodes over all frames), or a hint when there is no experiment."""
    if experiment is None:
        return "; pass an experiment to measure the difference"
    from ..experiment import simulate_like
    from ..simulation import required_substeps

    # the target's steps, unless either model needs more to be stable (the textbook element
    # beside the nodal form, stiffer as ν nears 0.5, needs more than the model itself)
    steps = max(steps or 1, required_substeps(model, experiment.dt),
                required_substeps(other, experiment.dt))
    with np.errstate(all="ignore"):
        own = simulate_like(model, experiment, steps)
        changed = simulate_like(other, experiment, steps)
    free = model.mesh.free
    difference = np.sqrt(np.mean(np.sum((own[:, free] - changed[:, free]) ** 2, axis=-1)))
    peak = np.max(np.linalg.norm(own[:, free] - own[0, free], axis=-1))
    share = f" ({100 * difference / peak:.2g} % of the peak motion {peak:.3g} m)" if peak else ""
    return (f"; on {experiment.source} the two {what} differ by {difference:.3g} m RMS per "
            f"node{share}, measured with neurofuzzy's own stepper at {steps} step(s) per frame")


def metadata(model, *, target: str, fit: dict | None, notes, experiment=None,
             time_step: float | None = None, steps: int | None = None) -> dict:
    """The JSON-ready block (see the module docstring)."""
    from ..version import __version__

    block = {"generator": f"neurofuzzy {__version__}", "target": target,
             "units": "SI: m, kg, s, N, Pa (stiffness N/m, damping N s/m, viscosity Pa s)",
             "regions": region_values(model),
             "volumetric_form": model.elements.volumetric if model.elements is not None else None,
             "material_law": model.elements.law_names() if model.elements is not None else None,
             "lack_of_fit": (fit or {}).get("lack_of_fit") or "not recorded",
             "fit": {k: v for k, v in (fit or {}).items() if k != "lack_of_fit"} or None,
             "notes": list(notes)}
    if time_step is not None:
        block["time_step_s"] = time_step
    if experiment is not None:
        block["experiment"] = {"source": str(experiment.source), "frames": experiment.n_frames,
                               "dt_s": experiment.dt, "steps_per_frame": steps}
    return block


def header_lines(model, *, target: str, fit: dict | None, notes, experiment=None,
                 time_step: float | None = None, steps: int | None = None) -> list[str]:
    """The block as lines of text (no comment markers)."""
    from ..version import __version__

    lines = [f"Written by neurofuzzy {__version__} (neurofuzzy export, target {target}). "
             "Units: SI (m, kg, s, N, Pa).", "Fitted values:"]
    lines += ["  " + line for line in _region_lines(model)]
    lines += fit_lines(fit)
    if experiment is not None:
        lines.append(f"experiment: {experiment.source}, {experiment.n_frames} frames of "
                     f"{experiment.dt:.6g} s" + (f", {steps} steps per frame" if steps else ""))
    if time_step is not None:
        lines.append(f"time step: {time_step:.6g} s")
    if notes:
        lines.append("Not expressed, merged or approximated in this target:")
        lines += [f"  - {note}" for note in notes]
    return lines
