"""The cohort report of ``fit-many``: every specimen's learned materials, the distribution and
the words of each group, and a comparison of the groups.

The comparison of two groups is the difference of their medians with a percentile bootstrap
interval (:func:`median_difference`): each group is resampled with replacement, separately,
``samples`` times, from a seeded generator, so the same cohort gives the same interval.
"""

from __future__ import annotations

import html
from collections import Counter
from itertools import combinations
from pathlib import Path

import numpy as np

from .manifest import relative_path
from .table import QUANTITIES, table_rows

__all__ = ["cohort_report", "cohort_summary", "median_difference", "REPORT_FORMAT"]

#: marks the JSON twin (a twin of another format is never overwritten)
REPORT_FORMAT = "neurofuzzy-cohort/1"
#: bootstrap resamples of each comparison
BOOTSTRAP_SAMPLES = 4000
UNITS = {"youngs_modulus": "Pa", "poisson_ratio": "", "viscosity": "Pa·s",
         "density": "kg/m³"}


def median_difference(first, second, *, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0,
                      level: float = 0.95) -> tuple[float, float, float]:
    """``median(second) - median(first)`` with a percentile bootstrap interval.

    Parameters
    ----------
    first, second : (n,) and (m,) float
        The values of two groups (n, m >= 1).
    samples : int
        Bootstrap resamples (each group resampled with replacement, independently).
    seed : int
        Seed of the generator.
    level : float
        Coverage of the interval.

    Returns
    -------
    difference, low, high : float
    """
    first, second = np.asarray(first, float), np.asarray(second, float)
    rng = np.random.default_rng(seed)
    resampled_first = first[rng.integers(0, first.size, (samples, first.size))]
    resampled_second = second[rng.integers(0, second.size, (samples, second.size))]
    differences = np.median(resampled_second, axis=1) - np.median(resampled_first, axis=1)
    tail = (1.0 - level) / 2.0
    low, high = np.quantile(differences, [tail, 1.0 - tail])
    return float(np.median(second) - np.median(first)), float(low), float(high)


def cohort_summary(cohort, *, seed: int = 0, samples: int = BOOTSTRAP_SAMPLES) -> dict:
    """The numbers of the cohort report (its JSON twin).

    Returns
    -------
    dict
        ``format``; ``specimens`` (the rows of :func:`~neurofuzzy.batch.table.table_rows`);
        ``groups`` (in the manifest's order); ``distributions`` (per region, quantity and
        group: ``n``, ``median``, ``min``, ``max``, ``values``); ``words`` (per region,
        quantity and group: word → count, and ``n``); ``comparisons`` (per region, quantity
        and pair of groups: ``difference`` of medians, ``interval``, ``relative``
        difference); ``failed`` (id, error); ``bootstrap`` (``samples``, ``seed``, ``level``).
    """
    rows = table_rows(cohort.specimens, cohort.records)
    fitted = [row for row in rows if row["status"] == "ok"]
    groups = list(dict.fromkeys(s.group for s in cohort.specimens))
    regions = list(dict.fromkeys(row["region"] for row in fitted))
    distributions, words, comparisons = [], [], []
    for region in regions:
        chosen = [row for row in fitted if row["region"] == region]
        for quantity in QUANTITIES:
            values = {g: np.array([r[quantity] for r in chosen if r["group"] == g
                                   and r[quantity] is not None], float) for g in groups}
            for group, array in values.items():
                if array.size:
                    distributions.append({
                        "region": region, "quantity": quantity, "group": group,
                        "n": int(array.size), "median": float(np.median(array)),
                        "min": float(array.min()), "max": float(array.max()),
                        "values": array.tolist()})
                counts = Counter(r[f"{quantity}_word"] for r in chosen
                                 if r["group"] == group and r[f"{quantity}_word"])
                if counts:
                    words.append({"region": region, "quantity": quantity, "group": group,
                                  "n": sum(1 for r in chosen if r["group"] == group),
                                  "words": dict(counts.most_common())})
            for first, second in combinations([g for g in groups if values[g].size], 2):
                if np.ptp(np.concatenate([values[first], values[second]])) == 0:
                    continue                  # the same for every specimen (ν of springs)
                difference, low, high = median_difference(values[first], values[second],
                                                          samples=samples, seed=seed)
                reference = float(np.median(values[first]))
                comparisons.append({
                    "region": region, "quantity": quantity, "groups": [first, second],
                    "n": [int(values[first].size), int(values[second].size)],
                    "difference": difference, "interval": [low, high],
                    "relative": difference / reference if reference else None,
                    "excludes_zero": bool(low > 0 or high < 0)})
    return {"format": REPORT_FORMAT, "specimens": rows, "groups": groups, "regions": regions,
            "distributions": distributions, "words": words, "comparisons": comparisons,
            "failed": [{"id": i, "error": cohort.records[i].get("error")}
                       for i in cohort.failed],
            "bootstrap": {"samples": samples, "seed": seed, "level": 0.95}}


def cohort_report(cohort, path, *, seed: int = 0, samples: int = BOOTSTRAP_SAMPLES,
                  title: str = "neurofuzzy cohort") -> Path:
    """Write the cohort report: one self-contained HTML file and its JSON twin.

    Sections: every specimen's learned materials, words and fit quality, linked to its own
    report; per group the distribution of each quantity (box and strip plots) and the words
    that describe it ("fibrotic: hard (8/10), firm (2/10)"); the comparison of the groups
    (difference of medians with a bootstrap 95 % interval); the failed specimens.

    Parameters
    ----------
    cohort : Cohort
        As returned by :func:`~neurofuzzy.batch.fit_many`.
    path : path
        The HTML file; the JSON twin (:func:`cohort_summary`) is written beside it.
    seed, samples
        Of the bootstrap.
    """
    from ..report import figure_html, table_html, write_report

    path = Path(path)
    summary = cohort_summary(cohort, seed=seed, samples=samples)
    several = len(summary["regions"]) > 1
    sections = [("Specimens", _specimen_table(summary, cohort.out, path, several, table_html))]
    if summary["distributions"]:
        sections.append(("Distributions per group", figure_html(
            _distribution_figure(summary, seed), "materials per group") +
            "<p class='note'>Boxes: quartiles and median; dots: the specimens.</p>"))
    if summary["words"]:
        sections.append(("Words per group", _words_html(summary, several, table_html)))
    if summary["comparisons"]:
        sections.append(("Group comparison", _comparison_html(summary, several, table_html)))
    elif len(summary["groups"]) > 1:
        sections.append(("Group comparison", "<p>Too few fitted specimens to compare.</p>"))
    if summary["failed"]:
        sections.append(("Failed specimens", table_html(
            ["id", "error"], [[f["id"], f["error"]] for f in summary["failed"]])))
    return write_report(path, title, sections, summary)


# -- sections ---------------------------------------------------------------------------------
class _Link:
    def __init__(self, text: str, href: str):
        self.text, self.href = text, href

    def __html__(self) -> str:
        return f'<a href="{html.escape(self.href)}">{html.escape(self.text)}</a>'


def _value(row, quantity) -> str:
    value, word = row[quantity], row[f"{quantity}_word"]
    if value is None:
        return ""
    return f"{value:.4g}" + (f" ({word})" if word else "")


def _specimen_table(summary, out: Path, path: Path, several: bool, table_html) -> str:
    header = ["id", "group", *(["region"] if several else []),
              *(f"{q} ({UNITS[q]})" if UNITS[q] else q for q in QUANTITIES),
              "RMS error (µm)", "noise ratio", "status"]
    rows = []
    for row in summary["specimens"]:
        target = (out / row["id"] / "report.html").resolve()
        ident = (_Link(row["id"], relative_path(target, path.resolve().parent))
                 if row["status"] == "ok" else row["id"])
        rms = "" if row["rms_error"] is None else f"{row['rms_error'] * 1e6:.3g}"
        ratio = "" if row["noise_ratio"] is None else f"{row['noise_ratio']:.3g}"
        rows.append([ident, row["group"], *([row["region"]] if several else []),
                     *(_value(row, q) for q in QUANTITIES), rms, ratio,
                     row["status"] if row["status"] == "ok" else f"{row['status']}: "
                     f"{row['error'] or ''}"])
    return (table_html(header, rows) +
            "<p class='note'>Noise ratio: RMS error over the marker noise estimated from the "
            "residual (1: the fit explains all but the noise; empty for noise-free data). "
            "Each id links to the specimen's own report.</p>")


def _words_html(summary, several: bool, table_html) -> str:
    groups = summary["groups"]
    cells = {}
    for entry in summary["words"]:
        counted = ", ".join(f"{word} ({count}/{entry['n']})"
                            for word, count in entry["words"].items())
        row = cells.setdefault((entry["region"], entry["quantity"]), dict.fromkeys(groups, ""))
        row[entry["group"]] = f"{entry['group']}: {counted}"
    rows = [[*([region] if several else []), quantity, *row.values()]
            for (region, quantity), row in cells.items()]
    return (table_html([*(["region"] if several else []), "quantity", *groups], rows) +
            "<p class='note'>The rule base's word for each specimen's learned value, counted "
            "per group (specimens with the word / fitted specimens of the group).</p>")


def _comparison_html(summary, several: bool, table_html) -> str:
    rows = []
    for entry in summary["comparisons"]:
        first, second = entry["groups"]
        low, high = entry["interval"]
        relative = "" if entry["relative"] is None else f"{entry['relative']:+.1%}"
        unit = UNITS[entry["quantity"]]
        rows.append([*([entry["region"]] if several else []),
                     entry["quantity"] + (f" ({unit})" if unit else ""),
                     f"{second} − {first}", f"{entry['n'][1]} / {entry['n'][0]}",
                     f"{entry['difference']:.4g}", relative, f"[{low:.4g}, {high:.4g}]",
                     "yes" if entry["excludes_zero"] else "no"])
    bootstrap = summary["bootstrap"]
    return (table_html([*(["region"] if several else []), "quantity", "groups", "n",
                        "difference of medians", "relative", "95 % bootstrap interval",
                        "excludes 0"], rows) +
            f"<p class='note'>Percentile bootstrap: {bootstrap['samples']} resamples of each "
            f"group, seed {bootstrap['seed']}. With few specimens per group the interval is "
            "rough; quantities equal in every specimen are left out.</p>")


def _distribution_figure(summary, seed: int):
    from ..report import pyplot as _pyplot

    plt = _pyplot()
    panels = list(dict.fromkeys((d["region"], d["quantity"]) for d in summary["distributions"]))
    groups = summary["groups"]
    figure, axes = plt.subplots(1, len(panels), figsize=(3.4 * len(panels), 3.6),
                                squeeze=False)
    jitter = np.random.default_rng(seed)
    for ax, (region, quantity) in zip(axes[0], panels):
        entries = {d["group"]: d["values"] for d in summary["distributions"]
                   if d["region"] == region and d["quantity"] == quantity}
        present = [g for g in groups if g in entries]
        ax.boxplot([entries[g] for g in present], widths=0.5, showfliers=False)
        for index, group in enumerate(present, start=1):
            values = np.asarray(entries[group])
            ax.scatter(index + jitter.uniform(-0.12, 0.12, values.size), values, s=16,
                       alpha=0.8, zorder=3)
        ax.set_xticks(range(1, len(present) + 1), present)
        values = np.concatenate([entries[g] for g in present])
        if values.min() > 0 and values.max() > 10 * values.min():
            ax.set_yscale("log")
        unit = f" ({UNITS[quantity]})" if UNITS[quantity] else ""
        ax.set_title(f"{quantity}{unit}" + (f"\n{region}" if len(summary["regions"]) > 1
                                            else ""), fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
    figure.tight_layout()
    return figure
