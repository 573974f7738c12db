"""``neurofuzzy studio``: the rule studio in the browser (:func:`neurofuzzy.studio`)."""

from __future__ import annotations

__all__ = ["studio"]


def studio(args) -> int:
    from ..errors import InputError
    from ..rulestudio import studio as run_studio

    if not 0 <= args.port <= 65535:
        raise InputError(f"got {args.port}; expected a port in 0..65535 (0: any free one)",
                         key="--port")
    run_studio(args.rules, host=args.host, port=args.port,
               open_browser=not args.no_browser, block=True)
    return 0
