"""A liver with a tumour: from a volume mesh with two regions to learned values and words per
region, starting from the model file that ``neurofuzzy mesh --region`` writes.

The object: the kidney-shaped organ of ``organ_surface_markers.py``, tetrahedralised (TetGen,
``pip install 'neurofuzzy[tetra]'``) and written as a Gmsh volume mesh with two physical
regions, ``organ`` and a ``tumour`` of 1.6 cm radius just under the top surface. The expert
describes the organ as healthy liver ("firm") with a tumour ("stony"); the hidden truth is
fibrotic liver ("hard") around the same tumour. A probe pushes the top above the tumour; optical
markers on the surface only, 20 µm noise, 1 kHz; RK4 data (another integrator than the
learner's).

The fit starts from the model file (regions, tissues, masses, tie groups within each region),
learns each region's values, and says per region in words what changed: the organ from firm to
hard, the tumour still stony.

Run:  python examples/organ_with_tumour.py [OUT_DIR] [--quick]
Writes OUT_DIR/organ.msh, organ.yaml, markers.csv, forces.csv, experiment.npz, fitted.yaml and
report.html (+ .json), and prints the same path as commands (mesh -> import -> fit --start).
"""

import sys
import time
from pathlib import Path

import meshio
import numpy as np
from organ_surface_markers import (CAPTURE_STEP, MARKER_NOISE, PROBE_FORCE, RAMP,
                                   organ_surface, write_forces, write_markers)

import neurofuzzy as nf
from neurofuzzy.extras import require_in_script

TUMOUR_RADIUS = 0.016        # m


def write_organ_volume(path, max_edge: float):
    """The organ tetrahedralised, with a physical region 'tumour' under the top surface."""
    mesh = nf.from_surface_tetra(organ_surface(), max_edge=max_edge)
    points = mesh.rest_positions
    centre = np.array([0.0, -0.005, points[:, 2].max() - TUMOUR_RADIUS])
    inside = np.linalg.norm(points[mesh.tetrahedra].mean(axis=1) - centre, axis=1)
    region = np.where(inside < TUMOUR_RADIUS, 2, 1)
    meshio.write(path, meshio.Mesh(points, [("tetra", mesh.tetrahedra)],
                                   cell_data={"gmsh:physical": [region],
                                              "gmsh:geometrical": [region]},
                                   field_data={"organ": np.array([1, 3]),
                                               "tumour": np.array([2, 3])}),
                 file_format="gmsh22", binary=False)
    return centre


def main(argv):
    require_in_script("tetra", "examples/organ_with_tumour.py (TetGen meshes the organ)")
    started = time.perf_counter()
    quick = "--quick" in argv
    paths = [a for a in argv if not a.startswith("--")]
    out = Path(paths[0] if paths else "organ-with-tumour-output")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(2027)
    rules = nf.load_rules(nf.shipped_rules("liver"))

    # 1. the volume mesh with its regions, and the model file `neurofuzzy mesh` writes
    size = 0.014 if quick else 0.01
    tumour_centre = write_organ_volume(out / "organ.msh", max_edge=2 * size)
    read = nf.read_mesh(out / "organ.msh")
    z = read.mesh.rest_positions[:, 2]
    fix_below = float(z.min() + 0.4 * size)
    mesh = read.mesh.with_fixed(where=lambda p: p[:, 2] <= fix_below)
    expert = read.tissue_regions({"organ": "liver", "tumour": "tumour"}, of="tetrahedra")
    nf.save_model(nf.initialize(rules, mesh, tetrahedron_regions=expert,
                                elements=False), out / "organ.yaml")
    print(f"organ: {mesh.n_nodes} nodes ({len(mesh.fixed)} fixed), {mesh.n_springs} springs, "
          f"{int(read.tetrahedron_regions['tumour'].sum())} of {mesh.n_tetrahedra} tetrahedra "
          "in the tumour")

    # 2. the hidden truth: fibrotic liver around the same tumour
    hidden = read.tissue_regions({"organ": "fibrotic_liver", "tumour": "tumour"},
                                 of="tetrahedra")
    truth = nf.initialize(rules, mesh, tetrahedron_regions=hidden, elements=False)

    # 3. the recording: a probe on the top above the tumour, markers on the surface
    n_frames = 151 if quick else 301
    surface = nf.surface_nodes(mesh)
    top = np.flatnonzero(surface & (z > z.max() - 0.6 * size))
    distance = np.linalg.norm(mesh.rest_positions[top, :2] - tumour_centre[:2], axis=1)
    probe = top[np.argsort(distance)[:3]]
    write_forces(out / "forces.csv", probe, n_frames, mesh)
    ramp = np.clip(np.arange(n_frames) * CAPTURE_STEP / RAMP, 0.0, 1.0)
    loads = np.zeros((n_frames, mesh.n_nodes, 3))
    loads[:, probe, 2] = -PROBE_FORCE / len(probe) * ramp[:, None]
    motion = nf.reference_simulate(truth, dt=CAPTURE_STEP, n_frames=n_frames,
                                   external_forces=loads, method="rk4", substeps=8).positions
    write_markers(out / "markers.csv", motion, np.flatnonzero(surface), rng)

    # 4. import, and fit from the model file
    model = nf.load_model(out / "organ.yaml")
    imported = nf.markers_to_experiment(nf.read_markers(out / "markers.csv"), model.mesh,
                                        forces=out / "forces.csv", node_mass=model.node_mass)
    experiment = imported.experiment
    nf.save_experiment(experiment, out / "experiment.npz")
    # the one fit pipeline of the command line and fit-many: start, learner, outcome check
    outcome = nf.fit(experiment, start=out / "organ.yaml", rules=rules, progress=True)
    start, learner = outcome.start, outcome.learner
    nf.save_model(learner.model_, out / "fitted.yaml")
    nf.fit_report(outcome, out / "report.html", title="neurofuzzy: a liver with a tumour",
                  files={"fitted model": out / "fitted.yaml"})

    before = nf.materials(start.model, rules)
    after = nf.materials(learner.model_, rules)
    true = nf.materials(truth, rules)
    print(f"\n{'region':<8}{'E start':>10}{'E fitted':>10}{'E truth':>10}{'error':>8}   words")
    for region, true_region in (("liver", "fibrotic_liver"), ("tumour", "tumour")):
        b, a, t = before[region], after[region], true[true_region]
        error = abs(a["youngs_modulus"] / t["youngs_modulus"] - 1)
        print(f"{region:<8}{b['youngs_modulus']:>10.4g}{a['youngs_modulus']:>10.4g}"
              f"{t['youngs_modulus']:>10.4g}{100 * error:>7.2f}%   "
              f"{b['labels']['youngs_modulus']} -> {a['labels']['youngs_modulus']} "
              f"(truth {t['labels']['youngs_modulus']})")
    print(f"RMS marker error {1e6 * learner.rms_error_initial_:.0f} µm -> "
          f"{1e6 * learner.rms_error_:.1f} µm (noise {MARKER_NOISE * 1e6 * np.sqrt(3):.1f} µm "
          f"per marker); {learner.n_cycles_} simulations")
    print(f"\nthe same with the command line (in {out}/):\n"
          f"  neurofuzzy mesh organ.msh --elements springs --rules liver --region organ=liver "
          f"--region tumour=tumour --fix-below {fix_below:.4f} --out organ.yaml\n"
          "  neurofuzzy import markers.csv --topology organ.yaml --forces forces.csv "
          "--out trial.npz\n"
          "  neurofuzzy fit trial.npz --start organ.yaml --rules liver --json --report fit.html")
    print(f"wrote {out}/ ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
