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


def _stroke(leg: Leg, number: int, value: float) -> None:
    if leg.stroke is not None and not leg.stroke[0] <= value <= leg.stroke[1]:
        raise UnreachablePoseError(f"leg {number + 1} needs its actuator at {value:.6g} m, outside its stroke "
                                   f"[{leg.stroke[0]:g}, {leg.stroke[1]:g}] m", legs=(number + 1,))


def _rrr(leg: Leg, number: int, point, sigma: int) -> list[float]:
    l1, d1 = _polar(leg.bodies[0].tip)
    l2, d2 = _polar(leg.bodies[1].tip)
    dx, dy = point[0] - leg.base[0], point[1] - leg.base[1]
    reach = math.hypot(dx, dy)
    cos_gamma = (l1 * l1 + reach * reach - l2 * l2) / (2 * l1 * reach) if reach > 0 else math.inf
    if not -1.0 <= cos_gamma <= 1.0:
        raise UnreachablePoseError(f"leg {number + 1}: the attachment point is {reach:.6g} m from its base, beyond "
                                   f"its reach {abs(l1 - l2):.6g}..{l1 + l2:.6g} m", legs=(number + 1,))
    gamma = math.atan2(dy, dx) + sigma * math.acos(cos_gamma)  # + : the elbow to the left of base -> point
    ex, ey = leg.base[0] + l1 * math.cos(gamma), leg.base[1] + l1 * math.sin(gamma)
    theta = gamma - d1
    phi = math.atan2(point[1] - ey, point[0] - ex) - d2
    if leg.joints[0].kind == "R" and leg.stroke is not None:
        _stroke(leg, number, theta)
    return [theta, phi]


def _rpr(leg: Leg, number: int, point, _sigma: int) -> list[float]:
    # p = b + R(psi) (t + (s, 0)), t = tip1 + tip2: the rod slides along the leg's direction
    tx = leg.bodies[0].tip[0] + leg.bodies[1].tip[0]
    ty = leg.bodies[0].tip[1] + leg.bodies[1].tip[1]
    dx, dy = point[0] - leg.base[0], point[1] - leg.base[1]
    reach2 = dx * dx + dy * dy - ty * ty
    if reach2 < 0:
        raise UnreachablePoseError(f"leg {number + 1}: the attachment point is closer to its base than the leg's "
                                   f"offset {abs(ty):.6g} m", legs=(number + 1,))
    s = math.sqrt(reach2) - tx
    _stroke(leg, number, s)
    psi = math.atan2(dy, dx) - math.atan2(ty, tx + s)
    return [psi, s]


def _prr(leg: Leg, number: int, point, sigma: int) -> list[float]:
    beta = leg.joints[0].axis
    ux, uy = math.cos(beta), math.sin(beta)
    t1x, t1y = leg.bodies[0].tip  # the revolute on the slider, in the slider's frame
    jx = leg.base[0] + ux * t1x - uy * t1y
    jy = leg.base[1] + uy * t1x + ux * t1y
    l2, d2 = _polar(leg.bodies[1].tip)
    wx, wy = point[0] - jx, point[1] - jy
    along = wx * ux + wy * uy
    disc = along * along - (wx * wx + wy * wy) + l2 * l2
    if disc < 0:
        raise UnreachablePoseError(f"leg {number + 1}: the attachment point is {math.sqrt(-disc + l2 * l2):.6g} m "
                                   f"from its rail, beyond the link's {l2:.6g} m", legs=(number + 1,))
    s = along + sigma * math.sqrt(disc)  # + : the slider beyond the foot of the perpendicular
    _stroke(leg, number, s)
    phi = math.atan2(point[1] - (jy + s * uy), point[0] - (jx + s * ux)) - d2
    return [s, phi]


_SOLVERS = {"R*RR": _rrr, "RP*R": _rpr, "P*RR": _prr}


def leg_inverse_kinematics(leg: Leg, number: int, point, sigma: int = 1) -> list[float]:
    """The joint coordinates (joint order, the last joint's excluded) of leg ``number`` (0-based) whose
    end is at ``point``, in working mode ``sigma`` (ignored by single-solution legs)."""
    return _solver(leg, number)(leg, number, point, sigma)


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
