"""Where a diagnosis's time goes (issue 51): ``diagnose`` of the probed block on the default
4 mm voxels a user's ``neurofuzzy mesh`` gives (1,089 nodes, 4,800 tetrahedra), from data of
solvers nobody here wrote, with a hidden effect or none:

- ``none``, ``gravity``: scikit-fem's quadratic tetrahedra, small strain, 131 frames, 20 µm
  marker noise (gravity: the block let go as the probe touches);
- ``small strain``, ``large strain``, ``relaxing``: sfepy's neo-Hookean block (stored in
  ``tests/data``): 4–5 % and 27–35 % compression under the probe (131 frames), and a Prony
  term (g = 0.5, τ = 50 ms) under a held load (331 frames).

The start is the SVK block ``neurofuzzy mesh`` writes. Every progress line of the diagnosis is
stamped with the seconds since it began; the phases are the spans between them (the first
fit, each scoring, each refit, the mesh check); ``fits`` is the whole diagnosis in units of its
first fit (the model as it is, at the diagnosis's looser tolerance), and with ``--one-fit``
``fits_of_one_fit`` in units of one fit of the same model as ``neurofuzzy fit`` makes it
(``GradientLearner(substeps="auto")``, its default tolerance), timed after the diagnosis in the
same run: issue 51's yardstick.

    python benchmarks/diagnosis_profile.py                  # every case, ~20 min
    python benchmarks/diagnosis_profile.py --cases none "large strain"
    python benchmarks/diagnosis_profile.py --cases relaxing --max-effects 1 --no-mesh-check
    python benchmarks/diagnosis_profile.py --cases "large strain" --max-effects 1 \
        --no-mesh-check --one-fit

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
from neurofuzzy.learn import GradientLearner
from neurofuzzy.validation.nonlinear.recordings import stored
from neurofuzzy.validation.probed_block import block_experiment, block_model, probed_block

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
#: case: scikit-fem's recording's options, or a stored sfepy recording
CASES = {"none": {}, "gravity": {"gravity": True},
         "small strain": DATA / "neo_hookean_block_small_strain.npz",
         "large strain": DATA / "neo_hookean_block_large_strain.npz",
         "relaxing": DATA / "relaxing_block.npz",
         # issue 51's length: 30 frames at rest and 371 of motion
         "large strain 401": DATA / "neo_hookean_block_large_strain_401.npz",
         "relaxing 401": DATA / "relaxing_block_401.npz",
         "small strain 401": DATA / "neo_hookean_block_small_strain_401.npz"}
#: what a right answer is
EXPECTED = {"none": ["none"], "gravity": ["gravity"], "small strain": ["none"],
            "large strain": ["hyperelasticity"], "relaxing": ["relaxation"],
            "large strain 401": ["hyperelasticity"], "relaxing 401": ["relaxation"],
            "small strain 401": ["none"]}


class _Stamped(io.TextIOBase):
    """stderr that keeps every line with the seconds since ``began`` (and still shows it)."""

    def __init__(self, began: float):
        self.began, self.lines, self.buffer = began, [], ""

    def write(self, text: str) -> int:
        self.buffer += text
        while "\n" in self.buffer:
            line, self.buffer = self.buffer.split("\n", 1)
            seconds = time.perf_counter() - self.began
            self.lines.append((seconds, line))
            if line.strip():
                sys.__stderr__.write(f"[{seconds:7.1f} s] {line}\n")
        return len(text)


def profile(case: str, max_effects: int = 3, mesh_check: bool = True,
            one_fit: bool = False, window="auto") -> dict:
    source = CASES[case]
    data = stored(source) if isinstance(source, Path) else probed_block(**source)
    start = block_model().tied("global")
    experiment = block_experiment(data, start.mesh)
    began = time.perf_counter()
    stamped = _Stamped(began)
    with contextlib.redirect_stderr(stamped):
        result = diagnose(start, experiment, progress=True, max_effects=max_effects,
                          mesh_check=mesh_check, window=window)
    total = time.perf_counter() - began
    phases, last = [], 0.0
    for seconds, line in stamped.lines:
        phases.append({"until": line.removeprefix("diagnose: ")[:110],
                       "seconds": round(seconds - last, 1)})
        last = seconds
    phases.append({"until": "the answer", "seconds": round(total - last, 1)})
    # the first fit: the phase that ends with it (a window's line may come first)
    first_fit = next((p["seconds"] for p in phases
                      if p["until"].startswith("fitted the model as it is")), phases[0]["seconds"])
    named = next((seconds for seconds, line in stamped.lines
                  if line.startswith(("diagnose: found", "diagnose: none"))), total)
    extra = {}
    if one_fit:             # the same model fitted as `neurofuzzy fit` would, nothing else
        began = time.perf_counter()
        GradientLearner(substeps="auto", mesh_check=False).fit(start, experiment)
        extra["one_fit"] = round(time.perf_counter() - began, 1)
        extra["fits_of_one_fit"] = round(total / extra["one_fit"], 2)
    return {**extra, "case": case, "max_effects": max_effects, "mesh_check": mesh_check,
            "window": result.window,
            "first_answer": round(named, 1), "elements": start.mesh.n_tetrahedra,
            "nodes": start.n_nodes,
            "frames": experiment.n_frames, "answer": result.names,
            "expected": EXPECTED[case], "right": result.names[:1] == EXPECTED[case][:1],
            "verdict": result.verdict, "seconds": round(total, 1),
            "first_fit": first_fit, "fits": round(total / max(first_fit, 1e-9), 2),
            "phases": phases}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    parser.add_argument("--max-effects", type=int, default=3,
                        help="as diagnose's (default 3); 1: until the first effect is named")
    parser.add_argument("--no-mesh-check", action="store_true",
                        help="leave out the refit on the refined mesh (16 fits' work)")
    parser.add_argument("--one-fit", action="store_true",
                        help="also time one default fit of the model (the yardstick)")
    parser.add_argument("--window", default="auto",
                        help="as diagnose's: auto (default), all, or frames of motion")
    args = parser.parse_args(argv)
    results = []
    for case in args.cases:
        result = profile(case, args.max_effects, not args.no_mesh_check, args.one_fit,
                         args.window)
        results.append(result)
        print(f"\n{case}: {result['nodes']} nodes, {result['elements']} tetrahedra, "
              f"{result['frames']} frames -> {', '.join(result['answer'])} "
              f"({'right' if result['right'] else 'expected ' + result['expected'][0]}) in "
              f"{result['seconds']:.0f} s, {result['fits']:.1f} times its first fit; the "
              f"first answer after {result['first_answer']:.0f} s" + (
                  f"; one default fit {result['one_fit']:.0f} s, the diagnosis "
                  f"{result['fits_of_one_fit']:.1f} of them" if args.one_fit else ""))
        for phase in result["phases"]:
            print(f"  {phase['seconds']:7.1f} s  until: {phase['until']}")
    path = Path(__file__).with_suffix(".json")
    kept = json.loads(path.read_text()) if path.exists() else []
    kept = [r for r in kept if isinstance(r, dict) and (
        r.get("case"), r.get("max_effects", 3), r.get("mesh_check", True))
        not in {(c, args.max_effects, not args.no_mesh_check) for c in args.cases}]
    path.write_text(json.dumps(kept + results, indent=1) + "\n")
    print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
