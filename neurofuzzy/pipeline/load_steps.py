"""The fit of a load-step file (a compression test between plates), as ``neurofuzzy fit`` and
``fit-many`` run it: :func:`fit_load_step_file` (where it starts, the fit, the record with
materials and words) — the load-step counterpart of :func:`neurofuzzy.pipeline.fit`."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..errors import InputError

__all__ = ["LoadStepOutcome", "fit_load_step_file", "load_step_start"]


@dataclass(frozen=True)
class LoadStepOutcome:
    """The start model, the data, the fit (``LoadStepFit``) and its record (the object of
    ``fit --json``)."""

    start: object
    data: object
    result: object
    record: dict
    rules: object = None


def load_step_start(data, *, start=None, rules=None, tissue: str | None = None,
                    law: str | None = None, option: str = "--start"):
    """The start of a fit of ``data`` (``LoadSteps``): a model (or model file) of its mesh,
    else a rule base's ``tissue``; ``law`` replaces the elements' law."""
    from ..io import load_model
    from ..model import Model
    from ..tissues import initialize

    if start is not None:
        model = start if isinstance(start, Model) else load_model(start)
        if model.n_nodes != data.mesh.n_nodes or model.elements is None:
            raise InputError(f"has {model.n_nodes} nodes"
                             + ("" if model.elements is not None else " and no elements")
                             + f"; the data's mesh has {data.mesh.n_nodes} nodes and "
                             "tetrahedra", source=None if isinstance(start, Model)
                             else str(start), key=option)
        model = model.replace(mesh=data.mesh)
    elif rules is not None and tissue:
        model = initialize(rules, data.mesh, tissue, elements=True)
    else:
        raise InputError("give the start: a model file (--start MODEL.yaml) or a rule base's "
                         "tissue (--rules R --tissue T)",
                         key=option)
    return model.with_elements(law=law) if law else model


def fit_load_step_file(path, *, start=None, rules=None,
                       tissue: str | None = None, law: str | None = None,
                       validate_on: Sequence[int] = (), reference_noise: bool = False,
                       mesh_check: bool | str = "auto",
                       progress: Callable[[str], None] | None = None) -> LoadStepOutcome:
    """Read the load-step file ``path`` (or take a ``LoadSteps``), fit it from ``start`` (a
    model or model file) or ``rules`` and ``tissue`` (:func:`load_step_start`), and make the
    record ``fit --json`` prints: E (None when not identifiable), ν, ``unidentifiable``,
    standard errors, the markers' and the load cell's errors and noise, the held-out steps, the
    registration, ``rms_error`` (the markers', for the tables of fit-many), ``materials`` with
    no value and no word for what is not identifiable, and the notes. ``reference_noise``: each
    marker's rest point estimated from every scan
    (:func:`~neurofuzzy.learn.load_step_fit.fit_load_steps`). ``mesh_check`` ("auto", "step",
    "refit" or False): how far E and ν move on the mesh refined once, which widens the
    intervals and gives the values extrapolated to a fine mesh
    (:func:`~neurofuzzy.learn.load_step_mesh_check.with_mesh_check`; "auto" where the refined
    mesh is small enough to be cheap)."""
    from ..io.load_steps import load_load_steps
    from ..learn.load_step_fit import fit_load_steps
    from ..learn.load_step_mesh_check import with_mesh_check
    from ..tissues import materials

    from ..load_steps import LoadSteps

    data = path if isinstance(path, LoadSteps) else load_load_steps(path)
    model = load_step_start(data, start=start, rules=rules, tissue=tissue, law=law)
    result = fit_load_steps(model, data, validate_on=validate_on,
                            reference_noise=reference_noise, progress=progress)
    if mesh_check:
        result = with_mesh_check(result, data, how="step" if mesh_check is True else mesh_check,
                                 reference_noise=reference_noise, validate_on=validate_on,
                                 progress=progress)
    found = materials(result.model_, rules, tissue)
    for region in found.values():
        for name in result.unidentifiable_:
            region.get("labels", {}).pop(name, None)
            if name in region:
                region[name] = None
    record = {"kind": "load steps", "youngs_modulus": None if "youngs_modulus" in
              result.unidentifiable_ else result.youngs_modulus_,
              "poisson_ratio": result.poisson_ratio_,
              "unidentifiable": list(result.unidentifiable_), "fixed": list(result.fixed_),
              "standard_errors": result.standard_errors_,
              "marker_rms_error": result.marker_rms_, "rms_error": result.marker_rms_,
              "marker_noise": result.marker_noise_,
              "force_rms_error": result.force_rms_, "force_noise": result.force_noise_,
              "validation": result.validation_, "iterations": result.iterations_,
              "registration": result.registration_.tolist(), "materials": found,
              "reference_noise": reference_noise,
              "intervals": {name: result.interval(name) for name in result.standard_errors_},
              "intervals_hold": result.intervals_hold,
              "mesh_check": (None if result.mesh_check_ is None
                             else result.mesh_check_.to_dict()),
              "notes": list(result.notes_)}
    return LoadStepOutcome(model, data, result, record, rules)
