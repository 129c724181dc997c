"""Closed-loop simulation: trajectory → controller → plant, sampled-data or continuous-time.

A :class:`Scenario` is a plain value — the controller's model of the manipulator, the real
machine (the plant, possibly different), the trajectory, the controller and its gains, the
sample time — and :func:`simulate` turns it into a :class:`SimulationResult` holding every
time series of SPEC §8 and its summary. The paper's three cases are
:func:`paper_scenario` ``("nominal" | "disturbed" | "fast")``.

Sampled-data control (SPEC §5, default ``Ts = 1 ms``): the torque computed from the measured
``θ, θ̇`` at ``t_k = k Ts`` is held until ``t_{k+1}``; the plant integrates the reduced model
(eq. 35) over each sample with classical Runge–Kutta in ``substeps`` equal steps (the torque
is constant inside the sample, so the solution is smooth there), branch-following its passive
variables at every stage. The whole loop is compiled. Continuous-time control re-evaluates
the controller at every stage of an adaptive DOP853 integration.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numba import njit
from scipy.integrate import solve_ivp

from .control import CONTROLLER_TYPES, ControllerSpec, control_torque
from .errors import BranchFollowingError, InvalidParameterError, SingularityError, UnreachablePoseError
from .geometry import WORKING_MODES, Planar3RRR
from .kinematics import forward_kinematics, inverse_kinematics, platform_pose, singularity_measure
from .mechanisms import rrr3
from .outputs import atomic_file
from .trajectory import desired_joint_motion, paper_trajectory

#: Columns of the per-sample time series (SPEC §8).
COLUMNS = ("t", "theta1", "theta2", "theta3", "theta1_d", "theta2_d", "theta3_d", "tau1", "tau2", "tau3",
           "x", "y", "alpha", "x_d", "y_d", "alpha_d", "S")


@dataclass(frozen=True)
class Scenario:
    """Everything that defines one closed-loop run.

    Attributes
    ----------
    model : Planar3RRR
        The controller's model of the manipulator (used for inverse kinematics, the
        pre-flight check and computed torque).
    plant : Planar3RRR or None
        The real machine; ``None`` means identical to ``model``.
    trajectory : Trajectory-like
        Gives ``desired(t) -> (pose, pose_dot, pose_ddot)`` and ``duration``.
    controller : ControllerSpec
    sample_time : float
        ``Ts`` in seconds; ``0`` selects continuous-time control.
    working_mode : "auto" or 3 signs
        ``"auto"`` picks the mode maximising ``min |S|`` along the path (SPEC §3).
    singularity_margin : float
        Paths with ``min |S|`` below this in every admissible mode are refused before simulating.
    singularity_guard : float
        A run stops with an error when the plant's ``|S|`` falls below this.
    substeps : int
        Runge–Kutta steps per sample for the plant (sampled-data control).
    name : str
    """

    model: Planar3RRR
    trajectory: object
    plant: Planar3RRR | None = None
    controller: ControllerSpec = field(default_factory=ControllerSpec)
    sample_time: float = 1e-3
    working_mode: object = "auto"
    singularity_margin: float = 0.05
    singularity_guard: float = 0.01
    substeps: int = 2
    name: str = "scenario"

    def __post_init__(self):
        ts = self.sample_time
        if not isinstance(ts, (int, float)) or not math.isfinite(ts) or ts < 0:
            raise InvalidParameterError(f"sample_time must be a non-negative number of seconds, got {ts!r}")
        if not isinstance(self.substeps, int) or self.substeps < 1:
            raise InvalidParameterError(f"substeps must be a positive integer, got {self.substeps!r}")
        for name in ("singularity_margin", "singularity_guard"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise InvalidParameterError(f"{name} must be a non-negative number, got {v!r}")

    @property
    def plant_model(self) -> Planar3RRR:
        return self.model if self.plant is None else self.plant

    def replace(self, **changes) -> Scenario:
        return replace(self, **changes)


def scaled_model(model: Planar3RRR, mass: float = 1.0, length: float = 1.0) -> Planar3RRR:
    """A machine whose link lengths ``l, r, a`` are ×``length`` and masses ×``mass``, with
    inertias ×``mass·length²`` (I ∝ m L²); the base is unchanged (SPEC §7)."""
    return model.replace(
        active_lengths=model.active_lengths * length,
        passive_lengths=model.passive_lengths * length,
        platform_side=model.platform_side * length,
        active_masses=model.active_masses * mass,
        passive_masses=model.passive_masses * mass,
        platform_mass=model.platform_mass * mass,
        active_inertias=model.active_inertias * mass * length**2,
        passive_inertias=model.passive_inertias * mass * length**2,
        platform_inertia=model.platform_inertia * mass * length**2,
    )


PAPER_CASES = ("nominal", "disturbed", "fast")
#: The scenario files of the paper's cases (package data).
SCENARIO_DIR = Path(__file__).parent / "scenarios"


def paper_scenario(name: str = "nominal") -> Scenario:
    """The paper's simulated cases (SPEC §7).

    The three cases of the paper are the scenario files ``scenarios/<name>.toml`` shipped in
    the package (``examples/`` links to them):

    * ``nominal``: the circle at 0.2 m/s, plant = model;
    * ``disturbed``: plant masses and link lengths ×1.15, inertias ×1.15³, base unchanged;
    * ``fast``: 0.4 m/s, plant = model;
    * ``disturbed_dynamics``: masses and inertias ×1.15, lengths unchanged (a variant).
    """
    if name in PAPER_CASES:
        from .scenario_io import load_scenario

        return load_scenario(SCENARIO_DIR / f"{name}.toml")
    model = Planar3RRR.paper()
    if name == "disturbed_dynamics":
        return Scenario(model, paper_trajectory(0.2), plant=scaled_model(model, 1.15, 1.0), name=name)
    raise InvalidParameterError(
        f"unknown paper scenario {name!r}: choose one of nominal, disturbed, fast, disturbed_dynamics"
    )


# ------------------------------------------------------------------ pre-flight
def choose_working_mode(scenario: Scenario, t: np.ndarray) -> tuple[tuple[int, int, int], float]:
    """The working mode of SPEC §3 and its ``min |S|`` along the desired path at times ``t``.

    Raises a one-line error naming the time and pose where the path leaves the workspace or
    comes within ``singularity_margin`` of ``S = 0`` in every admissible mode.
    """
    pose, _pd, _pdd = scenario.trajectory.desired(t)
    modes = WORKING_MODES if scenario.working_mode == "auto" else np.array([scenario.working_mode])
    ik = inverse_kinematics(scenario.model, pose, on_unreachable="nan")
    s_all = ik.S if scenario.working_mode == "auto" else None
    if scenario.working_mode != "auto":
        from .kinematics import _mode_array

        mode = _mode_array(scenario.working_mode)
        idx = int(np.flatnonzero((WORKING_MODES == mode).all(axis=1))[0])
        s_all = ik.S[:, idx:idx + 1]
    unreachable = np.isnan(s_all)
    if np.all(unreachable.any(axis=0)):
        rows = unreachable.all(axis=1) if unreachable.all(axis=1).any() else unreachable.any(axis=1)
        k = int(np.flatnonzero(rows)[0])
        try:
            inverse_kinematics(scenario.model, pose[k])
        except UnreachablePoseError as exc:
            raise UnreachablePoseError(f"the path leaves the workspace at t = {t[k]:.4f} s: {exc}") from None
        raise UnreachablePoseError(
            f"the path leaves the workspace at t = {t[k]:.4f} s, pose ({pose[k, 0]:.4f}, {pose[k, 1]:.4f}, "
            f"{pose[k, 2]:.4f}): no working mode reaches the whole path"
        )
    min_s = np.where(unreachable.any(axis=0), -np.inf, np.nanmin(np.abs(s_all), axis=0))
    best = int(np.argmax(min_s))
    if min_s[best] < scenario.singularity_margin:
        k = int(np.nanargmin(np.abs(s_all[:, best])))
        raise SingularityError(
            f"the path comes within {min_s[best]:.3g} of a gain-type singularity (margin "
            f"{scenario.singularity_margin:g}) in every admissible working mode; closest at t = {t[k]:.4f} s, "
            f"pose ({pose[k, 0]:.4f}, {pose[k, 1]:.4f}, {pose[k, 2]:.4f})"
        )
    chosen = modes[best] if scenario.working_mode == "auto" else modes[0]
    return tuple(int(v) for v in chosen), float(min_s[best])


# ------------------------------------------------------------------ compiled sampled-data loop
@njit(cache=True)
def _plant_derivative(theta, theta_dot, tau, q_plant, P, min_abs_s, q_out):
    status = rrr3.branch_following(q_plant, theta, P, q_out, min_abs_s)
    acc, ok = rrr3.forward_dynamics(q_out, theta_dot, tau, P)
    if status == rrr3.OK and not ok:
        status = rrr3.SINGULAR
    return acc, status


@njit(cache=True)
def _rk4_sample(theta, theta_dot, tau, q_plant, P, dt, n_sub, min_abs_s):
    """Advance the reduced plant over one sample with constant ``τ``: classical RK4 in ``n_sub`` steps."""
    h = dt / n_sub
    q_work = np.empty(7)
    for _ in range(n_sub):
        a1, s1 = _plant_derivative(theta, theta_dot, tau, q_plant, P, min_abs_s, q_work)
        th2 = theta + 0.5 * h * theta_dot
        w2 = theta_dot + 0.5 * h * a1
        a2, s2 = _plant_derivative(th2, w2, tau, q_plant, P, min_abs_s, q_work)
        th3 = theta + 0.5 * h * w2
        w3 = theta_dot + 0.5 * h * a2
        a3, s3 = _plant_derivative(th3, w3, tau, q_plant, P, min_abs_s, q_work)
        th4 = theta + h * w3
        w4 = theta_dot + h * a3
        a4, s4 = _plant_derivative(th4, w4, tau, q_plant, P, min_abs_s, q_work)
        if s1 != rrr3.OK or s2 != rrr3.OK or s3 != rrr3.OK or s4 != rrr3.OK:
            return theta, theta_dot, rrr3.SINGULAR
        theta = theta + h / 6.0 * (theta_dot + 2.0 * w2 + 2.0 * w3 + w4)
        theta_dot = theta_dot + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        status = rrr3.branch_following(q_plant, theta, P, q_work, min_abs_s)
        if status != rrr3.OK:
            return theta, theta_dot, status
        q_plant[:] = q_work
    return theta, theta_dot, rrr3.OK


@njit(cache=True)
def _sampled_data_loop(ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant, P_ctrl,
                       kind, kp, kv, min_abs_s, out_q, out_theta_dot, out_tau):
    """Run the whole sampled-data loop; returns ``(status, k)`` (``k`` = sample of a failure, else -1)."""
    n = theta_d.shape[0]
    q_plant = q_plant0.copy()
    q_ctrl = q_ctrl0.copy()
    q_ctrl_next = np.empty(7)
    theta = q_plant[:3].copy()
    theta_dot = np.zeros(3)
    for k in range(n):
        out_q[k] = q_plant
        out_q[k, :3] = theta
        out_theta_dot[k] = theta_dot
        tau, status = control_torque(kind, kp, kv, q_ctrl, theta, theta_dot, theta_d[k], theta_dot_d[k],
                                     theta_ddot_d[k], P_ctrl, min_abs_s, q_ctrl_next)
        if status != rrr3.OK:
            return 10 + status, k  # the controller's own model lost its branch
        q_ctrl[:] = q_ctrl_next
        out_tau[k] = tau
        if k == n - 1:
            break
        theta, theta_dot, status = _rk4_sample(theta, theta_dot, tau, q_plant, P_plant, ts, n_sub, min_abs_s)
        if status != rrr3.OK:
            return status, k
    return rrr3.OK, -1


# ------------------------------------------------------------------ results
@dataclass(frozen=True)
class SimulationResult:
    """Every time series of SPEC §8, one row per sample ``t = 0 … T`` (inclusive).

    ``q`` (N, 7) is the plant's configuration, ``pose`` (N, 3) its platform pose from its own
    geometry, ``pose_d`` the desired pose, ``theta_d`` the desired actuated angles (controller's
    model), ``tau`` (N, 3) the torques, ``S`` (N,) the plant's singularity measure.
    """

    scenario: Scenario
    working_mode: tuple[int, int, int]
    t: np.ndarray
    q: np.ndarray
    theta_dot: np.ndarray
    theta_d: np.ndarray
    tau: np.ndarray
    pose: np.ndarray
    pose_d: np.ndarray
    S: np.ndarray

    @property
    def theta(self) -> np.ndarray:
        return self.q[:, :3]

    @property
    def path_error(self) -> np.ndarray:
        """Euclidean distance (m) between the actual and the desired centroid."""
        return np.hypot(*(self.pose[:, :2] - self.pose_d[:, :2]).T)

    def summary(self) -> dict:
        """The summary fields of SPEC §8."""
        err = self.path_error
        joint = np.angle(np.exp(1j * (self.theta - self.theta_d)))
        return {
            "max_path_error_m": float(err.max()),
            "rms_path_error_m": float(np.sqrt(np.mean(err**2))),
            "max_alpha_error_rad": float(np.abs(np.angle(np.exp(1j * (self.pose[:, 2] - self.pose_d[:, 2])))).max()),
            "max_joint_error_rad": float(np.abs(joint).max()),
            "peak_torque_Nm": np.abs(self.tau).max(axis=0).tolist(),
            "min_abs_S": float(np.abs(self.S).min()),
            "working_mode": list(self.working_mode),
        }

    def table(self) -> np.ndarray:
        """The (N, 17) array of :data:`COLUMNS`."""
        return np.column_stack([self.t, self.theta, self.theta_d, self.tau, self.pose, self.pose_d, self.S])

    def to_csv(self, path) -> Path:
        """Write the time series (columns :data:`COLUMNS`) atomically."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(COLUMNS)
        for row in self.table():
            writer.writerow([repr(float(v)) for v in row])
        return _write_atomic(path, buf.getvalue())

    def to_json(self, path) -> Path:
        """Write the summary and the time series as JSON, atomically."""
        data = {"summary": self.summary(), "columns": list(COLUMNS), "rows": self.table().tolist()}
        return _write_atomic(path, json.dumps(data))


def _write_atomic(path, text: str) -> Path:
    with atomic_file(path) as tmp:
        tmp.write_text(text)
    return Path(path)


# ------------------------------------------------------------------ simulate
def _initial_plant_configuration(scenario: Scenario, q_ctrl0: np.ndarray) -> np.ndarray:
    """The plant at rest at the controller's IK angles, in its assembly mode nearest the controller's (SPEC §5)."""
    fk = forward_kinematics(scenario.plant_model, q_ctrl0[:3])
    if len(fk) == 0:
        raise InvalidParameterError(
            f"the plant cannot be assembled at the start angles theta = {np.round(q_ctrl0[:3], 6).tolist()}"
        )
    dist = np.max(np.abs(np.angle(np.exp(1j * (fk.q[: len(fk), 3:] - q_ctrl0[3:])))), axis=1)
    q = fk.q[int(np.argmin(dist))].copy()
    q[:3] = q_ctrl0[:3]
    return q


def simulate(scenario: Scenario) -> SimulationResult:
    """Run a closed-loop scenario and return its :class:`SimulationResult`.

    >>> result = simulate(paper_scenario("nominal"))
    >>> result.summary()["working_mode"]
    [-1, 1, -1]
    """
    T = float(scenario.trajectory.duration)
    ts = scenario.sample_time
    # samples t_k = k Ts for k = 0 … ceil(T / Ts): the grid covers the whole motion, up to and past T
    # (the desired motion is at rest after T); continuous-time runs report on a 1 ms grid
    step = ts if ts > 0 else 1e-3
    n = int(math.ceil(T / step - 1e-9)) + 1
    t = np.arange(n) * step
    mode, _min_s = choose_working_mode(scenario, t)
    desired = desired_joint_motion(scenario.model, scenario.trajectory, mode, t)
    q_ctrl0 = desired.q[0].copy()
    q_plant0 = _initial_plant_configuration(scenario, q_ctrl0)
    spec = scenario.controller
    kind = CONTROLLER_TYPES[spec.kind]
    kp, kv = float(spec.kp), spec.velocity_gain
    guard = float(scenario.singularity_guard)
    P_plant, P_ctrl = scenario.plant_model.packed, scenario.model.packed
    if ts > 0:
        q = np.zeros((n, 7))
        theta_dot = np.zeros((n, 3))
        tau = np.zeros((n, 3))
        status, k_fail = _sampled_data_loop(ts, scenario.substeps, desired.theta, desired.theta_dot,
                                            desired.theta_ddot, q_plant0, q_ctrl0, P_plant, P_ctrl,
                                            kind, kp, kv, guard, q, theta_dot, tau)
        if status != rrr3.OK:
            who = "the controller's model" if status >= 10 else "the plant"
            pose = platform_pose(scenario.plant_model, q[k_fail])
            raise BranchFollowingError(
                f"run stopped at t = {t[k_fail]:.4f} s: {who} came within |S| < {guard:g} of a gain-type "
                f"singularity near pose ({pose[0]:.4f}, {pose[1]:.4f}, {pose[2]:.4f})"
            )
    else:
        q, theta_dot, tau = _continuous_time(scenario, mode, t, q_plant0, q_ctrl0, kind, kp, kv, guard)
    pose = platform_pose(scenario.plant_model, q)
    pose[:, 2] = desired.pose[:, 2] + np.angle(np.exp(1j * (pose[:, 2] - desired.pose[:, 2])))
    theta_d = desired.theta + 2 * np.pi * np.round((q[:, :3] - desired.theta) / (2 * np.pi))
    return SimulationResult(scenario, mode, t, q, theta_dot, theta_d, tau, pose, desired.pose,
                            singularity_measure(scenario.plant_model, q))


def _continuous_time(scenario, mode, t, q_plant0, q_ctrl0, kind, kp, kv, guard):
    """Continuous-time control: the controller is evaluated at every stage of DOP853."""
    P_plant, P_ctrl = scenario.plant_model.packed, scenario.model.packed
    q_plant, q_ctrl = q_plant0.copy(), q_ctrl0.copy()
    q_work, q_ctrl_work = np.empty(7), np.empty(7)
    last_tau = np.zeros(3)

    def torque_at(time, theta, theta_dot):
        d = desired_joint_motion(scenario.model, scenario.trajectory, mode, [time])
        tau, status = control_torque(kind, kp, kv, q_ctrl, theta, theta_dot, d.theta[0], d.theta_dot[0],
                                     d.theta_ddot[0], P_ctrl, guard, q_ctrl_work)
        if status != rrr3.OK:
            raise BranchFollowingError(f"run stopped at t = {time:.4f} s: the controller's model lost its branch")
        q_ctrl[:] = q_ctrl_work
        return tau

    def rhs(time, y):
        tau = torque_at(time, y[:3], y[3:])
        last_tau[:] = tau
        acc, status = _plant_derivative(y[:3], y[3:], tau, q_plant, P_plant, guard, q_work)
        if status != rrr3.OK:
            raise BranchFollowingError(f"run stopped at t = {time:.4f} s: the plant approached a gain-type singularity")
        q_plant[:] = q_work
        return np.concatenate([y[3:], acc])

    sol = solve_ivp(rhs, (0.0, float(t[-1])), np.concatenate([q_plant0[:3], np.zeros(3)]), method="DOP853",
                    rtol=1e-12, atol=1e-13, t_eval=t)
    if sol.status != 0:
        raise SingularityError(f"integration failed: {sol.message}")
    n = t.size
    q = np.empty((n, 7))
    tau = np.empty((n, 3))
    q_prev = q_plant0
    q_c = q_ctrl0.copy()
    for k in range(n):
        q_next = np.empty(7)
        rrr3.branch_following(q_prev, sol.y[:3, k].copy(), P_plant, q_next, guard)
        q[k] = q_prev = q_next
        q[k, :3] = sol.y[:3, k]
        d = desired_joint_motion(scenario.model, scenario.trajectory, mode, [t[k]])
        tau[k], _st = control_torque(kind, kp, kv, q_c, sol.y[:3, k], sol.y[3:, k], d.theta[0], d.theta_dot[0],
                                     d.theta_ddot[0], P_ctrl, guard, q_ctrl_work)
        q_c = q_ctrl_work.copy()
    return q, sol.y[3:].T.copy(), tau
