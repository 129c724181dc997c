"""Rotations of many vectors at once, compiled: Rodrigues' formula row by row, and the angles that undo it.

What the closed-form inverse kinematics of spatial legs (:mod:`pkmlab.description.spatial_legs`) computes for every
point of a path, and the Delta's forward kinematics for its two: on a thousand rows NumPy's temporaries cost more
than the arithmetic. Each function works on rows
``(K, 3)`` and writes into arrays its caller made; every argument an array of float64, C-ordered.
"""

from __future__ import annotations

import math

from .._compile_cache import njit


@njit(cache=True)
def _wrapped(angle):
    """``angle`` into ``(-π, π]`` as :func:`pkmlab.numerics.angles.wrapped_angle` takes it: the argument of
    ``(cos, sin)``."""
    return math.atan2(math.sin(angle), math.cos(angle))


@njit(cache=True)
def rotate_rows(axis, angle, v, out):
    """``out[k] = Rot(axis, angle[k]) v[k]`` (K, 3), the unit ``axis`` (3,): ``c v + s (a × v) + (1 - c)(a · v) a``."""
    a0, a1, a2 = axis[0], axis[1], axis[2]
    for k in range(v.shape[0]):
        c, s = math.cos(angle[k]), math.sin(angle[k])
        x, y, z = v[k, 0], v[k, 1], v[k, 2]
        along = (1.0 - c) * (x * a0 + y * a1 + z * a2)
        out[k, 0] = c * x + s * (a1 * z - a2 * y) + along * a0
        out[k, 1] = c * y + s * (a2 * x - a0 * z) + along * a1
        out[k, 2] = c * z + s * (a0 * y - a1 * x) + along * a2


@njit(cache=True)
def turn_onto_rows(axis, v, w, out):
    """``out[k]``: the angle of the turn about the unit ``axis`` (3,) that takes the part of ``v[k]`` across the axis
    onto the direction of that of ``w[k]`` (K, 3)."""
    a0, a1, a2 = axis[0], axis[1], axis[2]
    for k in range(v.shape[0]):
        v0, v1, v2, w0, w1, w2 = v[k, 0], v[k, 1], v[k, 2], w[k, 0], w[k, 1], w[k, 2]
        sine = (v1 * w2 - v2 * w1) * a0 + (v2 * w0 - v0 * w2) * a1 + (v0 * w1 - v1 * w0) * a2
        cosine = (v0 * w0 + v1 * w1 + v2 * w2) - (v0 * a0 + v1 * a1 + v2 * a2) * (w0 * a0 + w1 * a1 + w2 * a2)
        out[k] = math.atan2(sine, cosine)


@njit(cache=True)
def universal_rows(a1, a2, tip, v, q1, q2, bad, turned):
    """The angles ``q1[k], q2[k]`` of a universal joint of perpendicular unit axes ``a1``, ``a2`` (3,) with
    ``Rot(a1, q1) Rot(a2, q2) tip[k] = v[k]`` (K, 3; ``v`` of the tip's length), ``bad[k]`` where no angle does it;
    ``turned`` (K, 3) is scratch. The first turn keeps the ``a1`` component, so
    ``a1 · Rot(a2, q2) tip = a1 · v``: ``α cos q2 + β sin q2 = γ``, of the root nearer zero; then ``q1`` turns
    ``Rot(a2, q2) tip`` onto ``v`` about ``a1``."""
    for k in range(v.shape[0]):
        t0, t1, t2 = tip[k, 0], tip[k, 1], tip[k, 2]
        alpha = t0 * a1[0] + t1 * a1[1] + t2 * a1[2]
        beta = (a2[1] * t2 - a2[2] * t1) * a1[0] + (a2[2] * t0 - a2[0] * t2) * a1[1] + (a2[0] * t1 - a2[1] * t0) * a1[2]
        gamma = v[k, 0] * a1[0] + v[k, 1] * a1[1] + v[k, 2] * a1[2]
        rho = math.hypot(alpha, beta)
        ratio = gamma / rho if rho > 0 else 0.0
        bad[k] = abs(gamma) > rho * (1 + 1e-12)
        ratio = min(max(ratio, -1.0), 1.0)
        centre, half = math.atan2(beta, alpha), math.acos(ratio)
        first, second = _wrapped(centre + half), _wrapped(centre - half)
        q2[k] = first if abs(first) <= abs(second) else second
    rotate_rows(a2, q2, tip, turned)
    turn_onto_rows(a1, turned, v, q1)
