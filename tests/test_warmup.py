"""The kernels compiled ahead of time, side by side (neurofuzzy.warmup)."""

import subprocess
import sys

import pytest

from neurofuzzy import warmup


def test_a_part_compiles_or_loads_in_a_process_of_its_own():
    seconds = warmup.compile_kernels(["static"], processes=1)
    assert list(seconds) == ["static"] and seconds["static"] > 0


def test_an_unknown_part_is_refused_naming_the_known_ones():
    with pytest.raises(ValueError, match="unknown part.*stepp.*known: sensitivity, stepper, "
                                         "static"):
        warmup.compile_kernels(["stepp"])
    result = subprocess.run([sys.executable, "-m", "neurofuzzy.warmup", "stepp"],
                            capture_output=True, text=True)
    assert result.returncode == 2 and "unknown part(s) stepp" in result.stderr


def test_a_part_that_fails_says_which_and_why(monkeypatch):
    monkeypatch.setattr(warmup.subprocess, "Popen", _popen_of(
        [sys.executable, "-c", "import sys; sys.exit('the compiler broke')"]))
    with pytest.raises(RuntimeError, match="'static' failed:\nthe compiler broke"):
        warmup.compile_kernels(["static"])


def _popen_of(command):
    real = subprocess.Popen

    def popen(_, **kwargs):
        return real(command, **kwargs)
    return popen
