"""Scenario files: a closed-loop run described in TOML (``pkmlab simulate SCENARIO.toml``).

Declarative, like MJCF: data, never code. Every table but ``[trajectory]`` is optional::

    [mechanism]                 # the controller's model; default: the paper's 3-RRR
    preset = "paper"            # a preset, or file = "my_machine.toml", or a description inline

    [plant]                     # the real machine relative to the model (conventions §7)
    mass_scale = 1.15           # masses ×; inertias × mass_scale·length_scale²
    length_scale = 1.15         # the bodies' and platform's lengths ×; the base is unchanged

    # the plant's drives, optional (one number, or one per actuator; pkmlab.simulation.realism):
    # gear_ratio = 1.0, armature (the motor's, kg m2), viscous, coulomb (at the joint), coulomb_rate = 1e-3
    # (0: exact sign), stick_slip = false (true: stick-slip friction, Karnopp's model: coulomb_rate is the window
    # of rates that count as rest), effort_limit (the motor's), effort_noise (its standard deviation)

    [sensors]                   # optional: what the controller measures, instead of the plant's exact state
    resolution = 1.5e-4         # the encoder's step at the joint (rad or m), one number or one per actuator
    noise = 0.0                 # white noise on the readings (standard deviation)
    delay = 0                   # samples between a reading and the effort computed from it
    rates = "difference"        # difference (the readings differenced) | exact (the plant's rates)

    [trajectory]
    type = "circle"             # circle | line | waypoints | spline | fourier
    center = [0.25, 0.21]
    radius = 0.05
    start_angle = 3.14159265    # default: pi, the leftmost point
    speed = 0.2                 # average speed (m/s), required
    alpha = 0.0                 # platform orientation (rad)
    time_law = "cubic"          # cubic | quintic
    # circle also: alpha_end (orientation at the end), turns (default 1)
    # line: start = [x, y, alpha], end = [x, y, alpha]
    # waypoints: points = [[x, y, alpha], ...]; with durations = [s, ...] poses of any machine's own
    #   coordinates (e.g. [x, y, z] for the Delta), at rest at each point; a rigid platform's [x, y, z, roll,
    #   pitch, yaw] with orientation_path = "geodesic" turns by the shortest rotation between points
    # spline: points and durations as waypoints, passed without stopping (a C2 cubic spline, at rest at its ends)
    # a spatial machine's circle: center = [x, y, z], normal = [0, 0, 1], orientation = [roll, pitch, yaw]
    # fourier: a periodic motion of the pose (what pkmlab excite writes): center = a pose of the machine's
    #   coordinates, period (s), periods (default 1), a and b = one row per harmonic k of the velocity's
    #   cosine and sine coefficients, each row one number per coordinate; Σ a_k = 0 and Σ k b_k = 0 (at rest)

    [controller]
    type = "computed_torque"    # computed_torque | pd
    kp = 1000.0
    kv = 63.2                   # default 2*sqrt(kp)
    sample_time = 0.001         # seconds; 0 = continuous-time control
    # mechanism = "identified.toml": the controller's own model (a description of the machine's structure; the
    #   scenario's machine is then the plant) — what pkmlab identify --consistent writes
    # computed torque's model of the drives, compensated (e.g. identified): gear_ratio, armature, viscous,
    # coulomb, coulomb_rate, stick_slip, as the plant's keys (pkmlab identify --drives --out writes them)

    [timing]                    # optional: the path on its time-optimal timing under actuator limits
    velocity = [3.0, 3.0, 3.0]  # rad/s or m/s per actuator (one number: every actuator alike)
    acceleration = 80.0         # rad/s² or m/s²
    effort = [0.5, 0.5, 0.5]    # N m or N (the controller's model's inverse dynamics); at least one limit
    grid = 400                  # intervals along the path where the limits are met

    [simulation]
    working_mode = "auto"       # or three signs, e.g. [1, -1, 1]
    singularity_margin = 0.05   # refuse paths whose min |S| is below this
    singularity_guard = 0.01    # stop a run when the plant's |S| falls below this
    substeps = 1                # Runge-Kutta (RK4) steps per sample
    seed = 0                    # the drives' and sensors' noise

A ``[manipulator]`` table (the paper's 3-RRR with ``preset`` and ``[manipulator.params]`` overrides of
pkmlab 0.2) is still read, with a :class:`~pkmlab.errors.PkmlabDeprecationWarning` that gives the
equivalent ``[mechanism]`` text.

Every problem — a missing file, malformed TOML (with its line), an unknown table or key (the
closest valid one is suggested), a wrong type, a value that is not finite or out of range, a
missing required key — is a :class:`~pkmlab.errors.PkmlabError` whose one-line message names
the file and the key, e.g. ``s.toml: [trajectory].radius must be a positive number, got -0.05``.
"""

from __future__ import annotations

import difflib
import json
import math
import warnings
from pathlib import Path

import numpy as np

from .._files import parse_toml, read_toml
from .._format import apart, suggestion
from .._keys import key as _spec
from ..algorithms.kinematics import as_working_mode
from ..control.controller import ControllerSpec
from ..control.time_optimal import time_optimal
from ..control.trajectory import (
    Circle,
    FourierTrajectory,
    Line,
    SpatialCircle,
    Spline,
    TimedWaypoints,
    Trajectory,
    WaypointTrajectory,
    paper_trajectory,
)
from ..description import presets
from ..errors import FileFormatError, InvalidParameterError, PkmlabDeprecationWarning, PkmlabError, shown
from ..model.mechanism_model import MechanismModel, load
from ..simulation.ahead import compile_loop_ahead_of, end_compiling_ahead
from ..simulation.realism import Drives, Sensors
from ..simulation.scenario import MAX_SAMPLES, Scenario, scaled_model
from .params import PARAM_KEYS, PRESETS, manipulator_from_dict
from .scenario_keys import DRIVES, PLANT_DRIVES, SCENARIO, TABLES, TRAJECTORY_TYPES, trajectory_keys

#: Keys of ``[trajectory]`` by its ``type``, besides ``type``, ``speed`` and ``time_law``.
TRAJECTORY_KEYS = {kind: trajectory_keys(kind) for kind in TRAJECTORY_TYPES}
TIME_LAWS = _spec(SCENARIO["trajectory"], "time_law").choices
#: Runs longer than this many samples are refused (memory: ~200 bytes per sample).
_PER_LEG = ("l", "r", "mass_l", "mass_r", "inertia_l", "inertia_r")
_SCALAR = ("b", "a", "mass_a", "inertia_a")


def show(value, limit: int = 60) -> str:
    """``value`` written as in a TOML file, on one line, shortened to about ``limit`` characters."""
    text = _toml_value(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"
    return json.dumps(str(value), ensure_ascii=False)  # dates and times


def _key(key: str) -> str:
    """A key as TOML writes it: bare if it can be, else quoted (so it never spans lines)."""
    bare = key and all(c.isascii() and (c.isalnum() or c in "-_") for c in key)
    return key if bare else json.dumps(key, ensure_ascii=False)


class _Reader:
    """Validation helpers that name the file, the table and the key in every message."""

    def __init__(self, source: str):
        self.source = source

    def where(self, table: str, key: str | None = None) -> str:
        return f"[{table}]" if key is None else f"[{table}].{_key(key)}"

    def format_error(self, text: str) -> FileFormatError:
        return FileFormatError(f"{self.source}: {text}")

    def value_error(self, text: str) -> InvalidParameterError:
        return InvalidParameterError(f"{self.source}: {text}")

    def table(self, data: dict, name: str, required: bool = False) -> dict:
        if name not in data:
            if required:
                raise self.format_error(f"the {self.where(name)} table is required")
            return {}
        table = data[name]
        if not isinstance(table, dict):
            raise self.format_error(f"{self.where(name)} must be a table, got {show(table)}")
        return table

    def known_keys(self, table: dict, name: str, valid) -> None:
        for key in table:
            if key not in valid:
                raise self.format_error(f"unknown key '{_key(key)}' in {self.where(name)}{suggestion(key, valid)}")

    def required(self, table: dict, name: str, key: str, what: str):
        if key not in table:
            raise self.format_error(f"{self.where(name, key)} is required ({what})")
        return table[key]

    def number(self, table: dict, name: str, key: str, default=None, sign: str = ""):
        """A finite number (``sign``: "" any, "positive", "non-negative"); ``default`` if absent."""
        if key not in table:
            return default
        return self.check_number(table[key], self.where(name, key), sign)

    def check_number(self, value, where: str, sign: str = "") -> float:
        kind = f"{sign} number" if sign else "number"
        article = "an" if kind[0] in "aeiou" else "a"
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.value_error(f"{where} must be {article} {kind}, got {show(value)}")
        try:
            v = float(value)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            raise self.value_error(f"{where} must be a finite {kind}, got {show(value)}")
        if (sign == "positive" and v <= 0) or (sign == "non-negative" and v < 0):
            raise self.value_error(f"{where} must be {article} {kind}, got {show(value)}")
        return v

    def vector(self, value, where: str, n: int, what: str) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != n:
            raise self.value_error(f"{where} must be {n} numbers {what}, got {show(value)}")
        return tuple(self.check_number(v, f"{where}[{i}]") for i, v in enumerate(value))

    def spec_number(self, table: dict, name: str, key: str):
        """The number ``[name].key`` as its declaration (:mod:`pkmlab.formats.scenario_keys`) says: its sign, and its
        default (None without one)."""
        k = _spec(SCENARIO[name], key)
        return self.number(table, name, key, k.default if k.has_default else None, k.sign)

    def spec_choice(self, table: dict, name: str, key: str) -> str:
        """The word ``[name].key`` among its declared choices, its declared default if absent (required without
        one)."""
        k = _spec(SCENARIO[name], key)
        return self.choice(table, name, key, k.choices, k.default if k.has_default else None)

    def choice(self, table: dict, name: str, key: str, choices, default=None) -> str:
        if key not in table:
            if default is None:
                raise self.format_error(f"{self.where(name, key)} is required (one of: {', '.join(choices)})")
            return default
        value = table[key]
        if not isinstance(value, str):
            raise self.value_error(f"{self.where(name, key)} must be one of {', '.join(choices)}, got {show(value)}")
        if value not in choices:
            close = difflib.get_close_matches(value, list(choices), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else f"; choose one of: {', '.join(choices)}"
            raise self.value_error(f"{self.where(name, key)} = {show(value)} is not known{hint}")
        return value


# ------------------------------------------------------------------ the tables
def _manipulator(rd: _Reader, table: dict):
    rd.known_keys(table, "manipulator", TABLES["manipulator"])
    preset = table.get("preset", _spec(SCENARIO["manipulator"], "preset").default)
    if not isinstance(preset, str) or preset not in PRESETS:
        close = difflib.get_close_matches(preset, list(PRESETS), n=1) if isinstance(preset, str) else []
        hint = f" (did you mean '{close[0]}'?)" if close else f"; presets: {', '.join(PRESETS)}"
        raise rd.value_error(f"{rd.where('manipulator', 'preset')} = {show(preset)} is not a known preset{hint}")
    params = table.get("params", {})
    if not isinstance(params, dict):
        raise rd.format_error(f"[manipulator.params] must be a table, got {show(params)}")
    rd.known_keys(params, "manipulator.params", PARAM_KEYS)
    for key, value in params.items():
        where = rd.where("manipulator.params", key)
        if key in _SCALAR:
            rd.check_number(value, where, "positive")
        elif key in _PER_LEG:
            if isinstance(value, list):
                rd.vector(value, where, 3, "(one per leg) or a single number")
                for i, v in enumerate(value):
                    rd.check_number(v, f"{where}[{i}]", "positive")
            else:
                rd.check_number(value, where, "positive")
        else:  # base_points
            if not isinstance(value, list) or len(value) != 3:
                raise rd.value_error(f"{where} must be 3 points [x, y], got {show(value)}")
            for i, point in enumerate(value):
                rd.vector(point, f"{where}[{i}]", 2, "[x, y]")
    if "b" in params and "base_points" in params:
        raise rd.format_error("[manipulator.params] has both b and base_points: give one of them")
    if not params:
        model, text = load("paper"), '[mechanism]\npreset = "paper"\n'
    else:
        from ..description.files import mechanism_to_toml

        description = manipulator_from_dict({"preset": preset, "params": params},
                                            f"{rd.source}: [manipulator.params]").to_mechanism()
        model, text = MechanismModel.from_description(description), mechanism_to_toml(description)
    warnings.warn(f"{rd.source}: [manipulator] is deprecated and will not be read by pkmlab 0.4; write the machine "
                  f"as [mechanism] instead:\n{text.rstrip()}", PkmlabDeprecationWarning, stacklevel=4)
    return model


def _mechanism(rd: _Reader, table: dict, folder: Path, ahead: bool = False):
    """The controller's model of a ``[mechanism]`` table: ``preset = "NAME"``, ``file = "PATH"`` (a
    mechanism file, relative to the scenario's folder) or a description inline; its loop compiled ahead where
    ``ahead`` (:func:`_model_of`)."""
    from ..description.files import mechanism_from_dict

    if "file" in table:
        others = sorted(set(table) - {"file"})
        if others:
            raise rd.value_error(f"[mechanism] has file and {', '.join(others)}: give one of them")
        return _description_file(rd, "[mechanism].file", table["file"], folder, ahead=ahead)
    try:
        return _model_of(mechanism_from_dict(table, "[mechanism]"), ahead)
    except PkmlabError as exc:
        raise rd.value_error(str(exc)) from None


def _description_file(rd: _Reader, where: str, path, folder: Path, named: bool = False,
                      ahead: bool = False) -> MechanismModel:
    """The machine of the description file ``path`` (relative to the scenario's ``folder``) the key ``where``
    names; the file's own errors with ``where`` before them when ``named``; its loop compiled ahead where
    ``ahead`` (:func:`_model_of`)."""
    from ..description.files import load_mechanism

    if not isinstance(path, str) or not path:
        raise rd.value_error(f"{where} must be a file name, got {show(path)}")
    try:
        return _model_of(load_mechanism(folder / path), ahead)
    except PkmlabError as exc:
        raise rd.value_error(f"{where}: {exc}" if named else str(exc)) from None


def _model_of(description, ahead: bool) -> MechanismModel:
    """The model of a scenario's machine. For a sampled-data run read to be run (``ahead``), its structure's loop
    starts compiling in a second process first (:func:`~pkmlab.simulation.ahead.compile_loop_ahead_of`; from an empty
    kernel cache only), while this process checks the description — the check compiles too — and prepares the run;
    a machine the check refuses ends that process."""
    process = compile_loop_ahead_of(description) if ahead else None
    try:
        return MechanismModel.from_description(description)
    except BaseException:
        end_compiling_ahead(process)
        raise


def _sampled_data(data: dict) -> bool:
    """Whether the scenario ``data`` runs sampled-data control, from its ``[controller].sample_time`` before that is
    checked (:func:`_controller` refuses a bad one): what decides only whether its loop starts compiling early."""
    controller = data.get("controller")
    sample_time = controller.get("sample_time") if isinstance(controller, dict) else None
    return sample_time is None or sample_time != 0


def _controller_model(rd: _Reader, table: dict, machine: MechanismModel, folder: Path) -> MechanismModel | None:
    """``[controller].mechanism = "PATH"``: the controller's own model of the machine (e.g. the identified one,
    ``pkmlab identify --consistent``), a description file of the same structure as the scenario's machine."""
    if "mechanism" not in table:
        return None
    path = table["mechanism"]
    model = _description_file(rd, "[controller].mechanism", path, folder, named=True)
    if model.kernels is not machine.kernels:
        raise rd.value_error(f"[controller].mechanism {path!r} is a {model.description.notation}, the machine a "
                             f"{machine.description.notation}: the controller's model must have its structure")
    return model


def _per_actuator(rd: _Reader, table: dict, name: str, key: str, n: int, sign: str, limit: bool = False):
    """A number, or a list of one per actuator, at ``[name].key`` (``inf`` allowed for a ``limit``)."""
    value = table[key]
    where = rd.where(name, key)

    def one(v, at):
        if limit and isinstance(v, float) and v == math.inf:
            return v
        return rd.check_number(v, at, sign)

    if isinstance(value, list):
        if len(value) != n:
            raise rd.value_error(f"{where} must be one number or {n}, one per actuator, got {show(value)}")
        return tuple(one(v, f"{where}[{i}]") for i, v in enumerate(value))
    return one(value, where)


#: The keys of ``[plant]`` that declare its drives (:class:`~pkmlab.simulation.realism.Drives`), with the sign of
#: their values.
DRIVE_KEYS = {k.name: k.sign for k in (*DRIVES, *PLANT_DRIVES) if k.many}


def _drives(rd: _Reader, table: dict, model, name: str = "plant") -> Drives | None:
    """The drives ``[name]`` declares (``[plant]``: the plant's; ``[controller]``: its model of them, which
    computed torque compensates), or None."""
    given = {key: _per_actuator(rd, table, name, key, model.n_actuators, sign, key == "effort_limit")
             for key, sign in DRIVE_KEYS.items() if key in table}
    if "coulomb_rate" in table:
        # no default here: Drives has it, and None tells it the key was not given
        given["coulomb_rate"] = rd.number(table, name, "coulomb_rate", None, _spec(DRIVES, "coulomb_rate").sign)
    if "stick_slip" in table:
        if not isinstance(table["stick_slip"], bool):
            raise rd.value_error(f"{rd.where(name, 'stick_slip')} must be true or false, got "
                                 f"{show(table['stick_slip'])}")
        given["stick_slip"] = table["stick_slip"]
    try:
        return Drives(**given) if given else None
    except InvalidParameterError as exc:
        raise rd.value_error(f"{rd.where(name)}: {exc}") from None


def _sensors(rd: _Reader, table: dict, model) -> Sensors | None:
    name = "sensors"
    rd.known_keys(table, name, TABLES[name])
    if not table:
        return None
    given = {k.name: _per_actuator(rd, table, name, k.name, model.n_actuators, k.sign)
             for k in SCENARIO[name] if k.many and k.name in table}
    spec = _spec(SCENARIO[name], "delay")
    delay = table.get("delay", spec.default)
    if isinstance(delay, bool) or not isinstance(delay, int) or not spec.minimum <= delay <= spec.maximum:
        raise rd.value_error(f"{rd.where(name, 'delay')} must be an integer number of samples from {spec.minimum} to "
                             f"{spec.maximum}, got {show(delay)}")
    return Sensors(**given, delay=delay, rates=rd.spec_choice(table, name, "rates"))


def _plant(rd: _Reader, table: dict, model):
    rd.known_keys(table, "plant", TABLES["plant"])
    mass = rd.spec_number(table, "plant", "mass_scale")
    length = rd.spec_number(table, "plant", "length_scale")
    if mass == 1.0 and length == 1.0:
        return None
    try:
        with np.errstate(all="ignore"):
            return scaled_model(model, mass, length)
    except (InvalidParameterError, OverflowError) as exc:
        raise rd.value_error(f"[plant]: the scaled machine is impossible (mass_scale = {mass:g}, "
                             f"length_scale = {length:g}): {exc}") from None


def _trajectory(rd: _Reader, table: dict, model: MechanismModel):
    name = "trajectory"
    kind = rd.spec_choice(table, name, "type")
    valid = ("type", "speed", "time_law", *TRAJECTORY_KEYS[kind])
    for key in table:
        if key in valid:
            continue
        if key in TABLES[name]:
            raise rd.format_error(f"{rd.where(name, key)} does not apply to a {kind} trajectory "
                                  f"(its keys: {', '.join(valid)})")
        raise rd.format_error(f"unknown key '{_key(key)}' in [{name}]{suggestion(key, valid)}")
    if kind == "fourier":
        return _fourier(rd, table, model)
    if kind == "waypoints" and "durations" in table:
        return _timed_waypoints(rd, table)
    if kind == "spline":
        if "durations" not in table:
            raise rd.format_error(f"{rd.where(name, 'durations')} is missing: a spline passes its points at the "
                                  "times the durations give (one per segment, s)")
        if "time_law" in table:
            raise rd.format_error(f"{rd.where(name, 'time_law')} does not apply to a spline (it starts and ends at "
                                  "rest by itself)")
        waypoints = _timed_waypoints(rd, table)
        return Spline(waypoints.points, waypoints.durations)
    speed = rd.check_number(rd.required(table, name, "speed", "the average speed in m/s"),
                            rd.where(name, "speed"), _spec(SCENARIO[name], "speed").sign)
    law = rd.spec_choice(table, name, "time_law")
    if kind == "circle" and isinstance(table.get("center"), list) and len(table["center"]) == 3:
        return _spatial_circle(rd, table, speed, law)
    for key in ("normal", "orientation"):
        if key in table:
            raise rd.format_error(f"{rd.where(name, key)} is for a circle of a spatial machine (center [x, y, z])")
    if kind == "circle":
        center = rd.vector(rd.required(table, name, "center", "[x, y] in m"), rd.where(name, "center"), 2, "[x, y]")
        radius = rd.check_number(rd.required(table, name, "radius", "in m"), rd.where(name, "radius"), "positive")
        start_angle = rd.spec_number(table, name, "start_angle")
        alpha = rd.spec_number(table, name, "alpha")
        alpha_end = rd.spec_number(table, name, "alpha_end")
        turns = rd.spec_number(table, name, "turns")
        path = Circle(center, radius, start_angle=start_angle, alpha=alpha, alpha_end=alpha_end, turns=turns)
        trajectory = Trajectory(path, speed, law)
    elif kind == "line":
        ends = [rd.vector(rd.required(table, name, key, "[x, y, alpha]"), rd.where(name, key), 3, "[x, y, alpha]")
                for key in ("start", "end")]
        if np.allclose(ends[0], ends[1]):
            raise rd.value_error(f"{rd.where(name, 'end')} must differ from start, got {show(list(ends[1]))}")
        trajectory = Trajectory(Line(*ends), speed, law)
    else:
        points = rd.required(table, name, "points", "a list of poses [x, y, alpha]")
        where = rd.where(name, "points")
        if not isinstance(points, list) or len(points) < 2:
            raise rd.value_error(f"{where} must be a list of at least two poses [x, y, alpha], got {show(points)}")
        poses = [rd.vector(p, f"{where}[{i}]", 3, "[x, y, alpha]") for i, p in enumerate(points)]
        for i in range(1, len(poses)):
            if np.allclose(poses[i - 1], poses[i]):
                raise rd.value_error(f"{where}[{i}] repeats the previous pose {show(points[i])}")
        trajectory = WaypointTrajectory(tuple(poses), speed, law)
    with np.errstate(all="ignore"):
        duration = float(trajectory.duration)
    if not math.isfinite(duration):
        raise rd.value_error(f"[trajectory]: the motion would last forever (length / speed is {duration})")
    return trajectory


def _spatial_circle(rd: _Reader, table: dict, speed: float, law: str) -> Trajectory:
    """``type = "circle"`` with ``center = [x, y, z]``: a circle of a spatial platform's point in the plane normal
    to ``normal`` (default ``[0, 0, 1]``), its ``orientation`` ``[roll, pitch, yaw]`` held (none for a
    translating platform)."""
    name = "trajectory"
    for key in ("alpha", "alpha_end"):
        if key in table:
            raise rd.format_error(f"{rd.where(name, key)} is a planar circle's: a spatial one holds its "
                                  "orientation = [roll, pitch, yaw]")
    center = rd.vector(table["center"], rd.where(name, "center"), 3, "[x, y, z]")
    radius = rd.check_number(rd.required(table, name, "radius", "in m"), rd.where(name, "radius"), "positive")
    normal = rd.vector(table.get("normal", list(_spec(SCENARIO[name], "normal").default)), rd.where(name, "normal"), 3,
                       "[x, y, z]")
    if not np.linalg.norm(normal) > 0:
        raise rd.value_error(f"{rd.where(name, 'normal')} must be a non-zero vector, got {show(table['normal'])}")
    orientation = table.get("orientation", [])
    if orientation != []:
        orientation = rd.vector(orientation, rd.where(name, "orientation"), 3, "[roll, pitch, yaw] in rad")
    path = SpatialCircle(center, radius, normal, rd.spec_number(table, name, "start_angle"), tuple(orientation),
                         rd.spec_number(table, name, "turns"))
    return Trajectory(path, speed, law)


def _fourier(rd: _Reader, table: dict, model: MechanismModel) -> FourierTrajectory:
    """``type = "fourier"``: a periodic motion of the machine's pose coordinates about ``center``, the velocity's
    Fourier coefficients ``a`` (cosines) and ``b`` (sines), one row per harmonic (what ``pkmlab excite``
    writes)."""
    name = "trajectory"
    for key in ("speed", "time_law"):
        if key in table:
            raise rd.format_error(f"{rd.where(name, key)} does not apply to a fourier trajectory (its period sets "
                                  "its timing)")
    names = model.pose_names
    center = rd.vector(rd.required(table, name, "center", f"[{', '.join(names)}]"), rd.where(name, "center"),
                       len(names), f"[{', '.join(names)}]")
    period = rd.check_number(rd.required(table, name, "period", "in s"), rd.where(name, "period"), "positive")
    periods = table.get("periods", _spec(SCENARIO[name], "periods").default)
    if isinstance(periods, bool) or not isinstance(periods, int) or periods < 1:
        raise rd.value_error(f"{rd.where(name, 'periods')} must be a positive integer, got {show(periods)}")
    rows = {}
    for key in ("a", "b"):
        value = rd.required(table, name, key, "one row per harmonic of one number per pose coordinate")
        kwhere = rd.where(name, key)
        if not isinstance(value, list) or not value:
            raise rd.value_error(f"{kwhere} must be a list of harmonics, each of {len(center)} numbers, got "
                                 f"{show(value)}")
        rows[key] = [rd.vector(row, f"{kwhere}[{i}]", len(center), "(one per pose coordinate, like center)")
                     for i, row in enumerate(value)]
    if len(rows["a"]) != len(rows["b"]):
        raise rd.value_error(f"{rd.where(name, 'b')} must have as many harmonics as a ({len(rows['a'])}), got "
                             f"{len(rows['b'])}")
    try:
        return FourierTrajectory(tuple(center), period, np.array(rows["a"]), np.array(rows["b"]), periods)
    except InvalidParameterError as error:
        raise rd.value_error(f"[{name}].{error}") from None


def _timed_waypoints(rd: _Reader, table: dict) -> TimedWaypoints:
    """``type = "waypoints"`` with ``durations``: poses of the machine's own coordinates (``[x, y, z]`` for the
    Delta), one time per segment, ``time_law`` quintic unless said otherwise."""
    name = "trajectory"
    if "speed" in table:
        raise rd.format_error(f"{rd.where(name, 'speed')}: give either speed or durations, not both")
    points = rd.required(table, name, "points", "a list of poses")
    where = rd.where(name, "points")
    if not isinstance(points, list) or len(points) < 2:
        raise rd.value_error(f"{where} must be a list of at least two poses, got {show(points)}")
    width = len(points[0]) if isinstance(points[0], list) else 0
    if width < 2:  # more than 6 for a kinematically redundant machine's controlled coordinates
        raise rd.value_error(f"{where}[0] must be a pose of 2 or more numbers ([x, y, z] for a Delta), got "
                             f"{show(points[0])}")
    poses = [rd.vector(p, f"{where}[{i}]", width, "(a pose, like points[0])")
             for i, p in enumerate(points)]
    for i in range(1, len(poses)):
        if np.allclose(poses[i - 1], poses[i]):
            raise rd.value_error(f"{where}[{i}] repeats the previous pose {show(points[i])}")
    durations = table["durations"]
    dwhere = rd.where(name, "durations")
    if not isinstance(durations, list) or len(durations) != len(poses) - 1:
        raise rd.value_error(f"{dwhere} must be {len(poses) - 1} times in s, one per segment, got {show(durations)}")
    times = [rd.check_number(d, f"{dwhere}[{i}]", "positive") for i, d in enumerate(durations)]
    law = rd.choice(table, name, "time_law", TIME_LAWS, "quintic")
    turn = rd.spec_choice(table, name, "orientation_path")
    if turn == "geodesic" and width != 6:
        raise rd.value_error(f"{rd.where(name, 'orientation_path')} = \"geodesic\" turns a rigid platform's whole "
                             f"orientation: its points are [x, y, z, roll, pitch, yaw], not {width} numbers")
    try:
        return TimedWaypoints(tuple(poses), tuple(times), law, turn)
    except InvalidParameterError as error:  # a geodesic's half turn or gimbal lock, named by its points
        raise rd.value_error(f"[{name}].{error}") from None


def _controller(rd: _Reader, table: dict, model) -> tuple[ControllerSpec, float]:
    name = "controller"
    rd.known_keys(table, name, TABLES[name])
    kind = rd.spec_choice(table, name, "type")
    kp = rd.spec_number(table, name, "kp")
    kv = rd.spec_number(table, name, "kv")
    sample_time = rd.spec_number(table, name, "sample_time")
    distribution = rd.spec_choice(table, name, "distribution")
    shares = {key: _per_actuator(rd, table, name, key, model.n_actuators, "positive" if key == "weights" else "")
              for key in ("weights", "preload") if key in table}
    shares = {key: value if isinstance(value, tuple) else (value,) * model.n_actuators
              for key, value in shares.items()}
    try:
        return ControllerSpec(kind, kp=kp, kv=kv, distribution=distribution, **shares), sample_time
    except InvalidParameterError as exc:
        raise rd.value_error(f"[{name}]: {exc}") from None


def _simulation(rd: _Reader, table: dict) -> dict:
    name = "simulation"
    rd.known_keys(table, name, TABLES[name])
    # the working mode as inverse_kinematics(mode=...) and --mode spell it ("auto", [1, -1, 1], "+-+"), checked
    # against the machine's two-branch legs by Scenario (whose message scenario_from_dict names the file in)
    keys = SCENARIO[name]
    out = {"working_mode": table.get("working_mode", _spec(keys, "working_mode").default)}
    out["singularity_margin"] = rd.spec_number(table, name, "singularity_margin")
    out["singularity_guard"] = rd.spec_number(table, name, "singularity_guard")
    spec = _spec(keys, "substeps")
    substeps = table.get("substeps", spec.default)
    if isinstance(substeps, bool) or not isinstance(substeps, int) or not spec.minimum <= substeps <= spec.maximum:
        raise rd.value_error(f"{rd.where(name, 'substeps')} must be an integer from {spec.minimum} to {spec.maximum}, "
                             f"got {show(substeps)}")
    out["substeps"] = substeps
    seed = table.get("seed", _spec(keys, "seed").default)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise rd.value_error(f"{rd.where(name, 'seed')} must be a non-negative integer, got {show(seed)}")
    out["seed"] = seed
    return out


def _timing(rd: _Reader, table: dict, model: MechanismModel) -> dict:
    """The ``[timing]`` table's limits and grid, checked: a number or one per actuator, positive."""
    name = "timing"
    rd.known_keys(table, name, TABLES[name])
    n = model.n_actuators
    out = {}
    for key in ("velocity", "acceleration", "effort"):
        if key not in table:
            continue
        value = table[key]
        where = rd.where(name, key)
        if isinstance(value, list):
            if len(value) != n:
                raise rd.value_error(f"{where} must be one number or {n}, one per actuator, got {show(value)}")
            out[key] = [rd.check_number(v, f"{where}[{i}]", "positive") for i, v in enumerate(value)]
        else:
            out[key] = rd.check_number(value, where, "positive")
    if not out:
        raise rd.format_error(f"{rd.where(name)} needs at least one limit: velocity, acceleration or effort")
    spec = _spec(SCENARIO[name], "grid")
    grid = table.get("grid", spec.default)
    if isinstance(grid, bool) or not isinstance(grid, int) or not spec.minimum <= grid <= spec.maximum:
        raise rd.value_error(f"{rd.where(name, 'grid')} must be an integer from {spec.minimum} to {spec.maximum}, got "
                             f"{show(grid)}")
    out["grid"] = grid
    return out


def _time_optimal(rd: _Reader, scenario: Scenario, limits: dict) -> Scenario:
    """``scenario`` on the time-optimal timing of its path, in its working mode (chosen along the path as its run
    chooses it when ``"auto"``)."""
    from ..simulation.run import sample_times
    from ..simulation.scenario import choose_working_mode

    try:
        mode = scenario.working_mode
        if mode == "auto":
            mode, _min_s = choose_working_mode(scenario, sample_times(scenario))
        retimed = time_optimal(scenario.trajectory, scenario.model, mode, **limits)
        return scenario.replace(trajectory=retimed, working_mode=mode)
    except PkmlabError as exc:
        raise rd.value_error(f"[timing]: {exc}") from None


# ------------------------------------------------------------------ public API
def scenario_from_dict(data: dict, source: str = "<scenario>", name: str | None = None, *,
                       compile_ahead: bool = False) -> Scenario:
    """The :class:`~pkmlab.simulation.scenario.Scenario` described by parsed TOML ``data``.

    ``source`` (the file) starts every error message; ``name`` defaults to its stem. ``compile_ahead``: the scenario
    is read to be run here (:func:`load_scenario`, ``pkmlab simulate``), so a sampled-data run's loop starts compiling
    as soon as its machine is known (:func:`_model_of`) — not for a study's variants, whose runs go to its workers.

    >>> s = scenario_from_dict({"trajectory": {"type": "circle", "center": [0.25, 0.21],
    ...                                        "radius": 0.05, "speed": 0.2}}, "mine.toml")
    >>> s.name, s.trajectory.duration
    ('mine', 1.5707963267948966)
    >>> scenario_from_dict({"trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": -0.05,
    ...                                    "speed": 0.2}}, "mine.toml")
    Traceback (most recent call last):
    ...
    pkmlab.errors.InvalidParameterError: mine.toml: [trajectory].radius must be a positive number, got -0.05
    """
    rd = _Reader(str(source))
    if not isinstance(data, dict):
        raise rd.format_error(f"a scenario must be a TOML document of tables, got {show(data)}")
    for key, value in data.items():
        if key in TABLES:
            continue
        owners = [t for t, keys in TABLES.items() if key in keys]
        if owners:
            hint = f" (did you mean [{owners[0]}].{key}?)"
        elif isinstance(value, dict):
            hint = suggestion(key, TABLES).replace("valid keys", "valid tables")
        else:
            hint = f" (a scenario holds only the tables {', '.join(f'[{t}]' for t in TABLES)})"
        raise rd.format_error(f"unknown {'table' if isinstance(value, dict) else 'key'} '{_key(key)}'{hint}")
    if "mechanism" in data and "manipulator" in data:
        raise rd.format_error("the scenario has both [manipulator] and [mechanism]: give one of them")
    ahead = compile_ahead and _sampled_data(data)
    if "mechanism" in data:
        model = _mechanism(rd, rd.table(data, "mechanism"), Path(str(source)).parent, ahead)
    elif "manipulator" in data:
        model = _manipulator(rd, rd.table(data, "manipulator"))
    else:
        model = _model_of(presets.preset("paper"), ahead)
    plant = _plant(rd, rd.table(data, "plant"), model)
    controller_model = _controller_model(rd, rd.table(data, "controller"), model, Path(str(source)).parent)
    if controller_model is not None:  # the scenario's machine is the plant; the controller computes with its own
        plant, model = plant or model, controller_model
    drives = _drives(rd, rd.table(data, "plant"), model)
    controller_drives = _drives(rd, rd.table(data, "controller"), model, "controller")
    sensors = _sensors(rd, rd.table(data, "sensors"), model)
    trajectory = _trajectory(rd, rd.table(data, "trajectory", required=True), model)
    controller, sample_time = _controller(rd, rd.table(data, "controller"), model)
    options = _simulation(rd, rd.table(data, "simulation"))
    try:
        options["working_mode"] = as_working_mode(model, options["working_mode"])
    except InvalidParameterError as exc:
        raise rd.value_error(f"[simulation].{exc}") from None
    if sample_time == 0 and "substeps" in rd.table(data, "simulation"):  # it would be silently ignored
        raise rd.format_error("[simulation].substeps applies to sampled-data control only, but "
                              "[controller].sample_time = 0 selects continuous-time control: remove one of them")
    step = sample_time or 1e-3
    samples = trajectory.duration / step
    # enough digits that a value just past its limit is never shown equal to it (0.0009996 s is not "0.001 s")
    if samples < 1:
        duration, one = apart(trajectory.duration, step)
        raise rd.value_error(f"[trajectory]: the motion would last {duration} s, less than one "
                             f"sample ({one} s): lengthen the path or lower [trajectory].speed")
    if samples > MAX_SAMPLES:
        count, most = apart(samples, MAX_SAMPLES)
        raise rd.value_error(f"the run would take {count} samples ({trajectory.duration:.4g} s at "
                             f"{step:g} s per sample; at most {most}): "
                             f"raise [trajectory].speed or [controller].sample_time")
    if name is None:
        name = Path(str(source)).stem or "scenario"
    timing = _timing(rd, rd.table(data, "timing"), model) if "timing" in data else None
    try:
        scenario = Scenario(model, trajectory, plant=plant, controller=controller, sample_time=sample_time,
                            name=name, drives=drives, sensors=sensors, controller_drives=controller_drives,
                            **options)
    except PkmlabError as exc:  # every value was checked above: a safety net for the message's file name
        raise rd.value_error(str(exc)) from None
    return scenario if timing is None else _time_optimal(rd, scenario, timing)


def fourier_table(trajectory: FourierTrajectory) -> dict:
    """The ``[trajectory]`` table of a :class:`~pkmlab.control.trajectory.FourierTrajectory` (read back by
    :func:`scenario_from_dict` to the same coefficients: floats are written to their last digit)."""
    return {"type": "fourier", "center": trajectory.center.tolist(), "period": trajectory.period,
            "periods": trajectory.periods, "a": trajectory.a.tolist(), "b": trajectory.b.tolist()}


def scenario_to_toml(data: dict, comment: str | None = None) -> str:
    """A scenario file's text from its tables ``data`` (nested tables written inline), with ``comment`` on top;
    :func:`scenario_from_dict` of the text read back gives the same scenario."""
    lines = [f"# {line}" if line else "#" for line in (comment or "").splitlines()]
    for table, values in data.items():
        lines += ["" if lines else None, f"[{_key(table)}]"]
        lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in values.items()]
    return "\n".join(line for line in lines if line is not None) + "\n"


def scenario_from_text(text: str, source: str | Path) -> Scenario:
    """The scenario of a scenario file's ``text``, already read from ``source`` (named in errors), to be run here
    (``compile_ahead``: :func:`scenario_from_dict`)."""
    return scenario_from_dict(parse_toml(text, source), str(source), Path(source).stem, compile_ahead=True)


def load_scenario(path: str | Path) -> Scenario:
    """Read a scenario file (format: this module's docstring); its name is the file's stem.

    Parameters
    ----------
    path : str or pathlib.Path
        The scenario file (TOML).

    Returns
    -------
    Scenario
        The run the file describes, ready for :func:`~pkmlab.simulate`.

    Raises
    ------
    FileFormatError
        If the file cannot be read, is malformed TOML, or does not follow the format (an unknown table or key).
    InvalidParameterError
        If ``path`` is not a file name, or a value in the file is refused (the message names the file and the key).

    Examples
    --------
    >>> import pkmlab
    >>> from pkmlab.formats.scenario import SCENARIO_DIR
    >>> scenario = pkmlab.load_scenario(SCENARIO_DIR / "fast.toml")
    >>> scenario.name, f"{scenario.trajectory.duration:.4f}", scenario.controller.kp
    ('fast', '0.7854', 1000.0)
    """
    if not isinstance(path, str) and not hasattr(path, "__fspath__"):
        raise InvalidParameterError(f"path must be a file name (a str or a pathlib.Path), got {type(path).__name__} "
                                    f"{shown(path, 50)}")
    data = read_toml(path)
    return scenario_from_dict(data, str(path), Path(path).stem, compile_ahead=True)


# ------------------------------------------------------------------ the paper's cases
PAPER_CASES = ("nominal", "disturbed", "fast")
#: The scenario files of the paper's cases (package data).
SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"


def paper_scenario(name: str = "nominal") -> Scenario:
    """The paper's simulated cases (conventions §7).

    The three cases of the paper are the scenario files ``scenarios/<name>.toml`` shipped in
    the package (``examples/`` links to them):

    * ``nominal``: the circle at 0.2 m/s, plant = model;
    * ``disturbed``: plant masses and link lengths ×1.15, inertias ×1.15³, base unchanged;
    * ``fast``: 0.4 m/s, plant = model;
    * ``disturbed_dynamics``: masses and inertias ×1.15, lengths unchanged (a variant, not a file).

    Parameters
    ----------
    name : {"nominal", "disturbed", "fast", "disturbed_dynamics"}
        The case (default ``"nominal"``).

    Returns
    -------
    Scenario

    Raises
    ------
    InvalidParameterError
        If ``name`` is not one of the cases.

    Examples
    --------
    >>> import pkmlab
    >>> scenario = pkmlab.paper_scenario("disturbed")
    >>> scenario.plant is None, f"{scenario.plant_model.description.platform.mass:.4f}"
    (False, '0.2691')
    """
    if isinstance(name, str) and name in PAPER_CASES:
        return load_scenario(SCENARIO_DIR / f"{name}.toml")
    from ..model.mechanism_model import load

    model = load("paper")
    if isinstance(name, str) and name == "disturbed_dynamics":
        return Scenario(model, paper_trajectory(0.2), plant=scaled_model(model, 1.15, 1.0), name=name)
    raise InvalidParameterError(
        f"unknown paper scenario name {shown(name)}: choose one of nominal, disturbed, fast, disturbed_dynamics"
    )
