"""Exception types raised for bad input.

Every error a user can cause by handing us a bad file, array or option is a subclass of
:class:`NeurofuzzyError` (itself a ``ValueError``). The command line catches exactly these,
prints the message on one line and exits with status 2; anything else is a bug in neurofuzzy.
"""

from __future__ import annotations

import difflib
import numbers
from collections.abc import Iterable

__all__ = [
    "NeurofuzzyError",
    "InputError",
    "UnstableTimeStepError", "FolderInUseError", "SchedulerLostError",
    "MissingDependencyError",
    "closest_name", "index_of", "RuleFileDeprecationWarning", "PlausibilityWarning"]


class NeurofuzzyError(ValueError):
    """Base class of every error caused by bad input."""


class InputError(NeurofuzzyError):
    """A value, array or file does not have the form it must have.

    Parameters
    ----------
    message : str
        What is wrong and, where it helps, how to fix it.
    source : str, optional
        The file (or other origin) the value came from; prefixed to the message.
    key : str, optional
        The key, argument or field inside ``source``.
    line : int, optional
        1-based line in ``source`` (YAML files).
    """

    def __init__(self, message: str, *, source: str | None = None, key: str | None = None,
                 line: int | None = None):
        self.source = source
        self.key = key
        self.line = line
        self.detail = message
        where = ""
        if source is not None:
            where = f"{source}:{line}: " if line is not None else f"{source}: "
        what = f"{key}: " if key is not None else ""
        super().__init__(f"{where}{what}{message}")


class MissingDependencyError(InputError):
    """An optional package is not installed; the message names the extra that installs it
    (:func:`neurofuzzy.extras.require`).

    Attributes
    ----------
    extra : str
        The extra of ``pip install 'neurofuzzy[EXTRA]'``.
    packages : list of str
        The missing packages, as pip names them.
    """

    def __init__(self, message: str, *, extra: str, packages=()):
        super().__init__(message)
        self.extra = extra
        self.packages = list(packages)


class UnstableTimeStepError(NeurofuzzyError):
    """The explicit time step is too large for the stiffest mode of the model."""


class FolderInUseError(InputError):
    """Another ``fit-many`` is writing the results folder (or may be: its lock was left by a
    run on another host); the message names the owner."""


class SchedulerLostError(NeurofuzzyError):
    """The Dask scheduler of a ``fit-many`` stopped or could not be reached any more; what
    finished is kept, and ``--resume`` fits the rest."""


def index_of(item, names) -> int | None:
    """Where ``item`` is in ``names``: an integer index in range, or one of the names (as
    text); None when it is neither (the caller says what was expected)."""
    if isinstance(item, numbers.Integral) and not isinstance(item, bool):
        return int(item) if 0 <= item < len(names) else None
    return names.index(str(item)) if str(item) in names else None


def closest_name(name: str, known: Iterable[str]) -> str | None:
    """Return the known name closest to ``name`` (for "did you mean" hints), or None."""
    matches = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return matches[0] if matches else None


class RuleFileDeprecationWarning(FutureWarning):
    """A rule file uses a form that still loads but will not forever (the message names
    FILE:LINE and what to change). A FutureWarning, so it is shown by default."""


class PlausibilityWarning(UserWarning):
    """A value that is physically possible but unusual (a 1.5 m organ, frames 60 stable
    steps apart, a tenth of a probe's force on fixed nodes): the message names the file or
    option, what is unusual and what it usually means. The command line prints it on stderr
    as ``neurofuzzy: warning: …`` once the command has succeeded."""
