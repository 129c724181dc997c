"""What one run of a study does: simulate its scenario, identify the plant from that run, or calibrate a machine
built with errors — and the metrics each job adds to the study's table.

``job = "simulate"`` (the default): the scenario's run and its summary's metrics.

``job = "identify"``: the scenario's run (typically an excitation trajectory, ``pkmlab excite``, on a plant with
drives and sensors), then its log — the measured actuators (``theta<j>_m`` when sensors are declared) and the
efforts — filtered and identified (:func:`~pkmlab.algorithms.identification.filter_measurements`,
:func:`~pkmlab.algorithms.identification.identify`) with the plant's geometry, as if calibrated. Its options, a
study file's ``[identification]`` table (each one also an axis, ``identification.window``)::

    window = 0.05          # the filter's window (s)
    polyorder = 4          # its polynomial's order
    drives = false         # estimate the drives' armature and friction too
    coulomb_rate = 0.0     # their Coulomb model: fc tanh(rate / coulomb_rate), 0 for fc sign(rate)

and its metrics, against the plant's own base parameters (its standard parameters, and its drives' ``N² I_m``,
``fv``, ``fc``, mapped to the base): ``base_error`` (the largest error over the largest base parameter),
``base_error_sigma`` (the largest error in units of its reported σ: about 3 when σ is honest),
``condition_number`` and ``max_relative_sigma_percent``.

``job = "calibrate"``: no simulation. The scenario's machine (its ``model``) as described; a machine built with
errors drawn per draw (:func:`~pkmlab.algorithms.calibration.perturbed_geometry`, seeded by the study's seed and
the draw, so that every grid point sees the same machines); its readings at ``poses`` measured poses, drawn at
random or chosen D-optimally among ``candidates``, measured with ``noise``; the calibration; and ``held_out``
other poses predicted from their readings. Options, a study file's ``[calibration]`` table::

    poses = 40             # measured poses
    noise = 1e-5           # the instrument's standard deviation per coordinate (m, rad)
    measure = "position"   # or "pose"
    size = 1e-3            # the geometry's errors: uniform in [-size, size] (m)
    angle = 0.00873        # the revolute actuators' zero errors: uniform in [-angle, angle] (rad)
    held_out = 50          # poses that check the result
    candidates = 0         # > 0: choose the poses D-optimally among this many (0: at random)
    span = 0.1             # the poses' region: span x the machine's size about its home pose...
    turn = 0.3             # ... and turn rad in orientation

and metrics ``held_out_error_m`` (the worst held-out point error), ``held_out_error_noise`` (the same over the
noise), ``rms_before``, ``rms_after``, ``observability_O1``, ``fixed_parameters`` (how many the poses do not
determine).
"""

from __future__ import annotations

import math

import numpy as np

from .._keys import defaults
from ..errors import InvalidParameterError, shown
from ..formats.study_keys import OPTIONS as _DECLARED

#: Each job's options and their defaults (declared in :mod:`pkmlab.formats.study_keys`).
OPTIONS = {job: defaults(keys) for job, keys in _DECLARED.items()}
#: Options that are counts, and options that are flags or words.
COUNTS = tuple(k.name for keys in _DECLARED.values() for k in keys if k.type == "integer")
FLAGS = tuple(k.name for keys in _DECLARED.values() for k in keys if k.type == "boolean")
WORDS = {k.name: k.choices for keys in _DECLARED.values() for k in keys if k.choices}
#: The metrics each job adds to the table.
METRICS = {
    "simulate": (),
    "identify": ("base_error", "base_error_sigma", "condition_number", "max_relative_sigma_percent"),
    "calibrate": ("held_out_error_m", "held_out_error_noise", "rms_before", "rms_after", "observability_O1",
                  "fixed_parameters"),
}
#: The two metrics each job's maps and distributions show, with their labels, and the figures' file stems.
HEADLINE = {
    "simulate": (("max_path_error_m", "max path error (m)", "error_map"),
                 ("peak_effort", "peak effort (N·m or N)", "effort_map")),
    "identify": (("base_error", "base-parameter error / largest base parameter", "error_map"),
                 ("condition_number", "condition number", "condition_map")),
    "calibrate": (("held_out_error_m", "held-out point error (m)", "error_map"),
                  ("rms_after", "RMS residual after calibration", "residual_map")),
}


def check_option(job: str, key: str, value, where: str):
    """``value`` of option ``key`` of ``job`` as the job uses it, or an error naming ``where``."""
    if key not in OPTIONS[job]:
        from .._format import suggestion

        raise InvalidParameterError(f"unknown key '{key}' in {where}{suggestion(str(key), tuple(OPTIONS[job]))}")
    if key in FLAGS:
        if not isinstance(value, bool):
            raise InvalidParameterError(f"{where}.{key} must be true or false, got {shown(value)}")
        return value
    if key in WORDS:
        if value not in WORDS[key]:
            raise InvalidParameterError(f"{where}.{key} must be one of {', '.join(WORDS[key])}, got {shown(value)}")
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(float(value)):
        raise InvalidParameterError(f"{where}.{key} must be a finite number, got {shown(value)}")
    spec = next(k for k in _DECLARED[job] if k.name == key)
    if key in COUNTS:
        if float(value) != int(value) or value < spec.minimum:
            kind = "non-negative" if spec.minimum == 0 else "positive"
            raise InvalidParameterError(f"{where}.{key} must be a {kind} integer, got {shown(value)}")
        return int(value)
    positive = spec.sign == "positive"
    if value < 0 or (value == 0 and positive):
        raise InvalidParameterError(f"{where}.{key} must be {'positive' if positive else '>= 0'}, got {shown(value)}")
    return float(value)


def job_options(job: str, given: dict, where: str) -> dict:
    """``job``'s options: the defaults with ``given`` (a study file's table) checked into them."""
    if not isinstance(given, dict):
        raise InvalidParameterError(f"{where} must be a table, got {shown(given)}")
    options = dict(OPTIONS[job])
    for key, value in given.items():
        options[key] = check_option(job, key, value, where)
    if job == "calibrate" and options["candidates"] and options["candidates"] < options["poses"]:
        raise InvalidParameterError(f"{where}.candidates = {options['candidates']}: fewer than the "
                                    f"{options['poses']} poses to choose among them")
    return options


# ------------------------------------------------------------------ identification
def _true_parameters(scenario, drives: bool) -> np.ndarray:
    """The plant's standard parameters (and its drives', in :data:`~pkmlab.algorithms.regressor.DRIVE_PARAMETERS`
    order): what an identification of its runs should find."""
    from ..algorithms.regressor import inertial_parameters

    plant = scenario.plant_model
    pi = inertial_parameters(plant)
    if not drives:
        return pi
    n = plant.n_actuators
    table = scenario.drives.table(n) if scenario.drives is not None else np.zeros((n, 5))
    return np.concatenate([pi, table[:, :3].reshape(-1)])


def identification_metrics(scenario, result, options: dict) -> dict:
    """The identify job's metrics for ``result``, the run of ``scenario``."""
    from ..algorithms.identification import filter_measurements, identify

    plant = scenario.plant_model
    theta = result.theta_measured if result.theta_measured is not None else result.theta
    data = filter_measurements(plant, result.t, theta, result.tau, window=options["window"],
                               polyorder=options["polyorder"], pose=result.pose[0], mode=result.working_mode,
                               reversals=options["reversals"])
    found = identify(plant, *data.states, data.tau, drives=options["drives"], coulomb_rate=options["coulomb_rate"])
    truth = found.base.of(_true_parameters(scenario, options["drives"]))
    error = np.abs(found.estimate - truth)
    with np.errstate(divide="ignore", invalid="ignore"):
        in_sigma = np.where(found.sigma > 0, error / found.sigma, np.where(error > 0, np.inf, 0.0))
    return {"base_error": float(error.max() / np.abs(truth).max()), "base_error_sigma": float(in_sigma.max()),
            "condition_number": float(found.condition_number),
            "max_relative_sigma_percent": float(np.max(found.relative_sigma))}


# ------------------------------------------------------------------ calibration
def calibration_metrics(model, options: dict, seed: int, draw: int) -> dict:
    """The calibrate job's metrics for draw ``draw`` of a study seeded ``seed``, on the described ``model``."""
    from ..algorithms.calibration import (
        calibrate,
        perturbed_geometry,
        predicted_measurements,
        reachable_poses,
        select_poses,
    )

    rng = np.random.default_rng((seed, draw))
    built, offsets = perturbed_geometry(model, rng, options["size"], options["angle"])
    count, held = options["poses"], options["held_out"]
    drawn = max(count, options["candidates"]) + held
    poses, q = reachable_poses(built, drawn, rng, span=options["span"], turn=options["turn"])
    readings = q[:, :model.n_actuators] - offsets
    measure = options["measure"]
    columns = [i for i, n in enumerate(model.pose_names) if measure == "pose" or n in ("x", "y", "z")]
    measured = poses[:, columns] + options["noise"] * rng.standard_normal((drawn, len(columns)))
    pool = np.arange(drawn - held)
    if options["candidates"]:
        chosen = pool[select_poses(model, readings[pool], measured[pool], count, measure=measure)]
    else:
        chosen = pool[:count]
    result = calibrate(model, readings[chosen], measured[chosen], measure=measure)
    check = np.arange(drawn - held, drawn)
    predicted = predicted_measurements(result.model, readings[check], poses[check][:, columns], measure=measure,
                                       offsets=result.offsets)
    point = [k for k, c in enumerate(columns) if model.pose_names[c] in ("x", "y", "z")]
    worst = float(np.linalg.norm(predicted[:, point] - poses[check][:, columns][:, point], axis=1).max())
    noise = options["noise"]
    return {"held_out_error_m": worst, "held_out_error_noise": worst / noise if noise > 0 else math.inf,
            "rms_before": float(result.rms_before), "rms_after": float(result.rms_after),
            "observability_O1": float(result.observability), "fixed_parameters": float(len(result.fixed))}
