"""What every part of the solver needs of sfepy: importing it quietly, and its variables."""

from __future__ import annotations

import contextlib
import io


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
        from ...extras import require

        require("validation-nonlinear", "the nonlinear reference (sfepy's solver)")
        raise           # installed, but broken: sfepy's own error
    import sfepy
    return sfepy


def field_variables(field) -> dict:
    from sfepy.discrete import FieldVariable

    u = FieldVariable("u", "unknown", field)
    return {"u": u, "v": FieldVariable("v", "test", field, primary_var_name="u")}
