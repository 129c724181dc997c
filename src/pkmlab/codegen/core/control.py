"""The compiled core, control: computed torque (eq. 36) and PD efforts from the controller's own model, and their
distribution over the actuators of a redundantly actuated machine.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    from pkmlab._compile_cache import NO_REFCOUNT, njit
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import N_ACTUATORS, N_INDEPENDENT

    from .branch_following import accept_trial, actuated_jacobian, factor_passive, follow_branch, keep_base_factors
    from .dynamics import actuator_space_model
    from .workspace import BASE, OK, REDUNDANT, SINGULAR, actuator_error, ldlt_solve

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
    rows of ``distribution`` (2, N_ACTUATORS) are ``D``'s diagonal and ``τp``: ones and zeros give the minimum
    2-norm (the pseudo-inverse's efforts), zeros in the second row a weighted minimum norm, ones in the first the
    minimum norm plus the preload's internal part (:func:`pkmlab.distribute_efforts`' methods).
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
        acc = 0.0
        for i in range(n):
            acc += ws.j_q_theta[a, i] * ws.force[i]
        tau[a] = distribution[1, a] + acc / distribution[0, a]
    return True
