"""Time-optimal timing of a path under actuator limits: the poses of a trajectory, followed as fast as the
actuators' velocity, acceleration and effort limits allow, at rest at both ends.

**The path.** Any trajectory of pkmlab gives the path — what is kept is the geometry, not the timing — as
poses ``x(u)`` of a parameter ``u`` that keeps ``x'`` from vanishing where it can
(:func:`~pkmlab.control.trajectory.path_geometry`: a circle's or a line's arc length, a waypoint segment's
fraction; a spline's own time). Where the path has a corner (waypoints) it must stop: each piece between
corners is timed on its own, from rest to rest.
The actuators follow ``θ(u)`` (the inverse kinematics in one working mode), ``θ' = dθ/du`` and ``θ''`` from
differentiating the loop closures (:func:`~pkmlab.model.mechanism_model.path_rates` at ``x'``, ``x''``).
A new timing ``u(t)`` gives ``θ̇ = θ' u̇`` and ``θ̈ = θ' ü + θ'' u̇²``.

**The limits**, per actuator ``j`` (each optional): ``|θ̇_j| ≤ v_j``, ``|θ̈_j| ≤ a_j`` and ``|τ_j| ≤ τ_j``
with the controller's model's inverse dynamics ``τ = M θ̈ + c(q, θ̇) + g``, ``c`` quadratic in the rates:
``τ = (M θ') ü + (M θ'' + c(q, θ')) u̇² + g`` — linear in ``(ü, u̇²)``, the form of the time-optimal path
parameterization problem (Bobrow, Dubowsky and Gibson 1985; Shin and McKay 1985).

**The method**: TOPP-RA (H. Pham and Q.-C. Pham, "A new approach to time-optimal path parameterization
based on reachability analysis", IEEE Trans. Robotics 34(3), 2018) by ``toppra``, its authors' maintained,
MIT-licensed implementation — a sequence of small linear programs on a grid of ``u``, robust where the
classical numerical integration of the switching curves fails at singular arcs (this module's reason to
choose it: no hand-written switching-point search). The constraints are met at the grid's points
(collocation); between them ``ü`` is constant, so ``u̇²`` is linear in ``u`` — the timing is exact, its
desired motion's derivatives exact, and the limits hold at the grid's points (between them to the grid's
discretisation, which a finer ``grid`` reduces).
"""

from __future__ import annotations

import functools
import logging
from dataclasses import dataclass

import numpy as np

from .._validate import as_count, as_limits, as_real
from ..errors import InvalidParameterError, PkmlabError, SingularityError, shown

#: The default number of grid intervals along the path, and the most.
GRID, MAX_GRID = 400, 100_000


@dataclass(frozen=True, eq=False)  # arrays: equal only to itself (hashable, so batches share its desired motion)
class TimeOptimal:
    """A trajectory's poses on a time-optimal timing (:func:`time_optimal`).

    A trajectory itself (``desired``, ``duration``), for a :class:`~pkmlab.Scenario`; at rest at both ends.

    Attributes
    ----------
    original : trajectory
        The trajectory whose path is retimed.
    geometry : PathGeometry
        The ``original`` trajectory's :class:`~pkmlab.control.trajectory.PathGeometry`: the path as a function of
        its parameter ``u``.
    u : ndarray, shape (N + 1,)
        The grid of the path's parameter.
    u_dot : ndarray, shape (N + 1,)
        The path speed at each grid point (per s).
    u_ddot : ndarray, shape (N,)
        The constant path acceleration on each interval (per s²).
    t_grid : ndarray, shape (N + 1,)
        The times (s) the grid points are reached.
    limits : dict
        The actuators' limits that were given (``{"velocity": (n,), ...}``).
    binding : tuple of (str, int), length N + 1
        At each grid point, the limit nearest to bounding the timing found, as ``(kind, actuator)``.

    Examples
    --------
    >>> import pkmlab
    >>> from pkmlab.control.trajectory import paper_trajectory
    >>> fast = pkmlab.time_optimal(paper_trajectory(0.2), pkmlab.load("paper"), (-1, 1, -1), velocity=2.0)
    >>> pose, pose_dot, pose_ddot = fast.desired([0.0, fast.duration])
    >>> pose.shape, float(abs(pose_dot).max())
    ((2, 3), 0.0)
    """

    original: object
    geometry: object
    u: np.ndarray
    u_dot: np.ndarray
    u_ddot: np.ndarray
    t_grid: np.ndarray
    limits: dict
    binding: tuple

    @property
    def duration(self) -> float:
        """The time (s) the timing takes: the last of ``t_grid``."""
        return float(self.t_grid[-1])

    @property
    def dimension(self) -> int:
        """The number of the path's pose coordinates (the original trajectory's; 3 for a planar ``(x, y, alpha)``)."""
        return int(getattr(self.original, "dimension", 3))

    @property
    def spatial(self) -> bool:
        """Whether the path's poses are in the machine's own coordinates (as a spatial machine's are)."""
        from .trajectory import Spline, TimedWaypoints

        return isinstance(self.original, TimedWaypoints | Spline) or bool(getattr(self.original, "spatial", False))

    def timing(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The path's parameter and its rates ``(u, u̇, ü)`` at times ``t``.

        ``u`` is a quadratic of time on each interval, at rest outside ``[0, duration)`` (at ``t = 0``, ``u̇ = 0``
        and ``ü`` the first interval's).

        Parameters
        ----------
        t : array_like, shape (...)
            Times (s).

        Returns
        -------
        u, u_dot, u_ddot : ndarray, shape (...)
        """
        t = np.asarray(t, dtype=float)
        flat = np.clip(t.reshape(-1), 0.0, self.duration)
        k = np.clip(np.searchsorted(self.t_grid, flat, side="right") - 1, 0, len(self.u_ddot) - 1)
        tau = flat - self.t_grid[k]
        u_ddot = self.u_ddot[k]
        u = np.minimum(self.u[k] + self.u_dot[k] * tau + 0.5 * u_ddot * tau**2, self.u[-1])
        u_dot = np.maximum(self.u_dot[k] + u_ddot * tau, 0.0)
        outside = (t.reshape(-1) < 0.0) | (t.reshape(-1) >= self.duration)  # at 0 it starts to move
        u_dot, u_ddot = np.where(outside, 0.0, u_dot), np.where(outside, 0.0, u_ddot)
        return u.reshape(t.shape), u_dot.reshape(t.shape), u_ddot.reshape(t.shape)

    def desired(self, t):
        """The desired poses and their derivatives ``(pose, pose_dot, pose_ddot)`` at times ``t``.

        The path's ``x(u(t))``, ``x' u̇`` and ``x'' u̇² + x' ü``.

        Parameters
        ----------
        t : array_like, shape (...)
            Times (s).

        Returns
        -------
        pose, pose_dot, pose_ddot : ndarray, shape (..., d)
            The poses (m, rad), their rates (m/s, rad/s) and accelerations (m/s², rad/s²); ``d`` is
            :attr:`dimension`.
        """
        u, u_dot, u_ddot = self.timing(t)
        x, x1, x2 = (np.asarray(a, dtype=float) for a in self.geometry.at(u))
        return x, x1 * u_dot[..., None], x2 * (u_dot**2)[..., None] + x1 * u_ddot[..., None]




def _where(x: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.4g}" for v in x) + ")"


def path_coefficients(model, at, mode, u: np.ndarray, piece: int | None = None):
    """Along the path ``at`` (:class:`~pkmlab.control.trajectory.PathGeometry`) at ``u`` (N + 1,): configurations
    ``q``, ``θ'``, ``θ''`` (N + 1, n) and the inverse dynamics' coefficients ``(M θ', M θ'' + c(q, θ'), g)`` (each
    (N + 1, n)) of the module docstring."""
    from ..model.mechanism_model import path_inverse_kinematics, path_rates

    x, x1, x2 = (np.ascontiguousarray(np.asarray(a, dtype=float)) for a in at(u, piece))
    dof = model.description.dof
    q, _s, failure = path_inverse_kinematics(model, x[:, :dof], mode, follow=True)
    if failure is not None:
        k, error = failure
        raise type(error)(f"the path at the pose {_where(x[k, :dof])}: {error}")
    d1, d2, k = path_rates(model, q, np.ascontiguousarray(x1[:, :dof]), np.ascontiguousarray(x2[:, :dof]))
    if k >= 0:
        raise SingularityError(f"the path meets an inverse-kinematic singularity (a leg at the edge of its reach) at "
                               f"the pose {_where(x[k, :dof])}")
    n = model.n_actuators
    kern = model.kernels
    M, c, g = np.empty((len(u), n, n)), np.empty((len(u), n)), np.empty((len(u), n))
    kern.actuator_space_models(np.ascontiguousarray(q), np.ascontiguousarray(d1), model.P, M, c, g)
    a = np.einsum("kij,kj->ki", M, d1)
    b = np.einsum("kij,kj->ki", M, d2) + c
    return q, d1, d2, (a, b, g), x[:, :dof]


def time_optimal(trajectory, model, mode, *, velocity=None, acceleration=None, effort=None,
                 grid: int = GRID) -> TimeOptimal:
    """The poses of ``trajectory`` on the shortest timing that keeps every actuator within its limits.

    Parameters
    ----------
    trajectory : trajectory
        Any trajectory (``desired(t)``, ``duration``): its poses give the path (module docstring).
    model : MechanismModel
        The machine (its controller's model): inverse kinematics and inverse dynamics.
    mode : tuple of int
        The working mode the path is followed in (one sign per two-branch leg; not ``"auto"``).
    velocity, acceleration, effort : array_like (n,) or float, optional
        The actuators' limits: rad/s or m/s, rad/s² or m/s², N·m or N (a number for every actuator alike). At
        least one.
    grid : int
        Intervals of the grid along the path, shared among its pieces in proportion to their parameter's length, at
        least 10 each (the constraints hold at its points).

    Returns
    -------
    TimeOptimal
        A trajectory (``desired``, ``duration``), at rest at both ends.

    Raises
    ------
    InvalidParameterError
        Limits that are not positive numbers, one per actuator, or none given; a grid below 10; a
        ``trajectory`` without ``desired`` and a positive ``duration``; a ``mode`` the machine does not have,
        or ``"auto"``.
    PkmlabError
        A pose the effort limits cannot hold against gravity (naming the actuator and the pose), or no timing
        that meets the limits.

    Examples
    --------
    The paper's circle, its motors within 2 rad/s and 0.5 N m (its own timing takes 1.571 s):

    >>> import pkmlab
    >>> from pkmlab.control.trajectory import paper_trajectory
    >>> fast = pkmlab.time_optimal(paper_trajectory(0.2), pkmlab.load("paper"), (-1, 1, -1), velocity=2.0,
    ...                            effort=0.5)
    >>> round(fast.duration, 3), sorted({kind for kind, _actuator in fast.binding})
    (1.078, ['effort', 'velocity'])
    """
    from ..algorithms.kinematics import as_model, as_working_mode, refuse_actuation_redundancy

    model = as_model(model)
    refuse_actuation_redundancy(model, "time-optimal timing (the actuators' velocities and efforts)")
    if not callable(getattr(trajectory, "desired", None)):
        raise InvalidParameterError(f"trajectory must be a trajectory (an object with desired(t) and duration), got "
                                    f"{type(trajectory).__name__} {shown(trajectory, 50)}")
    as_real("trajectory duration", getattr(trajectory, "duration", None), "positive")
    mode = as_working_mode(model, mode, "mode")
    if mode == "auto":
        raise InvalidParameterError("mode must be one of the machine's working modes, not \"auto\" (a scenario's "
                                    "timing chooses it as its run does)")
    n = model.n_actuators
    v_lim, a_lim, e_lim = (as_limits(name, value, n) for name, value in
                           (("velocity", velocity), ("acceleration", acceleration), ("effort", effort)))
    if v_lim is None and a_lim is None and e_lim is None:
        raise InvalidParameterError("time-optimal timing needs limits: give velocity, acceleration or effort")
    grid = as_count("grid", grid, 10, MAX_GRID)
    from .trajectory import path_geometry

    geometry = path_geometry(trajectory)
    total = sum(b - a for a, b in geometry.pieces)
    given = {k: v for k, v in (("velocity", v_lim), ("acceleration", a_lim), ("effort", e_lim)) if v is not None}
    grids, speeds, bindings = [], [], []
    for piece, (start, end) in enumerate(geometry.pieces):
        u = np.linspace(start, end, max(10, round(grid * (end - start) / total)) + 1)
        u_dot, binding = _piece(model, geometry.at, piece, mode, u, v_lim, a_lim, e_lim, given)
        grids.append(u if not grids else u[1:])
        speeds.append(u_dot if not speeds else u_dot[1:])
        bindings += binding if not bindings else binding[1:]
    u, u_dot = np.concatenate(grids), np.concatenate(speeds)
    x = u_dot**2
    u_ddot = np.diff(x) / (2.0 * np.diff(u))
    dt = 2.0 * np.diff(u) / np.maximum(u_dot[:-1] + u_dot[1:], 1e-300)
    t_grid = np.concatenate([[0.0], np.cumsum(dt)])
    return TimeOptimal(trajectory, geometry, u, u_dot, u_ddot, t_grid, given, tuple(bindings))


def _piece(model, at, piece: int, mode, u, v_lim, a_lim, e_lim, given) -> tuple[np.ndarray, list]:
    """The time-optimal path speed ``u̇`` (N + 1,) along piece ``piece`` of the path, from rest to rest (its end
    corner evaluated on this piece, not the next), and the limit nearest to bounding it at each point."""
    import toppra

    n = model.n_actuators
    q, d1, d2, (a, b, c), x = path_coefficients(model, at, mode, u, piece)
    if e_lim is not None:
        over = np.abs(c) > e_lim
        if over.any():
            k, j = np.unravel_index(int(np.argmax(over)), over.shape)
            raise PkmlabError(f"actuator {j + 1} needs {abs(c[k, j]):.4g} to hold the pose {_where(x[k])} against "
                              f"gravity, above its effort limit {e_lim[j]:.4g}")
    constraints = [_Coefficients(d1, d2, None, v_lim, "velocity")] if v_lim is not None else []
    if a_lim is not None:
        constraints.append(_Coefficients(d1, d2, None, a_lim, "acceleration"))
    if e_lim is not None:
        constraints.append(_Coefficients(a, b, c, e_lim, "effort"))
    path = _GridPath(u, q[:, :n], d1, d2)
    logger = logging.getLogger("toppra")  # its retries are logged as warnings: pkmlab says what failed, once
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        instance = toppra.algorithm.TOPPRA(constraints, path, gridpoints=u)
        _sdd, sd, _v, _k = instance.compute_parameterization(0.0, 0.0, return_data=True)
    finally:
        logger.setLevel(level)
    if sd is None or not np.all(np.isfinite(sd)):
        limits = "; ".join(f"{k} = {', '.join(f'{v:.4g}' for v in value)}" for k, value in given.items())
        raise PkmlabError(f"no timing of the path meets the limits ({limits}): the time-optimal parameterization "
                          "found none on its grid (limits this small or a grid this coarse are beyond its numerics)")
    u_dot = np.maximum(np.asarray(sd, dtype=float), 0.0)
    u_ddot = np.diff(u_dot**2) / (2.0 * np.diff(u))
    return u_dot, list(_binding(u_dot, u_ddot, d1, d2, (a, b, c), v_lim, a_lim, e_lim))


def _binding(u_dot, u_ddot, d1, d2, coefficients, v_lim, a_lim, e_lim) -> tuple:
    """At each grid point, the limit (kind, actuator) closest to active on the timing found."""
    x = u_dot**2
    acc = np.concatenate([u_ddot, u_ddot[-1:]])
    ratios = []
    if v_lim is not None:
        ratios.append(("velocity", np.abs(d1) * u_dot[:, None] / v_lim))
    if a_lim is not None:
        ratios.append(("acceleration", np.abs(d1 * acc[:, None] + d2 * x[:, None]) / a_lim))
    if e_lim is not None:
        a, b, c = coefficients
        ratios.append(("effort", np.abs(a * acc[:, None] + b * x[:, None] + c) / e_lim))
    out = []
    for k in range(len(u_dot)):
        kind, r = max(((name, r[k]) for name, r in ratios), key=lambda item: float(item[1].max()))
        out.append((kind, int(np.argmax(r)) + 1))
    return tuple(out)


class _GridPath:
    """The actuators' path for ``toppra``, known at the grid's points (the only ones it evaluates)."""

    def __init__(self, u, theta, d1, d2):
        self._u, self._values = u, (theta, d1, d2)

    def __call__(self, positions, order: int = 0):
        positions = np.atleast_1d(np.asarray(positions, dtype=float))
        index = np.searchsorted(self._u, positions)
        index = np.clip(index, 0, len(self._u) - 1)
        if not np.allclose(self._u[index], positions, rtol=0, atol=1e-12 * max(1.0, self._u[-1])):
            raise PkmlabError("time-optimal timing evaluated its path off its grid")  # never: toppra is given the grid
        return self._values[order][index]

    @property
    def dof(self) -> int:
        return self._values[0].shape[1]

    @property
    def path_interval(self):
        return np.array([self._u[0], self._u[-1]])

    @property
    def waypoints(self):
        return None

    def eval(self, positions):
        return self(positions, 0)

    def evald(self, positions):
        return self(positions, 1)

    def evaldd(self, positions):
        return self(positions, 2)


@functools.cache  # one class, built on first use (toppra imported lazily)
def _coefficients_constraint():
    import toppra.constraint as constraint

    class Coefficients(constraint.LinearConstraint):
        """``|a ü + b u̇² + c| ≤ limit`` at every grid point, the canonical linear form of ``toppra``."""

        def __init__(self, a, b, c, limit, name):
            super().__init__()
            self.a, self.b = a, b
            self.c = np.zeros_like(a) if c is None else c
            self.limit, self.name = limit, name
            # the limits at both ends of every interval, where the interval's constant ü acts (collocation would
            # check an interval's ü at its start only, and the first interval's, where θ' = 0, not at all)
            self.discretization_type = constraint.DiscretizationType.Interpolation
            self.dof = a.shape[1]
            self.identical = True
            m = self.dof
            self.F = np.vstack([np.eye(m), -np.eye(m)])
            self.g = np.concatenate([limit, limit])

        def compute_constraint_params(self, path, gridpoints, *args, **kwargs):
            if self.name == "velocity":  # |θ' u̇| ≤ v: a bound on x = u̇² alone
                with np.errstate(divide="ignore", over="ignore"):
                    speed = np.min(self.limit / np.abs(self.a), axis=1)
                top = np.minimum(speed, np.sqrt(_X_CAP)) ** 2
                xbound = np.column_stack([np.zeros(len(top)), top])
                return None, None, None, None, None, None, xbound
            return constraint.canlinear_colloc_to_interpolate(self.a, self.b, self.c, self.F, self.g, None, None,
                                                              gridpoints, identical=True)

    return Coefficients


#: The largest ``u̇²`` a grid point is given where no limit bounds it (a path at rest in its own timing).
_X_CAP = 1e12


def _Coefficients(a, b, c, limit, name):  # noqa: N802 -- toppra's constraint class, made once
    return _coefficients_constraint()(a, b, c, limit, name)
