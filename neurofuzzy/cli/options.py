"""A mistyped option gets "did you mean" (``unknown option --rulse; did you mean --rules?``)
before argparse, whose own message ("unrecognized arguments", or a required option reported
missing) would not say which option was meant."""

from __future__ import annotations

import argparse

from ..errors import closest_name

__all__ = ["unknown_option"]


def unknown_option(parser: argparse.ArgumentParser, argv: list[str]) -> str | None:
    """The message for the first ``--option`` of ``argv`` that its command does not know, or
    None when every one is known (or an abbreviation argparse accepts).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The ``neurofuzzy`` parser (:func:`~.parser.build_parser`).
    argv : list of str
        The command line without the program name.
    """
    command, names = parser, ["neurofuzzy"]
    for token in argv:
        if token == "--":
            break
        if token.startswith("--"):
            option = token.split("=", 1)[0]
            known = [s for action in command._actions for s in action.option_strings
                     if s.startswith("--")]
            if any(name.startswith(option) for name in known):
                continue
            hint = closest_name(option, known)
            return f"unknown option {option}" + (
                f"; did you mean {hint}?" if hint else
                f" ({' '.join(names)} --help lists the options)")
        elif not token.startswith("-"):
            commands = _subcommands(command)
            if token in commands:
                command = commands[token]
                names.append(token)
    return None


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The sub-command parsers of ``parser`` by name (none for a command's own parser)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}
