"""What the elements recover from a relaxing tissue recorded by a solver nobody here wrote: sfepy's
neo-Hookean block with one Prony term (g = 0.5 of the long-term E = 6 kPa, τ = 50 ms,
Kelvin–Voigt η = 2 Pa·s; quadratic tetrahedra on 5 mm Kuhn cells, Newmark, 20 µm marker
noise), pressed by the probe with a held 0.12 N (4 % strain) for 0.3 s, replayed from
``tests/data/relaxing_block.npz`` and fitted on voxel meshes of the block's surface (not the
reference's mesh), each law with and without a Prony term; and the diagnosis of the plain SVK
start on it, and on the small-strain neo-Hookean block, which does not relax.

    python benchmarks/relaxation.py [--meshes "vox 7.5 mm" "vox 5 mm"] [--no-diagnosis]
        [--prony-only]

Prints a table and writes ``benchmarks/relaxation.json``: per mesh, law and model the errors
of E, ν, η, g and τ against the truth, the RMS marker error as a multiple of the noise and the
seconds; per dataset the diagnosis' answer.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neurofuzzy.diagnosis import diagnose  # noqa: E402
from neurofuzzy.learn import GradientLearner  # noqa: E402
from neurofuzzy.validation.nonlinear.recordings import stored  # noqa: E402
from neurofuzzy.validation.probed_block import block_experiment, block_model  # noqa: E402

DATA = {"relaxing": ROOT / "tests" / "data" / "relaxing_block.npz",
        "small strain": ROOT / "tests" / "data" / "neo_hookean_block_small_strain.npz"}
MESHES = {"vox 7.5 mm": 0.0075, "vox 5 mm": 0.005, "vox 3.3 mm": 0.01 / 3, "vox 2.5 mm": 0.0025}
#: the meshes of a default run (the finer two take minutes to tens of minutes a fit)
DEFAULT_MESHES = ("vox 7.5 mm", "vox 5 mm")
LAWS = ("st-venant-kirchhoff", "neo-hookean")
#: the start of the Prony term (a fifth of the 0.3 s recording, as ``--relaxation 1``)
START = (0.5, 0.06)


def fit(recording, mesh: str, law: str, relaxing: bool) -> dict:
    """A global fit (one E, ν, η and, when ``relaxing``, g and τ) of the block."""
    start = block_model(pitch=MESHES[mesh]).tied("global").with_elements(law=law)
    if relaxing:
        start = start.with_elements(relaxation_moduli=[START[0]],
                                    relaxation_times=[START[1]])
    experiment = block_experiment(recording, start.mesh)
    began = time.perf_counter()
    fitted = GradientLearner(substeps="auto").fit(start, experiment)
    model, truth = fitted.model_, recording.truth
    row = {"youngs_modulus": float(model.elements.youngs_modulus[0]) / truth["youngs_modulus"] - 1,
           "poisson_ratio": float(model.elements.poisson_ratio[0]) - truth["poisson_ratio"],
           "viscosity": float(model.elements.viscosity[0]) / truth["viscosity"] - 1,
           "relative_modulus": None, "relaxation_time": None,
           "ratio": fitted.lack_of_fit_.ratio, "seconds": time.perf_counter() - began}
    if relaxing:
        prony = truth["prony"]
        row["relative_modulus"] = (float(model.elements.relaxation_moduli[0, 0])
                                   - prony["relative_moduli"][0])
        row["relaxation_time"] = (float(model.elements.relaxation_times[0, 0])
                                  / prony["times"][0] - 1)
    return row


def diagnosis(recording, mesh: str) -> dict:
    start = block_model(pitch=MESHES[mesh]).tied("global")
    began = time.perf_counter()
    result = diagnose(start, block_experiment(recording, start.mesh), mesh_check=False)
    model = result.model_
    return {"answer": result.names, "law": model.elements.law_names(),
            "prony": [model.elements.relaxation_moduli[0].tolist(),
                      model.elements.relaxation_times[0].tolist()],
            "ratio_before": result.rms_before / result.noise_rms,
            "ratio_after": result.rms_after / result.noise_rms,
            "seconds": time.perf_counter() - began}


def _percent(value) -> str:
    return f"{value:>+8.1%}" if value is not None else f"{'':>8}"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=list(DEFAULT_MESHES),
                        choices=list(MESHES))
    parser.add_argument("--laws", nargs="+", default=list(LAWS), choices=list(LAWS))
    parser.add_argument("--diagnosis-mesh", default="vox 7.5 mm", choices=list(MESHES))
    parser.add_argument("--no-diagnosis", action="store_true")
    parser.add_argument("--prony-only", action="store_true",
                        help="fit only the models with a Prony term")
    parser.add_argument("--out", default=str(Path(__file__).with_name("relaxation.json")))
    args = parser.parse_args(argv)
    results = {"fits": [], "diagnosis": {}}
    recording = stored(DATA["relaxing"])
    print(f"{'mesh':<12}{'law':<21}{'Prony':<7}{'E':>8}{'ν':>8}{'η':>8}{'g':>8}{'τ':>8}"
          f"{'RMS/noise':>11}{'s':>6}")
    for mesh in args.meshes:
        for law in args.laws:
            for relaxing in (True,) if args.prony_only else (False, True):
                row = {"mesh": mesh, "law": law, "prony": relaxing,
                       **fit(recording, mesh, law, relaxing)}
                results["fits"].append(row)
                g = row["relative_modulus"]
                print(f"{mesh:<12}{law:<21}{'yes' if relaxing else 'no':<7}"
                      f"{row['youngs_modulus']:>+8.1%}{row['poisson_ratio']:>+8.3f}"
                      f"{row['viscosity']:>+8.0%}"
                      + (f"{g:>+8.3f}" if g is not None else f"{'':>8}")
                      + _percent(row["relaxation_time"])
                      + f"{row['ratio']:>10.2f}x{row['seconds']:>6.0f}", flush=True)
    if not args.no_diagnosis:
        for name, path in DATA.items():
            found = diagnosis(stored(path), args.diagnosis_mesh)
            results["diagnosis"][name] = {"mesh": args.diagnosis_mesh, **found}
            print(f"diagnosis of the SVK start, {name}, {args.diagnosis_mesh}: "
                  f"{', '.join(found['answer']) or 'none'} ({found['law']}; Prony "
                  f"{found['prony']}); RMS {found['ratio_before']:.2f}x -> "
                  f"{found['ratio_after']:.2f}x the noise, {found['seconds']:.0f} s",
                  flush=True)
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
