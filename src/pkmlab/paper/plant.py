"""Plants: the simulated machine, advancing its state under actuator efforts.

Two independent formulations of the same physics (conventions §6):

* :class:`ReducedPlant` integrates the actuator-space model (eq. 35) in the state
  ``(θ, θ̇)``; after every evaluation the passive variables are recovered by
  branch-following forward kinematics (paper §3.2), so the configuration is always on the
  constraint manifold — the loop-closure residual stays at round-off level by construction.
  Its model and branch following are the compiled core's (:mod:`pkmlab.codegen.core`, on the
  machine's description), the simulation's own plant, here under an adaptive integrator.
* :class:`FullPlant` integrates the seven coordinates with Lagrange multipliers (eq. 26) as
  an index-1 differential-algebraic system, with Baumgarte stabilisation of the constraint
  drift. It shares no reduction step with the first and serves as its cross-check.

Both integrate with SciPy's DOP853 at tight tolerances (relative 1e-11 by default) so that
integration error stays far below any tracking error of interest; ``rtol``/``atol`` are
parameters. Efforts are given as a function ``tau(t, θ, θ̇) -> (3,)`` or as a constant.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import _compile_cache  # noqa: F401  (sets the kernel cache before any kernel is defined)
from .._compile_cache import njit
from .._validate import as_batch, as_real
from ..errors import BranchFollowingError, InvalidParameterError, SingularityError, shown
from ..model.mechanism_model import MechanismModel
from ..simulation.plants import check_times
from . import rrr3
from .geometry import Planar3RRR
from .kinematics import as_paper_model, constraint_residual, coordinates_from_3rrr, coordinates_to_3rrr


@dataclass(frozen=True)
class PlantRun:
    """Time series of a plant simulation (like SciPy's ``OdeResult``).

    ``q`` (N, 7) and ``q_dot`` (N, 7) are full configurations and rates at times ``t`` (N,);
    ``closure_violation`` (N,) is ``max |η(q)|`` in metres; ``n_evaluations`` counts right-hand
    side evaluations.
    """

    t: np.ndarray
    q: np.ndarray
    q_dot: np.ndarray
    closure_violation: np.ndarray
    n_evaluations: int

    @property
    def theta(self) -> np.ndarray:
        return self.q[:, :3]

    @property
    def theta_dot(self) -> np.ndarray:
        return self.q_dot[:, :3]


def _closure_violation(model, qs):
    """``max |η(q)|`` (m) of each configuration."""
    return np.abs(constraint_residual(model, qs)).max(axis=-1)


def _effort_function(tau) -> Callable[[float, np.ndarray, np.ndarray], np.ndarray]:
    if callable(tau):
        def checked(t, theta, theta_dot):  # the compiled dynamics would read past a short array
            effort = tau(t, theta, theta_dot)
            try:
                effort = np.asarray(effort, dtype=float)
            except (TypeError, ValueError, OverflowError):
                effort = None
            if effort is None or effort.shape != (3,):
                raise InvalidParameterError(f"tau(t, theta, theta_dot) must return 3 numbers, got {shown(effort)}")
            return effort

        return checked
    constant = as_batch("tau", tau, 3, single=True)[0][0].copy()
    return lambda t, theta, theta_dot: constant


def _initial(model, q0, rate_name, rate0, n_rate, tau, t_final, t_eval):
    """Validated ``(q0, rate0, tau function, t_final, t_eval)`` of a simulation request."""
    q0 = as_batch("q0", q0, 7, single=True)[0][0]
    residual = float(_closure_violation(model, q0))
    if residual > 1e-3 * float(np.max(model.active_lengths + model.passive_lengths)):
        raise InvalidParameterError(f"q0 is not a configuration of this machine: its loop-closure residual is "
                                    f"{residual:.3g} m (take it from inverse or forward kinematics)")
    rate0 = as_batch(rate_name, rate0, n_rate, single=True)[0][0]
    return (q0, rate0, _effort_function(tau), *check_times(t_final, t_eval))


@njit(cache=True)
def _full_rhs(y, tau, P, stabilization):
    out = np.empty(14)
    out[:7] = y[7:]
    q_ddot, _multipliers, ok = rrr3.full_dynamics(y[:7], y[7:], tau, P, stabilization)
    out[7:] = q_ddot
    return out, ok


class ReducedPlant:
    """The machine integrated in the actuator space: state ``(θ, θ̇)`` and eq. (35).

    Parameters
    ----------
    model : Planar3RRR
        The plant's own parameters (they may differ from a controller's model).
    rtol, atol : float
        DOP853 tolerances.
    singularity_guard : float
        Branch following stops the run with :class:`~pkmlab.errors.BranchFollowingError`
        when ``|S|`` falls below this (a gain-type singularity, where eq. 35 is invalid).
    """

    def __init__(self, model: Planar3RRR, rtol: float = 1e-11, atol: float = 1e-12, singularity_guard: float = 1e-6):
        self.model = as_paper_model(model)
        self.rtol, self.atol = as_real("rtol", rtol, "positive"), as_real("atol", atol, "non-negative")
        self.singularity_guard = as_real("singularity_guard", singularity_guard, "non-negative")

    def simulate(self, q0, theta_dot0, tau, t_final: float, t_eval=None) -> PlantRun:
        """Integrate from configuration ``q0`` (on the manifold) and actuated rates ``θ̇0``."""
        q0, theta_dot0, effort_of, t_final, t_eval = _initial(self.model, q0, "theta_dot0", theta_dot0, 3, tau,
                                                              t_final, t_eval)
        # the compiled core's reduced model and branch following, on the machine's description
        machine = MechanismModel.from_3rrr(self.model)
        kernels, P = machine.kernels, machine.P
        q_start = coordinates_from_3rrr(self.model, q0)
        q_last, q_work = q_start.copy(), np.empty_like(q_start)
        evaluations = 0

        def rhs(t, y):
            nonlocal evaluations
            evaluations += 1
            effort = np.asarray(effort_of(t, y[:3], y[3:]), dtype=float)
            ydot, status = kernels.actuator_space_rhs(q_last, y, effort, P, self.singularity_guard, kernels.NO_DRIVES,
                                                      q_work)
            if status != kernels.OK:
                why = (f"reached a gain-type singularity (|S| < singularity_guard = {self.singularity_guard:g})"
                       if status == kernels.SINGULAR else "could not follow its assembly mode")
                raise BranchFollowingError(f"the plant {why} at t = {t:.6g} s (theta = {np.round(y[:3], 6).tolist()})")
            q_last[:] = q_work
            return ydot

        y0 = np.concatenate([q0[:3], theta_dot0])
        from scipy.integrate import solve_ivp  # (0.3 s to import: only where it is used)
        sol = solve_ivp(rhs, (0.0, float(t_final)), y0, method="DOP853", rtol=self.rtol, atol=self.atol,
                        t_eval=t_eval)
        if sol.status != 0:
            raise SingularityError(f"integration failed: {sol.message} (rtol = {self.rtol:g}, atol = {self.atol:g})")
        # rebuild the passive variables at the output times, following the branch from q0
        path = np.empty((sol.t.size, q_start.size))
        status, k = kernels.follow_path(q_start, np.ascontiguousarray(sol.y[:3].T), P, self.singularity_guard, path)
        if status != kernels.OK:
            raise BranchFollowingError(f"lost the assembly mode at t = {sol.t[k]:.6g} s")
        qs = coordinates_to_3rrr(path)
        from .kinematics import coordinate_rates

        q_dot = coordinate_rates(self.model, qs, sol.y[3:].T)
        return PlantRun(sol.t, qs, q_dot, _closure_violation(self.model, qs), evaluations)


class FullPlant:
    """The machine integrated in all seven coordinates with multipliers (eq. 26, index-1 form).

    ``stabilization`` is the Baumgarte rate ω (1/s) of ``η̈ + 2ω η̇ + ω² η = 0``.
    """

    def __init__(self, model: Planar3RRR, rtol: float = 1e-11, atol: float = 1e-12, stabilization: float = 20.0):
        self.model = as_paper_model(model)
        self.rtol, self.atol = as_real("rtol", rtol, "positive"), as_real("atol", atol, "non-negative")
        self.stabilization = as_real("stabilization", stabilization, "non-negative")

    def simulate(self, q0, q_dot0, tau, t_final: float, t_eval=None) -> PlantRun:
        """Integrate from ``q0`` and ``q̇0`` (both consistent with the constraints)."""
        q0, q_dot0, effort_of, t_final, t_eval = _initial(self.model, q0, "q_dot0", q_dot0, 7, tau, t_final,
                                                          t_eval)
        P = self.model.packed
        evaluations = 0

        def rhs(t, y):
            nonlocal evaluations
            evaluations += 1
            effort = np.asarray(effort_of(t, y[:3], y[7:10]), dtype=float)
            ydot, ok = _full_rhs(y, effort, P, self.stabilization)
            if not ok:
                raise SingularityError(f"the constrained dynamics became singular at t = {t:.6g} s")
            return ydot

        from scipy.integrate import solve_ivp  # (0.3 s to import: only where it is used)
        sol = solve_ivp(rhs, (0.0, float(t_final)), np.concatenate([q0, q_dot0]), method="DOP853",
                        rtol=self.rtol, atol=self.atol, t_eval=t_eval)
        if sol.status != 0:
            raise SingularityError(f"integration failed: {sol.message} (rtol = {self.rtol:g}, atol = {self.atol:g})")
        qs = np.ascontiguousarray(sol.y[:7].T)
        return PlantRun(sol.t, qs, np.ascontiguousarray(sol.y[7:].T), _closure_violation(self.model, qs), evaluations)
