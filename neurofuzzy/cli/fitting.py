"""``neurofuzzy fit`` and ``neurofuzzy diagnose``: experiments and a start in, a fitted model,
a report and JSON out. The start policy is the library's :func:`~neurofuzzy.learn.start_model`."""

from __future__ import annotations

from pathlib import Path

from .common import print_json, refuse_overwrite, written

__all__ = ["fit", "diagnose"]


def _start(args, progress: bool):
    """The experiments named on the command line and the start of their fit."""
    from ..io import load_experiment
    from ..learn import start_model

    inputs = [Path(p) for p in args.experiments]
    protected = inputs + [Path(p) for p in (args.rules, args.start) if p]
    for option in ("out", "report"):
        refuse_overwrite(getattr(args, option, None), protected)
    if getattr(args, "report", None):            # and the report's JSON twin
        refuse_overwrite(str(Path(args.report).with_suffix(".json")), protected)
    experiments = [load_experiment(p) for p in inputs]
    start = start_model(experiments, model=args.start, rules=args.rules, tissue=args.tissue,
                        tie=args.tie, progress=progress)
    return inputs, experiments, start


def fit(args) -> int:
    from ..io import save_model
    from ..learn.run import fit_summary, make_learner

    progress = not args.quiet and not args.json
    inputs, experiments, start = _start(args, progress)
    learner = make_learner(args.method, cycles=args.cycles or None,
                           learn_masses=args.learn_masses, substeps=_substeps(args.substeps),
                           learning_rate=args.learning_rate,
                           mass_learning_rate=args.mass_learning_rate, progress=progress)
    learner.fit(start.model, experiments)
    if args.out:
        save_model(learner.model_, args.out)
    files = {"fitted model": args.out} if args.out else {}
    exported = {}
    if args.export:
        from ..export import export_paraview

        exported = export_paraview(args.export, learner.model_, experiments[0],
                                   substeps=learner.substeps_, stem=Path(inputs[0]).stem)
        files.update({f"ParaView {kind}": path for kind, path in exported.items()
                      if kind in ("pvd", "xdmf")})
    if args.report:
        from ..report import fit_report

        fit_report(start, learner, args.report, files=files)
    result = fit_summary(learner, start, method=args.method,
                         tie=args.tie or ("model" if args.start else "groups"),
                         experiments=inputs)
    if args.json:
        print_json(result)
    else:
        print(learner.model_.summary())
        print(f"RMS error: {result['rms_error_initial']:.4g} -> {result['rms_error']:.4g} "
              f"({result['cycles']} cycles, {result['seconds']:.1f} s)")
        written(args.out, args.report, exported.get("pvd"), exported.get("xdmf"))
    return 0


def diagnose(args) -> int:
    from ..diagnosis import diagnose as run_diagnosis
    from ..io import save_model
    from ..report import diagnosis_report

    progress = not args.quiet and not args.json
    if args.max_effects < 0:
        from ..errors import InputError

        raise InputError(f"got {args.max_effects}; expected 0 or more", key="--max-effects")
    inputs, experiments, start = _start(args, progress)
    result = run_diagnosis(start.model, experiments, max_effects=args.max_effects,
                           substeps=_substeps(args.substeps),
                           progress=progress)
    if args.out:
        save_model(result.model_, args.out)
    if args.report:
        diagnosis_report(result, args.report)
    data = result.to_dict()
    data.update(experiments=[str(p) for p in inputs], start=start.to_dict())
    if args.json:
        print_json(data)
    else:
        print(f"effects: {', '.join(result.names)}")
        for finding in result.effects:
            where = (f" springs {finding.springs}" if finding.springs else "") + \
                (f" node {finding.nodes}" if finding.nodes else "")
            print(f"  {finding.name} (confidence {finding.confidence:.2f}, runner-up "
                  f"{finding.runner_up}){where}: {finding.parameters}")
        print(f"RMS error: {result.rms_before:.4g} -> {result.rms_after:.4g} "
              f"(marker noise {result.noise_rms:.3g})")
        written(args.out, args.report)
    return 0


def _substeps(value):
    from ..simulation import check_substeps

    return check_substeps(value, "--substeps")
