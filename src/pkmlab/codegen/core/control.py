"""The compiled core, control: computed torque (eq. 36) and PD efforts from the controller's own model, and their
distribution over the actuators of a redundantly actuated machine.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    import numpy as np

    from pkmlab._compile_cache import NO_REFCOUNT, njit
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import N_ACTUATORS, N_INDEPENDENT

    from .branch_following import accept_trial, actuated_jacobian, factor_passive, follow_branch, keep_base_factors
    from .dynamics import actuator_space_model
    from .workspace import BASE, OK, REDUNDANT, SINGULAR, actuator_component, actuator_error, ldlt_solve

# ==== TEMPLATE
@njit(**NO_REFCOUNT)
def control_effort(kind, kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P,
                   singularity_guard, ws, tau):
    """Efforts ``τ`` of one controller evaluation into ``tau``; returns the status.

    ``kind = 0``, computed torque (eqs. 36–39 with gravity): ``τ = M̂θ v + ĉθ + ĝθ``,
    ``v = θ̈_d - kp e - kv ė``, with the controller's own model (parameters ``P``, workspace ``ws``),
    whose passive coordinates follow the measured ``θ`` by branch following (paper figure 2).
    ``kind = 1``, PD: ``τ = -kp e - kv ė``.

    ``θ`` are the independent coordinates: a redundantly actuated machine's controlled pose, whose generalised
    force is distributed over the actuators by :func:`distribute` (``distribution``).
    """
    n = N_INDEPENDENT
    if kind == 1 and not REDUNDANT:
        for i in range(n):
            tau[i] = -kp * actuator_error(theta, theta_d, i) - kv * (theta_dot[i] - theta_dot_d[i])
        return OK
    status = follow_branch(ws, theta, P, singularity_guard)
    if status != OK:
        return status
    accept_trial(ws)
    if kind == 0:
        return computed_torque(kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws,
                               tau)
    return distributed_pd(kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, P, ws, tau)


@njit(**NO_REFCOUNT)
def distributed_pd(kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, P, ws, tau):
    """PD of a redundantly actuated machine, with the controller's model already at the measured pose
    (``ws.q[BASE]``): the force ``-kp e - kv ė`` on its pose distributed (:func:`distribute`) with ``W`` there;
    returns the status."""
    if not factor_passive(ws, ws.q[BASE], ws.sc[BASE], P):
        return SINGULAR
    actuated_jacobian(ws, ws.j_q_theta)
    keep_base_factors(ws)  # (the next sample's branch following starts from them)
    for i in range(N_INDEPENDENT):
        ws.force[i] = -kp * actuator_error(theta, theta_d, i) - kv * (theta_dot[i] - theta_dot_d[i])
    return OK if distribute(ws, distribution, tau) else SINGULAR


@njit(**NO_REFCOUNT)
def computed_torque(kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws, tau):
    """The computed-torque law of :func:`control_effort` with the controller's model already at the measured
    ``theta`` (``ws.q[BASE]``); returns the status."""
    n = N_INDEPENDENT
    if not actuator_space_model(ws, ws.q[BASE], ws.sc[BASE], theta_dot, P):
        return SINGULAR
    keep_base_factors(ws)
    for i in range(n):  # v, kept in theta_ddot
        ws.theta_ddot[i] = (theta_ddot_d[i] - kp * actuator_error(theta, theta_d, i)
                            - kv * (theta_dot[i] - theta_dot_d[i]))
    for i in range(n):
        acc = ws.c_theta[i] + ws.g_theta[i]
        for j in range(n):
            acc += ws.m_theta[i, j] * ws.theta_ddot[j]
        ws.force[i] = acc
    return OK if distribute(ws, distribution, tau) else SINGULAR


@njit(**NO_REFCOUNT)
def distribute(ws, distribution, tau):
    """The actuators' efforts ``tau`` that exert ``ws.force``, the generalised force on the independent coordinates;
    returns ok (False: ``W`` is rank-deficient, an actuation singularity).

    With as many actuators as independent coordinates, ``τ = f``. A redundantly actuated machine's satisfy
    ``Wᵀ τ = f`` (``W = ∂θ/∂x``, the actuators' rows of ``ws.j_q_theta``, the last model's) nearest a preload in a
    weighted 2-norm: ``min (τ - τp)ᵀ D (τ - τp)``, that is ``τ = τp + D⁻¹ W (Wᵀ D⁻¹ W)⁻¹ (f - Wᵀ τp)``. The
    rows of ``distribution`` (4, N_ACTUATORS) are ``D``'s diagonal, ``τp``, the effort limits ``|τ_i| <= L_i``
    (``inf``: none) and the rule's flag (1 for the least peak ``max |τ_i|``, 0 for the 2-norm rules): ones and
    zeros give the minimum 2-norm (the pseudo-inverse's efforts), zeros in the second row a weighted minimum norm,
    ones in the first the minimum norm plus the preload's internal part (:func:`pkmlab.distribute_efforts`'
    methods). With one internal effort (``N_ACTUATORS = N_INDEPENDENT + 1``) the least peak is exact
    (:func:`least_peak`) and the limits are respected exactly where they can be (:func:`within_limits`); with more,
    only the 2-norm rules apply (a run refuses the least peak and effort limits for such a machine).
    """
    n = N_INDEPENDENT
    if not REDUNDANT:
        for i in range(n):
            tau[i] = ws.force[i]
        return True
    for i in range(n):  # f - Wᵀ τp and Wᵀ D⁻¹ W
        acc = ws.force[i]
        for a in range(N_ACTUATORS):
            acc -= ws.j_q_theta[a, i] * distribution[1, a]
        ws.force[i] = acc
        for j in range(i, n):
            acc = 0.0
            for a in range(N_ACTUATORS):
                acc += ws.j_q_theta[a, i] * ws.j_q_theta[a, j] / distribution[0, a]
            ws.normal[i, j] = acc
            ws.normal[j, i] = acc
    if not ldlt_solve(ws.normal, ws.normal_ldl, ws.force):
        return False
    for a in range(N_ACTUATORS):
        tau[a] = distribution[1, a] + actuator_component(ws, a, ws.force) / distribution[0, a]
    if N_ACTUATORS == n + 1:
        if distribution[3, 0] > 0.0:
            least_peak(ws, distribution, tau)
        else:
            within_limits(ws, distribution, tau)
    return True


@njit(**NO_REFCOUNT)
def internal_effort(ws, distribution):
    """The row of ``ws.internal`` that holds the machine's one internal effort ``u`` (``Wᵀ u = 0``), after
    :func:`distribute`: the column of the projector ``I - D⁻¹ W (Wᵀ D⁻¹ W)⁻¹ Wᵀ`` of the largest norm (every
    column is a multiple of ``u``; the largest is the best conditioned); -1 where the projector is zero."""
    n = N_INDEPENDENT
    best, best_norm = -1, 0.0
    for j in range(N_ACTUATORS):
        for i in range(n):
            ws.force[i] = ws.j_q_theta[j, i]
        ldlt_solve(ws.normal, ws.normal_ldl, ws.force)
        norm = 0.0
        for a in range(N_ACTUATORS):
            value = (1.0 if a == j else 0.0) - actuator_component(ws, a, ws.force) / distribution[0, a]
            ws.internal[j, a] = value
            norm += value * value
        if norm > best_norm:
            best, best_norm = j, norm
    return best


@njit(**NO_REFCOUNT)
def limits_interval(ws, best, distribution, tau):
    """``(low, high)``: the steps ``s`` along the internal effort (``ws.internal[best]``) for which ``τ + s u``
    holds every effort limit (``distribution[2]``); ``low > high`` where none does."""
    low, high = -np.inf, np.inf
    for a in range(N_ACTUATORS):
        u, limit = ws.internal[best, a], distribution[2, a]
        if limit == np.inf:
            continue
        if u == 0.0:
            if abs(tau[a]) > limit:
                return np.inf, -np.inf
            continue
        s1, s2 = (-limit - tau[a]) / u, (limit - tau[a]) / u
        low, high = max(low, min(s1, s2)), min(high, max(s1, s2))
    return low, high


@njit(**NO_REFCOUNT)
def within_limits(ws, distribution, tau):
    """Move the efforts ``tau`` of :func:`distribute` (one internal effort) along it into their limits
    (``distribution[2]``) where they can be: ``τ + s u``, ``u`` the internal effort (``Wᵀ u = 0``), ``s`` the
    point of the interval every limit allows nearest 0 — the distribution's own objective is a convex quadratic
    in ``s`` least at 0, so that point is the least-objective efforts within the limits. Where no ``s`` holds every
    limit, the efforts are left as they are (the drives saturate them; a run whose desired motion needs that is
    refused before it starts)."""
    limited = False
    for a in range(N_ACTUATORS):
        limited = limited or distribution[2, a] != np.inf
    if not limited:
        return
    best = internal_effort(ws, distribution)
    if best < 0:
        return
    low, high = limits_interval(ws, best, distribution, tau)
    if low > high or (low <= 0.0 <= high):
        return
    s = low if low > 0.0 else high
    for a in range(N_ACTUATORS):
        tau[a] += s * ws.internal[best, a]


@njit(**NO_REFCOUNT)
def peak_at(ws, best, tau, s):
    """``max |τ_a + s u_a|``, the peak effort a step ``s`` along the internal effort ``u`` gives."""
    peak = 0.0
    for a in range(N_ACTUATORS):
        peak = max(peak, abs(tau[a] + s * ws.internal[best, a]))
    return peak


@njit(**NO_REFCOUNT)
def least_peak(ws, distribution, tau):
    """The efforts of least ``max |τ_a|`` (``τ + s u`` from the minimum-norm ``tau`` of :func:`distribute`, ``u``
    the one internal effort), within the effort limits where they can be held: the linear program of
    :func:`pkmlab.distribute_efforts`' ``minimum_peak`` in one unknown, solved exactly. The peak is a convex
    piecewise-linear function of ``s``, least at one of its breakpoints, where two efforts are equal or opposite
    (``τ_a + s u_a = ±(τ_b + s u_b)``), or at an end of the limits' interval: every one is tried."""
    best = internal_effort(ws, distribution)
    if best < 0:
        return
    low, high = limits_interval(ws, best, distribution, tau)
    if low > high:  # no efforts hold the limits (refused before a run whose desired motion needs that)
        low, high = -np.inf, np.inf
    s_best = min(max(0.0, low), high)
    peak_best = peak_at(ws, best, tau, s_best)
    for side in range(2):
        s = low if side == 0 else high
        if s != -np.inf and s != np.inf:
            peak = peak_at(ws, best, tau, s)
            if peak < peak_best:
                s_best, peak_best = s, peak
    for a in range(N_ACTUATORS):
        for b in range(a + 1, N_ACTUATORS):
            for sign in (-1.0, 1.0):
                slope = ws.internal[best, a] - sign * ws.internal[best, b]
                if slope == 0.0:
                    continue
                s = -(tau[a] - sign * tau[b]) / slope
                if low <= s <= high:
                    peak = peak_at(ws, best, tau, s)
                    if peak < peak_best:
                        s_best, peak_best = s, peak
    for a in range(N_ACTUATORS):
        tau[a] += s_best * ws.internal[best, a]
