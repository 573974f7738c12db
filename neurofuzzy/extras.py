"""Optional dependencies: which extra of ``pip install 'neurofuzzy[EXTRA]'`` installs what,
and one check of them before work starts.

A missing optional package is bad input of a kind (the installation lacks it), so it is a
:class:`~neurofuzzy.errors.MissingDependencyError`: one line naming the extra to install,
exit status 2 on the command line, never a traceback. Commands and examples check with
:func:`require` (or :func:`require_in_script`) before they read or compute anything.
"""

from __future__ import annotations

import importlib.util
import sys

from .errors import MissingDependencyError

__all__ = ["EXTRAS", "require", "require_in_script", "missing"]

#: extra → the packages it installs, as (import name, what pip calls it); pyproject.toml's
#: ``[project.optional-dependencies]`` (tests/test_extras.py checks that they agree)
EXTRAS: dict[str, tuple[tuple[str, str], ...]] = {
    "validation": (("skfem", "scikit-fem"), ("felupe", "felupe"), ("tensortrax", "tensortrax")),
    "validation-nonlinear": (("skfem", "scikit-fem"), ("sfepy", "sfepy")),
    "batch": (("dask", "dask"), ("distributed", "distributed")),
    "studio": (("starlette", "starlette"), ("uvicorn", "uvicorn")),
    "export": (("mujoco", "mujoco"),),
    "tetra": (("tetgen", "tetgen"),),
    "docs": (("mkdocs", "mkdocs"), ("mkdocstrings", "mkdocstrings")),
}


def missing(extra: str) -> list[str]:
    """The packages of ``extra`` that are not installed (pip's names)."""
    return [package for module, package in EXTRAS[extra]
            if importlib.util.find_spec(module) is None]


def require(extra: str, what: str) -> None:
    """Raise :class:`MissingDependencyError` unless every package of ``extra`` is installed.

    Parameters
    ----------
    extra : str
        A key of :data:`EXTRAS` (``"validation"``, ``"batch"``, …).
    what : str
        What needs it, for the message (``"fit-many"``, ``"the continuum reference"``).

    Raises
    ------
    MissingDependencyError
        ``fit-many needs dask, distributed: pip install 'neurofuzzy[batch]'``.
    """
    absent = missing(extra)
    if absent:
        raise MissingDependencyError(f"{what} needs {', '.join(absent)}: pip install "
                                     f"'neurofuzzy[{extra}]'", extra=extra, packages=absent)


def require_in_script(extra: str, what: str) -> None:
    """:func:`require` for an example script: the message on one line of stderr and exit
    status 2 instead of a traceback."""
    try:
        require(extra, what)
    except MissingDependencyError as error:
        print(f"neurofuzzy: error: {error}", file=sys.stderr)
        raise SystemExit(2) from None
