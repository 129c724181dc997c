"""Mechanism-agnostic constrained Lagrangian dynamics (paper §3, eqs. 20–35).

A mechanism's bodies are described, for the dynamics, by

* ``J`` (nb, 3, n): for each body the Jacobian of its mass-centre velocity (rows 0, 1)
  and of its angular velocity (row 2) with respect to ``q̇`` (eqs. 21–22);
* ``H`` (nb, n, 3, n): the partial derivatives ``∂J/∂q_k`` (for the Christoffel symbols);
* ``bias`` (nb, 3): ``J̇ q̇``, the mass centres' (and rotations') accelerations when ``q̈ = 0``;
* ``D`` (nb, 3): ``(m, m, I)`` per body, with ``I`` about the body's own mass centre.

Planar bodies whose mass centre is a sum of rotating vectors ``R(q_j) v`` in absolute angles
(every planar linkage with revolute joints) get all three from :func:`rotating_vector_bodies`.
Everything else here is the paper's algebra, valid for any such mechanism. Functions are
compiled with Numba and act on one configuration.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile_cache import njit
from . import closed_chain


# ------------------------------------------------------------------ planar bodies
@njit(cache=True)
def rotating_vector_bodies(q, q_dot, n_bodies, term_body, term_coord, term_vec, body_angle, J, H, bias):
    """Fill ``J``, ``H`` and ``bias`` for bodies whose mass centre is ``x_b = c_b + Σ R(q_j) v``.

    Term ``t`` adds ``R(q[term_coord[t]]) term_vec[t]`` to body ``term_body[t]``; body ``b``
    rotates with coordinate ``body_angle[b]``. For such a term, ``∂x/∂q_j = R(q_j + π/2) v``,
    ``∂²x/∂q_j² = -R(q_j) v`` and no mixed second derivative exists, so ``J̇q̇`` is the sum of
    the centripetal terms ``-R(q_j) v q̇_j²``. ``H`` may be ``None``-sized (0 bodies) to skip it.
    """
    J[:, :, :] = 0.0
    bias[:, :] = 0.0
    want_h = H.shape[0] > 0
    if want_h:
        H[:, :, :, :] = 0.0
    for t in range(term_body.shape[0]):
        b, j = term_body[t], term_coord[t]
        c, s = math.cos(q[j]), math.sin(q[j])
        vx, vy = term_vec[t, 0], term_vec[t, 1]
        rx, ry = c * vx - s * vy, s * vx + c * vy  # R(q_j) v
        J[b, 0, j] -= ry
        J[b, 1, j] += rx
        w2 = q_dot[j] * q_dot[j]
        bias[b, 0] -= rx * w2
        bias[b, 1] -= ry * w2
        if want_h:
            H[b, j, 0, j] -= rx
            H[b, j, 1, j] -= ry
    for b in range(n_bodies):
        J[b, 2, body_angle[b]] = 1.0


# ------------------------------------------------------------------ full-space model
@njit(cache=True)
def mass_matrix(J, D):
    """``M = Σ_b J_bᵀ diag(m_b, m_b, I_b) J_b`` (eq. 23)."""
    n = J.shape[2]
    M = np.zeros((n, n))
    for b in range(J.shape[0]):
        for r in range(3):
            w = D[b, r]
            for i in range(n):
                ji = J[b, r, i]
                if ji != 0.0:
                    for k in range(n):
                        M[i, k] += w * ji * J[b, r, k]
    return M


@njit(cache=True)
def velocity_product(J, D, bias):
    """``C(q, q̇) q̇`` computed directly: ``Σ_b J_bᵀ diag(m_b, m_b, I_b) (J̇_b q̇)``.

    Equal to eq. (24)'s Christoffel form times ``q̇`` because every row of ``J_b`` is the
    Jacobian of a position or an angle (``d/dt ∂v/∂q̇ = ∂v/∂q``).
    """
    n = J.shape[2]
    h = np.zeros(n)
    for b in range(J.shape[0]):
        for r in range(3):
            f = D[b, r] * bias[b, r]
            if f != 0.0:
                for i in range(n):
                    h[i] += J[b, r, i] * f
    return h


@njit(cache=True)
def mass_matrix_partials(J, H, D):
    """``dM[k] = ∂M/∂q_k = Σ_b H_bkᵀ D_b J_b + J_bᵀ D_b H_bk``, shape (n, n, n)."""
    n = J.shape[2]
    dM = np.zeros((n, n, n))
    for b in range(J.shape[0]):
        for k in range(n):
            for r in range(3):
                w = D[b, r]
                for i in range(n):
                    hi = H[b, k, r, i]
                    if hi != 0.0:
                        for j in range(n):
                            v = w * hi * J[b, r, j]
                            dM[k, i, j] += v
                            dM[k, j, i] += v
    return dM


@njit(cache=True)
def christoffel_matrix(dM, q_dot):
    """``C_ij = ½ Σ_k (∂M_ij/∂q_k + ∂M_ik/∂q_j - ∂M_kj/∂q_i) q̇_k`` (eq. 24)."""
    n = q_dot.shape[0]
    C = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for k in range(n):
                acc += (dM[k, i, j] + dM[j, i, k] - dM[i, k, j]) * q_dot[k]
            C[i, j] = 0.5 * acc
    return C


@njit(cache=True)
def constrained_accelerations(M, h, j_eta_q, gamma, tau):
    """``q̈`` and ``λ`` of ``M q̈ + C q̇ = τ + Jηqᵀ λ`` with ``Jηq q̈ + J̇ηq q̇ = 0`` (eq. 26).

    Solves the saddle-point system ``[[M, -Jᵀ], [J, 0]] [q̈; λ] = [τ - C q̇; -J̇q̇]``.
    ``λ`` are the loop-closure forces (newtons, for constraints in metres). Returns
    ``(q̈, λ, ok)``.
    """
    n = M.shape[0]
    m = j_eta_q.shape[0]
    A = np.zeros((n + m, n + m))
    rhs = np.zeros((n + m, 1))
    A[:n, :n] = M
    for i in range(m):
        for j in range(n):
            A[j, n + i] = -j_eta_q[i, j]
            A[n + i, j] = j_eta_q[i, j]
        rhs[n + i, 0] = -gamma[i]
    for j in range(n):
        rhs[j, 0] = tau[j] - h[j]
    x, ok = closed_chain.lu_solve(A, rhs)
    return x[:n, 0].copy(), x[n:, 0].copy(), ok


@njit(cache=True)
def lagrange_multipliers(M, h, j_eta_q, gamma, tau):
    """``λ = -(Jηq M⁻¹ Jηqᵀ)⁻¹ (J̇ηq q̇ + Jηq M⁻¹ (τ - C q̇))``: the paper's explicit formula."""
    n = M.shape[0]
    m = j_eta_q.shape[0]
    rhs = np.empty((n, m + 1))
    rhs[:, :m] = j_eta_q.T
    rhs[:, m] = tau - h
    x, ok = closed_chain.lu_solve(M, rhs)  # [M⁻¹ Jᵀ, M⁻¹ (τ - h)]
    S = j_eta_q @ np.ascontiguousarray(x[:, :m])
    b = np.empty((m, 1))
    b[:, 0] = gamma + j_eta_q @ np.ascontiguousarray(x[:, m])
    multipliers, ok2 = closed_chain.lu_solve(S, b)
    return -multipliers[:, 0], ok and ok2


# ------------------------------------------------------------------ actuator space
@njit(cache=True)
def actuator_space_coriolis_matrix(M, C, j_q_theta, j_q_theta_dot):
    """``Cθ = Jqθᵀ (M J̇qθ + C Jqθ)`` (eq. 35) as a matrix."""
    return j_q_theta.T @ (M @ j_q_theta_dot + C @ j_q_theta)
