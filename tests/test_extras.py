"""A missing optional dependency is one line naming the extra to install, exit status 2, never
a traceback, checked before any work (issue 50)."""

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from neurofuzzy.cli import main
from neurofuzzy.errors import MissingDependencyError
from neurofuzzy.extras import EXTRAS, require

ROOT = Path(__file__).resolve().parents[1]


def _hide(monkeypatch, *modules):
    """Make ``modules`` look uninstalled (``import`` fails, ``find_spec`` finds nothing)."""
    for module in modules:
        monkeypatch.setitem(sys.modules, module, None)


def test_the_extras_are_pyprojects():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    for extra, packages in EXTRAS.items():
        requirements = declared[extra]
        names = {re.match(r"[A-Za-z0-9_.-]+", r).group(0) for r in requirements}
        bracketed = {x for r in requirements for x in re.findall(r"\[([^\]]+)\]", r)}
        ours = {package for _, package in packages}
        assert names <= ours <= names | bracketed, extra


def test_a_first_time_user_does_not_build_sfepy():
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert not any("sfepy" in r for r in declared["validation"])
    assert any("sfepy" in r for r in declared["validation-nonlinear"])
    assert not any("sfepy" in r for r in declared["test"])


def test_require_names_the_extra(monkeypatch):
    _hide(monkeypatch, "skfem")
    with pytest.raises(MissingDependencyError) as caught:
        require("validation", "the continuum reference")
    assert str(caught.value) == ("the continuum reference needs scikit-fem: pip install "
                                 "'neurofuzzy[validation]'")
    assert caught.value.extra == "validation" and caught.value.packages == ["scikit-fem"]
    from neurofuzzy.validation.continuum import _skfem

    with pytest.raises(MissingDependencyError, match=r"neurofuzzy\[validation\]"):
        _skfem()
    _hide(monkeypatch, "sfepy")
    from neurofuzzy.validation.nonlinear._sfepy_setup import require_sfepy

    with pytest.raises(MissingDependencyError, match=r"neurofuzzy\[validation-nonlinear\]"):
        require_sfepy()


def test_fit_many_without_dask_says_so_before_any_work(tmp_path, monkeypatch, capsys):
    _hide(monkeypatch, "dask", "distributed")
    out = tmp_path / "results"
    # the manifest does not exist: the extra is checked before anything is read
    assert main(["fit-many", str(tmp_path / "absent.csv"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("neurofuzzy: error: fit-many (specimens as tasks on Dask) needs dask, "
                   "distributed: pip install 'neurofuzzy[batch]'")
    assert not out.exists()


def test_mesh_tetra_without_tetgen_says_so_before_any_work(tmp_path, monkeypatch, capsys):
    _hide(monkeypatch, "tetgen")
    assert main(["mesh", str(tmp_path / "absent.stl"), "--tetra", "--rules", "liver",
                 "--tissue", "liver", "--out", str(tmp_path / "m.yaml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["neurofuzzy: error: --tetra (TetGen) needs tetgen: pip install "
                   "'neurofuzzy[tetra]'"]
    assert not (tmp_path / "m.yaml").exists()


@pytest.mark.parametrize("example, extra, module", [
    ("continuum_pipeline.py", "validation", "skfem"),
    ("springs_or_elements.py", "validation", "skfem"),
    ("organ_with_tumour.py", "tetra", "tetgen")])
def test_an_example_without_its_extra_says_so_in_one_line(tmp_path, example, extra, module):
    code = (f"import sys, runpy; sys.modules[{module!r}] = None; "
            f"sys.path.insert(0, {str(ROOT / 'examples')!r}); "
            f"sys.argv = [{example!r}, {str(tmp_path / 'out')!r}, '--quick']; "
            f"runpy.run_path({str(ROOT / 'examples' / example)!r}, run_name='__main__')")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            timeout=300, cwd=tmp_path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("neurofuzzy: error: examples/"), lines
    assert lines[0].endswith(f"pip install 'neurofuzzy[{extra}]'")
    assert not (tmp_path / "out").exists()


#: what a page's commands need, and which extra installs it
NEEDS = [(r"python examples/(continuum_pipeline|continuum_diagnosis|springs_or_elements)\.py",
          "validation"), (r"python examples/organ_with_tumour\.py", "tetra"),
         (r"neurofuzzy fit-many", "batch"), (r"^import mujoco", "export"),
         (r"neurofuzzy studio", "studio")]


def test_pages_that_need_an_extra_say_so_in_their_first_lines():
    from test_docs import blocks

    pages = sorted((ROOT / "docs" / "tutorials").glob("*.md")) + [ROOT / "docs" / "studio.md"]
    needing = 0
    for page in pages:
        text = page.read_text()
        run = "\n".join(code for _, code, _ in blocks(text))
        head = "\n".join(text.splitlines()[:8])
        for pattern, extra in NEEDS:
            if re.search(pattern, run, re.MULTILINE):
                needing += 1
                assert f"pip install 'neurofuzzy[{extra}]'" in head, (page.name, extra)
    assert needing >= 5
