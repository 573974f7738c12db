"""``neurofuzzy fit`` and ``neurofuzzy diagnose``: experiments and a start in, a fitted model,
a report and JSON out. The fit is the library's one pipeline (:func:`neurofuzzy.pipeline.fit`:
start, prior, learner, outcome check, summary); the diagnosis's is
:func:`neurofuzzy.diagnosis.diagnose_data` (the same start, the prior, the diagnosis, the
outcome check)."""

from __future__ import annotations

import sys
from pathlib import Path

from ..errors import InputError
from .common import (Outputs, at_least, mesh_check_option, positive, print_json, vtu_series,
                     written)
from ..formatting import length_text
from ..progress import Stopwatch

__all__ = ["fit", "diagnose"]


def _protected(args) -> list[Path]:
    """The files a fit or diagnosis reads (never written over)."""
    from .common import rule_file

    return [Path(p) for p in args.experiments] + [p for p in (rule_file(args.rules),
                                                              args.start and Path(args.start))
                                                  if p]


def fit(args) -> int:
    from ..pipeline.lab import LOAD_STEPS, MOVING, lab_kind
    from .moving import fit_moved
    from .steps import fit_load_steps

    kind = lab_kind(args.experiments[0])       # a second file: refused by the lab fits
    if kind == LOAD_STEPS:
        if args.target:
            raise InputError("is for time series run by a simulator; load steps are "
                             "equilibria, the same at any step", key="--target")
        return fit_load_steps(args)
    if kind == MOVING:
        return fit_moved(args)
    if args.reference_noise:
        raise InputError("is for a load-step file's scans (each marker's rest point "
                         "estimated from every scan); time series take the first frame as "
                         "measured", key="--reference-noise")
    validate_on = _held_out(args.validate_on, args.experiments)
    if args.dt is not None and not args.target:
        raise InputError("is the step of a --target simulator; give --target too", key="--dt")
    if args.dt is not None:
        positive(args.dt, "--dt")
    progress = not args.quiet   # on stderr: --json output on stdout stays one object
    positive(args.cycles, "--cycles", integer=True)
    positive(args.learning_rate, "--learning-rate")
    at_least(args.mass_learning_rate, 0, "--mass-learning-rate")
    substeps = _substeps(args.substeps)
    watch = Stopwatch()
    with Outputs(_protected(args)) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        export = outputs.folder(args.export, "--export",
                                owns=vtu_series(Path(args.experiments[0]).stem))
        outcome, exported = _fit(args, progress, substeps, out, report, export, outputs,
                                 validate_on)
    result, lack_of_fit = outcome.summary, outcome.lack_of_fit
    if not lack_of_fit.explained and not args.quiet:
        print(f"neurofuzzy: warning: {lack_of_fit.verdict}", file=sys.stderr)
    if args.json:
        print_json(result)
    else:
        print(outcome.model.summary())
        print(f"RMS error per marker: {length_text(result['rms_error_initial'])} -> "
              f"{length_text(result['rms_error'])} ({result['cycles']} cycles, "
              f"{result['seconds']:.1f} s{_compiling(watch)})")
        print(f"lack of fit: {lack_of_fit.verdict}")
        if "validation" in result:
            print(_validation_line(result["validation"]))
        if "target" in result:
            from ..learn.target import describe

            print(describe(result["target"])
                  + (f"; {args.out} holds the values for it" if args.out else ""))
        for name, (low, high) in list(outcome.intervals.items())[:12]:
            print(f"  95 % interval of {name}: {low:.4g} .. {high:.4g}")
        if outcome.intervals and outcome.model.elements is not None:
            print(f"  (they hold {outcome.intervals_hold})")
        if result.get("prior"):
            print(f"prior: weight {result['prior']['alpha']:.3g} ({result['prior']['how']}); "
                  f"{result['regions_found_words']}")
        written(args.out, args.report, exported.get("pvd"), exported.get("xdmf"))
    return 0


def _held_out(text: str | None, experiments) -> float | list[str] | None:
    """``--validate-on`` of time series: a time (``0.3s`` or ``0.3``) or experiment files."""
    if not text:
        return None
    value = text[:-1] if text.endswith("s") and not text.endswith(".npz") else text
    try:
        return float(value)
    except ValueError:
        pass
    given = {Path(p).name: str(Path(p)) for p in experiments}
    given |= {str(p): str(Path(p)) for p in experiments}
    chosen = [part.strip() for part in text.split(",") if part.strip()]
    for part in chosen:
        if part not in given:
            raise InputError(f"got {part!r}: of time series, hold out some of the experiment "
                             f"files given ({', '.join(map(str, experiments))}) or a time in "
                             "seconds (e.g. 0.3s); load steps are held out of a load-step file",
                             key="--validate-on")
    return [given[part] for part in chosen]


def _validation_line(v: dict) -> str:
    what = (f"frames from {v['from_time']:g} s" if "from_time" in v
            else ", ".join(v["experiments"]))
    times = f", {v['times_noise']:.2f}x the noise" if "times_noise" in v else ""
    return (f"held out ({what}): RMS {length_text(v['rms_error'])} per marker predicted"
            f"{times}; fitted {length_text(v['fitted_rms_error'])}")


def _fit(args, progress, substeps, out, report, export, outputs, validate_on=None):
    """Fit (the library's pipeline, which refuses a failed fit), write the staged outputs."""
    from ..io import load_experiment, save_model
    from ..pipeline import fit as fit_pipeline
    from .common import rule_base_for

    inputs = [Path(p) for p in args.experiments]
    loaded = [load_experiment(p) for p in inputs]
    elements = {"tetra": True, "springs": False}.get(args.elements)
    rules = rule_base_for(args.rules, args.tissue, quiet=not progress)
    outcome = fit_pipeline(loaded, start=args.start, rules=rules,
                           tissue=args.tissue, tie=args.tie, elements=elements,
                           law=args.law, relaxation=args.relaxation,
                           stiffening=args.stiffening, prior=args.prior,
                           method=args.method, cycles=args.cycles,
                           learn_masses=args.learn_masses, substeps=substeps,
                           learning_rate=args.learning_rate,
                           mass_learning_rate=args.mass_learning_rate,
                           mesh_check=mesh_check_option(args), names=inputs, progress=progress,
                           validate_on=validate_on)
    learner, record, experiments = outcome.learner, outcome.record, outcome.experiments
    saved = learner.model_
    if args.target:
        from ..learn.target import fit_for_target

        aimed = fit_for_target(learner.model_, experiments, target=args.target,
                               dt=0.016 if args.dt is None else args.dt,
                               substeps=learner.substeps_)
        record = {**record, "target": aimed.record()}
        outcome.summary["target"] = aimed.record()
        saved = aimed.model
    if out:
        save_model(saved, out, fit=record)
    files = {"fitted model": args.out} if args.out else {}
    exported = {}
    if export:
        from ..export import export_paraview
        from ..export.metadata import header_lines

        comment = "\n".join(header_lines(learner.model_, target="vtu", fit=record, notes=(),
                                         experiment=experiments[0]))
        exported = export_paraview(export, learner.model_, experiments[0],
                                   substeps=learner.substeps_, stem=Path(inputs[0]).stem,
                                   comment=comment)
        exported = {kind: outputs.target_of(path) if isinstance(path, (str, Path)) else path
                    for kind, path in exported.items()}
        files.update({f"ParaView {kind}": path for kind, path in exported.items()
                      if kind in ("pvd", "xdmf")})
    if report:
        from ..report import fit_report

        fit_report(outcome, report, files=files)
    return outcome, exported


def diagnose(args) -> int:
    from ..pipeline.lab import LOAD_STEPS, MOVING, lab_kind
    from .moving import diagnose_moved
    from .steps import diagnose_load_steps

    kind = lab_kind(args.experiments[0])
    if kind == LOAD_STEPS:
        return diagnose_load_steps(args)
    if kind == MOVING:
        return diagnose_moved(args)
    from ..diagnosis import diagnose_data
    from ..diagnosis.window import check_window
    from ..io import save_model
    from ..report import diagnosis_report
    from .common import rule_base_for

    progress = not args.quiet   # on stderr: --json output on stdout stays one object
    at_least(args.max_effects, 0, "--max-effects")
    positive(args.max_time, "--max-time")
    substeps = _substeps(args.substeps)
    window = check_window(args.window, "--window")
    with Outputs(_protected(args)) as outputs:
        out = outputs.file(args.out, "--out")
        report = outputs.file(args.report, "--report", twins=(".json",))
        inputs = [Path(p) for p in args.experiments]
        run = diagnose_data(inputs, start=args.start,
                            rules=rule_base_for(args.rules, args.tissue, quiet=not progress),
                            tissue=args.tissue, tie=args.tie,
                            elements={"tetra": True, "springs": False}.get(args.elements),
                            law=args.law, relaxation=args.relaxation,
                            stiffening=args.stiffening, localise=args.localise,
                            max_effects=args.max_effects, substeps=substeps,
                            mesh_check=not args.no_mesh_check, max_time=args.max_time,
                            window=window, progress=progress)
        result = run.diagnosis
        if out:
            save_model(result.model_, out)
        if report:
            diagnosis_report(result, report)
    data = run.to_dict(names=inputs)
    if args.json:
        print_json(data)
    else:
        print(f"effects: {', '.join(result.names)}")
        for finding in result.effects:
            print(f"  {finding.name} (confidence {finding.confidence:.2f}, runner-up "
                  f"{finding.runner_up}){_where(finding)}: {finding.parameters}")
        first, every = "", ""
        if result.window and not result.window["rediagnosed"]:
            first = f" (first {result.window['frames']} frames)"
            every = f" (all {result.window['of']})"
        print(f"RMS error per marker: {length_text(result.rms_before)}{first} -> "
              f"{length_text(result.rms_after)}{every} (marker noise "
              f"{length_text(result.noise_rms)})")
        print(f"verdict: {result.verdict}")
        if result.localisation:
            covered = ", ".join(f"{share:.0%}" for share in result.localisation.overlap)
            print(f"item by item, with the rule base as a prior: {result.localisation.words} "
                  f"(share of the inclusion in these regions: {covered})")
        elif args.localise:
            print("no inclusion found: nothing to locate item by item")
        written(args.out, args.report)
    return 0


def _where(finding) -> str:
    """Where a located effect acts, in a few words (the JSON has the full lists)."""
    if finding.centroid is None:
        return ""
    parts = [f"{len(getattr(finding, key))} {key}" for key in ("springs", "elements")
             if getattr(finding, key)]
    if len(finding.nodes) == 1:
        parts.append(f"node {finding.nodes[0]}")
    centre = ", ".join(f"{1e3 * c:.1f}" for c in finding.centroid)
    return f" at ({centre}) mm" + (f" ({', '.join(parts)})" if parts else "")


def _compiling(watch) -> str:
    """The kernels' one-time compilation, when this command did it (not in the fit's time)."""
    return f"; {watch.compiling:.0f} s more compiling the kernels, once" \
        if watch.compiling >= 0.5 else ""


def _substeps(value):
    from ..simulation import check_substeps

    return check_substeps(value, "--substeps")

