"""The compiled path tracker of :mod:`pkmlab.numerics.homotopy`: a parameter homotopy's paths followed one at a
time, each with its own adaptive step, by a :mod:`straight-line program <pkmlab.numerics.straight_line>` of the
family's system and derivatives.

The program evaluates, from the register file's inputs ``(x, p)`` (``n`` unknowns, then the parameters), the
outputs ``F (n)``, ``∂F/∂x (n, n)`` and ``∂F/∂p (n, k)`` — the derivative along the first ``k`` parameters
only: the ones a homotopy moves (the others, such as a machine's fixed geometry, stay put along a path).

Always compiled, even in a process whose kernels run interpreted (``PKMLAB_INTERPRETED=1``): a straight-line
program interpreted by Python would take seconds per solve.
"""

from __future__ import annotations

import numpy as np

from .. import _compile_cache

if _compile_cache.INTERPRETED:  # this module is compiled all the same (module docstring)
    _compile_cache.configure()
from numba import prange  # noqa: E402

njit = _compile_cache.compiled_njit

#: Relative size of Newton's last correction for a corrector step to be accepted.
TRACK_TOL = 1e-9
#: Largest first Newton correction (relative to |x|) of an accepted corrector step.
FIRST_STEP = 1e-2


@njit(cache=True)
def run_program(code, r):
    """Run the instructions ``code`` (K, 4) on the register file ``r`` in place."""
    for k in range(code.shape[0]):
        op, a, b, d = code[k, 0], code[k, 1], code[k, 2], code[k, 3]
        if op == 0:
            r[d] = r[a] + r[b]
        elif op == 1:
            r[d] = r[a] - r[b]
        elif op == 2:
            r[d] = r[a] * r[b]
        else:
            r[d] = r[a] / r[b]


@njit(cache=True)
def evaluate_rows(code, registers, outputs, x):
    """The outputs of the program at each row of ``x`` (P, inputs): (P, len(outputs))."""
    r = registers.copy()
    out = np.empty((x.shape[0], outputs.shape[0]), dtype=np.complex128)
    for i in range(x.shape[0]):
        r[:x.shape[1]] = x[i]
        run_program(code, r)
        for k in range(outputs.shape[0]):
            out[i, k] = r[outputs[k]]
    return out


@njit(cache=True)
def solve(A, b):
    """``A⁻¹ b`` by Gaussian elimination with partial pivoting, ``A`` (n, n) and ``b`` (n,) overwritten; the
    answer in ``b``. False (``b`` unusable) where ``A`` is singular to working precision."""
    n = A.shape[0]
    for c in range(n):
        p, best = c, abs(A[c, c])
        for r in range(c + 1, n):
            if abs(A[r, c]) > best:
                p, best = r, abs(A[r, c])
        if best == 0.0 or not np.isfinite(best):
            return False
        if p != c:
            for k in range(c, n):
                A[c, k], A[p, k] = A[p, k], A[c, k]
            b[c], b[p] = b[p], b[c]
        inv = 1.0 / A[c, c]
        for r in range(c + 1, n):
            f = A[r, c] * inv
            if f != 0:
                for k in range(c + 1, n):
                    A[r, k] -= f * A[c, k]
                b[r] -= f * b[c]
    for c in range(n - 1, -1, -1):
        s = b[c]
        for k in range(c + 1, n):
            s -= A[c, k] * b[k]
        b[c] = s / A[c, c]
    return True


@njit(cache=True)
def _load(r, x, p0, p1, t):
    n = x.shape[0]
    for i in range(n):  # element by element: an array assigned to a slice compiles its error message (seconds)
        r[i] = x[i]
    for k in range(p0.shape[0]):
        r[n + k] = t * p0[k] + (1 - t) * p1[k]


@njit(cache=True)
def _tangent(code, r, outputs, n, moving, x, p0, p1, t, A, out):
    """``dx/dt = −F_x⁻¹ F_p (p₀ − p₁)`` at ``(x, t)`` into ``out``; False at a singular ``F_x``."""
    _load(r, x, p0, p1, t)
    run_program(code, r)
    for i in range(n):
        for j in range(n):
            A[i, j] = r[outputs[n + i * n + j]]
        s = 0j
        base = n + n * n + i * moving
        for k in range(moving):
            s += r[outputs[base + k]] * (p0[k] - p1[k])
        out[i] = -s
    return solve(A, out)


@njit(cache=True)
def _newton(code, r, outputs, n, x, p0, p1, t, A, out):
    """One Newton correction ``−F_x⁻¹ F`` at ``(x, t)`` into ``out``; False at a singular ``F_x``."""
    _load(r, x, p0, p1, t)
    run_program(code, r)
    for i in range(n):
        out[i] = -r[outputs[i]]
        for j in range(n):
            A[i, j] = r[outputs[n + i * n + j]]
    return solve(A, out)


@njit(cache=True)
def _norm(v):
    s = 0.0
    for k in range(v.shape[0]):
        s += v[k].real ** 2 + v[k].imag ** 2
    return np.sqrt(s)


@njit(cache=True)
def _track_one(code, r, outputs, n, moving, x, p0, p1, t_end, bound, scale, max_steps, stall_floor):
    """Track one path from ``x`` (overwritten with its end) at ``t = 1``: returns ``(t reached, diverged)``."""
    A = np.empty((n, n), dtype=np.complex128)
    k1 = np.empty(n, dtype=np.complex128)
    k2 = np.empty(n, dtype=np.complex128)
    k3 = np.empty(n, dtype=np.complex128)
    k4 = np.empty(n, dtype=np.complex128)
    y = np.empty(n, dtype=np.complex128)
    dx = np.empty(n, dtype=np.complex128)
    done = max(t_end * (1 + 1e-9), 1e-15)
    t, h, successes = 1.0, 0.05, 0
    for _ in range(max_steps):
        if t <= done:
            break
        ha = min(h, t - t_end)
        ok = _tangent(code, r, outputs, n, moving, x, p0, p1, t, A, k1)
        for i in range(n):  # element by element: an array assigned to a slice compiles its error message
            y[i] = x[i] - ha / 2 * k1[i]
        ok = ok and _tangent(code, r, outputs, n, moving, y, p0, p1, t - ha / 2, A, k2)
        for i in range(n):
            y[i] = x[i] - ha / 2 * k2[i]
        ok = ok and _tangent(code, r, outputs, n, moving, y, p0, p1, t - ha / 2, A, k3)
        for i in range(n):
            y[i] = x[i] - ha * k3[i]
        ok = ok and _tangent(code, r, outputs, n, moving, y, p0, p1, t - ha, A, k4)
        t1 = t - ha
        for i in range(n):
            y[i] = x[i] - ha / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i])
        size = max(_norm(y), 1e-3 * scale)
        prev = np.inf
        if ok:
            for it in range(3):
                good = _newton(code, r, outputs, n, y, p0, p1, t1, A, dx)
                step = _norm(dx) if good else np.inf
                if not np.isfinite(step):
                    step = np.inf
                if it == 0:
                    ok = ok and step <= FIRST_STEP * size
                else:
                    ok = ok and (step <= 0.25 * prev or step <= TRACK_TOL * size)
                if np.isfinite(step):
                    y += dx
                prev = step
            ok = ok and prev <= TRACK_TOL * size
        if ok:
            for i in range(n):
                x[i] = y[i]
            t = t1
            successes += 1
            if successes >= 3:
                h = min(2 * h, 0.25)
                successes = 0
            if _norm(x) > bound:
                return t, True
        else:
            h *= 0.5
            successes = 0
            if h < 1e-9 * max(t, stall_floor):
                break
    return t, False


@njit(cache=True, parallel=True)
def track_paths(code, registers, outputs, n, moving, x0, p0, p1, t_end, scale, bound, max_steps, stall_floor):
    """Every path of the homotopy ``F(x; t p₀[i] + (1 − t) p₁[i]) = 0`` from its start ``x0[i]`` at ``t = 1``
    towards ``t_end`` (each path its own parameters, ``p0`` and ``p1`` (P, m): many targets solved at once), the
    paths shared among the cores: a fourth-order Runge–Kutta predictor on ``dx/dt`` and three
    Newton corrections that must contract (the first at most :data:`FIRST_STEP` of ``|x|``, the last below
    :data:`TRACK_TOL`), the step doubled after three accepted steps (at most 0.25) and halved after a rejected
    one. A path stops at ``t_end``, where ``|x|`` exceeds ``bound · max(scale, 1)`` (diverged), or where its step
    falls below ``1e-9 max(t, stall_floor)`` (near a singular endpoint); corrections are relative to ``|x|``, or
    to ``1e-3 scale`` where ``|x|`` is smaller. Returns the endpoints, the ``t`` each reached and whether each
    diverged."""
    P = x0.shape[0]
    xs = x0.copy()
    ts = np.ones(P)
    diverged = np.zeros(P, dtype=np.bool_)
    limit = bound * max(scale, 1.0)
    for i in prange(P):
        r = registers.copy()
        ts[i], diverged[i] = _track_one(code, r, outputs, n, moving, xs[i], p0[i], p1[i], t_end, limit, scale,
                                        max_steps, stall_floor)
    return xs, ts, diverged
