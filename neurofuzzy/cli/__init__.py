"""The ``neurofuzzy`` command: a thin shell over library calls (parsing, printing, exit codes).

Every sub-command reports bad input as one line on stderr (``neurofuzzy: error: FILE: …``) and
exits with status 2; ``--json`` output goes to stdout, progress to stderr.
"""

from __future__ import annotations

import functools
import sys
import warnings

from ..errors import NeurofuzzyError, PlausibilityWarning, RuleFileDeprecationWarning
from ..progress import announced
from .common import EXIT_BAD_INPUT

__all__ = ["main", "EXIT_BAD_INPUT"]


def main(argv: list[str] | None = None) -> int:
    from .options import unknown_option
    from .parser import build_parser

    parser = build_parser()
    unknown = unknown_option(parser, sys.argv[1:] if argv is None else list(argv))
    if unknown:                # before argparse: its message would not say which was meant
        print(f"neurofuzzy: error: {unknown}", file=sys.stderr)
        return EXIT_BAD_INPUT
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    held: list[str] = []           # our notes on the input, printed once the command succeeded
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", RuleFileDeprecationWarning)
            warnings.simplefilter("always", PlausibilityWarning)
            warnings.showwarning = functools.partial(_show_warning, held=held)
            with announced(not getattr(args, "quiet", False)      # rules, studio: no kernels
                           and args.command not in ("rules", "studio")):
                status = args.run(args) or 0
    except NeurofuzzyError as error:
        # one root cause: the notes on the input that led here are not repeated
        print(f"neurofuzzy: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as error:   # an output we cannot write: the user's path, not our bug
        print(f"neurofuzzy: error: {error.filename or ''}: {error.strerror or error}",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("neurofuzzy: interrupted", file=sys.stderr)
        return 130
    for line in dict.fromkeys(held):
        print(line, file=sys.stderr)
    return status


def _show_warning(message, category, filename, lineno, file=None, line=None, *, held):
    """Our notes on the input (deprecated rule-file forms, unusual values; they name FILE:LINE
    or the option themselves) are held as one line each and printed when the command
    succeeds; other warnings as usual, at once."""
    if issubclass(category, RuleFileDeprecationWarning):
        held.append(f"neurofuzzy: deprecated: {message}")
    elif issubclass(category, PlausibilityWarning):
        held.append(f"neurofuzzy: warning: {message}")
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line),
              file=sys.stderr, end="")
