"""The paper's own formulation of its planar 3-RRR, compiled: constraints, Jacobians, inverse and
forward kinematics, and the bodies of the full-space model.

Every function here works on one configuration and reads the architecture from the packed
parameter vector ``P`` (:attr:`pkmlab.paper.geometry.Planar3RRR.packed`, layout in
:mod:`pkmlab.paper.geometry`). They are compiled with Numba (``cache=True``) and serve the public API
in the paper's coordinates (:mod:`pkmlab.paper.kinematics`, :mod:`pkmlab.paper.dynamics`, which broadcast
over batches), the reproduction's reference and the independent cross-check of the generic
pipeline; the simulation, the controller, the reduced model and branch following run on the
compiled core of every mechanism (:mod:`pkmlab.codegen.core`, on the machine's description).
Conventions are those of conventions §1–§3 and :mod:`pkmlab.paper.geometry`:
``q = (θ1, θ2, θ3, φ1, φ2, φ3, α)``, absolute angles.

Loop-closure constraints (paper eqs. (2), (3), (5), (6), in that order)::

    η[0:2] = e1 + r1 u(φ1) + R(α) P2        - e2 - r2 u(φ2)    (loop b1 → p1 → p2 ← b2)
    η[2:4] = e2 + r2 u(φ2) + R(α) (P3 - P2) - e3 - r3 u(φ3)    (loop b2 → p2 → p3 ← b3)

with ``e_i = b_i + l_i u(θ_i)``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .._compile_cache import NO_REFCOUNT, NO_REFCOUNT_INLINE, NO_REFCOUNT_PYTHON, njit
from ..algorithms.three_circles import DEGENERATE, OK, rotate, three_circles  # noqa: F401  (status bits here too)
from ..description._rrr3_layout import (
    ACTIVE_COM,
    ACTIVE_INERTIA,
    ACTIVE_LENGTH,
    ACTIVE_MASS,
    BASE,
    PASSIVE_COM,
    PASSIVE_INERTIA,
    PASSIVE_LENGTH,
    PASSIVE_MASS,
    PLATFORM,
    PLATFORM_COM,
    PLATFORM_INERTIA,
    PLATFORM_MASS,
    REFERENCE,
)
from ..numerics import closed_chain, lagrangian

N_COORDINATES = 7
N_ACTIVE = 3
N_CONSTRAINTS = 4
MAX_ASSEMBLY_MODES = 6

# Status bits of forward kinematics and branch following, with OK and DEGENERATE of three_circles.
NOT_CONVERGED = 1  # Newton's method did not converge (no nearby solution)
SINGULAR = 2  # det(Jηφ) vanished or changed sign: a gain-type singularity was met

TWO_PI = 2.0 * math.pi


@njit(**NO_REFCOUNT)
def wrap_angle(x):
    """``x`` mapped to ``(-π, π]``."""
    if -math.pi < x <= math.pi:  # the common case costs a comparison, not a division
        return x
    y = x - TWO_PI * math.floor((x + math.pi) / TWO_PI)  # in [-π, π)
    if y <= -math.pi:
        y += TWO_PI
    return y


@njit(cache=True)
def elbows(theta, P):
    """Elbow points ``e_i = b_i + l_i u(θ_i)`` as a (3, 2) array."""
    e = np.empty((3, 2))
    for i in range(3):
        li = P[ACTIVE_LENGTH + i]
        e[i, 0] = P[BASE + 2 * i] + li * math.cos(theta[i])
        e[i, 1] = P[BASE + 2 * i + 1] + li * math.sin(theta[i])
    return e


@njit(**NO_REFCOUNT)
def angle_sincos(q, sc, first=0):
    """Write ``(cos q_j, sin q_j)`` of the coordinates ``j >= first`` into ``sc`` (7, 2).

    Every term of ``η``, of its Jacobian and of the bodies is ``k u(q_j)`` or ``R(q_j) v``: the
    functions below take these once-computed values instead of calling ``cos``/``sin`` again.
    """
    for j in range(first, N_COORDINATES):
        sc[j, 0] = math.cos(q[j])
        sc[j, 1] = math.sin(q[j])


@njit(**NO_REFCOUNT)
def constraints_from_sincos(sc, P, out):
    """Write ``η`` (eqs. 2, 3, 5, 6) into ``out`` (4,) from :func:`angle_sincos`; returns ``max |η_k|``."""
    ca, sa = sc[6, 0], sc[6, 1]
    p2x, p2y = P[PLATFORM], P[PLATFORM + 1]
    dx, dy = P[PLATFORM + 2] - p2x, P[PLATFORM + 3] - p2y  # P3 - P2
    # vertex p_i reached through leg i
    v0x = P[BASE] + P[ACTIVE_LENGTH] * sc[0, 0] + P[PASSIVE_LENGTH] * sc[3, 0]
    v0y = P[BASE + 1] + P[ACTIVE_LENGTH] * sc[0, 1] + P[PASSIVE_LENGTH] * sc[3, 1]
    v1x = P[BASE + 2] + P[ACTIVE_LENGTH + 1] * sc[1, 0] + P[PASSIVE_LENGTH + 1] * sc[4, 0]
    v1y = P[BASE + 3] + P[ACTIVE_LENGTH + 1] * sc[1, 1] + P[PASSIVE_LENGTH + 1] * sc[4, 1]
    v2x = P[BASE + 4] + P[ACTIVE_LENGTH + 2] * sc[2, 0] + P[PASSIVE_LENGTH + 2] * sc[5, 0]
    v2y = P[BASE + 5] + P[ACTIVE_LENGTH + 2] * sc[2, 1] + P[PASSIVE_LENGTH + 2] * sc[5, 1]
    out[0] = v0x + ca * p2x - sa * p2y - v1x
    out[1] = v0y + sa * p2x + ca * p2y - v1y
    out[2] = v1x + ca * dx - sa * dy - v2x
    out[3] = v1y + sa * dx + ca * dy - v2y
    return max(max(abs(out[0]), abs(out[1])), max(abs(out[2]), abs(out[3])))


@njit(**NO_REFCOUNT)
def constraint_jacobian_from_sincos(sc, P, out):
    """Write ``Jηq = ∂η/∂q`` (4, 7) into ``out``; columns ``[Jηθ | Jηφ]`` (paper §2.3)."""
    out[:, :] = 0.0
    ca, sa = sc[6, 0], sc[6, 1]
    p2x, p2y = P[PLATFORM], P[PLATFORM + 1]
    dx, dy = P[PLATFORM + 2] - p2x, P[PLATFORM + 3] - p2y
    for i in range(3):
        li, ri = P[ACTIVE_LENGTH + i], P[PASSIVE_LENGTH + i]
        # d/dx (k u(x)) = k (-sin x, cos x); leg i enters loop 1 (rows 0-1) and/or loop 2.
        gtx, gty = -li * sc[i, 1], li * sc[i, 0]
        gpx, gpy = -ri * sc[3 + i, 1], ri * sc[3 + i, 0]
        if i == 0:
            out[0, 0], out[1, 0] = gtx, gty
            out[0, 3], out[1, 3] = gpx, gpy
        elif i == 1:
            out[0, 1], out[1, 1], out[2, 1], out[3, 1] = -gtx, -gty, gtx, gty
            out[0, 4], out[1, 4], out[2, 4], out[3, 4] = -gpx, -gpy, gpx, gpy
        else:
            out[2, 2], out[3, 2] = -gtx, -gty
            out[2, 5], out[3, 5] = -gpx, -gpy
    # d/dα R(α) v = R(α + π/2) v
    out[0, 6] = -sa * p2x - ca * p2y
    out[1, 6] = ca * p2x - sa * p2y
    out[2, 6] = -sa * dx - ca * dy
    out[3, 6] = ca * dx - sa * dy


@njit(**NO_REFCOUNT)
def constraint_convective_from_sincos(sc, q_dot, P, out):
    """Write ``J̇ηq q̇`` (4,) into ``out``: ``η̈`` when ``q̈ = 0``.

    Each term ``k u(x)`` of ``η`` contributes ``-k u(x) ẋ²``; ``R(α) v`` contributes
    ``-R(α) v α̇²``.
    """
    ca, sa = sc[6, 0], sc[6, 1]
    w2 = q_dot[6] * q_dot[6]
    p2x, p2y = P[PLATFORM], P[PLATFORM + 1]
    dx, dy = P[PLATFORM + 2] - p2x, P[PLATFORM + 3] - p2y
    # centripetal acceleration of vertex p_i reached through leg i
    a0x, a0y = _leg_centripetal(sc, q_dot, P, 0)
    a1x, a1y = _leg_centripetal(sc, q_dot, P, 1)
    a2x, a2y = _leg_centripetal(sc, q_dot, P, 2)
    out[0] = a0x - (ca * p2x - sa * p2y) * w2 - a1x
    out[1] = a0y - (sa * p2x + ca * p2y) * w2 - a1y
    out[2] = a1x - (ca * dx - sa * dy) * w2 - a2x
    out[3] = a1y - (sa * dx + ca * dy) * w2 - a2y


@njit(**NO_REFCOUNT)
def _leg_centripetal(sc, q_dot, P, i):
    li, ri = P[ACTIVE_LENGTH + i], P[PASSIVE_LENGTH + i]
    t2, f2 = q_dot[i] * q_dot[i], q_dot[3 + i] * q_dot[3 + i]
    return (-li * sc[i, 0] * t2 - ri * sc[3 + i, 0] * f2, -li * sc[i, 1] * t2 - ri * sc[3 + i, 1] * f2)


@njit(cache=True)
def constraints(q, P, out):
    """Write ``η(q)`` (eqs. 2, 3, 5, 6) into ``out`` (4,)."""
    sc = np.empty((N_COORDINATES, 2))
    angle_sincos(q, sc)
    constraints_from_sincos(sc, P, out)


@njit(cache=True)
def constraint_jacobian(q, P, out):
    """Write ``Jηq = ∂η/∂q`` (4, 7) into ``out``; columns ``[Jηθ | Jηφ]`` (paper §2.3)."""
    sc = np.empty((N_COORDINATES, 2))
    angle_sincos(q, sc)
    constraint_jacobian_from_sincos(sc, P, out)


@njit(cache=True)
def constraint_convective(q, q_dot, P, out):
    """Write ``J̇ηq q̇`` (4,) into ``out``: ``η̈`` when ``q̈ = 0``."""
    sc = np.empty((N_COORDINATES, 2))
    angle_sincos(q, sc)
    constraint_convective_from_sincos(sc, q_dot, P, out)


@njit(cache=True)
def platform_pose(q, P, out):
    """Write the platform pose ``(x, y, α)`` (3,): its reference point (centroid) and orientation.

    The position is reached through leg 1: ``p1 = b1 + l1 u(θ1) + r1 u(φ1)``, then
    ``(x, y) = p1 + R(α) C`` with ``C`` the reference point in the platform frame.
    """
    ca, sa = math.cos(q[6]), math.sin(q[6])
    cx, cy = P[REFERENCE], P[REFERENCE + 1]
    l1, r1 = P[ACTIVE_LENGTH], P[PASSIVE_LENGTH]
    out[0] = P[BASE] + l1 * math.cos(q[0]) + r1 * math.cos(q[3]) + ca * cx - sa * cy
    out[1] = P[BASE + 1] + l1 * math.sin(q[0]) + r1 * math.sin(q[3]) + sa * cx + ca * cy
    out[2] = q[6]


@njit(cache=True)
def pose_jacobian(q, P, out):
    """Write ``∂(x, y, α)/∂q`` (3, 7) into ``out`` (the paper's ``Jpq`` of eq. 17, plus ``α``)."""
    out[:, :] = 0.0
    ca, sa = math.cos(q[6]), math.sin(q[6])
    cx, cy = P[REFERENCE], P[REFERENCE + 1]
    l1, r1 = P[ACTIVE_LENGTH], P[PASSIVE_LENGTH]
    out[0, 0], out[1, 0] = -l1 * math.sin(q[0]), l1 * math.cos(q[0])
    out[0, 3], out[1, 3] = -r1 * math.sin(q[3]), r1 * math.cos(q[3])
    out[0, 6], out[1, 6] = -sa * cx - ca * cy, ca * cx - sa * cy
    out[2, 6] = 1.0


@njit(cache=True)
def pose_convective(q, q_dot, P, out):
    """Write ``J̇pq q̇`` (3,): the platform pose's acceleration when ``q̈ = 0``."""
    ca, sa = math.cos(q[6]), math.sin(q[6])
    cx, cy = P[REFERENCE], P[REFERENCE + 1]
    l1, r1 = P[ACTIVE_LENGTH], P[PASSIVE_LENGTH]
    t2, f2, w2 = q_dot[0] * q_dot[0], q_dot[3] * q_dot[3], q_dot[6] * q_dot[6]
    out[0] = -l1 * math.cos(q[0]) * t2 - r1 * math.cos(q[3]) * f2 - (ca * cx - sa * cy) * w2
    out[1] = -l1 * math.sin(q[0]) * t2 - r1 * math.sin(q[3]) * f2 - (sa * cx + ca * cy) * w2
    out[2] = 0.0


@njit(**NO_REFCOUNT_PYTHON)
def singularity_scale(P):
    """``a r1 r2 r3``: the factor of eq. (18) that makes ``S`` independent of the scale."""
    a = math.hypot(P[PLATFORM], P[PLATFORM + 1])
    return a * P[PASSIVE_LENGTH] * P[PASSIVE_LENGTH + 1] * P[PASSIVE_LENGTH + 2]


@njit(cache=True)
def forward_singularity_determinant(q, P):
    """``det(Jηφ)`` (eq. 18): zero at a gain-type (forward) singularity."""
    j = np.empty((4, 7))
    constraint_jacobian(q, P, j)
    return closed_chain.determinant(j[:, 3:])


@njit(cache=True)
def singularity_measure(q, P):
    """``S = -det(Jηφ) / (a r1 r2 r3)`` (eq. 19 with conventions §2's sign)."""
    return -forward_singularity_determinant(q, P) / singularity_scale(P)


# ------------------------------------------------------------------ inverse kinematics
@njit(cache=True)
def inverse_kinematics(pose, mode, P, q):
    """Inverse kinematics of one pose for one working mode (paper §2, conventions §3).

    ``pose = (x, y, α)``; ``mode = (σ1, σ2, σ3)``, ``σ_i = +1`` when elbow ``e_i`` lies to the
    left of the directed line ``b_i → p_i``. Writes ``q`` (7,) and returns a bit mask of the
    legs that cannot reach their vertex (bit ``i`` for leg ``i + 1``; 0 when all reach).
    """
    ca, sa = math.cos(pose[2]), math.sin(pose[2])
    cx, cy = P[REFERENCE], P[REFERENCE + 1]
    p1x = pose[0] - (ca * cx - sa * cy)
    p1y = pose[1] - (sa * cx + ca * cy)
    unreachable = 0
    for i in range(3):
        if i == 0:
            vx, vy = 0.0, 0.0
        else:
            vx, vy = P[PLATFORM + 2 * (i - 1)], P[PLATFORM + 2 * (i - 1) + 1]
        px = p1x + ca * vx - sa * vy
        py = p1y + sa * vx + ca * vy
        dx, dy = px - P[BASE + 2 * i], py - P[BASE + 2 * i + 1]
        rho = math.hypot(dx, dy)
        li, ri = P[ACTIVE_LENGTH + i], P[PASSIVE_LENGTH + i]
        if rho == 0.0:
            cos_beta = 2.0 if li != ri else 1.0
        else:
            cos_beta = (li * li + rho * rho - ri * ri) / (2.0 * li * rho)
        if not (abs(cos_beta) <= 1.0 + 1e-12):  # also catches NaN
            unreachable |= 1 << i
            cos_beta = 1.0
        beta = math.acos(min(1.0, max(-1.0, cos_beta)))
        theta = math.atan2(dy, dx) + mode[i] * beta
        ex = P[BASE + 2 * i] + li * math.cos(theta)
        ey = P[BASE + 2 * i + 1] + li * math.sin(theta)
        q[i] = wrap_angle(theta)
        q[3 + i] = math.atan2(py - ey, px - ex)
    q[6] = pose[2]
    return unreachable


@njit(cache=True)
def forward_kinematics(theta, P, q_out, s_out, ws):
    """Every assembly mode for actuated angles ``θ`` (paper §2.2.2, eq. 12).

    The elbows fix three circles (:func:`three_circles`); each real root is rebuilt into a
    configuration and polished with Newton's method on ``η = 0`` (:func:`correct_passive`, in
    the ``TRIAL`` slot of the workspace ``ws`` of ``P``).

    Writes up to 6 configurations into ``q_out`` (6, 7), sorted by ``α``, and their ``S`` into
    ``s_out`` (6,). Returns ``(count, status)``; ``status`` is ``DEGENERATE`` when the sextic
    vanishes identically (architecture singularity).
    """
    e = elbows(theta, P)
    alphas = np.empty(6)
    p1 = np.empty((6, 2))
    n_roots, status = three_circles(e, P[PASSIVE_LENGTH:PASSIVE_LENGTH + 3], P[PLATFORM:PLATFORM + 4], alphas, p1)
    if status != OK:
        return 0, status
    count = 0
    for j in range(n_roots):
        alpha = alphas[j]
        ca, sa = math.cos(alpha), math.sin(alpha)
        p1x, p1y = p1[j, 0], p1[j, 1]
        q = q_out[count]
        q[0], q[1], q[2] = theta[0], theta[1], theta[2]
        q[6] = alpha
        for i in range(3):
            if i == 0:
                vx, vy = p1x, p1y
            else:
                ox, oy = rotate(P[PLATFORM + 2 * (i - 1)], P[PLATFORM + 2 * (i - 1) + 1], ca, sa)
                vx, vy = p1x + ox, p1y + oy
            q[3 + i] = math.atan2(vy - e[i, 1], vx - e[i, 0])
        ws.q[TRIAL_SLOT, :] = q
        status = correct_passive(ws, TRIAL_SLOT, P, 30)
        q[:] = ws.q[TRIAL_SLOT]
        if status != OK and not _residual_small(q, P):
            continue
        for i in range(3, 7):
            q[i] = wrap_angle(q[i])
        duplicate = False
        for other in range(count):
            diff = 0.0
            for i in range(3, 7):
                diff = max(diff, abs(wrap_angle(q[i] - q_out[other, i])))
            if diff < 1e-8:
                duplicate = True
        if not duplicate:
            count += 1
    # Sort by α (insertion sort; at most 6 entries).
    for a_idx in range(1, count):
        b_idx = a_idx
        while b_idx > 0 and q_out[b_idx - 1, 6] > q_out[b_idx, 6]:
            for i in range(7):
                q_out[b_idx - 1, i], q_out[b_idx, i] = q_out[b_idx, i], q_out[b_idx - 1, i]
            b_idx -= 1
    for j in range(count):
        s_out[j] = singularity_measure(q_out[j], P)
    return count, OK


@njit(cache=True)
def _residual_small(q, P):
    eta = np.empty(4)
    constraints(q, P, eta)
    worst = 0.0
    for k in range(4):
        worst = max(worst, abs(eta[k]))
    return worst <= 1e-12


# ------------------------------------------------------------------ workspace
class Workspace(NamedTuple):
    """Mutable scratch of the compiled kernels for one model (MuJoCo's ``mjData``, Pinocchio's ``Data``).

    The model (the packed parameter vector ``P``) never changes; everything a kernel computes
    lands here, so that a batch allocates nothing. Build it with :func:`make_workspace` for the
    ``P`` it will be used with. Configuration slots (first index of the per-configuration
    fields): ``BASE`` and ``TRIAL``, e.g. a configuration and its Newton-polished neighbour
    (:func:`correct_passive`). Each slot holds the
    configuration ``q`` and its linearisation: ``(cos q, sin q)``, ``Jηq``, the LU factors of
    ``Jηφ``, ``det Jηφ`` and ``Jqθ``.
    """

    q: np.ndarray  # (2, 7)
    sincos: np.ndarray  # (2, 7, 2)
    jac: np.ndarray  # (2, 4, 7) Jηq
    lu: np.ndarray  # (2, 4, 4) LU factors of Jηφ
    piv: np.ndarray  # (2, 4)
    det: np.ndarray  # (2,) det Jηφ
    j_q_theta: np.ndarray  # (2, 7, 3)
    eta: np.ndarray  # (4,) constraint residual / right-hand sides
    q_dot: np.ndarray  # (7,) q̇ = Jqθ θ̇
    bias_q: np.ndarray  # (7,) J̇qθ θ̇
    constants: np.ndarray  # [a r1 r2 r3 (scale of S), tolerance on |η| (m)]


BASE_SLOT, TRIAL_SLOT = 0, 1
_S_SCALE, _ETA_TOL = 0, 1


@njit(cache=True)
def make_workspace(P):
    """A :class:`Workspace` for the model ``P``."""
    # |η| is a sum of a few lengths: its round-off is a few ulps of the largest reach
    reach = 0.0
    for i in range(3):
        reach = max(reach, math.hypot(P[BASE + 2 * i], P[BASE + 2 * i + 1]))
    reach += max(P[ACTIVE_LENGTH], max(P[ACTIVE_LENGTH + 1], P[ACTIVE_LENGTH + 2]))
    reach += max(P[PASSIVE_LENGTH], max(P[PASSIVE_LENGTH + 1], P[PASSIVE_LENGTH + 2]))
    reach += max(math.hypot(P[PLATFORM], P[PLATFORM + 1]), math.hypot(P[PLATFORM + 2], P[PLATFORM + 3]))
    constants = np.array([singularity_scale(P), 4.0 * 2.220446049250313e-16 * reach])
    return Workspace(
        np.zeros((2, 7)), np.zeros((2, 7, 2)), np.zeros((2, 4, 7)), np.zeros((2, 4, 4)),
        np.zeros((2, 4), np.int64), np.zeros(2), np.zeros((2, 7, 3)), np.zeros(4), np.zeros(7), np.zeros(7),
        constants,
    )


@njit(**NO_REFCOUNT_INLINE)
def linearize(ws, slot, P):
    """Linearise the configuration ``ws.q[slot]``: ``(cos, sin)``, ``Jηq``, LU of ``Jηφ``, ``Jqθ``.

    Returns False at a gain-type singularity (``Jηφ`` singular to working precision).
    """
    sc = ws.sincos[slot]
    angle_sincos(ws.q[slot], sc)
    constraint_jacobian_from_sincos(sc, P, ws.jac[slot])
    ok, det = closed_chain.lu_factor(ws.jac[slot, :, 3:], ws.lu[slot], ws.piv[slot], 4)
    ws.det[slot] = det
    if ok:
        closed_chain.actuated_jacobian_from_lu(ws.jac[slot], ws.lu[slot], ws.piv[slot], ws.j_q_theta[slot])
    return ok


@njit(**NO_REFCOUNT_INLINE)
def correct_passive(ws, slot, P, max_iter):
    """Newton's method on ``η(θ, φ) = 0`` for the passive coordinates of ``ws.q[slot]``, ``θ`` fixed.

    Converged when ``max |η|`` is at round-off level (a few ulps of the mechanism's reach) or
    the last Newton step was below 1e-15 rad; the slot is then linearised at the converged
    configuration (the last residual evaluation doubles as the linearisation). Returns the status.
    """
    q, sc, jac, lu, piv, eta = ws.q[slot], ws.sincos[slot], ws.jac[slot], ws.lu[slot], ws.piv[slot], ws.eta
    tiny_step = False
    for it in range(max_iter + 1):
        angle_sincos(q, sc, 0 if it == 0 else N_ACTIVE)  # θ is fixed: its sines once
        residual = constraints_from_sincos(sc, P, eta)
        constraint_jacobian_from_sincos(sc, P, jac)
        ok, det = closed_chain.lu_factor(jac[:, 3:], lu, piv, 4)
        ws.det[slot] = det
        if not ok:
            return SINGULAR
        if residual <= ws.constants[_ETA_TOL] or tiny_step:
            closed_chain.actuated_jacobian_from_lu(jac, lu, piv, ws.j_q_theta[slot])
            return OK
        if it == max_iter or not math.isfinite(residual):
            break
        for k in range(4):
            eta[k] = -eta[k]
        closed_chain.lu_solve_factored(lu, piv, eta, 4)
        step = 0.0
        for k in range(4):
            q[3 + k] += eta[k]
            step = max(step, abs(eta[k]))
        if not math.isfinite(step) or step > 1.0:
            return NOT_CONVERGED
        tiny_step = step <= 1e-15
    return NOT_CONVERGED


# ------------------------------------------------------------------ dynamics (paper §3)
N_BODIES = 7  # active links 1-3, passive links 1-3, platform


@njit(cache=True)
def body_description(P):
    """The bodies as sums of rotating vectors, for :func:`pkmlab.numerics.lagrangian.rotating_vector_bodies`.

    Mass centres: active link ``i``: ``b_i + R(θ_i) c_li``; passive link ``i``:
    ``b_i + l_i u(θ_i) + R(φ_i) c_ri``; platform (reached through leg 1, as ``p`` of eq. 13):
    ``b_1 + l_1 u(θ_1) + r_1 u(φ_1) + R(α) c_a``. Returns ``(term_body, term_coord, term_vec,
    body_angle, D)`` with ``D[b] = (m_b, m_b, I_b)``.
    """
    term_body = np.array([0, 1, 2, 3, 3, 4, 4, 5, 5, 6, 6, 6])
    term_coord = np.array([0, 1, 2, 0, 3, 1, 4, 2, 5, 0, 3, 6])
    term_vec = np.zeros((12, 2))
    D = np.empty((N_BODIES, 3))
    for i in range(3):
        term_vec[i, 0] = P[ACTIVE_COM + 2 * i]
        term_vec[i, 1] = P[ACTIVE_COM + 2 * i + 1]
        term_vec[3 + 2 * i, 0] = P[ACTIVE_LENGTH + i]
        term_vec[4 + 2 * i, 0] = P[PASSIVE_COM + 2 * i]
        term_vec[4 + 2 * i, 1] = P[PASSIVE_COM + 2 * i + 1]
        D[i, 0] = D[i, 1] = P[ACTIVE_MASS + i]
        D[i, 2] = P[ACTIVE_INERTIA + i]
        D[3 + i, 0] = D[3 + i, 1] = P[PASSIVE_MASS + i]
        D[3 + i, 2] = P[PASSIVE_INERTIA + i]
    term_vec[9, 0] = P[ACTIVE_LENGTH]
    term_vec[10, 0] = P[PASSIVE_LENGTH]
    term_vec[11, 0] = P[PLATFORM_COM]
    term_vec[11, 1] = P[PLATFORM_COM + 1]
    D[6, 0] = D[6, 1] = P[PLATFORM_MASS]
    D[6, 2] = P[PLATFORM_INERTIA]
    body_angle = np.arange(N_BODIES)
    return term_body, term_coord, term_vec, body_angle, D


@njit(cache=True)
def bodies(q, q_dot, P, with_partials):
    """Body Jacobians ``J`` (7, 3, 7), partials ``H`` (7, 7, 3, 7) or empty, ``J̇q̇`` and ``D``."""
    term_body, term_coord, term_vec, body_angle, D = body_description(P)
    J = np.empty((N_BODIES, 3, 7))
    H = np.empty((N_BODIES if with_partials else 0, 7, 3, 7))
    bias = np.empty((N_BODIES, 3))
    lagrangian.rotating_vector_bodies(q, q_dot, N_BODIES, term_body, term_coord, term_vec, body_angle, J, H, bias)
    return J, H, bias, D


@njit(cache=True)
def constraint_jacobian_rate(q, q_dot, P, out):
    """Write ``J̇ηq`` (4, 7): column ``j`` of ``Jηq`` is ``R(q_j + π/2) v``, so its rate is that
    column turned by a further ``π/2`` and scaled by ``q̇_j``."""
    constraint_jacobian(q, P, out)
    for j in range(7):
        for r in (0, 2):
            x, y = out[r, j], out[r + 1, j]
            out[r, j] = -y * q_dot[j]
            out[r + 1, j] = x * q_dot[j]


@njit(**NO_REFCOUNT_INLINE)
def evaluate_velocities(ws, slot, theta_dot, P):
    """``q̇ = Jqθ θ̇`` (eq. 31) and ``J̇qθ θ̇`` (from eq. 32) at the linearised ``slot``, into ``ws.q_dot``,
    ``ws.bias_q``."""
    jqt, q_dot, bias_q = ws.j_q_theta[slot], ws.q_dot, ws.bias_q
    for i in range(7):
        q_dot[i] = jqt[i, 0] * theta_dot[0] + jqt[i, 1] * theta_dot[1] + jqt[i, 2] * theta_dot[2]
    constraint_convective_from_sincos(ws.sincos[slot], q_dot, P, ws.eta)
    closed_chain.passive_acceleration_bias_from_lu(ws.lu[slot], ws.piv[slot], ws.eta)
    bias_q[0] = bias_q[1] = bias_q[2] = 0.0
    for k in range(4):
        bias_q[3 + k] = ws.eta[k]


@njit(cache=True)
def full_dynamics(q, q_dot, tau, P, stabilization):
    """``(q̈, λ, ok)`` of the full 7-coordinate model with multipliers (eq. 26), actuated torques ``τ`` (3,).

    With ``stabilization = ω > 0`` the constraint is imposed at acceleration level as
    ``η̈ + 2ω η̇ + ω² η = 0`` (Baumgarte), so that drift off the manifold decays instead of
    growing during integration; on the manifold (``η = η̇ = 0``) nothing changes.
    """
    jac = np.empty((4, 7))
    constraint_jacobian(q, P, jac)
    gamma = np.empty(4)
    constraint_convective(q, q_dot, P, gamma)
    if stabilization > 0.0:
        eta = np.empty(4)
        constraints(q, P, eta)
        eta_dot = jac @ q_dot
        for k in range(4):
            gamma[k] += 2.0 * stabilization * eta_dot[k] + stabilization * stabilization * eta[k]
    J, _H, body_bias, D = bodies(q, q_dot, P, False)
    M = lagrangian.mass_matrix(J, D)
    h = lagrangian.velocity_product(J, D, body_bias)
    tau_q = np.zeros(7)
    tau_q[:3] = tau
    return lagrangian.constrained_accelerations(M, h, jac, gamma, tau_q)


@njit(cache=True)
def kinetic_energy(q, q_dot, P):
    """``T = ½ q̇ᵀ M q̇`` (eq. 20)."""
    J, _H, _b, D = bodies(q, q_dot, P, False)
    M = lagrangian.mass_matrix(J, D)
    return 0.5 * (q_dot @ (M @ q_dot))
