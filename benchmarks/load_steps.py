"""Compression between plates: how our elements lock (or not) as ν → 0.5 against a converged
reference nobody here wrote, what a fit from load steps recovers from that reference's data,
and how long a fit takes as the mesh grows.

    python benchmarks/load_steps.py [--cells 4 6 8] [--graded-cells 8 12] [--data-cells 6 8]
                                    [--graded-data-cells 12] [--check-cells 4 6 8]
                                    [--graded-check-cells 8] [--fit-cells 4 6 8]
                                    [--only PART ...]

Part 1, locking: a 2 cm neo-Hookean cube (E 6 kPa) on a fixed anvil, its top bonded to a
plate moved down 5, 12.5 and 18 %; the plate's force by our linear tetrahedra in the nodal
volumetric form (the default) and the element form (one volume constraint per tetrahedron)
against FElupe's (:mod:`neurofuzzy.validation.plates`: quadratic tetrahedra in the three-field
form, extrapolated from 6 and 8 cells; the recordings ``tests/data/plates_nu*.npz``), also on
blocks graded toward their faces (``kuhn_block(grading=GRADING)``: the bonded edges are
singular, and most of the linear elements' error is there). Part 2, the fit on those
recordings: 343 beads with 20 µm noise on every scan (the reference too),
embedded where the reference scan saw them, a load cell with 1 % noise or none, fitted on
Kuhn blocks of ``--data-cells`` (and graded ones of ``--graded-data-cells``), with the
reference scan taken as exact and with ``reference_noise``. Part 2b, the mesh check
(:mod:`neurofuzzy.learn.load_step_mesh_check`) of the fits with a load cell on blocks of
``--check-cells`` (and graded ``--graded-check-cells``): E and ν on the mesh, on the mesh
refined once, extrapolated, whether the intervals hold FElupe's values, and the check's
seconds beside the fit's. Part 3, speed: the seconds of
``fit_load_steps`` (three load steps, 125 markers, with and without a load cell; our own
data) on Kuhn blocks of 4³ to 8³ cells.
Prints the tables and writes ``benchmarks/load_steps.json`` (``--only`` runs the parts named;
a run replaces the rows it measures again and keeps the file's others). ``--grading`` sets
the graded blocks' grading (default 0.8).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from neurofuzzy.learn.load_step_fit import fit_load_steps  # noqa: E402
from neurofuzzy.learn.load_step_mesh_check import with_mesh_check  # noqa: E402
from neurofuzzy.load_steps import DrivenPath, LoadSteps, simulate_load_steps  # noqa: E402
from neurofuzzy.mesh import from_tetra, kuhn_block  # noqa: E402
from neurofuzzy.model import Model  # noqa: E402
from neurofuzzy.observation import EmbeddedMarkers, embed_points  # noqa: E402
from neurofuzzy.simulation.static import Driven, equilibrium  # noqa: E402

SIZE, E = 0.02, 6000.0
DATA = ROOT / "tests" / "data"
GRADING = 0.8
PARTS = ("locking", "independent", "mesh-check", "speed")
RATIOS = tuple(nu for nu in (0.45, 0.49, 0.499) if (DATA / f"plates_nu{nu}.npz").exists())


def _model(cells, nu, volumetric="nodal", law="st-venant-kirchhoff", grading=0.0):
    points, tetrahedra = kuhn_block((cells,) * 3, SIZE / cells, grading=grading)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    return Model.continuum(mesh, youngs_modulus=E, poisson_ratio=nu, viscosity=1.0,
                           density=1000.0, volumetric=volumetric, law=law)


def _top(model):
    return np.flatnonzero(np.isclose(model.mesh.rest_positions[:, 2], SIZE))


def _recording(nu):
    return np.load(DATA / f"plates_nu{nu}.npz")


def locking(cells, graded_cells=()):
    rows = []
    variants = ([("nodal", n, 0.0) for n in cells] + [("element", n, 0.0) for n in cells]
                + [("nodal", n, GRADING) for n in graded_cells])
    for nu in RATIOS:
        recorded = _recording(nu)
        reference = recorded["force"][:, 2]
        rows.append({"nu": nu, "element": "FElupe P2/P1/P1, extrapolated",
                     "force": reference.tolist(), "error": [0.0] * len(reference)})
        for volumetric, n, grading in variants:
            model = _model(n, nu, volumetric, law="neo-hookean", grading=grading)
            top = _top(model)
            forces, positions = [], None
            start = time.perf_counter()
            for strain in recorded["strains"]:
                result = equilibrium(model, driven=Driven(top, (0, 0, -strain * SIZE)),
                                     start=positions, increments=4)
                positions = result.positions
                forces.append(result.reaction_on(top)[2])
            forces = np.array(forces)
            rows.append({"nu": nu, "element": f"P1 {volumetric} {n}^3"
                         + (f" graded {grading}" if grading else ""),
                         "cells": n, "grading": grading, "force": forces.tolist(),
                         "error": (forces / reference - 1).tolist(),
                         "seconds": time.perf_counter() - start})
    return rows


def _lab_data(recorded, mesh, load_cell, seed=0):
    """The recording as a lab would have it: every scan noisy, the beads embedded where the
    reference scan saw them, the load cell's force with 1 % noise."""
    rng = np.random.default_rng(seed)
    scans = np.concatenate([recorded["beads"][None],
                            recorded["beads"] + recorded["displacements"]])
    scans = scans + rng.normal(scale=20e-6, size=scans.shape)
    nodes, weights, _ = embed_points(mesh, scans[0])
    force = recorded["force"]
    reaction = force + 0.01 * np.abs(force[:, 2:]) * rng.normal(size=force.shape)
    top = np.flatnonzero(np.isclose(mesh.rest_positions[:, 2], SIZE))
    plate = DrivenPath(top, np.array([[0, 0, -s * SIZE] for s in recorded["strains"]]))
    return LoadSteps(mesh, (plate,), EmbeddedMarkers(nodes, weights, scans),
                     reaction if load_cell else None)


def independent(cells, graded_cells=()):
    rows = []
    for nu in RATIOS:
        recorded = _recording(nu)
        for n, grading in [(n, 0.0) for n in cells] + [(n, GRADING) for n in graded_cells]:
            model = _model(n, nu, law="neo-hookean", grading=grading).with_elements(
                youngs_modulus=3000.0, poisson_ratio=0.3)
            for load_cell in (False, True):
                data = _lab_data(recorded, model.mesh, load_cell)
                for reference_noise in (False, True):
                    start = time.perf_counter()
                    fit = fit_load_steps(model, data, marker_noise=20e-6, validate_on=[3],
                                         reference_noise=reference_noise)
                    rows.append({
                        "nu": nu, "cells": n, "grading": grading, "load_cell": load_cell,
                        "reference_noise": reference_noise,
                        "seconds": time.perf_counter() - start,
                        "nu_error": fit.poisson_ratio_ - nu,
                        "E_error": None if "youngs_modulus" in fit.unidentifiable_
                        else fit.youngs_modulus_ / E - 1,
                        "fitted_x_noise": fit.marker_rms_ / fit.marker_scale,
                        "held_out_x_noise": fit.validation_["rms_error"] / fit.marker_scale})
    return rows


def mesh_checked(cells, graded_cells=()):
    """Part 2b: the fits with a load cell and their mesh check (one step)."""
    rows = []
    for nu in RATIOS:
        recorded = _recording(nu)
        for n, grading in [(n, 0.0) for n in cells] + [(n, GRADING) for n in graded_cells]:
            model = _model(n, nu, law="neo-hookean", grading=grading).with_elements(
                youngs_modulus=3000.0, poisson_ratio=0.3)
            data = _lab_data(recorded, model.mesh, True)
            start = time.perf_counter()
            fit = fit_load_steps(model, data, marker_noise=20e-6, validate_on=[3])
            fitted = time.perf_counter() - start
            checked = with_mesh_check(fit, data, validate_on=[3])
            values = checked.mesh_check_.values
            truth = {"youngs_modulus": E, "poisson_ratio": nu}
            row = {"nu": nu, "cells": n, "grading": grading,
                   "tetrahedra": model.mesh.n_tetrahedra, "fit_seconds": fitted,
                   "check_seconds": time.perf_counter() - start - fitted}
            for name, key in (("youngs_modulus", "E_check"), ("poisson_ratio", "nu_check")):
                scale = E if name == "youngs_modulus" else 1.0
                row[key] = {stage: (values[name][stage] - truth[name]) / scale
                            for stage in ("mesh", "refined", "extrapolated")}
                row[key]["noise_interval"] = 1.96 * fit.standard_errors_[name] / scale
                row[key]["interval"] = checked.interval(name) / scale
                row[key]["holds"] = bool(abs(values[name]["mesh"] - truth[name]) <= (
                    checked.interval(name)))
            rows.append(row)
    return rows


def speed(cells):
    rows = []
    strains = (0.05, 0.125, 0.18)
    for n in cells:
        truth = _model(n, 0.45, law="neo-hookean")
        beads = np.random.default_rng(1).uniform(0.1 * SIZE, 0.9 * SIZE, size=(125, 3))
        nodes, weights, _ = embed_points(truth.mesh, beads)
        plate = DrivenPath(_top(truth), np.array([[0, 0, -s * SIZE] for s in strains]))
        data = simulate_load_steps(truth, [plate], EmbeddedMarkers(
            nodes, weights, np.zeros((4, 125, 3))), marker_noise=20e-6, force_noise=1e-3)
        start_model = truth.with_elements(youngs_modulus=3000.0, poisson_ratio=0.3)
        for force in (False, True):
            steps = data if force else LoadSteps(data.mesh, data.driven, data.markers, None)
            start = time.perf_counter()
            fit = fit_load_steps(start_model, steps)
            rows.append({"tetrahedra": truth.mesh.n_tetrahedra, "load_cell": force,
                         "seconds": time.perf_counter() - start,
                         "iterations": fit.iterations_,
                         "nu_error": fit.poisson_ratio_ - 0.45,
                         "E_error": None if "youngs_modulus" in fit.unidentifiable_
                         else fit.youngs_modulus_ / E - 1})
    return rows


def main(argv=None):
    global GRADING
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="*", default=[4, 6, 8])
    parser.add_argument("--graded-cells", type=int, nargs="*", default=[8, 12])
    parser.add_argument("--data-cells", type=int, nargs="*", default=[6, 8])
    parser.add_argument("--graded-data-cells", type=int, nargs="*", default=[12])
    parser.add_argument("--fit-cells", type=int, nargs="+", default=[4, 6, 8])
    parser.add_argument("--check-cells", type=int, nargs="*", default=[4, 6, 8])
    parser.add_argument("--graded-check-cells", type=int, nargs="*", default=[8])
    parser.add_argument("--only", nargs="+", choices=PARTS, default=list(PARTS))
    parser.add_argument("--grading", type=float, default=GRADING,
                        help="the graded blocks' kuhn_block(grading=...)")
    args = parser.parse_args(argv)
    GRADING = args.grading
    out = ROOT / "benchmarks" / "load_steps.json"
    results = json.loads(out.read_text()) if out.exists() else {}
    if "locking" in args.only:
        _merge(results, "locking", _print_locking(locking(args.cells, args.graded_cells)))
    if "independent" in args.only:
        _merge(results, "independent", _print_fits(independent(args.data_cells,
                                                                args.graded_data_cells)))
    if "mesh-check" in args.only:
        _merge(results, "mesh_check", _print_checks(mesh_checked(args.check_cells,
                                                                 args.graded_check_cells)))
    if "speed" in args.only:
        _merge(results, "fit", _print_speed(speed(args.fit_cells)))
    out.write_text(json.dumps(results, indent=1) + "\n")
    print(f"wrote {out}")


#: what tells one row of each part's table from another: a new run replaces the rows it
#: measured again and keeps the others
ROW_KEYS = ("nu", "element", "cells", "grading", "load_cell", "reference_noise", "tetrahedra")


def _merge(results: dict, part: str, rows: list) -> None:
    def key(row):
        return tuple(row.get(name) for name in ROW_KEYS)

    fresh = {key(row) for row in rows}
    results[part] = [row for row in results.get(part, []) if key(row) not in fresh] + rows


def _print_locking(table):
    print("bonded compression 5 / 12.5 / 18 %, neo-Hookean: plate force against FElupe's")
    print(f"{'nu':>6}  {'element':<35} {'force (N)':>26}  {'error':>22}")
    for row in table:
        force = " ".join(f"{-f:.4f}" for f in row["force"])
        error = " ".join(f"{100 * e:+6.1f}%" for e in row["error"])
        print(f"{row['nu']:>6}  {row['element']:<35} {force:>26}  {error:>22}")
    return table


def _print_fits(fits):
    print("\nfit of FElupe's data (343 beads, 20 um noise on every scan, step 3 held out)")
    print(f"{'nu':>6} {'cells':>9} {'load cell':>9} {'ref. noise':>10} {'s':>6} "
          f"{'nu err':>7} {'E err':>7} {'fit/noise':>9} {'held-out':>8}")
    for row in fits:
        e = "unid." if row["E_error"] is None else f"{100 * row['E_error']:+.1f}%"
        cells = f"{row['cells']}" + (" graded" if row["grading"] else "")
        print(f"{row['nu']:>6} {cells:>9} {str(row['load_cell']):>9} "
              f"{str(row['reference_noise']):>10} {row['seconds']:>6.1f} "
              f"{row['nu_error']:>+7.4f} {e:>7} {row['fitted_x_noise']:>9.2f} "
              f"{row['held_out_x_noise']:>8.2f}")
    return fits


def _print_checks(rows):
    print("\nthe mesh check of the fits with a load cell: error on the mesh / refined once / "
          "extrapolated; the 95 % interval, noise alone -> with the mesh")
    print(f"{'nu':>6} {'cells':>9} {'E error':>24} {'E interval':>16} {'nu error':>27} "
          f"{'nu interval':>16} {'fit s':>6} {'check s':>7}")
    for row in rows:
        cells = f"{row['cells']}" + (" graded" if row["grading"] else "")
        e, n = row["E_check"], row["nu_check"]
        stages = ("mesh", "refined", "extrapolated")
        print(f"{row['nu']:>6} {cells:>9} "
              + " ".join(f"{100 * e[k]:+6.1f}%" for k in stages)
              + f" {100 * e['noise_interval']:5.1f}->{100 * e['interval']:5.1f}%"
              + (" " if e["holds"] else "!") + " "
              + " ".join(f"{n[k]:+.4f}" for k in stages)
              + f" {n['noise_interval']:.4f}->{n['interval']:.4f}"
              + (" " if n["holds"] else "!")
              + f" {row['fit_seconds']:6.1f} {row['check_seconds']:7.1f}")
    return rows


def _print_speed(timing):
    print("\nfit from 3 load steps (neo-Hookean gel, nu 0.45, 125 markers, 20 um noise)")
    print(f"{'tetrahedra':>10} {'load cell':>9} {'s':>7} {'iter':>5} {'nu err':>8} {'E err':>7}")
    for row in timing:
        e = "unid." if row["E_error"] is None else f"{100 * row['E_error']:.1f}%"
        print(f"{row['tetrahedra']:>10} {str(row['load_cell']):>9} {row['seconds']:>7.1f} "
              f"{row['iterations']:>5} {row['nu_error']:>8.4f} {e:>7}")
    return timing


if __name__ == "__main__":
    main()
