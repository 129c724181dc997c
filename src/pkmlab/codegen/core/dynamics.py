"""The compiled core, dynamics: the actuator-space model ``Mθ θ̈ + cθ + gθ = τθ`` (eq. 35 with gravity), body by body,
and the accelerations it gives under efforts.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    import numpy as np

    from pkmlab._compile_cache import NO_REFCOUNT, NO_REFCOUNT_PYTHON, NO_WRAPPERS, njit
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import (
        ANGULAR,
        BODY_ROWS,
        DIM,
        GRAVITY_INDEX,
        INERTIA_INDEX,
        JB_BODY,
        JB_COL,
        JB_ROW,
        MASS_INDEX,
        N_BODIES,
        N_CONSTRAINTS,
        N_COORDINATES,
        N_INDEPENDENT,
        N_JB,
        body_bias,
        body_jacobian_values,
        constraint_bias,
        trig,
    )
    from pkmlab.numerics.closed_chain import ldlt_solve

    from .branch_following import actuated_jacobian, factor_passive, passive_solve
    from .workspace import dependent_column, generalised_force, independent_column, make_workspaces

# ==== TEMPLATE
@njit(**NO_REFCOUNT)
def actuator_space_model(ws, q, sc, theta_dot, P):
    """``Mθ``, ``cθ = Cθ θ̇`` and ``gθ = ∂V/∂θ`` of ``Mθ θ̈ + cθ + gθ = τ`` (eq. 35, with gravity) at ``q``
    on the manifold (trig table ``sc``), into ``ws.m_theta``, ``ws.c_theta``, ``ws.g_theta``; returns ok
    (``det Jηφ ≠ 0``).

    Body by body, with ``Jt = J_b Jqθ`` the body's velocity per actuator rate and
    ``a_b = J_b J̇qθ θ̇ + J̇_b q̇`` its acceleration at ``θ̈ = 0``:
    ``Mθ = Σ Jtᵀ D_b Jt``, ``cθ = Σ Jtᵀ D_b a_b``, ``gθ = -Σ m_b Jt_linᵀ g`` (``D_b = diag(m, m, I)``; in
    space :func:`spatial_body_sums`).
    """
    n, N = N_INDEPENDENT, N_COORDINATES
    if not factor_passive(ws, q, sc, P):
        return False
    actuated_jacobian(ws, ws.j_q_theta)
    for i in range(N):
        acc = 0.0
        for j in range(n):
            acc += ws.j_q_theta[i, j] * theta_dot[j]
        ws.q_dot[i] = acc
    constraint_bias(q, sc, ws.q_dot[:], P, ws.gamma[:])
    for k in range(N_CONSTRAINTS):  # φ̈ at θ̈ = 0: -Jηφ⁻¹ J̇ηq q̇ (eq. 32)
        ws.gamma[k] = -ws.gamma[k]
    passive_solve(ws.lu, ws.piv, ws.top, ws.gamma, ws.work)
    for i in range(n):
        ws.bias_q[independent_column(i)] = 0.0
    for k in range(N_CONSTRAINTS):
        ws.bias_q[dependent_column(k)] = ws.gamma[k]
    body_jacobian_values(q, sc, P, ws.jb[:])
    body_bias(q, sc, ws.q_dot[:], P, ws.bb[:])
    for b in range(N_BODIES):
        for r in range(BODY_ROWS):
            for j in range(n):
                ws.jt[b, r, j] = 0.0
    for z in range(N_JB):  # Jt = J_b Jqθ and a_b += J_b J̇qθ θ̇ over the non-zeros of J_b only
        b, r, k, v = JB_BODY[z], JB_ROW[z], JB_COL[z], ws.jb[z]
        for j in range(n):
            ws.jt[b, r, j] += v * ws.j_q_theta[k, j]
        ws.bb[b, r] += v * ws.bias_q[k]
    if ANGULAR == 3:
        spatial_body_sums(ws, theta_dot, P)
        return True
    gx, gy = P[GRAVITY_INDEX[0]], P[GRAVITY_INDEX[1]]
    # each entry summed in a register and stored once (accumulating into the workspace's arrays would
    # load and store at every term: the compiler cannot rule out that they overlap)
    for i in range(n):
        c, g = 0.0, 0.0
        for b in range(N_BODIES):
            mass, inertia = P[MASS_INDEX[b]], P[INERTIA_INDEX[b]]
            c += (mass * (ws.jt[b, 0, i] * ws.bb[b, 0] + ws.jt[b, 1, i] * ws.bb[b, 1])
                  + inertia * ws.jt[b, 2, i] * ws.bb[b, 2])
            g -= mass * (ws.jt[b, 0, i] * gx + ws.jt[b, 1, i] * gy)
        ws.c_theta[i] = c
        ws.g_theta[i] = g
        for j in range(i, n):
            acc = 0.0
            for b in range(N_BODIES):
                mass, inertia = P[MASS_INDEX[b]], P[INERTIA_INDEX[b]]
                acc += (mass * (ws.jt[b, 0, i] * ws.jt[b, 0, j] + ws.jt[b, 1, i] * ws.jt[b, 1, j])
                        + inertia * ws.jt[b, 2, i] * ws.jt[b, 2, j])
            ws.m_theta[i, j] = acc
            ws.m_theta[j, i] = acc
    return True


@njit(**NO_REFCOUNT)
def spatial_body_sums(ws, theta_dot, P):
    """The body sums of :func:`actuator_space_model` for spatial bodies, whose Jacobian rows are the mass
    centre's velocity (3) and the angular velocity in the body's own frame ``ω`` (3), with the inertia
    tensor ``I`` about the mass centre in that frame (6 parameters from ``INERTIA_INDEX``: xx, yy, zz,
    xy, xz, yz): Newton–Euler projected on the actuators,
    ``Mθ = Σ m Jt_vᵀ Jt_v + Jt_ωᵀ I Jt_ω``, ``cθ = Σ m Jt_vᵀ a_v + Jt_ωᵀ (I a_ω + ω × I ω)``,
    ``gθ = -Σ m Jt_vᵀ g``. The gyroscopic term ``ω × I ω`` is what a planar body never has."""
    n = N_INDEPENDENT
    for b in range(N_BODIES):  # the angular rows of bb become I a_ω + ω × I ω
        k = INERTIA_INDEX[b]
        ixx, iyy, izz, ixy, ixz, iyz = P[k], P[k + 1], P[k + 2], P[k + 3], P[k + 4], P[k + 5]
        for j in range(n):  # I Jt_ω, column by column: once, not once per entry of Mθ it enters
            ux, uy, uz = ws.jt[b, 3, j], ws.jt[b, 4, j], ws.jt[b, 5, j]
            ws.inertia_jt[b, 0, j] = ixx * ux + ixy * uy + ixz * uz
            ws.inertia_jt[b, 1, j] = ixy * ux + iyy * uy + iyz * uz
            ws.inertia_jt[b, 2, j] = ixz * ux + iyz * uy + izz * uz
        wx, wy, wz = 0.0, 0.0, 0.0
        for j in range(n):
            wx += ws.jt[b, 3, j] * theta_dot[j]
            wy += ws.jt[b, 4, j] * theta_dot[j]
            wz += ws.jt[b, 5, j] * theta_dot[j]
        hx = ixx * wx + ixy * wy + ixz * wz
        hy = ixy * wx + iyy * wy + iyz * wz
        hz = ixz * wx + iyz * wy + izz * wz
        ax, ay, az = ws.bb[b, 3], ws.bb[b, 4], ws.bb[b, 5]
        ws.bb[b, 3] = ixx * ax + ixy * ay + ixz * az + (wy * hz - wz * hy)
        ws.bb[b, 4] = ixy * ax + iyy * ay + iyz * az + (wz * hx - wx * hz)
        ws.bb[b, 5] = ixz * ax + iyz * ay + izz * az + (wx * hy - wy * hx)
    for i in range(n):
        c, g = 0.0, 0.0
        for b in range(N_BODIES):
            mass = P[MASS_INDEX[b]]
            c += (mass * (ws.jt[b, 0, i] * ws.bb[b, 0] + ws.jt[b, 1, i] * ws.bb[b, 1] + ws.jt[b, 2, i] * ws.bb[b, 2])
                  + ws.jt[b, 3, i] * ws.bb[b, 3] + ws.jt[b, 4, i] * ws.bb[b, 4] + ws.jt[b, 5, i] * ws.bb[b, 5])
            for d in range(DIM):
                g -= mass * ws.jt[b, d, i] * P[GRAVITY_INDEX[d]]
        ws.c_theta[i] = c
        ws.g_theta[i] = g
        for j in range(i, n):
            acc = 0.0
            for b in range(N_BODIES):
                acc += (P[MASS_INDEX[b]] * (ws.jt[b, 0, i] * ws.jt[b, 0, j] + ws.jt[b, 1, i] * ws.jt[b, 1, j]
                                            + ws.jt[b, 2, i] * ws.jt[b, 2, j])
                        + ws.jt[b, 3, i] * ws.inertia_jt[b, 0, j] + ws.jt[b, 4, i] * ws.inertia_jt[b, 1, j]
                        + ws.jt[b, 5, i] * ws.inertia_jt[b, 2, j])
            ws.m_theta[i, j] = acc
            ws.m_theta[j, i] = acc


@njit(cache=True)
def actuator_space_models(qs, theta_dots, P, m_out, c_out, g_out):
    """:func:`actuator_space_model` of every configuration ``qs`` (K, N) and rates ``theta_dots`` (K, n) into
    ``m_out`` (K, n, n), ``c_out`` and ``g_out`` (K, n); returns the first singular one's index, or -1."""
    return _actuator_space_models(make_workspaces(1), qs, theta_dots, P, m_out, c_out, g_out)


@njit(**NO_WRAPPERS)
def _actuator_space_models(workspaces, qs, theta_dots, P, m_out, c_out, g_out):
    ws = workspaces[0]
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        if not actuator_space_model(ws, qs[k], sc, theta_dots[k], P):
            return k
        for i in range(N_INDEPENDENT):  # element by element: an array assigned to a slice compiles its error message
            c_out[k, i] = ws.c_theta[i]
            g_out[k, i] = ws.g_theta[i]
            for j in range(N_INDEPENDENT):
                m_out[k, i, j] = ws.m_theta[i, j]
    return -1


@njit(**NO_REFCOUNT_PYTHON)
def solve_accelerations(ws, tau):
    """``θ̈ = Mθ⁻¹ (τ - cθ - gθ)`` into ``ws.theta_ddot`` from the last :func:`actuator_space_model` (a redundantly
    actuated machine's: ``ẍ = Mx⁻¹ (Wᵀ τ - cx - gx)``, :func:`generalised_force`)."""
    for i in range(N_INDEPENDENT):
        ws.theta_ddot[i] = generalised_force(ws, tau, i) - ws.c_theta[i] - ws.g_theta[i]
    return ldlt_solve(ws.m_theta, ws.ldl, ws.theta_ddot)
