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
