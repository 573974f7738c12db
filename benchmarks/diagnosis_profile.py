"""Where a diagnosis's time goes (issue 51, item 1): ``diagnose`` of the probed block on the
default 4 mm voxels a user's ``neurofuzzy mesh`` gives (1,089 nodes, 4,800 tetrahedra), from
data of a solver nobody here wrote (scikit-fem's quadratic tetrahedra, small strain,
20 µm marker noise), with a hidden effect or none. Every progress line of the diagnosis is
stamped with the seconds since it began; the phases are the spans between them (the first
fit, each scoring, each refit, the mesh check).

    python benchmarks/diagnosis_profile.py                  # none and gravity, ~10 min
    python benchmarks/diagnosis_profile.py --cases none

Prints a table per case and writes ``benchmarks/diagnosis_profile.json``.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path

from neurofuzzy.diagnosis import diagnose
from neurofuzzy.validation.probed_block import block_experiment, block_model, probed_block

CASES = {"none": {}, "gravity": {"gravity": True}}


class _Stamped(io.TextIOBase):
    """stderr that keeps every line with the seconds since ``began`` (and still shows it)."""

    def __init__(self, began: float):
        self.began, self.lines, self.buffer = began, [], ""

    def write(self, text: str) -> int:
        sys.__stderr__.write(text)
        self.buffer += text
        while "\n" in self.buffer:
            line, self.buffer = self.buffer.split("\n", 1)
            self.lines.append((time.perf_counter() - self.began, line))
        return len(text)


def profile(case: str) -> dict:
    data = probed_block(**CASES[case])
    start = block_model().tied("global")
    experiment = block_experiment(data, start.mesh)
    began = time.perf_counter()
    stamped = _Stamped(began)
    with contextlib.redirect_stderr(stamped):
        result = diagnose(start, experiment, progress=True)
    total = time.perf_counter() - began
    phases, last = [], 0.0
    for seconds, line in stamped.lines:
        phases.append({"until": line.removeprefix("diagnose: ")[:110],
                       "seconds": round(seconds - last, 1)})
        last = seconds
    phases.append({"until": "the answer", "seconds": round(total - last, 1)})
    return {"case": case, "elements": start.mesh.n_tetrahedra, "nodes": start.n_nodes,
            "frames": experiment.n_frames, "answer": result.names,
            "verdict": result.verdict, "seconds": round(total, 1), "phases": phases}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    args = parser.parse_args(argv)
    results = []
    for case in args.cases:
        result = profile(case)
        results.append(result)
        print(f"\n{case}: {result['nodes']} nodes, {result['elements']} tetrahedra, "
              f"{result['frames']} frames -> {', '.join(result['answer'])} in "
              f"{result['seconds']:.0f} s")
        for phase in result["phases"]:
            print(f"  {phase['seconds']:7.1f} s  until: {phase['until']}")
    path = Path(__file__).with_suffix(".json")
    path.write_text(json.dumps(results, indent=1) + "\n")
    print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
