"""The same rule base as a :mod:`skfuzzy.control` system, to cross-check our inference.

Only for comparison (tests and ``benchmarks/run.py``): ``skfuzzy.control`` evaluates one crisp
input at a time and keeps results on shared objects; :meth:`RuleBase.infer` is vectorised over
many (fuzzy or crisp) descriptions. Hedged terms are materialised as extra terms.
"""

from __future__ import annotations

import numpy as np

from .rulebase import RuleBase
from .membership import apply_hedges

__all__ = ["control_system", "control_infer"]


def control_system(rules: RuleBase):
    """``(ControlSystem, antecedents, consequents)`` equivalent to ``rules``."""
    from skfuzzy import control as ctrl

    def term(variable, fuzzy, phrase):
        label = " ".join(phrase.hedges + (phrase.term,))
        if label not in fuzzy.terms:
            fuzzy[label] = apply_hedges(variable.terms[phrase.term].values, phrase.hedges)
        return fuzzy[label]

    antecedents, consequents = {}, {}
    for name, variable in rules.inputs.items():
        antecedents[name] = ctrl.Antecedent(variable.grid, name)
        for t in variable.terms.values():
            antecedents[name][t.name] = t.values
    for name, variable in rules.outputs.items():
        consequents[name] = ctrl.Consequent(variable.grid, name,
                                            defuzzify_method=rules.defuzzification)
        for t in variable.terms.values():
            consequents[name][t.name] = t.values
    control_rules = []
    for rule in rules.rules:
        expression = None
        for group in rule.antecedent:
            conjunction = None
            for clause in group:
                item = term(rules.inputs[clause.variable], antecedents[clause.variable],
                            clause.phrase)
                conjunction = item if conjunction is None else conjunction & item
            expression = conjunction if expression is None else expression | conjunction
        outputs = [term(rules.outputs[c.variable], consequents[c.variable], c.phrase)
                   for c in rule.consequents]
        control_rule = ctrl.Rule(expression, outputs[0] if len(outputs) == 1 else outputs)
        if rule.weight != 1.0:
            raise ValueError("skfuzzy.control has no rule weights")
        control_rules.append(control_rule)
    return ctrl.ControlSystem(control_rules), antecedents, consequents


def control_infer(rules: RuleBase, inputs: list[dict]) -> dict[str, np.ndarray]:
    """Crisp inputs (internal coordinates) → outputs (physical units), one at a time."""
    from skfuzzy import control as ctrl

    system, _, _ = control_system(rules)
    simulation = ctrl.ControlSystemSimulation(system)
    results = {name: [] for name in rules.outputs}
    for values in inputs:
        for name, value in values.items():
            simulation.input[name] = value
        simulation.compute()
        for name, variable in rules.outputs.items():
            results[name].append(float(variable.to_physical(simulation.output[name])))
    return {name: np.array(v) for name, v in results.items()}
