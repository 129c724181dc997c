"""Kinematics of the planar 3-RRR: inverse, forward (every assembly mode), branch following,
velocity and acceleration kinematics, and the singularity measure (paper §2, §3.2).

Every function takes the model first and arrays shaped ``(..., n)``: one configuration or a
batch of any shape, with the same code path. The arithmetic happens in compiled kernels
(:mod:`pkmlab.paper.rrr3`, :mod:`pkmlab.numerics.closed_chain`); this module validates inputs,
broadcasts, and turns failures into one-line errors.

Examples
--------
>>> import numpy as np
>>> from pkmlab.paper.geometry import Planar3RRR
>>> from pkmlab.paper.kinematics import inverse_kinematics, forward_kinematics
>>> model = Planar3RRR.paper()
>>> ik = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1))
>>> np.round(ik.theta, 4).tolist()
[1.6146, 1.9831, -1.1846]
>>> fk = forward_kinematics(model, ik.theta)
>>> int(fk.count), np.allclose(fk.nearest([0.2, 0.21, 0.0]).pose, [0.2, 0.21, 0.0], atol=1e-12)
(2, True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._compile_cache import njit
from .._validate import as_batch, as_broadcast, as_choice, as_mode, as_pair, as_real, index_text
from ..algorithms.kinematics import CLOSURE_TOLERANCE, refuse_off_closure
from ..errors import BranchFollowingError, InvalidParameterError, SingularityError, UnreachablePoseError, shown
from ..numerics import closed_chain
from ..numerics.angles import wrapped_angle
from . import rrr3
from .geometry import WORKING_MODES, Planar3RRR

__all__ = [
    "InverseKinematicsSolution",
    "ForwardKinematicsSolution",
    "AssemblyMode",
    "inverse_kinematics",
    "forward_kinematics",
    "branch_following",
    "platform_pose",
    "constraint_residual",
    "constraint_jacobian",
    "passive_jacobian",
    "actuated_jacobian",
    "velocity_jacobian",
    "platform_jacobian",
    "passive_rates",
    "coordinate_rates",
    "acceleration_bias",
    "coordinate_accelerations",
    "forward_singularity_determinant",
    "singularity_measure",
    "working_mode_of",
]


def as_paper_model(model, name: str = "model") -> Planar3RRR:
    """``model`` itself if it is a :class:`Planar3RRR`: anything else would fail deep inside, unnamed."""
    if not isinstance(model, Planar3RRR):
        raise InvalidParameterError(f"{name} must be a Planar3RRR (e.g. Planar3RRR.paper()), "
                                    f"got {type(model).__name__} {shown(model, 50)}")
    return model


# ------------------------------------------------------------------ compiled batch drivers
@njit(cache=True)
def _inverse_kinematics_batch(poses, modes, P, q_out, unreachable):
    for k in range(poses.shape[0]):
        for m in range(modes.shape[0]):
            unreachable[k, m] = rrr3.inverse_kinematics(poses[k], modes[m], P, q_out[k, m])


@njit(cache=True)
def _forward_kinematics_batch(thetas, P, q_out, s_out, count, status):
    ws = rrr3.make_workspace(P)
    for k in range(thetas.shape[0]):
        count[k], status[k] = rrr3.forward_kinematics(thetas[k], P, q_out[k], s_out[k], ws)


@njit(cache=True)
def _first_order_batch(qs, P, residual, j_eta_q, j_pose_q, j_q_theta, det, ok):
    ws = rrr3.make_workspace(P)
    for k in range(qs.shape[0]):
        ws.q[0, :] = qs[k]
        ok[k] = rrr3.linearize(ws, 0, P)
        rrr3.constraints_from_sincos(ws.sincos[0], P, residual[k])
        j_eta_q[k] = ws.jac[0]
        rrr3.pose_jacobian(qs[k], P, j_pose_q[k])
        det[k] = ws.det[0]
        j_q_theta[k] = ws.j_q_theta[0]


@njit(cache=True)
def _determinant_batch(qs, P, det):
    sc, jac, lu, piv = np.empty((7, 2)), np.empty((4, 7)), np.empty((4, 4)), np.empty(4, np.int64)
    for k in range(qs.shape[0]):
        rrr3.angle_sincos(qs[k], sc)
        rrr3.constraint_jacobian_from_sincos(sc, P, jac)
        _ok, det[k] = closed_chain.lu_factor(jac[:, 3:], lu, piv, 4)


@njit(cache=True)
def _second_order_batch(qs, theta_dots, P, q_dot, bias, pose_bias, ok):
    ws = rrr3.make_workspace(P)
    for k in range(qs.shape[0]):
        ws.q[0, :] = qs[k]
        ok[k] = rrr3.linearize(ws, 0, P)
        rrr3.evaluate_velocities(ws, 0, theta_dots[k], P)
        q_dot[k] = ws.q_dot
        bias[k] = ws.bias_q
        rrr3.pose_convective(qs[k], q_dot[k], P, pose_bias[k])


@njit(cache=True)
def _pose_batch(qs, P, out):
    for k in range(qs.shape[0]):
        rrr3.platform_pose(qs[k], P, out[k])


# ------------------------------------------------------------------ inverse kinematics
@dataclass(frozen=True)
class InverseKinematicsSolution:
    """Result of :func:`inverse_kinematics`.

    ``q`` has shape ``(..., 7)`` for one working mode, ``(..., 8, 7)`` for all of them (in
    the order of ``modes``); entries for poses out of reach are NaN when
    ``on_unreachable="nan"``. ``unreachable_legs`` is a bit mask per solution (bit ``i`` set
    when leg ``i + 1`` cannot reach); ``S`` is the singularity measure of each solution.
    """

    q: np.ndarray
    modes: np.ndarray
    unreachable_legs: np.ndarray
    S: np.ndarray

    @property
    def theta(self) -> np.ndarray:
        """Actuated angles ``(θ1, θ2, θ3)``."""
        return self.q[..., :3]

    @property
    def phi(self) -> np.ndarray:
        """Passive angles ``(φ1, φ2, φ3)`` of the legs (``α`` is ``q[..., 6]``)."""
        return self.q[..., 3:6]

    @property
    def reachable(self) -> np.ndarray:
        return self.unreachable_legs == 0


def inverse_kinematics(model: Planar3RRR, pose, mode=None, *, on_unreachable: str = "raise"):
    """Actuated and passive angles that put the platform at ``pose = (x, y, α)`` (conventions §3).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    pose : array_like, shape (..., 3)
        Platform centroid ``(x, y)`` in metres and orientation ``α`` in radians.
    mode : sequence of 3 signs, optional
        Working mode ``(σ1, σ2, σ3)``; ``σ_i = +1`` when elbow ``e_i`` lies to the left of
        the directed line ``b_i → p_i``. All 8 modes (:data:`pkmlab.paper.geometry.WORKING_MODES`)
        when omitted.
    on_unreachable : {"raise", "nan"}
        Raise :class:`~pkmlab.errors.UnreachablePoseError` naming the leg(s) that cannot reach,
        or fill those solutions with NaN (for maps over a region).

    Returns
    -------
    InverseKinematicsSolution
        ``q`` of shape (..., 7) = ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad) for one working mode, (..., 8, 7) for all
        of them (in the order of ``modes``), each on the loop closure; ``unreachable_legs`` and the singularity
        measure ``S`` (dimensionless, eq. 19) of each solution.

    Raises
    ------
    UnreachablePoseError
        With ``on_unreachable="raise"``, for the first pose that a leg cannot reach in a requested working mode
        (its ``legs`` and ``index`` attributes say which).
    InvalidParameterError
        If ``pose`` does not have 3 components, ``mode`` is not three signs or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> ik = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1))
    >>> ik.q.shape, np.round(ik.theta, 4).tolist(), round(float(ik.S), 4)
    ((7,), [1.6146, 1.9831, -1.1846], -0.7446)
    >>> inverse_kinematics(model, [0.20, 0.21, 0.0]).q.shape  # all eight working modes
    (8, 7)
    >>> far = inverse_kinematics(model, [5.0, 0.0, 0.0], mode=(1, 1, 1), on_unreachable="nan")
    >>> bool(np.isnan(far.q).all()), int(far.unreachable_legs)  # bit i set: leg i + 1 cannot reach
    (True, 7)
    """
    as_choice("on_unreachable", on_unreachable, ("raise", "nan"))
    poses, shape = as_batch("pose", pose, 3)
    modes = WORKING_MODES if mode is None else as_mode(mode)[None, :]
    q = np.empty((poses.shape[0], modes.shape[0], 7))
    unreachable = np.zeros((poses.shape[0], modes.shape[0]), dtype=np.int64)
    _inverse_kinematics_batch(poses, modes, as_paper_model(model).packed, q, unreachable)
    bad = np.flatnonzero(unreachable.any(axis=1))
    if bad.size and on_unreachable == "raise":
        k = int(bad[0])
        raise _unreachable_error(model, poses[k], int(unreachable[k].max()), k, shape)
    q[unreachable != 0] = np.nan
    s = -determinant_formula(model, np.where(np.isnan(q), 0.0, q)) / rrr3.singularity_scale(model.packed)
    s[unreachable != 0] = np.nan
    if mode is not None:
        q, unreachable, s, modes = q[:, 0], unreachable[:, 0], s[:, 0], modes[0]
        return InverseKinematicsSolution(
            q.reshape(*shape, 7), modes, unreachable.reshape(shape), s.reshape(shape)
        )
    return InverseKinematicsSolution(
        q.reshape(*shape, 8, 7), modes, unreachable.reshape(*shape, 8), s.reshape(*shape, 8)
    )


def _unreachable_error(model, pose, mask, flat, shape) -> UnreachablePoseError:
    from .._format import apart

    legs = tuple(i + 1 for i in range(3) if mask & (1 << i))
    x, y, alpha = pose
    c, s = np.cos(alpha), np.sin(alpha)
    rot = np.array([[c, -s], [s, c]])
    p1 = np.array([x, y]) - rot @ model.reference_point
    details = []
    for leg in legs:
        i = leg - 1
        p = p1 + rot @ model.platform_vertices[i]
        rho = float(np.hypot(*(p - model.base_points[i])))
        lo = abs(model.active_lengths[i] - model.passive_lengths[i])
        hi = model.active_lengths[i] + model.passive_lengths[i]
        # enough digits that a distance just beyond the reach never shows as equal to it
        rho_text, hi_text = apart(rho, hi, 4, 4)
        if rho <= hi:
            rho_text, lo_text = apart(rho, lo, 4, 4)
        else:
            lo_text = f"{lo:.4g}"
        details.append(f"leg {leg}: |p{leg} - b{leg}| = {rho_text} m, reach {lo_text}..{hi_text} m")
    which = f"leg {legs[0]}" if len(legs) == 1 else "legs " + ", ".join(map(str, legs[:-1])) + f" and {legs[-1]}"
    return UnreachablePoseError(
        f"pose (x={x:.6g}, y={y:.6g}, alpha={alpha:.6g}){index_text(flat, shape)} is out of reach of "
        f"{which} ({'; '.join(details)})",
        legs=legs,
        index=None if shape == () else tuple(int(i) for i in np.unravel_index(flat, shape)),
    )


def working_mode_of(model: Planar3RRR, q) -> np.ndarray:
    """Working mode ``σ`` (..., 3) of configurations ``q``: the sign of ``(p_i - b_i) × (e_i - b_i)``.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad); the elbows ``e_i`` and attachment points ``p_i``
        are those of the legs' own angles.

    Returns
    -------
    ndarray of int, shape (..., 3)
        ``σ_i = +1`` when elbow ``e_i`` lies to the left of the directed line ``b_i → p_i``, else -1.

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics, working_mode_of
    >>> model = Planar3RRR.paper()
    >>> ik = inverse_kinematics(model, [0.20, 0.21, 0.0])  # all eight working modes
    >>> bool(np.array_equal(working_mode_of(model, ik.q), ik.modes))
    True
    """
    qs, shape = as_batch("q", q, 7)
    b = as_paper_model(model).base_points
    e = b + model.active_lengths[:, None] * np.stack([np.cos(qs[:, :3]), np.sin(qs[:, :3])], axis=-1)
    p = e + model.passive_lengths[:, None] * np.stack([np.cos(qs[:, 3:6]), np.sin(qs[:, 3:6])], axis=-1)
    u, v = p - b, e - b
    cross = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return np.where(cross > 0, 1, -1).reshape(*shape, 3)


# ------------------------------------------------------------------ forward kinematics
@dataclass(frozen=True)
class AssemblyMode:
    """One solution of forward kinematics: configuration, platform pose and ``S``."""

    q: np.ndarray
    pose: np.ndarray
    S: float

    @property
    def phi(self) -> np.ndarray:
        return self.q[3:6]

    @property
    def alpha(self) -> float:
        return float(self.q[6])


@dataclass(frozen=True)
class ForwardKinematicsSolution:
    """Every assembly mode for each ``θ`` of a batch (paper §2.2.2).

    ``q`` (..., 6, 7), ``pose`` (..., 6, 3) and ``S`` (..., 6) hold up to six solutions per
    ``θ``, sorted by ``α``; the first ``count`` (...) are valid, the rest NaN. For a single
    ``θ`` the object is a sequence of :class:`AssemblyMode`.
    """

    q: np.ndarray
    pose: np.ndarray
    S: np.ndarray
    count: np.ndarray

    def __len__(self) -> int:
        if self.count.ndim:
            raise TypeError("len() of a batched ForwardKinematicsSolution: use .count")
        return int(self.count)

    def __getitem__(self, j: int) -> AssemblyMode:
        n = len(self)
        if not -n <= j < n:
            raise IndexError(f"assembly mode {j} of {n}")
        j %= n
        return AssemblyMode(self.q[j].copy(), self.pose[j].copy(), float(self.S[j]))

    def nearest(self, pose) -> AssemblyMode:
        """The assembly mode whose platform pose is nearest to ``pose`` (metres and radians)."""
        n = len(self)
        if n == 0:
            raise IndexError("no assembly mode")
        target = as_batch("pose", pose, 3, single=True)[0][0]
        d = self.pose[:n] - target
        d[:, 2] = wrapped_angle(d[:, 2])
        return self[int(np.argmin(np.linalg.norm(d, axis=1)))]


def forward_kinematics(model: Planar3RRR, theta) -> ForwardKinematicsSolution:
    """Every assembly mode for actuated angles ``θ`` (..., 3), from the degree-6 polynomial.

    Each real root of the sextic (eq. 12) is turned into a configuration and polished with
    Newton's method on ``η = 0``, so each returned ``q`` satisfies the loop closure to
    round-off. ``count`` is 0 where the mechanism cannot be assembled.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    theta : array_like, shape (..., 3)
        Actuated angles ``(θ1, θ2, θ3)`` (rad).

    Returns
    -------
    ForwardKinematicsSolution
        Up to six assembly modes per ``θ``, sorted by ``α``: ``q`` (..., 6, 7) (rad), ``pose`` (..., 6, 3)
        (``x``, ``y`` in m, ``α`` in rad) and ``S`` (..., 6) (dimensionless, eq. 19), of which the first
        ``count`` (...) are valid and the rest NaN. For a single ``θ`` it is a sequence of :class:`AssemblyMode`.

    Raises
    ------
    SingularityError
        If the polynomial vanishes identically at a ``θ`` (an architecture singularity: a continuum of assembly
        modes).
    InvalidParameterError
        If ``theta`` does not have 3 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import constraint_residual, forward_kinematics, inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> theta = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).theta
    >>> fk = forward_kinematics(model, theta)
    >>> int(fk.count), fk.q.shape, np.round(fk.pose[:2], 4).tolist()
    (2, (6, 7), [[0.2203, 0.2955, -0.5753], [0.2, 0.21, 0.0]])
    >>> bool(np.abs(constraint_residual(model, fk.q[:2])).max() < 1e-12)  # on the loop closure
    True
    """
    thetas, shape = as_batch("theta", theta, 3)
    n = thetas.shape[0]
    q = np.full((n, 6, 7), np.nan)
    s = np.full((n, 6), np.nan)
    count = np.zeros(n, dtype=np.int64)
    status = np.zeros(n, dtype=np.int64)
    _forward_kinematics_batch(thetas, as_paper_model(model).packed, q, s, count, status)
    if np.any(status == rrr3.DEGENERATE):
        k = int(np.flatnonzero(status == rrr3.DEGENERATE)[0])
        raise SingularityError(
            f"theta = {thetas[k].tolist()}{index_text(k, shape)}: the forward-kinematics polynomial "
            "vanishes identically (architecture singularity, a continuum of assembly modes)"
        )
    for k in range(n):
        q[k, count[k]:] = np.nan
        s[k, count[k]:] = np.nan
    pose = platform_pose(model, np.where(np.isnan(q), 0.0, q))
    pose[np.isnan(q[..., 0])] = np.nan
    return ForwardKinematicsSolution(
        q.reshape(*shape, 6, 7), pose.reshape(*shape, 6, 3), s.reshape(*shape, 6), count.reshape(shape)
    )


def branch_following(model: Planar3RRR, q_previous, theta, *, singularity_guard: float = 1e-6) -> np.ndarray:
    """The configuration at ``θ`` continuously connected to ``q_previous`` (paper §3.2).

    This is the forward kinematics used during simulation: among the up to six assembly
    modes, the one on the same branch as the previous configuration. Cheap in the common
    case (one predictor-corrector step); a large step is subdivided.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q_previous : array_like, shape (..., 7)
        Configurations on the loop closure (rad): the assembly modes to follow.
    theta : array_like, shape (..., 3)
        The actuated angles to move to (rad), broadcast against ``q_previous``.
    singularity_guard : float
        The least ``|S|`` (dimensionless, eq. 19) the branch may come to on the way.

    Returns
    -------
    ndarray, shape (..., 7)
        The configurations at ``theta`` on the branches of ``q_previous`` (rad; the passive angles ``φ`` in
        (-π, π]).

    Raises
    ------
    BranchFollowingError
        When the branch cannot be followed: ``|S|`` falls to ``singularity_guard`` or changes sign on
        the way (a gain-type singularity), or the corrector does not converge.
    InvalidParameterError
        If ``q_previous`` is off the loop closure (naming its residual), or an argument has the wrong shape or
        value.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import (branch_following, constraint_residual, inverse_kinematics,
    ...                                      platform_pose, working_mode_of)
    >>> model = Planar3RRR.paper()
    >>> q0 = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> q1 = branch_following(model, q0, q0[:3] + [0.01, 0.0, 0.0])
    >>> np.round(platform_pose(model, q1), 4).tolist(), working_mode_of(model, q1).tolist()
    ([0.2, 0.2127, -0.0161], [1, -1, 1])
    >>> bool(np.abs(constraint_residual(model, q1)).max() < 1e-12)
    True
    """
    q_prev, thetas, shape = as_pair("q_previous", q_previous, 7, "theta", theta, 3)
    require_on_closure(model, _first_order(model, q_prev)[1], shape, "q_previous")
    from ..model.mechanism_model import MechanismModel

    # the compiled core's branch following on the machine's description: the simulation's own
    machine = MechanismModel.from_3rrr(as_paper_model(model))
    q_out = np.empty((q_prev.shape[0], machine.kernels.N_COORDINATES))
    status = np.zeros(q_prev.shape[0], dtype=np.int64)
    machine.kernels.branch_following_batch(np.ascontiguousarray(coordinates_from_3rrr(model, q_prev)), thetas,
                                           machine.P, as_real("singularity_guard", singularity_guard, "non-negative"),
                                           np.inf, q_out, status)
    q_out = coordinates_to_3rrr(q_out)
    if np.any(status != machine.kernels.OK):
        k = int(np.flatnonzero(status != machine.kernels.OK)[0])
        s_prev = float(singularity_measure(model, q_prev[k]))
        from .._format import apart

        s_text, limit_text = apart(abs(s_prev), singularity_guard)  # |S| = 0.009996 is never shown as the limit 0.01
        why = ("a gain-type singularity" if status[k] == machine.kernels.SINGULAR else
               "no configuration found on the way (too near a singularity, or out of reach)")
        raise BranchFollowingError(
            f"cannot follow the assembly mode from q_previous (theta = {np.round(q_prev[k, :3], 6).tolist()}) "
            f"to {np.round(thetas[k], 6).tolist()}{index_text(k, shape)}: {why} "
            f"(S = {'-' if s_prev < 0 else ''}{s_text} at the start, limit singularity_guard = {limit_text})"
        )
    return q_out.reshape(*shape, 7)


def coordinates_from_3rrr(model, q: np.ndarray) -> np.ndarray:
    """A :class:`~pkmlab.paper.geometry.Planar3RRR`'s configurations ``q`` (..., 7) = ``(θ, φ, α)`` in the generic
    model's coordinates (..., 9) = ``(θ, φ, x, y, α)``
    (:meth:`~pkmlab.model.mechanism_model.MechanismModel.from_3rrr`)."""
    q = np.asarray(q, dtype=float)
    pose = platform_pose(model, q)
    return np.concatenate([q[..., :6], pose[..., :2], q[..., 6:]], axis=-1)


def coordinates_to_3rrr(q: np.ndarray) -> np.ndarray:
    """The inverse of :func:`coordinates_from_3rrr`: ``(θ, φ, x, y, α)`` → ``(θ, φ, α)``, the passive angles ``φ``
    in (-π, π] as the 3-RRR's kinematics gives them (``α`` stays continuous)."""
    out = np.concatenate([q[..., :6], q[..., 8:]], axis=-1)
    out[..., 3:6] = wrapped_angle(out[..., 3:6])
    return out


# ------------------------------------------------------------------ first-order kinematics
def _first_order(model, q):
    qs, shape = as_batch("q", q, 7)
    n = qs.shape[0]
    residual = np.empty((n, 4))
    j_eta_q = np.empty((n, 4, 7))
    j_pose_q = np.empty((n, 3, 7))
    j_q_theta = np.empty((n, 7, 3))
    det = np.empty(n)
    ok = np.zeros(n, dtype=np.bool_)
    _first_order_batch(qs, as_paper_model(model).packed, residual, j_eta_q, j_pose_q, j_q_theta, det, ok)
    return shape, residual, j_eta_q, j_pose_q, j_q_theta, det, ok


def length_scale(model: Planar3RRR) -> float:
    """The machine's size (m): its largest base distance, link length or platform side (what the closure
    tolerance is scaled by, as for any machine: :data:`pkmlab.algorithms.kinematics.CLOSURE_TOLERANCE`)."""
    model = as_paper_model(model)
    return float(max(np.abs(model.base_points).max(), model.active_lengths.max(), model.passive_lengths.max(),
                     model.platform_side))


def require_on_closure(model, residual, shape, name: str = "q") -> None:
    """Refuse configurations whose loop-closure residual ``max |η(q)|`` (from :func:`constraint_residual`, (K, 4))
    exceeds ``CLOSURE_TOLERANCE`` times the machine's size: the Jacobians, the singularity measure and the
    actuator-space model are those of the closed chain, and off it they would be numbers of nothing."""
    refuse_off_closure(residual, CLOSURE_TOLERANCE * length_scale(model), shape, name)


def require_regular(ok, shape, what, name: str = "q"):
    if not np.all(ok):
        k = int(np.flatnonzero(~ok)[0])
        raise SingularityError(
            f"{what} is undefined{index_text(k, shape)}: {name} is at a gain-type singularity, det(J_eta_phi) = 0"
        )


def platform_pose(model: Planar3RRR, q) -> np.ndarray:
    """Platform pose ``(x, y, α)`` (..., 3) of configurations ``q`` (eq. 13, centroid position).

    The centroid is reached through leg 1 (``θ1``, ``φ1``) and the orientation ``α``; ``q`` is not checked
    against the loop closure.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (..., 3)
        The centroid ``(x, y)`` (m) and the orientation ``α`` (rad).

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics, platform_pose
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> bool(np.allclose(platform_pose(model, q), [0.20, 0.21, 0.0], atol=1e-12))
    True
    """
    qs, shape = as_batch("q", q, 7)
    out = np.empty((qs.shape[0], 3))
    _pose_batch(qs, as_paper_model(model).packed, out)
    return out.reshape(*shape, 3)


def constraint_residual(model: Planar3RRR, q) -> np.ndarray:
    """Loop-closure residual ``η(q)`` (..., 4), eqs. (2), (3), (5), (6).

    Any configuration is accepted: ``η`` is zero on the loop closure only.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad), on the loop closure or not.

    Returns
    -------
    ndarray, shape (..., 4)
        The gaps (m) in x and y at ``p2`` through loop 1, then at ``p3`` through loop 2.

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import constraint_residual, inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> bool(np.abs(constraint_residual(model, q)).max() < 1e-12)
    True
    >>> bool(np.abs(constraint_residual(model, q + [0, 0, 0, 0.01, 0, 0, 0])).max() > 1e-4)  # φ1 moved alone
    True
    """
    shape, residual, *_ = _first_order(model, q)
    return residual.reshape(*shape, 4)


def constraint_jacobian(model: Planar3RRR, q) -> np.ndarray:
    """``Jηq = ∂η/∂q`` (..., 4, 7) = ``[Jηθ | Jηφ]`` (paper §2.3).

    Any configuration is accepted, as for :func:`constraint_residual`.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad), on the loop closure or not.

    Returns
    -------
    ndarray, shape (..., 4, 7)
        The derivatives of ``η`` (m) by the coordinates (rad): m per rad.

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import constraint_jacobian, coordinate_rates, inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> jac = constraint_jacobian(model, q)
    >>> jac.shape, bool(np.allclose(jac @ coordinate_rates(model, q, [0.1, -0.2, 0.3]), 0.0))  # Jηq q̇ = 0
    ((4, 7), True)
    """
    shape, _r, j_eta_q, *_ = _first_order(model, q)
    return j_eta_q.reshape(*shape, 4, 7)


def passive_jacobian(model: Planar3RRR, q) -> np.ndarray:
    """``Jφθ = -Jηφ⁻¹ Jηθ`` (..., 4, 3), eq. (15): ``φ̇ = Jφθ θ̇``.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (..., 4, 3)
        The rates of ``(φ1, φ2, φ3, α)`` per unit rate of ``(θ1, θ2, θ3)`` (rad per rad).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), does not have 7 components, or ``model`` is not a
        Planar3RRR.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import constraint_jacobian, inverse_kinematics, passive_jacobian
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> jac, j_phi_theta = constraint_jacobian(model, q), passive_jacobian(model, q)
    >>> bool(np.allclose(jac[:, :3] + jac[:, 3:] @ j_phi_theta, 0.0))  # Jηθ + Jηφ Jφθ = 0
    True
    >>> passive_jacobian(model, q + [0, 0, 0, 0.01, 0, 0, 0])
    Traceback (most recent call last):
        ...
    pkmlab.errors.InvalidParameterError: q is off the loop closure: max |eta(q)| = 0.00149 m exceeds ...
    """
    shape, residual, _j, _jp, j_q_theta, _d, ok = _first_order(model, q)
    require_on_closure(model, residual, shape)
    require_regular(ok, shape, "J_phi_theta")
    return j_q_theta[:, 3:, :].reshape(*shape, 4, 3)


def actuated_jacobian(model: Planar3RRR, q) -> np.ndarray:
    """``Jqθ = [I3; Jφθ]`` (..., 7, 3), eq. (31): ``q̇ = Jqθ θ̇``.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (..., 7, 3)
        The rates of the seven coordinates per unit rate of ``(θ1, θ2, θ3)`` (rad per rad).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), does not have 7 components, or ``model`` is not a
        Planar3RRR.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import actuated_jacobian, inverse_kinematics, passive_jacobian
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> j_q_theta = actuated_jacobian(model, q)
    >>> bool(np.allclose(j_q_theta[:3], np.eye(3)) and np.allclose(j_q_theta[3:], passive_jacobian(model, q)))
    True
    """
    shape, residual, _j, _jp, j_q_theta, _d, ok = _first_order(model, q)
    require_on_closure(model, residual, shape)
    require_regular(ok, shape, "J_q_theta")
    return j_q_theta.reshape(*shape, 7, 3)


def platform_jacobian(model: Planar3RRR, q) -> np.ndarray:
    """``∂(ẋ, ẏ, α̇)/∂θ̇`` (..., 3, 3): ``Jpq Jqθ`` with the orientation row added (eqs. 14–17).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Rows ``ẋ``, ``ẏ`` (m per rad) and ``α̇`` (rad per rad) per unit rate of ``(θ1, θ2, θ3)``.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), does not have 7 components, or ``model`` is not a
        Planar3RRR.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import branch_following, inverse_kinematics, platform_jacobian, platform_pose
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> theta_dot, h = np.array([0.1, -0.2, 0.3]), 1e-6
    >>> moved = branch_following(model, q, q[:3] + h * theta_dot)  # a finite difference along the branch
    >>> pose_dot = (platform_pose(model, moved) - platform_pose(model, q)) / h
    >>> bool(np.allclose(pose_dot, platform_jacobian(model, q) @ theta_dot, atol=1e-5))
    True
    """
    shape, residual, _j, j_pose_q, j_q_theta, _d, ok = _first_order(model, q)
    require_on_closure(model, residual, shape)
    require_regular(ok, shape, "the platform Jacobian")
    return (j_pose_q @ j_q_theta).reshape(*shape, 3, 3)


def velocity_jacobian(model: Planar3RRR, q) -> np.ndarray:
    """``Jv = Jpθ + Jpφ Jφθ`` (..., 2, 3), eq. (16): centroid velocity ``ṗ = Jv θ̇``.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (..., 2, 3)
        The centroid's velocity (m/s) per unit rate of ``(θ1, θ2, θ3)`` (rad/s): m per rad. The first two rows
        of :func:`platform_jacobian`.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), does not have 7 components, or ``model`` is not a
        Planar3RRR.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics, velocity_jacobian
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(velocity_jacobian(model, q), 4).tolist()
    [[-0.0029, -0.1431, 0.0861], [0.2654, -0.3092, -0.0161]]
    """
    return platform_jacobian(model, q)[..., :2, :]


def _second_order(model, q, theta_dot):
    qs, theta_dots, shape = as_pair("q", q, 7, "theta_dot", theta_dot, 3)
    n = qs.shape[0]
    q_dot = np.empty((n, 7))
    bias = np.empty((n, 7))
    pose_bias = np.empty((n, 3))
    ok = np.zeros(n, dtype=np.bool_)
    require_on_closure(model, _first_order(model, qs)[1], shape)
    _second_order_batch(qs, theta_dots, as_paper_model(model).packed, q_dot, bias, pose_bias, ok)
    require_regular(ok, shape, "the passive rates")
    return shape, q_dot, bias, pose_bias


def coordinate_rates(model: Planar3RRR, q, theta_dot) -> np.ndarray:
    """``q̇ = Jqθ θ̇`` (..., 7), eq. (31).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates ``(θ̇1, θ̇2, θ̇3)`` (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (..., 7)
        The rates of the seven coordinates (rad/s); the first three are ``theta_dot``.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import coordinate_rates, inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(coordinate_rates(model, q, [0.1, -0.2, 0.3]), 4).tolist()
    [0.1, -0.2, 0.3, 0.7922, -0.1941, -0.3586, -0.5276]
    """
    shape, q_dot, _b, _pb = _second_order(model, q, theta_dot)
    return q_dot.reshape(*shape, 7)


def passive_rates(model: Planar3RRR, q, theta_dot) -> np.ndarray:
    """``φ̇ = Jφθ θ̇`` (..., 4) = ``(φ̇1, φ̇2, φ̇3, α̇)``, eq. (15).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates ``(θ̇1, θ̇2, θ̇3)`` (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (..., 4)
        ``(φ̇1, φ̇2, φ̇3, α̇)`` (rad/s).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics, passive_jacobian, passive_rates
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> theta_dot = np.array([0.1, -0.2, 0.3])
    >>> bool(np.allclose(passive_rates(model, q, theta_dot), passive_jacobian(model, q) @ theta_dot))
    True
    """
    return coordinate_rates(model, q, theta_dot)[..., 3:]


def acceleration_bias(model: Planar3RRR, q, theta_dot) -> np.ndarray:
    """``J̇qθ θ̇`` (..., 7): ``q̈`` when ``θ̈ = 0`` (eq. 32); zero in the actuated rows.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates ``(θ̇1, θ̇2, θ̇3)`` (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (..., 7)
        The coordinates' accelerations (rad/s²) at ``θ̈ = 0``.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import acceleration_bias, inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(acceleration_bias(model, q, [0.1, -0.2, 0.3]), 4).tolist()
    [0.0, 0.0, 0.0, 1.203, -0.8442, -0.8555, -0.7837]
    """
    shape, _qd, bias, _pb = _second_order(model, q, theta_dot)
    return bias.reshape(*shape, 7)


def coordinate_accelerations(model: Planar3RRR, q, theta_dot, theta_ddot) -> np.ndarray:
    """``q̈ = Jqθ θ̈ + J̇qθ θ̇`` (..., 7), eq. (32).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates ``(θ̇1, θ̇2, θ̇3)`` (rad/s).
    theta_ddot : array_like, shape (..., 3)
        Actuated accelerations ``(θ̈1, θ̈2, θ̈3)`` (rad/s²); the three arguments are broadcast together.

    Returns
    -------
    ndarray, shape (..., 7)
        The coordinates' accelerations (rad/s²); the first three are ``theta_ddot``.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import (acceleration_bias, actuated_jacobian, coordinate_accelerations,
    ...                                      inverse_kinematics)
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> theta_dot, theta_ddot = np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.0, -0.5])
    >>> q_ddot = coordinate_accelerations(model, q, theta_dot, theta_ddot)
    >>> expected = actuated_jacobian(model, q) @ theta_ddot + acceleration_bias(model, q, theta_dot)
    >>> bool(np.allclose(q_ddot, expected)), np.round(q_ddot[:3], 4).tolist()
    (True, [1.0, 0.0, -0.5])
    """
    qs, theta_dots, theta_ddots, shape = as_broadcast(("q", q, 7), ("theta_dot", theta_dot, 3),
                                                      ("theta_ddot", theta_ddot, 3))
    qs, theta_dots, theta_ddots = qs.reshape(*shape, 7), theta_dots.reshape(*shape, 3), theta_ddots.reshape(*shape, 3)
    bias = acceleration_bias(model, qs, theta_dots)
    j_q_theta = actuated_jacobian(model, qs)
    return bias + np.einsum("...ij,...j->...i", j_q_theta, theta_ddots)


def determinant_formula(model: Planar3RRR, q) -> np.ndarray:
    """Eq. (18)'s ``det(Jηφ)`` (...) as a formula of any seven numbers ``q``, on the loop closure or not: what
    :func:`forward_singularity_determinant` evaluates once ``q`` is checked (and inverse kinematics, at the
    configurations it has just built)."""
    qs, shape = as_batch("q", q, 7)
    det = np.empty(qs.shape[0])
    _determinant_batch(qs, as_paper_model(model).packed, det)
    return det.reshape(shape)


def forward_singularity_determinant(model: Planar3RRR, q) -> np.ndarray:
    """``det(Jηφ)`` (...), eq. (18); zero at a gain-type singularity. ``q`` must be on the loop closure.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (...)
        The determinant (m⁴: each entry of ``Jηφ`` in m per rad); :func:`singularity_measure` is it made
        dimensionless.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), does not have 7 components, or ``model`` is not a
        Planar3RRR.

    Examples
    --------
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import forward_singularity_determinant, inverse_kinematics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> round(float(forward_singularity_determinant(model, q)), 7)
    0.0004311
    """
    qs, shape = as_batch("q", q, 7)
    require_on_closure(model, _first_order(model, qs)[1], shape)
    return determinant_formula(model, qs).reshape(shape)


def singularity_measure(model: Planar3RRR, q) -> np.ndarray:
    """``S = -det(Jηφ) / (a r1 r2 r3)`` (...), eq. (19) with conventions §2's sign. ``q`` must be on the loop
    closure.

    For the paper's geometry (equal ``r_i``, equilateral platform) this is
    ``sin(φ1 - α) sin(φ2 - φ3) + sin(φ1 - φ2) sin(α + 2π/3 - φ3)``.

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).

    Returns
    -------
    ndarray, shape (...)
        ``S`` (dimensionless): zero at a gain-type singularity, changing sign across one.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), does not have 7 components, or ``model`` is not a
        Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics, singularity_measure
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> phi1, phi2, phi3, alpha = q[3:]
    >>> formula = (np.sin(phi1 - alpha) * np.sin(phi2 - phi3)
    ...            + np.sin(phi1 - phi2) * np.sin(alpha + 2 * np.pi / 3 - phi3))
    >>> s = float(singularity_measure(model, q))
    >>> round(s, 4), bool(np.isclose(s, formula))
    (-0.7446, True)
    """
    return -forward_singularity_determinant(model, q) / rrr3.singularity_scale(model.packed)


# ------------------------------------------------------------------ the desired motion of a path (paper eqs. 14-17, 32)
@njit(cache=True)
def _joint_motion_batch(pose, pose_dot, pose_ddot, mode, P, q, theta_dot, theta_ddot, det):
    """Per sample: IK, ``θ̇`` from ``ẋ = J θ̇``, ``θ̈`` from ``ẍ = J θ̈ + Jpq J̇qθ θ̇ + J̇pq q̇`` (eqs. 14–17, 32),
    and ``det Jηφ`` (eq. 18) of the factors computed on the way.

    ``J = Jpq Jqθ`` is the platform Jacobian. Returns the first sample that is out of reach or
    singular, or -1.
    """
    ws = rrr3.make_workspace(P)
    jp, jac, lu = np.empty((3, 7)), np.empty((3, 3)), np.empty((3, 3))
    piv, bias, b = np.empty(3, np.int64), np.empty(3), np.empty(3)
    for k in range(pose.shape[0]):
        if rrr3.inverse_kinematics(pose[k], mode, P, q[k]) != 0:
            return k
        ws.q[0, :] = q[k]
        ok = rrr3.linearize(ws, 0, P)
        det[k] = ws.det[0]
        if not ok:
            return k
        rrr3.pose_jacobian(q[k], P, jp)
        jqt = ws.j_q_theta[0]
        for i in range(3):
            for j in range(3):
                acc = 0.0
                for c in range(7):
                    acc += jp[i, c] * jqt[c, j]
                jac[i, j] = acc
        ok, _det = closed_chain.lu_factor(jac, lu, piv, 3)
        if not ok:
            return k
        for i in range(3):
            b[i] = pose_dot[k, i]
        closed_chain.lu_solve_factored(lu, piv, b, 3)
        for i in range(3):
            theta_dot[k, i] = b[i]
        rrr3.evaluate_velocities(ws, 0, b, P)
        rrr3.pose_convective(q[k], ws.q_dot, P, bias)
        for i in range(3):
            acc = pose_ddot[k, i] - bias[i]
            for c in range(7):
                acc -= jp[i, c] * ws.bias_q[c]
            b[i] = acc
        closed_chain.lu_solve_factored(lu, piv, b, 3)
        for i in range(3):
            theta_ddot[k, i] = b[i]
    return -1


def desired_joint_motion(model: Planar3RRR, trajectory, mode, t):
    """Exact inverse kinematics of a trajectory and its first and second time derivatives, and the
    singularity measure ``S`` (eq. 19) along it.

    ``θ`` is unwrapped along ``t`` so that it is continuous (IK returns angles in (-π, π]).
    Raises the error of :func:`~pkmlab.paper.kinematics.inverse_kinematics` or
    :func:`~pkmlab.paper.kinematics.platform_jacobian` for the first sample out of reach or singular.
    """
    t = np.atleast_1d(np.asarray(t, dtype=float))
    return joint_motion(model, trajectory.desired(t), mode, t)


def joint_motion(model: Planar3RRR, desired, mode, t: np.ndarray):
    """:func:`desired_joint_motion` from the trajectory's ``desired = (pose, pose_dot, pose_ddot)`` at the
    times ``t`` (N,), already evaluated."""
    pose, pose_dot, pose_ddot = (np.ascontiguousarray(a, dtype=float) for a in desired)
    from ..control.trajectory import JointMotion

    mode = as_mode(mode)
    n = t.size
    q, theta_dot, theta_ddot, det = np.empty((n, 7)), np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
    k = _joint_motion_batch(pose, pose_dot, pose_ddot, mode, model.packed, q, theta_dot, theta_ddot, det)
    if k >= 0:  # the public functions name the problem
        q_k = inverse_kinematics(model, pose[k], mode=mode).q
        platform_jacobian(model, q_k)
        raise SingularityError(f"the platform Jacobian is singular at t = {t[k]:.4f} s")
    theta = np.unwrap(q[:, :3], axis=0)
    q[:, :3] = theta
    # S as kinematics.singularity_measure computes it: the same factors of the same configurations
    return JointMotion(t, q, pose, theta, theta_dot, theta_ddot, -det / rrr3.singularity_scale(model.packed))
