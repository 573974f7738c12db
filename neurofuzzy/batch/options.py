"""The fit options of a ``fit-many`` manifest row, checked as ``neurofuzzy fit`` checks its
flags."""

from __future__ import annotations

import math

from ..errors import InputError
from ..learn.prior import parse_prior
from ..pipeline.options import METHODS

__all__ = ["fit_options"]

_TRUE, _FALSE = ("true", "yes", "1"), ("false", "no", "0", "")


def fit_options(text: dict, problem) -> dict:
    """The fit options of one manifest row (``tie``, ``law``, ``stiffening``, ``relaxation``,
    ``prior``, ``method``, ``cycles``, ``dt``, ``substeps``, ``units``, ``learn_masses``,
    ``diagnose``), each checked by the rule the command line applies to its flag; the columns
    left empty are absent.

    ``problem(detail, column)`` makes the error that names the manifest, the row's line and
    the column.
    """
    from ..simulation import check_substeps

    options = {}
    if text.get("tie"):
        if text["tie"] not in ("global", "groups", "none"):
            raise problem(f"got {text['tie']!r}; expected global, groups or none", "tie")
        options["tie"] = text["tie"]
    if text.get("law"):
        from ..forces.laws import LAWS, law_number

        try:
            options["law"] = LAWS[law_number(text["law"])]
        except InputError as error:
            raise problem(error.detail, "law") from None
    if text.get("stiffening"):
        from ..forces.laws import stiffening_array

        try:
            value = float(stiffening_array(float(text["stiffening"]), 1)[0])
        except (ValueError, InputError):            # checked by the model's own rule
            raise problem(f"got {text['stiffening']!r}; expected the law's own constant "
                          "(Yeoh's C20/C10, Mooney-Rivlin's C01/C10), a number >= 0",
                          "stiffening") from None
        from ..forces.laws import STIFFENING_CONSTANT, law_number

        if law_number(options.get("law", 0)) not in STIFFENING_CONSTANT:
            raise problem("a stiffening is the law's own constant (Yeoh's C20/C10, Mooney-"
                          "Rivlin's C01/C10); give law: yeoh or law: mooney-rivlin",
                          "stiffening")
        options["stiffening"] = value
    if text.get("relaxation"):
        from ..forces.relaxation import start_terms

        try:
            start_terms(text["relaxation"], 1.0)          # checked here; started in the fit
        except InputError as error:
            raise problem(error.detail, "relaxation") from None
        options["relaxation"] = text["relaxation"]
    if text.get("prior"):
        try:
            options["prior"] = parse_prior(text["prior"])
        except InputError as error:
            raise problem(error.detail, "prior") from None
    if text.get("method"):
        if text["method"] not in METHODS:
            raise problem(f"got {text['method']!r}; expected {' or '.join(METHODS)}", "method")
        options["method"] = text["method"]
    for key, kind in (("cycles", int), ("dt", float)):
        if text.get(key):
            try:
                value = kind(text[key])
            except ValueError:
                value = None
            if value is None or not (math.isfinite(value) and value > 0):
                raise problem(f"got {text[key]!r}; expected a positive number"
                              + (" of seconds" if key == "dt" else ""), key)
            options[key] = value
    if text.get("substeps"):
        try:
            options["substeps"] = check_substeps(text["substeps"], "substeps")
        except InputError as error:
            raise problem(error.detail, "substeps") from None
    if text.get("units"):
        if text["units"] not in ("m", "cm", "mm"):
            raise problem(f"got {text['units']!r}; expected m, cm or mm", "units")
        options["units"] = text["units"]
    for key in ("learn_masses", "diagnose"):
        value = (text.get(key) or "").lower()
        if value not in _TRUE + _FALSE:
            raise problem(f"got {text[key]!r}; expected true or false", key)
        if value in _TRUE:
            options[key] = True
    return options
