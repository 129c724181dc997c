"""The keys of pkmlab's TOML files declared once: each key's type, unit, default and meaning.

A file format's loader takes its key names, defaults, signs and choices from its tables of :class:`Key`, and
:mod:`pkmlab.formats.schemas` writes the same tables as JSON Schemas (draft 7), so that the schema an editor
checks a file against and the loader that reads it cannot drift apart. The checks a schema cannot state (a
vector's length given by the machine, a path that must not repeat a pose...) stay in the loaders.
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: A key without a default (absent from the file, it is required or means "none").
NO_DEFAULT = object()

#: JSON Schema fragments of the values every format shares.
NUMBER = {"type": "number"}
POINT = {"type": "array", "items": NUMBER, "minItems": 2, "maxItems": 2}
VECTOR = {"type": "array", "items": NUMBER, "minItems": 3, "maxItems": 3}


def per_actuator(sign: str = "") -> dict:
    """One number for every actuator, or a list of one per actuator (their count is the machine's)."""
    one = {"type": "number", **bound(sign)}
    return {"type": ["number", "array"], "anyOf": [one, {"type": "array", "items": one, "minItems": 1}]}


def bound(sign: str) -> dict:
    """The JSON Schema bound of a number's ``sign``: ``"positive"``, ``"non-negative"`` or ``""`` (any)."""
    return {"positive": {"exclusiveMinimum": 0}, "non-negative": {"minimum": 0}}.get(sign, {})


@dataclass(frozen=True)
class Key:
    """One key of a TOML table.

    Parameters
    ----------
    name : str
        The key as written in the file.
    type : str
        ``"number"``, ``"integer"``, ``"string"``, ``"boolean"``, ``"array"`` or ``"table"``; the value's schema
        when ``schema`` does not say more.
    description : str
        What the key means, for the user (the schema's ``description``).
    unit : str
        The value's unit (SI), or ``""`` for none; appended to the description.
    default : object
        The value the loader takes when the key is absent; :data:`NO_DEFAULT` for none.
    examples : tuple
        Values worth showing (the schema's ``examples``).
    required : bool
        Whether the loader refuses the table without it.
    sign : str
        For a number: ``"positive"``, ``"non-negative"`` or ``""`` (any finite number).
    choices : tuple
        For a string: the words the loader accepts.
    minimum, maximum : int or None
        For an integer: its bounds, both included.
    schema : dict or None
        The value's JSON Schema, when the type alone does not state it (vectors, lists, alternatives).
    many : bool
        For a number: one number, or a list of them (one per actuator: their count is the machine's).
    only : tuple
        The kinds (e.g. the ``type`` of a ``[trajectory]``) the key applies to; empty: every kind.
    """

    name: str
    type: str
    description: str
    unit: str = ""
    default: object = NO_DEFAULT
    examples: tuple = ()
    required: bool = False
    sign: str = ""
    choices: tuple = ()
    minimum: int | None = None
    maximum: int | None = None
    schema: dict | None = field(default=None, compare=False)
    many: bool = False
    only: tuple = ()

    @property
    def has_default(self) -> bool:
        return self.default is not NO_DEFAULT

    def value_schema(self) -> dict:
        """The JSON Schema of the key's value, without its documentation."""
        if self.schema is not None:
            return dict(self.schema)
        if self.type == "table":
            return {"type": "object"}
        if self.many:
            return per_actuator(self.sign)
        out = {"type": self.type}
        if self.type == "number":
            out.update(bound(self.sign))
        if self.choices:
            out["enum"] = list(self.choices)
        if self.minimum is not None:
            out["minimum"] = self.minimum
        if self.maximum is not None:
            out["maximum"] = self.maximum
        return out

    def json_schema(self, value: dict | None = None) -> dict:
        """The JSON Schema of the key: its value's (``value`` if given), with its description (and unit),
        default and examples."""
        text = self.description + (f" Unit: {self.unit}." if self.unit else "")
        out = {"description": text, **(self.value_schema() if value is None else value)}
        if self.has_default:
            out["default"] = jsonable(self.default)
        if self.examples:
            out["examples"] = [jsonable(v) for v in self.examples]
        return out


def jsonable(value):
    """``value`` as JSON writes it (tuples as lists)."""
    if isinstance(value, tuple | list):
        return [jsonable(v) for v in value]
    return value


def names(keys) -> tuple[str, ...]:
    """The names of ``keys``, in their order (the order the loader's messages list them in)."""
    return tuple(k.name for k in keys)


def defaults(keys) -> dict:
    """``{name: default}`` of the keys that have one."""
    return {k.name: k.default for k in keys if k.has_default}


def key(keys, name: str) -> Key:
    """The key ``name`` among ``keys``."""
    return next(k for k in keys if k.name == name)


def table_schema(keys, description: str = "", closed: bool = True, overrides: dict | None = None) -> dict:
    """The JSON Schema of a table of ``keys``: its properties, the required ones, unknown keys refused when
    ``closed``; ``overrides`` replaces some keys' schemas (e.g. a nested table's)."""
    overrides = overrides or {}
    props = {}
    for k in keys:
        props[k.name] = k.json_schema(overrides.get(k.name))
    out = {"type": "object"}
    if description:
        out["description"] = description
    out["properties"] = props
    required = [k.name for k in keys if k.required]
    if required:
        out["required"] = required
    if closed:
        out["additionalProperties"] = False
    return out
