"""Mechanism-agnostic algorithms of closed-chain (parallel) mechanisms.

A mechanism is described by its coordinates ``q = (θ, φ)`` — the ``n_a`` actuated ones first,
then the ``m`` passive ones — its loop-closure constraints ``η(q) = 0`` (``m`` equations),
and its bodies. Everything in this module works on the matrices a mechanism provides:

* ``J_eta_q = ∂η/∂q`` (``m × n``), split into ``Jηθ`` (first ``n_a`` columns) and ``Jηφ``;
* ``gamma = J̇ηq·q̇``, the convective term of the constraints' second derivative.

These are the paper's equations (15), (31) and (32), valid for any parallel manipulator
whose passive coordinates are locally determined by the actuated ones (``det Jηφ ≠ 0``).
All functions are compiled with Numba and take single configurations; the public API in
:mod:`pkmlab.paper.kinematics` broadcasts them over batches.
"""

from __future__ import annotations

import numpy as np

from .._compile_cache import NO_REFCOUNT, NO_REFCOUNT_INLINE, njit

# The dense kernels below take the system's size ``m`` as an argument, and the solves are inlined: a
# caller that passes a constant (a generated structure's size) gets loops of known trip count, which the
# compiler unrolls, keeping the small system in registers (measured on a 4x4 system: the three solves of
# Jqθ 2.5x faster than with the size read from the array's shape at run time). The factorization is
# not inlined: unrolled, its pivot search and row swaps were measured slower (140 ns against 94 ns).


@njit(**NO_REFCOUNT)
def lu_factor(a, lu, piv, m):
    """Factor ``P a = L U`` by Gaussian elimination with partial pivoting, into ``lu`` and ``piv``.

    ``a`` (m, m) is left unchanged (it may be a view, e.g. the passive columns of ``Jηq``);
    ``lu`` (m, m) receives ``L`` (unit diagonal, below) and ``U`` (above the diagonal), with
    ``1 / U_kk`` on the diagonal so that solves need no division; ``piv`` (m,) the row swapped
    with row ``k`` at step ``k``. Returns ``(ok, det)``; ``ok`` is
    False when a pivot is below ``1e-14 max|a|`` (singular to working precision). Allocates
    nothing: this is the workhorse of the simulation loop.
    """
    scale = 0.0
    for i in range(m):
        for j in range(m):
            lu[i, j] = a[i, j]
            scale = max(scale, abs(a[i, j]))
    det = 1.0
    ok = scale > 0.0
    for col in range(m):
        p = col
        for row in range(col + 1, m):
            if abs(lu[row, col]) > abs(lu[p, col]):
                p = row
        piv[col] = p
        if abs(lu[p, col]) <= 1e-14 * scale or lu[p, col] == 0.0:
            return False, 0.0
        if p != col:
            det = -det
            for j in range(m):
                lu[col, j], lu[p, j] = lu[p, j], lu[col, j]
        det *= lu[col, col]
        inv = 1.0 / lu[col, col]
        for row in range(col + 1, m):
            f = lu[row, col] * inv
            lu[row, col] = f
            if f != 0.0:
                for j in range(col + 1, m):
                    lu[row, j] -= f * lu[col, j]
        lu[col, col] = inv
    return ok, det


@njit(**NO_REFCOUNT_INLINE)
def lu_solve_factored(lu, piv, b, m):
    """Overwrite ``b`` (m,) with ``a⁻¹ b`` from the factors of :func:`lu_factor`."""
    for col in range(m):  # the row interchanges first (they also reordered the stored multipliers)
        p = piv[col]
        if p != col:
            b[col], b[p] = b[p], b[col]
    for col in range(m):
        for row in range(col + 1, m):
            b[row] -= lu[row, col] * b[col]
    for col in range(m - 1, -1, -1):
        acc = b[col]
        for c in range(col + 1, m):
            acc -= lu[col, c] * b[c]
        b[col] = acc * lu[col, col]  # the diagonal holds 1 / U_kk


@njit(**NO_REFCOUNT_INLINE)
def lu_solve_factored_matrix(lu, piv, b, m, k):
    """Overwrite ``b`` (m, k) with ``a⁻¹ b`` from the factors of :func:`lu_factor`, all columns at once."""
    for col in range(m):
        p = piv[col]
        if p != col:
            for j in range(k):
                b[col, j], b[p, j] = b[p, j], b[col, j]
    for col in range(m):
        for row in range(col + 1, m):
            f = lu[row, col]
            for j in range(k):
                b[row, j] -= f * b[col, j]
    for col in range(m - 1, -1, -1):
        inv = lu[col, col]  # the diagonal holds 1 / U_kk
        for j in range(k):
            acc = b[col, j]
            for c in range(col + 1, m):
                acc -= lu[col, c] * b[c, j]
            b[col, j] = acc * inv


@njit(**NO_REFCOUNT)
def ldlt_solve(a, work, b):
    """Overwrite ``b`` (m,) with ``a⁻¹ b`` for a symmetric positive-definite ``a`` (m, m), by ``L D Lᵀ``.

    For mass matrices: no pivoting and no square roots, about half the work of an LU.
    ``work`` (m, m) receives ``L`` below its diagonal and ``D`` on it. Returns False (``b``
    then meaningless) when a pivot of ``D`` is not above ``1e-14`` times its diagonal entry:
    ``a`` is not positive definite to working precision.
    """
    m = a.shape[0]
    for j in range(m):
        d = a[j, j]
        for k in range(j):
            d -= work[j, k] * work[j, k] * work[k, k]
        if not d > 1e-14 * abs(a[j, j]):
            return False
        work[j, j] = d
        inv = 1.0 / d
        for i in range(j + 1, m):
            acc = a[i, j]
            for k in range(j):
                acc -= work[i, k] * work[j, k] * work[k, k]
            work[i, j] = acc * inv
    for i in range(m):  # L y = b
        for k in range(i):
            b[i] -= work[i, k] * b[k]
    for i in range(m):  # D z = y
        b[i] /= work[i, i]
    for i in range(m - 1, -1, -1):  # Lᵀ x = z
        for k in range(i + 1, m):
            b[i] -= work[k, i] * b[k]
    return True


@njit(cache=True)
def lu_solve(a, b):
    """Solve ``a x = b`` for small dense systems; ``a`` (m, m), ``b`` (m, k), both left unchanged.

    Returns ``(x, ok)``; ``ok`` is False when ``a`` is singular to working precision (see
    :func:`lu_factor`), and ``x`` is then meaningless.
    """
    m = a.shape[0]
    lu = np.empty((m, m))
    piv = np.empty(m, np.int64)
    x = b.copy()
    ok, _det = lu_factor(a, lu, piv, m)
    if ok:
        col = np.empty(m)
        for j in range(b.shape[1]):
            for i in range(m):
                col[i] = b[i, j]
            lu_solve_factored(lu, piv, col, m)
            for i in range(m):
                x[i, j] = col[i]
    return x, ok


@njit(cache=True)
def determinant(a):
    """Determinant of a small square matrix (from its LU factors; 0 when singular to working precision)."""
    m = a.shape[0]
    _ok, det = lu_factor(a, np.empty((m, m)), np.empty(m, np.int64), m)
    return det


@njit(**NO_REFCOUNT)
def actuated_jacobian_from_lu(j_eta_q, lu, piv, out):
    """Write ``Jqθ = [I; Jφθ]`` (eq. 31), ``Jφθ = -Jηφ⁻¹ Jηθ`` (eq. 15), into ``out`` (n, n_a).

    ``lu``, ``piv`` are the factors of ``Jηφ`` from :func:`lu_factor`; ``n_a = out.shape[1]``.
    """
    n_active = out.shape[1]
    for i in range(n_active):
        for col in range(n_active):
            out[i, col] = 1.0 if i == col else 0.0
    for k in range(j_eta_q.shape[0]):
        for col in range(n_active):
            out[n_active + k, col] = -j_eta_q[k, col]
    lu_solve_factored_matrix(lu, piv, out[n_active:, :], j_eta_q.shape[0], n_active)


@njit(**NO_REFCOUNT)
def passive_acceleration_bias_from_lu(lu, piv, gamma):
    """Overwrite ``gamma = J̇ηq q̇`` with ``J̇φθ θ̇ = -Jηφ⁻¹ (J̇ηq q̇)``: passive accelerations when ``θ̈ = 0``.

    Differentiating ``Jηq q̇ = 0`` (eq. 32) gives ``Jηφ φ̈ = -Jηθ θ̈ - J̇ηq q̇``, hence
    ``φ̈ = Jφθ θ̈ + J̇φθ θ̇``. ``lu``, ``piv`` are the factors of ``Jηφ`` from :func:`lu_factor`.
    """
    for k in range(gamma.shape[0]):
        gamma[k] = -gamma[k]
    lu_solve_factored(lu, piv, gamma, gamma.shape[0])


@njit(cache=True)
def actuated_jacobian(j_eta_q, n_active):
    """``Jqθ = [I; Jφθ]`` (eq. 31) as a new ``(n, n_a)`` array, and ``ok`` (False when ``det Jηφ = 0``)."""
    m = j_eta_q.shape[0]
    lu = np.empty((m, m))
    piv = np.empty(m, np.int64)
    out = np.zeros((j_eta_q.shape[1], n_active))
    ok, _det = lu_factor(j_eta_q[:, n_active:], lu, piv, m)
    if ok:
        actuated_jacobian_from_lu(j_eta_q, lu, piv, out)
    return out, ok


@njit(cache=True)
def passive_jacobian(j_eta_q, n_active):
    """``Jφθ = -Jηφ⁻¹ Jηθ`` (eq. 15): passive rates per unit actuated rate, ``(m, n_a)``, and ``ok``."""
    out, ok = actuated_jacobian(j_eta_q, n_active)
    return out[n_active:].copy(), ok
