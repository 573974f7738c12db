"""Recordings of the probed block at large strain, made by sfepy, to validate against.

The block of :mod:`neurofuzzy.validation.probed_block` (4 × 4 × 3 cm, bottom held, 148 markers on
the top and two sides, 1 kHz, 20 µm noise, 30 frames at rest and 101 while the probe pushes
through its 1 cm contact patch) with the material laws of :mod:`.materials` solved by
:class:`~.solver.HyperelasticSolver` (quadratic tetrahedra on Kuhn cells of ``cell``
metres, Newmark with ``substeps`` steps a frame). The probe's force is a dead load, as the
toolkit's node forces are.

How hard the probe presses is told by :func:`compressive_strain`: the engineering
compression of the top centimetre (one contact radius) of material beneath the probe's
centre. On this block (E = 6 kPa, ν = 0.45, neo-Hookean, 5 mm cells) a held 0.7 N compresses
it by 27 % in equilibrium and by 35 % at the first overshoot after the probe touches, 0.12 N
by 4 % and 5 %: the presets :data:`LARGE_FORCE` and :data:`SMALL_FORCE`.

- :func:`large_strain_block` — neo-Hookean, 0.7 N: the tissue under the probe compressed by
  27–35 %, where SVK softens.
- :func:`small_strain_block` — neo-Hookean, 0.12 N (4–5 %), where every law agrees.
- :func:`relaxing_block` — neo-Hookean with one Prony term (g = 0.5, τ = 50 ms) under the
  held small-strain load: the block creeps as the tissue relaxes.
- :func:`stiffening_block` — Yeoh (C₂₀ = C₁₀, same small-strain E and ν), 0.7 N.

``reference_data.block_experiment`` imports a recording onto a toolkit mesh with the
recording's own force (``truth["force"]``).
"""

from __future__ import annotations

import time

import numpy as np

from ...errors import InputError
from ..probed_block import BLOCK, Recording, marker_points
from .materials import NeoHookean, Prony, Yeoh

__all__ = ["LARGE_FORCE", "SMALL_FORCE", "nonlinear_block", "large_strain_block",
           "small_strain_block", "relaxing_block", "stiffening_block", "compressive_strain",
           "block_solver", "store", "stored"]

#: The probe's force (N): 27 % compression under the probe held, 35 % at the overshoot.
LARGE_FORCE = 0.7
#: The probe's force (N): 4 % held, 5 % at the overshoot.
SMALL_FORCE = 0.12


def block_solver(*, law: str = "neo-hookean", poisson_ratio: float = 0.45,
                 prony: Prony | None = None, stiffening: float = 1.0, cell: float = 0.005,
                 order: int = 2, viscosity: float | None = None):
    """The :class:`~.solver.HyperelasticSolver` of the block: Kuhn cells of ``cell`` m,
    E = 6 kPa, η = 2 Pa·s, 1050 kg/m³ (``reference_data.BLOCK``), bottom held. ``law`` is
    ``"neo-hookean"`` or ``"yeoh"`` (with C₂₀ = ``stiffening`` · C₁₀, C₃₀ = 0)."""
    from ...mesh import kuhn_block
    from .solver import HyperelasticSolver

    size = np.array(BLOCK["size"])
    cells = np.round(size / cell).astype(int)
    if np.any(np.abs(cells * cell - size) > 1e-9):
        raise InputError(f"the cell {cell} does not divide the block {tuple(size)}", key="cell")
    modulus = BLOCK["youngs_modulus"]
    if law == "neo-hookean":
        material = NeoHookean(modulus, poisson_ratio)
    elif law == "yeoh":
        material = Yeoh.from_youngs(modulus, poisson_ratio, c20_ratio=stiffening)
    else:
        raise InputError(f"got {law!r}; expected 'neo-hookean' or 'yeoh'", key="law")
    return HyperelasticSolver(*kuhn_block(tuple(cells), cell), material=material,
                              density=BLOCK["density"], fixed=lambda x: x[2] < 1e-9,
                              viscosity=BLOCK["viscosity"] if viscosity is None else viscosity,
                              prony=prony, order=order, quadrature_order=2)


def compressive_strain(solver, displacement) -> np.ndarray:
    """(...,): the engineering compression of the top centimetre beneath the probe's centre,
    ``(u_z(depth 1 cm) - u_z(top)) / 1 cm``, for displacements (..., n_dofs)."""
    (px, py, top), depth = BLOCK["probe"], BLOCK["radius"]
    uz = solver.at(displacement, [[px, py, top], [px, py, top - depth]])[..., 2]
    return (uz[..., 1] - uz[..., 0]) / depth


def nonlinear_block(*, law: str = "neo-hookean", force: float = LARGE_FORCE,
                    poisson_ratio: float = 0.45, prony: Prony | None = None,
                    stiffening: float = 1.0, noise: float = 20e-6, rest_frames: int = 30,
                    frames: int = 101, seed: int = 0, cell: float = 0.005,
                    substeps: int = 2) -> Recording:
    """The block's markers, recorded for ``rest_frames`` frames at rest and then ``frames``
    frames while the probe pushes with ``force`` N (held from its first touch), the block
    made of ``law`` (see :func:`block_solver`) with Kelvin–Voigt η = 2 Pa·s and, if given,
    the ``prony`` series on top."""
    from ...markers import MarkerData

    if not (np.isfinite(force) and force > 0):
        raise InputError(f"must be a positive number of newtons, got {force!r}", key="force")
    started = time.perf_counter()
    solver = block_solver(law=law, poisson_ratio=poisson_ratio, prony=prony,
                          stiffening=stiffening, cell=cell)
    load = solver.probe_load(BLOCK["probe"], BLOCK["radius"], (0.0, 0.0, -force))
    # Newton stops at corrections of 1e-6 × the largest displacement (4 nm at 0.7 N): the
    # markers move by 0.05 µm at most against 1e-11 (measured on 1 cm cells)
    run = solver.trajectory(load, dt=BLOCK["dt"], n_frames=frames, substeps=substeps,
                            tolerance=1e-6)
    points = marker_points()
    moved = np.concatenate([np.zeros((rest_frames, len(points), 3)),
                            solver.at(run.displacement, points)])
    strain = compressive_strain(solver, run.displacement)
    rng = np.random.default_rng(seed)
    n_frames = rest_frames + frames
    markers = MarkerData(names=tuple(f"M{i}" for i in range(len(points))),
                         times=np.arange(n_frames) * BLOCK["dt"],
                         positions=points[None] + moved + rng.normal(0.0, noise, moved.shape),
                         source=f"<sfepy {law} block, {force} N, nu {poisson_ratio}, "
                                f"seed {seed}>")
    material = solver.material
    truth = {"law": material.name, "form": material.form,
             "youngs_modulus": material.youngs_modulus, "poisson_ratio": material.poisson_ratio,
             "shear_modulus": material.shear_modulus, "bulk_modulus": material.bulk_modulus,
             "viscosity": solver.viscosity, "density": solver.density, "noise": noise,
             "force": force, "inclusion": None, "gravity": False,
             "prony": None if prony is None else {"relative_moduli": prony.relative_moduli,
                                                  "times": prony.times},
             "compressive_strain": strain, "compressive_strain_peak": float(strain.max()),
             "solver": "sfepy", "mesh": f"Kuhn cells of {cell} m, quadratic tetrahedra",
             "substeps": substeps, "seconds": time.perf_counter() - started}
    if isinstance(material, Yeoh):
        truth.update(c10=material.c10, c20=material.c20, c30=material.c30)
    return Recording(markers, points, rest_frames, truth)


def large_strain_block(**options) -> Recording:
    """Neo-Hookean, :data:`LARGE_FORCE` (27–35 % under the probe)."""
    return nonlinear_block(**{"force": LARGE_FORCE, **options})


def small_strain_block(**options) -> Recording:
    """Neo-Hookean, :data:`SMALL_FORCE` (4–5 %)."""
    return nonlinear_block(**{"force": SMALL_FORCE, **options})


def relaxing_block(**options) -> Recording:
    """Neo-Hookean with one Prony term, g = 0.5, τ = 50 ms (long-term E = 6 kPa, 9 kPa at
    once), under the held :data:`SMALL_FORCE`."""
    return nonlinear_block(**{"force": SMALL_FORCE, "prony": Prony((0.5,), (0.05,)),
                              **options})


def stiffening_block(**options) -> Recording:
    """Yeoh with C₂₀ = C₁₀ (and the neo-Hookean block's small-strain E and ν),
    :data:`LARGE_FORCE`."""
    return nonlinear_block(**{"law": "yeoh", "force": LARGE_FORCE, **options})


#: the resolution a stored recording keeps its marker displacements at (m): 0.1 µm, far below
#: the 20 µm noise, so a stored recording is the recording for every fit
STORED_RESOLUTION = 1e-7


def store(recording: Recording, path) -> None:
    """Write ``recording`` compactly (``.npz``: displacements from the rest points in steps of
    :data:`STORED_RESOLUTION`, the rest points, times, touch frame and truth as JSON), so
    tests and benchmarks replay it without sfepy."""
    import json

    steps = np.round((recording.markers.positions - recording.rest_points[None])
                     / STORED_RESOLUTION).astype(np.int32)
    truth = {key: (value.tolist() if isinstance(value, np.ndarray) else value)
             for key, value in recording.truth.items()}
    np.savez_compressed(path, displacement=steps, rest_points=recording.rest_points,
                        times=recording.markers.times, touch=recording.touch,
                        source=recording.markers.source, truth=json.dumps(truth))


def stored(path) -> Recording:
    """A recording written by :func:`store`."""
    import json

    from ...markers import MarkerData

    with np.load(path) as data:
        rest = data["rest_points"]
        positions = rest[None] + data["displacement"] * STORED_RESOLUTION
        markers = MarkerData(names=tuple(f"M{i}" for i in range(len(rest))),
                             times=data["times"], positions=positions,
                             source=str(data["source"]))
        return Recording(markers, rest, int(data["touch"]), json.loads(str(data["truth"])))
