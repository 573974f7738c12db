"""The package's layers hold (docs/architecture.md): no import cycle between modules or between
packages, no private module or name imported across packages, no module much over 400 lines,
and the compiled kernels import nothing of the toolkit but each other.

Imports are read from the source with :mod:`ast`, function-level imports included (a cycle
hidden in a function body is still a cycle)."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "neurofuzzy"
#: "no module over about 400 lines" (issue 26); the hook that reviews every change flags 450
MAX_LINES = 420


def _modules() -> dict[str, Path]:
    modules = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        modules[".".join(parts)] = path
    return modules


MODULES = _modules()


def _imports(name: str) -> list[tuple[str, str | None]]:
    """``(module, imported name or None)`` for every import of the toolkit in ``name``."""
    path = MODULES[name]
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            target = ".".join(base + ([node.module] if node.module else []))
            if target.split(".")[0] != "neurofuzzy":
                continue
            for alias in node.names:
                child = f"{target}.{alias.name}"
                out.append((child, None) if child in MODULES else (target, alias.name))
        elif isinstance(node, ast.Import):
            out += [(alias.name, None) for alias in node.names
                    if alias.name.split(".")[0] == "neurofuzzy"]
    return out


def _graph() -> dict[str, set[str]]:
    return {name: {target for target, _ in _imports(name) if target in MODULES and target != name}
            for name in MODULES}


def _unit(name: str) -> str:
    """The package a module belongs to (``neurofuzzy.learn``), or the module itself for the
    modules at the top of the package."""
    parts = name.split(".")
    if len(parts) > 2 or (len(parts) == 2 and MODULES[name].name == "__init__.py"):
        return ".".join(parts[:2])
    return name


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one node (Tarjan)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node):
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in graph.get(node, ()):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                other = stack.pop()
                on_stack.discard(other)
                component.append(other)
                if other == node:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def test_no_module_imports_itself_back():
    assert _cycles(_graph()) == []


def test_no_package_imports_itself_back():
    packages: dict[str, set[str]] = {}
    for name, targets in _graph().items():
        for target in targets:
            if name != "neurofuzzy" and target != "neurofuzzy" and _unit(name) != _unit(target):
                packages.setdefault(_unit(name), set()).add(_unit(target))
    assert _cycles(packages) == []


def _private(module: str, name: str | None) -> bool:
    parts = module.split(".")[1:] + ([name] if name else [])
    return any(part.startswith("_") and not part.startswith("__") for part in parts)


def test_private_modules_and_names_stay_inside_their_package():
    """One rule for underscore modules: ``_name`` is private to its package (the top of the
    package counts as one package); other packages go through its public modules."""
    crossing = [f"{name} imports {target}{'.' + what if what else ''}"
                for name in MODULES for target, what in _imports(name)
                if _private(target, what) and target in MODULES
                and _unit(name).split(".")[:2] != _unit(target).split(".")[:2]
                and not (len(_unit(target).split(".")) == 2 and _unit(target) == target
                         and _unit(name) == name)]
    assert crossing == []


def test_the_compiled_kernels_import_only_each_other():
    for name in MODULES:
        if name.startswith("neurofuzzy.kernels"):
            outside = [t for t, _ in _imports(name) if not t.startswith("neurofuzzy.kernels")]
            assert outside == [], name


def _inlined(function: ast.FunctionDef) -> bool:
    """Whether ``function`` is decorated ``numba.njit(..., inline="always")``."""
    return any(isinstance(decorator, ast.Call) and any(
        keyword.arg == "inline" and isinstance(keyword.value, ast.Constant)
        and keyword.value.value == "always" for keyword in decorator.keywords)
        for decorator in function.decorator_list)


def _loops_over_items(function: ast.FunctionDef) -> list[str]:
    """The ``range(...)`` bounds of ``function``'s loops that count items (elements, nodes,
    springs, a thread's run): any bound but a number or a count along an array's second
    axis (Prony terms, tangent columns)."""
    def within_an_item(bound: ast.expr) -> bool:
        if isinstance(bound, ast.Constant):
            return True
        return (isinstance(bound, ast.Subscript) and isinstance(bound.value, ast.Attribute)
                and bound.value.attr == "shape"
                and isinstance(bound.slice, ast.Constant) and bound.slice.value > 0)

    bounds = []
    for node in ast.walk(function):
        if (isinstance(node, ast.For) and isinstance(node.iter, ast.Call)
                and getattr(node.iter.func, "id", None) in ("range", "prange")
                and not all(within_an_item(bound) for bound in node.iter.args)):
            bounds.append(ast.unparse(node.iter))
    return bounds


def test_an_inlined_kernel_does_not_loop_over_the_items():
    """numba copies an inlined function's body, with everything inlined into it, into each
    caller: a per-item function is worth it, a pass over the items is not (it only added to
    the compilation: ``neurofuzzy/kernels/__init__.py``)."""
    found, loops = 0, {}
    for name, path in MODULES.items():
        if name.startswith("neurofuzzy.kernels"):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.FunctionDef) and _inlined(node):
                    found += 1
                    if bounds := _loops_over_items(node):
                        loops[f"{name}.{node.name}"] = bounds
    assert found > 20               # the check reads the decorators it means to
    assert loops == {}


def test_the_inlining_check_sees_a_pass():
    source = ('@numba.njit(cache=True, inline="always")\n'
              'def f(a, g):\n'
              '    for k in range(g.shape[1]):\n        pass\n'
              '    for i in range(a.shape[0]):\n        pass\n')
    function = ast.parse(source).body[0]
    assert _inlined(function) and _loops_over_items(function) == ["range(a.shape[0])"]


#: "no kernel signature longer than about ten arguments" (issue 44): the kernels the rest of
#: the package calls take the model in groups (tuples, named where numba reads their fields)
MAX_KERNEL_ARGUMENTS = 10


def _kernel_arguments() -> dict[str, int]:
    """``{"module.function": its parameter count}`` of every compiled kernel that a module
    outside ``neurofuzzy.kernels`` imports."""
    counts = {}
    for name in MODULES:
        if name.startswith("neurofuzzy.kernels"):
            continue
        for target, what in _imports(name):
            if not target.startswith("neurofuzzy.kernels.") or what is None:
                continue
            tree = ast.parse(MODULES[target].read_text(encoding="utf-8"))
            for node in tree.body:
                if isinstance(node, ast.FunctionDef) and node.name == what:
                    counts[f"{target}.{what}"] = len(node.args.args)
    return counts


def test_the_kernels_the_package_calls_take_the_model_in_groups():
    counts = _kernel_arguments()
    assert {"neurofuzzy.kernels.stepper.frames", "neurofuzzy.kernels.sensitivity.forward",
            "neurofuzzy.kernels.adjoint.pull_back"} <= set(counts)
    assert {name: n for name, n in counts.items() if n > MAX_KERNEL_ARGUMENTS} == {}


def test_the_rules_hold_words_only():
    """DESIGN's layers: ``rules`` never imports the physics (models, forces, constants); what
    joins a rule base to a model is :mod:`neurofuzzy.tissues`. The rules may read YAML through
    the toolkit's safe loader and raise its errors."""
    def words(module):
        return module == "neurofuzzy.rules" or module.startswith("neurofuzzy.rules.")

    allowed = {"neurofuzzy.errors", "neurofuzzy.io.safe_yaml"}
    outside = {f"{name} imports {target}" for name in MODULES if words(name)
               for target, _ in _imports(name) if not (words(target) or target in allowed)}
    assert outside == set()


def test_the_physics_does_not_read_words():
    """The constants (material values ↔ term constants), the models and the terms import
    no rule base; :mod:`neurofuzzy.tissues` uses a rule base through its methods."""
    physics = ("neurofuzzy.constants", "neurofuzzy.model", "neurofuzzy.forces",
               "neurofuzzy.effects", "neurofuzzy.kernels", "neurofuzzy.mesh",
               "neurofuzzy.tissues")
    readers = {name for name in MODULES if name.startswith(physics)
               and any(t == "neurofuzzy.rules" or t.startswith("neurofuzzy.rules.")
                       for t, _ in _imports(name))}
    assert readers == set()


def test_the_learners_read_no_files_and_choose_no_start():
    """DESIGN: "the learner never reads files". Model files, experiments and the start of a fit
    (a model file, a rule base's tissue) are the pipeline's (:mod:`neurofuzzy.pipeline`); the
    learners get objects: the prior a loaded rule base, used through its methods. (``learn``
    formats its results with :func:`neurofuzzy.formatting.json_safe`, outside ``io``.)"""
    found = {f"{name} imports {target}" for name in MODULES if name.startswith("neurofuzzy.learn")
             for target, _ in _imports(name)
             if target.startswith(("neurofuzzy.io", "neurofuzzy.pipeline", "neurofuzzy.tissues",
                                   "neurofuzzy.rules"))}
    assert found == set()


def test_the_reports_draw_what_they_are_handed():
    """Issue 44: a report draws the outcome of a fit or a diagnosis; it computes no fit
    result itself, so ``report`` imports nothing from ``learn``."""
    found = {f"{name} imports {target}" for name in MODULES if name.startswith("neurofuzzy.report")
             for target, _ in _imports(name) if target.startswith("neurofuzzy.learn")}
    assert found == set()


LEARNERS = {"GradientLearner", "PaperLearner"}


def _learner_imports(name: str) -> set[str]:
    """The learner classes and modules ``name`` imports."""
    modules = ("neurofuzzy.learn.gradient", "neurofuzzy.learn.paper")
    return ({target for target, _ in _imports(name) if target in modules}
            | {f"{target}.{what}" for target, what in _imports(name) if what in LEARNERS})


def test_the_diagnosis_and_the_demo_fit_through_nf_fit():
    """Issue 44: one fit path. The diagnosis's fits and refits, its localisation and the demo
    call :func:`neurofuzzy.fit` with one :class:`~neurofuzzy.pipeline.FitOptions`; none of
    them makes a learner itself."""
    users = ["neurofuzzy.demo"] + [name for name in MODULES
                                   if name.startswith("neurofuzzy.diagnosis")]
    found = {f"{name} imports {what}" for name in users for what in _learner_imports(name)}
    assert found == set()
    fitting = {name for name in users
               if ("neurofuzzy.pipeline", "fit") in _imports(name)}
    assert {"neurofuzzy.demo", "neurofuzzy.diagnosis.refits"} <= fitting


def test_the_fit_and_diagnose_commands_assemble_no_pipeline():
    """Issue 44: ``neurofuzzy fit`` and ``neurofuzzy diagnose`` of time series hand their
    options to the library's pipelines (:func:`neurofuzzy.fit`,
    :func:`neurofuzzy.diagnosis.diagnose_data`); neither starts, checks or explains a fit
    itself."""
    names = {what for target, what in _imports("neurofuzzy.cli.fitting")
             if target.startswith(("neurofuzzy.pipeline", "neurofuzzy.plausibility"))}
    assert names & {"start_model", "check_outcome", "explained", "check_fit_inputs",
                    "make_prior", "require_motion"} == set()
    assert ("neurofuzzy.diagnosis", "diagnose_data") in _imports("neurofuzzy.cli.fitting")


def test_the_fit_report_draws_a_fit_outcome_not_a_learner():
    """Issue 44: ``report/fit.py`` reads what a :class:`~neurofuzzy.pipeline.FitOutcome`
    offers; no ``.learner`` and no ``getattr`` guessing which learner made it."""
    tree = ast.parse((PACKAGE / "report" / "fit.py").read_text(encoding="utf-8"))
    found = {node.attr for node in ast.walk(tree)
             if isinstance(node, ast.Attribute) and node.attr == "learner"}
    found |= {node.func.id for node in ast.walk(tree)
              if isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id == "getattr"}
    assert found == set()


def test_the_learner_check_sees_a_learner_import(tmp_path, monkeypatch):
    path = tmp_path / "refit.py"
    path.write_text("from ..learn import GradientLearner\nfrom ..learn.paper import x\n")
    monkeypatch.setitem(MODULES, "neurofuzzy.diagnosis.refit", path)
    assert _learner_imports("neurofuzzy.diagnosis.refit") == {
        "neurofuzzy.learn.GradientLearner", "neurofuzzy.learn.paper"}


def test_nothing_imports_the_command_line():
    users = [name for name in MODULES if not name.startswith("neurofuzzy.cli")
             and any(t.startswith("neurofuzzy.cli") for t, _ in _imports(name))]
    assert users == []


def test_only_the_datasets_import_the_validation_code():
    """neurofuzzy.validation makes data to validate against with other solvers; the toolkit's
    own code does not depend on it, but for the paper cube's RK4 data (datasets)."""
    users = {name for name in MODULES if not name.startswith("neurofuzzy.validation")
             and name != "neurofuzzy"
             and any(t.startswith("neurofuzzy.validation") for t, _ in _imports(name))}
    assert users == {"neurofuzzy.datasets"}


def test_nothing_imports_the_nonlinear_reference():
    """neurofuzzy.validation.nonlinear is validation code (and needs sfepy): it may import
    the toolkit, never the reverse."""
    users = [name for name in MODULES if not name.startswith("neurofuzzy.validation.nonlinear")
             and any(t.startswith("neurofuzzy.validation.nonlinear") for t, _ in _imports(name))]
    assert users == []


@pytest.mark.parametrize("name", sorted(MODULES))
def test_no_module_is_much_over_400_lines(name):
    lines = MODULES[name].read_text(encoding="utf-8").count("\n")
    assert lines <= MAX_LINES, f"{MODULES[name]}: {lines} lines"


def test_the_checks_see_a_cycle_and_a_private_import():
    """The checks above are not vacuous."""
    assert _cycles({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]
    assert _private("neurofuzzy.learn._compiled", None)
    assert _private("neurofuzzy.rules", "_helper")
    assert not _private("neurofuzzy.version", "__version__")
    assert len(_graph()["neurofuzzy.learn.gradient"]) > 3
