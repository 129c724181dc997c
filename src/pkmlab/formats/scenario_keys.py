"""The keys of a scenario file, table by table (:mod:`pkmlab.formats.scenario` reads them;
:mod:`pkmlab.formats.schemas` writes them as a JSON Schema)."""

from __future__ import annotations

import math

from .._keys import NUMBER, VECTOR, Key, names
from ..control.controller import CONTROLLER_TYPES, RUN_DISTRIBUTIONS
from ..control.time_optimal import GRID, MAX_GRID
from ..control.trajectory import ORIENTATION_PATHS
from ..description.keys import MECHANISM
from ..simulation.realism import SENSED_RATES
from ..simulation.scenario import MAX_SUBSTEPS
from .params import PARAM_KEYS, PRESETS

_POSE = {"type": "array", "items": NUMBER, "minItems": 2}  # more than 6 for a kinematically redundant machine
_ROWS = {"type": "array", "minItems": 1, "items": {"type": "array", "items": NUMBER, "minItems": 1}}
#: A working mode as ``inverse_kinematics(mode=...)`` takes it: "auto", signs "+-+", or [1, -1, 1].
_MODE = {"type": ["string", "array"], "anyOf": [{"type": "string", "pattern": r"^(auto|[+-]+)$"},
                   {"type": "array", "minItems": 1,
                    "items": {"anyOf": [{"type": "integer", "enum": [1, -1]},
                                        {"type": "string", "enum": ["+", "-", "+1", "-1", "1"]}]}}]}
_PARAMS = {"type": "object", "propertyNames": {"enum": list(PARAM_KEYS)},
           "additionalProperties": {"type": ["number", "array"]}}

#: The drives' keys, of ``[plant]`` (the plant's) and of ``[controller]`` (the model computed torque compensates).
DRIVES = (
    Key("gear_ratio", "number", "The drives' gear ratio: one number, or one per actuator.", default=1.0,
        sign="positive", many=True),
    Key("armature", "number", "The motors' armature inertia (at the motor): one number, or one per actuator.",
        "kg m^2", default=0.0, sign="non-negative", many=True),
    Key("viscous", "number", "Viscous friction at the joint: one number, or one per actuator.",
        "N m s/rad or N s/m", default=0.0, sign="non-negative", many=True),
    Key("coulomb", "number", "Coulomb friction at the joint: one number, or one per actuator.", "N m or N",
        default=0.0, sign="non-negative", many=True),
    Key("coulomb_rate", "number", "The rate over which Coulomb friction turns (tanh); 0: an exact sign; with "
        "stick_slip, the rates that count as rest.", "rad/s or m/s", default=1e-3, sign="non-negative"),
    Key("stick_slip", "boolean", "Stick-slip friction (Karnopp's model) instead of a smooth Coulomb law.",
        default=False),
)
#: The drives' keys of the plant alone (a controller compensates no effort limit or noise).
PLANT_DRIVES = (
    Key("effort_limit", "number", "The motors' effort limit: one number, or one per actuator; inf or none: no "
        "limit.", "N m or N", sign="positive", many=True),
    Key("effort_noise", "number", "The standard deviation of the efforts' noise: one number, or one per actuator.",
        "N m or N", default=0.0, sign="non-negative", many=True),
)

#: The keys of each table of a scenario file.
SCENARIO = {
    "manipulator": (
        Key("preset", "string", "Deprecated ([mechanism] replaces [manipulator]): the paper's 3-RRR.",
            default="paper", choices=tuple(PRESETS)),
        Key("params", "table", "Deprecated: overrides of the 3-RRR's parameters ([manipulator.params]).",
            schema=_PARAMS),
    ),
    # a preset, a description file, or a description inline (pkmlab.description.keys)
    "mechanism": (
        MECHANISM[0],
        Key("file", "string", "A description file holding the machine's [mechanism] (relative to the scenario's "
            "folder); no other key may be given with it.", examples=("3rps.toml",), schema={"type": "string",
                                                                                            "minLength": 1}),
        *MECHANISM[1:],
    ),
    "plant": (
        Key("mass_scale", "number", "The real machine's masses relative to the model's (inertias scale by "
            "mass_scale times length_scale squared).", default=1.0, sign="positive", examples=(1.15,)),
        Key("length_scale", "number", "The real machine's body and platform lengths relative to the model's (the "
            "base is unchanged).", default=1.0, sign="positive", examples=(1.15,)),
        *DRIVES, *PLANT_DRIVES,
    ),
    "sensors": (
        Key("resolution", "number", "The encoders' step at the joint: one number, or one per actuator.", "rad or m",
            default=0.0, sign="non-negative", many=True, examples=(1.5e-4,)),
        Key("noise", "number", "White noise on the readings (standard deviation): one number, or one per actuator.",
            "rad or m", default=0.0, sign="non-negative", many=True),
        Key("delay", "integer", "Samples between a reading and the effort computed from it.", "samples", default=0,
            minimum=0, maximum=1000),
        Key("rates", "string", "How the controller gets the rates: the readings differenced, or the plant's exact "
            "ones.", default="difference", choices=SENSED_RATES),
    ),
    "trajectory": (
        Key("type", "string", "The path: circle, line, waypoints (at rest at each), spline (through them) or fourier "
            "(a periodic excitation).", required=True, choices=("circle", "line", "waypoints", "spline", "fourier")),
        Key("speed", "number", "The average speed along the path (circle, line, waypoints without durations).",
            "m/s", sign="positive", examples=(0.2,)),
        Key("time_law", "string", "The time law along the path (timed waypoints: quintic by default).",
            default="cubic", choices=("cubic", "quintic")),
        Key("center", "array", "A circle's centre [x, y] (planar) or [x, y, z] (spatial); a fourier motion's mean "
            "pose, in the machine's coordinates.", "m (rad for angles)", schema=_POSE, only=("circle", "fourier"),
            examples=([0.25, 0.21],)),
        Key("radius", "number", "The circle's radius.", "m", sign="positive", only=("circle",), examples=(0.05,)),
        Key("start_angle", "number", "Where the circle starts, the angle about its centre (pi: the leftmost "
            "point).", "rad", default=math.pi, only=("circle",)),
        Key("alpha", "number", "A planar circle's platform orientation.", "rad", default=0.0, only=("circle",)),
        Key("alpha_end", "number", "A planar circle's orientation at its end (none: alpha throughout).", "rad",
            only=("circle",)),
        Key("turns", "number", "Turns around the circle.", default=1.0, sign="positive", only=("circle",)),
        Key("normal", "array", "A spatial circle's plane normal [x, y, z].", default=(0.0, 0.0, 1.0), schema=VECTOR,
            only=("circle",)),
        Key("orientation", "array", "A spatial circle's platform orientation held, [roll, pitch, yaw] (none for a "
            "translating platform).", "rad", schema={"type": "array", "anyOf": [VECTOR, {"maxItems": 0}]},
            only=("circle",)),
        Key("start", "array", "The line's first pose [x, y, alpha].", "m, rad", schema=VECTOR, only=("line",)),
        Key("end", "array", "The line's last pose [x, y, alpha].", "m, rad", schema=VECTOR, only=("line",)),
        Key("points", "array", "The poses to pass: [x, y, alpha], or with durations any machine's own coordinates "
            "(e.g. [x, y, z] for a Delta).", "m, rad",
            schema={"type": "array", "minItems": 2, "items": _POSE}, only=("waypoints", "spline")),
        Key("durations", "array", "The time of each segment between points.", "s",
            schema={"type": "array", "minItems": 1, "items": {"type": "number", "exclusiveMinimum": 0}},
            only=("waypoints", "spline")),
        Key("orientation_path", "string", "Timed waypoints of a rigid platform: 'angles' interpolates roll, pitch, "
            "yaw; 'geodesic' turns by the shortest rotation.", default="angles", choices=ORIENTATION_PATHS,
            only=("waypoints",)),
        Key("period", "number", "The fourier motion's period.", "s", sign="positive", only=("fourier",)),
        Key("periods", "integer", "How many periods the fourier motion lasts.", default=1, minimum=1,
            only=("fourier",)),
        Key("a", "array", "The velocity's cosine coefficients: one row per harmonic, one number per pose "
            "coordinate.", schema=_ROWS, only=("fourier",)),
        Key("b", "array", "The velocity's sine coefficients: one row per harmonic, one number per pose coordinate.",
            schema=_ROWS, only=("fourier",)),
    ),
    "controller": (
        Key("type", "string", "The control law.", default="computed_torque", choices=tuple(CONTROLLER_TYPES)),
        Key("kp", "number", "The position gain.", "1/s^2", default=1000.0, sign="positive"),
        Key("kv", "number", "The velocity gain (none: 2 sqrt(kp), critical damping).", "1/s", sign="non-negative"),
        Key("sample_time", "number", "The control period; 0: continuous-time control.", "s", default=1e-3,
            sign="non-negative"),
        Key("distribution", "string", "How a redundantly actuated machine's efforts are shared among its actuators: "
            "the least 2-norm, the least weighted 2-norm (weights), the least largest effort (one actuator beyond the "
            "degrees of freedom), or the least 2-norm plus a preload's internal part (preload).",
            default="minimum_norm", choices=RUN_DISTRIBUTIONS),
        Key("weights", "number", "The weights of distribution = 'weighted': one per actuator.", sign="positive",
            many=True),
        Key("preload", "number", "The preload of distribution = 'preload': one effort per actuator.", "N m or N",
            many=True),
        Key("mechanism", "string", "The controller's own model: a description file of the machine's structure "
            "(relative to the scenario's folder); the scenario's machine is then the plant.",
            examples=("identified.toml",), schema={"type": "string", "minLength": 1}),
        *DRIVES,
    ),
    "simulation": (
        Key("working_mode", "string", "The working mode: 'auto' (chosen along the path), or one sign per "
            "two-branch leg, e.g. '+-+' or [1, -1, 1].", default="auto", schema=_MODE),
        Key("singularity_margin", "number", "Paths whose least |S| (the Jacobian's conditioning) is below this are "
            "refused.", default=0.05, sign="non-negative"),
        Key("singularity_guard", "number", "A run stops when the plant's |S| falls below this.", default=0.01,
            sign="non-negative"),
        Key("substeps", "integer", "Runge-Kutta (RK4) steps per sample (sampled-data control only).", default=1,
            minimum=1, maximum=MAX_SUBSTEPS),
        Key("seed", "integer", "The seed of the drives' and sensors' noise.", default=0, minimum=0),
    ),
    "timing": (
        Key("velocity", "number", "The actuators' velocity limit: one number, or one per actuator.", "rad/s or m/s",
            sign="positive", many=True),
        Key("acceleration", "number", "The actuators' acceleration limit: one number, or one per actuator.",
            "rad/s^2 or m/s^2", sign="positive", many=True),
        Key("effort", "number", "The actuators' effort limit (the model's inverse dynamics): one number, or one per "
            "actuator.", "N m or N", sign="positive", many=True),
        Key("grid", "integer", "Intervals along the path where the limits are met.", default=GRID, minimum=10,
            maximum=MAX_GRID),
    ),
}
#: What each table is for (the schema's descriptions).
TABLE_DESCRIPTIONS = {
    "manipulator": "Deprecated: the paper's 3-RRR with parameter overrides; write [mechanism] instead.",
    "mechanism": "The machine (the controller's model): a preset, a description file, or a description inline. "
                 "Default: the paper's 3-RRR.",
    "plant": "The real machine relative to the model, and its drives.",
    "sensors": "What the controller measures, instead of the plant's exact state.",
    "trajectory": "The motion to follow (required).",
    "controller": "The control law, its gains and its sample time.",
    "simulation": "The run's working mode, singularity checks, integration and noise seed.",
    "timing": "The path on its time-optimal timing under actuator limits (at least one limit).",
}
#: The kinds of ``[trajectory]``.
TRAJECTORY_TYPES = next(k for k in SCENARIO["trajectory"] if k.name == "type").choices
#: The keys every kind of ``[trajectory]`` has.
TRAJECTORY_COMMON = tuple(k.name for k in SCENARIO["trajectory"] if not k.only)


def trajectory_keys(kind: str) -> tuple[str, ...]:
    """The keys of a ``[trajectory]`` of ``type = kind``, besides ``type``, ``speed`` and ``time_law``."""
    return tuple(k.name for k in SCENARIO["trajectory"] if kind in k.only)


#: The key names of each table.
TABLES = {table: names(keys) for table, keys in SCENARIO.items()}
