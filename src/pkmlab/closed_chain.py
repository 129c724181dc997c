"""Mechanism-agnostic algorithms of closed-chain (parallel) mechanisms.

A mechanism is described by its coordinates ``q = (θ, φ)`` — the ``n_a`` actuated ones first,
then the ``m`` passive ones — its loop-closure constraints ``η(q) = 0`` (``m`` equations),
and its bodies. Everything in this module works on the matrices a mechanism provides:

* ``J_eta_q = ∂η/∂q`` (``m × n``), split into ``Jηθ`` (first ``n_a`` columns) and ``Jηφ``;
* ``gamma = J̇ηq·q̇``, the convective term of the constraints' second derivative.

These are the paper's equations (15), (31) and (32), valid for any parallel manipulator
whose passive coordinates are locally determined by the actuated ones (``det Jηφ ≠ 0``).
All functions are compiled with Numba and take single configurations; the public API in
:mod:`pkmlab.kinematics` broadcasts them over batches.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def lu_solve(a, b):
    """Solve ``a x = b`` by Gaussian elimination with partial pivoting (small dense systems).

    ``a`` is ``(m, m)``, ``b`` is ``(m, k)``; both are left unchanged. Returns ``(x, ok)``;
    ``ok`` is False when a pivot vanishes (``a`` singular), and ``x`` is then meaningless.
    Cheaper than LAPACK for the 4×4 systems of a planar mechanism, and allocation-light.
    """
    m = a.shape[0]
    k = b.shape[1]
    lu = a.copy()
    x = b.copy()
    scale = 0.0
    for i in range(m):
        for j in range(m):
            scale = max(scale, abs(lu[i, j]))
    if scale == 0.0:
        return x, False
    for col in range(m):
        piv = col
        for row in range(col + 1, m):
            if abs(lu[row, col]) > abs(lu[piv, col]):
                piv = row
        if abs(lu[piv, col]) <= 1e-14 * scale:  # singular to working precision
            return x, False
        if piv != col:
            for j in range(m):
                lu[col, j], lu[piv, j] = lu[piv, j], lu[col, j]
            for j in range(k):
                x[col, j], x[piv, j] = x[piv, j], x[col, j]
        inv = 1.0 / lu[col, col]
        for row in range(col + 1, m):
            f = lu[row, col] * inv
            if f != 0.0:
                for j in range(col, m):
                    lu[row, j] -= f * lu[col, j]
                for j in range(k):
                    x[row, j] -= f * x[col, j]
    for col in range(m - 1, -1, -1):
        inv = 1.0 / lu[col, col]
        for j in range(k):
            acc = x[col, j]
            for c in range(col + 1, m):
                acc -= lu[col, c] * x[c, j]
            x[col, j] = acc * inv
    return x, True


@njit(cache=True)
def determinant(a):
    """Determinant of a small square matrix by Gaussian elimination with partial pivoting."""
    m = a.shape[0]
    lu = a.copy()
    det = 1.0
    for col in range(m):
        piv = col
        for row in range(col + 1, m):
            if abs(lu[row, col]) > abs(lu[piv, col]):
                piv = row
        if lu[piv, col] == 0.0:
            return 0.0
        if piv != col:
            det = -det
            for j in range(m):
                lu[col, j], lu[piv, j] = lu[piv, j], lu[col, j]
        det *= lu[col, col]
        inv = 1.0 / lu[col, col]
        for row in range(col + 1, m):
            f = lu[row, col] * inv
            for j in range(col, m):
                lu[row, j] -= f * lu[col, j]
    return det


@njit(cache=True)
def passive_jacobian(j_eta_q, n_active):
    """``Jφθ = -Jηφ⁻¹ Jηθ`` (eq. 15): passive rates per unit actuated rate, ``(m, n_a)``.

    Returns ``(Jφθ, ok)``; ``ok`` is False at a gain-type singularity (``det Jηφ = 0``).
    """
    j_eta_theta = j_eta_q[:, :n_active]
    j_eta_phi = j_eta_q[:, n_active:]
    x, ok = lu_solve(j_eta_phi, j_eta_theta)
    return -x, ok


@njit(cache=True)
def actuated_jacobian(j_eta_q, n_active):
    """``Jqθ = [I; Jφθ]`` (eq. 31): all coordinate rates per unit actuated rate, ``(n, n_a)``."""
    m, n = j_eta_q.shape
    j_phi_theta, ok = passive_jacobian(j_eta_q, n_active)
    out = np.zeros((n, n_active))
    for i in range(n_active):
        out[i, i] = 1.0
    out[n_active:, :] = j_phi_theta
    return out, ok


@njit(cache=True)
def passive_acceleration_bias(j_eta_q, gamma, n_active):
    """``J̇φθ θ̇ = -Jηφ⁻¹ (J̇ηq q̇)``: passive accelerations when ``θ̈ = 0`` (from eq. 32).

    Differentiating ``Jηq q̇ = 0`` gives ``Jηφ φ̈ = -Jηθ θ̈ - J̇ηq q̇``, hence
    ``φ̈ = Jφθ θ̈ + J̇φθ θ̇`` with the bias returned here. ``gamma = J̇ηq q̇``.
    """
    m = gamma.shape[0]
    rhs = np.empty((m, 1))
    rhs[:, 0] = gamma
    x, ok = lu_solve(j_eta_q[:, n_active:], rhs)
    return -x[:, 0], ok
