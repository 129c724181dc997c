"""The checks and the TOML spelling every description's fields share (planar and spatial): one-line errors
naming the field."""

from __future__ import annotations

import difflib
import json
import math

from .._validate import MAX_MAGNITUDE
from ..errors import InvalidParameterError


def finite_number(where: str, value, *, positive: bool = False, non_negative: bool = False) -> float:
    """A finite float of magnitude at most :data:`MAX_MAGNITUDE`; bools and strings are slips, not numbers."""
    try:
        v = None if isinstance(value, (bool, str, bytes)) else float(value)
    except (TypeError, ValueError, OverflowError):
        v = None
    if v is None or not math.isfinite(v):
        raise InvalidParameterError(f"{where} must be a finite number, got {value!r}")
    if abs(v) > MAX_MAGNITUDE:
        raise InvalidParameterError(f"{where} = {v:g} is beyond any machine: a description's numbers (SI units) must "
                                    f"be at most {MAX_MAGNITUDE:g} in magnitude")
    if positive and v <= 0:
        raise InvalidParameterError(f"{where} must be positive, got {v:g}")
    if non_negative and v < 0:
        raise InvalidParameterError(f"{where} must not be negative, got {v:g}")
    return v


def stroke(where: str, value) -> tuple[float, float] | None:
    """A leg's actuator stroke ``(lower, upper)``, or None (no limit)."""
    if value is None:
        return None
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise InvalidParameterError(f"{where}: stroke must be [lower, upper], got {value!r}")
    lo, hi = (finite_number(f"{where}: stroke[{k}]", v) for k, v in enumerate(value))
    if not lo < hi:
        raise InvalidParameterError(f"{where}: the stroke [{lo:g}, {hi:g}] is empty (lower must be below upper)")
    return (lo, hi)


def known_keys(table, valid, where: str) -> dict:
    """``table`` when it is a table of known keys; an unknown key is named, with the closest valid one."""
    if not isinstance(table, dict):
        raise InvalidParameterError(f"{where} must be a table, got {table!r}")
    for key in table:
        if key not in valid:
            close = difflib.get_close_matches(str(key), valid, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else f" (valid keys: {', '.join(valid)})"
            raise InvalidParameterError(f"unknown key '{key}' in {where}{hint}")
    return table


def required(table: dict, key: str, where: str):
    """``table[key]``, named as missing when it is not there."""
    if key not in table:
        raise InvalidParameterError(f"{where}.{key} is required")
    return table[key]


def toml_value(value) -> str:
    """A value in TOML: a string quoted, a list of values, a float as the shortest text that reads back."""
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(float(value))  # the shortest text that reads back as exactly this float
