"""Recordings of a probed soft block made by code nobody here wrote, to validate against.

The block of the documentation's continuum examples: 4 × 4 × 3 cm, bottom held, pushed on the top
centre by a probe through a 1 cm contact patch; markers on the top (off the patch) and two
sides on a 5 mm grid, recorded at 1 kHz with white noise. The motion comes from scikit-fem's
quadratic tetrahedra (:class:`~neurofuzzy.validation.continuum.ContinuumSolver`: Kuhn cells of
``cell`` metres, consistent mass, Newmark), optionally with a stiffer (or softer) sphere
inside and with gravity nobody declared. :func:`block_model` and :func:`block_experiment`
then build what a user of the toolkit would: a model meshed from the block's surface (voxels
of any pitch, or TetGen; never the reference's own mesh) and the imported recording.

:func:`mujoco_block` makes the same recording with MuJoCo instead (``pip install mujoco``):
the block as a MuJoCo flex of linear St. Venant–Kirchhoff tetrahedra with stiffness-
proportional damping (another code's elements, integrator and damping form), on a mesh of
``cell`` metres split its own way (five tetrahedra per cube, alternating, where our voxels take
six around a diagonal), with the probe's patch load, an inclusion as a second flex and gravity
as MuJoCo's own.

Needs scikit-fem (``pip install 'neurofuzzy[validation]'``), and mujoco
(``pip install 'neurofuzzy[export]'``) for :func:`mujoco_block`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

__all__ = ["BLOCK", "Inclusion", "Recording", "probed_block", "mujoco_block", "marker_points",
           "block_model", "graded_block", "block_experiment", "five_tetrahedra_block"]

#: The block and its probe (SI units).
BLOCK = {"size": (0.04, 0.04, 0.03), "probe": (0.02, 0.02, 0.03), "force": 0.05,
         "radius": 0.01, "dt": 1e-3, "youngs_modulus": 6000.0, "viscosity": 2.0,
         "density": 1050.0}


@dataclass(frozen=True)
class Inclusion:
    """A region of other stiffness, ``contrast`` × the block's E: a sphere of ``radius`` (m)
    about ``centre`` (m), or with ``half_size`` (m, per axis) the box of those half-widths
    about it."""

    centre: tuple = (0.014, 0.02, 0.017)
    radius: float = 0.0095
    contrast: float = 5.0
    half_size: tuple | None = None

    @classmethod
    def box(cls, low, high, contrast: float = 5.0) -> Inclusion:
        """The box from corner ``low`` to corner ``high`` (m)."""
        low, high = np.asarray(low, float), np.asarray(high, float)
        return cls(centre=tuple((low + high) / 2), radius=0.0, contrast=contrast,
                   half_size=tuple((high - low) / 2))

    def inside(self, points: np.ndarray) -> np.ndarray:
        offset = np.asarray(points) - np.asarray(self.centre)
        if self.half_size is not None:
            return np.all(np.abs(offset) <= np.asarray(self.half_size) + 1e-12, axis=-1)
        return np.linalg.norm(offset, axis=-1) <= self.radius

    @property
    def volume(self) -> float:
        """m³."""
        if self.half_size is not None:
            return float(np.prod(2 * np.asarray(self.half_size)))
        return float(4 / 3 * np.pi * self.radius**3)

    @property
    def volume_share(self) -> float:
        """The inclusion's share of the block's volume (it lies wholly inside)."""
        return self.volume / float(np.prod(BLOCK["size"]))


@dataclass
class Recording:
    """A marker recording of the probed block and what made it.

    Attributes
    ----------
    markers : MarkerData
        Positions (m) with noise, at the frame times.
    rest_points : (n_markers, 3) float
        Where the markers are at rest (m), without noise.
    touch : int
        The frame from which the probe pushes (frames before it are at rest).
    truth : dict
        E, ν, η, density, the inclusion, gravity and the noise per coordinate.
    """

    markers: object
    rest_points: np.ndarray
    touch: int
    truth: dict = field(default_factory=dict)

    @property
    def n_frames(self) -> int:
        return len(self.markers.times)


def marker_points() -> np.ndarray:
    """(148, 3): a 5 mm grid on the top (off the probe's patch) and on the sides x = 0 and
    y = 0."""
    (sx, _, sz), (px, py, _) = BLOCK["size"], BLOCK["probe"]
    grid = np.arange(0.0025, sx, 0.005)
    heights = np.arange(0.0025, sz, 0.005)
    top = [(x, y, sz) for x in grid for y in grid if np.hypot(x - px, y - py) > BLOCK["radius"]]
    sides = ([(x, 0.0, z) for x in grid for z in heights]
             + [(0.0, y, z) for y in grid for z in heights])
    return np.array(top + sides)


def probed_block(*, poisson_ratio: float = 0.45, inclusion: Inclusion | None = None,
                 gravity: bool = False, noise: float = 20e-6, rest_frames: int = 30,
                 frames: int = 101, seed: int = 0, cell: float = 0.005,
                 profile: np.ndarray | None = None) -> Recording:
    """The block's markers, recorded for ``rest_frames`` frames at rest and then ``frames``
    frames while the probe pushes (from its first touch). With ``gravity`` the block is let go
    under its weight as the probe touches; with an ``inclusion`` the sphere is stiffer.
    ``profile`` ((rest_frames + frames,) floats) scales the probe's force frame by frame (a
    ramp, a release; default a step to the full force at the touch), kept in ``truth``."""
    from .continuum import ContinuumSolver
    from ..mesh import kuhn_block
    from ..markers import MarkerData

    size = np.array(BLOCK["size"])
    cells = np.round(size / cell).astype(int)
    if np.any(np.abs(cells * cell - size) > 1e-9):
        raise InputError(f"the cell {cell} does not divide the block {tuple(size)}", key="cell")
    modulus = BLOCK["youngs_modulus"]

    def youngs_modulus(centroids):
        if inclusion is None:
            return np.full(len(centroids), modulus)
        return np.where(inclusion.inside(centroids), inclusion.contrast * modulus, modulus)

    solver = ContinuumSolver(*kuhn_block(tuple(cells), cell), youngs_modulus=youngs_modulus,
                             poisson_ratio=poisson_ratio, viscosity=BLOCK["viscosity"],
                             density=BLOCK["density"], fixed=lambda x: x[2] < 1e-9)
    load = solver.probe_load(BLOCK["probe"], BLOCK["radius"], (0.0, 0.0, -BLOCK["force"]))
    if gravity:
        load = load + solver.gravity_load((0.0, 0.0, -9.81))
    n_frames = rest_frames + frames
    loads = np.zeros((n_frames, len(load)))
    loads[rest_frames:] = load
    if profile is not None:
        profile = np.asarray(profile, float)
        if profile.shape != (n_frames,):
            raise InputError(f"got shape {profile.shape}; expected ({n_frames},)",
                             key="profile")
        loads = profile[:, None] * load[None]
    points = marker_points()
    moved = solver.at(solver.dynamic(loads, dt=BLOCK["dt"], n_frames=n_frames), points)
    rng = np.random.default_rng(seed)
    positions = points[None] + moved + rng.normal(0.0, noise, moved.shape)
    markers = MarkerData(names=tuple(f"M{i}" for i in range(len(points))),
                         times=np.arange(n_frames) * BLOCK["dt"], positions=positions,
                         source=f"<scikit-fem block, nu {poisson_ratio}, seed {seed}>")
    truth = {"youngs_modulus": modulus, "poisson_ratio": poisson_ratio,
             "viscosity": BLOCK["viscosity"], "density": BLOCK["density"], "noise": noise,
             "inclusion": inclusion, "gravity": gravity, "profile": profile}
    return Recording(markers, points, rest_frames, truth)


def block_model(*, pitch: float | None = None, tetgen: bool = False,
                max_edge: float | None = None, graded: float | None = None,
                rules: str = "liver", tissue: str = "liver"):
    """The start model a user builds for the block: ``neurofuzzy mesh block.stl --fix-bottom
    --rules RULES --tissue TISSUE`` with voxels of ``pitch`` (default 4 mm cells) or TetGen
    (``max_edge``), elements from the rule base's tissue; or (``graded``) a block of Kuhn
    cells ``graded`` metres wide under the probe (the top centimetre within 1 cm of the
    probe's axis, in x and y), widening by 1.4 per cell to at most 5 mm towards the sides and
    the bottom, as a mesher's size field would grade it (:func:`graded_block`)."""
    import trimesh

    from ..mesh import from_surface_tetra, from_tetra, from_trimesh, lattice_to_tetra
    from ..rules import resolve
    from ..tissues import initialize

    surface = trimesh.creation.box(extents=BLOCK["size"])
    surface.apply_translation(np.array(BLOCK["size"]) / 2)
    if graded:
        mesh = from_tetra(*graded_block(graded))
    elif tetgen:
        mesh = from_surface_tetra(surface, max_edge=max_edge)
    else:
        mesh = lattice_to_tetra(from_trimesh(surface, pitch or 0.004), bounds=surface.bounds)
    z = mesh.rest_positions[:, 2]
    mesh = mesh.with_fixed(where=lambda p: z <= z.min() + 0.25 * mesh.rest_lengths.min())
    return initialize(resolve(rules), mesh, tissue, elements=True)


def graded_block(fine: float, growth: float = 1.4, coarse: float = 0.005):
    """``(points, tetrahedra)`` of the block in Kuhn cells ``fine`` metres wide under the
    probe (x and y within 1 cm of its axis, the top centimetre), each next cell outwards
    ``growth`` times wider up to ``coarse`` (the last ones stretched to fill the block)."""
    from ..mesh import kuhn_block

    (sx, sy, sz), (px, py, _), reach = BLOCK["size"], BLOCK["probe"], BLOCK["radius"]

    def widening(length):               # cell ends from the fine zone outwards
        sizes, size = [], fine
        while sum(sizes) < length - 1e-12:
            size = min(size * growth, coarse)
            sizes.append(size)
        return np.cumsum(np.array(sizes) * length / sum(sizes))

    def axis(low, high, end):
        inner = np.linspace(low, high, int(round((high - low) / fine)) + 1)
        ends = [low - widening(low)[::-1], inner]
        if end > high:
            ends.append(high + widening(end - high))
        return np.unique(np.round(np.concatenate([[0.0], *ends, [end]]), 12).clip(0.0, end))

    xs, ys = axis(px - reach, px + reach, sx), axis(py - reach, py + reach, sy)
    zs = axis(sz - reach, sz, sz)
    grid, tetrahedra = kuhn_block((len(xs) - 1, len(ys) - 1, len(zs) - 1), 1.0)
    index = grid.astype(int)
    return np.column_stack([xs[index[:, 0]], ys[index[:, 1]], zs[index[:, 2]]]), tetrahedra


def block_experiment(recording: Recording, mesh):
    """The recording imported on ``mesh`` (``neurofuzzy import markers.csv --forces
    probe.csv``): markers embedded at their rest positions (the mean of the frames at rest),
    the probe's force (``recording.truth["force"]``, the block's 0.05 N if it names none)
    spread over its contact patch from the frame it touches (or scaled by the recording's
    ``profile``)."""
    from ..markers import markers_to_experiment
    from ..mesh import patch_loads

    force = recording.truth.get("force", BLOCK["force"])
    load = patch_loads(mesh, BLOCK["probe"], BLOCK["radius"], (0.0, 0.0, -force))
    forces = np.zeros((recording.n_frames, mesh.n_nodes, 3))
    forces[recording.touch:] = load
    if recording.truth.get("profile") is not None:
        forces = recording.truth["profile"][:, None, None] * load[None]
    return markers_to_experiment(recording.markers, mesh, forces=forces,
                                 source=recording.markers.source).experiment


def five_tetrahedra_block(cell: float):
    """``(points, tetrahedra)`` of the block in cubes of ``cell`` metres, each split into five
    tetrahedra (a central one and four corners), mirrored from cube to cube so that faces
    match: another split than our voxels' six Kuhn tetrahedra."""
    size = np.array(BLOCK["size"])
    cells = np.round(size / cell).astype(int)
    shape = tuple(int(n) + 1 for n in cells)
    points = np.argwhere(np.ones(shape, bool)).astype(float) * cell
    index = np.arange(np.prod(shape)).reshape(shape)
    even = [[0, 3, 5, 6], [0, 1, 3, 5], [0, 2, 3, 6], [0, 4, 5, 6], [3, 5, 6, 7]]
    odd = [[1, 2, 4, 7], [0, 1, 2, 4], [1, 2, 3, 7], [1, 4, 5, 7], [2, 4, 6, 7]]
    tetrahedra = []
    for i, j, k in np.ndindex(*cells):
        corners = [index[i + a, j + b, k + c] for a in (0, 1) for b in (0, 1) for c in (0, 1)]
        for tet in (even if (i + j + k) % 2 == 0 else odd):
            tetrahedra.append([corners[v] for v in tet])
    return points, np.array(tetrahedra)


def mujoco_block(*, poisson_ratio: float = 0.45, inclusion: Inclusion | None = None,
                 gravity: bool = False, noise: float = 20e-6, rest_frames: int = 30,
                 frames: int = 101, seed: int = 0, cell: float = 0.0025) -> Recording:
    """:func:`probed_block`'s recording made by MuJoCo (module docstring) on cubes of
    ``cell`` metres split in five."""
    from ..experiment import Experiment
    from ..export.mujoco import mjcf, simulate_mujoco
    from ..markers import MarkerData
    from ..mesh import from_tetra, patch_loads
    from ..model import Model
    from ..observation import embed_points

    points, tetrahedra = five_tetrahedra_block(cell)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    centroids = points[tetrahedra].mean(axis=1)
    modulus = np.full(len(tetrahedra), BLOCK["youngs_modulus"])
    region = np.zeros(len(tetrahedra), np.intp)
    if inclusion is not None:
        inside = inclusion.inside(centroids)
        modulus[inside] *= inclusion.contrast
        region[inside] = 1
    truth_model = Model.continuum(mesh, youngs_modulus=modulus,
                                  poisson_ratio=poisson_ratio,
                                  viscosity=BLOCK["viscosity"] * modulus
                                  / BLOCK["youngs_modulus"],
                                  density=BLOCK["density"], volumetric="element")
    if inclusion is not None:
        truth_model = truth_model.replace(
            region_names=("block", "inclusion"), region_tissues=(None, None),
            terms=(truth_model.elements.replace(region=region),))
    if gravity:
        from ..effects import Gravity

        truth_model = truth_model.with_effects(Gravity((0.0, 0.0, -9.81)))
    n_frames = rest_frames + frames
    forces = np.zeros((n_frames, mesh.n_nodes, 3))
    forces[rest_frames:] = patch_loads(mesh, BLOCK["probe"], BLOCK["radius"],
                                       (0.0, 0.0, -BLOCK["force"]))
    if gravity:                          # let go as the probe touches, as probed_block does
        forces[:rest_frames] = -truth_model.node_mass[:, None] * np.array([0, 0, -9.81])
    experiment = Experiment(mesh=mesh, dt=BLOCK["dt"],
                            positions=np.repeat(mesh.rest_positions[None], n_frames, axis=0),
                            external_forces=forces)
    moved = simulate_mujoco(mjcf(truth_model, experiment=experiment)[0], experiment)
    rest_points = marker_points()
    nodes, weights, _ = embed_points(mesh, rest_points)
    at_markers = np.einsum("mk,tmkj->tmj", weights, moved[:, nodes])
    rng = np.random.default_rng(seed)
    markers = MarkerData(names=tuple(f"M{i}" for i in range(len(rest_points))),
                         times=np.arange(n_frames) * BLOCK["dt"],
                         positions=at_markers + rng.normal(0.0, noise, at_markers.shape),
                         source=f"<MuJoCo block, nu {poisson_ratio}, seed {seed}>")
    truth = {"youngs_modulus": BLOCK["youngs_modulus"], "poisson_ratio": poisson_ratio,
             "viscosity": BLOCK["viscosity"], "density": BLOCK["density"], "noise": noise,
             "inclusion": inclusion, "gravity": gravity, "solver": "mujoco"}
    return Recording(markers, rest_points, rest_frames, truth)
