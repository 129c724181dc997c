"""Closed-loop simulation: trajectory → controller → plant, sampled-data or continuous-time.

A :class:`Scenario` is a plain value — the controller's model of the machine, the real
machine (the plant, possibly different), the trajectory, the controller and its gains, the
sample time — and :func:`simulate` turns it into a :class:`SimulationResult` holding every
time series of conventions §8 and its summary. The paper's three cases are
:func:`pkmlab.formats.scenario.paper_scenario` ``("nominal" | "disturbed" | "fast")``.

Sampled-data control (conventions §5, default ``Ts = 1 ms``): the torque computed from the measured
``θ, θ̇`` at ``t_k = k Ts`` is held until ``t_{k+1}``; the plant integrates the actuator-space model
(eq. 35) over each sample with classical Runge–Kutta in ``substeps`` equal steps (the torque
is constant inside the sample, so the solution is smooth there and a fixed-step high-order
method needs no error control: one RK4 step per 1 ms sample is off a DOP853 reference at rtol
1e-13 by about 1e-12 rad at the fast case's highest speed, and the error falls 16-fold per
halving), branch-following its passive variables at every stage from the start of the step.
The whole loop is compiled and allocation-free: the one written in :mod:`pkmlab.codegen.core` and bound
to each structure's generated kernels, the same for every machine, the paper's included;
:func:`simulate_batch` runs many scenarios over all cores. Continuous-time control
re-evaluates the controller at every stage of an adaptive DOP853 integration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .._format import apart
from .._validate import as_choice
from ..control.controller import (
    CONTROLLER_TYPES,
    PD,
    STABILITY_TOLERANCE,
    largest_stable_kp,
    largest_stable_sample_time,
    sampled_data_spectral_radius,
)
from ..errors import (
    AssemblyError,
    BranchFollowingError,
    InvalidParameterError,
    PkmlabError,
    SingularityError,
    UnreachablePoseError,
    UnstableControlError,
    shown,
)
from ..model.mechanism_model import MechanismModel, pose_of
from ..numerics.angles import wrapped_angle, wrapped_where
from .ahead import compile_loop_ahead, compile_plant_stage_meanwhile
from .result import SimulationResult, actuator_errors
from .scenario import Scenario, best_working_mode, pose_text

# ------------------------------------------------------------------ simulate
#: Samples of a sampled-data run that the compiled loop runs at a time (:func:`simulate`), its state handed from one
#: piece to the next: the pieces compute exactly what the whole run would, and each reads only its own piece of the
#: desired motion.
SIMULATION_PIECE = 65536


def _initial_plant_configuration(scenario: Scenario, q_ctrl0: np.ndarray, mode) -> np.ndarray:
    """The plant at rest at the controller's inverse-kinematic actuator values, in its assembly mode nearest
    the controller's configuration (docs/conventions.md §5); a redundantly actuated plant, whose actuators
    over-determine it, at the controller's start pose, in the run's working mode ``mode``."""
    from ..algorithms.assembly import assembly_modes as machine_fk
    from ..model.mechanism_model import inverse_kinematics

    model = scenario.model
    n = model.n_actuators
    if scenario.plant is None or scenario.plant_model == model:
        return q_ctrl0.copy()
    if model.description.actuation_redundancy:
        try:
            return inverse_kinematics(scenario.plant_model, pose_of(model, q_ctrl0), mode)
        except PkmlabError as exc:
            raise AssemblyError(f"the plant cannot be assembled at the start pose: {exc}") from None
    solutions = machine_fk(scenario.plant_model, q_ctrl0[:n])
    if not solutions:
        raise AssemblyError(f"the plant cannot be assembled at the start actuators "
                            f"{np.round(q_ctrl0[:n], 6).tolist()}")
    angles = np.array(model.kernels.ANGLES)
    gaps = [np.max(np.abs(wrapped_where(q - q_ctrl0, angles))[n:]) for q, _s in solutions]
    q = solutions[int(np.argmin(gaps))][0].copy()
    # the passive angles on the controller's side of 2π (the FK wraps them)
    q[angles] = q_ctrl0[angles] + wrapped_angle(q[angles] - q_ctrl0[angles])
    q[:n] = q_ctrl0[:n]
    return q


@dataclass(frozen=True)
class PreparedRun:
    """Everything a run needs before its loop: sample grid, working mode, desired motion, start."""

    t: np.ndarray
    motion: DesiredMotion
    q_ctrl0: np.ndarray
    q_plant0: np.ndarray
    kind: int
    kp: float
    kv: float
    # how a redundantly actuated machine's controller distributes its efforts, as the loop reads it (the compiled
    # core's ``distribute``): rows of the weights, the preload, the effort limits and the least-peak flag, one
    # column per actuator
    distribution: np.ndarray
    singularity_guard: float
    P_ctrl: np.ndarray  # the packed parameters of the controller's model and of the plant, as the loop reads them
    P_plant: np.ndarray
    realism: Realism  # the plant's drives and the controller's sensors, as the loop reads them

    @property
    def mode(self) -> tuple[int, ...]:
        """The run's working mode."""
        return self.motion.mode

    @property
    def desired(self):
        """The whole run's desired motion (a :class:`~pkmlab.control.trajectory.JointMotion`)."""
        return self.motion.whole()


class Realism(NamedTuple):
    """The compiled loop's arguments for the plant's drives and the controller's sensors
    (:mod:`~pkmlab.simulation.realism`): no rows, ``sensing = -1`` for the ideal plant and exact state."""

    drive: np.ndarray  # (n, DRIVE_COLUMNS) or (0, DRIVE_COLUMNS): Drives.table
    ctrl_drive: np.ndarray  # the controller's model of the drives, as drive
    effort_noise: np.ndarray  # (N, n) or (0, n)
    resolution: np.ndarray  # (n,)
    theta_noise: np.ndarray  # (N, n) or (0, n)
    sensing: int
    delay: int

    @property
    def signature(self) -> tuple:
        """What runs of one compiled batch call must share: which arrays have rows."""
        return (self.drive.shape[0], self.ctrl_drive.shape[0], self.effort_noise.shape[0], self.theta_noise.shape[0],
                self.sensing >= 0)


def realism(scenario: Scenario, count: int) -> Realism:
    """The loop's drive and sensor arrays of ``scenario`` over ``count`` samples, its noise drawn from its seed."""
    from .realism import noise_rows

    n = scenario.model.n_actuators
    drives, sensors = scenario.drives, scenario.sensors
    ideal = scenario.model.kernels.NO_DRIVES
    drive = drives.table(n) if drives is not None else ideal
    ctrl_drive = scenario.controller_drives.table(n) if scenario.controller_drives is not None else ideal
    effort_noise = (noise_rows(drives.noise_levels(n), count, scenario.seed, 0) if drives is not None
                    else np.zeros((0, n)))
    if sensors is None:
        return Realism(drive, ctrl_drive, effort_noise, np.zeros(n), np.zeros((0, n)), -1, 0)
    return Realism(drive, ctrl_drive, effort_noise, sensors.resolutions(n),
                   noise_rows(sensors.noise_levels(n), count, scenario.seed, 1),
                   _sensing(scenario.model.kernels, sensors.rates), sensors.delay)


def _sensing(kernels, rates: str) -> int:
    """The loop's ``sensing`` for :class:`~pkmlab.simulation.realism.Sensors`' ``rates``."""
    return {"exact": kernels.EXACT_RATES, "difference": kernels.DIFFERENCED_RATES,
            "backward2": kernels.BACKWARD_RATES}[rates]


def sample_times(scenario: Scenario) -> np.ndarray:
    # samples t_k = k Ts for k = 0 … ceil(T / Ts): the grid covers the whole motion, up to and past T
    # (the desired motion is at rest after T); continuous-time runs report on a 1 ms grid
    step = scenario.sample_time if scenario.sample_time > 0 else 1e-3
    n = int(math.ceil(float(scenario.trajectory.duration) / step - 1e-9)) + 1
    return np.arange(n) * step


class DesiredMotion:
    """The desired motion of a run in its working mode, from the trajectory's poses by the exact inverse kinematics
    and its derivatives, made :data:`SIMULATION_PIECE` samples at a time: a long run holds one piece of it at a
    time. A run of one piece keeps it whole (:meth:`whole`), as the batches and the plants other than the
    compiled loop read it."""

    def __init__(self, scenario: Scenario, t: np.ndarray):
        """Choose the working mode along the path (:func:`~pkmlab.simulation.scenario.best_working_mode`, a piece
        at a time) and prepare the desired motion in it."""
        self.scenario, self.t = scenario, t
        self._evaluated: tuple[tuple[int, int], list[np.ndarray]] | None = None
        self.mode, _min_s, q = best_working_mode(scenario, t, lambda rows: self._poses(rows)[0], SIMULATION_PIECE)
        self._whole = None
        if q is not None:  # the path's inverse kinematics, known from the choice of the working mode
            self._whole = _joint_motion(scenario.model, self._poses(slice(0, t.size)), q, t)
            self._evaluated = None
        self._first = None

    def _poses(self, rows: slice) -> list[np.ndarray]:
        """The trajectory's ``(pose, pose_dot, pose_ddot)`` at the samples ``rows`` (the last rows asked for kept:
        each working mode's inverse kinematics reads the same poses)."""
        if self._evaluated is None or self._evaluated[0] != (rows.start, rows.stop):
            self._evaluated = ((rows.start, rows.stop),
                               [np.asarray(a, dtype=float) for a in self.scenario.trajectory.desired(self.t[rows])])
        return self._evaluated[1]

    def pieces(self):
        """Each piece of the run in order, as ``(rows, JointMotion of those rows)``: the actuators' angles unwrapped
        along the whole path, as in :meth:`whole`."""
        count = self.t.size
        if self._whole is not None:
            yield slice(0, count), self._whole
            return
        previous = None
        for k0 in range(0, count, SIMULATION_PIECE):
            rows = slice(k0, min(count, k0 + SIMULATION_PIECE))
            motion = self._piece(rows, previous)
            previous = motion.theta[-1]
            yield rows, motion

    def _piece(self, rows: slice, previous: np.ndarray | None):
        from ..model.mechanism_model import path_inverse_kinematics

        if rows.start == 0 and self._first is not None:
            return self._first
        model, full = self.scenario.model, self._poses(rows)
        q, _s, failure = path_inverse_kinematics(model, np.ascontiguousarray(full[0][:, :model.dof]), self.mode,
                                                 follow=True)
        if failure is not None:  # the working mode reached every pose when chosen: a leg's branch lost on the way
            k, exc = failure
            raise UnreachablePoseError(f"the path leaves the workspace at t = {self.t[rows][k]:.4f} s, pose "
                                       f"{pose_text(full[0][k, :model.dof])}: {exc}") from None
        motion = _joint_motion(model, full, q, self.t[rows], previous)
        if rows.start == 0:
            self._first = motion
        return motion

    def first(self):
        """The first piece's desired motion (the whole run's if it is one piece)."""
        return next(self.pieces())[1]

    def at(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The desired configurations and poses at the samples ``rows``, each by the inverse kinematics of its pose
        in the run's working mode."""
        from ..model.mechanism_model import path_inverse_kinematics

        if self._whole is not None:
            return self._whole.q[rows], self._whole.pose[rows]
        model = self.scenario.model
        pose = np.asarray(self.scenario.trajectory.desired(self.t[rows])[0], dtype=float)
        pose = np.ascontiguousarray(pose[:, :model.dof])
        return path_inverse_kinematics(model, pose, self.mode)[0], pose

    def whole(self):
        """The whole run's desired motion, one :class:`~pkmlab.control.trajectory.JointMotion` (kept for a run
        of one piece)."""
        if self._whole is not None:
            return self._whole
        from ..control.trajectory import JointMotion

        parts = [motion for _rows, motion in self.pieces()]
        return JointMotion(self.t, *(np.concatenate([getattr(m, name) for m in parts])
                                     for name in ("q", "pose", "theta", "theta_dot", "theta_ddot")), None,
                           *(np.concatenate([getattr(m, name) for m in parts]) for name in ("pose_dot", "pose_ddot")))


def _joint_motion(model: MechanismModel, full, q: np.ndarray, t: np.ndarray, previous: np.ndarray | None = None):
    """The desired actuator motion of the desired ``full = (pose, pose_dot, pose_ddot)`` at ``t``, whose inverse
    kinematics in the run's working mode is ``q``: the first and second derivatives of that inverse kinematics
    (:func:`~pkmlab.model.mechanism_model.path_rates`), angles unwrapped along it — from ``previous``, the
    actuators' values at the sample before (a piece of a longer path), if given."""
    from ..control.trajectory import JointMotion
    from ..model.mechanism_model import path_rates

    dof = model.description.dof
    # a point has no orientation to track: never ignore one
    if dof == 2 and full[0].shape[1] > 2 and np.any(full[0][:, 2] != 0.0):
        k = int(np.argmax(full[0][:, 2] != 0.0))
        raise InvalidParameterError(f"{model.description.name} tracks a point (x, y), but the trajectory asks for the "
                                    f"orientation alpha = {full[0][k, 2]:.4g} rad at t = {t[k]:.4f} s: remove alpha "
                                    "from the trajectory")
    pose, pose_dot, pose_ddot = (np.ascontiguousarray(a[:, :dof]) for a in full)
    theta_dot, theta_ddot, k = path_rates(model, q, pose_dot, pose_ddot)
    if k >= 0:
        raise SingularityError(f"the path meets an inverse-kinematic singularity (a leg at the edge of its reach) "
                               f"at t = {t[k]:.4f} s, pose {pose_text(pose[k])}")
    n = model.n_actuators
    angles = np.array(model.kernels.ANGLES[:n])
    if previous is None:
        q[:, :n][:, angles] = np.unwrap(q[:, :n][:, angles], axis=0)
    else:
        q[:, :n][:, angles] = np.unwrap(np.vstack([previous[angles], q[:, :n][:, angles]]), axis=0)[1:]
    return JointMotion(t, q, pose, q[:, :n].copy(), theta_dot, theta_ddot, None, pose_dot, pose_ddot)


def loop_motion(model: MechanismModel, d) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The desired motion the compiled loop tracks, of a :class:`~pkmlab.control.trajectory.JointMotion` ``d``: the
    actuators' ``(θ_d, θ̇_d, θ̈_d)``, or for a redundantly actuated machine its controlled pose and the pose's rates
    (the loop's independent coordinates, which its actuators over-determine)."""
    if model.description.actuation_redundancy:
        return d.pose, d.pose_dot, d.pose_ddot
    return d.theta, d.theta_dot, d.theta_ddot


def run_measures(model: MechanismModel, q: np.ndarray, s: np.ndarray | None = None) -> np.ndarray:
    """The singularity measure a run reports at its configurations ``q``
    (:func:`~pkmlab.model.mechanism_model.configuration_measures`, a piece of rows at a time): ``S``, which is the
    loop's own ``s`` where given, or for a redundantly actuated machine its actuation measure (whose loop's ``S``
    guards its legs' serial singularities)."""
    if s is not None and not model.description.actuation_redundancy:
        return s
    from ..model.mechanism_model import configuration_measures

    out = np.empty(len(q))
    for k0 in range(0, len(q), SIMULATION_PIECE):
        rows = slice(k0, k0 + SIMULATION_PIECE)
        out[rows] = configuration_measures(model, q[rows])
    return out


def actuator_rates(model: MechanismModel, q: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """The actuators' rates of a run whose loop recorded the rates ``rates`` (K, N_INDEPENDENT) of its independent
    coordinates at configurations ``q``: those rates themselves, or for a redundantly actuated machine
    ``θ̇ = W ẋ`` (a piece of rows at a time)."""
    if not model.description.actuation_redundancy:
        return rates
    from ..model.mechanism_model import pose_jacobians

    n = model.n_actuators
    out = np.empty((len(q), n))
    for k0 in range(0, len(q), SIMULATION_PIECE):
        rows = slice(k0, k0 + SIMULATION_PIECE)
        out[rows] = np.einsum("kij,kj->ki", pose_jacobians(model, q[rows])[0][:, :n, :], rates[rows])
    return out


def prepare_run(scenario: Scenario, desired_cache: dict | None = None) -> PreparedRun:
    t = sample_times(scenario)
    # a batch often shares the controller's model and path between runs: its desired motion once
    key = None
    if desired_cache is not None:
        key = (scenario.model, scenario.trajectory, scenario.working_mode, scenario.singularity_margin, t.size,
               t[-1])
        try:
            hash(key)
        except TypeError:
            key = None
    if key is not None and key in desired_cache:
        motion = desired_cache[key]
    else:
        motion = DesiredMotion(scenario, t)
        if key is not None:
            desired_cache[key] = motion
    q_ctrl0 = motion.first().q[0].copy()
    q_plant0 = _initial_plant_configuration(scenario, q_ctrl0, motion.mode)
    spec = scenario.controller
    prep = PreparedRun(t, motion, q_ctrl0, q_plant0, CONTROLLER_TYPES[spec.kind], float(spec.kp),
                     float(spec.velocity_gain), _distribution(scenario), float(scenario.singularity_guard),
                     scenario.model.P, scenario.plant_model.P, realism(scenario, t.size))
    if scenario.sample_time > 0:
        _check_sampled_data_stability(scenario, prep)
    else:
        _check_continuous_stiffness(scenario, prep)
    if scenario.model.description.actuation_redundancy:
        _check_effort_limits(scenario, prep)
    return prep


# ------------------------------------------------------------------ sampled-data stability
#: The pre-flight stability check evaluates the mass matrices at every this-many samples of the path
#: (6 mm apart at 0.4 m/s and 1 ms; they vary on the scale of the links, away from singularities).
STABILITY_STRIDE = 16
#: ... and at no more than this many points in all: a batch of perturbed plants repeats the check per run
#: (measured: 1.1 ms per run at every 16th of 1,571 samples), and the mass matrices vary slowly.
STABILITY_POINTS = 25


def _modal_gains(scenario: Scenario, kind: int, q_ctrl: np.ndarray, q_plant: np.ndarray) -> np.ndarray:
    """The gains ``μ`` (n, 3) of the loop's modal directions
    (:func:`~pkmlab.control.controller.sampled_data_spectral_radius`)
    with the controller's model at ``q_ctrl`` (n, 7) and the plant at ``q_plant`` (n, 7): the eigenvalues of
    ``Mθ_plant⁻¹ M̂θ`` for computed torque, of ``Mθ_plant⁻¹`` for the PD law."""
    plant = scenario.plant_model
    n = plant.kernels.N_INDEPENDENT
    if kind != PD and (plant is scenario.model or plant == scenario.model):
        return np.ones((q_ctrl.shape[0], n))  # the model is exact: M̂θ = Mθ
    m_plant = _mass_matrices(plant, q_plant)
    if kind == PD:
        return 1.0 / np.linalg.eigvalsh(m_plant)
    m_ctrl = _mass_matrices(scenario.model, q_ctrl)
    # Mθ_plant⁻¹ M̂θ is similar to L⁻¹ M̂θ L⁻ᵀ (Mθ_plant = L Lᵀ): symmetric, real positive eigenvalues
    inv_l = np.linalg.inv(np.linalg.cholesky(m_plant))
    return np.linalg.eigvalsh(inv_l @ m_ctrl @ np.swapaxes(inv_l, -1, -2))


def _mass_matrices(model: MechanismModel, qs: np.ndarray) -> np.ndarray:
    """``Mθ`` (K, n, n) at configurations ``qs`` (K, n_coordinates) on the manifold: the compiled core's, as the
    loop evaluates it (a redundantly actuated machine's in its pose, ``Mx``)."""
    n, count = model.kernels.N_INDEPENDENT, qs.shape[0]
    out, c, g = np.empty((count, n, n)), np.empty((count, n)), np.empty((count, n))
    qs = np.ascontiguousarray(qs)
    if model.kernels.actuator_space_models(qs, np.zeros((count, n)), model.P, out, c, g) >= 0:
        raise SingularityError("the configuration is at a gain-type singularity: det(J_eta_phi) = 0")
    return out


def _round_down(x: float, digits: int = 3) -> str:
    """``x`` shown with ``digits`` significant digits, rounded down (a limit the user can safely use)."""
    unit = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return f"{math.floor(x * (1.0 + 1e-9) / unit) * unit:.{digits}g}"


def _stability_advice(scenario: Scenario, prep: PreparedRun, mu: np.ndarray) -> str:
    """What would be stable instead: the largest sample time for these gains, the largest ``kp`` at this ``Ts``."""
    ts = scenario.sample_time
    options = []
    ts_max = largest_stable_sample_time(prep.kp, prep.kv, mu)
    if ts_max is not None and math.isfinite(ts_max):
        options.append(f"Ts <= {_round_down(ts_max * 1e3)} ms with these gains")
    kp_max = largest_stable_kp(ts, mu)
    if kp_max is not None and math.isfinite(kp_max):
        options.append(f"kp <= {_round_down(kp_max)} with kv = 2*sqrt(kp) at this Ts")
    stable = f" (stable: {', or '.join(options)})" if options else ""
    if prep.kv <= 0 < prep.kp:  # no sample time makes a loop without damping stable
        return f"; add damping, kv > kp*Ts/2{stable}"
    return f"; lower the gains or the sample time{stable}"


def _law(prep: PreparedRun) -> str:
    """The control law's name in messages."""
    return "PD" if prep.kind == PD else "computed torque"


def _path_modal_gains(scenario: Scenario, prep: PreparedRun) -> tuple[np.ndarray, np.ndarray]:
    """The loop's modal gains ``μ`` (:func:`_modal_gains`) at every :data:`STABILITY_STRIDE`-th sample of the path
    (at most :data:`STABILITY_POINTS`), and those samples' indices."""
    n = prep.t.size
    step = max(STABILITY_STRIDE, math.ceil(n / STABILITY_POINTS))
    idx = np.unique(np.append(np.arange(0, n, step), n - 1))
    q_desired, pose_desired = prep.motion.at(idx)
    q_ctrl, q_plant, k = q_desired, q_desired, idx
    if scenario.plant_model is not scenario.model and scenario.plant_model != scenario.model:
        # The plant's configurations are known only once it has run. A tracking plant's platform
        # follows the desired poses, so the plant's own inverse kinematics of those poses, in the run's
        # working mode, puts it on its own constraint manifold next to where it will be (the mass matrix
        # is smooth: μ is off by the order of the tracking error); its start, q_plant0, is exact. Poses it
        # cannot reach, or only within the singularity guard, are skipped: the run-time guard stops a run
        # there, and near S = 0 the plant's Mθ grows without bound (μ → 0: sluggish, not unstable).
        from ..model.mechanism_model import path_inverse_kinematics

        ik_q, ik_s, _failure = path_inverse_kinematics(scenario.plant_model, pose_desired, prep.mode, follow=True)
        ok = np.abs(np.nan_to_num(ik_s)) >= max(prep.singularity_guard, 1e-6)
        q_plant = np.vstack([prep.q_plant0, ik_q[ok]])
        q_ctrl, k = np.vstack([prep.q_ctrl0, q_desired[ok]]), np.append(0, idx[ok])
    return _modal_gains(scenario, prep.kind, q_ctrl, q_plant), k


def _check_sampled_data_stability(scenario: Scenario, prep: PreparedRun) -> None:
    """Refuse, before running, gains and a sample time whose sampled-data loop is unstable along the path.

    The spectral radius of :func:`~pkmlab.control.controller.sampled_data_spectral_radius` is evaluated at every
    :data:`STABILITY_STRIDE`-th sample with the modal gains of :func:`_modal_gains`; above 1 (beyond
    round-off) the joint error would grow by that factor every sample, and an
    :class:`~pkmlab.errors.UnstableControlError` says so.
    """
    mu, k = _path_modal_gains(scenario, prep)
    rho = sampled_data_spectral_radius(prep.kp, prep.kv, scenario.sample_time, mu).max(axis=-1)
    worst = int(np.argmax(rho))
    if rho[worst] <= 1.0 + STABILITY_TOLERANCE:
        return
    law = _law(prep)
    radius, _one = apart(rho[worst], 1.0)
    raise UnstableControlError(
        f"the sampled-data loop is unstable: {law} with kp = {prep.kp:g}, kv = {prep.kv:g} at "
        f"Ts = {scenario.sample_time * 1e3:g} ms has spectral radius {radius} > 1 (the joint error would grow "
        f"that much per sample; worst at t = {prep.t[k[worst]]:.4f} s)" + _stability_advice(scenario, prep, mu)
    )


#: A continuous-time run may last at most this many time constants of its loop's fastest mode: an explicit
#: integrator's steps are bounded by that mode's stability (DOP853: about 1/6 of a time constant at most; each
#: step 12 evaluations of pkmlab's controller and plant), so 10,000 is some 20,000 evaluations, a few minutes.
MAX_TIME_CONSTANTS = 10_000


def _fastest_rate(kp: float, kv: float, mu: np.ndarray) -> np.ndarray:
    """The largest ``|s|`` of the error dynamics ``s² + μ kv s + μ kp = 0`` over the modal gains ``μ`` (...)."""
    b, c = mu * kv, mu * kp
    disc = b * b - 4.0 * c
    return np.where(disc >= 0.0, (b + np.sqrt(np.maximum(disc, 0.0))) / 2.0, np.sqrt(c))


def _check_continuous_stiffness(scenario: Scenario, prep: PreparedRun) -> None:
    """Refuse, before running, continuous-time gains that make the loop too stiff for its explicit integrator
    (:data:`MAX_TIME_CONSTANTS`): such a run would not end in reasonable time, and would fail late for the wrong
    reason. Says the largest ``kp`` (with ``kv = 2√kp``) within the limit, and the sampled-data alternative."""
    mu, _k = _path_modal_gains(scenario, prep)
    duration = float(prep.t[-1])
    rate = float(_fastest_rate(prep.kp, prep.kv, mu).max())
    if not rate * duration > MAX_TIME_CONSTANTS:
        return
    # with kv = 2√kp the fastest rate is √kp f(μ): f = √μ for μ ≤ 1 (complex roots), μ + √(μ² − μ) above
    m = float(np.max(mu))
    f = math.sqrt(m) if m <= 1.0 else m + math.sqrt(m * m - m)
    kp_max = (MAX_TIME_CONSTANTS / (duration * f)) ** 2
    law = _law(prep)
    raise UnstableControlError(
        f"continuous-time {law} with kp = {prep.kp:g}, kv = {prep.kv:g} is too stiff to integrate: its fastest "
        f"error mode decays at {rate:.3g} 1/s, and the {duration:.4g} s run spans {rate * duration:.3g} of its time "
        f"constants (at most {MAX_TIME_CONSTANTS:,} in reasonable time); lower the gains (kp <= "
        f"{_round_down(kp_max)} with kv = 2*sqrt(kp)) or use sampled-data control (sample_time > 0)")


def _divergence(scenario: Scenario, prep: PreparedRun, q: np.ndarray, k_fail: int, theta_d: np.ndarray,
                q_d: np.ndarray) -> str | None:
    """Why a run that stopped at sample ``k_fail`` diverged, or ``None`` if it did not; ``theta_d`` the desired
    actuator values up to that sample at least, ``q_d`` the desired configuration there.

    It diverged when the loop is unstable at its last configuration (the plant where it was recorded,
    the controller's model on the desired path), or when its joint error grew a hundredfold or more
    over its last samples to beyond 0.01 rad — a plant meeting a singularity while tracking does not.
    """
    if k_fail < 1:
        return None
    n = scenario.model.n_actuators
    e = np.abs(actuator_errors(scenario.model, q[:k_fail + 1, :n], theta_d[:k_fail + 1])).max(axis=1)
    window = max(1, min(50, k_fail // 2))
    before = float(e[max(0, k_fail - 2 * window):k_fail - window + 1].max())
    growth = (f"the joint error grew from {before:.2g} to {e[k_fail]:.2g} rad in {window} "
              f"sample{'s' if window > 1 else ''}")
    try:
        mu = _modal_gains(scenario, prep.kind, q_d[None, :], q[k_fail:k_fail + 1])
        rho = float(sampled_data_spectral_radius(prep.kp, prep.kv, scenario.sample_time, mu).max())
    except (PkmlabError, np.linalg.LinAlgError):  # the plant at a singularity: no model there
        rho = 0.0
    if rho > 1.0 + STABILITY_TOLERANCE:
        radius, _one = apart(rho, 1.0)
        return (f"the run diverged ({growth}): the sampled-data loop is unstable there (spectral radius {radius} "
                f"> 1 with kp = {prep.kp:g}, kv = {prep.kv:g}, Ts = {scenario.sample_time * 1e3:g} ms)"
                + _stability_advice(scenario, prep, mu))
    if e[k_fail] >= 0.01 and e[k_fail] >= 100.0 * before:
        return (f"the run diverged ({growth}): the controller with kp = {prep.kp:g}, kv = {prep.kv:g} at "
                f"Ts = {scenario.sample_time * 1e3:g} ms does not hold this plant; lower the gains or the sample time")
    return None


def _distribution(scenario: Scenario) -> np.ndarray:
    """The loop's distribution of the efforts (:class:`PreparedRun`): the weights, the preload, the effort limits
    and the least-peak flag of the compiled core's ``distribute`` — unit weights and no preload for the minimum
    2-norm (which for as many actuators as degrees of freedom is the one solution) and the minimum peak, which
    starts from it; the limits the plant's drives declare, at the joint."""
    spec, n = scenario.controller, scenario.model.n_actuators
    drives = scenario.drives
    limits = np.full(n, np.inf) if drives is None else drives.table(n)[:, scenario.model.kernels.EFFORT_LIMIT]
    return np.vstack([np.ones(n) if spec.weights is None else spec.weights,
                      np.zeros(n) if spec.preload is None else spec.preload, limits,
                      np.full(n, float(spec.distribution == "minimum_peak"))])


def _check_effort_limits(scenario: Scenario, prep: PreparedRun) -> None:
    """Refuse, before running, a redundantly actuated machine's desired motion whose efforts the declared effort
    limits cannot hold however the controller shares them (:func:`pkmlab.distribute_efforts` within the limits, at
    every :data:`STABILITY_STRIDE`-th sample and the last, on the controller's model): one line naming the time and
    the actuator."""
    from ..algorithms.redundancy import distribute_efforts, pose_space_model

    limits = prep.distribution[2]
    if not np.isfinite(limits).any():
        return
    spec, model = scenario.controller, scenario.model
    count = prep.t.size
    rows = np.unique(np.append(np.arange(0, count, STABILITY_STRIDE), count - 1))
    d = prep.desired
    dynamics = pose_space_model(model, d.q[rows], d.pose_dot[rows])
    force = np.einsum("kij,kj->ki", dynamics.M, d.pose_ddot[rows]) + dynamics.c + dynamics.g
    for k, W, f in zip(rows, dynamics.W, force, strict=True):  # (the spec holds only its distribution's own)
        distribute_efforts(W, f, spec.distribution, weights=spec.weights, preload=spec.preload, limits=limits,
                           where=f"t = {prep.t[k]:.4f} s: ")


def _pose_of(model: MechanismModel, q: np.ndarray) -> np.ndarray:
    """The plant's pose at configurations ``q`` (:func:`~pkmlab.model.mechanism_model.pose_of`), a copy."""
    return pose_of(model, q).copy()


def _loop_error(scenario: Scenario, prep: PreparedRun, status: int, q: np.ndarray, k_fail: int,
                prefix: str = "", theta_d: np.ndarray | None = None, q_d: np.ndarray | None = None) -> PkmlabError:
    """The error of a run stopped in the compiled loop: diverged (unstable) or near a singularity; ``theta_d`` and
    ``q_d`` as for :func:`_divergence` (default: from the whole desired motion)."""
    if theta_d is None:
        desired = prep.desired
        theta_d, q_d = desired.theta, desired.q[k_fail]
    diverged = _divergence(scenario, prep, q, k_fail, theta_d, q_d)
    if diverged is not None:
        return UnstableControlError(f"{prefix}run stopped at t = {prep.t[k_fail]:.4f} s: {diverged}")
    return BranchFollowingError(prefix + _loop_failure(scenario, prep, status, q, k_fail))


def branch_failure_text(status: int, singularity_guard: float) -> str:
    """What a branch-following status of the compiled core means, as the end of a sentence."""
    if status % 10 == 2:  # SINGULAR
        return f"came within |S| < {singularity_guard:g} of a gain-type singularity"
    return "could not follow its assembly mode (no configuration found near the last one)"


def _loop_failure(scenario: Scenario, prep: PreparedRun, status: int, q: np.ndarray, k_fail: int) -> str:
    who = "the controller's model" if status >= 10 else "the plant"
    pose = _pose_of(scenario.plant_model, q[k_fail])
    return (f"run stopped at t = {prep.t[k_fail]:.4f} s: {who} {branch_failure_text(status, prep.singularity_guard)} "
            f"near pose {pose_text(pose)}")


def run_result(scenario: Scenario, prep: PreparedRun, q, theta_dot, tau, pose=None, s=None,
               theta_measured=None, theta_d=None, pose_d=None) -> SimulationResult:
    """The result of a run; ``pose`` and ``S`` of the plant are computed unless the loop recorded them.

    ``theta_d`` (N, n), the desired actuator values, becomes the result's in place, and ``pose_d`` (N, dof) are
    the desired poses; by default a copy of the desired motion's, and its poses. The plant's orientation angles
    (in ``pose``) and ``theta_d`` are put on the desired ones', and on the plant's, side of 2π, a piece of rows at
    a time (a long run's memory)."""
    model = scenario.plant_model
    if theta_d is None:
        desired = prep.desired
        theta_d, pose_d = desired.theta.copy(), desired.pose
    pose = _pose_of(model, q) if pose is None else pose
    if s is None:
        from ..model.mechanism_model import singularity_measure

        s = np.array([singularity_measure(model, qk) for qk in q])
    n = model.n_actuators
    orientation = [k for k, name in enumerate(model.pose_names) if name in ("alpha", "roll", "pitch", "yaw")]
    angles = np.array(model.kernels.ANGLES[:n])
    for k0 in range(0, q.shape[0], SIMULATION_PIECE):
        rows = slice(k0, k0 + SIMULATION_PIECE)
        for k in orientation:  # the plant's orientation angles on the desired one's side of 2π
            pose[rows, k] -= 2 * np.pi * np.round((pose[rows, k] - pose_d[rows, k]) / (2 * np.pi))
        turns = np.round((q[rows, :n] - theta_d[rows]) / (2 * np.pi))  # θ_d on θ's side of 2π
        turns[:, ~angles] = 0.0
        theta_d[rows] += 2 * np.pi * turns
    return SimulationResult(scenario, prep.mode, prep.t, q, theta_dot, theta_d, tau, pose, pose_d, s,
                            theta_measured=theta_measured)


def simulate(scenario: Scenario) -> SimulationResult:
    """Run a closed-loop scenario and return its :class:`SimulationResult`.

    Before running, the working mode is chosen along the path (conventions §3) and the path refused if it leaves
    the workspace or comes within ``singularity_margin`` of ``S = 0``; sampled-data control (``sample_time > 0``,
    conventions §5) is checked for stability along the path, continuous-time control (``sample_time = 0``) for
    stiffness. The plant starts at rest at the controller's inverse-kinematic actuator values, in its assembly
    mode nearest the controller's configuration. Sampled-data control runs the compiled loop (one RK4 integration
    of eq. (35) per sample in ``substeps`` steps); continuous-time control an adaptive DOP853 integration.

    Parameters
    ----------
    scenario : Scenario
        The run: the controller's model, the plant, the trajectory, the controller, the sample time (s).

    Returns
    -------
    SimulationResult
        Every time series of the run, one row per sample ``t = 0 … T`` (N rows), and its summary.

    Raises
    ------
    InvalidParameterError
        If ``scenario`` is not a :class:`Scenario`.
    UnreachablePoseError
        If the path leaves the workspace in every admissible working mode.
    SingularityError
        If the path comes within ``singularity_margin`` of a gain-type singularity in every admissible mode.
    UnstableControlError
        If the gains and the sample time give an unstable sampled-data loop along the path, or the run diverges.
    BranchFollowingError
        If the plant or the controller's model comes within ``singularity_guard`` of a gain-type singularity
        during the run, or cannot follow its assembly mode.
    AssemblyError
        If the plant cannot be assembled at the start actuator values.

    Notes
    -----
    A machine's first sampled-data run from an empty kernel cache compiles its loop in a second Python process
    while this one prepares the run (:mod:`pkmlab.simulation.ahead`; ``PKMLAB_COMPILE_AHEAD=0`` switches it off).

    Examples
    --------
    >>> import pkmlab
    >>> result = pkmlab.simulate(pkmlab.paper_scenario("fast"))
    >>> result.t.shape, result.summary()["working_mode"]
    ((787,), [-1, 1, -1])
    >>> bool(result.summary()["max_path_error_m"] < 1e-4)
    True
    """
    if not isinstance(scenario, Scenario):
        hint = f" (a paper case: simulate(paper_scenario({scenario!r})))" if isinstance(scenario, str) else ""
        raise InvalidParameterError(f"scenario must be a Scenario, got {type(scenario).__name__} "
                                    f"{shown(scenario, 50)}{hint}")
    compile_loop_ahead(scenario)  # from an empty kernel cache: the loop compiled meanwhile, in a second process
    return run_prepared(scenario, prepare_run(scenario))


def run_prepared(scenario: Scenario, prep: PreparedRun) -> SimulationResult:
    """:func:`simulate` of a run prepared already: several runs prepared before the first of them, while their loop
    compiles in a second process (:mod:`~pkmlab.simulation.ahead`).

    Parameters
    ----------
    scenario : Scenario
        The run.
    prep : PreparedRun
        :func:`prepare_run` of ``scenario``.

    Returns
    -------
    SimulationResult
        As :func:`simulate`'s.
    """
    if not isinstance(scenario, Scenario) or not isinstance(prep, PreparedRun):
        raise InvalidParameterError(f"run_prepared takes a Scenario and its PreparedRun, got "
                                    f"{type(scenario).__name__} and {type(prep).__name__}")
    ctrl, plant = scenario.model, scenario.plant_model
    q_plant0, q_ctrl0 = prep.q_plant0, prep.q_ctrl0
    if scenario.sample_time == 0:
        q, rates, tau = _continuous_time(scenario, prep, ctrl, plant, q_plant0, q_ctrl0)
        s = np.empty(q.shape[0])
        plant.kernels.singularity_measures(q, plant.P, s)
        return run_result(scenario, prep, q, actuator_rates(plant, q, rates), tau, _pose_of(plant, q),
                          run_measures(plant, q, s))
    k_, n, n_x = ctrl.kernels, ctrl.n_actuators, ctrl.kernels.N_INDEPENDENT
    count = prep.t.size
    q, rates, tau, s = np.zeros((count, q_ctrl0.size)), np.zeros((count, n_x)), np.zeros((count, n)), np.zeros(count)
    r = prep.realism
    theta_m = np.zeros((count if r.sensing >= 0 else 0, n))
    theta_d, pose_d = np.empty((count, n)), np.empty((count, _dof(ctrl)))  # the desired motion the result keeps
    # the loop's state, handed from one piece of the run to the next
    workspaces, x, theta_dot_m = k_.make_workspaces(2), np.zeros(2 * n_x), np.zeros_like(theta_m)
    compile_plant_stage_meanwhile(ctrl, prep.P_plant, r.drive)  # (an empty cache: a share of the loop's compile)
    for rows, d in prep.motion.pieces():
        theta_d[rows], pose_d[rows] = d.theta, d.pose
        status, k_fail = k_.sampled_data_chunk(workspaces, x, theta_dot_m, rows.start, count, scenario.sample_time,
                                               scenario.substeps, *loop_motion(ctrl, d), q_plant0,
                                               q_ctrl0, prep.P_plant, prep.P_ctrl, prep.kind, prep.kp, prep.kv,
                                               prep.distribution, prep.singularity_guard, *r, q, rates, tau, s,
                                               theta_m)
        if status != k_.OK:
            raise _loop_error(scenario, prep, status, q, k_fail, theta_d=theta_d, q_d=d.q[k_fail - rows.start])
    # the plant's pose is its configuration's last coordinates: a view of q, not a copy (a long run's memory; a
    # kinematically redundant machine's, whose base actuators are q's first, a copy)
    return run_result(scenario, prep, q, actuator_rates(plant, q, rates), tau, pose_of(plant, q),
                      run_measures(plant, q, s), theta_m if r.sensing >= 0 else None, theta_d, pose_d)


def _dof(model: MechanismModel) -> int:
    return model.description.dof


def _continuous_time(scenario: Scenario, prep: PreparedRun, ctrl: MechanismModel, plant: MechanismModel,
                     q_plant0: np.ndarray, q_ctrl0: np.ndarray):
    """Continuous-time control: the controller evaluated at every stage of DOP853. Configurations in the loop
    model's coordinates; the state is the loop's independent coordinates and their rates (the actuators', or a
    redundantly actuated machine's pose's). Returns the configurations, those rates and the efforts at the
    samples."""
    k_, n, n_x = ctrl.kernels, ctrl.n_actuators, ctrl.kernels.N_INDEPENDENT
    P_plant, P_ctrl = plant.P, ctrl.P
    # the last configurations reached: each evaluation branch-follows from there
    q_plant, q_ctrl, q_next = q_plant0.copy(), q_ctrl0.copy(), np.empty_like(q_plant0)
    tau, applied, r = np.zeros(n), np.zeros(n), prep.realism
    readings = np.zeros((0, n))  # continuous-time control reads the plant's state

    def control(time, theta, theta_dot):
        d = _loop_motion_at(scenario, prep, time)
        status = k_.measured_control_effort(0, 0.0, np.concatenate([theta, theta_dot]), q_ctrl, prep.kind, prep.kp,
                                            prep.kv, prep.distribution, *d, P_ctrl, prep.singularity_guard, r.drive,
                                            r.ctrl_drive, r.effort_noise, r.resolution, r.theta_noise, r.sensing,
                                            r.delay, readings, readings, q_next, tau, applied)
        if status != k_.OK:
            raise BranchFollowingError(f"run stopped at t = {time:.4f} s: the controller's model "
                                       f"{branch_failure_text(status, prep.singularity_guard)}")
        q_ctrl[:] = q_next
        return tau

    def rhs(time, y):
        control(time, y[:n_x], y[n_x:])
        y_dot, status = k_.actuator_space_rhs(q_plant, y, applied, P_plant, prep.singularity_guard, r.drive, q_next)
        if status != k_.OK:
            raise BranchFollowingError(f"run stopped at t = {time:.4f} s: the plant "
                                       f"{branch_failure_text(status, prep.singularity_guard)}")
        q_plant[:] = q_next
        return y_dot

    from scipy.integrate import solve_ivp  # (0.3 s to import: only where it is used)
    start = q_plant0[list(k_.INDEPENDENT)]
    sol = solve_ivp(rhs, (0.0, float(prep.t[-1])), np.concatenate([start, np.zeros(n_x)]),
                    method="DOP853", rtol=1e-12, atol=1e-13, t_eval=prep.t)
    if sol.status != 0:
        raise SingularityError(f"integration failed: {sol.message}")
    # the reported samples: configurations by branch following along the solution, efforts re-evaluated
    q = np.empty((prep.t.size, len(q_plant0)))
    status, k = k_.follow_path(q_plant0, np.ascontiguousarray(sol.y[:n_x].T), P_plant, prep.singularity_guard, q)
    if status != k_.OK:
        raise BranchFollowingError(f"run stopped at t = {prep.t[k]:.4f} s: the plant "
                                   f"{branch_failure_text(status, prep.singularity_guard)}")
    efforts = np.empty((prep.t.size, n))
    q_ctrl[:] = q_ctrl0
    for k in range(prep.t.size):
        efforts[k] = control(prep.t[k], sol.y[:n_x, k].copy(), sol.y[n_x:, k].copy())  # the commands
    return q, sol.y[n_x:].T.copy(), efforts


def _loop_motion_at(scenario: Scenario, prep: PreparedRun, time: float):
    """The desired motion the loop tracks (:func:`loop_motion`) at one time: ``(θ_d, θ̇_d, θ̈_d)`` from the
    configuration of the nearest sample (the same branch), or a redundantly actuated machine's pose and its rates."""
    from ..model.mechanism_model import inverse_kinematics as machine_ik
    from ..model.mechanism_model import path_rates

    model = scenario.model
    dof = model.dof
    pose, pose_dot, pose_ddot = (np.asarray(a, dtype=float)[:, :dof] for a in scenario.trajectory.desired([time]))
    if model.description.actuation_redundancy:
        return pose[0], pose_dot[0], pose_ddot[0]
    q = machine_ik(model, pose[0], prep.mode)[None, :]
    theta_dot, theta_ddot, k = path_rates(model, q, pose_dot, pose_ddot)
    if k >= 0:
        raise SingularityError(f"the path meets an inverse-kinematic singularity at t = {time:.4f} s")
    nearest = min(int(round(time / (prep.t[1] - prep.t[0]))) if prep.t.size > 1 else 0, prep.t.size - 1)
    n = model.n_actuators
    theta = q[0, :n] + np.where(np.array(model.kernels.ANGLES[:n]),
                                2 * np.pi * np.round((prep.desired.theta[nearest] - q[0, :n]) / (2 * np.pi)), 0.0)
    return theta, theta_dot[0], theta_ddot[0]


def simulate_batch(scenarios, *, on_error: str = "raise") -> list:
    """Run many sampled-data scenarios in one call, spread over the CPU cores.

    The scenarios may differ in anything — plants, controller models, gains, speeds, paths,
    sample times — as long as they have the same number of samples (trajectories of equal
    length at equal ``Ts``, or any combination giving the same ``ceil(T / Ts) + 1``). Each run
    executes exactly the compiled code of :func:`simulate`, so its result is the same, bit for
    bit, as the run done alone. The set-up of runs that share the controller's model and path
    (an uncertainty study of the plant, a gain sweep) is done once. Use ``NUMBA_NUM_THREADS`` (or
    :func:`numba.set_num_threads`) to choose how many cores.

    Parameters
    ----------
    scenarios : iterable of Scenario
        The runs, all sampled-data (``sample_time > 0``) with the same number of samples.
    on_error : {"raise", "none", "return"}
        ``"raise"`` raises the first run's error, naming the run; ``"none"`` puts ``None`` in place of a failed
        run and keeps the others; ``"return"`` puts the run's error (a :class:`~pkmlab.errors.PkmlabError`
        naming the run, the time and the pose) in its place, so that a study can count why runs failed.

    Returns
    -------
    list
        One :class:`SimulationResult` per scenario, in order (or ``None`` or the error of a failed run).

    Raises
    ------
    InvalidParameterError
        If ``scenarios`` is not a list of scenarios, one is continuous-time, or their numbers of samples differ.
    PkmlabError
        With ``on_error="raise"``, the first failed run's error (as :func:`simulate` raises it), naming the run.

    Examples
    --------
    >>> from pkmlab import ControllerSpec, paper_scenario, simulate_batch
    >>> base = paper_scenario("disturbed")
    >>> runs = simulate_batch([base.replace(controller=ControllerSpec(kp=kp)) for kp in (400.0, 1000.0)])
    >>> len(runs), [r.t.size for r in runs]
    (2, [1572, 1572])
    """
    as_choice("on_error", on_error, ("raise", "none", "return"))
    try:
        if isinstance(scenarios, (Scenario, str, bytes)):
            raise TypeError
        scenarios = list(scenarios)
    except TypeError:
        raise InvalidParameterError(f"scenarios must be a list of Scenario objects, got {type(scenarios).__name__} "
                                    f"{shown(scenarios, 50)}") from None
    if not scenarios:
        return []
    cache: dict = {}
    preps: list[PreparedRun | None] = []
    errors: dict[int, PkmlabError] = {}
    for i, sc in enumerate(scenarios):
        if not isinstance(sc, Scenario):
            raise InvalidParameterError(f"scenarios[{i}] must be a Scenario, got {type(sc).__name__} {shown(sc, 50)}")
        if sc.sample_time <= 0:
            raise InvalidParameterError(f"run {i} ({sc.name}): simulate_batch runs sampled-data control only "
                                        "(sample_time > 0); use simulate for continuous-time control")
        try:
            preps.append(prepare_run(sc, cache))
        except PkmlabError as exc:
            errors[i] = type(exc)(f"run {i} ({sc.name}): {exc}")
            if on_error == "raise":
                raise errors[i] from None
            preps.append(None)
    sizes = {p.t.size for p in preps if p is not None}
    if len(sizes) > 1:
        raise InvalidParameterError(f"all runs of a batch need the same number of samples, got {sorted(sizes)}")
    live = [i for i, p in enumerate(preps) if p is not None]
    results: list = [errors.get(i) if on_error == "return" else None for i in range(len(scenarios))]
    groups: dict = {}  # one compiled call per structure: its generated loop
    for i in live:  # and per shape of the drive and sensor arrays, which one call stacks
        groups.setdefault((scenarios[i].model.kernels, preps[i].realism.signature), []).append(i)
    for (kernels, _signature), members in groups.items():
        outcome = _run_batch(kernels, [scenarios[i] for i in members], [preps[i] for i in members])
        for i, (status, q, theta_dot, tau, pose, s, k_fail, theta_m) in zip(members, outcome, strict=True):
            sc, p = scenarios[i], preps[i]
            if status != kernels.OK:
                error = _loop_error(sc, p, status, q, k_fail, f"run {i} ({sc.name}): ")
                if on_error == "raise":
                    raise error
                if on_error == "return":
                    results[i] = error
                continue
            results[i] = run_result(sc, p, q, theta_dot, tau, pose, s, theta_m)
    return results


def _run_batch(kernels, scenarios: list, preps: list) -> list:
    """Run prepared scenarios of one structure (``kernels``) and one shape of drive and sensor arrays in one
    parallel compiled call; per run ``(status, q, θ̇, τ, pose, S, k_fail, θ measured or None)``, configurations in
    each scenario's own coordinates."""
    m, n = len(scenarios), preps[0].t.size
    loop = scenarios[0].model
    n_act, n_x, n_q, P_len = loop.n_actuators, kernels.N_INDEPENDENT, kernels.N_COORDINATES, loop.P.size
    stack = [np.empty((m, n, n_x)) for _ in range(3)]  # the desired motion the loop tracks
    q0, qc0 = np.empty((m, n_q)), np.empty((m, n_q))
    P_plant, P_ctrl = np.empty((m, P_len)), np.empty((m, P_len))
    ts, n_sub, kind = np.empty(m), np.empty(m, np.int64), np.empty(m, np.int64)
    kp, kv, guards = np.empty(m), np.empty(m), np.empty(m)
    distribution = np.empty((m, 4, n_act))
    real = preps[0].realism
    drive, ctrl_drive, effort_noise, theta_noise = (np.empty((m, *a.shape)) for a in (
        real.drive, real.ctrl_drive, real.effort_noise, real.theta_noise))
    resolution, sensing, delay = np.empty((m, n_act)), np.empty(m, np.int64), np.empty(m, np.int64)
    for r, (sc, p) in enumerate(zip(scenarios, preps, strict=True)):
        for series, desired in zip(stack, loop_motion(loop, p.desired), strict=True):
            series[r] = desired
        q0[r], qc0[r] = p.q_plant0, p.q_ctrl0
        P_plant[r], P_ctrl[r] = p.P_plant, p.P_ctrl
        ts[r], n_sub[r], kind[r] = sc.sample_time, sc.substeps, p.kind
        kp[r], kv[r], distribution[r], guards[r] = p.kp, p.kv, p.distribution, p.singularity_guard
        drive[r], ctrl_drive[r], effort_noise[r], resolution[r], theta_noise[r], sensing[r], delay[r] = p.realism
    # read-only as a model's own parameters are (simulate passes those): the runs of a batch and a single run then
    # call one compiled loop, not two of different argument types
    P_plant.setflags(write=False)
    P_ctrl.setflags(write=False)
    q, rates, tau = np.zeros((m, n, n_q)), np.zeros((m, n, n_x)), np.zeros((m, n, n_act))
    s = np.zeros((m, n))
    theta_m = np.zeros((m, n if real.sensing >= 0 else 0, n_act))
    status, k_fail = np.zeros(m, np.int64), np.zeros(m, np.int64)
    kernels.sampled_data_batch(ts, n_sub, *stack, q0, qc0, P_plant, P_ctrl, kind, kp, kv, distribution, guards, drive,
                               ctrl_drive, effort_noise, resolution, theta_noise, sensing, delay, q, rates, tau, s,
                               theta_m, status, k_fail)
    return [(status[r], q[r], actuator_rates(loop, q[r], rates[r]), tau[r], _pose_of(loop, q[r]),
             run_measures(loop, q[r], s[r]), k_fail[r],
             theta_m[r] if real.sensing >= 0 else None) for r in range(m)]
