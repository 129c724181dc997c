"""Rotations of many vectors at once, compiled: Rodrigues' formula row by row, and the angles that undo it.

What the closed-form inverse kinematics of spatial legs (:mod:`pkmlab.description.spatial_legs`) computes for every
point of a path (a universal joint's angles, a crank's), and the Delta's forward kinematics for its two: on a
thousand rows NumPy's temporaries cost more than the arithmetic. Each function works on rows
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
def _roots(alpha, beta, ratio):
    """The two roots ``atan2(β, α) ± acos(ratio)`` of ``α cos θ + β sin θ = γ`` (``ratio = γ / √(α² + β²)``, taken
    into [-1, 1]: the nearest angle where none reaches; NaN stays NaN), each taken into (-π, π]."""
    if ratio > 1.0:
        ratio = 1.0
    elif ratio < -1.0:
        ratio = -1.0
    middle, half = math.atan2(beta, alpha), math.acos(ratio)
    return _wrapped(middle + half), _wrapped(middle - half)


@njit(cache=True)
def _rotated(axis, angle, x, y, z):
    """``Rot(axis, angle) (x, y, z)`` by Rodrigues' formula, ``c v + s (a × v) + (1 - c)(a · v) a`` (unit ``axis``)."""
    a0, a1, a2 = axis[0], axis[1], axis[2]
    c, s = math.cos(angle), math.sin(angle)
    along = (1.0 - c) * (x * a0 + y * a1 + z * a2)
    return (c * x + s * (a1 * z - a2 * y) + along * a0, c * y + s * (a2 * x - a0 * z) + along * a1,
            c * z + s * (a0 * y - a1 * x) + along * a2)


@njit(cache=True)
def rotate_rows(axis, angle, v, out):
    """``out[k] = Rot(axis, angle[k]) v[k]`` (K, 3), the unit ``axis`` (3,) (:func:`_rotated`)."""
    for k in range(v.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = _rotated(axis, angle[k], v[k, 0], v[k, 1], v[k, 2])


@njit(cache=True)
def _off_line(x, y, z, point, direction):
    """The distance of ``(x, y, z)`` from the line through ``point`` along the unit ``direction``."""
    d0, d1, d2 = x - point[0], y - point[1], z - point[2]
    along = d0 * direction[0] + d1 * direction[1] + d2 * direction[2]
    e0, e1, e2 = d0 - along * direction[0], d1 - along * direction[1], d2 - along * direction[2]
    return math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)


@njit(cache=True)
def crank_rows(axis, start, across, alpha, beta, ratio, sigma, point, direction, by_side, theta, elbow):
    """The angle ``theta[k]`` of a crank turning about the unit ``axis`` (3,) whose tip ``elbow[k]`` (K, 3) is
    ``start + Rot(axis, θ) across`` and solves ``α cos θ + β sin θ = γ`` (``ratio[k] = γ / √(α² + β²)``). Of its two
    roots (:func:`_roots`), working mode ``sigma = +1`` takes the one whose tip is farther from the line through
    ``point`` along the unit ``direction`` ("knee out"), -1 the other; where ``by_side`` (the crank's axis along
    that line), +1 takes the first root, ``atan2(β, α) + acos(ratio)``, and -1 the second."""
    for k in range(alpha.shape[0]):
        first, second = _roots(alpha[k], beta[k], ratio[k])
        x0, y0, z0 = _rotated(axis, first, across[0], across[1], across[2])
        x1, y1, z1 = _rotated(axis, second, across[0], across[1], across[2])
        x0, y0, z0 = start[0] + x0, start[1] + y0, start[2] + z0
        x1, y1, z1 = start[0] + x1, start[1] + y1, start[2] + z1
        outer = by_side or _off_line(x0, y0, z0, point, direction) > _off_line(x1, y1, z1, point, direction)
        if outer == (sigma > 0):
            theta[k], elbow[k, 0], elbow[k, 1], elbow[k, 2] = first, x0, y0, z0
        else:
            theta[k], elbow[k, 0], elbow[k, 1], elbow[k, 2] = second, x1, y1, z1


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
    ``a1 · Rot(a2, q2) tip = a1 · v``: ``α cos q2 + β sin q2 = γ``, of its roots (:func:`_roots`) the one nearer
    zero; then ``q1`` turns ``Rot(a2, q2) tip`` onto ``v`` about ``a1``."""
    for k in range(v.shape[0]):
        t0, t1, t2 = tip[k, 0], tip[k, 1], tip[k, 2]
        alpha = t0 * a1[0] + t1 * a1[1] + t2 * a1[2]
        beta = (a2[1] * t2 - a2[2] * t1) * a1[0] + (a2[2] * t0 - a2[0] * t2) * a1[1] + (a2[0] * t1 - a2[1] * t0) * a1[2]
        gamma = v[k, 0] * a1[0] + v[k, 1] * a1[1] + v[k, 2] * a1[2]
        rho = math.hypot(alpha, beta)
        bad[k] = abs(gamma) > rho * (1 + 1e-12)
        first, second = _roots(alpha, beta, gamma / rho if rho > 0 else 0.0)
        q2[k] = first if abs(first) <= abs(second) else second
    rotate_rows(a2, q2, tip, turned)
    turn_onto_rows(a1, turned, v, q1)
