"""Plants for every machine: the simulated machine, advancing its state under actuator efforts.

Two independent formulations of the same physics, for any :class:`~pkmlab.model.mechanism_model.MechanismModel`
(:func:`pkmlab.load`):

* :class:`ActuatorSpacePlant` integrates the actuator-space model (eq. 35), ``Mθ θ̈ + cθ + gθ = τ``, in the
  state ``(θ, θ̇)``; at every evaluation the passive coordinates are found by the compiled core's branch
  following (the paper's §3.2), so the configuration stays on the loop closure to round-off by
  construction. It is the simulation's own plant, under an adaptive integrator.
* :class:`FullSpacePlant` integrates all ``n`` coordinates with the loop-closure multipliers (eq. 26) as an
  index-1 differential-algebraic system, ``M q̈ + C q̇ + g = Q(τ) + Jηqᵀ λ`` with
  ``Jηq q̈ = -J̇ηq q̇ - 2ω Jηq q̇ - ω² η`` (Baumgarte stabilisation of the drift, ``η̈ + 2ω η̇ + ω² η = 0``).
  It shares no reduction step with the first and serves as its cross-check.

Both integrate with SciPy's DOP853 at tight tolerances (relative 1e-11 by default), so that the integration
error stays far below any tracking error of interest. Efforts are a constant ``(n_actuators,)`` or a
function ``tau(t, theta, theta_dot) -> (n_actuators,)`` (N·m for revolute actuators, N for prismatic ones).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._validate import as_batch, as_real
from ..algorithms.kinematics import (
    CLOSURE_TOLERANCE,
    SINGULAR_S,
    as_model,
    check_loop_closure,
    constraint_residuals,
    coordinate_rates,
    length_scale,
)
from ..errors import BranchFollowingError, InvalidParameterError, SingularityError, shown
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from ..numerics import lagrangian

__all__ = ["PlantRun", "ActuatorSpacePlant", "FullSpacePlant"]


@dataclass(frozen=True)
class PlantRun:
    """Time series of a plant simulation (like SciPy's ``OdeResult``).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Output times (s): ``t_eval`` when given, else the integrator's own steps.
    q : ndarray, shape (N, n)
        Configurations ``(θ, passive joints, pose)`` at ``t`` (``model.coordinates`` names the entries).
    q_dot : ndarray, shape (N, n)
        Their rates.
    closure_violation : ndarray, shape (N,)
        ``max |η(q)|`` (m) at each output time: how far the loop closure is from holding.
    n_evaluations : int
        How many times the plant's right-hand side was evaluated.
    n_actuators : int
        How many of the coordinates' leading entries are the actuators.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q0 = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> run = pkmlab.ActuatorSpacePlant(model).simulate(q0, [0.0, 0.0], [0.0, 0.0], 0.02, t_eval=[0.0, 0.01, 0.02])
    >>> run.t.tolist(), run.theta_dot.shape, bool(np.allclose(run.theta, q0[:2]))
    ([0.0, 0.01, 0.02], (3, 2), True)
    """

    t: np.ndarray
    q: np.ndarray
    q_dot: np.ndarray
    closure_violation: np.ndarray
    n_evaluations: int
    n_actuators: int

    @property
    def theta(self) -> np.ndarray:
        """The actuator values ``θ`` (N, n_actuators) (rad or m)."""
        return self.q[:, :self.n_actuators]

    @property
    def theta_dot(self) -> np.ndarray:
        """The actuator rates ``θ̇`` (N, n_actuators) (rad/s or m/s)."""
        return self.q_dot[:, :self.n_actuators]


# ------------------------------------------------------------------ shared checks
def _effort_function(tau, n_actuators: int) -> Callable[[float, np.ndarray, np.ndarray], np.ndarray]:
    """``tau`` as a checked function of ``(t, θ, θ̇)``: a constant is validated once, a callable's output at
    every call (the compiled dynamics would read past a short array)."""
    if callable(tau):
        def checked(t, theta, theta_dot):
            value = tau(t, theta.copy(), theta_dot.copy())
            complex_ = getattr(value, "dtype", None) is not None and np.dtype(value.dtype).kind == "c"
            try:
                arr = None if complex_ else np.asarray(value, dtype=float)
            except (TypeError, ValueError, OverflowError):
                arr = None
            if arr is None or arr.shape != (n_actuators,):
                raise InvalidParameterError(f"tau(t, theta, theta_dot) must return {n_actuators} numbers, got "
                                            f"{shown(value)} at t = {t:.6g} s")
            if not np.all(np.isfinite(arr)):
                raise InvalidParameterError(f"tau(t, theta, theta_dot) must return finite numbers, got "
                                            f"{shown(value)} at t = {t:.6g} s")
            return arr

        return checked
    constant = as_batch("tau", tau, n_actuators, single=True)[0][0].copy()
    return lambda t, theta, theta_dot: constant


def check_times(t_final, t_eval):
    """Validated ``(t_final, t_eval)``: a positive horizon and output times increasing within it."""
    t_final = as_real("t_final", t_final, "positive")
    if t_eval is None:
        return t_final, None
    complex_ = getattr(t_eval, "dtype", None) is not None and np.dtype(t_eval.dtype).kind == "c"
    try:
        arr = None if complex_ else np.asarray(t_eval, dtype=float)
    except (TypeError, ValueError, OverflowError):
        arr = None
    if (arr is None or arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr))
            or np.any(np.diff(arr) <= 0) or arr[0] < 0 or arr[-1] > t_final):
        raise InvalidParameterError(f"t_eval must be times increasing strictly within [0, t_final], "
                                    f"got {shown(t_eval)}")
    return t_final, arr


def _start(model: MechanismModel, q0) -> np.ndarray:
    """``q0`` as a validated (n,) configuration on the loop closure."""
    q0 = as_batch("q0", q0, len(model.coordinates), single=True)[0][0].copy()
    check_loop_closure(model, q0[None, :], (), "q0")
    return q0


def _closure_violation(model: MechanismModel, qs: np.ndarray) -> np.ndarray:
    """``max |η(q)|`` (m) of each configuration of ``qs`` (K, n)."""
    return np.abs(constraint_residuals(model, qs)).max(axis=1)


def _integrate(rhs, t_final, y0, t_eval, rtol, atol):
    from scipy.integrate import solve_ivp  # (0.3 s to import: only where it is used)

    sol = solve_ivp(rhs, (0.0, float(t_final)), y0, method="DOP853", rtol=rtol, atol=atol, t_eval=t_eval)
    if sol.status != 0:
        reached = sol.t[-1] if sol.t.size else 0.0
        raise SingularityError(f"the integration failed after t = {reached:.6g} s: {sol.message} "
                               f"(rtol = {rtol:g}, atol = {atol:g})")
    return sol


def _finite_or_raise(values: np.ndarray, t: float, what: str) -> None:
    if not np.all(np.isfinite(values)):
        raise SingularityError(f"the plant blew up at t = {t:.6g} s: its {what} are not finite (efforts or "
                               "rates too large for the model)")


# ------------------------------------------------------------------ the plants
class ActuatorSpacePlant:
    """The machine integrated in the actuator space: state ``(θ, θ̇)`` and eq. (35), ``Mθ θ̈ + cθ + gθ = τ``.

    The passive coordinates follow by the compiled core's branch following; DOP853 integrates the state.

    Parameters
    ----------
    model : MechanismModel
        The plant's own machine (:func:`pkmlab.load`; it may differ from a controller's model).
    rtol, atol : float
        DOP853's relative and absolute tolerances on the state ``(θ, θ̇)`` (``atol`` in rad and rad/s, or m
        and m/s); defaults 1e-11 and 1e-12.
    singularity_guard : float
        Branch following stops the run with :class:`~pkmlab.errors.BranchFollowingError` when ``|S|``
        falls below this (a gain-type singularity, where eq. 35 does not exist; default
        :data:`~pkmlab.SINGULAR_S`).

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model, ``rtol`` is not positive, or ``atol`` or ``singularity_guard`` is
        negative.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q0 = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> run = pkmlab.ActuatorSpacePlant(model).simulate(q0, [0.0, 0.0], [0.01, -0.01], 0.05,
    ...                                                 t_eval=np.linspace(0.0, 0.05, 6))
    >>> run.q.shape, run.theta.shape, bool(run.closure_violation.max() < 1e-12)
    ((6, 6), (6, 2), True)
    """

    def __init__(self, model: MechanismModel, rtol: float = 1e-11, atol: float = 1e-12,
                 singularity_guard: float = SINGULAR_S):
        self.model = as_model(model)
        self.rtol, self.atol = as_real("rtol", rtol, "positive"), as_real("atol", atol, "non-negative")
        self.singularity_guard = as_real("singularity_guard", singularity_guard, "non-negative")

    def simulate(self, q0, theta_dot0, tau, t_final: float, t_eval=None) -> PlantRun:
        """Integrate from configuration ``q0`` and actuator rates ``θ̇0`` under efforts ``tau``.

        Parameters
        ----------
        q0 : array_like, shape (n,)
            The initial configuration, on the loop closure (from inverse or forward kinematics or branch
            following); its assembly mode is the one followed.
        theta_dot0 : array_like, shape (n_actuators,)
            The initial actuator rates (rad/s or m/s).
        tau : array_like, shape (n_actuators,), or callable
            Constant actuator efforts (N·m or N), or a function ``tau(t, theta, theta_dot)`` returning them.
        t_final : float
            The horizon (s), positive.
        t_eval : array_like, shape (N,), optional
            Output times, increasing strictly within ``[0, t_final]``; the integrator's own steps if omitted.

        Returns
        -------
        PlantRun
            ``q`` by branch following along ``θ(t)`` from ``q0``, ``q_dot = Jqθ θ̇``.

        Raises
        ------
        InvalidParameterError
            A malformed or non-finite argument, ``q0`` off the loop closure, or ``tau`` returning the wrong
            shape.
        BranchFollowingError
            The run nears a gain-type singularity (``|S| < singularity_guard``) or loses its assembly mode (names
            the time).
        SingularityError
            The integration fails or the state blows up (names the time).
        """
        model = self.model
        n, na = len(model.coordinates), model.n_actuators
        q0 = _start(model, q0)
        theta_dot0 = as_batch("theta_dot0", theta_dot0, na, single=True)[0][0]
        effort = _effort_function(tau, na)
        t_final, t_eval = check_times(t_final, t_eval)
        kernels, P, singularity_guard = model.kernels, model.P, self.singularity_guard
        s0 = float(mm.singularity_measure(model, q0))
        if not abs(s0) >= singularity_guard:
            raise BranchFollowingError(f"q0 is at a gain-type singularity (|S| = {abs(s0):.3g} < singularity_guard = "
                                       f"{singularity_guard:g}): the actuator-space model does not exist there")
        q_last, q_work = q0.copy(), np.empty(n)
        evaluations = 0

        def rhs(t, y):
            nonlocal evaluations
            evaluations += 1
            efforts = effort(t, y[:na], y[na:])
            y_dot, status = kernels.actuator_space_rhs(q_last, np.ascontiguousarray(y), efforts, P, singularity_guard,
                                                       kernels.NO_DRIVES, q_work)
            if status != kernels.OK:
                why = (f"reached a gain-type singularity (|S| < singularity_guard = {singularity_guard:g})"
                       if status == kernels.SINGULAR else "could not follow its assembly mode")
                raise BranchFollowingError(f"the plant {why} at t = {t:.6g} s "
                                           f"(theta = {np.round(y[:na], 6).tolist()})")
            _finite_or_raise(y_dot, t, "actuator accelerations")
            q_last[:] = q_work
            return y_dot

        sol = _integrate(rhs, t_final, np.concatenate([q0[:na], theta_dot0]), t_eval, self.rtol, self.atol)
        # the passive coordinates at the output times, following the assembly mode from q0
        qs = np.empty((sol.t.size, n))
        status, k = kernels.follow_path(q0, np.ascontiguousarray(sol.y[:na].T), P, singularity_guard, qs)
        if status != kernels.OK:
            raise BranchFollowingError(f"the plant lost its assembly mode at t = {sol.t[k]:.6g} s")
        q_dot = coordinate_rates(model, qs, np.ascontiguousarray(sol.y[na:].T))
        return PlantRun(sol.t, qs, q_dot, _closure_violation(model, qs), evaluations, na)


class FullSpacePlant:
    """The machine integrated in all ``n`` coordinates with the loop-closure multipliers (eq. 26).

    An index-1 differential-algebraic system with Baumgarte stabilisation — no actuator-space reduction.

    At every evaluation it solves the saddle-point system ``M q̈ + C q̇ + g = Q(τ) + Jηqᵀ λ``,
    ``Jηq q̈ = -J̇ηq q̇ - 2ω Jηq q̇ - ω² η`` for ``(q̈, λ)``, where ``Q`` applies ``τ`` to the actuated
    coordinates.

    Parameters
    ----------
    model : MechanismModel
        The plant's own machine (:func:`pkmlab.load`).
    rtol, atol : float
        DOP853's relative and absolute tolerances on the state ``(q, q̇)`` (``atol`` in the coordinates'
        units and theirs per second); defaults 1e-11 and 1e-12.
    stabilization : float
        The Baumgarte rate ω (1/s) of ``η̈ + 2ω η̇ + ω² η = 0`` (critically damped; default 20); 0 integrates
        ``η̈ = 0`` alone, and the drift grows.

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model, ``rtol`` is not positive, or ``atol`` or ``stabilization`` is
        negative.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q0 = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> q_dot0 = pkmlab.coordinate_rates(model, q0, [0.5, -0.2])
    >>> run = pkmlab.FullSpacePlant(model).simulate(q0, q_dot0, [0.0, 0.0], 0.05,
    ...                                             t_eval=np.linspace(0.0, 0.05, 6))
    >>> run.q.shape, bool(run.closure_violation.max() < 1e-9)
    ((6, 6), True)
    """

    def __init__(self, model: MechanismModel, rtol: float = 1e-11, atol: float = 1e-12,
                 stabilization: float = 20.0):
        self.model = as_model(model)
        self.rtol, self.atol = as_real("rtol", rtol, "positive"), as_real("atol", atol, "non-negative")
        self.stabilization = as_real("stabilization", stabilization, "non-negative")

    def simulate(self, q0, q_dot0, tau, t_final: float, t_eval=None) -> PlantRun:
        """Integrate from configuration ``q0`` and rates ``q̇0`` under efforts ``tau``.

        Parameters
        ----------
        q0 : array_like, shape (n,)
            The initial configuration, on the loop closure (from inverse or forward kinematics or branch
            following).
        q_dot0 : array_like, shape (n,)
            The initial rates, tangent to the loop closure (``Jηq q̇0 = 0``:
            ``pkmlab.coordinate_rates(model, q0, theta_dot0)``).
        tau : array_like, shape (n_actuators,), or callable
            Constant actuator efforts (N·m or N), or a function ``tau(t, theta, theta_dot)`` returning them.
        t_final : float
            The horizon (s), positive.
        t_eval : array_like, shape (N,), optional
            Output times, increasing strictly within ``[0, t_final]``; the integrator's own steps if omitted.

        Returns
        -------
        PlantRun
            ``q`` and ``q_dot`` as integrated; ``closure_violation`` is the drift Baumgarte leaves.

        Raises
        ------
        InvalidParameterError
            A malformed or non-finite argument, ``q0`` off the loop closure, ``q_dot0`` not tangent to it,
            or ``tau`` returning the wrong shape.
        SingularityError
            The constrained system is singular (the loop-closure Jacobian loses rank), the integration fails,
            or the state blows up (names the time).
        """
        model = self.model
        n, na = len(model.coordinates), model.n_actuators
        q0 = _start(model, q0)
        q_dot0 = as_batch("q_dot0", q_dot0, n, single=True)[0][0].copy()
        effort = _effort_function(tau, na)
        t_final, t_eval = check_times(t_final, t_eval)
        kernels, P, omega = model.kernels, model.P, self.stabilization
        m = kernels.N_CONSTRAINTS
        j_eta, gamma, eta = np.empty((1, m, n)), np.empty((1, m)), np.empty(m)
        kernels.constraint_jacobians(q0[None, :], P, j_eta)
        drift = float(np.abs(j_eta[0] @ q_dot0).max())
        tolerance = CLOSURE_TOLERANCE * length_scale(model) * max(1.0, float(np.abs(q_dot0).max()))
        if not drift <= tolerance:
            raise InvalidParameterError(f"q_dot0 is not tangent to the loop closure: max |J_eta q_dot0| = "
                                        f"{drift:.3g} m/s exceeds {tolerance:.3g} m/s (take it from "
                                        "pkmlab.coordinate_rates(model, q0, theta_dot0))")
        Q = np.zeros(n)
        evaluations = 0

        def rhs(t, y):
            nonlocal evaluations
            evaluations += 1
            q, q_dot = np.ascontiguousarray(y[:n]), np.ascontiguousarray(y[n:])
            Q[:na] = effort(t, q[:na], q_dot[:na])
            M, h, g = mm.full_space_model(model, q, q_dot)
            kernels.constraint_jacobians(q[None, :], P, j_eta)
            kernels.constraint_biases(q[None, :], q_dot[None, :], P, gamma)
            kernels.constraints(q, mm.trig_table(model, q), P, eta)
            J = j_eta[0]
            # J q̈ = -(J̇ q̇ + 2ω J q̇ + ω² η): the constraint's acceleration with Baumgarte's correction
            bias = gamma[0] + 2.0 * omega * (J @ q_dot) + omega * omega * eta
            q_ddot, _multipliers, ok = lagrangian.constrained_accelerations(M, h + g, J, bias, Q)
            if not ok:
                raise SingularityError(f"the constrained dynamics became singular at t = {t:.6g} s (the "
                                       "loop-closure Jacobian lost rank)")
            _finite_or_raise(q_ddot, t, "accelerations")
            return np.concatenate([q_dot, q_ddot])

        sol = _integrate(rhs, t_final, np.concatenate([q0, q_dot0]), t_eval, self.rtol, self.atol)
        qs = np.ascontiguousarray(sol.y[:n].T)
        return PlantRun(sol.t, qs, np.ascontiguousarray(sol.y[n:].T), _closure_violation(model, qs), evaluations, na)
