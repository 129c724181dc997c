"""Excitation trajectories: motions that make a machine's base parameters identifiable from few, noisy data.

A motion excites the base parameters well when its base regressor ``W`` (the regressor of every sample stacked,
:mod:`~pkmlab.algorithms.regressor`) has a small condition number: then no combination of parameters hides in
the noise. :func:`excitation_trajectory` finds one: in every pose coordinate a finite Fourier series
(:class:`~pkmlab.control.trajectory.FourierTrajectory`, Swevers et al. 1997) about a centre pose, whose
coefficients minimise the logarithm of the scaled condition number of ``W`` over one period, subject to — at
every sample —

- the pose staying within ``excursion`` of the centre, coordinate by coordinate;
- the pose reachable in the working mode, ``|S| ≥ singularity_margin`` (the singularity measure of the
  scenarios' margin);
- each actuator's rate within its ``velocity`` limit and, when given, each effort of the model within its
  ``effort`` limit.

The series is written in the pose rather than in the actuators because the inverse kinematics of a parallel
machine is its direct map: every sample's configuration is exact, with no branch to follow and no assembly
mode to lose, and a pose outside the workspace is seen as such. The actuators, functions of the pose, are as
periodic and smooth. The first harmonic's coefficients are fixed by the others so that each period starts and
ends at rest. The optimisation is sequential quadratic programming (SciPy's SLSQP) from a random start
(``seed``), the gradients by forward differences; it keeps the best feasible motion it evaluates, and the
result is checked again on a grid ten times finer, its amplitude reduced if a limit is passed between samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validate import as_batch, as_count, as_flag, as_limits, as_real
from ..algorithms.identification import scaled_condition_number
from ..algorithms.kinematics import as_model, as_working_mode, length_scale
from ..algorithms.regressor import base_parameters, dynamics_regressor, inertial_parameters
from ..errors import InvalidParameterError, SingularityError, UnreachablePoseError, shown
from ..model import mechanism_model as mm
from .trajectory import FourierTrajectory, JointMotion

__all__ = ["Excitation", "excitation_trajectory", "DEFAULT_PERIOD", "DEFAULT_HARMONICS"]

#: The default period (s): a base frequency of 0.1 Hz, as Swevers et al. excite serial robots.
DEFAULT_PERIOD = 10.0
#: The default number of harmonics per coordinate.
DEFAULT_HARMONICS = 5
#: The default singularity margin on ``|S|`` (that of the scenarios).
DEFAULT_MARGIN = 0.05
#: The default excursion from the centre: this share of the machine's size (m) for a position, and (rad) for an
#: angle.
POSITION_EXCURSION = 0.1
ANGLE_EXCURSION = 0.3
#: Samples per period of the highest harmonic on which the optimisation checks the limits; the result is checked
#: again on a grid ten times finer.
SAMPLES_PER_HARMONIC = 16
_ANGLES = ("alpha", "roll", "pitch", "yaw")


@dataclass(frozen=True)
class Excitation:
    """An excitation trajectory (:func:`excitation_trajectory`) and what it was checked against.

    Attributes
    ----------
    trajectory : FourierTrajectory
        The motion of the pose, at rest at its centre at the start and end of each period.
    mode : tuple of int
        The working mode it is run in.
    condition_number : float
        The scaled condition number of its base regressor (on the fine grid of one period).
    start_condition_number : float
        The same of the random start the optimisation began from.
    singularity : float
        The smallest ``|S|`` along it.
    excursion : ndarray, shape (dof,)
        The largest distance of each pose coordinate from the centre.
    velocity, effort : ndarray, shape (n_actuators,)
        Each actuator's largest rate and the largest effort of the model.
    limits : dict
        The limits it satisfies: ``excursion`` (dof,), ``velocity`` and ``effort`` (n_actuators,) or None,
        ``singularity_margin``.
    iterations : int
        The optimiser's iterations.
    drives : bool
        Whether the drives' armature and friction were among the parameters to excite.
    """

    trajectory: FourierTrajectory
    mode: tuple
    condition_number: float
    start_condition_number: float
    singularity: float
    excursion: np.ndarray
    velocity: np.ndarray
    effort: np.ndarray
    limits: dict
    iterations: int
    drives: bool

    def motion(self, model, rate: float = 1000.0) -> JointMotion:
        """The desired motion of ``model``'s actuators sampled at ``rate`` (Hz) over the whole trajectory: what a
        user plays on the machine (``θ``, ``θ̇``, ``θ̈`` exact, from the pose's inverse kinematics)."""
        rate = as_real("rate", rate, "positive")
        t = np.arange(int(math.floor(self.trajectory.duration * rate + 1e-9)) + 1) / rate
        return _motion(model, self.trajectory, self.mode, t)

    def summary(self) -> dict:
        """A JSON-ready summary."""
        tr = self.trajectory
        limits = {k: None if v is None else np.asarray(v).tolist() for k, v in self.limits.items()}
        return {"period_s": tr.period, "periods": tr.periods, "harmonics": tr.harmonics,
                "duration_s": tr.duration, "center": tr.center.tolist(), "working_mode": list(self.mode),
                "condition_number": self.condition_number, "start_condition_number": self.start_condition_number,
                "min_abs_S": self.singularity, "excursion": self.excursion.tolist(),
                "peak_velocity": self.velocity.tolist(), "peak_effort": self.effort.tolist(), "limits": limits,
                "iterations": self.iterations, "drives": self.drives}


def _motion(model, trajectory: FourierTrajectory, mode, t: np.ndarray) -> JointMotion:
    pose, pose_dot, pose_ddot = trajectory.desired(t)
    q, s, failure = mm.path_inverse_kinematics(model, pose, mode, follow=True)
    if failure is not None:
        raise UnreachablePoseError(f"the excitation leaves the workspace at t = {t[failure[0]]:.4f} s: "
                                   f"{failure[1]}") from None
    theta_dot, theta_ddot, k = mm.path_rates(model, q, pose_dot, pose_ddot)
    if k >= 0:
        raise SingularityError(f"the excitation meets an inverse-kinematic singularity at t = {t[k]:.4f} s")
    n = model.n_actuators
    return JointMotion(t, q, pose, q[:, :n].copy(), theta_dot, theta_ddot, np.abs(s))


class _Problem:
    """The optimisation over the dimensionless coefficients ``x`` (2, harmonics - 1, dof): ``a_k = E ω x_0k`` and
    ``b_k = E ω x_1k`` for ``k ≥ 2`` (``E`` the excursions), the first harmonic's fixed by the rest conditions."""

    def __init__(self, model, mode, center, excursion, period, harmonics, velocity, effort, margin, base, drives,
                 samples):
        self.model, self.mode, self.center, self.E = model, mode, center, excursion
        self.period, self.H = period, harmonics
        self.velocity, self.effort, self.margin = velocity, effort, margin
        self.base, self.drives = base, drives
        self.pi = inertial_parameters(model)
        self.t = np.arange(samples) * period / samples
        self.w = 2 * math.pi / period
        self.k = np.arange(1, harmonics + 1)[:, None]
        self.cache: dict[bytes, tuple[float, np.ndarray, dict]] = {}
        self.best: tuple[float, np.ndarray] | None = None

    @property
    def size(self) -> int:
        return 2 * (self.H - 1) * len(self.center)

    def trajectory(self, x: np.ndarray) -> FourierTrajectory:
        x = x.reshape(2, self.H - 1, len(self.center))
        a = np.empty((self.H, len(self.center)))
        b = np.empty_like(a)
        a[1:], b[1:] = self.E * self.w * x[0], self.E * self.w * x[1]
        a[0] = -a[1:].sum(axis=0)
        b[0] = -(self.k[1:] * b[1:]).sum(axis=0)
        return FourierTrajectory(tuple(self.center), self.period, a, b)

    def evaluate(self, x: np.ndarray, t: np.ndarray | None = None) -> tuple[float, np.ndarray, dict]:
        """``(objective, constraints ≥ 0, details)`` of ``x`` on the grid ``t`` (default the optimisation's)."""
        key = x.tobytes()
        if t is None and key in self.cache:
            return self.cache[key]
        t = self.t if t is None else t
        model, n = self.model, self.model.n_actuators
        pose, pose_dot, pose_ddot = self.trajectory(x).desired(t)
        deviation = (pose - self.center) / self.E
        q, s, _failure = mm.path_inverse_kinematics(model, pose, self.mode, follow=True)
        ok = np.all(np.isfinite(q), axis=1)
        theta_dot = np.full((len(t), n), np.nan)
        theta_ddot = np.full((len(t), n), np.nan)
        if ok.any():
            theta_dot[ok], theta_ddot[ok], _k = mm.path_rates(model, q[ok], pose_dot[ok], pose_ddot[ok])
        ok &= np.all(np.isfinite(theta_dot), axis=1) & np.all(np.isfinite(theta_ddot), axis=1)
        parts = [1.0 - deviation.ravel(), 1.0 + deviation.ravel(),
                 np.where(ok, np.abs(s), 0.0) - self.margin]
        details = {"excursion": np.abs(pose - self.center).max(axis=0), "singularity": float(np.abs(s).min())
                   if ok.all() else 0.0, "velocity": np.abs(theta_dot).max(axis=0), "effort": np.full(n, np.nan)}
        if self.velocity is not None:
            parts.append(np.where(ok[:, None], 1.0 - (theta_dot / self.velocity) ** 2, -1.0).ravel())
        objective = math.inf
        if ok.sum() * n >= self.base.rank:
            with np.errstate(all="ignore"):
                Y = dynamics_regressor(model, q[ok], theta_dot[ok], theta_ddot[ok], drives=self.drives)
                W = np.swapaxes(self.base.regressor(Y), 0, 1).reshape(-1, self.base.rank)
                objective = math.log(scaled_condition_number(W))
                tau = Y[..., :self.pi.size] @ self.pi  # the model's efforts, Y π = τ (drives' columns zero)
            details["effort"] = np.abs(tau).max(axis=0)
            if self.effort is not None:
                full = np.full((len(t), n), -1.0)
                full[ok] = 1.0 - (tau / self.effort) ** 2
                parts.append(full.ravel())
        elif self.effort is not None:
            parts.append(np.full(len(t) * n, -1.0))
        constraints = np.nan_to_num(np.concatenate(parts), nan=-1.0)
        out = (objective if math.isfinite(objective) else 1e3, constraints, details)
        if t is self.t:
            self.cache[key] = out
            if constraints.min() >= 0.0 and math.isfinite(objective) and (self.best is None
                                                                          or objective < self.best[0]):
                self.best = (objective, x.copy())
        return out

    def gradients(self, x: np.ndarray, step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
        """Forward differences of the objective and the constraints, from one evaluation per coordinate."""
        f0, c0, _ = self.evaluate(x)
        grad, jac = np.empty(x.size), np.empty((c0.size, x.size))
        for i in range(x.size):
            xi = x.copy()
            xi[i] += step
            f, c, _ = self.evaluate(xi)
            grad[i], jac[:, i] = (f - f0) / step, (c - c0) / step
        return grad, jac


def _start(problem: _Problem, rng: np.random.Generator) -> np.ndarray:
    """A random feasible start: coefficients falling off as ``1/k``, scaled to half the excursion and halved
    until every limit holds."""
    x = rng.uniform(-1.0, 1.0, (2, problem.H - 1, len(problem.center))) / problem.k[1:]
    x = x.ravel()
    peak = np.abs(problem.trajectory(x).desired(problem.t)[0] - problem.center).max(axis=0) / problem.E
    x *= 0.5 / max(float(peak.max()), 1e-300)
    for _ in range(12):
        if problem.evaluate(x)[1].min() >= 0.0:
            return x
        x *= 0.5
    raise InvalidParameterError("no excitation within the limits was found near the centre: lower the excursion "
                                "or raise the velocity or effort limits")


def _within_limits(problem: _Problem, x: np.ndarray, t: np.ndarray, shrink: float = 0.98, tries: int = 60):
    """``(objective, x, details)`` of ``x`` shrunk by ``shrink`` until every limit holds on the grid ``t``, or None
    if ``tries`` shrinks are not enough."""
    for _ in range(tries):
        objective, constraints, details = problem.evaluate(x, t)
        if constraints.min() >= 0.0:
            return objective, x, details
        x = shrink * x
    return None


def _centre(model, center, mode, margin) -> np.ndarray:
    dof = model.description.dof
    if center is None:
        return mm.pose_of(model, mm.well_conditioned_configuration(model, mode)).copy()
    center = as_batch("center", center, dof, single=True)[0][0].copy()
    _q, s, failure = mm.path_inverse_kinematics(model, center[None], mode)
    if failure is not None:
        raise UnreachablePoseError(f"the centre {center.tolist()} is not reachable in working mode "
                                   f"{list(mode)}: {failure[1]}")
    if abs(s[0]) < margin:
        raise SingularityError(f"the centre {center.tolist()} is within |S| = {abs(s[0]):.3g} of a gain-type "
                               f"singularity (margin {margin:g})")
    return center


def excitation_trajectory(model, *, period: float = DEFAULT_PERIOD, harmonics: int = DEFAULT_HARMONICS,
                          periods: int = 1, center=None, mode=None, excursion=None, velocity=None, effort=None,
                          singularity_margin: float = DEFAULT_MARGIN, drives: bool = False, seed: int = 0,
                          iterations: int = 50, callback=None) -> Excitation:
    """An excitation trajectory of ``model`` for dynamic identification: a Fourier series of the pose minimising
    the condition number of the base regressor within the limits (the module's text).

    Parameters
    ----------
    model : MechanismModel
        The machine (its nominal inertial parameters set the effort limits' check only).
    period : float
        The period ``T`` (s); the base frequency is ``1/T``.
    harmonics : int
        The number of harmonics per pose coordinate (2 to 20).
    periods : int
        How many times the trajectory repeats its period (averaging the noise of repeated periods).
    center : array_like, shape (dof,), optional
        The pose the motion is about, where it starts and ends (default a pose far from singularities,
        :func:`~pkmlab.model.mechanism_model.well_conditioned_configuration`).
    mode : sequence of int, optional
        The working mode (default the first).
    excursion : float or array_like, shape (dof,), optional
        The largest distance from ``center`` of each coordinate (m, rad); default 0.1 of the machine's size
        for a position and 0.3 rad for an angle.
    velocity, effort : float or array_like, shape (n_actuators,), optional
        The largest rate (rad/s, m/s) and effort (N m, N) of each actuator; no limit when not given.
    singularity_margin : float
        The smallest ``|S|`` allowed along the motion.
    drives : bool
        Excite the drives' armature and friction parameters too.
    seed : int
        The random start of the optimisation.
    iterations : int
        The optimiser's largest number of iterations.
    callback : callable, optional
        Called after each iteration with its number and the best condition number so far (a progress bar).

    Returns
    -------
    Excitation

    Raises
    ------
    InvalidParameterError
        For a limit that is not positive, or when no motion within the limits could be started from.
    UnreachablePoseError, SingularityError
        For a centre outside the workspace or near a singularity.
    """
    model = as_model(model)
    dof, n = model.description.dof, model.n_actuators
    period = as_real("period", period, "positive")
    harmonics = as_count("harmonics", harmonics, 2, 20)
    periods = as_count("periods", periods)
    iterations = as_count("iterations", iterations, 1, 10_000)
    seed = as_count("seed", seed, 0)
    drives = as_flag("drives", drives)
    margin = as_real("singularity_margin", singularity_margin, "non-negative")
    if callback is not None and not callable(callback):
        raise InvalidParameterError(f"callback must be a function of (iteration, condition number), got "
                                    f"{shown(callback)}")
    mode = tuple(mm.working_modes(model)[0] if mode is None else as_working_mode(model, mode, "mode"))
    if mode == "auto":
        raise InvalidParameterError("mode must be a working mode (one sign per two-branch leg), not 'auto'")
    center = _centre(model, center, mode, margin)
    default = np.array([ANGLE_EXCURSION if name in _ANGLES else POSITION_EXCURSION * length_scale(model)
                        for name in model.pose_names])
    excursion = default if excursion is None else as_limits("excursion", excursion, dof, "pose coordinate")
    velocity, effort = as_limits("velocity", velocity, n), as_limits("effort", effort, n)
    base = base_parameters(model, drives=drives)
    problem = _Problem(model, mode, center, excursion, period, harmonics, velocity, effort, margin, base, drives,
                       SAMPLES_PER_HARMONIC * harmonics)
    x0 = _start(problem, np.random.default_rng(seed))
    start_cond = math.exp(problem.evaluate(x0)[0])
    from scipy.optimize import minimize

    grads: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def gradients(x):
        key = x.tobytes()
        if key not in grads:
            grads[key] = problem.gradients(x)
        return grads[key]

    done = [0]

    def step(_x):
        done[0] += 1
        if callback is not None:
            callback(done[0], math.exp(problem.best[0]))

    result = minimize(lambda x: problem.evaluate(x)[0], x0, jac=lambda x: gradients(x)[0], method="SLSQP",
                      constraints=[{"type": "ineq", "fun": lambda x: problem.evaluate(x)[1],
                                    "jac": lambda x: gradients(x)[1]}],
                      bounds=[(-1.0, 1.0)] * problem.size, options={"maxiter": iterations, "ftol": 1e-4},
                      callback=step)
    fine = np.arange(10 * len(problem.t)) * period / (10 * len(problem.t))
    # SLSQP's last iterate may pass a limit by a little, and any motion may pass one between the samples: each
    # candidate is shrunk towards the centre until it holds every limit on the fine grid, the better one kept
    candidates = [_within_limits(problem, x, fine) for x in (result.x, problem.best[1])]
    found = [c for c in candidates if c is not None]
    if not found:
        raise InvalidParameterError("no excitation holds its limits between the optimisation's samples: lower the "
                                    "harmonics or the excursion")
    objective, x, details = min(found, key=lambda c: c[0])
    trajectory = problem.trajectory(x)
    trajectory = FourierTrajectory(trajectory.center, period, trajectory.a, trajectory.b, periods)
    limits = {"excursion": excursion, "velocity": velocity, "effort": effort, "singularity_margin": margin}
    return Excitation(trajectory, mode, math.exp(objective), start_cond, details["singularity"],
                      details["excursion"], details["velocity"], details["effort"], limits, int(result.nit), drives)
