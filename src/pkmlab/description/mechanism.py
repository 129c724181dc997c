"""A planar parallel manipulator described as data: legs of joints from the base to the platform.

A :class:`Mechanism` is a *model* in the MuJoCo/Pinocchio sense — architecture and inertia,
validated once, never mutated — and, like an MJCF file, it is data: its TOML form
(:mod:`pkmlab.description.files` reads and writes it) describes any planar machine whose legs
are chains of revolute (``R``) and prismatic (``P``) joints. The presets of pkmlab
(:mod:`pkmlab.description.presets`) are written in the same form.

Conventions (pkmlab's, for every mechanism):

* SI units; the machine lies in the x–y plane; ``u(a) = (cos a, sin a)``; every angle is
  absolute, measured counter-clockwise from the base x axis.
* A leg is a serial chain from its base point ``base`` to the platform. Each joint but the last
  moves the body that follows it; the last joint is a passive revolute that carries the
  platform (at the platform's attachment point of that leg).
* Every body has its own frame: origin at the joint that moves it, x axis along the body's
  direction. Its ``tip`` is where the next joint sits, in that frame.
* ``R`` joint: its coordinate is the **absolute** angle of the following body; the joint sits at
  the tip of the preceding body (at ``base`` for the first joint).
* ``P`` joint: its coordinate ``s`` slides the following body along an axis: for the first joint
  of a leg, a rail fixed to the base at absolute angle ``axis``; otherwise the direction of the
  preceding body (a telescopic leg). The following body keeps that direction; its origin is the
  joint's location moved by ``s`` along the axis.
* The platform is ``rigid`` (pose ``(x, y, alpha)``: its reference point and the absolute angle
  of its frame's x axis; attachment points given in that frame) or a ``point`` (pose ``(x, y)``,
  2 DOF: every leg ends at the same point, which may carry a payload mass).
* One joint per leg is actuated (``*`` after its letter in the TOML form:
  ``joints = "R*RR"``, ``"RP*R"``, ``"P*RR"``); actuator values are angles (rad) or
  displacements (m), efforts torques (N·m) or forces (N). A *kinematically redundant* leg has more:
  its first joints, from the base, are actuated too (``"P*R*RR"``, the 3-PRRR's) and carry an ordinary
  leg on a base they move. Their values are controlled coordinates beside the platform's pose — the
  machine has as many degrees of freedom as actuators, the platform three (or two) of them. A leg may
  also carry more actuators than its ordinary part needs (``"R*R*R"``: its elbow driven too), or a
  machine more legs than its pose has coordinates (a 4-RRR): *actuation redundancy*, more actuators
  than degrees of freedom, whose efforts balance each other in part (internal efforts). An actuated
  revolute after another revolute drives its body's absolute angle, as a belt or a parallelogram from
  the base does, its effort a torque against the base. Actuators are numbered ``a1, a2, …`` leg by leg,
  base to platform.
* Gravity is a vector in the plane, zero by default (a machine in the horizontal plane).
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from .._keys import defaults, names
from ..errors import InvalidParameterError
from ._fields import finite_number, known_keys, required, stroke, toml_value
from .keys import MECHANISM, PLANAR_BODY, PLANAR_LEG, PLANAR_PLATFORM

JOINT_KINDS = ("R", "P")
PLATFORM_KINDS = ("rigid", "point")


class LegsAndPose:
    """What every description (planar or spatial) derives from its legs and its platform's pose."""

    #: Whether the machine is spatial (:class:`~pkmlab.description.spatial.SpatialMechanism`) or planar.
    spatial = False

    @functools.cached_property
    def dof(self) -> int:
        """Degrees of freedom: the number of controlled coordinates (:attr:`pose_names`), the mobility; the number of
        actuators too but for a redundantly actuated machine (:attr:`actuation_redundancy`)."""
        return len(self.pose_names)

    @functools.cached_property
    def actuation_redundancy(self) -> int:
        """How many actuators the machine has beyond its degrees of freedom: 0, or, for a redundantly actuated
        machine (a 4-RRR: four actuated legs for the platform's three coordinates), the dimension of its internal
        efforts — the actuator efforts that balance each other and move nothing."""
        return len(self.actuators) - self.dof

    @functools.cached_property
    def pose_names(self) -> tuple[str, ...]:
        """The controlled coordinates: the platform's pose, then the actuators that move a kinematically redundant
        leg's base (:attr:`redundancy_names`)."""
        return (*self.platform.pose_names, *self.redundancy_names)

    @functools.cached_property
    def actuators(self) -> tuple[tuple[int, int], ...]:
        """``(leg, joint)`` of every actuator ``a1, a2, …`` (0-based), leg by leg, base to platform."""
        return tuple((i, k) for i, leg in enumerate(self.legs) for k in leg.actuated_joints)

    @functools.cached_property
    def redundancy_actuators(self) -> tuple[int, ...]:
        """The actuators (0-based indices of :attr:`actuators`) that move the base of a kinematically redundant leg
        (its first :attr:`~JointChain.moving_base` joints), ``(0, 2, 4)`` for a 3-PRRR; empty for a machine whose
        legs have three joints (an ``R*R*R`` leg's second actuator moves no base)."""
        return tuple(k for k, (i, joint) in enumerate(self.actuators) if joint < self.legs[i].moving_base)

    @functools.cached_property
    def redundancy_names(self) -> tuple[str, ...]:
        """The names of :attr:`redundancy_actuators`, ``("a1", "a3", "a5")`` for a 3-PRRR."""
        return tuple(f"a{k + 1}" for k in self.redundancy_actuators)

    @functools.cached_property
    def actuator_kinds(self) -> tuple[str, ...]:
        """``"R"`` (an angle, torque in N·m) or ``"P"`` (a displacement, force in N) per actuator."""
        return tuple(self.legs[i].joints[k].kind for i, k in self.actuators)

    @functools.cached_property
    def notation(self) -> str:
        """E.g. ``"3-R*RR"``, ``"6-UP*S"``, or ``"R*RR + R*RR"`` for legs that differ."""
        names = [leg.notation for leg in self.legs]
        return f"{len(names)}-{names[0]}" if len(set(names)) == 1 else " + ".join(names)


def _point(where: str, value) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise InvalidParameterError(f"{where} must be a point [x, y], got {value!r}")
    return (finite_number(f"{where}[0]", value[0]), finite_number(f"{where}[1]", value[1]))


# ------------------------------------------------------------------ the values
@dataclass(frozen=True)
class Body:
    """A rigid body of a leg: its ``tip`` (where the next joint sits), mass, mass centre and
    moment of inertia about the mass centre, all in the body's frame."""

    tip: tuple[float, float] = (0.0, 0.0)
    mass: float = 0.0
    com: tuple[float, float] = (0.0, 0.0)
    inertia: float = 0.0

    def checked(self, where: str) -> Body:
        return Body(_point(f"{where}.tip", self.tip), finite_number(f"{where}.mass", self.mass, positive=True),
                    _point(f"{where}.com", self.com),
                    finite_number(f"{where}.inertia", self.inertia, non_negative=True))


@dataclass(frozen=True)
class Joint:
    """A joint of a leg: ``kind`` ``"R"`` or ``"P"``, whether it is actuated, and for a prismatic
    joint on the base the rail's absolute angle ``axis`` (rad)."""

    kind: str
    actuated: bool = False
    axis: float | None = None


class JointChain:
    """What every leg (planar or spatial) derives from its joints."""

    #: How many joints an ordinary leg has (a planar one: its actuator, a passive joint and the platform's revolute);
    #: None where the joint count alone does not say (a spatial leg, which never moves its own base).
    ORDINARY_JOINTS: ClassVar[int | None] = None

    @functools.cached_property
    def actuated(self) -> int:
        """Index of the leg's own actuated joint: the first of its ordinary part (:attr:`moving_base`), the one
        whose kind makes the leg's type (``R*RR``'s ``R*``, a ``P*R*RR``'s ``R*``, an ``R*R*R``'s first)."""
        return next(i for i, j in enumerate(self.joints) if j.actuated and i >= self.moving_base)

    @functools.cached_property
    def actuated_joints(self) -> tuple[int, ...]:
        """Indices of the leg's actuated joints, base to platform: one, or more for a kinematically redundant leg
        (its base's) and for a leg of more actuators than its ordinary part needs (actuation redundancy)."""
        return tuple(i for i, j in enumerate(self.joints) if j.actuated)

    @functools.cached_property
    def extra_actuated(self) -> tuple[int, ...]:
        """The leg's actuated joints in its ordinary part after its own (:attr:`actuated`): an ``R*R*R`` leg's
        second, whose actuator only adds to the machine's internal efforts (actuation redundancy); empty for most
        legs."""
        return tuple(k for k in self.actuated_joints if k > self.actuated)

    @functools.cached_property
    def moving_base(self) -> int:
        """How many joints at the base move the base of the leg's ordinary part: a kinematically redundant leg's
        first joints, actuated, beyond the ordinary leg's joint count (``P*R*RR``: 1); 0 for an ordinary leg, and
        for a leg whose extra actuators act within its ordinary part (``R*R*R``)."""
        if self.ORDINARY_JOINTS is None:
            return 0
        leading = next((k for k, j in enumerate(self.joints) if not j.actuated), len(self.joints))
        return max(0, min(leading, len(self.joints) - self.ORDINARY_JOINTS))

    @functools.cached_property
    def notation(self) -> str:
        """The leg in the literature's notation, the actuated joint starred: ``"R*RR"``, ``"UP*S"``."""
        return notation_of(self.joints)

    def own_actuator_only(self):
        """The leg with its :attr:`extra_actuated` joints passive: what its kinematics are solved as (an actuator
        held or moving changes no joint's geometry); the leg itself when it has none."""
        extra = self.extra_actuated
        if not extra:
            return self
        from dataclasses import replace

        return replace(self, joints=tuple(replace(j, actuated=False) if k in extra else j
                                          for k, j in enumerate(self.joints)))


def notation_of(joints) -> str:
    """Joints in the literature's notation, each actuated one starred: ``"R*RR"``, ``"P*R*RR"``."""
    return "".join(j.kind + ("*" if j.actuated else "") for j in joints)


@dataclass(frozen=True)
class Leg(JointChain):
    """A serial chain from ``base`` to the platform: ``joints`` (the last one carries the platform),
    ``bodies`` (one after each joint but the last), the stroke (lower, upper) of its own actuator
    (:attr:`~JointChain.actuated`, the first of its ordinary part) or None."""

    base: tuple[float, float]
    joints: tuple[Joint, ...]
    bodies: tuple[Body, ...]
    stroke: tuple[float, float] | None = None

    ORDINARY_JOINTS: ClassVar[int] = 3


@dataclass(frozen=True)
class Platform:
    """The moving platform: ``kind`` ``"rigid"`` (pose x, y, alpha) or ``"point"`` (pose x, y);
    ``attachments``, one point per leg in the platform frame (origin at the tracked point, x axis
    at angle alpha); mass, mass centre (platform frame) and inertia about the mass centre."""

    kind: str = "rigid"
    attachments: tuple[tuple[float, float], ...] = ()
    mass: float = 0.0
    com: tuple[float, float] = (0.0, 0.0)
    inertia: float = 0.0

    @property
    def pose_names(self) -> tuple[str, ...]:
        return ("x", "y", "alpha") if self.kind == "rigid" else ("x", "y")


@dataclass(frozen=True)
class Mechanism(LegsAndPose):
    """A planar parallel manipulator: its legs, its platform, gravity and a name.

    Validated on construction; every problem is one :class:`~pkmlab.errors.InvalidParameterError`
    line naming the leg, the joint or the body. See the module docstring for the conventions.
    """

    name: str
    legs: tuple[Leg, ...]
    platform: Platform
    gravity: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self):
        set_ = object.__setattr__
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"the mechanism's name must be a non-empty string, got {self.name!r}")
        set_(self, "gravity", _point("gravity", self.gravity))
        platform = self.platform
        if not isinstance(platform, Platform) or platform.kind not in PLATFORM_KINDS:
            kind = getattr(platform, "kind", platform)
            raise InvalidParameterError(f"platform must be 'rigid' or 'point', got {kind!r}")
        legs = tuple(self.legs)
        if not legs:
            raise InvalidParameterError("a mechanism needs legs")
        set_(self, "legs", tuple(self._checked_leg(i + 1, leg) for i, leg in enumerate(legs)))
        set_(self, "platform", self._checked_platform(platform))
        self._check_mobility()

    # -------------------------------------------------------------- validation
    def _checked_leg(self, number: int, leg: Leg) -> Leg:
        where = f"leg {number}"
        if not isinstance(leg, Leg):
            raise InvalidParameterError(f"{where} must be a Leg, got {type(leg).__name__}")
        joints = tuple(leg.joints)
        if len(joints) < 2:
            raise InvalidParameterError(f"{where} needs at least two joints (one actuated, one carrying the "
                                        f"platform), got {len(joints)}")
        for k, joint in enumerate(joints):
            if not isinstance(joint, Joint) or joint.kind not in JOINT_KINDS:
                kind = getattr(joint, "kind", joint)
                raise InvalidParameterError(f"{where}, joint {k + 1}: unknown joint type {kind!r} "
                                            f"(use R for revolute, P for prismatic)")
        actuated = [k for k, j in enumerate(joints) if j.actuated]
        notation = notation_of(joints)
        if not actuated:
            raise InvalidParameterError(f"{where} ({notation}) has no actuated joint: at least one joint per leg is "
                                        "actuated "
                                        "(mark it with *, e.g. R*RR)")
        moved = Leg(leg.base, joints, ()).moving_base
        extra = len(joints) - Leg.ORDINARY_JOINTS
        if moved < extra:
            first = "the first" if extra == 1 else f"the first {extra}"
            raise InvalidParameterError(f"{where} ({notation}) has {len(joints)} joints, {extra} more than an ordinary "
                                        f"leg: {first}, moving the ordinary leg's base, must be actuated (kinematic "
                                        "redundancy, e.g. P*R*RR); a passive one would be a freedom no actuator holds")
        if not any(j.actuated for j in joints[moved:]):
            first = "its first joint moves" if moved == 1 else f"its first {moved} joints move"
            ordinary = notation_of(joints[moved:])
            raise InvalidParameterError(f"{where} ({notation}): the ordinary leg {first} ({ordinary}) has no actuated "
                                        "joint (mark one with *, e.g. P*R*RR)")
        last = joints[-1]
        if last.kind != "R" or last.actuated:
            raise InvalidParameterError(f"{where}: its last joint carries the platform and must be a passive "
                                        f"revolute (R), got {last.kind}{'*' if last.actuated else ''}")
        checked_joints = []
        for k, joint in enumerate(joints):
            axis = joint.axis
            if joint.kind == "P" and k == 0:
                if axis is None:
                    raise InvalidParameterError(f"{where}, joint 1: a prismatic joint on the base needs the "
                                                "rail's absolute angle 'axis' (rad)")
                axis = finite_number(f"{where}, joint 1: axis", axis)
            elif axis is not None:
                raise InvalidParameterError(f"{where}, joint {k + 1}: 'axis' is only for a prismatic joint on the "
                                            "base (a later one slides along the preceding body)")
            checked_joints.append(Joint(joint.kind, bool(joint.actuated), axis))
        bodies = tuple(leg.bodies)
        if len(bodies) != len(joints) - 1:
            raise InvalidParameterError(f"{where} has {len(joints)} joints and so {len(joints) - 1} bodies (one "
                                        f"after each joint but the last), got {len(bodies)}")
        checked_bodies = []
        for k, body in enumerate(bodies):
            if not isinstance(body, Body):
                raise InvalidParameterError(f"{where}, body {k + 1} must be a Body, got {type(body).__name__}")
            checked_bodies.append(body.checked(f"{where}, body {k + 1}"))
        for k in range(len(joints) - 1):  # two revolutes in a row are joined by a link of non-zero length
            if joints[k].kind == "R" and joints[k + 1].kind == "R" and math.hypot(*checked_bodies[k].tip) == 0:
                raise InvalidParameterError(f"{where}, body {k + 1}: its tip must not be at its joint (a link of "
                                            "zero length between two revolute joints)")
        rotates = [any(j.kind == "R" for j in joints[: k + 1]) for k in range(len(bodies))]
        for k, (body, turns) in enumerate(zip(checked_bodies, rotates, strict=True)):
            if turns and body.inertia <= 0:
                raise InvalidParameterError(f"{where}, body {k + 1}: it rotates, so its inertia must be positive, "
                                            f"got {body.inertia:g}")
        return Leg(_point(f"{where}: base", leg.base), tuple(checked_joints), tuple(checked_bodies),
                   stroke(where, leg.stroke))

    def _checked_platform(self, platform: Platform) -> Platform:
        n = len(self.legs)
        if platform.kind == "point":
            given = platform.attachments or ()
            if any(_point(f"platform attachment {i + 1}", p) != (0.0, 0.0) for i, p in enumerate(given)):
                raise InvalidParameterError("a point platform has no attachment points: every leg ends at the "
                                            "tracked point")
            attachments = ((0.0, 0.0),) * n
            mass = finite_number("platform mass (payload)", platform.mass, non_negative=True)
            return Platform("point", attachments, mass, (0.0, 0.0), 0.0)
        attachments = tuple(_point(f"platform attachment {i + 1}", p) for i, p in enumerate(platform.attachments))
        if len(attachments) != n:
            raise InvalidParameterError(f"the platform needs one attachment point per leg: {n} legs, "
                                        f"{len(attachments)} attachment points")
        for i in range(n):
            for k in range(i):
                if math.dist(attachments[i], attachments[k]) == 0:
                    raise InvalidParameterError(f"platform attachments {k + 1} and {i + 1} coincide: a rigid "
                                                "platform needs them apart")
        return Platform("rigid", attachments, finite_number("platform mass", platform.mass, positive=True),
                        _point("platform com", platform.com),
                        finite_number("platform inertia", platform.inertia, positive=True))

    def _check_mobility(self) -> None:
        """Grübler's count for planar chains, ``3 (bodies - 1) - 2 joints``, must equal the degrees of freedom (a
        point platform's idle spin about its own point discounted): the pose's dimension, plus the actuators that
        move a kinematically redundant leg's base. A leg beyond the pose's dimension adds an actuator, not a degree
        of freedom: actuation redundancy."""
        dof = len(self.platform.pose_names)
        if len(self.legs) < dof:  # one ordinary leg per pose coordinate; more: actuation redundancy
            raise InvalidParameterError(f"a {self.platform.kind} platform (pose {', '.join(self.platform.pose_names)}) "
                                        f"needs at least {dof} actuated legs, got {len(self.legs)}")
        bodies = 1 + sum(len(leg.bodies) for leg in self.legs) + 1  # base, leg bodies, platform
        joints = sum(len(leg.joints) for leg in self.legs)
        mobility = 3 * (bodies - 1) - 2 * joints - (1 if self.platform.kind == "point" else 0)
        if mobility != self.dof:
            extra = (f" and {len(self.redundancy_names)} moving its legs' bases" if self.redundancy_names else "")
            raise InvalidParameterError(
                f"the mechanism's mobility (Grübler: 3 x {bodies - 1} moving bodies - 2 x {joints} joints"
                f"{' - 1, the point platform' if self.platform.kind == 'point' else ''} = {mobility}) is not its "
                f"{self.dof} degrees of freedom ({dof} for its pose {', '.join(self.platform.pose_names)}{extra}); "
                f"{len(self.legs)} legs of {', '.join(leg.notation for leg in self.legs)}")


# ------------------------------------------------------------------ leg kinematics (one numeric reference)
def leg_chain(leg: Leg, coordinates) -> list[tuple[tuple[float, float], float]]:
    """Origin and direction of every body of ``leg`` (and, last, the platform attachment point with the
    direction of the last body) for the leg's joint coordinates, one per joint but the last.

    The plain, readable statement of the chain conventions (module docstring), used by tests and as
    the reference the generated kernels are checked against::

        >>> leg = Leg((0.0, 0.0), (Joint("R", True), Joint("R"), Joint("R")),
        ...           (Body((0.25, 0.0), 1.0, (0.125, 0.0), 1e-3), Body((0.1667, 0.0), 1.0, (0.08, 0.0), 1e-3)))
        >>> [tuple(round(c, 4) for c in o) for o, _ in leg_chain(leg, [math.pi / 2, 0.0])]
        [(0.0, 0.0), (0.0, 0.25), (0.1667, 0.25)]
    """
    coordinates = [float(c) for c in coordinates]
    if len(coordinates) != len(leg.joints) - 1:
        raise InvalidParameterError(f"a {leg.notation} leg has {len(leg.joints) - 1} joint coordinates, got "
                                    f"{len(coordinates)}")
    point, direction = leg.base, 0.0
    out = []
    for k, (joint, body, q) in enumerate(zip(leg.joints, leg.bodies, coordinates, strict=False)):
        if joint.kind == "R":
            direction = q
            origin = point
        else:
            axis = joint.axis if k == 0 else direction
            origin = (point[0] + q * math.cos(axis), point[1] + q * math.sin(axis))
            direction = axis
        out.append((origin, direction))
        c, s = math.cos(direction), math.sin(direction)
        point = (origin[0] + c * body.tip[0] - s * body.tip[1], origin[1] + s * body.tip[0] + c * body.tip[1])
    out.append((point, direction))
    return out


def moving_base(leg: Leg, values) -> tuple[np.ndarray, np.ndarray]:
    """Where the ordinary part of a kinematically redundant ``leg`` starts (:func:`ordinary_part`), for the values
    ``(K, leg.moving_base)`` of its base actuators: the position of its first joint ``(K, 2)`` and the direction
    of the body before it ``(K,)`` (rad) — the chain conventions of :func:`leg_chain`, for many values at once."""
    values = np.asarray(values, dtype=float).reshape(-1, leg.moving_base)
    point = np.tile(np.asarray(leg.base, dtype=float), (len(values), 1))
    direction = np.zeros(len(values))
    for k in range(leg.moving_base):
        joint, body, v = leg.joints[k], leg.bodies[k], values[:, k]
        if joint.kind == "R":
            direction = v
        else:
            axis = np.full(len(values), joint.axis) if k == 0 else direction
            point = point + v[:, None] * np.column_stack([np.cos(axis), np.sin(axis)])
            direction = axis
        c, s = np.cos(direction), np.sin(direction)
        point = point + np.column_stack([c * body.tip[0] - s * body.tip[1], s * body.tip[0] + c * body.tip[1]])
    return point, direction


def leg_columns(description) -> list[list[int]]:
    """The columns of a configuration ``q`` (actuators, passive joint coordinates leg by leg, pose: the generated
    kernels' order) of each leg's joint coordinates, in the order of its joints (a universal joint's two): its
    actuators among ``q``'s first (numbered leg by leg), its passive ones among those after them. For a planar or a
    spatial description."""
    n = len(description.actuators)
    actuators, passive = iter(range(n)), itertools.count(n)
    return [[next(actuators) if joint.actuated else next(passive)
             for joint in leg.joints[:-1] for _ in range(getattr(joint, "coordinates", 1))]
            for leg in description.legs]


def ordinary_part(leg: Leg, origin=(0.0, 0.0), direction: float = 0.0) -> Leg:
    """The ordinary leg (one actuator, its own) of ``leg``: a kinematically redundant leg's carried on the base its
    first actuators move, with that base at ``origin`` and the body before it at angle ``direction`` (what a first
    prismatic joint slides along); its extra actuators (:attr:`~JointChain.extra_actuated`) passive, which move
    nothing the ordinary leg's kinematics does not; ``leg`` itself when it has one actuator."""
    leg, k = leg.own_actuator_only(), leg.moving_base
    if not k:
        return leg
    joints = list(leg.joints[k:])
    if joints[0].kind == "P":
        joints[0] = Joint("P", joints[0].actuated, float(direction))
    return Leg((float(origin[0]), float(origin[1])), tuple(joints), leg.bodies[k:], leg.stroke)


def attachment_point(mechanism: Mechanism, leg: int, pose) -> tuple[float, float]:
    """Where leg ``leg`` (0-based) meets the platform at ``pose``: ``(x, y) + R(alpha)·attachment``; ``pose`` the
    platform's, or every controlled coordinate (a kinematically redundant machine's base actuators are not read)."""
    pose = [float(v) for v in pose]
    if len(pose) not in (mechanism.dof, len(mechanism.platform.pose_names)):
        raise InvalidParameterError(f"pose must be ({', '.join(mechanism.pose_names)}), got {len(pose)} values")
    x, y = attachment_points(mechanism, leg, np.array([pose]))[0]
    return (float(x), float(y))


def attachment_points(mechanism: Mechanism, leg: int, poses: np.ndarray, turns=None) -> np.ndarray:
    """:func:`attachment_point` of many poses ``(K, dof)`` at once, ``(K, 2)``; ``turns``: the platform's
    :func:`platform_turns` at those poses, where the caller has them (one computation for every leg)."""
    ax, ay = mechanism.platform.attachments[leg]  # (0, 0) for a point platform
    c, s = platform_turns(mechanism, poses) if turns is None else turns
    return np.column_stack([poses[:, 0] + c * ax - s * ay, poses[:, 1] + s * ax + c * ay])


def platform_turns(mechanism: Mechanism, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(cos α, sin α)`` of the platform's orientation at many poses ``(K, dof)`` (a point platform: α = 0)."""
    alpha = poses[:, 2] if mechanism.platform.kind == "rigid" else np.zeros(len(poses))
    return np.cos(alpha), np.sin(alpha)


# ------------------------------------------------------------------ the TOML form
#: Keys of the TOML form, by table (declared in :mod:`pkmlab.description.keys`).
MECHANISM_KEYS = names(MECHANISM)
PLATFORM_KEYS = names(PLANAR_PLATFORM)
LEG_KEYS = names(PLANAR_LEG)
BODY_KEYS = names(PLANAR_BODY)
_DEFAULTS = {"mechanism": defaults(MECHANISM), "platform": defaults(PLANAR_PLATFORM), "leg": defaults(PLANAR_LEG),
             "body": defaults(PLANAR_BODY)}
_JOINTS = re.compile(r"^([RP]\*?)+$")


def scaled_mechanism(mechanism: Mechanism, mass: float = 1.0, length: float = 1.0) -> Mechanism:
    """The same machine with every body's mass ×``mass``, its inertia ×``mass·length²`` (I ∝ m L²), and
    every length of its bodies and platform ×``length`` (tips, mass centres, attachment points); the
    base points, rail directions and actuator strokes are unchanged — the paper's disturbed plant
    (its section 5) for any mechanism."""
    def body(b: Body) -> Body:
        return Body((b.tip[0] * length, b.tip[1] * length), b.mass * mass, (b.com[0] * length, b.com[1] * length),
                    b.inertia * mass * length**2)

    legs = tuple(Leg(leg.base, leg.joints, tuple(body(b) for b in leg.bodies), leg.stroke) for leg in mechanism.legs)
    p = mechanism.platform
    platform = Platform(p.kind, tuple((x * length, y * length) for x, y in p.attachments), p.mass * mass,
                        (p.com[0] * length, p.com[1] * length), p.inertia * mass * length**2)
    return Mechanism(mechanism.name, legs, platform, mechanism.gravity)


def _joints(text, where: str) -> tuple[Joint, ...]:
    compact = text.replace(" ", "") if isinstance(text, str) else None
    if compact is None or not _JOINTS.match(compact):
        raise InvalidParameterError(f"{where}.joints must be letters R (revolute) and P (prismatic) from the base to "
                                    f"the platform, the actuated one starred, e.g. \"R*RR\" or \"RP*R\"; got {text!r}")
    return tuple(Joint(m.group(0)[0], m.group(0).endswith("*")) for m in re.finditer(r"[RP]\*?", compact))


def platform_and_legs(table: dict, where: str, platform_keys, kinds, point: str):
    """The ``[mechanism.platform]`` table checked (its keys, its ``kind`` among ``kinds``, its attachment list of
    ``point``s) and the list of ``[[mechanism.leg]]`` tables: ``(platform, kind, attachments, legs)``."""
    platform = known_keys(required(table, "platform", where), platform_keys, f"{where}.platform")
    kind = platform.get("kind", "rigid")
    if kind not in kinds:
        raise InvalidParameterError(f"{where}.platform.kind must be {' or '.join(repr(k) for k in kinds)}, got "
                                    f"{kind!r}")
    attachments = platform.get("attachments", ())
    if not isinstance(attachments, list | tuple):
        raise InvalidParameterError(f"{where}.platform.attachments must be a list of points {point}")
    legs = required(table, "leg", where)
    if not isinstance(legs, list) or not legs:
        raise InvalidParameterError(f"{where}.leg must be a list of legs ([[mechanism.leg]] tables)")
    return platform, kind, attachments, legs


def planar_mechanism_from_dict(table: dict, source: str = "[mechanism]") -> Mechanism:
    """The planar mechanism of a ``[mechanism]`` table whose keys are known (:data:`MECHANISM_KEYS`) and that
    names no preset: :func:`pkmlab.description.files.mechanism_from_dict` reads every table."""
    where = source
    platform, kind, attachments, legs_table = platform_and_legs(table, where, PLATFORM_KEYS, PLATFORM_KINDS,
                                                                "[x, y]")
    legs = []
    for i, leg in enumerate(legs_table):
        lw = f"{where}.leg[{i + 1}]"
        leg = known_keys(leg, LEG_KEYS, lw)
        joints = list(_joints(required(leg, "joints", lw), lw))
        if "axis" in leg:
            joints[0] = Joint(joints[0].kind, joints[0].actuated, leg["axis"])
        bodies = leg.get("bodies", _DEFAULTS["leg"]["bodies"])
        if not isinstance(bodies, list):
            raise InvalidParameterError(f"{lw}.bodies must be a list of bodies")
        parsed = []
        for k, body in enumerate(bodies):
            bw = f"{lw}.bodies[{k + 1}]"
            body = {**_DEFAULTS["body"], **known_keys(body, BODY_KEYS, bw)}
            parsed.append(Body(body["tip"], required(body, "mass", bw), body["com"], body["inertia"]))
        legs.append(Leg(required(leg, "base", lw), tuple(joints), tuple(parsed), leg.get("stroke")))
    platform = {**_DEFAULTS["platform"], **platform}
    table = {**_DEFAULTS["mechanism"], **table}
    return Mechanism(table["name"], tuple(legs),
                     Platform(kind, tuple(attachments), platform["mass"], platform["com"], platform["inertia"]),
                     table["gravity"])


def planar_mechanism_to_toml(mechanism: Mechanism, comment: str | None = None) -> str:
    """The TOML form of a planar ``mechanism``, as :func:`pkmlab.description.files.mechanism_to_toml` writes
    it."""
    lines = [f"# {line}" for line in (comment or "").splitlines()]
    lines += [""] if lines else []
    m = mechanism
    lines += ["[mechanism]", f"name = {toml_value(m.name)}", f"gravity = {toml_value(m.gravity)}", "",
              "[mechanism.platform]", f"kind = {toml_value(m.platform.kind)}"]
    if m.platform.kind == "rigid":
        lines += [f"attachments = {toml_value(m.platform.attachments)}   # platform frame, one per leg"]
    lines += [f"mass = {toml_value(m.platform.mass)}"]
    if m.platform.kind == "rigid":
        lines += [f"com = {toml_value(m.platform.com)}", f"inertia = {toml_value(m.platform.inertia)}"]
    for leg in m.legs:
        lines += ["", "[[mechanism.leg]]", f"base = {toml_value(leg.base)}", f"joints = {toml_value(leg.notation)}"]
        if leg.joints[0].axis is not None:
            lines += [f"axis = {toml_value(leg.joints[0].axis)}"]
        if leg.stroke is not None:
            lines += [f"stroke = {toml_value(leg.stroke)}"]
        lines += ["bodies = ["]
        lines += [f"  {{ tip = {toml_value(b.tip)}, mass = {toml_value(b.mass)}, com = {toml_value(b.com)}, "
                  f"inertia = {toml_value(b.inertia)} }}," for b in leg.bodies]
        lines += ["]"]
    return "\n".join(lines) + "\n"
