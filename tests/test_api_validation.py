"""The public API refuses wrong arguments with a one-line PkmlabError that names the argument.

A Hypothesis fuzzer calls every public function and class the way a careless user would: one
argument at a time replaced by ``None``, a string, a dict, a bool, a wrong-shaped or ragged
array, NaN, infinity, a huge number, or an object of the wrong class (a Scenario where a model
belongs...). The property: the call succeeds, or raises a :class:`pkmlab.PkmlabError` whose
message is a single line naming the argument by its parameter name (for :class:`Planar3RRR`,
the paper's names ``l``, ``r``, ``a``... are accepted too). Never an AttributeError, a
TypeError, a raw NumPy error, nor a NumPy warning on the way (RuntimeWarnings are errors here).
A value accepted must also be usable: what a constructor returns is put to use (a scenario is
prepared for its run, a trajectory evaluated...), which must then succeed or raise a one-line
PkmlabError. ``pytest -s`` prints how many inputs each
target received.
"""

from __future__ import annotations

import collections
import dataclasses
import functools
import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import pkmlab
from pkmlab.algorithms.consistency import identified_model, physically_consistent
from pkmlab.control.controller import ControllerSpec
from pkmlab.control.excitation import excitation_trajectory
from pkmlab.control.trajectory import Circle, FourierTrajectory, Line, Trajectory, WaypointTrajectory
from pkmlab.formats.scenario import SCENARIO_DIR
from pkmlab.paper import dynamics
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.paper.plant import FullPlant, ReducedPlant
from pkmlab.simulation.realism import Drives, Sensors
from pkmlab.simulation.run import prepare_run

# ------------------------------------------------------------------ valid arguments
MODEL = Planar3RRR.paper()
# The configuration of pose (0.2, 0.21, 0) in working mode -+-, and its rates for THETA_DOT, as inverse kinematics and
# coordinate_rates give them (test_the_valid_arguments_are_the_machines_own checks it): written out, because every
# worker of ``pytest -n`` collects this module, and computing them here would make each compile the paper's kernels
# before its first test.
Q = np.array([0.18901246549290407, 3.112030887676176, -2.6424045361135295, 2.275956433356745, 1.6164584394659685,
              -0.29512459017084014, 0.0])
THETA = Q[:3].copy()
THETA_DOT = np.array([0.3, -0.2, 0.5])
THETA_DDOT = np.array([1.0, 0.0, -1.0])
TAU = np.array([0.1, -0.2, 0.3])
Q_DOT = np.array([0.3, -0.2, 0.5, -0.5290498661672587, -0.30979988136650916, 1.2622983416055762, -0.6279306161666469])
CIRCLE = Circle((0.25, 0.21), 0.05)
TRAJECTORY = Trajectory(CIRCLE, 0.2)
CONTROLLER = ControllerSpec("computed_torque", kp=400.0)
SCENARIO = pkmlab.paper_scenario("nominal").replace(sample_time=0.01, name="coarse")  # 158 samples: quick
RNG = np.random.default_rng(0)
# the one API, on the paper's machine as every machine loads (tests/test_api.py checks its numbers): the same
# configuration with the platform's pose
GENERIC = pkmlab.load("paper")
G_Q = np.array([*Q[:6], 0.2, 0.21, 0.0])
G_Q_DOT = np.array([0.3, -0.2, 0.5, -0.5290498661672584, -0.30979988136650893, 1.2622983416055762,
                    0.07572617776040173, 0.09158115598435614, -0.627930616166647])

# ------------------------------------------------------------------ careless arguments
NAN, INF = float("nan"), float("inf")
FIXED = [
    None, True, False, 0, -1, 1, 3, 10**20, -(10**20), 10**400, 0.0, -1.0, 1e-320, 1e308, -1e308, NAN, INF, -INF,
    1 + 2j, "", "abc", "nominal", "auto", "+-+", "0.5", "two\nlines", b"abc", {}, {"kp": 1.0}, {"x": 1.0},
    {1, 2, 3}, (), [], [[]], [None], [None] * 3, [1.0, 2.0], [1.0, 2.0, 3.0], [1.0] * 4, [1.0] * 7,
    [[1.0, 2.0], [3.0]], [[1.0] * 3] * 2, [1.0, "a", 3.0], [1, [2], 3], [NAN] * 3, [INF] * 7, [1e308] * 3,
    [10**400] * 3, [True, False, True], np.float64(NAN), np.int64(-5), np.zeros(()), np.zeros(2), np.zeros(3),
    np.zeros(4), np.zeros(7), np.zeros((3, 3)), np.zeros((7, 3)), np.zeros((0, 3)), np.zeros((2, 7)),
    np.zeros((3, 2)), np.zeros((2, 1, 3)), np.full(3, NAN), np.full(7, INF), np.ones(3) + 1j,
    np.array(["a", "b", "c"]), np.array([["a", "b"], ["c", "d"]]), np.zeros(3, dtype=bool),
    np.arange(3, dtype=np.int64), MODEL, GENERIC, SCENARIO, CONTROLLER, CIRCLE, TRAJECTORY, RNG, object(),
    lambda *args: [1.0, 2.0], Path("no-such-file.toml"), Ellipsis,
]
_floats = st.floats(allow_nan=True, allow_infinity=True)
CARELESS = st.one_of(
    st.sampled_from(FIXED),
    _floats,
    st.integers(),
    st.text(max_size=6),
    st.lists(_floats, max_size=8),
    st.lists(st.lists(_floats, max_size=4), max_size=4),
    hnp.arrays(np.float64, hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=8), elements=_floats),
)
#: For the plants, no huge finite numbers: a torque of 1e47 N·m or a t_final of 1e20 s is well formed, and
#: integrating it takes forever (the wrong types and shapes are the same).
CARELESS_TYPES = st.one_of(
    st.sampled_from([v for v in FIXED if not (isinstance(v, (int, float)) and 1e3 < abs(v) < INF)]),
    st.integers(-10, 10),
    st.text(max_size=6),
)


# ------------------------------------------------------------------ targets
@dataclass
class Target:
    """A public callable, valid keyword arguments, and which of them to corrupt.

    ``names`` maps a parameter to the regular expressions that count as naming it (default: the
    parameter's own name as a word); ``examples`` is the number of inputs Hypothesis tries.
    """

    name: str
    call: Callable
    valid: dict
    params: tuple = ()
    names: dict = field(default_factory=dict)
    examples: int = 250
    then: Callable | None = None  # puts an accepted result to use
    careless: st.SearchStrategy = CARELESS

    def __post_init__(self):
        self.params = tuple(self.params) or tuple(self.valid)


def _fields(cls) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls) if f.init)


def _sig(func, **valid) -> Target:
    return Target(f"{func.__module__.removeprefix('pkmlab.')}.{func.__name__}", func, valid)


# the paper's parameter names stand for the model's attributes in Planar3RRR's messages
PAPER_NAMES = {
    "base_points": [r"\bbase_points\b", r"\bbase point"],
    "active_lengths": [r"\bactive_lengths\b", r"\bl\b"],
    "passive_lengths": [r"\bpassive_lengths\b", r"\br\b"],
    "platform_side": [r"\bplatform_side\b", r"\ba \(platform side\)", r"\ba = "],
    "active_masses": [r"\bactive_masses\b", r"\bmass_l\b"],
    "passive_masses": [r"\bpassive_masses\b", r"\bmass_r\b"],
    "platform_mass": [r"\bplatform_mass\b", r"\bmass_a\b"],
    "active_inertias": [r"\bactive_inertias\b", r"\binertia_l\b"],
    "passive_inertias": [r"\bpassive_inertias\b", r"\binertia_r\b"],
    "platform_inertia": [r"\bplatform_inertia\b", r"\binertia_a\b"],
    "a": [r"\ba \(platform side\)", r"\ba = "],  # "a" alone would match the article
    "b": [r"\bb\b", r"\bbase point", r"\bthe base\b"],
}
_MODEL_ARGS = dict(base_points=MODEL.base_points, active_lengths=MODEL.active_lengths,
                   passive_lengths=MODEL.passive_lengths, platform_side=MODEL.platform_side,
                   active_masses=MODEL.active_masses, passive_masses=MODEL.passive_masses,
                   platform_mass=MODEL.platform_mass, active_inertias=MODEL.active_inertias,
                   passive_inertias=MODEL.passive_inertias, platform_inertia=MODEL.platform_inertia,
                   active_com=None, passive_com=None, platform_com=None)
_PAPER_PARAMS = dict(b=0.52, l=0.25, r=0.1667, a=0.125, mass_l=0.468, mass_r=0.312, mass_a=0.234,
                     inertia_l=2.438e-3, inertia_r=0.722e-3, inertia_a=0.305e-3, base_points=None)


def _reduced_plant(model, rtol, atol, singularity_guard, q0, theta_dot0, tau, t_final, t_eval):
    plant = ReducedPlant(model, rtol=rtol, atol=atol, singularity_guard=singularity_guard)
    return plant.simulate(q0, theta_dot0, tau, t_final, t_eval=t_eval)


def _actuator_space_plant(model, rtol, atol, singularity_guard, q0, theta_dot0, tau, t_final, t_eval):
    plant = pkmlab.ActuatorSpacePlant(model, rtol=rtol, atol=atol, singularity_guard=singularity_guard)
    return plant.simulate(q0, theta_dot0, tau, t_final, t_eval=t_eval)


def _full_space_plant(model, rtol, atol, stabilization, q0, q_dot0, tau, t_final, t_eval):
    plant = pkmlab.FullSpacePlant(model, rtol=rtol, atol=atol, stabilization=stabilization)
    return plant.simulate(q0, q_dot0, tau, t_final, t_eval=t_eval)




def _full_plant(model, rtol, atol, stabilization, q0, q_dot0, tau, t_final, t_eval):
    plant = FullPlant(model, rtol=rtol, atol=atol, stabilization=stabilization)
    return plant.simulate(q0, q_dot0, tau, t_final, t_eval=t_eval)


_PLANT = dict(model=MODEL, rtol=1e-9, atol=1e-10, q0=Q, tau=np.zeros(3), t_final=1e-3, t_eval=None)
# a well-formed but wild state, torque or rate blows the integration up: the error names the time
_BLOW_UP = [r"\bt = "]
_PLANT_NAMES = {name: [rf"\b{name}\b", *_BLOW_UP] for name in
                ("theta_dot0", "q_dot0", "tau", "t_final", "stabilization", "rtol", "atol")}
_SPACE_PLANT = dict(model=GENERIC, rtol=1e-9, atol=1e-10, q0=G_Q, tau=np.zeros(3), t_final=1e-3, t_eval=None)
_SPACE_PLANT_NAMES = {name: [rf"\b{name}\b", *_BLOW_UP] for name in
                      ("theta_dot0", "q_dot0", "tau", "t_final", "stabilization", "rtol", "atol")}


_LOG_T = np.linspace(0.0, 0.04, 41)
_LOG_THETA = THETA + 0.05 * np.sin(40.0 * _LOG_T)[:, None]


class Lazy:
    """A valid argument computed when a test first needs it, not as the module is collected (every worker of
    ``pytest -n`` collects every module: a run or an identification made there costs each worker its compiles)."""

    def __init__(self, make: Callable, array: bool = False):
        self.make, self.array = make, array  # array: the value is a non-empty array of floats

    @functools.cached_property
    def value(self):
        return self.make()


def _states_identified():
    states = pkmlab.random_states(GENERIC, 8, seed=1)
    tau = pkmlab.inverse_dynamics(GENERIC, *states)
    return states, tau, pkmlab.identify(GENERIC, *states, tau)


_STATES = Lazy(_states_identified)
_RUN = Lazy(lambda: pkmlab.simulate(SCENARIO))


def _use_trajectory(trajectory):
    return trajectory.desired(np.linspace(0.0, trajectory.duration, 5))


def _use_path(path):
    return path.at(np.linspace(0.0, path.length, 5))

TARGETS = [
    # the one API
    _sig(pkmlab.load, source="five_bar"),
    _sig(pkmlab.working_modes, model=GENERIC),
    _sig(pkmlab.inverse_kinematics, model=GENERIC, pose=[0.2, 0.21, 0.0], mode=None, on_unreachable="raise"),
    _sig(pkmlab.forward_kinematics, model=GENERIC, theta=THETA, actuators=None),
    _sig(pkmlab.branch_following, model=GENERIC, q_previous=G_Q, theta=THETA + 0.01, singularity_guard=1e-6,
         max_step=0.05),
    *(_sig(f, model=GENERIC, q=G_Q) for f in (
        pkmlab.constraint_residual, pkmlab.constraint_jacobian, pkmlab.coordinate_jacobian, pkmlab.velocity_jacobian,
        pkmlab.singularity_measure, pkmlab.singularity_kinds)),
    *(_sig(f, model=GENERIC, q=G_Q, theta_dot=THETA_DOT) for f in (
        pkmlab.coordinate_rates, pkmlab.acceleration_bias, pkmlab.actuator_space_model)),
    _sig(pkmlab.coordinate_accelerations, model=GENERIC, q=G_Q, theta_dot=THETA_DOT, theta_ddot=THETA_DDOT),
    _sig(pkmlab.full_space_model, model=GENERIC, q=G_Q, q_dot=G_Q_DOT),
    *(_sig(f, model=GENERIC, q=G_Q) for f in (pkmlab.pose_coordinate_jacobian, pkmlab.actuation_jacobian)),
    _sig(pkmlab.actuation_singularity_measure, model=GENERIC, q=G_Q, actuators=None),
    _sig(pkmlab.pose_space_model, model=GENERIC, q=G_Q, pose_dot=[0.1, 0.0, 0.2]),
    _sig(pkmlab.distribute_efforts, W=[[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]], force=[1.0, 0.0], method="minimum_norm",
         weights=None, preload=None, limits=None, where=""),
    _sig(pkmlab.constrained_dynamics, model=GENERIC, q=G_Q, q_dot=G_Q_DOT, tau=TAU),
    _sig(pkmlab.inverse_dynamics, model=GENERIC, q=G_Q, theta_dot=THETA_DOT, theta_ddot=THETA_DDOT),
    _sig(pkmlab.forward_dynamics, model=GENERIC, q=G_Q, theta_dot=THETA_DOT, tau=TAU),
    *(_sig(f, model=GENERIC) for f in (pkmlab.inertial_parameter_names, pkmlab.inertial_parameters)),
    _sig(pkmlab.dynamics_regressor, model=GENERIC, q=G_Q, theta_dot=THETA_DOT, theta_ddot=THETA_DDOT),
    Target("random_states", pkmlab.random_states, dict(model=GENERIC, count=3, seed=0, mode=None), examples=60),
    Target("base_parameters", pkmlab.base_parameters,
           dict(model=GENERIC, states=(np.stack([G_Q] * 4), np.eye(4, 3), np.ones((4, 3))), seed=0, drives=False),
           examples=60),
    _sig(pkmlab.drive_parameter_names, model=GENERIC),
    _sig(pkmlab.follow_path, model=GENERIC, q_start=G_Q, theta=THETA + np.linspace(0.0, 0.02, 5)[:, None],
         singularity_guard=1e-6),
    Target("filter_measurements", pkmlab.filter_measurements,
           dict(model=GENERIC, t=_LOG_T, theta=_LOG_THETA, tau=np.zeros((41, 3)), window=0.01, polyorder=4,
                decimate="auto", q_start=G_Q, pose=None, mode=None, first_row=0, efforts="held", reversals="keep"),
           examples=80),
    Target("identify", pkmlab.identify, dict(model=GENERIC, q=Lazy(lambda: _STATES.value[0][0], True),
                                             theta_dot=Lazy(lambda: _STATES.value[0][1], True),
                                             theta_ddot=Lazy(lambda: _STATES.value[0][2], True),
                                             tau=Lazy(lambda: _STATES.value[1], True), drives=False, base=None),
           examples=60),
    Target("physically_consistent", physically_consistent,
           dict(model=GENERIC, identification=Lazy(lambda: _STATES.value[2]), prior=None, slack=0.01, min_mass=None),
           examples=15),
    Target("identified_model", identified_model, dict(model=GENERIC, parameters=pkmlab.inertial_parameters(GENERIC)),
           examples=40),
    Target("ActuatorSpacePlant.simulate", _actuator_space_plant,
           {**_SPACE_PLANT, "singularity_guard": 1e-6, "theta_dot0": np.zeros(3)},
           names=_SPACE_PLANT_NAMES, examples=150, careless=CARELESS_TYPES),
    Target("FullSpacePlant.simulate", _full_space_plant, {**_SPACE_PLANT, "stabilization": 20.0, "q_dot0": np.zeros(9)},
           names=_SPACE_PLANT_NAMES, examples=150, careless=CARELESS_TYPES),
    Target("draw", pkmlab.draw, dict(model=GENERIC, q=G_Q, title=None), examples=40),
    _sig(pkmlab.time_optimal, trajectory=TRAJECTORY, model=GENERIC, mode=(-1, 1, -1), velocity=2.0, acceleration=None,
         effort=[0.5, 0.5, 0.5], grid=40),
    # the paper's own formulation (the independent oracle of the tests)
    _sig(kin.inverse_kinematics, model=MODEL, pose=[0.2, 0.21, 0.0], mode=None, on_unreachable="raise"),
    _sig(kin.forward_kinematics, model=MODEL, theta=THETA),
    _sig(kin.branch_following, model=MODEL, q_previous=Q, theta=THETA + 0.01, singularity_guard=1e-6),
    *(_sig(f, model=MODEL, q=Q) for f in (
        kin.platform_pose, kin.constraint_residual, kin.constraint_jacobian, kin.passive_jacobian,
        kin.actuated_jacobian, kin.velocity_jacobian, kin.platform_jacobian,
        kin.forward_singularity_determinant, kin.singularity_measure, kin.working_mode_of)),
    *(_sig(f, model=MODEL, q=Q, theta_dot=THETA_DOT) for f in (
        kin.passive_rates, kin.coordinate_rates, kin.acceleration_bias)),
    _sig(kin.coordinate_accelerations, model=MODEL, q=Q, theta_dot=THETA_DOT, theta_ddot=THETA_DDOT),
    # dynamics
    _sig(dynamics.mass_matrix, model=MODEL, q=Q),
    *(_sig(f, model=MODEL, q=Q, q_dot=Q_DOT) for f in (
        dynamics.coriolis_matrix, dynamics.velocity_product, dynamics.kinetic_energy)),
    *(_sig(f, model=MODEL, q=Q, q_dot=Q_DOT, tau=TAU) for f in (
        dynamics.constrained_accelerations, dynamics.lagrange_multipliers)),
    *(_sig(f, model=MODEL, q=Q, theta_dot=THETA_DOT) for f in (
        dynamics.actuator_space_model, dynamics.actuator_space_coriolis_matrix)),
    _sig(dynamics.inverse_dynamics, model=MODEL, q=Q, theta_dot=THETA_DOT, theta_ddot=THETA_DDOT),
    _sig(dynamics.forward_dynamics, model=MODEL, q=Q, theta_dot=THETA_DOT, tau=TAU),
    # the model
    Target("Planar3RRR", Planar3RRR, _MODEL_ARGS, names=PAPER_NAMES, examples=150),
    Target("Planar3RRR.from_params", Planar3RRR.from_params, _PAPER_PARAMS, names=PAPER_NAMES, examples=150),
    Target("Planar3RRR.replace", MODEL.replace, {}, _fields(Planar3RRR), names=PAPER_NAMES, examples=150),
    # analyses
    _sig(pkmlab.singularity_map, model=GENERIC, alpha=0.0, mode=(-1, 1, -1), x_range=None, y_range=None,
         resolution=5, progress=None),
    # trajectories and controllers
    Target("Circle", Circle, dict(center=(0.25, 0.21), radius=0.05, start_angle=math.pi, alpha=0.0, alpha_end=None,
                                  turns=1.0), then=_use_path),
    Target("Line", Line, dict(start=(0.2, 0.2, 0.0), end=(0.3, 0.2, 0.1)), then=_use_path),
    Target("Trajectory", Trajectory, dict(path=CIRCLE, speed=0.2, law="cubic"), then=_use_trajectory),
    Target("WaypointTrajectory", WaypointTrajectory, dict(points=((0.2, 0.2, 0.0), (0.3, 0.2, 0.1)), speed=0.1,
                                                          law="cubic"), then=_use_trajectory),
    Target("FourierTrajectory", FourierTrajectory, dict(center=(0.25, 0.21, 0.0), period=2.0,
                                                        a=np.array([[0.01, 0.0, 0.02], [-0.01, 0.0, -0.02]]),
                                                        b=np.array([[0.02, 0.01, 0.0], [-0.01, -0.005, 0.0]]),
                                                        periods=1), then=_use_trajectory),
    Target("excitation_trajectory", excitation_trajectory,
           dict(model=GENERIC, period=2.0, harmonics=2, periods=1, center=None, mode=None, excursion=0.02,
                velocity=None, effort=None, singularity_margin=0.05, drives=False, seed=0, iterations=1,
                callback=None), examples=30),
    Target("ControllerSpec", ControllerSpec, dict(kind="computed_torque", kp=400.0, kv=None),
           then=lambda spec: spec.velocity_gain),
    # scenarios and simulation (an accepted scenario is prepared for its run: pre-flight, desired motion)
    Target("Scenario", pkmlab.Scenario, dict(model=GENERIC, trajectory=TRAJECTORY, plant=None, controller=CONTROLLER,
                                             sample_time=0.01, working_mode="auto", singularity_margin=0.05,
                                             singularity_guard=0.01, substeps=1, name="mine",
                                             drives=Drives(viscous=0.01), sensors=Sensors(resolution=1e-4), seed=0),
           then=prepare_run),
    Target("Drives", Drives, dict(gear_ratio=2.0, armature=(1e-5, 1e-5, 2e-5), viscous=0.01, coulomb=0.002,
                                  coulomb_rate=1e-3, effort_limit=1.0, effort_noise=0.0), then=lambda d: d.table(3)),
    Target("Sensors", Sensors, dict(resolution=1e-4, noise=(0.0, 1e-5, 0.0), delay=1, rates="difference"),
           then=lambda s: s.resolutions(3)),
    Target("Scenario.replace", SCENARIO.replace, {}, _fields(pkmlab.Scenario), then=prepare_run),
    _sig(pkmlab.simulate, scenario=SCENARIO),
    _sig(pkmlab.simulate_batch, scenarios=[SCENARIO], on_error="raise"),
    _sig(pkmlab.perturbed_model, model=GENERIC, rng=RNG, spread=0.15),
    _sig(pkmlab.paper_scenario, name="nominal"),
    _sig(pkmlab.load_scenario, path=SCENARIO_DIR / "nominal.toml"),
    # studies (pkmlab.sweep and pkmlab.tune run whole studies — processes, a cluster, files — and are checked
    # argument by argument in tests/test_study.py)
    Target("Study.create", pkmlab.Study.create, dict(base=SCENARIO_DIR / "fast.toml", grid={"controller.kp": [500.0]},
                                                     uncertainty=None, draws=0, seed=0, name=None, source="<study>",
                                                     combine="cross"), examples=60),
    _sig(pkmlab.load_study, path=Path(__file__).parents[1] / "examples" / "fast_gain_sweep.toml"),
    # the notebook's interactive view of a run
    Target("show", pkmlab.show, dict(result=_RUN), examples=40),
    Target("plot", pkmlab.plot, dict(result=_RUN), examples=40),
    # plants
    Target("ReducedPlant.simulate", _reduced_plant, {**_PLANT, "singularity_guard": 1e-6, "theta_dot0": np.zeros(3)},
           names=_PLANT_NAMES, examples=150, careless=CARELESS_TYPES),
    Target("FullPlant.simulate", _full_plant, {**_PLANT, "stabilization": 20.0, "q_dot0": np.zeros(7)},
           names=_PLANT_NAMES, examples=150, careless=CARELESS_TYPES),
]

#: Inputs tried per target (printed at the end of the module with ``pytest -s``).
TRIED: collections.Counter = collections.Counter()


def _patterns(target: Target, param: str, bad) -> list[str]:
    patterns = list(target.names.get(param, [rf"\b{re.escape(param)}\b"]))
    if param == "path" and isinstance(bad, (str, PathLike)):  # a file's errors name the file itself
        patterns += [re.escape(text) for text in (str(bad), str(Path(bad)), repr(str(Path(bad))))]
    return patterns


def _valid(target: Target) -> dict:
    """``target``'s valid arguments, the lazy ones computed."""
    return {name: value.value if isinstance(value, Lazy) else value for name, value in target.valid.items()}


def check(target: Target, param: str, bad) -> None:
    """Call ``target`` with ``param`` replaced by ``bad``: success, or a one-line PkmlabError naming ``param``."""
    TRIED[target.name] += 1
    valid = _valid(target)
    try:
        result = target.call(**{**valid, param: bad})
    except pkmlab.PkmlabError as exc:
        message = str(exc)
        where = f"{target.name}({param}={bad!r}) raised {type(exc).__name__}({message!r})"
        assert message and "\n" not in message, f"{where}: the message is not one line"
        assert any(re.search(p, message) for p in _patterns(target, param, bad)), f"{where}: {param!r} is not named"
        return
    if target.then is not None:  # accepted: then it must be usable (or refused later, in one line)
        try:
            target.then(result)
        except pkmlab.PkmlabError as exc:
            assert str(exc) and "\n" not in str(exc), f"{target.name}({param}={bad!r}), then: {exc!r}"


FUZZ = settings(derandomize=True, database=None, deadline=None, suppress_health_check=list(HealthCheck))


@pytest.fixture(scope="module", autouse=True)
def report_counts():
    yield
    print(f"\napi fuzzer: {sum(TRIED.values())} inputs over {len(TRIED)} targets")
    for name, n in sorted(TRIED.items()):
        print(f"  {name:45s} {n:5d}")


# NumPy's warnings are errors here: a huge value is refused by its name, or computed quietly (an overflow
# the function then names), never warned of with NumPy's words first
@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("target", TARGETS, ids=lambda t: t.name)
def test_wrong_arguments_are_refused_by_name(target):
    @settings(FUZZ, max_examples=target.examples)
    @given(param=st.sampled_from(target.params), bad=target.careless)
    def fuzz(param, bad):
        check(target, param, bad)

    fuzz()


def test_every_public_callable_is_fuzzed():
    """A new public function or class must get a target here."""
    fuzzed = {t.name.split(".")[-1] for t in TARGETS} | {t.name.split(".")[0] for t in TARGETS}
    fuzzed |= {"ReducedPlant", "FullPlant", "ActuatorSpacePlant", "FullSpacePlant"}
    # results, built by pkmlab, not by users
    exempt = {"InverseKinematicsSolution", "ForwardKinematicsSolution", "AssemblyMode", "SimulationResult",
              "PlantRun", "SingularityMap", "Singularities", "TimeOptimal", "FullSpaceModel", "ConstrainedDynamics",
              "ActuatorSpaceModel", "BaseParameters", "Identification", "Measurements", "PoseSpaceModel",
              "EffortDistribution",
              "MechanismModel",  # built by pkmlab.load, fuzzed above
              "sweep", "tune"}  # whole studies: their arguments are checked one by one in tests/test_study.py
    public = {name: getattr(pkmlab, name) for name in pkmlab.__all__}
    callables = [name for name, obj in public.items()
                 if callable(obj) and not (isinstance(obj, type) and issubclass(obj, Exception))]
    missing = [name for name in callables if name not in fuzzed | exempt]
    missing += [f"dynamics.{name}" for name in dynamics.__all__ if name not in fuzzed]
    assert not missing, f"public callables without a fuzz target: {missing}"


# ------------------------------------------------------------------ the instances
def test_simulate_names_a_wrong_scenario():
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^scenario must be a Scenario.*paper_scenario"):
        pkmlab.simulate("nominal")


@pytest.mark.parametrize(("changes", "name"), [
    ({"controller": {"kp": 400.0}}, "controller"),
    ({"model": None}, "model"),
    ({"plant": SCENARIO}, "plant"),
    ({"trajectory": CIRCLE}, "trajectory"),
    ({"working_mode": "bad"}, "working_mode"),
    ({"name": 3}, "name"),
    ({"sample_tim": 0.01}, "sample_tim"),
])
def test_scenario_replace_names_a_wrong_value(changes, name):
    with pytest.raises(pkmlab.InvalidParameterError, match=rf"\b{name}\b"):
        SCENARIO.replace(**changes)


@pytest.mark.parametrize("spelling", ["-+-", ("-", "+", "-"), (-1, 1, -1), ["-1", "+1", "-1"], np.array([-1, 1, -1])])
def test_scenario_working_mode_takes_the_spellings_of_inverse_kinematics(spelling):
    scenario = SCENARIO.replace(working_mode=spelling)
    assert scenario.working_mode == (-1, 1, -1)
    assert all(type(s) is int for s in scenario.working_mode)
    np.testing.assert_array_equal(kin.inverse_kinematics(MODEL, [0.2, 0.21, 0.0], mode=spelling).q,
                                  kin.inverse_kinematics(MODEL, [0.2, 0.21, 0.0], mode=(-1, 1, -1)).q)


def test_the_valid_arguments_are_the_machines_own():
    """The configurations and rates written out above are the paper machine's (inverse kinematics and
    ``coordinate_rates``, both formulations), to round-off (another platform's libm may differ in the last bit)."""
    close = functools.partial(np.testing.assert_allclose, rtol=0.0, atol=1e-13)
    ik = kin.inverse_kinematics(MODEL, [0.2, 0.21, 0.0], mode=(-1, 1, -1))
    close(ik.q, Q)
    close(ik.theta, THETA)
    close(kin.coordinate_rates(MODEL, Q, THETA_DOT), Q_DOT)
    close(pkmlab.inverse_kinematics(GENERIC, [0.2, 0.21, 0.0], mode=(-1, 1, -1)).q, G_Q)
    close(pkmlab.coordinate_rates(GENERIC, G_Q, THETA_DOT), G_Q_DOT)


def test_planar3rrr_replace_names_an_unknown_attribute():
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^platform_sid is not an attribute"):
        MODEL.replace(platform_sid=0.1)


@pytest.mark.parametrize("bad", [[1.0, 2.0], [1.0, 2.0, 3.0, 4.0], np.zeros((3, 2)), None, "abc"])
def test_theta_ddot_is_validated_like_the_other_arrays(bad):
    for call in (lambda: kin.coordinate_accelerations(MODEL, Q, THETA_DOT, bad),
                 lambda: dynamics.inverse_dynamics(MODEL, Q, THETA_DOT, bad)):
        with pytest.raises(pkmlab.InvalidParameterError, match=r"\btheta_ddot\b"):
            call()


def test_an_effort_function_of_the_wrong_shape_is_refused():
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^tau\(t, theta, theta_dot\) must return 3 numbers"):
        ReducedPlant(MODEL).simulate(Q, np.zeros(3), lambda t, theta, theta_dot: [1.0, 2.0], 1e-3)


def test_a_scenario_with_a_string_working_mode_runs():
    assert pkmlab.simulate(SCENARIO.replace(working_mode="-+-")).working_mode == (-1, 1, -1)


# ------------------------------------------------------------------ numbers written as text or truth values
def _numeric_params(target: Target) -> list[str]:
    """The parameters of ``target`` whose valid value is an array of floats (not a mode, a name or a path)."""
    valid = target.valid
    return [p for p in target.params if (isinstance(valid.get(p), Lazy) and valid[p].array)
            or (isinstance(valid.get(p), np.ndarray) and valid[p].dtype.kind == "f" and valid[p].size)]


_NUMERIC = [(t, p) for t in TARGETS for p in _numeric_params(t)]


@pytest.mark.parametrize("spelling", ["text", "truth"])
@pytest.mark.parametrize(("target", "param"), _NUMERIC, ids=[f"{t.name}-{p}" for t, p in _NUMERIC])
def test_numbers_written_as_text_or_truth_values_are_refused_by_name(target, param, spelling):
    """NumPy reads ``"0.1667"`` as 0.1667 and ``True`` as 1: an array argument given as text or as truth values
    (Planar3RRR(passive_lengths="0.1667") was accepted) is refused, naming the argument, not converted."""
    arguments = _valid(target)
    valid = arguments[param]
    bad = (valid.astype(str) if spelling == "text" else valid != 0).tolist()
    with pytest.raises(pkmlab.PkmlabError) as info:
        target.call(**{**arguments, param: bad})
    assert any(re.search(p, str(info.value)) for p in _patterns(target, param, bad)), str(info.value)


@pytest.mark.parametrize("field", ["passive_lengths", "active_lengths", "active_masses"])
def test_planar3rrr_refuses_a_length_written_as_text(field):
    arrays = {name: getattr(MODEL, name) for name in ("base_points", "active_lengths", "passive_lengths",
                                                       "platform_side")}
    with pytest.raises(pkmlab.InvalidParameterError, match=r"must be a number or a list of 3 numbers, got '0.1667'"):
        Planar3RRR(**{**arrays, field: "0.1667"})


@pytest.mark.filterwarnings("error::RuntimeWarning")
@pytest.mark.parametrize("make", [lambda v: Trajectory(CIRCLE, v), lambda v: WaypointTrajectory(((0.2, 0.2, 0.0),
                                                                                                 (0.3, 0.2, 0.1)), v)])
def test_a_speed_near_the_float_range_is_named_without_numpys_warning(make):
    """speed = 3e153 m/s: the motion's accelerations (L / T^2) overflowed, with NumPy's warning."""
    trajectory = make(3.0680122625494442e153)
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^speed = 3\.06801e\+153 m/s is too high for a path"):
        trajectory.desired(np.linspace(0.0, trajectory.duration, 5))
