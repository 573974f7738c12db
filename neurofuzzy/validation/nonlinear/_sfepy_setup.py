"""What every part of the solver needs of sfepy: importing it quietly, and its variables."""

from __future__ import annotations

import contextlib
import io

from ...errors import InputError


@contextlib.contextmanager
def quiet():
    """sfepy reports its progress on stdout (and, without jax, a warning on import)."""
    with contextlib.redirect_stdout(io.StringIO()):
        yield


def require_sfepy():
    try:
        with quiet():
            import sfepy.discrete  # noqa: F401
            import sfepy.discrete.fem  # noqa: F401
            import sfepy.terms  # noqa: F401
            from sfepy.base.base import output
            output.set_output(quiet=True)  # sfepy's own switch; it only silences sfepy
    except ImportError:
        raise InputError("the nonlinear reference needs sfepy: pip install sfepy "
                         "(or neurofuzzy[validation])") from None
    import sfepy
    return sfepy


def field_variables(field) -> dict:
    from sfepy.discrete import FieldVariable

    u = FieldVariable("u", "unknown", field)
    return {"u": u, "v": FieldVariable("v", "test", field, primary_var_name="u")}
