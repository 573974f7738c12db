"""Fitted models out to the simulators where surgery is simulated, and to ParaView.

:func:`export` is the one entry point (``nf.export``, ``neurofuzzy export --to``):

========== ======================== ===============================================================
target     file                     what it holds
========== ======================== ===============================================================
``mujoco`` MJCF ``.xml``            node bodies, one flex per region and material, spring tendons
                                    (:mod:`.mujoco`; run by MuJoCo in the tests)
``sofa``   SofaPython3 scene ``.py`` ``createScene(root)``: topology, mass, fixed nodes,
                                    tetrahedral FEM and springs, the load (:mod:`.sofa`)
``febio``  FEBio ``.feb`` (4.0)     nodes, a part and a material per region, fixed nodes, nodal
                                    loads with load curves (:mod:`.febio`)
``vtu``    ParaView folder          VTU series + PVD and XDMF of the simulated and measured
                                    motion (:mod:`.paraview`, :func:`export_paraview`)
========== ======================== ===============================================================

Every file carries the fitted values with their units, the lack of fit and its verdict (from
the model file's ``fit:`` record; "lack of fit: not recorded" without one), the toolkit
version, and what the target could not express (:mod:`.metadata`).

This package imports nothing heavy: ``neurofuzzy`` imports it at start-up so that the
function ``nf.export`` keeps its name whatever imports ``neurofuzzy.export`` later (a
submodule imported for the first time is set as an attribute of its parent, over a function of
the same name).
"""

from __future__ import annotations

import os
from importlib import import_module
from pathlib import Path

__all__ = ["export", "export_paraview", "TARGETS", "FORMATS", "Exported"]

#: Where :func:`export` writes to, and the file suffix each target expects.
TARGETS: dict[str, str] = {"mujoco": ".xml", "sofa": ".py", "febio": ".feb", "vtu": ""}
#: The ParaView forms (``to="vtu"``; the same as ``paraview.FORMATS``, kept here so that this
#: package imports nothing heavy).
FORMATS: tuple[str, ...] = ("vtu", "xdmf")
#: The module and function that write each simulator's file.
_WRITERS = {"mujoco": ("mujoco", "mjcf"), "sofa": ("sofa", "scene"), "febio": ("febio", "feb")}


def export(model, to: str, path, *, experiment=None, fit: dict | None = None,
           substeps="auto", max_materials: int = 256, every: int = 1,
           stem: str = "neurofuzzy", formats=FORMATS):
    """Write a (fitted) model for a simulator.

    Parameters
    ----------
    model : Model or path
        The model, or a model file (YAML); a file's ``fit:`` record is read when ``fit`` is
        not given.
    to : {"mujoco", "sofa", "febio", "vtu"}
        The target (see the module docstring).
    path : path
        The file to write (``.xml``, ``.py``, ``.feb``); for ``"vtu"`` a folder. Written
        atomically; never a model file given as ``model``.
    experiment : Experiment, optional
        Its time step sets the simulator's (``dt / substeps``), its load becomes the load of
        the SOFA scene and the FEBio file (and the motion of the ParaView files), and the
        header measures what the targets' textbook tetrahedron changes for a model with the
        nodal volumetric form.
    fit : dict, optional
        The record of the fit (``lack_of_fit``: ``rms``, ``noise`` in m per marker,
        ``ratio``, ``verdict``), as :func:`~neurofuzzy.io.models.load_fit_record` reads it.
    substeps : int or "auto"
        Simulator steps per frame of the experiment (``"auto"``: the fewest stable for
        semi-implicit Euler, as :func:`neurofuzzy.simulate` picks them).
    max_materials : int
        Most distinct element materials (MuJoCo flexes, FEBio parts) before elements are
        binned.
    every, stem, formats
        ``"vtu"`` only: as :func:`export_paraview`.

    Returns
    -------
    Exported
        The file(s) written and the notes on what the target could not express.

    Raises
    ------
    InputError
        An unknown target, a path that names the model file or a folder (or, for ``"vtu"``,
        a file), or a model the target cannot take.
    """
    from ..errors import InputError, closest_name
    from ..io.models import load_fit_record, load_model
    from ..io.writing import atomic_write
    from .base import Exported

    if to not in TARGETS:
        hint = closest_name(str(to), tuple(TARGETS))
        raise InputError(f"unknown target {to!r}" + (f"; did you mean {hint!r}?" if hint else "")
                         + f" (known: {', '.join(TARGETS)})", key="to")
    path = Path(path)
    if isinstance(model, (str, os.PathLike)):
        source = Path(model)
        if path.exists() and path.resolve() == source.resolve():
            raise InputError("names the model file; neurofuzzy never writes over its input",
                             source=str(path))
        if fit is None:
            fit = load_fit_record(source)
        model = load_model(source)
    if to == "vtu":
        from .metadata import header_lines
        from .paraview import export_paraview as write_folder

        comment = "\n".join(header_lines(model, target="vtu", fit=fit, notes=(),
                                         experiment=experiment))
        files = write_folder(path, model, experiment, every=every, substeps=substeps, stem=stem,
                             formats=formats, comment=comment)
        written = tuple(p for value in files.values()
                        for p in (value if isinstance(value, list) else [value]))
        main = files.get("pvd") or files.get("xdmf")
        return Exported("vtu", main, written, ())
    if path.is_dir():
        raise InputError(f"is a folder; expected a file name such as tissue{TARGETS[to]}",
                         source=str(path))
    if experiment is not None:
        from ..experiment import check_experiments

        check_experiments(model, experiment)
    module, function = _WRITERS[to]
    writer = getattr(import_module(f".{module}", __name__), function)
    text, notes = writer(model, experiment=experiment, fit=fit, substeps=substeps,
                               max_materials=max_materials)
    with atomic_write(path, "w") as handle:
        handle.write(text)
    return Exported(to, path, (path,), tuple(notes))


def __getattr__(name: str):
    if name == "export_paraview":
        from .paraview import export_paraview

        return export_paraview
    if name == "Exported":
        from .base import Exported

        return Exported
    raise AttributeError(f"module 'neurofuzzy.export' has no attribute {name!r}")
