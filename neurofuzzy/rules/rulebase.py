"""The :class:`RuleBase`: a parsed, validated rule base and its three jobs (infer values from
words, describe values in words, explain values by words)."""

from __future__ import annotations

import numpy as np

from . import inference, words
from .terms import Label, Phrase, Rule, Variable

__all__ = ["RuleBase"]


class RuleBase:
    """A parsed, validated rule base (use :func:`load_rules`)."""

    def __init__(self, *, name, source, inputs, outputs, rules, tissues, defuzzification,
                 and_method, or_method, renamed=None, tissue_lines=None, files=None):
        self.name = name
        self.source = source
        self.inputs: dict[str, Variable] = inputs
        self.outputs: dict[str, Variable] = outputs
        self.rules: list[Rule] = rules
        self.tissues: dict[str, dict[str, Phrase]] = tissues
        self.defuzzification = defuzzification
        self.and_method = and_method
        self.or_method = or_method
        #: old output names of a deprecated file → their new names (:mod:`.parser`)
        self.renamed: dict[str, str] = dict(renamed or {})
        #: tissue name → (rule file, line) where it is described (for messages)
        self.tissue_lines: dict[str, tuple[str, int]] = dict(tissue_lines or {})
        #: (file, sha256) of every file read: this one first, then the files it extends
        self.files: list[tuple[str, str]] = list(files or [])

    @property
    def sha256(self) -> str | None:
        """Checksum of the rule file as read (``sha256sum FILE``), None for a rule base
        built without a file."""
        return self.files[0][1] if self.files else None

    @property
    def origin(self) -> str:
        """Which file this is, in one line: ``rules/liver.yaml (sha256 1a2b3c4d…)``."""
        return f"{self.source} (sha256 {self.sha256[:8]}…)" if self.sha256 else str(self.source)

    def provenance(self) -> dict:
        """Which file this rule base was read from, for records (``fit --json``, model files,
        reports): ``{"path": absolute path, "sha256": ..., "extends": [{"path", "sha256"},
        ...]}`` (``extends`` only when the file extends others)."""
        from pathlib import Path

        files = [{"path": str(Path(path).resolve()), "sha256": digest}
                 for path, digest in self.files] or [{"path": str(self.source), "sha256": None}]
        return {**files[0], **({"extends": files[1:]} if files[1:] else {})}

    @property
    def variables(self) -> dict[str, Variable]:
        return {**self.inputs, **self.outputs}

    def infer(self, descriptions: list[dict]) -> dict[str, np.ndarray]:
        """Output values for many descriptions at once (:func:`.inference.infer`)."""
        return inference.infer(self, descriptions)

    def rule_strengths(self, descriptions: list[dict]) -> np.ndarray:
        """(n_rules, n_descriptions) how strongly every rule fires for every description
        (:func:`.inference.rule_strengths`)."""
        return inference.rule_strengths(self, descriptions)

    def tissue(self, name: str) -> dict[str, float]:
        """Inferred output values (physical units) of a tissue of the rule base."""
        return inference.tissue_values(self, name)

    def tissue_sets(self, name: str) -> dict[str, np.ndarray]:
        """The inferred output fuzzy sets of a tissue, before defuzzification, on each
        output's grid (:func:`.inference.tissue_sets`)."""
        return inference.tissue_sets(self, name)

    def describe(self, values: dict[str, float]) -> dict[str, Label]:
        """For every output value: the term with the highest membership and all degrees."""
        return words.describe(self, self._current(values))

    def explain(self, values: dict[str, float], *, hedges=("very", "somewhat")) -> dict:
        """The input words whose inferred outputs come closest to ``values``
        (:func:`.words.explain`)."""
        return words.explain(self, self._current(values), hedges=hedges)

    def deciding(self, outputs) -> set[str]:
        """The input variables of the rules that conclude on any of ``outputs`` (names)."""
        outputs = set(outputs)
        return {clause.variable for rule in self.rules
                if any(c.variable in outputs for c in rule.consequents)
                for group in rule.antecedent for clause in group}

    def defaults_taken(self, description: dict) -> dict[str, Phrase]:
        """The inputs ``description`` (a tissue's words) leaves out, with the default words
        it takes for each (inputs without a default are left out: their rules do not fire,
        :func:`.inference.undescribed`)."""
        return {name: variable.default for name, variable in self.inputs.items()
                if description.get(name) is None and variable.default is not None}

    def _current(self, values: dict) -> dict:
        """Values keyed by an old (renamed) output name, under the new one."""
        return {self.renamed.get(name, name): value for name, value in values.items()}

    def summary(self) -> str:
        lines = [f"rule base {self.name!r} ({self.origin})"]
        for role, variables in (("input", self.inputs), ("output", self.outputs)):
            for v in variables.values():
                unit = f" {v.unit}" if v.unit else ""
                quantity = f" = {v.quantity}" if v.quantity else ""
                default = f"; default {v.default}" if v.default is not None else ""
                lines.append(f"  {role} {v.name}{quantity}: {v.low:g}..{v.high:g}{unit} "
                             f"({v.scale}); terms: {', '.join(v.terms)}{default}")
        lines.append(f"  {len(self.rules)} rules; defuzzification {self.defuzzification}, "
                     f"and={self.and_method}, or={self.or_method}")
        lines.append(f"  tissues: {', '.join(self.tissues) or '(none)'}")
        return "\n".join(lines)
