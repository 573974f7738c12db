"""How results are written: lengths for people (the one way the toolkit prints a length: the
command line, progress, reports, fits' verdicts) and values for JSON."""

from __future__ import annotations

import numpy as np

__all__ = ["length_text", "json_safe"]


def length_text(metres: float) -> str:
    """A length with a unit people read: ``41.2 µm``, ``1.23 mm``, ``4.5 cm``."""
    if not np.isfinite(metres):
        return str(metres)
    size = abs(metres)
    unit, scale = (("m", 1.0) if size >= 1 else ("cm", 1e-2) if size >= 1e-2
                   else ("mm", 1e-3) if size >= 1e-3 else ("µm", 1e-6))
    return f"{metres / scale:.3g} {unit}"


def json_safe(value):
    """``value`` with every dict, list, tuple and array converted recursively so that
    ``json.dumps`` accepts it and writes no ``NaN``/``Infinity`` (they become ``null``)."""
    if isinstance(value, dict):
        return {str(key): json_safe(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(item) for item in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    return value
