"""JSON Schemas of pkmlab's three TOML files — a description, a scenario, a study (sweep) — written from the key
tables the loaders read them with, for editors that check a TOML file as it is typed.

The tables: :mod:`pkmlab.description.keys` (a ``[mechanism]``), :mod:`pkmlab.formats.scenario_keys` (a scenario
file) and :mod:`pkmlab.formats.study_keys` (a study file). Each key's schema has its type, a description with its
unit, its default and examples; a table refuses unknown keys where its loader does. The rules between keys
that a schema can state (a preset alone, a trajectory's keys by its type, the job's options table) are stated
here beside them. What a schema cannot state stays the loader's alone: a list's length given by the machine (one
value per actuator, a pose of its coordinates), a leg's joints and bodies agreeing, a path that repeats a pose,
an integer written as a float (``2.0``, which JSON does not tell from ``2``).

The schemas ship in ``pkmlab/schemas/`` (:func:`path`); after changing a key table, write them again::

    python -m pkmlab.formats.schemas --write

(``--check`` exits with 1 when a shipped schema is not the one the tables give.)
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .._keys import key, table_schema
from ..description import keys as description_keys
from ..description.presets import PRESETS
from .scenario_keys import SCENARIO, TABLE_DESCRIPTIONS, TRAJECTORY_COMMON, TRAJECTORY_TYPES, trajectory_keys
from .study_keys import OPTIONS, RANGE, STUDY, TABLE, TABLES_OF_A_STUDY, UNCERTAINTY, axis_keys

#: The folder of the shipped schemas (package data).
SCHEMA_DIR = Path(__file__).resolve().parents[1] / "schemas"
#: The file formats that have a schema.
KINDS = ("description", "scenario", "sweep")
_DRAFT = "http://json-schema.org/draft-07/schema#"


def path(kind: str) -> Path:
    """The shipped JSON Schema of ``kind`` (``"description"``, ``"scenario"`` or ``"sweep"``).

    >>> path("scenario").name
    'scenario.schema.json'
    """
    if kind not in KINDS:
        from ..errors import InvalidParameterError

        raise InvalidParameterError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    return SCHEMA_DIR / f"{kind}.schema.json"


def _ref(name: str) -> dict:
    return {"$ref": f"#/definitions/{name}"}


def _list_of(name: str) -> dict:
    return {"type": "array", "minItems": 1, "items": _ref(name)}


# ------------------------------------------------------------------ a description
def _description_definitions() -> dict:
    k = description_keys
    preset = key(k.MECHANISM, "preset")
    planar = [x for x in k.MECHANISM if x.name != "preset"]
    spatial = [key(k.MECHANISM, "dimension"), *k.SPATIAL_MECHANISM]
    return {
        "mechanism": {
            "description": "The machine: a preset (preset = \"NAME\" alone), a planar description (dimension = 2, "
                           "the default) or a spatial one (dimension = 3).",
            "type": "object",
            # the loader's order: a preset first, then the dimension picks the kind of description
            "if": {"required": ["preset"]}, "then": _ref("preset_mechanism"),
            "else": {"if": {"properties": {"dimension": {"const": 3}}, "required": ["dimension"]},
                     "then": _ref("spatial_mechanism"), "else": _ref("planar_mechanism")},
        },
        "preset_mechanism": table_schema([preset], "A preset machine.",
                                         overrides={"preset": {"type": "string", "enum": list(PRESETS)}}),
        "planar_mechanism": table_schema(planar, "A planar machine (in the x-y plane).", overrides={
            "dimension": {"type": "integer", "enum": [2]}, "platform": _ref("planar_platform"),
            "leg": _list_of("planar_leg")}),
        "planar_platform": table_schema(k.PLANAR_PLATFORM, "The planar machine's platform ([mechanism.platform])."),
        "planar_leg": table_schema(k.PLANAR_LEG, "A leg ([[mechanism.leg]]).",
                                   overrides={"bodies": {"type": "array", "items": _ref("planar_body")}}),
        "planar_body": table_schema(k.PLANAR_BODY, "A body of a planar leg."),
        "spatial_mechanism": table_schema(spatial, "A spatial machine (dimension = 3).", overrides={
            "dimension": {"type": "integer", "enum": [3]}, "platform": _ref("spatial_platform"),
            "leg": _list_of("spatial_leg")}),
        "spatial_platform": table_schema(k.SPATIAL_PLATFORM, "The spatial machine's platform ([mechanism.platform])."),
        "spatial_leg": table_schema(k.SPATIAL_LEG, "A leg ([[mechanism.leg]]).",
                                    overrides={"bodies": {"type": "array", "items": _ref("spatial_body")}}),
        "spatial_body": table_schema(k.SPATIAL_BODY, "A body of a spatial leg."),
    }


def description_schema() -> dict:
    """The schema of a description file: a ``[mechanism]`` table (other tables are not read, so not refused)."""
    return {"$schema": _DRAFT, "title": "pkmlab description file",
            "description": "A machine described in TOML: its [mechanism] table (pkmlab.description).",
            "type": "object", "properties": {"mechanism": _ref("mechanism")}, "required": ["mechanism"],
            "definitions": _description_definitions()}


# ------------------------------------------------------------------ a scenario
def _is(name: str, value) -> dict:
    """The condition: the key ``name`` is given, and is ``value``."""
    return {"properties": {name: {"const": value}}, "required": [name]}


def _absent(*keys: str) -> dict:
    return {"properties": {k: False for k in keys}}


#: The keys each kind of ``[trajectory]`` requires, and those it refuses though they are among its keys
#: (pkmlab.formats.scenario's _trajectory, _timed_waypoints and _fourier check the same).
_TRAJECTORY_RULES = {
    "circle": {"required": ["center", "radius", "speed"]},
    "line": {"required": ["start", "end", "speed"]},
    "waypoints": {"required": ["points"],
                  # with durations the poses are timed (no speed); without, speed times them
                  "if": {"required": ["durations"]}, "then": _absent("speed"), "else": {"required": ["speed"]}},
    "spline": {"required": ["points", "durations"], **_absent("speed", "time_law")},
    "fourier": {"required": ["center", "period", "a", "b"], **_absent("speed", "time_law")},
}


def _trajectory() -> dict:
    out = table_schema(SCENARIO["trajectory"], TABLE_DESCRIPTIONS["trajectory"])
    rules = []
    for kind in TRAJECTORY_TYPES:
        then = {"propertyNames": {"enum": [*TRAJECTORY_COMMON, *trajectory_keys(kind)]}, **_TRAJECTORY_RULES[kind]}
        rules.append({"if": _is("type", kind), "then": then})
    # a circle's centre [x, y, z] makes it a spatial one: normal and orientation, not alpha
    spatial = {"properties": {"center": {"minItems": 3}}, "required": ["center"]}
    rules.append({"if": _is("type", "circle"), "then": {
        "properties": {"center": {"maxItems": 3}},
        "if": spatial, "then": _absent("alpha", "alpha_end"), "else": _absent("normal", "orientation")}})
    out["allOf"] = rules
    return out


def _scenario_definitions() -> dict:
    out = _description_definitions()
    file_key = key(SCENARIO["mechanism"], "file")
    out["scenario_mechanism"] = {
        "description": TABLE_DESCRIPTIONS["mechanism"], "type": "object",
        "if": {"required": ["file"]}, "then": table_schema([file_key], "The machine of a description file."),
        "else": _ref("mechanism")}
    for table in SCENARIO:
        if table == "mechanism":
            continue
        out[table] = _trajectory() if table == "trajectory" else table_schema(SCENARIO[table],
                                                                               TABLE_DESCRIPTIONS[table])
    out["timing"]["anyOf"] = [{"required": [name]} for name in ("velocity", "acceleration", "effort")]
    out["scenario"] = {
        "type": "object", "properties": {t: _ref("scenario_mechanism" if t == "mechanism" else t) for t in SCENARIO},
        "required": ["trajectory"], "additionalProperties": False,
        "not": {"required": ["mechanism", "manipulator"]}}
    return out


def scenario_schema() -> dict:
    """The schema of a scenario file (``pkmlab simulate SCENARIO.toml``)."""
    defs = _scenario_definitions()
    # the document's own tables inline: draft 7 ignores the keywords beside a "$ref"
    root = defs.pop("scenario")
    return {"$schema": _DRAFT, "title": "pkmlab scenario file",
            "description": "A closed-loop run in TOML (pkmlab.formats.scenario): the machine, the plant, the "
                           "trajectory, the controller.",
            **root, "definitions": defs}


# ------------------------------------------------------------------ a study
def _axis(name: str) -> dict:
    """An axis of ``[grid]``: a list of values of the key it varies, or a range of numbers."""
    table, _, rest = name.partition(".")
    if table in TABLE.values():
        job = next(j for j, t in TABLE.items() if t == table)
        spec = key(OPTIONS[job], rest)
    elif table == "manipulator":
        spec = None
    else:
        spec = key(SCENARIO[table], rest)
    values = spec.value_schema() if spec is not None else {"type": ["number", "array"]}
    numeric = spec is None or spec.many or spec.type in ("number", "integer")
    text = f"Values of {name}" + (f": {spec.description}" if spec is not None else " (a deprecated 3-RRR parameter).")
    listed = {"type": "array", "minItems": 1, "items": values}
    return {"description": text + " A list of values" + (", or a range {start, stop, num[, scale]}." if numeric
                                                          else "."),
            **({"type": ["array", "object"], "anyOf": [listed, _ref("range")]} if numeric else listed)}


def sweep_schema() -> dict:
    """The schema of a study file (``pkmlab sweep SWEEP.toml``)."""
    defs = _scenario_definitions()
    defs["study"] = table_schema(STUDY, TABLES_OF_A_STUDY["study"])
    defs["range"] = table_schema(RANGE, "Evenly (or geometrically) spaced values, the ends included.")
    every_option = tuple(f"{TABLE[job]}.{k.name}" for job in TABLE for k in OPTIONS[job])
    defs["grid"] = {"description": TABLES_OF_A_STUDY["grid"], "type": "object",
                    "properties": {a: _axis(a) for a in (*axis_keys(), *every_option)},
                    "additionalProperties": False}
    defs["uncertainty"] = table_schema(UNCERTAINTY, TABLES_OF_A_STUDY["uncertainty"])
    for job, table in TABLE.items():
        defs[table] = table_schema(OPTIONS[job], TABLES_OF_A_STUDY[table])
    tables = {name: _ref("scenario" if name == "base" else name) for name in TABLES_OF_A_STUDY}
    # a job's options, as a table or as axes, belong to that job only
    rules = [{"if": {"properties": {"study": _is("job", job)}, "required": ["study"]}, "else": {
        "properties": {table: False, "grid": {"propertyNames": {"not": {"pattern": f"^{table}\\."}}}}}}
        for job, table in TABLE.items()]
    return {"$schema": _DRAFT, "title": "pkmlab study file",
            "description": "A study in TOML (pkmlab.study): a base scenario, axes crossed or zipped, plants drawn.",
            "type": "object", "properties": tables, "additionalProperties": False,
            # the base scenario once: [study].base = "FILE.toml" or inline [base.*] tables
            "oneOf": [{"required": ["base"]}, {"properties": {"study": {"required": ["base"]}}, "required": ["study"]}],
            "allOf": rules, "definitions": defs}


_BUILDERS = {"description": description_schema, "scenario": scenario_schema, "sweep": sweep_schema}


def schema(kind: str) -> dict:
    """The JSON Schema of ``kind`` as the key tables give it now (:func:`path` is the shipped one)."""
    path(kind)  # the kind checked
    return _BUILDERS[kind]()


def schema_text(kind: str) -> str:
    """The text of the schema file of ``kind``, as :func:`write` writes it."""
    return json.dumps(schema(kind), indent=2, ensure_ascii=False) + "\n"


def write(folder: Path = SCHEMA_DIR) -> list[Path]:
    """Write every schema into ``folder``; the files written."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for kind in KINDS:
        target = folder / path(kind).name
        target.write_text(schema_text(kind), encoding="utf-8")
        out.append(target)
    return out


def stale(folder: Path = SCHEMA_DIR) -> list[str]:
    """The kinds whose schema file in ``folder`` is missing or not what the key tables give."""
    def current(kind):
        target = folder / path(kind).name
        return target.is_file() and target.read_text(encoding="utf-8") == schema_text(kind)

    return [kind for kind in KINDS if not current(kind)]


def main(argv=None) -> int:
    """``python -m pkmlab.formats.schemas [--write | --check]``: print, write or check the shipped schemas."""
    parser = argparse.ArgumentParser(prog="python -m pkmlab.formats.schemas", description=__doc__.split("\n\n")[0])
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--write", action="store_true", help=f"write the schemas into {SCHEMA_DIR}")
    group.add_argument("--check", action="store_true", help="exit with 1 if a shipped schema is out of date")
    parser.add_argument("--kind", choices=KINDS, help="print this schema (default: list the schemas' paths)")
    args = parser.parse_args(argv)
    if args.write:
        for target in write():
            print(target)
        return 0
    if args.check:
        old = stale()
        for kind in old:
            print(f"{path(kind)} is out of date: run python -m pkmlab.formats.schemas --write", file=sys.stderr)
        return 1 if old else 0
    if args.kind:
        sys.stdout.write(schema_text(args.kind))
        return 0
    for kind in KINDS:
        print(f"{kind}: {path(kind)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
