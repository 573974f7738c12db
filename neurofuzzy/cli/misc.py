"""``neurofuzzy demo`` and ``neurofuzzy rules check|show``."""

from __future__ import annotations

import json
from pathlib import Path

from ..progress import Stopwatch, note
from .common import Outputs, positive, print_json

__all__ = ["demo", "rules_check", "rules_show"]


def demo(args) -> int:
    positive(args.cycles, "--cycles", integer=True)
    outputs = Outputs()
    staged = outputs.folder(args.out, "--out")
    watch = Stopwatch()
    with outputs:
        _demo(args, staged)
    compiling = (f"; {watch.compiling:.0f} s more compiling the kernels, once"
                 if watch.compiling >= 0.5 else "")
    print(f"\nwrote {args.out}/: error_per_cycle.png (the paper's Figure 4), table.txt, "
          f"summary.json, report.html (+ .json), diagnosis.html (+ .json) "
          f"({watch.seconds:.1f} s{compiling})")
    return 0


def _demo(args, out: Path) -> None:
    from ..demo import comparison_table, paper_experiments, plot_error_curves, words_and_diagnosis

    out.mkdir(parents=True)
    progress = not args.quiet
    note(progress, "neurofuzzy demo: the paper's cube (27 nodes, 86 springs, bottom fixed, "
                   "constant force on the top centre node, 250 steps)")
    runs = paper_experiments(cycles=args.cycles, progress=progress, gradient_for=(3,))
    table = comparison_table(runs)
    print(table)
    from ..formatting import json_safe
    from ..io.writing import atomic_write

    plot_error_curves(runs, out / "error_per_cycle.png")
    summary = {"runs": [{"experiment": r.experiment, "learner": r.learner, "cycles": r.cycles,
                         "E": r.final_error, "stiffness_error": r.stiffness_error,
                         "damping_error": r.damping_error, "mass_error": r.mass_error,
                         "rms_initial": r.rms_initial, "rms_final": r.rms_final,
                         "seconds": r.seconds} for r in runs]}
    with atomic_write(out / "summary.json", "w") as handle:
        json.dump(json_safe(summary), handle, indent=2, allow_nan=False)  # diverged: null
    with atomic_write(out / "table.txt", "w") as handle:
        handle.write(table + "\n")
    print()
    for line in words_and_diagnosis(out, progress=progress):
        print(line)


def rules_check(args) -> int:
    from .common import load_rule_base

    rule_base = load_rule_base(args.rules, quiet=True)      # its summary names the file
    print(rule_base.summary())
    return 0


def rules_show(args) -> int:
    from .common import load_rule_base

    rule_base = load_rule_base(args.rules, quiet=True)      # its output names the file
    values = rule_base.tissue(args.tissue)
    labels = rule_base.describe(values)
    defaults = rule_base.defaults_taken(rule_base.tissues[args.tissue])
    if args.json:
        print_json({
            "tissue": args.tissue,
            "rules": rule_base.provenance(),
            "words": {k: str(v) for k, v in rule_base.tissues[args.tissue].items()},
            "defaults": {k: str(v) for k, v in defaults.items()},
            "values": values,
            "units": {k: rule_base.outputs[k].unit for k in values},
            "labels": {k: {"term": l.term, "degree": l.degree, "degrees": l.degrees}
                       for k, l in labels.items()}})
    else:
        words = ", ".join(f"{k} is {v}" for k, v in rule_base.tissues[args.tissue].items())
        print(f"rules: {rule_base.origin}")
        print(f"{args.tissue}: {words}")
        if defaults:
            print("  not described, so the rule base's defaults: " + ", ".join(
                f"{k} is {v}" for k, v in defaults.items()))
        for name, label in labels.items():
            print(f"  {name} = {label.value:.4g} {rule_base.outputs[name].unit}   ({label})")
    return 0
