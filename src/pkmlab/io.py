"""Reading user files: manipulator parameters from TOML (``--params FILE.toml``).

Format (the ``[manipulator]`` table of a scenario file; see the README)::

    [manipulator]
    preset = "paper"          # optional, the default
    [manipulator.params]      # optional overrides, per-leg lists allowed for l, r, masses, inertias
    l = [0.25, 0.25, 0.26]
    a = 0.12

A file holding only the parameter keys at top level is accepted too. Unknown keys are
refused with the closest valid key suggested; malformed TOML is reported with its line.
"""

from __future__ import annotations

import difflib
import tomllib
from pathlib import Path

from .errors import InvalidParameterError, PkmlabError
from .geometry import Planar3RRR

PARAM_KEYS = ("b", "l", "r", "a", "mass_l", "mass_r", "mass_a", "inertia_l", "inertia_r", "inertia_a",
              "base_points")
PRESETS = {"paper": Planar3RRR.paper}


class FileFormatError(PkmlabError, ValueError):
    """A file that cannot be read or does not follow the documented format."""


def _unknown_key(key: str, valid, where: str) -> FileFormatError:
    close = difflib.get_close_matches(key, list(valid), n=1)
    hint = f" (did you mean '{close[0]}'?)" if close else f" (valid keys: {', '.join(valid)})"
    return FileFormatError(f"unknown key '{key}' in {where}{hint}")


def read_toml(path: str | Path) -> dict:
    """Parse a TOML file, turning every failure into a one-line :class:`FileFormatError`."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise FileFormatError(f"cannot read {path}: no such file") from None
    except IsADirectoryError:
        raise FileFormatError(f"cannot read {path}: it is a directory") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise FileFormatError(f"cannot read {path}: {exc}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise FileFormatError(f"{path}: malformed TOML: {exc}") from None


def _is_numeric(value) -> bool:
    """A number or a (nested) list of numbers; TOML booleans are not numbers."""
    if isinstance(value, list):
        return all(_is_numeric(v) for v in value)
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def manipulator_from_dict(table: dict, where: str = "[manipulator]") -> Planar3RRR:
    """Build the model from a ``[manipulator]`` table (``preset`` and ``params``)."""
    for key in table:
        if key not in ("preset", "params"):
            raise _unknown_key(key, ("preset", "params"), where)
    preset = table.get("preset", "paper")
    if preset not in PRESETS:
        close = difflib.get_close_matches(str(preset), list(PRESETS), n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise FileFormatError(f"unknown preset '{preset}' in {where}{hint}; presets: {', '.join(PRESETS)}")
    params = table.get("params", {})
    if not isinstance(params, dict):
        raise FileFormatError(f"{where}.params must be a table")
    for key, value in params.items():
        if key not in PARAM_KEYS:
            raise _unknown_key(key, PARAM_KEYS, f"{where}.params")
        if not _is_numeric(value):
            raise InvalidParameterError(f"{where}.params.{key} must be a number or a list of numbers")
    return Planar3RRR.from_params(**params)


def load_manipulator(path: str | Path) -> Planar3RRR:
    """The manipulator described by a TOML file (see the module docstring)."""
    data = read_toml(path)
    if "manipulator" in data:
        if not isinstance(data["manipulator"], dict):
            raise FileFormatError(f"{path}: [manipulator] must be a table")
        return manipulator_from_dict(data["manipulator"], f"{Path(path).name}: [manipulator]")
    return manipulator_from_dict({"params": data}, f"{Path(path).name}")
