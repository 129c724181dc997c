"""What is particular to each leg type: closed-form inverse kinematics and its working modes.

A leg meets the platform at a point; given that point, each leg type of pkmlab's planar
machines has a closed-form solution, with at most two branches:

* ``R*RR`` (and the five-bar's legs): two links from the base point — a circle–circle
  intersection. Working mode ``σ = +1`` when the elbow lies to the **left** of the directed line
  from the base point to the attachment point (``(p - b) × (e - b) > 0``), ``-1`` to its right.
* ``RP*R``: a telescopic leg — one solution (no working mode).
* ``P*RR``: a slider on a rail and a link — a line–circle intersection. ``σ = +1`` for the
  slider beyond the foot of the perpendicular from the attachment point to the rail (the larger
  displacement), ``-1`` for the smaller.

Each solver returns the leg's joint coordinates in joint order (the actuated one included), or
raises :class:`~pkmlab.errors.UnreachablePoseError` naming the leg (out of reach, or outside its
actuator's stroke).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidParameterError, UnreachablePoseError
from .description import Leg

#: Leg types with a closed-form solution, and how many working modes each has.
BRANCHES = {"R*RR": 2, "RP*R": 1, "P*RR": 2}


def working_modes(leg: Leg) -> tuple[int, ...]:
    """The working modes of ``leg``: ``(1, -1)`` for a two-branch leg, ``()`` for a single solution."""
    _solver(leg, 0)
    return (1, -1) if BRANCHES[leg.notation] == 2 else ()


def _solver(leg: Leg, number: int):
    try:
        return _SOLVERS[leg.notation]
    except KeyError:
        raise InvalidParameterError(f"leg {number + 1}: no closed-form inverse kinematics for a {leg.notation} leg "
                                    f"(known: {', '.join(_SOLVERS)})") from None


def _polar(tip) -> tuple[float, float]:
    return math.hypot(*tip), math.atan2(tip[1], tip[0])


class _Solved:
    """A leg type's solution for K points: ``coordinates`` (K, joints), and for each point that cannot be
    reached ``bad[k]`` True and ``why(k)``, the one-line reason (naming the leg)."""

    def __init__(self, coordinates: np.ndarray, bad: np.ndarray, why):
        self.coordinates, self.bad, self.why = coordinates, bad, why


def _stroke(leg: Leg, number: int, value: np.ndarray, bad: np.ndarray, why):
    """Mark the values outside the leg's stroke as bad, their reason naming the leg and the stroke."""
    if leg.stroke is None:
        return bad, why
    lo, hi = leg.stroke
    outside = ~bad & ~((lo <= value) & (value <= hi))

    def reason(k):
        if outside[k]:
            unit = "m" if leg.joints[leg.actuated].kind == "P" else "rad"
            return (f"leg {number + 1} needs its actuator at {value[k]:.6g} {unit}, outside its stroke "
                    f"[{lo:g}, {hi:g}] {unit}")
        return why(k)

    return bad | outside, reason


def _rrr(leg: Leg, number: int, point: np.ndarray, sigma: int) -> _Solved:
    l1, d1 = _polar(leg.bodies[0].tip)
    l2, d2 = _polar(leg.bodies[1].tip)
    dx, dy = point[:, 0] - leg.base[0], point[:, 1] - leg.base[1]
    reach = np.hypot(dx, dy)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_gamma = np.where(reach > 0, (l1 * l1 + reach * reach - l2 * l2) / (2 * l1 * reach), np.inf)
    bad = ~((-1.0 <= cos_gamma) & (cos_gamma <= 1.0))
    gamma = np.arctan2(dy, dx) + sigma * np.arccos(np.clip(cos_gamma, -1.0, 1.0))  # + : elbow left of base -> point
    ex, ey = leg.base[0] + l1 * np.cos(gamma), leg.base[1] + l1 * np.sin(gamma)
    theta = gamma - d1
    phi = np.arctan2(point[:, 1] - ey, point[:, 0] - ex) - d2

    def why(k):
        return (f"leg {number + 1}: the attachment point is {reach[k]:.6g} m from its base, beyond its reach "
                f"{abs(l1 - l2):.6g}..{l1 + l2:.6g} m")

    if leg.joints[0].kind == "R":
        bad, why = _stroke(leg, number, theta, bad, why)
    return _Solved(np.column_stack([theta, phi]), bad, why)


def _rpr(leg: Leg, number: int, point: np.ndarray, _sigma: int) -> _Solved:
    # p = b + R(psi) (t + (s, 0)), t = tip1 + tip2: the rod slides along the leg's direction
    tx = leg.bodies[0].tip[0] + leg.bodies[1].tip[0]
    ty = leg.bodies[0].tip[1] + leg.bodies[1].tip[1]
    dx, dy = point[:, 0] - leg.base[0], point[:, 1] - leg.base[1]
    reach2 = dx * dx + dy * dy - ty * ty
    bad = reach2 < 0
    s = np.sqrt(np.maximum(reach2, 0.0)) - tx
    psi = np.arctan2(dy, dx) - np.arctan2(ty, tx + s)

    def why(_k):
        return f"leg {number + 1}: the attachment point is closer to its base than the leg's offset {abs(ty):.6g} m"

    bad, why = _stroke(leg, number, s, bad, why)
    return _Solved(np.column_stack([psi, s]), bad, why)


def _prr(leg: Leg, number: int, point: np.ndarray, sigma: int) -> _Solved:
    beta = leg.joints[0].axis
    ux, uy = math.cos(beta), math.sin(beta)
    t1x, t1y = leg.bodies[0].tip  # the revolute on the slider, in the slider's frame
    jx = leg.base[0] + ux * t1x - uy * t1y
    jy = leg.base[1] + uy * t1x + ux * t1y
    l2, d2 = _polar(leg.bodies[1].tip)
    wx, wy = point[:, 0] - jx, point[:, 1] - jy
    along = wx * ux + wy * uy
    disc = along * along - (wx * wx + wy * wy) + l2 * l2
    bad = disc < 0
    s = along + sigma * np.sqrt(np.maximum(disc, 0.0))  # + : the slider beyond the foot of the perpendicular
    phi = np.arctan2(point[:, 1] - (jy + s * uy), point[:, 0] - (jx + s * ux)) - d2

    def why(k):
        return (f"leg {number + 1}: the attachment point is {math.sqrt(-disc[k] + l2 * l2):.6g} m from its rail, "
                f"beyond the link's {l2:.6g} m")

    bad, why = _stroke(leg, number, s, bad, why)
    return _Solved(np.column_stack([s, phi]), bad, why)


_SOLVERS = {"R*RR": _rrr, "RP*R": _rpr, "P*RR": _prr}


def leg_inverse_kinematics_batch(leg: Leg, number: int, points, sigma: int = 1) -> _Solved:
    """:func:`leg_inverse_kinematics` of many attachment points ``(K, 2)`` at once: the coordinates
    ``(K, joints)``, ``bad`` (K,) for the points out of reach and ``why(k)`` naming the reason."""
    return _solver(leg, number)(leg, number, np.asarray(points, dtype=float).reshape(-1, 2), sigma)


def leg_inverse_kinematics(leg: Leg, number: int, point, sigma: int = 1) -> list[float]:
    """The joint coordinates (joint order, the last joint's excluded) of leg ``number`` (0-based) whose
    end is at ``point``, in working mode ``sigma`` (ignored by single-solution legs); raises
    :class:`~pkmlab.errors.UnreachablePoseError` naming the leg when it cannot reach."""
    solved = leg_inverse_kinematics_batch(leg, number, point, sigma)
    if solved.bad[0]:
        raise UnreachablePoseError(solved.why(0), legs=(number + 1,))
    return [float(v) for v in solved.coordinates[0]]


# ------------------------------------------------------------------ forward kinematics: the circle of a leg
def leg_circle(leg: Leg, actuator: float) -> tuple[tuple[float, float], float]:
    """With its actuator at ``actuator``, every leg type here holds its platform attachment point on a
    circle: ``(centre, radius)`` — the elbow and the passive link (``R*RR``), the base pivot and the
    leg's length (``RP*R``), the slider's pivot and the passive link (``P*RR``)."""
    from .description import leg_chain

    _solver(leg, 0)
    if leg.notation == "RP*R":
        tx = leg.bodies[0].tip[0] + leg.bodies[1].tip[0] + actuator
        return leg.base, math.hypot(tx, leg.bodies[0].tip[1] + leg.bodies[1].tip[1])
    centre = leg_chain(leg, [actuator, 0.0])[1][0]
    return centre, math.hypot(*leg.bodies[1].tip)


def leg_coordinates(leg: Leg, actuator: float, point) -> list[float]:
    """The joint coordinates (joint order, the last joint's excluded) of a leg whose actuator is at
    ``actuator`` and whose end is at ``point`` (on its :func:`leg_circle`)."""
    _solver(leg, 0)
    if leg.notation == "RP*R":
        tx = leg.bodies[0].tip[0] + leg.bodies[1].tip[0] + actuator
        ty = leg.bodies[0].tip[1] + leg.bodies[1].tip[1]
        return [math.atan2(point[1] - leg.base[1], point[0] - leg.base[0]) - math.atan2(ty, tx), actuator]
    (cx, cy), _r = leg_circle(leg, actuator)
    passive = math.atan2(point[1] - cy, point[0] - cx) - math.atan2(leg.bodies[1].tip[1], leg.bodies[1].tip[0])
    return [actuator, passive]
