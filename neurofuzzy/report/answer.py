"""The answer of a diagnosis that refits the set-up's likely mistakes (the load steps' and the
moved recording's, :mod:`neurofuzzy.diagnosis.load_steps`): what was named, and every
candidate's fall of χ² against the threshold (:func:`answer_section`)."""

from __future__ import annotations

import html

from .html import figure_html, table_html

__all__ = ["answer_label", "answer_section"]


def answer_label(names) -> str:
    """What a figure calls the model with the answer's effects (``names``)."""
    return "with " + ", ".join(names) if names != ["none"] else "nothing added: the base fit"


def answer_section(plt, names, record) -> str:
    """The effects named (``names``) and a bar of every candidate's χ² fall against the
    threshold (``record``: a diagnosis' ``to_dict()``, with ``candidates`` and
    ``threshold``), with their table."""
    falls = sorted(record["candidates"].items(), key=lambda item: -item[1])
    text = (f"<p>Answer: <b>{html.escape(', '.join(names))}</b>. Each candidate was refitted "
            "as the base fit was (the same steps) and scored by the fall of χ² with the base "
            f"fit's noise; one is named when χ² falls by more than {record['threshold']:g}, "
            "the best added and the others tried again on top of it.</p>")
    if not falls:
        return text + "<p class='note'>No candidate applies to this set-up.</p>"
    figure, ax = plt.subplots(figsize=(6.5, 0.5 + 0.45 * len(falls)))
    labels = [name for name, _ in falls][::-1]
    values = [fall for _, fall in falls][::-1]
    ax.barh(labels, values, color=["darkorange" if v > record["threshold"] else "0.6"
                                   for v in values])
    ax.axvline(record["threshold"], color="k", ls="--", lw=1, label="threshold")
    ax.set_xscale("symlog", linthresh=max(record["threshold"], 1.0))
    ax.set_xlabel("fall of χ² (negative: the candidate fits worse)")
    ax.legend(fontsize=8)
    return (text + figure_html(figure, "candidate scores")
            + table_html(["candidate", "fall of χ²", "named"],
                         [[name, fall, "yes" if name in names else "no"]
                          for name, fall in falls]))
