"""What messages share: numbers shown so that they cannot contradict the limit they are compared with, and
the closest valid name to a misspelt one."""

from __future__ import annotations

import difflib
import math


def apart(value: float, limit: float, digits: int = 3, limit_digits: int = 6) -> tuple[str, str]:
    """``(value, limit)`` as text, with ``digits`` significant digits or more until the texts compare
    as the numbers do (``0.04996`` against ``0.05`` is ``"0.04996"``, never ``"0.05"``).

    The limit keeps at least ``limit_digits`` significant digits (6: ``:g``, as it was typed).

    >>> apart(0.04996, 0.05)
    ('0.04996', '0.05')
    >>> apart(1.0000004, 1.0)
    ('1.0000004', '1')
    """
    value, limit = float(value), float(limit)
    if not (math.isfinite(value) and math.isfinite(limit)):
        return f"{value:.{digits}g}", f"{limit:.{limit_digits}g}"
    order = (value > limit) - (value < limit)
    for d in range(digits, 18):
        v, lim = f"{value:.{d}g}", f"{limit:.{max(d, limit_digits)}g}"
        if (float(v) > float(lim)) - (float(v) < float(lim)) == order:
            return v, lim
    return repr(value), repr(limit)


def suggestion(key: str, valid) -> str:
    """The end of an "unknown key" message: the closest of ``valid`` to ``key``, or every valid key.

    >>> suggestion("mas", ("mass", "length"))
    " (did you mean 'mass'?)"
    """
    close = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else f" (valid keys: {', '.join(valid)})"
