"""Self-contained HTML reports (plots embedded as PNG) with a JSON twin: of a fit
(:func:`fit_report`), of a diagnosis (:func:`diagnosis_report`); the page, tables and figures
(:mod:`.html`) for other reports (the cohort's). matplotlib is imported only inside the
functions that plot."""

from .diagnosis import diagnosis_report
from .fit import fit_report, identifiability_html
from .html import REPORT_MARKER, figure_html, pyplot, table_html, write_report

__all__ = ["fit_report", "diagnosis_report", "identifiability_html", "write_report",
           "figure_html", "table_html", "pyplot", "REPORT_MARKER"]
