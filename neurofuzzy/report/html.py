"""The page itself: self-contained HTML (plots embedded as PNG) with a JSON twin, written
atomically; tables and figures as HTML. matplotlib is imported only by :func:`pyplot`."""

from __future__ import annotations

import base64
import html
import io
import json
from pathlib import Path

import numpy as np

from ..formatting import json_safe
from ..io.writing import atomic_write

__all__ = ["write_report", "figure_html", "table_html", "pyplot", "REPORT_MARKER"]

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { font-size: 1.6em; } h2 { font-size: 1.25em; margin-top: 1.6em; border-bottom: 1px solid #ddd; }
table { border-collapse: collapse; margin: 0.8em 0; } td, th { padding: 4px 10px; border: 1px solid #ddd; }
th { background: #f4f4f4; text-align: left; } .changed { background: #fff3c4; font-weight: 600; }
.note { color: #555; font-size: 0.92em; } img { max-width: 100%; }
"""


def pyplot():
    """matplotlib's pyplot on the Agg backend (imported on first use)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_html(figure, alt: str) -> str:
    """Embed a matplotlib figure as a PNG data URI and close it."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    pyplot().close(figure)
    encoded = base64.b64encode(buffer.getvalue()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{encoded}">'


def table_html(header: list[str], rows: list[list], highlight: list[bool] | None = None) -> str:
    """An HTML table; rows flagged in ``highlight`` are marked as changed. Cells are text,
    except values with an ``__html__`` method, whose markup is used as it is."""
    out = ["<table><tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>"]
    for index, row in enumerate(rows):
        css = ' class="changed"' if highlight and highlight[index] else ""
        out.append(f"<tr{css}>" + "".join(f"<td>{_cell(c)}</td>" for c in row) + "</tr>")
    return "".join(out) + "</table>"


def _cell(value) -> str:
    """A cell's HTML: escaped text, or the markup of a value that has ``__html__`` (a link)."""
    return value.__html__() if hasattr(value, "__html__") else html.escape(_fmt(value))


def _fmt(value) -> str:
    if isinstance(value, (float, np.floating)):
        return f"{value:.4g}"
    return str(value)


#: the key of a report's JSON twin that says neurofuzzy wrote it (the command line replaces
#: an existing twin only if it has it)
REPORT_MARKER = "generator"


def write_report(path, title: str, sections: list[tuple[str, str]], data: dict) -> Path:
    """Write ``path`` (HTML) and its JSON twin (same name, ``.json``) atomically."""
    path = Path(path)
    data = {REPORT_MARKER: f"neurofuzzy report: {title}", **data}
    body = "".join(f"<h2>{html.escape(heading)}</h2>{content}" for heading, content in sections)
    page = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title><style>{_STYLE}</style></head><body><h1>{html.escape(title)}</h1>"
            f"{body}</body></html>")
    twin = path.with_suffix(".json")
    with atomic_write(twin, "w") as handle:
        json.dump(json_safe(data), handle, indent=2)
    with atomic_write(path, "w") as handle:
        handle.write(page)
    return path
