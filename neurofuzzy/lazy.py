"""Lazy re-exports of a package (PEP 562): names imported from their modules on first use, so
that importing the package stays fast and loads scipy, numba or the simulator only when a part
needs them."""

from __future__ import annotations

from importlib import import_module

__all__ = ["lazy"]


def lazy(package: str, exports: dict[str, str], aliases: dict[str, str] | None = None):
    """``(__getattr__, __dir__)`` for ``package``: ``exports`` maps every name to its module
    (relative to the package), ``aliases`` a name to the module's own name for it. A name is
    imported once and then kept in the package's namespace."""
    aliases = aliases or {}
    namespace = import_module(package).__dict__

    def __getattr__(name: str):
        if name in exports:
            module = import_module(f".{exports[name]}", package)
            value = getattr(module, aliases.get(name, name))
            namespace[name] = value
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__():
        return sorted(set(namespace) | set(exports))

    return __getattr__, __dir__
