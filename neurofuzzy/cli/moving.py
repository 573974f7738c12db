"""``fit`` of an experiment file in time whose body a stage moved (``import MARKERS.csv
--displacements PLATE.csv`` with a ``time`` column): the fit through implicit steps
(:func:`~neurofuzzy.pipeline.moving.fit_moving_file`)."""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import InputError
from .common import Outputs, mesh_check_option, print_json, written

__all__ = ["fit_moved"]

#: ``fit`` options of the time-series fit that a fit through implicit steps has no use for
UNUSED = ("validate_on", "target", "dt", "reference_noise")


def fit_moved(args) -> int:
    """``fit`` of one experiment file with driven sets or a tool."""
    from ..io import save_model
    from ..pipeline.moving import fit_moving_file
    from .common import rule_base_for

    if len(args.experiments) != 1:
        raise InputError("takes one recording of a plate or tool at a time",
                         key="EXPERIMENT.npz")
    for option in UNUSED:
        if getattr(args, option, None):
            raise InputError("is not available for a recording whose body a stage moved (it is "
                             "fitted through implicit steps)",
                             key=f"--{option.replace('_', '-')}")
    substeps = 1 if args.substeps in (None, "auto") else int(args.substeps)
    if substeps < 1:
        raise InputError(f"got {args.substeps}; expected a positive integer", key="--substeps")
    source = Path(args.experiments[0])
    with Outputs([source] + [Path(p) for p in (args.rules, args.start) if p]) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        say = (lambda text: print(text, file=sys.stderr)) if not args.quiet else None
        outcome = fit_moving_file(source, start=args.start,
                                  rules=rule_base_for(args.rules, args.tissue),
                                  tissue=args.tissue, law=args.law, substeps=substeps,
                                  mesh_check=mesh_check_option(args), progress=say)
        record, data = outcome.record, outcome.data
        if out:
            save_model(outcome.result.model, out)
        if report:
            _report(outcome, substeps, report)
    if args.json:
        print_json(record)
        return 0
    markers = 0 if data.markers is None else data.markers.n_markers
    print(f"moved in time: {data.n_frames} frames of {data.dt:.4g} s, {markers} markers"
          + (", the load cell's force" if data.reaction is not None else ", no force"))
    print(f"  E = {record['youngs_modulus']:.4g} Pa, nu = {record['poisson_ratio']:.4f}, "
          f"viscosity = {record['viscosity']:.4g} Pa s ({record['scheme']} steps of "
          f"{record['step']:.3g} s, {record['evaluations']} evaluations: {record['reason']})")
    print(f"  markers: RMS {1e6 * record['marker_rms_error']:.3g} um"
          + ("" if record["force_rms_error"] is None else
             f"; force: RMS {1e3 * record['force_rms_error']:.3g} mN (noise "
             f"{1e3 * record['force_noise']:.3g} mN)"))
    check = record["mesh_check"]
    if check is not None:
        print(f"  on a fine mesh (from {check['elements'][0]} and {check['elements'][1]} "
              f"tetrahedra): E = {check['youngs_modulus']['extrapolated']:.4g} Pa, nu = "
              f"{check['poisson_ratio']['extrapolated']:.4f}, viscosity = "
              f"{check['viscosity']['extrapolated']:.4g} Pa s")
    elif record["mesh_check_skipped"]:
        print(f"  no mesh check: {record['mesh_check_skipped']}")
    for region, values in record["materials"].items():
        labels = values.get("labels", {})
        if labels:
            print(f"  {region}: " + ", ".join(f"{k} {v}" for k, v in labels.items()))
    for note in record["notes"]:
        print(f"  note: {note}")
    written(args.out, args.report)
    return 0


def _report(outcome, substeps: int, path) -> None:
    """The report of a fit through implicit steps: the fitted model run as it was fitted."""
    from ..report.moving import moving_report
    from ..simulation.implicit import simulate_implicit

    data, fit, record = outcome.data, outcome.result, outcome.record
    run = simulate_implicit(fit.model, dt=data.dt, n_frames=data.n_frames,
                            external_forces=data.external_forces,
                            initial_positions=data.initial_positions(), substeps=substeps,
                            iterations=50, tolerance=1e-11, scheme=record["scheme"],
                            driven=data.driven, tool=data.tool)
    labels = next(iter(record["materials"].values()), {}).get("labels", {})
    moving_report(outcome.start, fit, data, run, path, labels=labels, notes=record["notes"])
