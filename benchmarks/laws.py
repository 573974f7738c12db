"""What St. Venant–Kirchhoff, neo-Hookean and Yeoh elements recover from data of a solver
nobody here wrote: sfepy's total-Lagrangian neo-Hookean block (quadratic tetrahedra on 5 mm
Kuhn cells, Newmark, 20 µm marker noise; ``neurofuzzy.validation.nonlinear``), probed to 27–35 %
compression (large strain) and to 4–5 % (small strain), and its uncoupled Yeoh block (C20 =
C10, the same small-strain E and ν) probed by the same 0.7 N ("stiffening"), replayed from
``tests/data`` and fitted on the meshes a user builds from the block's surface (voxels split
six to a cube, TetGen), none of them the reference's own. Also the diagnosis of the SVK start
on each dataset.

    python benchmarks/laws.py [--meshes "vox 7.5 mm" "vox 5 mm" ...] [--data stiffening]
                              [--laws yeoh ...] [--no-diagnosis]
                              [--diagnosis-mesh "vox 3.3 mm"] [--mesh-check]
                              [--confirm-mesh "vox 1.7 mm"]

Prints a table and writes ``benchmarks/laws.json``: per dataset, mesh and law the errors of E,
ν, η, the shear modulus μ and the bulk modulus K against the truth (and Yeoh's fitted
C20/C10), the RMS marker error as a multiple of the noise, and the seconds; per dataset the
diagnosis' answer. A run of some datasets, meshes or laws replaces their rows in an existing
file and keeps the others.
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
from neurofuzzy.effects import EFFECTS  # noqa: E402
from neurofuzzy.experiment import duration  # noqa: E402
from neurofuzzy.learn import GradientLearner  # noqa: E402
from neurofuzzy.validation.nonlinear.recordings import stored  # noqa: E402
from neurofuzzy.validation.probed_block import block_experiment, block_model  # noqa: E402

DATA = {"large strain": ROOT / "tests" / "data" / "neo_hookean_block_large_strain.npz",
        "small strain": ROOT / "tests" / "data" / "neo_hookean_block_small_strain.npz",
        "stiffening": ROOT / "tests" / "data" / "stiffening_block.npz"}
MESHES = {"vox 7.5 mm": {"pitch": 0.0075}, "vox 5 mm": {"pitch": 0.005},
          "TetGen 8 mm": {"tetgen": True, "max_edge": 0.008},
          "vox 3.3 mm": {"pitch": 0.01 / 3}, "vox 2.5 mm": {"pitch": 0.0025},
          "vox 1.7 mm": {"pitch": 0.01 / 6},
          # Kuhn cells of 2.5 / 1.7 mm under the probe, widening to 3.7-5 mm elsewhere
          "graded 2.5 mm": {"graded": 0.0025}, "graded 1.7 mm": {"graded": 0.01 / 6}}
#: the meshes of a default run (vox 2.5 mm, 18,432 tetrahedra, takes 10 minutes a fit)
DEFAULT_MESHES = ("vox 7.5 mm", "vox 5 mm", "TetGen 8 mm", "vox 3.3 mm")
LAWS = ("st-venant-kirchhoff", "neo-hookean", "yeoh")


def fit(recording, mesh: str, law: str) -> dict:
    """A global fit (one E, ν, η) of the block with ``law`` on ``mesh``."""
    start = block_model(**MESHES[mesh]).tied("global").with_elements(law=law)
    experiment = block_experiment(recording, start.mesh)
    began = time.perf_counter()
    fitted = GradientLearner(substeps="auto").fit(start, experiment)
    model, truth = fitted.model_, recording.truth
    E, nu, eta = (float(model.elements.youngs_modulus[0]), float(model.elements.poisson_ratio[0]),
                  float(model.elements.viscosity[0]))
    mu, bulk = E / (2 * (1 + nu)), E / (3 * (1 - 2 * nu))
    return {"youngs_modulus": E / truth["youngs_modulus"] - 1,
            "poisson_ratio": nu - truth["poisson_ratio"], "viscosity": eta / truth["viscosity"] - 1,
            "shear_modulus": mu / truth["shear_modulus"] - 1,
            "bulk_modulus": bulk / truth["bulk_modulus"] - 1,
            "stiffening": (float(model.elements.stiffening[0]) if law == "yeoh" else None),
            "stiffening_truth": (truth["c20"] / truth["c10"] if truth.get("c10") else 0.0),
            "ratio": fitted.lack_of_fit_.ratio, "explained": fitted.lack_of_fit_.explained,
            "seconds": time.perf_counter() - began}


def diagnosis(recording, mesh: str, mesh_check: bool = False,
              confirm_mesh: str | None = None) -> dict:
    """The diagnosis of the SVK start on ``mesh``; with ``mesh_check`` its final model is
    also refitted on the mesh refined once (how much of what is left is the mesh's), with
    ``confirm_mesh`` the material it switched to is fitted from the start on that mesh
    (where the mesh's own error is below the noise)."""
    start = block_model(**MESHES[mesh]).tied("global")
    experiment = block_experiment(recording, start.mesh)
    began = time.perf_counter()
    result = diagnose(start, experiment, mesh_check=mesh_check)
    refined = result.mesh or {}
    found = {"answer": result.names, "law": result.model_.elements.law_names(),
             "ratio_before": result.rms_before / result.noise_rms,
             "ratio_after": result.rms_after / result.noise_rms,
             "refined_elements": refined.get("elements"), "ratio_refined": refined.get("ratio"),
             "seconds": time.perf_counter() - began}
    if confirm_mesh is not None:
        found.update(confirm(recording, confirm_mesh, result))
    return found


def confirm(recording, mesh: str, result) -> dict:
    """The start on ``mesh`` switched as the diagnosis ``result`` switched its model (every
    finding that changes the material: a law, relaxation), fitted."""
    model = block_model(**MESHES[mesh]).tied("global")
    experiment = block_experiment(recording, model.mesh)
    for finding in result.effects:
        kind = EFFECTS[finding.name]
        if kind.switches_material:
            model = kind.switch(model, duration([experiment]))
    began = time.perf_counter()
    fitted = GradientLearner(substeps="auto").fit(model, experiment)
    return {"confirm_mesh": mesh, "confirm_elements": model.mesh.n_tetrahedra,
            "confirm_law": fitted.model_.elements.law_names(),
            "ratio_confirmed": fitted.lack_of_fit_.ratio,
            "confirm_explained": fitted.lack_of_fit_.explained,
            "confirm_seconds": time.perf_counter() - began}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=list(DEFAULT_MESHES),
                        choices=list(MESHES))
    parser.add_argument("--laws", nargs="+", default=list(LAWS), choices=list(LAWS))
    parser.add_argument("--data", nargs="+", default=list(DATA), choices=list(DATA))
    parser.add_argument("--diagnosis-mesh", default="vox 7.5 mm", choices=list(MESHES))
    parser.add_argument("--no-diagnosis", action="store_true")
    parser.add_argument("--mesh-check", action="store_true",
                        help="refit the diagnosis' final model on its mesh refined once")
    parser.add_argument("--confirm-mesh", choices=list(MESHES),
                        help="fit the material the diagnosis switched to on this mesh")
    parser.add_argument("--out", default=str(Path(__file__).with_name("laws.json")))
    args = parser.parse_args(argv)
    out = Path(args.out)
    results = (json.loads(out.read_text()) if out.exists()
               else {"fits": [], "diagnosis": {}})
    print(f"{'data':<13}{'mesh':<13}{'law':<21}{'E':>8}{'ν':>8}{'μ':>8}{'K':>8}{'η':>8}"
          f"{'C20/C10':>9}{'RMS/noise':>11}{'s':>6}")
    for name in args.data:
        recording = stored(DATA[name])
        for mesh in args.meshes:
            for law in args.laws:
                row = {"data": name, "mesh": mesh, "law": law, **fit(recording, mesh, law)}
                results["fits"] = [old for old in results["fits"]
                                   if (old["data"], old["mesh"], old["law"]) != (name, mesh, law)]
                results["fits"].append(row)
                c = "" if row["stiffening"] is None else f"{row['stiffening']:.2f}"
                print(f"{name:<13}{mesh:<13}{law:<21}{row['youngs_modulus']:>+8.1%}"
                      f"{row['poisson_ratio']:>+8.3f}{row['shear_modulus']:>+8.1%}"
                      f"{row['bulk_modulus']:>+8.0%}{row['viscosity']:>+8.0%}{c:>9}"
                      f"{row['ratio']:>10.2f}x{row['seconds']:>6.0f}", flush=True)
        if not args.no_diagnosis:
            found = diagnosis(recording, args.diagnosis_mesh, args.mesh_check,
                              args.confirm_mesh)
            results["diagnosis"][name] = {"mesh": args.diagnosis_mesh, **found}
            refined = ("" if found["ratio_refined"] is None else
                       f" ({found['ratio_refined']:.2f}x on the mesh refined once, "
                       f"{found['refined_elements']:,} tetrahedra)")
            print(f"diagnosis of the SVK start, {name}, {args.diagnosis_mesh}: "
                  f"{', '.join(found['answer'])} ({found['law']}); RMS "
                  f"{found['ratio_before']:.2f}x -> {found['ratio_after']:.2f}x the noise"
                  f"{refined}, {found['seconds']:.0f} s", flush=True)
            if args.confirm_mesh:
                print(f"  {found['confirm_law']} fitted on {args.confirm_mesh} "
                      f"({found['confirm_elements']:,} tetrahedra): "
                      f"{found['ratio_confirmed']:.2f}x the noise"
                      f"{' (explained)' if found['confirm_explained'] else ''}, "
                      f"{found['confirm_seconds']:.0f} s", flush=True)
    out.write_text(json.dumps(results, indent=2, default=float))
    print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
