"""Reading user files: manipulator parameters from TOML (``--params FILE.toml``).

Format (the ``[manipulator]`` table of a scenario file; ``pkmlab help parameter-files``)::

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
import math
from pathlib import Path

import numpy as np

from .._files import read_text, read_toml
from ..errors import FileFormatError, InvalidParameterError
from ..paper.geometry import Planar3RRR

PARAM_KEYS = ("b", "l", "r", "a", "mass_l", "mass_r", "mass_a", "inertia_l", "inertia_r", "inertia_a",
              "base_points")
PRESETS = {"paper": Planar3RRR.paper}


def _unknown_key(key: str, valid, where: str) -> FileFormatError:
    close = difflib.get_close_matches(key, list(valid), n=1)
    hint = f" (did you mean '{close[0]}'?)" if close else f" (valid keys: {', '.join(valid)})"
    return FileFormatError(f"unknown key '{key}' in {where}{hint}")


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
    try:
        return Planar3RRR.from_params(**params)
    except InvalidParameterError as exc:  # name the file (and table) the impossible values came from
        raise InvalidParameterError(f"{where}: {exc}") from None


def _manipulator_table(path: str | Path) -> tuple[dict, str]:
    """The ``[manipulator]`` table of a parameter file and the name its errors start with."""
    data = read_toml(path)
    if "manipulator" not in data:  # a file of parameter keys only
        return {"params": data}, Path(path).name
    if not isinstance(data["manipulator"], dict):
        raise FileFormatError(f"{path}: [manipulator] must be a table")
    return data["manipulator"], f"{Path(path).name}: [manipulator]"


def load_manipulator(path: str | Path) -> Planar3RRR:
    """The manipulator described by a TOML file (see the module docstring)."""
    return manipulator_from_dict(*_manipulator_table(path))


def read_manipulator_table(path: str | Path) -> dict:
    """The ``[manipulator]`` table (``preset``, ``params``) of a parameter file, as a scenario file
    holds it; the machine it describes is checked first, so a bad file is refused here."""
    table, where = _manipulator_table(path)
    manipulator_from_dict(table, where)
    return table


def _toml_number(value: float) -> str:
    value = float(value)
    if not math.isfinite(value):
        raise InvalidParameterError(f"cannot write the non-finite value {value} to a parameter file")
    return repr(value)  # the shortest text that reads back as exactly this float


def manipulator_to_toml(model: Planar3RRR, comment: str | None = None) -> str:
    """A parameter file (:func:`load_manipulator` format) that reads back as a model equal to ``model``.

    Every parameter is written explicitly, the base as ``base_points``. Mass centres other than
    the defaults (link midpoints, platform centroid) have no key in the format and are refused.

    >>> import tomllib
    >>> m = Planar3RRR.paper()
    >>> text = manipulator_to_toml(m)
    >>> manipulator_from_dict(tomllib.loads(text)["manipulator"]) == m
    True
    """
    defaults = Planar3RRR(model.base_points, model.active_lengths, model.passive_lengths, model.platform_side)
    for name in ("active_com", "passive_com", "platform_com"):
        if not np.array_equal(getattr(model, name), getattr(defaults, name)):
            raise InvalidParameterError(f"cannot write {name} to a parameter file: only the default mass centres "
                                        f"(link midpoints, platform centroid) can be expressed")

    def vec(values) -> str:
        return "[" + ", ".join(_toml_number(v) for v in np.ravel(values)) + "]"

    lines = [f"# {line}" for line in (comment or "").splitlines()]
    lines += [""] if lines else []
    lines += [
        "[manipulator]",
        'preset = "paper"',
        "",
        "[manipulator.params]",
        "base_points = [" + ", ".join(vec(p) for p in model.base_points) + "]",
        f"l = {vec(model.active_lengths)}",
        f"r = {vec(model.passive_lengths)}",
        f"a = {_toml_number(model.platform_side)}",
        f"mass_l = {vec(model.active_masses)}",
        f"mass_r = {vec(model.passive_masses)}",
        f"mass_a = {_toml_number(model.platform_mass)}",
        f"inertia_l = {vec(model.active_inertias)}",
        f"inertia_r = {vec(model.passive_inertias)}",
        f"inertia_a = {_toml_number(model.platform_inertia)}",
    ]
    return "\n".join(lines) + "\n"


def read_result_csv(path: str | Path, columns, optional=()) -> dict:
    """The named ``columns`` of a result CSV (header row, then one row per sample) as float arrays, and the
    ``optional`` columns that the file has.

    Written by :meth:`pkmlab.simulation.result.SimulationResult.to_csv` (columns
    :data:`pkmlab.simulation.result.COLUMNS`); other columns are ignored. A missing file, missing
    columns (all named), a row of the wrong length or a value that is not a finite number (with
    its row and line) is a one-line :class:`FileFormatError`.
    """
    import csv

    import numpy as np

    path = Path(path)
    text = read_text(path)
    reader = csv.reader(text.splitlines())
    try:
        header = [name.strip() for name in next(reader)]
    except StopIteration:
        raise FileFormatError(f"{path}: empty file (expected a header row: {', '.join(columns)})") from None
    except csv.Error as exc:
        raise FileFormatError(f"{path}: malformed CSV header: {exc}") from None
    missing = [c for c in columns if c not in header]
    if missing:
        plural = "s" if len(missing) > 1 else ""
        raise FileFormatError(f"{path}: missing column{plural} {', '.join(missing)}")
    columns = [*columns, *(c for c in optional if c in header and c not in columns)]
    index = {c: header.index(c) for c in columns}
    rows = []
    try:
        for record in reader:
            if not record or all(not field.strip() for field in record):
                continue  # blank line
            row_number, line = len(rows) + 1, reader.line_num
            if len(record) != len(header):
                raise FileFormatError(f"{path}: row {row_number} (line {line}) has {len(record)} fields, "
                                      f"the header has {len(header)}")
            values = []
            for c in columns:
                field = record[index[c]].strip()
                try:
                    value = float(field)
                except ValueError:
                    raise FileFormatError(f"{path}: row {row_number} (line {line}): {c} = {field!r} "
                                          "is not a number") from None
                if not np.isfinite(value):
                    raise FileFormatError(f"{path}: row {row_number} (line {line}): {c} = {field!r} "
                                          "is not a finite number")
                values.append(value)
            rows.append(values)
    except csv.Error as exc:
        raise FileFormatError(f"{path}: malformed CSV at line {reader.line_num}: {exc}") from None
    if not rows:
        raise FileFormatError(f"{path}: no data rows after the header")
    data = np.array(rows, dtype=float)
    return {c: data[:, j] for j, c in enumerate(columns)}
