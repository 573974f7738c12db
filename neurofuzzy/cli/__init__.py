"""The ``neurofuzzy`` command: a thin shell over library calls (parsing, printing, exit codes).

Every sub-command reports bad input as one line on stderr (``neurofuzzy: error: FILE: …``) and
exits with status 2; ``--json`` output goes to stdout, progress to stderr.
"""

from __future__ import annotations

import sys
import warnings

from ..errors import NeurofuzzyError, RuleFileDeprecationWarning
from .common import EXIT_BAD_INPUT

__all__ = ["main", "EXIT_BAD_INPUT"]


def main(argv: list[str] | None = None) -> int:
    from .parser import build_parser

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", RuleFileDeprecationWarning)
            warnings.showwarning = _show_warning
            return args.run(args) or 0
    except NeurofuzzyError as error:
        print(f"neurofuzzy: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as error:   # an output we cannot write: the user's path, not our bug
        print(f"neurofuzzy: error: {error.filename or ''}: {error.strerror or error}",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("neurofuzzy: interrupted", file=sys.stderr)
        return 130


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Our deprecation notes as one line (they name FILE:LINE themselves); others as usual."""
    if issubclass(category, RuleFileDeprecationWarning):
        print(f"neurofuzzy: deprecated: {message}", file=sys.stderr)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line),
              file=sys.stderr, end="")
