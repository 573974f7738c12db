"""What several test modules share: running the command, writing volume meshes."""

import contextlib
import io
import subprocess
import sys
from types import SimpleNamespace

import numpy as np


def cli(*args):
    """The command in this process (fast): returncode, stdout, stderr."""
    from neurofuzzy.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in args])
    return SimpleNamespace(returncode=status, stdout=out.getvalue(), stderr=err.getvalue())


#: the words of a firm tissue, and no more (for rule files that add one more word)
FIRM = ("consistency: firm, elasticity: elastic, heaviness: normal, "
        "compressibility: incompressible")


def soft_tissue_rules(path, name, tissues):
    """A rule base at ``path`` extending the shipped ``soft_tissue.yaml`` with ``tissues``
    (name → the words inside ``{…}``), loaded."""
    from pathlib import Path

    from neurofuzzy.rules import load_rules

    shared = Path(__file__).resolve().parents[1] / "rules" / "soft_tissue.yaml"
    path.write_text(f"extends: {shared}\nname: {name}\ntissues:\n" + "".join(
        f"  {tissue}: {{{words}}}\n" for tissue, words in tissues.items()))
    return load_rules(path)


def write_c3d_points(path, labels, frames_mm, rate, invisible=()):
    """A C3D file at ``path``: the points ``frames_mm`` (n_frames, n_points, 3) in mm, named
    ``labels``, ``rate`` frames a second; ``invisible`` (frame, point) pairs not seen."""
    import warnings

    import c3d

    writer = c3d.Writer(point_rate=float(rate), point_units="mm  ")
    writer.set_point_labels(list(labels))
    frames = []
    for t, positions in enumerate(frames_mm):
        points = np.zeros((len(labels), 5), np.float32)
        points[:, :3] = positions
        for frame, column in invisible:
            if frame == t:
                points[column, 3] = -1.0
        frames.append((points, np.zeros((0, 0), np.float32)))
    writer.add_frames(frames)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open(path, "wb") as handle:
            writer.write(handle)
    return path


def cli_process(*args, cwd=None):
    """The installed command in a fresh interpreter, as a user runs it."""
    return subprocess.run([sys.executable, "-m", "neurofuzzy.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=300)


def write_gmsh(path, points, tetrahedra, region, names):
    """A Gmsh 2.2 volume mesh with physical groups: ``region`` (n_tets,) ids, ``names`` id → name."""
    import meshio

    meshio.write(path, meshio.Mesh(points, [("tetra", tetrahedra)],
                                   cell_data={"gmsh:physical": [region],
                                              "gmsh:geometrical": [region]},
                                   field_data={name: np.array([tag, 3])
                                               for tag, name in names.items()}),
                 file_format="gmsh22", binary=False)
    return path


def assert_gradient_exact(sensitivity, theta, experiment, substeps):
    """The adjoint gradient equals Jᵀr of the forward sensitivities and central differences
    of the loss, for every parameter; returns ``(loss, gradient, run)``."""
    import pytest

    loss, gradient, _ = sensitivity.gradient(theta, experiment, substeps=substeps)
    run = sensitivity.run(theta, experiment, substeps=substeps, tangents=True)
    assert 0.5 * np.sum(run.residuals**2) == pytest.approx(loss, rel=1e-12)
    assert np.allclose(run.jacobian.reshape(-1, theta.size).T @ run.residuals.ravel(),
                       gradient, rtol=1e-8, atol=1e-12 * np.abs(gradient).max())
    for k in range(theta.size):
        step = np.zeros(theta.size)
        step[k] = 1e-6 * max(1.0, abs(theta[k]))       # raw effect parameters may be large
        numeric = (sensitivity.gradient(theta + step, experiment, substeps=substeps)[0]
                   - sensitivity.gradient(theta - step, experiment, substeps=substeps)[0]
                   ) / (2 * step[k])
        assert gradient[k] == pytest.approx(numeric, rel=1e-5, abs=1e-9 * np.abs(gradient).max())
    return loss, gradient, run


def pressed_on_top(model, newtons, frames=150, **options):
    """An experiment of ``model`` pressed down on its top face by ``newtons`` (spread over the
    face's nodes) for ``frames`` frames of 1 ms, at its stable substeps (``options`` go to
    :func:`~neurofuzzy.experiment.simulate_experiment`: noise, seed)."""
    from neurofuzzy.experiment import simulate_experiment
    from neurofuzzy.simulation import required_substeps

    rest = model.mesh.rest_positions
    load = np.zeros((model.n_nodes, 3))
    top = np.flatnonzero(np.isclose(rest[:, 2], rest[:, 2].max()))
    load[top, 2] = -newtons / len(top)
    return simulate_experiment(model, dt=1e-3, n_frames=frames, external_forces=load,
                               substeps=required_substeps(model, 1e-3), **options)
