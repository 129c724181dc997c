"""Description files: the TOML form of every mechanism, planar or spatial, and of the presets.

A ``[mechanism]`` table is a preset (``preset = "NAME"``), a planar description
(:mod:`pkmlab.description.mechanism`, the default ``dimension = 2``) or a spatial one
(:mod:`pkmlab.description.spatial`, ``dimension = 3``). :func:`mechanism_from_dict` reads any of them,
:func:`mechanism_to_toml` writes any description back (read again, it is an equal value), and
:func:`load_mechanism` reads a file. Every error is one line naming the key (and the file).
"""

from __future__ import annotations

from pathlib import Path

from .._files import read_toml
from .._keys import key
from ..errors import InvalidParameterError
from ._fields import known_keys
from .keys import MECHANISM
from .mechanism import MECHANISM_KEYS, Mechanism, planar_mechanism_from_dict, planar_mechanism_to_toml
from .presets import preset
from .spatial import SpatialMechanism, spatial_mechanism_from_dict, spatial_mechanism_to_toml


def mechanism_from_dict(table: dict, source: str = "[mechanism]") -> Mechanism | SpatialMechanism:
    """The mechanism of a ``[mechanism]`` table (a preset by ``preset = "NAME"``; the format:
    :mod:`pkmlab.description.mechanism` and :mod:`pkmlab.description.spatial`).

    >>> m = mechanism_from_dict({"preset": "3rpr"})
    >>> m.notation, m.pose_names
    ('3-RP*R', ('x', 'y', 'alpha'))
    """
    where = source
    table = known_keys(table, MECHANISM_KEYS, where)
    if "preset" in table:
        others = sorted(set(table) - {"preset"})
        if others:
            raise InvalidParameterError(f"{where}: give either preset or a description ({', '.join(others)}), "
                                        "not both")
        return preset(table["preset"])
    dimension = table.get("dimension", key(MECHANISM, "dimension").default)
    if dimension not in (2, 3) or isinstance(dimension, bool):
        raise InvalidParameterError(f"{where}.dimension must be 2 (a planar machine) or 3 (a spatial one), got "
                                    f"{dimension!r}")
    if dimension == 3:
        return spatial_mechanism_from_dict({k: v for k, v in table.items() if k != "dimension"}, source)
    return planar_mechanism_from_dict(table, source)


def mechanism_to_toml(mechanism: Mechanism | SpatialMechanism, comment: str | None = None) -> str:
    """The TOML form of ``mechanism`` (``comment`` on top); :func:`mechanism_from_dict` reads it back as an
    equal value.

    >>> import tomllib
    >>> mechanism_from_dict(tomllib.loads(mechanism_to_toml(preset("3prr")))["mechanism"]) == preset("3prr")
    True
    """
    if getattr(mechanism, "spatial", False):
        return spatial_mechanism_to_toml(mechanism, comment)
    return planar_mechanism_to_toml(mechanism, comment)


def load_mechanism(path) -> Mechanism | SpatialMechanism:
    """The mechanism of a TOML file holding a ``[mechanism]`` table; every error names the file."""
    data = read_toml(path)
    if "mechanism" not in data:
        raise InvalidParameterError(f"{Path(path).name}: no [mechanism] table")
    try:
        return mechanism_from_dict(data["mechanism"], "[mechanism]")
    except InvalidParameterError as exc:
        raise InvalidParameterError(f"{Path(path).name}: {exc}") from None
