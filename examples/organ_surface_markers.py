"""From an organ mesh and surface markers to a fitted model, end to end.

The object: a kidney-shaped closed surface (generated with trimesh, no download) becomes a
volumetric spring network. Its "true" tissue is fibrotic liver (the rule base's words
"hard, elastic"); a probe pushes a patch of its top with a force ramped to 1 N in 50 ms and
held; the bottom rests on a table (fixed). The "measurement" is continuous physics (RK4, 8
substeps per frame, another integrator than the learner's) recorded at 1 kHz by optical markers
on the surface nodes only, with 20 µm noise: a marker CSV in millimetres and a probe-force CSV.

The fit: the expert's first guess is healthy liver ("firm"); the files are imported as a
mocap user would (markers matched to the nearest nodes, inner nodes unobserved), the gradient
learner refines the start values from the surface alone, and the report maps the result back
to words, with ParaView files of simulation and measurement.

Run:  python examples/organ_surface_markers.py [OUT_DIR] [--quick] [--tetra]
(--quick: a coarser network and a shorter recording; --tetra: tetrahedra from tetgen instead
of the voxel lattice.) Writes OUT_DIR/organ.stl, markers.csv, forces.csv, experiment.npz,
fitted.yaml, report.html (+ .json) and paraview/ (organ.pvd, organ.xdmf).

The same with the command line, on the files this script writes:

    neurofuzzy mesh OUT/organ.stl --elements springs --pitch 0.01 --fix-bottom --rules liver \\
        --tissue liver --out organ.yaml
    neurofuzzy import OUT/markers.csv --topology organ.yaml --forces OUT/forces.csv \\
        --out trial.npz
    neurofuzzy fit trial.npz --start organ.yaml --rules liver --out fitted.yaml \\
        --report fit.html --export paraview
"""

import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from neurofuzzy.export import export_paraview
from neurofuzzy.io import save_experiment, save_model
from neurofuzzy.markers import markers_to_experiment, read_markers, write_node_forces
from neurofuzzy.mesh import read_mesh, surface_nodes
from neurofuzzy.pipeline import fit
from neurofuzzy.validation.integrators import reference_simulate
from neurofuzzy.report import fit_report
from neurofuzzy.rules import load_rules, shipped
from neurofuzzy.tissues import initialize

CAPTURE_STEP = 1e-3          # s (a 1 kHz optical system)
MARKER_NOISE = 2e-5          # m
PROBE_FORCE = 1.0            # N, spread over the probe's nodes
RAMP = 0.05                  # s


def organ_surface() -> trimesh.Trimesh:
    """A kidney-like closed surface, 10 x 5.3 x 7 cm, with an indentation (the hilum)."""
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    vertices = sphere.vertices * [0.05, 0.03, 0.035]
    # push the y > 0 side in around x = 0; the weight grows smoothly from the far side, so
    # the surface never folds through itself
    weight = ((vertices[:, 1] / 0.03 + 1.0) / 2.0) ** 2
    vertices[:, 1] -= 0.012 * weight * np.exp(-(vertices[:, 0] / 0.02) ** 2)
    return trimesh.Trimesh(vertices, sphere.faces)


def write_markers(path, positions, nodes, rng):
    """The recording as a mocap CSV (mm), one row per marker and frame."""
    noisy = positions[:, nodes] + rng.normal(0.0, MARKER_NOISE, positions[:, nodes].shape)
    noisy[0] = positions[0, nodes]                   # the organ is at rest at frame 0
    times = np.repeat(np.arange(len(positions)) * CAPTURE_STEP, len(nodes))
    names = np.tile([f"marker{n}" for n in nodes], len(positions))
    rows = [f"{t:.4f},{name},{x:.4f},{y:.4f},{z:.4f}" for t, name, (x, y, z)
            in zip(times, names, 1e3 * noisy.reshape(-1, 3))]
    Path(path).write_text("# units: mm\ntime,marker,x,y,z\n" + "\n".join(rows) + "\n")


def write_forces(path, probe, n_frames, mesh):
    """The probe's force log: one row per node while the force ramps up, then it holds. The
    file names the mesh its node numbers belong to (a '# mesh:' line), so that it is refused
    on another one."""
    ramp_frames = int(round(RAMP / CAPTURE_STEP))
    rows = []
    for t in range(min(ramp_frames, n_frames) + 1):
        fz = -PROBE_FORCE / len(probe) * min(t / ramp_frames, 1.0)
        rows += [(t * CAPTURE_STEP, node, 0.0, 0.0, fz) for node in probe]
    write_node_forces(path, rows, mesh)


def main(argv):
    started = time.perf_counter()
    quick = "--quick" in argv
    method = "tetra" if "--tetra" in argv else "voxel"
    paths = [a for a in argv if not a.startswith("--")]
    out = Path(paths[0] if paths else "organ-surface-markers-output")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(2026)

    # 1. the organ mesh -> a spring network resting on a table
    organ_surface().export(out / "organ.stl")
    size = 0.014 if quick else 0.01
    read = read_mesh(out / "organ.stl", pitch=size if method == "voxel" else None,
                     max_edge=2 * size if method == "tetra" else None, method=method)
    z = read.mesh.rest_positions[:, 2]
    mesh = read.mesh.with_fixed(where=lambda p: z <= z.min() + 0.4 * size)
    surface = surface_nodes(mesh)
    print(f"organ: {mesh.n_nodes} nodes ({surface.sum()} on the surface, {len(mesh.fixed)} "
          f"fixed), {mesh.n_springs} springs ({method})")

    # 2. words -> start model; the hidden truth is another tissue of the same rule base
    rules = load_rules(shipped("liver"))
    truth = initialize(rules, mesh, "fibrotic_liver", elements=False)
    start = initialize(rules, mesh, "liver", elements=False)

    # 3. the measurement: a probe pushes the top; markers on the surface only
    n_frames = 151 if quick else 301
    top = np.flatnonzero(surface & (mesh.rest_positions[:, 2] > z.max() - 0.6 * size))
    centre = mesh.rest_positions[top, :2].mean(axis=0)
    probe = top[np.argsort(np.linalg.norm(mesh.rest_positions[top, :2] - centre, axis=1))[:5]]
    write_forces(out / "forces.csv", probe, n_frames, mesh)
    ramp = np.clip(np.arange(n_frames) * CAPTURE_STEP / RAMP, 0.0, 1.0)
    loads = np.zeros((n_frames, mesh.n_nodes, 3))
    loads[:, probe, 2] = -PROBE_FORCE / len(probe) * ramp[:, None]
    motion = reference_simulate(truth, dt=CAPTURE_STEP, n_frames=n_frames,
                                external_forces=loads, method="rk4", substeps=8).positions
    markers_on = np.flatnonzero(surface)
    write_markers(out / "markers.csv", motion, markers_on, rng)
    print(f"recording: {len(markers_on)} surface markers, {n_frames} frames at "
          f"{1 / CAPTURE_STEP:.0f} Hz, noise {MARKER_NOISE * 1e6:.0f} µm; probe on nodes "
          f"{probe.tolist()}, peak displacement {1e3 * np.abs(motion - motion[0]).max():.2f} mm")

    # 4. import the files as a mocap user would
    imported = markers_to_experiment(read_markers(out / "markers.csv"), mesh,
                                     forces=out / "forces.csv", node_mass=start.node_mass)
    experiment, summary = imported.experiment, imported.summary
    save_experiment(experiment, out / "experiment.npz")
    print(f"imported: {summary['markers']} markers -> nodes, {summary['frames']} frames, "
          f"{100 * summary['gaps']:.1f} % gaps; inner nodes unobserved: "
          f"{int((~experiment.observed).sum())}")

    # 5. fit from the surface alone
    # the one fit pipeline of the command line and fit-many: start, learner, outcome check
    outcome = fit(experiment, start=start, rules=rules, progress=True)
    learner = outcome.learner
    fitted = learner.model_
    save_model(fitted, out / "fitted.yaml")
    files = {"fitted model": out / "fitted.yaml"}
    exported = export_paraview(out / "paraview", fitted, experiment,
                               substeps=learner.substeps_, stem="organ", every=5)
    files.update({"ParaView series (.pvd)": exported["pvd"],
                  "ParaView time series (.xdmf)": exported["xdmf"]})
    fit_report(outcome, out / "report.html", files=files,
               title="neurofuzzy: organ from surface markers")

    print(f"\n{'':<22}{'start (liver)':>14}{'fitted':>12}{'truth':>12}{'error':>9}")
    for name, values in (("stiffness", lambda m: m.springs.stiffness),
                         ("viscosity", lambda m: m.springs.damping)):
        for group, true in truth.group_values(values(truth)).items():
            first = start.group_values(values(start))[group]
            got = fitted.group_values(values(fitted))[group]
            print(f"{name + ' ' + group:<22}{first:>14.4g}{got:>12.4g}{true:>12.4g}"
                  f"{100 * abs(got / true - 1):>8.2f}%")
    print(f"RMS marker error {1e6 * learner.rms_error_initial_:.0f} µm -> "
          f"{1e6 * learner.rms_error_:.1f} µm (noise {MARKER_NOISE * 1e6:.0f} µm per "
          f"coordinate, {MARKER_NOISE * 1e6 * np.sqrt(3):.1f} µm per marker); "
          f"{learner.n_cycles_} simulations, substeps {learner.substeps_}")
    print(f"wrote {out}/: organ.stl, markers.csv, forces.csv, experiment.npz, fitted.yaml, "
          f"report.html, paraview/ ({time.perf_counter() - started:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
