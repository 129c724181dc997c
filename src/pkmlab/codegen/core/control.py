"""The compiled core, control: computed torque (eq. 36) and PD efforts from the controller's own model.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    from pkmlab._compile_cache import NO_REFCOUNT, njit
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import N_ACTUATORS

    from .branch_following import accept_trial, follow_branch, keep_base_factors
    from .dynamics import actuator_space_model
    from .workspace import BASE, OK, SINGULAR, actuator_error

# ==== TEMPLATE
@njit(**NO_REFCOUNT)
def control_effort(kind, kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, singularity_guard, ws, tau):
    """Efforts ``τ`` of one controller evaluation into ``tau``; returns the status.

    ``kind = 0``, computed torque (eqs. 36–39 with gravity): ``τ = M̂θ v + ĉθ + ĝθ``,
    ``v = θ̈_d - kp e - kv ė``, with the controller's own model (parameters ``P``, workspace ``ws``),
    whose passive coordinates follow the measured ``θ`` by branch following (paper figure 2).
    ``kind = 1``, PD: ``τ = -kp e - kv ė``.
    """
    n = N_ACTUATORS
    if kind == 1:
        for i in range(n):
            tau[i] = -kp * actuator_error(theta, theta_d, i) - kv * (theta_dot[i] - theta_dot_d[i])
        return OK
    status = follow_branch(ws, theta, P, singularity_guard)
    if status != OK:
        return status
    accept_trial(ws)
    return computed_torque(kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws, tau)


@njit(**NO_REFCOUNT)
def computed_torque(kp, kv, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws, tau):
    """The computed-torque law of :func:`control_effort` with the controller's model already at the measured
    ``theta`` (``ws.q[BASE]``); returns the status."""
    n = N_ACTUATORS
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
        tau[i] = acc
    return OK
