"""JSON-ready values: numpy scalars and arrays to Python, non-finite floats to ``None``."""

from __future__ import annotations

import numpy as np

__all__ = ["json_safe"]


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
