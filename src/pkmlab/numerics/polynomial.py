"""Real roots of real polynomials of low degree, robustly and without complex arithmetic.

Forward kinematics needs every *real* root of a sextic, including roots very close together
(near a singularity) and roots of large magnitude. Companion-matrix eigenvalues find all
complex roots and then need an arbitrary threshold on the imaginary part; here the real
roots are isolated instead by the derivative cascade: the real roots of ``p^(k)`` separate
those of ``p^(k-1)`` (Rolle), so working up from the linear ``p^(n-1)`` every root of ``p``
is bracketed by a sign change between consecutive critical points, and solved by
safeguarded Newton iteration. A root of even multiplicity (no sign change) is caught at the
critical point where ``|p|`` is at round-off level.

Coefficients are ordered highest degree first, as in :func:`numpy.roots`.
"""

from __future__ import annotations

import numpy as np

from .. import _compile_cache  # noqa: F401  (sets the kernel cache before any kernel is defined)
from .._compile_cache import njit


@njit(cache=True)
def horner(c, x):
    """``(p(x), p'(x), Σ|c_j||x|^(n-j))`` for coefficients ``c`` (highest degree first).

    The third value bounds the round-off in ``p(x)`` (times machine epsilon).
    """
    p = c[0]
    dp = 0.0
    mag = abs(c[0])
    ax = abs(x)
    for j in range(1, c.shape[0]):
        dp = dp * x + p
        p = p * x + c[j]
        mag = mag * ax + abs(c[j])
    return p, dp, mag


@njit(cache=True)
def _bracketed_root(c, lo, hi, f_lo):
    """Root of ``c`` in ``[lo, hi]`` where ``p(lo)`` and ``p(hi)`` differ in sign."""
    x = 0.5 * (lo + hi)
    for _ in range(200):
        f, df, _mag = horner(c, x)
        if f == 0.0:
            return x
        if (f < 0.0) == (f_lo < 0.0):
            lo = x
        else:
            hi = x
        step_ok = False
        if df != 0.0:
            xn = x - f / df
            if lo < xn < hi:
                step_ok = True
        if not step_ok:
            xn = 0.5 * (lo + hi)
        if abs(xn - x) <= 2.2e-16 * max(1.0, abs(x)) or hi - lo <= 4.4e-16 * max(1.0, abs(x)):
            return xn
        x = xn
    return x


@njit(cache=True)
def real_roots(coeffs, out):
    """Write the distinct real roots of a polynomial, ascending, into ``out``; return their count.

    ``coeffs`` has the highest degree first; leading zeros are dropped (a vanishing leading
    coefficient lowers the degree). ``out`` needs room for ``len(coeffs) - 1`` roots.

    >>> import numpy as np
    >>> out = np.empty(3)
    >>> n = real_roots(np.array([1.0, -6.0, 11.0, -6.0]), out)  # (x-1)(x-2)(x-3)
    >>> np.round(out[:n], 12).tolist()
    [1.0, 2.0, 3.0]
    """
    n_coeffs = coeffs.shape[0]
    start = 0
    while start < n_coeffs - 1 and coeffs[start] == 0.0:
        start += 1
    deg = n_coeffs - 1 - start
    if deg <= 0:
        return 0
    lead = coeffs[start]
    # der[k, :deg+1-k]: k-th derivative of the monic polynomial (row 0 is the polynomial).
    der = np.zeros((deg, deg + 1))
    for j in range(deg + 1):
        der[0, j] = coeffs[start + j] / lead
    bound = 0.0
    for j in range(1, deg + 1):
        bound = max(bound, abs(der[0, j]))
    bound = 1.0 + bound  # Cauchy's bound: every root, and by Gauss-Lucas every critical point
    for k in range(1, deg):
        d = deg - k + 1  # degree of row k-1
        for j in range(d):
            der[k, j] = der[k - 1, j] * (d - j)

    crit = np.empty(deg + 1)
    roots = np.empty(deg + 1)
    n_crit = 0
    for k in range(deg - 1, -1, -1):
        d = deg - k
        c = der[k, : d + 1]
        n_roots = 0
        if d == 1:
            roots[0] = -c[1] / c[0]
            n_roots = 1
        else:
            lo = -bound
            f_lo, _dp, _m = horner(c, lo)
            for idx in range(n_crit + 1):
                hi = crit[idx] if idx < n_crit else bound
                f_hi, _dp, mag_hi = horner(c, hi)
                if f_lo == 0.0:
                    if n_roots == 0 or roots[n_roots - 1] != lo:
                        roots[n_roots] = lo
                        n_roots += 1
                elif f_hi != 0.0 and (f_lo < 0.0) != (f_hi < 0.0):
                    roots[n_roots] = _bracketed_root(c, lo, hi, f_lo)
                    n_roots += 1
                elif k == 0 and idx < n_crit and abs(f_hi) <= 64.0 * 2.2e-16 * mag_hi:
                    # |p| at round-off level at a critical point: a (near-)double root.
                    roots[n_roots] = hi
                    n_roots += 1
                lo = hi
                f_lo = f_hi
            if f_lo == 0.0 and (n_roots == 0 or roots[n_roots - 1] != lo):
                roots[n_roots] = lo
                n_roots += 1
        for j in range(n_roots):
            crit[j] = roots[j]
        n_crit = n_roots
    for j in range(n_crit):
        out[j] = crit[j]
    return n_crit


@njit(cache=True)
def moebius_shift(coeffs, tau):
    """Coefficients of ``(1 - τ t')ⁿ p((t' + τ)/(1 - τ t'))`` (highest degree first).

    With ``t = tan(x/2)`` and ``τ = tan(x0/2)`` this is ``p`` re-parametrised by
    ``t' = tan((x - x0)/2)``: the same roots in ``x``, shifted away from ``x = π`` where
    ``t`` is infinite.
    """
    n = coeffs.shape[0] - 1
    out = np.zeros(n + 1)
    # Expand Σ_j c_j (t'+τ)^(n-j) (1-τt')^j ; poly arrays indexed by power, low first.
    for j in range(n + 1):
        a = np.zeros(n + 1)
        a[0] = 1.0
        deg_a = 0
        for _ in range(n - j):  # multiply by (τ + t')
            for p in range(deg_a + 1, 0, -1):
                a[p] = a[p] * tau + a[p - 1]
            a[0] = a[0] * tau
            deg_a += 1
        for _ in range(j):  # multiply by (1 - τ t')
            for p in range(deg_a + 1, 0, -1):
                a[p] = a[p] - tau * a[p - 1]
            deg_a += 1
        for p in range(n + 1):
            out[n - p] += coeffs[j] * a[p]
    return out
