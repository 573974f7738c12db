"""What every command shares: JSON output, refusing to write over inputs, "wrote" lines."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from ..serialization import json_safe
from ..errors import InputError

__all__ = ["EXIT_BAD_INPUT", "print_json", "refuse_overwrite", "written", "usage"]

EXIT_BAD_INPUT = 2


def print_json(value) -> None:
    """One JSON object on stdout (non-finite numbers as null)."""
    print(json.dumps(json_safe(value)))


def refuse_overwrite(out, inputs) -> None:
    """Refuse an output path that names one of the ``inputs`` (never write over input)."""
    if out is None:
        return
    target = Path(out).resolve()
    for path in inputs:
        if path is not None and Path(path).exists() and Path(path).resolve() == target:
            raise InputError("--out names an input file; neurofuzzy never writes over its input",
                             source=str(out))


def written(*paths) -> None:
    for path in paths:
        if path:
            print(f"wrote {path}")


def usage(parser) -> int:
    parser.print_help(sys.stderr)
    return EXIT_BAD_INPUT
