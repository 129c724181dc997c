"""A spatial parallel manipulator described as data: legs of R, P, U and S joints, bodies with
inertia tensors, gravity as a vector — the Delta robot and the Stewart–Gough platform among them.

The spatial counterpart of :mod:`pkmlab.description.mechanism` (whose planar machines stay as
they are). A :class:`SpatialMechanism` is an immutable *model*, validated once.

Conventions (pkmlab's, for every spatial mechanism):

* SI units; a right-handed world frame, ``z`` up in the presets; gravity is a vector
  (``(0, 0, -9.81)`` for a machine working against gravity).
* **The zero configuration.** Every joint coordinate zero, every body's frame is parallel to the
  world's. Joint axes, body tips and mass centres are given in that configuration (like an MJCF file
  whose bodies carry no rotation): a body's frame has its origin at the joint that moves it.
* A leg is a serial chain from its ``base`` point to the platform, of any number of joints:

  - ``R`` (revolute, 1 coordinate): the following body turns by the coordinate (rad, right-hand
    rule) about ``axis``, fixed in the preceding body; the joint sits at the preceding body's tip
    (at ``base`` for the first joint);
  - ``P`` (prismatic, 1 coordinate): the following body slides by the coordinate (m) along ``axis``
    and keeps the preceding body's orientation; its origin is the preceding tip moved along the axis;
  - ``U`` (universal, 2 coordinates): a turn about ``axes[0]`` (fixed in the preceding body), then
    about ``axes[1]`` (carried by the first turn); the two axes must be perpendicular;
  - ``S`` (spherical, no coordinate): the last joint, and only there: it carries the platform at
    the tip of the leg's last body (the platform's attachment point of that leg).

  The last joint is the leg's *platform joint*: an ``S``, or a passive ``U`` (a 3-UPU): its first axis fixed
  in the leg's last body, its second in the platform. A platform joint's angles are not coordinates: they
  follow from the leg's last body and the platform's orientation (:func:`platform_joint_angles`), and the
  leg's joint coordinates are those of the joints before it. Under a rigid platform a ``U`` closes the loop
  by one equation more than an ``S``: its two axes stay perpendicular (:mod:`pkmlab.description.mobility`);
  and a leg may end in a passive ``R``, its axis fixed in both the leg's last body and the platform (two
  equations more: a spherical wrist's, whose axes all meet at its centre).

  One joint of each leg, ``R*`` or ``P*``, anywhere in the chain, is actuated: the leg's own actuator. A leg may
  carry more (``R*R*S``: a 3-RRS leg whose knee is driven too): the machine is then redundantly actuated, its
  actuators more than its degrees of freedom; the leg's own actuator is its first (its stroke the file's).
* The platform is ``translating`` (pose ``(x, y, z)``: its orientation is held fixed by its legs —
  parallelogram forearms, as the Delta's are, a forearm between a universal joint and the spherical
  joint, a ``…US`` leg; or universal joints at the platform whose axes keep it level, as Tsai's 3-UPU's;
  three legs) or ``rigid`` (pose
  ``(x, y, z, roll, pitch, yaw)``). Its orientation is ``R = Rz(yaw)·Ry(pitch)·Rx(roll)``:
  yaw about the world's z, then pitch about the new y, then roll about the newest x (the z-y'-x''
  convention of aeronautics and ROS); it is singular at ``pitch = ±π/2`` (gimbal lock), where poses are
  refused. Attachment points and the mass centre are in the platform frame, whose origin is the
  tracked point.
* **Lower mobility.** A rigid platform on fewer than six legs moves in as many coordinates as it has
  legs: the user names them, ``controlled`` (e.g. ``("z", "roll", "pitch")`` for a 3-PRS), and the
  others are the *parasitic* motions the legs impose, which pkmlab computes. In the coordinates ``q``
  of the generated kernels the parasitic ones come before the controlled ones (:attr:`SpatialPlatform.q_pose_names`),
  so that the pose a trajectory gives is always ``q``'s last entries. The machine's mobility is computed,
  not assumed (:mod:`pkmlab.description.mobility`).
* Inertia tensors are 3×3, about the body's mass centre, in the body's frame (symmetric, positive
  semi-definite, principal moments obeying the triangle inequality); a thin rod along x may have
  ``I_xx = 0``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .._keys import defaults, names
from ..errors import InvalidParameterError
from ._fields import finite_number, known_keys, required, stroke, toml_value
from .keys import SPATIAL_BODY, SPATIAL_LEG, SPATIAL_MECHANISM, SPATIAL_PLATFORM
from .mechanism import JointChain, LegsAndPose, platform_and_legs

SPATIAL_JOINTS = ("R", "P", "U", "S")
#: The joints that may carry the platform, a leg's last (module docstring).
PLATFORM_JOINTS = ("S", "U", "R")
SPATIAL_PLATFORMS = ("translating", "rigid")
#: The pose's coordinates of each platform kind.
POSE_NAMES = {"translating": ("x", "y", "z"), "rigid": ("x", "y", "z", "roll", "pitch", "yaw")}
_COORDINATES = {"R": 1, "P": 1, "U": 2, "S": 0}
#: Pitch closer than this to ±π/2 (rad) is gimbal lock: roll and yaw are no longer told apart.
GIMBAL_MARGIN = 1e-6
#: Joint coordinates of each joint type.
JOINT_COORDINATES = _COORDINATES


def _vector(where: str, value) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 3:
        raise InvalidParameterError(f"{where} must be a vector [x, y, z], got {value!r}")
    return tuple(finite_number(f"{where}[{k}]", v) for k, v in enumerate(value))


#: How far from 1 an axis's norm may be (a unit vector written to five digits) and be normalised; beyond, refused.
UNIT_TOLERANCE = 1e-5


def _unit(where: str, value) -> tuple[float, float, float]:
    v = np.array(_vector(where, value))
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise InvalidParameterError(f"{where} must be a non-zero direction, got {list(value)!r}")
    if abs(norm - 1.0) <= 1e-15:  # unit already (to round-off): kept as given, so that a description reads back equal
        return tuple(float(c) for c in v)
    if abs(norm - 1.0) > UNIT_TOLERANCE:  # not a unit vector written to few digits: a mistake, not to be guessed at
        raise InvalidParameterError(f"{where} must be a unit vector, got {list(value)!r} (norm {norm:.6g}): divide it "
                                    "by its norm")
    return tuple(float(c) for c in v / norm)


def _tensor(where: str, value) -> tuple[tuple[float, float, float], ...]:
    """A 3×3 inertia tensor: symmetric, positive semi-definite, principal moments obeying the triangle
    inequality (every real body's do). A number ``I`` is read as ``I·identity``."""
    if not isinstance(value, (list, tuple)):
        v = finite_number(where, value, non_negative=True)
        return ((v, 0.0, 0.0), (0.0, v, 0.0), (0.0, 0.0, v))
    if len(value) != 3 or any(isinstance(r, (str, bytes)) or not hasattr(r, "__len__") or len(r) != 3
                              for r in value):
        raise InvalidParameterError(f"{where} must be a 3x3 inertia tensor [[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], "
                                    f"[Ixz, Iyz, Izz]], got {value!r}")
    t = np.array([[finite_number(f"{where}[{i}][{j}]", value[i][j]) for j in range(3)] for i in range(3)])
    scale = max(float(np.abs(t).max()), 1e-300)
    if np.abs(t - t.T).max() > 1e-12 * scale:
        raise InvalidParameterError(f"{where} must be symmetric, got {t.tolist()}")
    moments = np.linalg.eigvalsh(t)
    if moments[0] < -1e-12 * scale:
        raise InvalidParameterError(f"{where} must be positive semi-definite, its principal moments are "
                                    f"{', '.join(f'{m:.4g}' for m in moments)}")
    if moments[0] + moments[1] < moments[2] - 1e-9 * scale:
        raise InvalidParameterError(f"{where}: principal moments {', '.join(f'{m:.4g}' for m in moments)} break the "
                                    "triangle inequality (no body has them)")
    return tuple(tuple(float(c) for c in row) for row in (t + t.T) / 2)


# ------------------------------------------------------------------ the values
@dataclass(frozen=True)
class SpatialBody:
    """A rigid body of a leg: its ``tip`` (where the next joint sits), mass, mass centre and inertia
    tensor about the mass centre, all in the body's frame (module docstring)."""

    tip: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mass: float = 0.0
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))

    def checked(self, where: str) -> SpatialBody:
        return SpatialBody(_vector(f"{where}.tip", self.tip), finite_number(f"{where}.mass", self.mass, positive=True),
                           _vector(f"{where}.com", self.com), _tensor(f"{where}.inertia", self.inertia))


@dataclass(frozen=True)
class SpatialJoint:
    """A joint: ``kind`` R, P, U or S, whether it is actuated, and its ``axes`` (one for R and P, two
    perpendicular ones for U, none for S) in the preceding body's frame."""

    kind: str
    actuated: bool = False
    axes: tuple = ()

    @property
    def coordinates(self) -> int:
        return _COORDINATES[self.kind]


@dataclass(frozen=True)
class SpatialLeg(JointChain):
    """A serial chain from ``base`` to the platform: ``joints`` (the last the platform joint, an S, a U or an R),
    ``bodies`` (one after each joint but the platform joint), the ``stroke`` (lower, upper) of its own actuator (its
    first) or None."""

    base: tuple[float, float, float]
    joints: tuple[SpatialJoint, ...]
    bodies: tuple[SpatialBody, ...]
    stroke: tuple[float, float] | None = None


@dataclass(frozen=True)
class SpatialPlatform:
    """The moving platform: ``kind`` ``"translating"`` or ``"rigid"``; ``attachments`` (one point per leg,
    platform frame); mass, mass centre (platform frame) and inertia tensor about the mass centre;
    ``controlled``, the pose coordinates the actuators control (None: all of the kind's; a rigid platform
    on fewer than six legs names them, module docstring)."""

    kind: str = "translating"
    attachments: tuple = ()
    mass: float = 0.0
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    controlled: tuple[str, ...] | None = None

    @property
    def full_pose_names(self) -> tuple[str, ...]:
        """Every coordinate of the platform's pose, controlled or not: ``(x, y, z)`` or all six."""
        return POSE_NAMES[self.kind]

    @property
    def pose_names(self) -> tuple[str, ...]:
        """The controlled pose coordinates, in the order of :attr:`full_pose_names`: what a pose, a trajectory
        and inverse kinematics give."""
        return POSE_NAMES[self.kind] if self.controlled is None else tuple(self.controlled)

    @property
    def parasitic_names(self) -> tuple[str, ...]:
        """The pose coordinates the legs impose (empty unless the platform has lower mobility)."""
        return tuple(n for n in POSE_NAMES[self.kind] if n not in self.pose_names)

    @property
    def q_pose_names(self) -> tuple[str, ...]:
        """The pose's coordinates as ``q`` orders them: the parasitic ones, then the controlled ones."""
        return (*self.parasitic_names, *self.pose_names)


@dataclass(frozen=True)
class SpatialMechanism(LegsAndPose):
    """A spatial parallel manipulator: legs, platform, gravity (a 3-vector) and a name.

    Validated on construction: every problem is one :class:`~pkmlab.errors.InvalidParameterError` line
    naming the leg, the joint or the body. See the module docstring for the conventions.
    """

    name: str
    legs: tuple[SpatialLeg, ...]
    platform: SpatialPlatform
    gravity: tuple[float, float, float] = (0.0, 0.0, 0.0)

    #: Every spatial description says so; a planar :class:`~pkmlab.description.mechanism.Mechanism` does not.
    spatial = True

    def __post_init__(self):
        set_ = object.__setattr__
        if not isinstance(self.name, str) or not self.name:
            raise InvalidParameterError(f"the mechanism's name must be a non-empty string, got {self.name!r}")
        set_(self, "gravity", _vector("gravity", self.gravity))
        platform = self.platform
        if not isinstance(platform, SpatialPlatform) or platform.kind not in SPATIAL_PLATFORMS:
            kind = getattr(platform, "kind", platform)
            raise InvalidParameterError(f"a spatial platform is 'translating' or 'rigid', got {kind!r}")
        legs = tuple(self.legs)
        platform = _checked_controlled(platform, len(legs))
        dof = len(platform.pose_names)
        if len(legs) < dof:  # one leg per controlled coordinate; more: actuation redundancy
            raise InvalidParameterError(f"a {platform.kind} platform (pose {', '.join(platform.pose_names)}) needs "
                                        f"at least {dof} actuated legs, got {len(legs)}")
        set_(self, "legs", tuple(self._checked_leg(i + 1, leg) for i, leg in enumerate(legs)))
        for i, leg in enumerate(self.legs):
            if leg.joints[-1].kind == "R" and platform.kind != "rigid":
                raise InvalidParameterError(f"leg {i + 1} ({leg.notation}) ends in a revolute joint, which carries a "
                                            "rigid platform only (a translating platform's legs end in S or U)")
        set_(self, "platform", self._checked_platform(platform))

    def _checked_leg(self, number: int, leg: SpatialLeg) -> SpatialLeg:
        where = f"leg {number}"
        if not isinstance(leg, SpatialLeg):
            raise InvalidParameterError(f"{where} must be a SpatialLeg, got {type(leg).__name__}")
        joints = tuple(leg.joints)
        for k, joint in enumerate(joints):
            if not isinstance(joint, SpatialJoint) or joint.kind not in SPATIAL_JOINTS:
                kind = getattr(joint, "kind", joint)
                raise InvalidParameterError(f"{where}, joint {k + 1}: unknown joint type {kind!r} (use R, P, U or S)")
        if not joints or joints[-1].kind not in PLATFORM_JOINTS or joints[-1].actuated:
            raise InvalidParameterError(f"{where}: its last joint carries the platform and must be a passive "
                                        "spherical joint (S), universal joint (U) or, under a rigid platform, "
                                        "revolute joint (R)")
        if any(j.kind == "S" for j in joints[:-1]):
            raise InvalidParameterError(f"{where}: a spherical joint (S) may only be the last joint")
        actuated = [k for k, j in enumerate(joints) if j.actuated]
        if not actuated:
            raise InvalidParameterError(f"{where} ({''.join(j.kind for j in joints)}) has no actuated joint: an R or P "
                                        "joint of each leg is actuated (mark it with *, e.g. R*US or UP*S)")
        for k in actuated:
            if joints[k].kind not in ("R", "P"):
                raise InvalidParameterError(f"{where}, joint {k + 1}: an actuated {joints[k].kind} joint; only R and P "
                                            "joints are actuated (mark them with *, e.g. R*US, UP*S, R*R*S)")
        checked = []
        for k, joint in enumerate(joints):
            axes = tuple(joint.axes)
            wanted = {"R": 1, "P": 1, "U": 2, "S": 0}[joint.kind]
            if len(axes) != wanted:
                raise InvalidParameterError(f"{where}, joint {k + 1} ({joint.kind}): needs {wanted} axis vector(s), "
                                            f"got {len(axes)}")
            axes = tuple(_unit(f"{where}, joint {k + 1} ({joint.kind}): axis {a + 1}", v) for a, v in enumerate(axes))
            if joint.kind == "U" and abs(float(np.dot(axes[0], axes[1]))) > 1e-9:
                angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(axes[0], axes[1]))))))
                raise InvalidParameterError(f"{where}, joint {k + 1} (U): its two axes must be perpendicular, they "
                                            f"are {angle:.3g} degrees apart (a degenerate universal joint)")
            checked.append(SpatialJoint(joint.kind, bool(joint.actuated), axes))
        bodies = tuple(leg.bodies)
        if len(bodies) != len(joints) - 1:
            raise InvalidParameterError(f"{where} has {len(joints)} joints and so {len(joints) - 1} bodies (one after "
                                        f"each joint but the platform joint), got {len(bodies)}")
        checked_bodies = []
        for k, body in enumerate(bodies):
            if not isinstance(body, SpatialBody):
                raise InvalidParameterError(f"{where}, body {k + 1} must be a SpatialBody, got {type(body).__name__}")
            checked_bodies.append(body.checked(f"{where}, body {k + 1}"))
        return SpatialLeg(_vector(f"{where}: base", leg.base), tuple(checked), tuple(checked_bodies),
                          stroke(where, leg.stroke))

    def _checked_platform(self, platform: SpatialPlatform) -> SpatialPlatform:
        n = len(self.legs)
        attachments = tuple(_vector(f"platform attachment {i + 1}", p) for i, p in enumerate(platform.attachments))
        if len(attachments) != n:
            raise InvalidParameterError(f"the platform needs one attachment point per leg: {n} legs, "
                                        f"{len(attachments)} attachment points")
        if platform.kind == "rigid":
            for i in range(n):
                for k in range(i):
                    if math.dist(attachments[i], attachments[k]) == 0:
                        raise InvalidParameterError(f"platform attachments {k + 1} and {i + 1} coincide: a rigid "
                                                    "platform of six legs needs them apart")
        return SpatialPlatform(platform.kind, attachments, finite_number("platform mass", platform.mass, positive=True),
                               _vector("platform com", platform.com), _tensor("platform inertia", platform.inertia),
                               platform.controlled)


def _checked_controlled(platform, legs: int):
    """``platform`` with its ``controlled`` coordinates checked and put in the pose's order (None when they are
    all of its kind's), or as given when it is not a platform (the caller refuses it)."""
    if not isinstance(platform, SpatialPlatform) or platform.kind not in SPATIAL_PLATFORMS:
        return platform
    names = POSE_NAMES[platform.kind]
    given = platform.controlled
    if given is None:
        if platform.kind == "rigid" and legs < 6:  # (more legs than six: a redundantly actuated platform)
            raise InvalidParameterError(
                f"a rigid platform on {legs} legs moves in at most {legs} of its pose's coordinates: name them, "
                f"controlled = [...] among {', '.join(names)} (e.g. [\"z\", \"roll\", \"pitch\"] for a 3-PRS); the "
                "others are the parasitic motions its legs impose")
        return platform
    if isinstance(given, (str, bytes)) or not hasattr(given, "__iter__"):
        raise InvalidParameterError(f"the platform's controlled coordinates must be a list of names among "
                                    f"{', '.join(names)}, got {given!r}")
    given = list(given)
    for name in given:
        if name not in names:
            from .._format import suggestion

            raise InvalidParameterError(f"the platform's controlled coordinates: unknown name {name!r} "
                                        f"(a {platform.kind} platform's pose is {', '.join(names)})"
                                        f"{suggestion(str(name), names)}")
    if len(set(given)) != len(given):
        raise InvalidParameterError(f"the platform's controlled coordinates name one twice: {given}")
    ordered = tuple(n for n in names if n in given)
    return SpatialPlatform(platform.kind, platform.attachments, platform.mass, platform.com, platform.inertia,
                           None if ordered == names else ordered)


# ------------------------------------------------------------------ rotations (one numeric reference)
def axis_rotation(axis, angle: float) -> np.ndarray:
    """Rodrigues: the rotation by ``angle`` about the unit ``axis``."""
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def orientation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``Rz(yaw)·Ry(pitch)·Rx(roll)`` (module docstring)."""
    return orientations(np.array([[roll, pitch, yaw]], dtype=float))[0]


def orientation_angles(rot) -> tuple[float, float, float]:
    """``(roll, pitch, yaw)`` of a rotation matrix ``rot = Rz(yaw)·Ry(pitch)·Rx(roll)``, pitch in [-π/2, π/2]: the
    inverse of :func:`orientation` away from gimbal lock."""
    pitch = -math.asin(max(-1.0, min(1.0, float(rot[2][0]))))
    return math.atan2(rot[2][1], rot[2][2]), pitch, math.atan2(rot[1][0], rot[0][0])


def orientations_angles(rot) -> np.ndarray:
    """:func:`orientation_angles` of many rotations (K, 3, 3) at once, (K, 3): pitch in [-π/2, π/2]."""
    rot = np.asarray(rot, dtype=float)
    pitch = -np.arcsin(np.clip(rot[:, 2, 0], -1.0, 1.0))
    return np.stack([np.arctan2(rot[:, 2, 1], rot[:, 2, 2]), pitch, np.arctan2(rot[:, 1, 0], rot[:, 0, 0])], axis=-1)


def angle_rates(angles, omega, alpha) -> tuple[np.ndarray, np.ndarray]:
    """The rates and accelerations (K, 3) of ``(roll, pitch, yaw)`` (K, 3) that give the world-frame angular
    velocity ``omega`` and acceleration ``alpha`` (K, 3): ``ω = E (ṙ, ṗ, ẏ)`` with the columns of ``E`` the
    roll axis ``Rz Ry e_x``, the pitch axis ``Rz e_y`` and the yaw axis ``e_z``, and ``α = E (r̈, p̈, ÿ) + Ė (ṙ, ṗ, ẏ)``.
    ``E`` is singular at gimbal lock (``cos pitch = 0``), which the caller refuses."""
    angles, omega, alpha = (np.asarray(a, dtype=float) for a in (angles, omega, alpha))
    cp, sp = np.cos(angles[:, 1]), np.sin(angles[:, 1])
    cy, sy = np.cos(angles[:, 2]), np.sin(angles[:, 2])

    def solve(w):  # E⁻¹ w
        roll = (cy * w[:, 0] + sy * w[:, 1]) / cp
        return np.stack([roll, -sy * w[:, 0] + cy * w[:, 1], w[:, 2] + sp * roll], axis=-1)

    rates = solve(omega)
    r, p, y = rates[:, 0], rates[:, 1], rates[:, 2]
    e_dot = np.stack([(-sy * cp * y - cy * sp * p) * r - cy * y * p, (cy * cp * y - sy * sp * p) * r - sy * y * p,
                      -cp * p * r], axis=-1)  # Ė (ṙ, ṗ, ẏ)
    return rates, solve(alpha - e_dot)


def orientations(angles) -> np.ndarray:
    """:func:`orientation` of many ``(roll, pitch, yaw)`` (K, 3) at once, (K, 3, 3)."""
    angles = np.asarray(angles, dtype=float)
    cr, sr = np.cos(angles[:, 0]), np.sin(angles[:, 0])
    cp, sp = np.cos(angles[:, 1]), np.sin(angles[:, 1])
    cy, sy = np.cos(angles[:, 2]), np.sin(angles[:, 2])
    return np.stack([
        np.stack([cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr], axis=-1),
        np.stack([sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr], axis=-1),
        np.stack([-sp, cp * sr, cp * cr], axis=-1)], axis=-2)


def check_pose(mechanism: SpatialMechanism, pose, where: str = "pose") -> np.ndarray:
    """``pose`` as an array, refused when it has the wrong length, is not finite or is at gimbal lock."""
    values = np.asarray(pose, dtype=float)
    names = mechanism.pose_names
    if values.shape != (len(names),) or not np.all(np.isfinite(values)):
        raise InvalidParameterError(f"{where} must be ({', '.join(names)}), finite, got {np.asarray(pose).tolist()}")
    if "pitch" in names:
        pitch = values[names.index("pitch")]
        if abs(abs(math.remainder(pitch, 2 * math.pi)) - math.pi / 2) < GIMBAL_MARGIN:
            raise InvalidParameterError(f"{where} has pitch = {pitch:.6g} rad: at pitch = ±pi/2 roll and yaw are the "
                                        "same turn (gimbal lock of the z-y'-x'' angles); tilt the platform otherwise")
    return values


def q_poses(mechanism: SpatialMechanism, whole) -> np.ndarray:
    """The inverse of :func:`full_poses`: the pose's coordinates as ``q`` orders them (..., parasitic then
    controlled) from the whole pose (..., :attr:`SpatialPlatform.full_pose_names`)."""
    whole = np.asarray(whole, dtype=float)
    order = [mechanism.platform.full_pose_names.index(n) for n in mechanism.platform.q_pose_names]
    return whole[..., order]


def full_poses(mechanism: SpatialMechanism, q_pose) -> np.ndarray:
    """The platform's whole pose (..., 3 or 6), in the order of :attr:`SpatialPlatform.full_pose_names`, from
    its coordinates as ``q`` orders them (..., parasitic then controlled: the last entries of ``q``)."""
    q_pose = np.asarray(q_pose, dtype=float)
    order = [mechanism.platform.q_pose_names.index(n) for n in mechanism.platform.full_pose_names]
    return q_pose[..., order]


def leg_frames(leg: SpatialLeg, coordinates) -> list[tuple[np.ndarray, np.ndarray]]:
    """Origin and orientation of every body of ``leg`` (and, last, the platform joint's centre with the last
    body's orientation) at the leg's joint coordinates (:func:`leg_coordinate_count`): the readable statement of the
    chain conventions (module docstring), which the generated kernels are checked against."""
    coordinates = [float(c) for c in coordinates]
    if len(coordinates) != leg_coordinate_count(leg):
        raise InvalidParameterError(f"a {leg.notation} leg has {leg_coordinate_count(leg)} joint coordinates, got "
                                    f"{len(coordinates)}")
    values = iter(coordinates)
    point, rot = np.array(leg.base, dtype=float), np.eye(3)
    out = []
    for joint, body in zip(leg.joints, leg.bodies, strict=False):
        if joint.kind == "R":
            rot = rot @ axis_rotation(joint.axes[0], next(values))
            origin = point
        elif joint.kind == "U":
            rot = rot @ axis_rotation(joint.axes[0], next(values)) @ axis_rotation(joint.axes[1], next(values))
            origin = point
        else:  # P
            origin = point + next(values) * (rot @ np.array(joint.axes[0]))
        out.append((origin, rot))
        point = origin + rot @ np.array(body.tip)
    out.append((point, rot))
    return out


def leg_coordinate_count(leg: SpatialLeg) -> int:
    """How many joint coordinates ``leg`` has (1 per R and P joint, 2 per U joint, its platform joint's not
    counted: module docstring)."""
    return sum(j.coordinates for j in leg.joints[:-1])


def platform_joint_angles(leg: SpatialLeg, rotation, platform_rotation=None) -> tuple[float, float, float]:
    """The angles ``(q1, q2)`` of the universal joint that ends ``leg``, whose last body has the
    orientation ``rotation`` (3, 3) under a platform of orientation ``platform_rotation`` (default ``I``, a
    translating platform's), and how far the joint misses it: ``|Rot(a1, q1) Rot(a2, q2) - target|`` with
    ``target = rotationᵀ platform_rotation`` (0 when the joint can turn the body onto the platform)."""
    a1, a2 = (np.array(a, dtype=float) for a in leg.joints[-1].axes)
    target = np.asarray(rotation, dtype=float).T  # the platform's frame in the last body's
    if platform_rotation is not None:
        target = target @ np.asarray(platform_rotation, dtype=float)
    # Rot(a1, q1) Rot(a2, q2) a2 = Rot(a1, q1) a2: the first angle turns a2 onto target·a2 about a1
    w = target @ a2
    q1 = math.atan2(float(np.cross(a2, w) @ a1), float(a2 @ w - (a2 @ a1) * (w @ a1)))
    # then Rot(a2, q2) = Rot(a1, q1)ᵀ target: its turn of a1 (across a2) gives q2
    rest = axis_rotation(a1, -q1) @ target
    v = rest @ a1
    q2 = math.atan2(float(np.cross(a1, v) @ a2), float(a1 @ v - (a1 @ a2) * (v @ a2)))
    miss = float(np.linalg.norm(axis_rotation(a1, q1) @ axis_rotation(a2, q2) - target))
    return q1, q2, miss


def attachment_point(mechanism: SpatialMechanism, leg: int, pose) -> np.ndarray:
    """Where leg ``leg`` (0-based) meets the platform at the whole ``pose``
    (:attr:`SpatialPlatform.full_pose_names`)."""
    pose = np.asarray(pose, dtype=float)
    rot = orientation(*pose[3:6]) if mechanism.platform.kind == "rigid" else np.eye(3)
    return pose[:3] + rot @ np.array(mechanism.platform.attachments[leg])


def attachment_points(mechanism: SpatialMechanism, leg: int, poses: np.ndarray, turns=None) -> np.ndarray:
    """:func:`attachment_point` of many whole poses (K, 3 or 6) at once, (K, 3); ``turns``: the platform's
    :func:`platform_turns` at those poses, where the caller has them (one computation for every leg)."""
    poses = np.asarray(poses, dtype=float)
    a = np.array(mechanism.platform.attachments[leg])
    if mechanism.platform.kind != "rigid":
        return poses[:, :3] + a
    return poses[:, :3] + np.einsum("kij,j->ki", orientations(poses[:, 3:6]) if turns is None else turns, a)


def platform_turns(mechanism: SpatialMechanism, poses: np.ndarray) -> np.ndarray | None:
    """The rigid platform's :func:`orientations` at many whole poses (K, 6), (K, 3, 3); None for a translating one."""
    if mechanism.platform.kind != "rigid":
        return None
    return orientations(np.asarray(poses, dtype=float)[:, 3:6])


# ------------------------------------------------------------------ the TOML form
#: Keys of the TOML form, by table (declared in :mod:`pkmlab.description.keys`).
MECHANISM_KEYS = names(SPATIAL_MECHANISM)
PLATFORM_KEYS = names(SPATIAL_PLATFORM)
LEG_KEYS = names(SPATIAL_LEG)
BODY_KEYS = names(SPATIAL_BODY)
_DEFAULTS = {"mechanism": defaults(SPATIAL_MECHANISM), "platform": defaults(SPATIAL_PLATFORM),
             "leg": defaults(SPATIAL_LEG), "body": defaults(SPATIAL_BODY)}
_JOINTS = re.compile(r"^([RPUS]\*?)+$")


def spatial_mechanism_from_dict(table: dict, source: str = "[mechanism]") -> SpatialMechanism:
    """The spatial mechanism of a ``[mechanism]`` table with ``dimension = 3``.

    Each ``[[mechanism.leg]]`` has ``base``, ``joints`` (e.g. ``"UP*S"``), ``axes`` (a list with one entry per
    joint but an S: a vector for R and P, a pair of vectors for U), ``stroke`` and ``bodies`` (``tip``,
    ``mass``, ``com``, ``inertia``: a 3×3 tensor or a number for ``I·identity``).
    """
    where = source
    table = known_keys(table, MECHANISM_KEYS, where)
    platform, kind, attachments, legs_table = platform_and_legs(table, where, PLATFORM_KEYS, SPATIAL_PLATFORMS,
                                                                "[x, y, z]")
    legs = []
    for i, leg in enumerate(legs_table):
        lw = f"{where}.leg[{i + 1}]"
        leg = known_keys(leg, LEG_KEYS, lw)
        text = required(leg, "joints", lw)
        compact = text.replace(" ", "") if isinstance(text, str) else None
        if compact is None or not _JOINTS.match(compact):
            raise InvalidParameterError(f"{lw}.joints must be letters R, P, U, S from the base to the platform, the "
                                        f"actuated one starred, e.g. \"UP*S\" or \"R*US\"; got {text!r}")
        kinds = [m.group(0) for m in re.finditer(r"[RPUS]\*?", compact)]
        axes = leg.get("axes", _DEFAULTS["leg"]["axes"])
        movable = [k for k in kinds if k[0] != "S"]
        if not isinstance(axes, list) or len(axes) != len(movable):
            raise InvalidParameterError(f"{lw}.axes needs one entry per joint but the S ({len(movable)}): a vector "
                                        "[x, y, z] for R and P, a pair of perpendicular vectors for U")
        joints, values = [], iter(axes)
        for k in kinds:
            given = () if k[0] == "S" else next(values)
            if k[0] == "U":
                if not isinstance(given, list) or len(given) != 2:
                    raise InvalidParameterError(f"{lw}.axes: a U joint needs a pair of vectors [[x, y, z], [x, y, z]], "
                                                f"got {given!r}")
                given = tuple(given)
            elif k[0] != "S":
                given = (given,)
            joints.append(SpatialJoint(k[0], k.endswith("*"), given))
        bodies = leg.get("bodies", _DEFAULTS["leg"]["bodies"])
        if not isinstance(bodies, list):
            raise InvalidParameterError(f"{lw}.bodies must be a list of bodies")
        parsed = []
        for k, body in enumerate(bodies):
            bw = f"{lw}.bodies[{k + 1}]"
            body = {**_DEFAULTS["body"], **known_keys(body, BODY_KEYS, bw)}
            parsed.append(SpatialBody(body["tip"], required(body, "mass", bw), body["com"], body["inertia"]))
        legs.append(SpatialLeg(required(leg, "base", lw), tuple(joints), tuple(parsed), leg.get("stroke")))
    platform = {**_DEFAULTS["platform"], **platform}
    table = {**_DEFAULTS["mechanism"], **table}
    return SpatialMechanism(table["name"], tuple(legs),
                            SpatialPlatform(kind, tuple(attachments), platform["mass"], platform["com"],
                                            platform["inertia"], platform.get("controlled")),
                            table["gravity"])


def scaled_spatial_mechanism(mechanism: SpatialMechanism, mass: float = 1.0, length: float = 1.0) -> SpatialMechanism:
    """As :func:`~pkmlab.description.mechanism.scaled_mechanism`: masses ×``mass``, inertias ×``mass·length²``,
    the bodies' and platform's lengths ×``length``; base points, axes and strokes unchanged."""
    def scale(v):
        return tuple(c * length for c in v)

    def tensor(t):
        return tuple(tuple(c * mass * length**2 for c in row) for row in t)

    legs = tuple(SpatialLeg(leg.base, leg.joints, tuple(SpatialBody(scale(b.tip), b.mass * mass, scale(b.com),
                                                                    tensor(b.inertia)) for b in leg.bodies),
                            leg.stroke) for leg in mechanism.legs)
    p = mechanism.platform
    platform = SpatialPlatform(p.kind, tuple(scale(a) for a in p.attachments), p.mass * mass, scale(p.com),
                               tensor(p.inertia), p.controlled)
    return SpatialMechanism(mechanism.name, legs, platform, mechanism.gravity)


def spatial_mechanism_to_toml(mechanism: SpatialMechanism, comment: str | None = None) -> str:
    """The TOML form of a spatial mechanism (``dimension = 3``); it reads back as an equal value."""
    lines = [f"# {line}" for line in (comment or "").splitlines()]
    lines += [""] if lines else []
    m = mechanism
    lines += ["[mechanism]", f"name = {toml_value(m.name)}", "dimension = 3", f"gravity = {toml_value(m.gravity)}", "",
              "[mechanism.platform]", f"kind = {toml_value(m.platform.kind)}",
              f"attachments = {toml_value(m.platform.attachments)}   # platform frame, one per leg",
              f"mass = {toml_value(m.platform.mass)}", f"com = {toml_value(m.platform.com)}",
              f"inertia = {toml_value(m.platform.inertia)}"]
    if m.platform.controlled is not None:
        lines += [f"controlled = {toml_value(list(m.platform.controlled))}   # the others are parasitic"]
    for leg in m.legs:
        axes = [list(j.axes) if j.kind == "U" else j.axes[0] for j in leg.joints if j.kind != "S"]
        lines += ["", "[[mechanism.leg]]", f"base = {toml_value(leg.base)}", f"joints = {toml_value(leg.notation)}",
                  f"axes = {toml_value(axes)}"]
        if leg.stroke is not None:
            lines += [f"stroke = {toml_value(leg.stroke)}"]
        lines += ["bodies = ["]
        lines += [f"  {{ tip = {toml_value(b.tip)}, mass = {toml_value(b.mass)}, com = {toml_value(b.com)}, "
                  f"inertia = {toml_value(b.inertia)} }}," for b in leg.bodies]
        lines += ["]"]
    return "\n".join(lines) + "\n"
