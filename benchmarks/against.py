"""Speed against another commit, side by side in one run: ``benchmarks/run.py`` on this
checkout and on REF (checked out into a temporary git worktree), one after the other on the
same machine (alternately, ``--repeat`` times each, every timing at its best), and the ratio
of every timing both report.

    python benchmarks/against.py REF            # e.g. a tag or the commit before a change
    python benchmarks/against.py REF --quick    # run.py --quick on both (a few minutes)

Prints one line per measure (this checkout, REF, the ratio, faster/slower) and writes
``benchmarks/against.json``. A measure counts as a rate when its name says steps per second
(higher is better); every other timing is a duration (lower is better). Exits 1 when any
measure is more than ``--tolerance`` (default 10 %) worse than on REF.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RATES = ("steps_per_s",)


def _leaves(value, prefix=""):
    """Flatten run.py's JSON to ``{"a.b.c": number}``."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from _leaves(item, f"{prefix}.{key}" if prefix else str(key))
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield prefix, float(value)


def _kind(name: str) -> str | None:
    """``"rate"``, ``"duration"`` or None (not a timing) for a flattened key."""
    parts = name.split(".")
    if any(rate in name for rate in RATES):
        return "rate"
    if name == "seconds" or any(word in name for word in ("speedup", "ratio", "error")):
        return None             # the run's own wall time; ratios and errors are not timings
    if any("seconds" in part or part.endswith("_s") or "us" in part.split("_")
           for part in parts):
        return "duration"
    if parts[0] == "large_elements_gradient" and parts[-1] in ("numba", "numpy"):
        return "duration"       # one gradient's seconds per backend
    return None


def _run(checkout: Path, quick: bool, out: Path) -> dict:
    command = [sys.executable, str(checkout / "benchmarks" / "run.py"), "--out", str(out)]
    command += ["--quick"] if quick else []
    environment = {**os.environ, "PYTHONPATH": str(checkout)}
    print(f"running {' '.join(command)} (neurofuzzy from {checkout})", file=sys.stderr,
          flush=True)
    subprocess.run(command, check=True, env=environment, cwd=checkout)
    return json.loads(out.read_text())


def _best(runs: list[dict]) -> dict[str, float]:
    """Every timing at its best over repeated runs (the first run of a fresh checkout also
    compiles numba's kernels into its cache)."""
    best = {}
    for run in runs:
        for name, value in _leaves(run):
            kind = _kind(name)
            if name not in best or kind is None:
                best[name] = value
            elif kind == "rate":
                best[name] = max(best[name], value)
            else:
                best[name] = min(best[name], value)
    return best


def compare(ours: list[dict], theirs: list[dict], tolerance: float) -> list[dict]:
    """One row per timing both runs report: values, the speed-up (>1 is faster here)."""
    a, b = _best(ours), _best(theirs)
    rows = []
    for name in sorted(a.keys() & b.keys()):
        kind = _kind(name)
        if kind is None or a[name] <= 0 or b[name] <= 0:
            continue
        speedup = a[name] / b[name] if kind == "rate" else b[name] / a[name]
        rows.append({"measure": name, "kind": kind, "here": a[name], "ref": b[name],
                     "speedup": speedup, "worse": speedup < 1 - tolerance})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("ref", help="the commit to compare with (anything git checkout takes)")
    parser.add_argument("--quick", action="store_true", help="run.py --quick on both")
    parser.add_argument("--tolerance", type=float, default=0.10,
                        help="how much slower a measure may be before it counts as worse "
                             "(default 0.10)")
    parser.add_argument("--repeat", type=int, default=2,
                        help="runs of each checkout, alternately; every timing at its best "
                             "(default 2: the first run of a fresh checkout compiles numba)")
    parser.add_argument("--out", default=str(HERE / "against.json"))
    args = parser.parse_args(argv)
    # a stopped run still removes its worktree (the finally below runs on SystemExit)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    with tempfile.TemporaryDirectory() as folder:
        reference = Path(folder) / "ref"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(reference),
                        args.ref], check=True, capture_output=True)
        try:
            ours, theirs = [], []
            for round_ in range(args.repeat):      # alternately, so both see the same load
                theirs.append(_run(reference, args.quick, Path(folder) / f"ref{round_}.json"))
                ours.append(_run(ROOT, args.quick, Path(folder) / f"here{round_}.json"))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force",
                            str(reference)], check=False, capture_output=True)
    rows = compare(ours, theirs, args.tolerance)
    print(f"\n{'measure':<64} {'here':>11} {'ref':>11} {'speed-up':>9}")
    for row in rows:
        flag = "  SLOWER" if row["worse"] else ""
        print(f"{row['measure']:<64} {row['here']:>11.4g} {row['ref']:>11.4g} "
              f"{row['speedup']:>8.2f}x{flag}")
    Path(args.out).write_text(json.dumps({"ref": args.ref, "quick": args.quick,
                                          "rows": rows}, indent=1))
    worse = [row["measure"] for row in rows if row["worse"]]
    print(f"\n{len(rows)} measures, {len(worse)} more than {args.tolerance:.0%} slower"
          + (f": {', '.join(worse)}" if worse else ""))
    return 1 if worse else 0


if __name__ == "__main__":
    sys.exit(main())
