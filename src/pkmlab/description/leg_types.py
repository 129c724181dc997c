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

Any other leg of an actuator, one passive joint and the platform's revolute (``R*PR``, ``RR*R``,
``PR*R``, ...) is solved by a general method, in closed form too (:class:`Locus`, :func:`_general`): with its
actuator held the leg's end lies on a circle or a line, and the actuator values that put the attachment point
on it are the roots of a first-degree trigonometric polynomial in a revolute actuator, or of a quadratic in a
prismatic one; checked against the three closed forms by the tests.

Each solver returns the leg's joint coordinates in joint order (the actuated one included), or
raises :class:`~pkmlab.errors.UnreachablePoseError` naming the leg (out of reach, or outside its
actuator's stroke).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import InvalidParameterError, UnreachablePoseError
from ..numerics.angles import wrapped_angle
from .mechanism import Leg, moving_base, ordinary_part

#: Leg types with a closed-form solution, and how many working modes each has.
BRANCHES = {"R*RR": 2, "RP*R": 1, "P*RR": 2}


def working_modes(leg: Leg) -> tuple[int, ...]:
    """The working modes of ``leg``: ``(1, -1)`` for a two-branch leg (every leg solved by the general method
    is one), ``()`` for a single solution; a kinematically redundant leg's are those of its ordinary part."""
    part = ordinary_part(leg)
    _solver(part, 0)
    return (1, -1) if BRANCHES.get(part.notation, 2) == 2 else ()


def _solver(leg: Leg, number: int):
    """The leg type's closed form, or for any other leg the general method (:func:`_general`)."""
    if leg.notation in SOLVERS:
        return SOLVERS[leg.notation]
    Locus(leg, number)  # refuses a leg the general method cannot take, naming it
    return _general


def _polar(tip) -> tuple[float, float]:
    return math.hypot(*tip), math.atan2(tip[1], tip[0])


class Solved:
    """A leg type's solution for K points: ``coordinates`` (K, joints), and for each point that cannot be
    reached ``bad[k]`` True and ``why(k)``, the one-line reason (naming the leg)."""

    def __init__(self, coordinates: np.ndarray, bad: np.ndarray, why):
        self.coordinates, self.bad, self.why = coordinates, bad, why


def mark_outside_stroke(leg: Leg, number: int, value: np.ndarray, bad: np.ndarray, why):
    """Mark the values outside the leg's stroke as bad, their reason naming the leg and the stroke."""
    if leg.stroke is None:
        return bad, why
    lo, hi = leg.stroke
    outside = ~bad & ~((lo <= value) & (value <= hi))

    def reason(k):
        if outside[k]:
            unit = "m" if leg.joints[leg.actuated].kind == "P" else "rad"
            which = "its actuator" if len(leg.actuated_joints) == 1 else f"its own actuator (joint {leg.actuated + 1})"
            return (f"leg {number + 1} needs {which} at {value[k]:.6g} {unit}, outside its stroke "
                    f"[{lo:g}, {hi:g}] {unit}")
        return why(k)

    return bad | outside, reason


def _rrr(leg: Leg, number: int, point: np.ndarray, sigma: int) -> Solved:
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
        bad, why = mark_outside_stroke(leg, number, theta, bad, why)
    return Solved(np.column_stack([theta, phi]), bad, why)


def _rpr(leg: Leg, number: int, point: np.ndarray, _sigma: int) -> Solved:
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

    bad, why = mark_outside_stroke(leg, number, s, bad, why)
    return Solved(np.column_stack([psi, s]), bad, why)


def _prr(leg: Leg, number: int, point: np.ndarray, sigma: int) -> Solved:
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

    bad, why = mark_outside_stroke(leg, number, s, bad, why)
    return Solved(np.column_stack([s, phi]), bad, why)


SOLVERS = {"R*RR": _rrr, "RP*R": _rpr, "P*RR": _prr}


# ------------------------------------------------------------------ any other leg: its locus and a general method
class Locus:
    """Where the end of a leg can be with its actuator held, as a function of the actuator value ``a``.

    A leg whose joints are its actuator, one passive joint and the platform's revolute has its end on a
    **circle** when that passive joint is a revolute (``end = centre + R(φ) v``, ``φ`` the passive angle)
    and on a **line** when it is prismatic (``end = point + s u``, ``s`` the slide). The centre or point
    ``A(a)`` and the vector ``B(a)`` (``v`` or ``u``) are ``X0 + R(a) X1`` for a revolute actuator (an
    absolute angle turns what follows it) and ``X0 + a X1`` for a prismatic one: both are read off the
    leg's chain (:func:`~pkmlab.description.mechanism.leg_chain`) at two actuator values, for any leg type.
    """

    def __init__(self, leg: Leg, number: int):
        from .mechanism import leg_chain

        passive = [k for k, j in enumerate(leg.joints[:-1]) if not j.actuated]
        if len(passive) != 1:
            raise InvalidParameterError(f"leg {number + 1} ({leg.notation}): a leg of pkmlab has its actuator, one "
                                        f"passive joint and the platform's revolute, got {len(passive)} passive "
                                        "joints before the platform")
        self.leg, self.number, self.passive = leg, number, passive[0]
        self.kind = "circle" if leg.joints[self.passive].kind == "R" else "line"
        self.angle = leg.joints[leg.actuated].kind == "R"

        def end(a, phi):
            coords = [0.0, 0.0]
            coords[leg.actuated], coords[self.passive] = a, phi
            return np.array(leg_chain(leg, coords)[-1][0])

        def parts(a):  # (A, B) at actuator a
            if self.kind == "circle":
                e0, e_pi = end(a, 0.0), end(a, math.pi)
                return (e0 + e_pi) / 2, (e0 - e_pi) / 2
            e0 = end(a, 0.0)
            return e0, end(a, 1.0) - e0

        (a0, b0), (a1, b1) = parts(0.0), parts(math.pi if self.angle else 1.0)
        if self.angle:  # f(0) = X0 + X1, f(π) = X0 - X1
            self.A, self.B = ((a0 + a1) / 2, (a0 - a1) / 2), ((b0 + b1) / 2, (b0 - b1) / 2)
        else:  # f(0) = X0, f(1) = X0 + X1
            self.A, self.B = (a0, a1 - a0), (b0, b1 - b0)
        if np.hypot(*self.B[0]) + np.hypot(*self.B[1]) == 0.0:
            raise InvalidParameterError(f"leg {number + 1} ({leg.notation}): its passive joint does not move its end")

    def at(self, a) -> tuple[np.ndarray, np.ndarray]:
        """``A(a)``, ``B(a)`` (..., 2) for actuator values ``a`` (...)."""
        a = np.asarray(a, dtype=float)[..., None]
        out = []
        for x0, x1 in (self.A, self.B):
            if self.angle:
                c, s = np.cos(a), np.sin(a)
                out.append(x0 + np.concatenate([c * x1[0] - s * x1[1], s * x1[0] + c * x1[1]], axis=-1))
            else:
                out.append(x0 + a * x1)
        return out[0], out[1]

    def gap(self, a, points) -> np.ndarray:
        """How far ``points`` (..., 2) are off the locus at actuator ``a`` (...): ``|p - A|² - |B|²`` for a circle,
        ``B × (p - A)`` for a line (zero on the locus, changing sign across it)."""
        centre, b = self.at(a)
        d = points - centre
        if self.kind == "circle":
            return (d * d).sum(axis=-1) - (b * b).sum(axis=-1)
        return b[..., 0] * d[..., 1] - b[..., 1] * d[..., 0]

    def passive_coordinate(self, a, points) -> np.ndarray:
        """The passive coordinate that puts the end at ``points``, on the locus at ``a``."""
        centre, b = self.at(a)
        d = points - centre
        if self.kind == "circle":
            return np.arctan2(d[..., 1], d[..., 0]) - np.arctan2(b[..., 1], b[..., 0])
        return (d * b).sum(axis=-1) / (b * b).sum(axis=-1)

    def domain(self) -> tuple[float, float]:
        """The actuator values searched: its stroke, else a full turn (an angle) or the leg's reach (a slide)."""
        if self.leg.stroke is not None:
            return self.leg.stroke
        if self.angle:
            return -math.pi, math.pi
        reach = sum(math.hypot(*b.tip) for b in self.leg.bodies) + 10.0 * (1.0 + math.hypot(*self.leg.base))
        return -reach, reach


def _actuator_roots(locus: Locus, point: np.ndarray, sigma: int, lo: float, hi: float):
    """The actuator values in ``[lo, hi]`` that put ``point`` (K, 2) on the locus with the gap rising (``sigma =
    +1``) or falling (``-1``) through them: the first of them (K,) and how many there are (K,).

    The gap is exactly a polynomial in the actuator, read off three of its values: ``c0 + c1 cos a + c2 sin a``
    for a revolute actuator (``A(a)`` and ``B(a)`` turn with ``a``, and a turn keeps lengths and cross
    products), ``q0 + q1 a + q2 a²`` for a prismatic one."""
    if locus.angle:
        g0, g90, g180 = (locus.gap(np.full(len(point), a), point) for a in (0.0, 0.5 * math.pi, math.pi))
        c0, c1, c2 = 0.5 * (g0 + g180), 0.5 * (g0 - g180), g90 - 0.5 * (g0 + g180)
        r = np.hypot(c1, c2)
        with np.errstate(divide="ignore", invalid="ignore"):
            cos_delta = -c0 / r
        # c1 cos a + c2 sin a = r cos(a - ψ) = -c0 at a = ψ ∓ δ, where the gap rises (-) or falls (+)
        delta = np.arccos(np.clip(cos_delta, -1.0, 1.0))
        crossing = (np.abs(cos_delta) <= 1.0) & (np.sin(delta) > 0.0)  # a tangency is no crossing
        root = np.where(crossing, np.arctan2(c2, c1) - sigma * delta, lo)  # (where none: refused, kept finite)
        turns = 2.0 * math.pi
        if locus.leg.stroke is None:  # a whole turn: one value, in [-π, π)
            return root - turns * np.floor((root + math.pi) / turns), crossing.astype(np.int64)
        first, last = np.ceil((lo - root) / turns), np.floor((hi - root) / turns)
        count = np.where(crossing, np.maximum(last - first + 1.0, 0.0), 0.0).astype(np.int64)
        return root + turns * first, count
    g_minus, g0, g_plus = (locus.gap(np.full(len(point), a), point) for a in (-1.0, 0.0, 1.0))
    q0, q1, q2 = g0, 0.5 * (g_plus - g_minus), 0.5 * (g_plus + g_minus) - g0
    disc = q1 * q1 - 4.0 * q2 * q0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -0.5 * (q1 + np.copysign(np.sqrt(np.maximum(disc, 0.0)), q1))  # the two roots without cancellation
        roots = np.stack([t / q2, q0 / t])
        slope = q1 + 2.0 * q2 * roots
    wanted = (disc >= 0.0) & ((slope > 0.0) if sigma > 0 else (slope < 0.0)) & (lo <= roots) & (roots <= hi)
    count = wanted.sum(axis=0)
    # where there is none, a value of the domain: the point is refused, its coordinates only kept finite
    return np.where(wanted[0], roots[0], np.where(count > 0, roots[1], lo)), count


def _general(leg: Leg, number: int, point: np.ndarray, sigma: int) -> Solved:
    """Inverse kinematics of any leg of :class:`Locus` form, in closed form: the attachment point lies on the
    leg's locus for the actuator values where :meth:`Locus.gap` vanishes, the roots of a first-degree
    trigonometric polynomial (a revolute actuator) or of a quadratic (a prismatic one) over the actuator's
    domain (:func:`_actuator_roots`). A leg has two such values in general: working mode ``σ = +1`` for the one
    where the gap grows with the actuator value, ``-1`` where it falls. More than one value of the asked sign
    (a stroke longer than a turn) is refused: the working mode would be ambiguous."""
    locus = Locus(leg, number)
    lo, hi = locus.domain()
    actuator, count = _actuator_roots(locus, point, sigma, lo, hi)
    passive = locus.passive_coordinate(actuator, point)
    bad = count != 1

    def why(k):
        if count[k] == 0:
            return (f"leg {number + 1} ({leg.notation}) reaches the attachment point ({point[k, 0]:.6g}, "
                    f"{point[k, 1]:.6g}) in working mode {sigma:+d} with no actuator value in [{lo:.6g}, {hi:.6g}]")
        return (f"leg {number + 1} ({leg.notation}) reaches ({point[k, 0]:.6g}, {point[k, 1]:.6g}) with {count[k]} "
                f"actuator values of working mode {sigma:+d}: its working mode is ambiguous there")

    coordinates = np.empty((point.shape[0], 2))
    coordinates[:, leg.actuated], coordinates[:, locus.passive] = actuator, passive
    return Solved(coordinates, bad, why)


def leg_inverse_kinematics_batch(leg: Leg, number: int, points, sigma: int = 1, base_values=None) -> Solved:
    """:func:`leg_inverse_kinematics` of many attachment points ``(K, 2)`` at once: the coordinates
    ``(K, joints)``, ``bad`` (K,) for the points out of reach and ``why(k)`` naming the reason.

    A kinematically redundant leg needs its base actuators' values ``(K, leg.moving_base)``: its ordinary part
    is solved in the frame of the base they move (origin at its first joint, x axis along the body before it),
    its angles turned back, its actuator's stroke checked on the values in the machine's frame."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not leg.moving_base:
        part = ordinary_part(leg)
        return _solver(part, number)(part, number, points, sigma)
    values = np.asarray(base_values, dtype=float).reshape(len(points), leg.moving_base)
    origin, direction = moving_base(leg, values)
    part = replace(ordinary_part(leg), stroke=None)
    c, s = np.cos(direction), np.sin(direction)
    dx, dy = points[:, 0] - origin[:, 0], points[:, 1] - origin[:, 1]
    solved = _solver(part, number)(part, number, np.column_stack([c * dx + s * dy, c * dy - s * dx]), sigma)
    turns = np.array([j.kind == "R" for j in part.joints[:-1]])
    # the angles turned back into the machine's frame and wrapped to (-pi, pi], where the stroke is read
    turned = wrapped_angle(solved.coordinates + direction[:, None])
    coordinates = np.column_stack([values, np.where(turns, turned, solved.coordinates)])
    bad, why = mark_outside_stroke(leg, number, coordinates[:, leg.actuated], solved.bad, solved.why)
    return Solved(coordinates, bad, why)


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
    leg's length (``RP*R``), the slider's pivot and the passive link (``P*RR``). A kinematically redundant leg is
    given as its ordinary part on its moved base (:func:`pkmlab.algorithms.assembly.ordinary_machine`)."""
    from .mechanism import leg_chain

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
