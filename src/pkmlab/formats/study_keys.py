"""The keys of a study file (``pkmlab sweep SWEEP.toml``), table by table: :mod:`pkmlab.study.definition` and
:mod:`pkmlab.study.jobs` read them; :mod:`pkmlab.formats.schemas` writes them as a JSON Schema."""

from __future__ import annotations

import math

from .._keys import Key, names
from ..simulation.uncertainty import QUANTITIES
from .params import PARAM_KEYS
from .scenario_keys import TABLES

#: What a run of a study does (:mod:`pkmlab.study.jobs`).
JOBS = ("simulate", "identify", "calibrate")
#: The study file's table of each job's options.
TABLE = {"identify": "identification", "calibrate": "calibration"}

#: The keys of ``[study]``.
STUDY = (
    Key("name", "string", "The study's name (default: the study file's name).", schema={"type": "string",
                                                                                        "minLength": 1}),
    Key("base", "string", "The base scenario: a scenario file, relative to this file (or inline [base.*] tables "
        "instead).", examples=("fast.toml",), schema={"type": "string", "minLength": 1}),
    Key("draws", "integer", "Plants drawn per grid point within [uncertainty] (0: the scenario's plant, once); a "
        "calibration study's machines built with errors.", default=0, minimum=0),
    Key("seed", "integer", "The seed of the draws.", default=0, minimum=0),
    Key("combine", "string", "'cross': every combination of the axes' values; 'zip': value by value (axes of one "
        "length).", default="cross", choices=("cross", "zip")),
    Key("job", "string", "What a run does: simulate its scenario, identify the plant from its log, or calibrate a "
        "machine built with errors.", default="simulate", choices=JOBS),
)
#: The keys of a range of axis values, ``{start, stop, num[, scale]}``.
RANGE = (
    Key("start", "number", "The first value.", required=True),
    Key("stop", "number", "The last value (included).", required=True),
    Key("num", "integer", "How many values.", required=True, minimum=1),
    Key("scale", "string", "'linear': evenly spaced; 'log': geometrically (start and stop > 0).", default="linear",
        choices=("linear", "log")),
)
#: The quantities ``[uncertainty]`` draws, body by body.
UNCERTAINTY = tuple(
    Key(q, "number", f"The plant's {q} factors: a spread s (uniform in [1 - s, 1 + s]) or two factors [low, high].",
        examples=(0.15, [0.9, 1.1]),
        schema={"type": ["number", "array"],
                "anyOf": [{"type": "number", "minimum": 0, "exclusiveMaximum": 1},
                          {"type": "array", "items": {"type": "number", "exclusiveMinimum": 0}, "minItems": 2,
                           "maxItems": 2}]})
    for q in QUANTITIES)
#: Each job's options (its table's keys), with their defaults.
OPTIONS = {
    "simulate": (),
    "identify": (
        Key("window", "number", "The measurements' filter window.", "s", default=0.05, sign="positive"),
        Key("polyorder", "integer", "The filter's polynomial order.", default=4, minimum=1),
        Key("drives", "boolean", "Estimate the drives' armature and friction too.", default=False),
        Key("coulomb_rate", "number", "The drives' Coulomb model: fc tanh(rate / coulomb_rate); 0 for fc sign(rate).",
            "rad/s or m/s", default=0.0, sign="non-negative"),
        Key("reversals", "string", "The samples whose filter window holds a reversal of an actuator's rate (or "
            "rest): left out, or kept.", default="drop", choices=("drop", "keep")),
    ),
    "calibrate": (
        Key("poses", "integer", "Measured poses.", default=40, minimum=1),
        Key("noise", "number", "The instrument's standard deviation per coordinate.", "m or rad", default=1e-5,
            sign="non-negative"),
        Key("measure", "string", "What the instrument measures: the platform's position, or its whole pose.",
            default="position", choices=("position", "pose")),
        Key("size", "number", "The geometry's errors: uniform in [-size, size].", "m", default=1e-3,
            sign="non-negative"),
        Key("angle", "number", "The revolute actuators' zero errors: uniform in [-angle, angle].", "rad",
            default=math.radians(0.5), sign="non-negative"),
        Key("held_out", "integer", "Poses that check the result.", default=50, minimum=1),
        Key("candidates", "integer", "Choose the poses D-optimally among this many (0: at random).", default=0,
            minimum=0),
        Key("span", "number", "The poses' region: span times the machine's size about its home pose.", default=0.1,
            sign="positive"),
        Key("turn", "number", "The poses' region in orientation about the home pose.", "rad", default=0.3,
            sign="non-negative"),
    ),
}
#: The tables of a study file, with what each is for.
TABLES_OF_A_STUDY = {
    "study": "The study: its name, base scenario, draws, seed, how its axes combine and its job.",
    "base": "The base scenario inline, as a scenario file's tables (instead of [study].base).",
    "grid": "The axes: 'table.key' of a scenario value (or of the job's options) = a list of values or a range "
            "{start, stop, num[, scale]}.",
    "uncertainty": "Per body, the plants' factors drawn uniformly: a spread or [low, high].",
    "identification": "The options of job = 'identify'; each is also an axis ('identification.window').",
    "calibration": "The options of job = 'calibrate'; each is also an axis ('calibration.noise').",
}
STUDY_TABLES = tuple(TABLES_OF_A_STUDY)
STUDY_KEYS = names(STUDY)
RANGE_KEYS = names(RANGE)


def axis_keys() -> tuple[str, ...]:
    """Every scenario value an axis may vary: ``table.key`` for the scenario tables' keys, and
    ``manipulator.params.<name>``. The machine's structure (``[mechanism]``, ``manipulator.preset``)
    is the base's: a study compares runs of one machine."""
    keys = [f"{table}.{key}" for table, names_ in TABLES.items() if table not in ("mechanism", "manipulator")
            for key in names_]
    return (*keys, *(f"manipulator.params.{k}" for k in PARAM_KEYS))


def option_keys(job: str) -> tuple[str, ...]:
    """The axis keys of ``job``'s options: ``identification.window`` ..."""
    return tuple(f"{TABLE[job]}.{k.name}" for k in OPTIONS[job]) if job in TABLE else ()

