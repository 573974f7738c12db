"""Find the missing effect, end to end on the paper's cube.

The "measurement": the cube, pushed at its top centre, has a stiff inclusion around its centre
node (a tumour in soft tissue) and hangs under gravity; markers carry 0.2 % noise. Our model
knows neither. The diagnosis fits the model, finds where simulation and measurement disagree,
names the missing effects one after the other, adds them, refits and shows the gap shrink.

Run:  python examples/find_missing_effect.py [OUT_DIR] [--quick]
(--quick: one hidden effect, no noise.) Writes OUT_DIR/diagnosis.html and diagnosis.json.
"""

import sys
from pathlib import Path

from neurofuzzy.datasets import CUBE, paper_cube_experiment, paper_cube_model
from neurofuzzy.diagnosis import diagnose
from neurofuzzy.effects import Gravity, StiffInclusion
from neurofuzzy.report import diagnosis_report


def main(argv):
    quick = "--quick" in argv
    paths = [a for a in argv if not a.startswith("--")]
    out = Path(paths[0] if paths else "find-missing-effect-output")
    truth = paper_cube_model(stiffness={"edge": 60.0, "diagonal": 35.0})
    centre = [j for j in range(truth.n_springs) if 13 in truth.mesh.springs[j]]
    hidden = [StiffInclusion.for_model(truth, [120.0, 70.0], springs=centre)]
    if not quick:
        hidden.append(Gravity([0.0, 0.0, -9.81]))
    noise = 0.0 if quick else 0.002 * CUBE["edge_length"]
    data = paper_cube_experiment(truth.with_effects(*hidden), noise=noise, seed=1)
    print("hidden in the data:", ", ".join(e.name for e in hidden),
          f"(marker noise {noise * 1e6:.0f} µm)")

    start = paper_cube_model(stiffness=50.0, damping=0.03, tie="groups")
    result = diagnose(start, data, progress=True)

    print(f"\n{'effect':<22}{'confidence':>11}{'runner-up':>18}{'RMS before':>13}"
          f"{'RMS after':>12}  where")
    for finding in result.effects:
        where = f"{len(finding.springs)} springs" if finding.springs else (
            f"node {finding.nodes}" if finding.nodes else "everywhere")
        print(f"{finding.name:<22}{finding.confidence:>11.3f}{finding.runner_up:>18}"
              f"{finding.rms_before:>13.3g}{finding.rms_after:>12.3g}  {where}")
    if not result.effects:
        print("none")
    found = next((f for f in result.effects if f.springs), None)
    if found:
        common = len(set(found.springs) & set(centre))
        print(f"\ninclusion: {common} of the {len(centre)} true springs found, "
              f"{len(found.springs) - common} others")
    out.mkdir(parents=True, exist_ok=True)
    diagnosis_report(result, out / "diagnosis.html")
    print(f"wrote {out / 'diagnosis.html'} and {out / 'diagnosis.json'}")


if __name__ == "__main__":
    main(sys.argv[1:])
