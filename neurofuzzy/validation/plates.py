"""A large-strain reference for compression between plates, from a solver nobody here wrote:
FElupe's quadratic tetrahedra in the Hu–Washizu three-field form, which does not lock as
ν → 0.5.

The lab-experiments tests need a compression test whose answer we did not compute ourselves:
a cube of the coupled compressible neo-Hookean solid (``Ψ = μ/2 (I₁ - 3) - μ ln J +
λ/2 (ln J)²``, FElupe's ``NeoHookeCompressible``, exactly our ``neo-hookean`` law) on a fixed
anvil, its top face bonded to a plate moved down by a few per cent of its height, at rest at
each load step. FElupe (Dutzler, https://github.com/adtzlr/felupe) assembles and solves it
with its own elements, quadrature and Newton iteration; this module only states the problem
and reads the answer at the beads.

Why the three-field form: at ν = 0.499 plain elements, quadratic ones included, are too stiff
in the bulging a plate produces. FElupe's :class:`~felupe.ThreeFieldVariation` (displacement
P2, pressure P1, volume ratio P1 on the same tetrahedra: Taylor–Hood, inf–sup stable) is the
standard cure (Simo, Taylor & Pister 1985), so the reference converges at every ν.

Convergence: the plate's force converges like ``h`` (the bonded edges are singular), so
:func:`converged_force` extrapolates the force from two meshes (Richardson, order 1); the
beads, inside the body, converge faster and are read from the finer mesh.

Needs the ``validation`` extra (``pip install 'neurofuzzy[validation]'``, FElupe ≥ 11.3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..extras import require

__all__ = ["PlateCompression", "compress_between_plates", "converged_force"]


@dataclass(frozen=True)
class PlateCompression:
    """What FElupe computed: the beads' displacements and the plate's force at each step.

    Attributes
    ----------
    displacements : (n_steps, n_points, 3) float
        Each bead's displacement from rest at load steps 1..n_steps (m).
    force : (n_steps, 3) float
        The total force the plate exerts on the body at each step (N); compression is
        negative ``z``.
    cells : int
        Cells a side of the reference mesh (six quadratic tetrahedra each).
    """

    displacements: np.ndarray
    force: np.ndarray
    cells: int


def _bead_values(mesh, values, points):
    """The quadratic field ``values`` (n_mesh_points, 3) at ``points``: barycentric
    coordinates in the tetrahedron that holds each point, then P2 shape functions."""
    cells = mesh.cells
    corners = mesh.points[cells[:, :4]]                              # (c, 4, 3)
    edges = np.transpose(corners[:, 1:] - corners[:, :1], (0, 2, 1))   # (c, 3, 3)
    local = np.einsum("cij,pcj->pci", np.linalg.inv(edges),
                      points[:, None, :] - corners[None, :, 0])       # (p, c, 3)
    bary = np.concatenate([1 - local.sum(-1, keepdims=True), local], axis=-1)
    inside = np.argmax(bary.min(-1), axis=1)                          # best-fitting cell
    if np.any(bary[np.arange(len(points)), inside].min(-1) < -1e-9):
        raise InputError("a bead lies outside the block", key="points")
    lam = bary[np.arange(len(points)), inside]                        # (p, 4)
    # which two corners each of the six midpoint nodes sits between (FElupe's edge order)
    mid = mesh.points[cells[0, 4:]]
    pairs = [min(((a, b) for a in range(4) for b in range(a + 1, 4)),
                 key=lambda ab: np.linalg.norm(corners[0, ab[0]] + corners[0, ab[1]] - 2 * m))
             for m in mid]
    shape = np.concatenate([lam * (2 * lam - 1),
                            np.stack([4 * lam[:, a] * lam[:, b] for a, b in pairs], 1)], 1)
    return np.einsum("pk,pkd->pd", shape, values[cells[inside]])


def compress_between_plates(points, *, size: float, youngs_modulus: float,
                            poisson_ratio: float, strains, cells: int = 6,
                            increments: int = 3, plates: str = "bonded") -> PlateCompression:
    """Compress a cube of side ``size`` (m) between plates and read the beads.

    The top face is moved down by ``strain · size`` at each load step (``increments``
    Newton solves per step, each to a residual of 1e-10). ``plates="bonded"``: the bottom
    face held, the top face bonded to its plate (it moves only down). ``"sliding"``: both
    plates frictionless, the faces ``x = 0`` and ``y = 0`` held normal to themselves (the
    symmetry planes of a quarter of a larger specimen): the cube deforms homogeneously, the
    uniaxial closed form of :mod:`.nonlinear.closed_forms`.

    Parameters
    ----------
    points : (n, 3) float
        Bead positions at rest (m), inside the cube ``[0, size]³``.
    size, youngs_modulus, poisson_ratio : float
        The cube's side (m) and the neo-Hookean solid's small-strain E (Pa) and ν.
    strains : sequence of float
        The plate's compression at each load step, increasing (0.05 for 5 %).
    cells : int
        Cells a side (six quadratic tetrahedra each).
    """
    require("validation", "the large-strain plate reference (FElupe)")
    import felupe as fem
    strains = np.asarray(strains, float)
    if strains.ndim != 1 or strains.size == 0 or np.any(np.diff(strains) <= 0) \
            or strains[0] <= 0:
        raise InputError(f"must be increasing positive strains, got {strains.tolist()}",
                         key="strains")
    points = np.asarray(points, float)
    mu = youngs_modulus / (2 * (1 + poisson_ratio))
    lam = youngs_modulus * poisson_ratio / ((1 + poisson_ratio) * (1 - 2 * poisson_ratio))
    mesh = fem.Cube(b=(size,) * 3, n=cells + 1).triangulate().add_midpoints_edges()
    field = fem.FieldsMixed(fem.RegionQuadraticTetra(mesh), n=3)
    solid = fem.SolidBody(fem.ThreeFieldVariation(fem.NeoHookeCompressible(mu=mu, lmbda=lam)),
                          field)
    x, y, z = mesh.points.T
    top = np.isclose(z, size)
    if plates == "bonded":
        bounds = {"anvil": fem.Boundary(field[0], mask=np.isclose(z, 0.0)),
                  "plate_xy": fem.Boundary(field[0], mask=top, skip=(0, 0, 1))}
    elif plates == "sliding":
        bounds = {"anvil": fem.Boundary(field[0], mask=np.isclose(z, 0.0), skip=(1, 1, 0)),
                  "x0": fem.Boundary(field[0], mask=np.isclose(x, 0.0), skip=(0, 1, 1)),
                  "y0": fem.Boundary(field[0], mask=np.isclose(y, 0.0), skip=(1, 0, 1))}
    else:
        raise InputError(f"must be 'bonded' or 'sliding', got {plates!r}", key="plates")
    bounds["plate_z"] = fem.Boundary(field[0], mask=top, skip=(1, 1, 0))
    path = np.concatenate([np.linspace(start, end, increments + 1)[1:] for start, end
                           in zip(np.concatenate([[0.0], strains[:-1]]), strains)])
    displacements, force = [], []

    def record(context, state):
        if (state.substepnumber + 1) % increments == 0:
            force.append(fem.tools.force(field, context.substep.fun, bounds["plate_z"]))
            displacements.append(_bead_values(mesh, field[0].values, points))

    step = fem.Step(items=[solid], ramp={bounds["plate_z"]: -path * size}, boundaries=bounds)
    fem.Job(steps=[step], plugins=[record]).evaluate(verbose=0, tol=1e-10)
    # at a held degree of freedom FElupe's residual is the internal force, which the plate
    # balances: the force the plate exerts on the body (compression: negative z)
    return PlateCompression(np.array(displacements), np.array(force), cells)


def converged_force(coarse: PlateCompression, fine: PlateCompression) -> np.ndarray:
    """The plate's force extrapolated to zero cell size from two meshes (Richardson, first
    order: the bonded edges' singularity makes the force converge like ``h``)."""
    ratio = fine.cells / coarse.cells
    if ratio <= 1:
        raise InputError("the fine mesh must have more cells than the coarse one",
                         key="cells")
    return fine.force + (fine.force - coarse.force) / (ratio - 1)


#: The recorded experiment: a 2 cm gel cube (E = 6 kPa), compressed 5, 12.5 and 18 %, with
#: 343 beads drawn uniformly from the middle 80 % of each axis (seed 0).
SIZE, YOUNGS, STRAINS, N_BEADS = 0.02, 6000.0, (0.05, 0.125, 0.18), 343


def beads(n: int = N_BEADS, seed: int = 0) -> np.ndarray:
    """The recorded experiment's bead positions at rest (m)."""
    return np.random.default_rng(seed).uniform(0.1 * SIZE, 0.9 * SIZE, size=(n, 3))


def record(poisson_ratio: float, path, cells=(6, 8)) -> dict:
    """Solve the recorded experiment on two meshes and store it (``.npz``): the beads at
    rest, their displacements on the finer mesh, the plate's force on each mesh and
    extrapolated (:func:`converged_force`)."""
    points = beads()
    coarse, fine = (compress_between_plates(points, size=SIZE, youngs_modulus=YOUNGS,
                                            poisson_ratio=poisson_ratio, strains=STRAINS,
                                            cells=n) for n in cells)
    data = {"beads": points, "strains": np.array(STRAINS), "size": SIZE,
            "youngs_modulus": YOUNGS, "poisson_ratio": poisson_ratio,
            "displacements": fine.displacements, "force": converged_force(coarse, fine),
            "force_coarse": coarse.force, "force_fine": fine.force,
            "cells": np.array(cells)}
    np.savez(path, **data)
    return data


if __name__ == "__main__":          # python -m neurofuzzy.validation.plates NU OUT.npz
    import sys

    record(float(sys.argv[1]), sys.argv[2])
