"""Desired motions of the platform: paths, time laws and waypoints.

A trajectory is a geometric path of platform poses ``(x, y, α)`` parametrised by arc length
``s ∈ [0, L]`` (a pure rotation is measured in radians), traversed with a time law
``s(t)`` that starts and ends at rest (conventions §4: the paper's "third-order polynomial");
:class:`SpatialCircle` is a circle in any plane of a spatial platform's point (its orientation held);
:class:`TimedWaypoints` give a path in any machine's pose coordinates, at rest at each waypoint, and
:class:`Spline` a smooth one through them that does not stop. :meth:`Trajectory.desired` gives
pose, velocity and acceleration at any time; a simulation turns them into the desired actuator motion
``θ_d, θ̇_d, θ̈_d`` (a :class:`JointMotion`) by the machine's exact inverse kinematics and its exact first and
second derivatives (:func:`pkmlab.model.mechanism_model.path_rates`, no finite differences).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .._validate import as_batch, as_choice, as_count, as_real, real_array, shape_of
from ..errors import InvalidParameterError, shown


# ------------------------------------------------------------------ time laws
def time_law(kind: str, tau):
    """``(σ, σ', σ'')`` of a rest-to-rest law on ``τ ∈ [0, 1]``: cubic ``3τ² - 2τ³`` or quintic.

    Outside ``[0, 1]`` the motion is at rest at its end points (``σ' = σ'' = 0``); the cubic's
    acceleration jumps there (``σ''(1) = -6``), as in the paper.
    """
    raw = np.asarray(tau, dtype=float)
    tau = np.clip(raw, 0.0, 1.0)
    if kind == "cubic":
        sigma, d1, d2 = 3 * tau**2 - 2 * tau**3, 6 * tau - 6 * tau**2, 6 - 12 * tau
    elif kind == "quintic":
        sigma, d1, d2 = (10 * tau**3 - 15 * tau**4 + 6 * tau**5, 30 * tau**2 - 60 * tau**3 + 30 * tau**4,
                         60 * tau - 180 * tau**2 + 120 * tau**3)
    else:
        raise InvalidParameterError(f"time_law must be 'cubic' or 'quintic', got {kind!r}")
    outside = (raw < 0.0) | (raw > 1.0)
    return sigma, np.where(outside, 0.0, d1), np.where(outside, 0.0, d2)


def _positive(name, value):
    return as_real(name, value, "positive")


def _finite_vector(name, value, n):
    return as_batch(name, value, n, single=True)[0][0]


def _times(t) -> np.ndarray:
    """Times ``t`` (any shape) as a float array."""
    t = real_array("t", t, "times in seconds")
    if not np.all(np.isfinite(t)):
        raise InvalidParameterError(f"t must be finite times in seconds, got {shown(t)}")
    return t


#: The coefficients of a :class:`FourierTrajectory` start at rest when their sums are below this share of the
#: largest (per harmonic): round-off of coefficients written to a file and read back.
REST_TOL = 1e-9
#: How :class:`TimedWaypoints` turn a rigid platform between waypoints.
ORIENTATION_PATHS = ("angles", "geodesic")


# ------------------------------------------------------------------ paths
@dataclass(frozen=True)
class Circle:
    """A circle of the platform centroid, ``turns`` times counter-clockwise from ``start_angle``.

    The orientation goes linearly (in arc length) from ``alpha`` to ``alpha_end`` (constant by
    default). The paper's path: ``Circle((0.25, 0.21), 0.05)`` (start at the leftmost point).
    """

    center: tuple[float, float]
    radius: float
    start_angle: float = math.pi
    alpha: float = 0.0
    alpha_end: float | None = None
    turns: float = 1.0

    def __post_init__(self):
        _finite_vector("circle center", self.center, 2)
        _positive("circle radius", self.radius)
        _positive("circle turns", self.turns)
        as_real("circle start_angle", self.start_angle)
        as_real("circle alpha", self.alpha)
        if self.alpha_end is not None:
            as_real("circle alpha_end", self.alpha_end)
        if not math.isfinite(self.length):
            raise InvalidParameterError(f"circle radius × turns is too large: the length is {self.length}")

    @property
    def length(self) -> float:
        return 2 * math.pi * self.radius * self.turns

    def at(self, s):
        """Pose, ``d/ds`` and ``d²/ds²`` (each (..., 3)) at arc lengths ``s``."""
        s = np.asarray(s, dtype=float)
        r = self.radius
        psi = self.start_angle + s / r
        a_end = self.alpha if self.alpha_end is None else self.alpha_end
        da = (a_end - self.alpha) / self.length
        c, sn = np.cos(psi), np.sin(psi)
        pose = np.stack([self.center[0] + r * c, self.center[1] + r * sn, self.alpha + da * s], axis=-1)
        d1 = np.stack([-sn, c, np.full_like(s, da)], axis=-1)
        d2 = np.stack([-c / r, -sn / r, np.zeros_like(s)], axis=-1)
        return pose, d1, d2


@dataclass(frozen=True)
class Line:
    """A straight segment between two poses ``(x, y, α)``; ``α`` interpolated linearly.

    The parameter is the distance travelled; for a pure rotation (same position) it is the
    angle turned, in radians.
    """

    start: tuple[float, float, float]
    end: tuple[float, float, float]

    def __post_init__(self):
        a = _finite_vector("line start", self.start, 3)
        b = _finite_vector("line end", self.end, 3)
        with np.errstate(all="ignore"):  # the checks themselves may overflow: it is what the second looks for
            if np.allclose(a, b):
                raise InvalidParameterError("line start and end are the same pose")
            d, length = np.subtract(b, a), self.length
            # twice the difference a float too: the pose along the line, ``start + s (d / length)``, stays one
            fits = np.isfinite(length) and np.all(np.isfinite(2 * d)) and np.all(np.isfinite(d / length))
        if not fits:
            raise InvalidParameterError(f"line start {tuple(map(float, a))} and end {tuple(map(float, b))}: too far "
                                        "apart for their difference or its rate along the line to be a float")

    @property
    def length(self) -> float:
        d = np.subtract(self.end, self.start)
        dist = float(np.hypot(d[0], d[1]))
        return dist if dist > 0 else abs(float(d[2]))

    def at(self, s):
        s = np.asarray(s, dtype=float)
        d = np.subtract(self.end, self.start) / self.length
        pose = np.asarray(self.start) + s[..., None] * d
        return pose, np.broadcast_to(d, pose.shape).copy(), np.zeros_like(pose)


# ------------------------------------------------------------------ trajectories
@dataclass(frozen=True)
class Trajectory:
    """A path traversed with a rest-to-rest time law at average speed ``speed`` (m/s).

    ``duration = length / speed`` (conventions §4: ``T = L / v``).
    """

    path: Circle | Line | SpatialCircle
    speed: float
    law: str = "cubic"

    def __post_init__(self):
        if not callable(getattr(self.path, "at", None)):
            raise InvalidParameterError(f"path must be a Circle, a Line or a SpatialCircle, got "
                                        f"{type(self.path).__name__} "
                                        f"{shown(self.path, 50)}")
        length = _positive("path length", getattr(self.path, "length", None))
        speed = _positive("speed", self.speed)
        as_choice("law", self.law, ("cubic", "quintic"))
        if not math.isfinite(length / speed):
            raise InvalidParameterError(f"speed = {speed:g} m/s is too low for a path of {length:g} m: "
                                        "the motion would never end")

    @property
    def duration(self) -> float:
        return self.path.length / self.speed

    @property
    def spatial(self) -> bool:
        """Whether the path is of a spatial machine's pose (a :class:`SpatialCircle`), not ``(x, y, α)``."""
        return isinstance(self.path, SpatialCircle)

    @property
    def dimension(self) -> int:
        """The number of the poses' coordinates: 3 for a planar path ``(x, y, α)``, the circle's otherwise."""
        return getattr(self.path, "dimension", 3)

    def desired(self, t):
        """``(pose, pose_dot, pose_ddot)``, each (..., dimension), at times ``t`` (clamped to [0, T])."""
        T = self.duration
        L = self.path.length
        t = _times(t)
        # a speed near the float range (1e153 m/s) overflows the accelerations (L/T²): refused by name, not warned
        # of in NumPy's words (nor answered with accelerations of 1e308 m/s² that overflowed on the way)
        try:
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                sigma, dsigma, ddsigma = time_law(self.law, t / T)
                s, s_dot, s_ddot = L * sigma, L * dsigma / T, L * ddsigma / T**2
                pose, d1, d2 = self.path.at(s)
                return pose, d1 * s_dot[..., None], d2 * (s_dot**2)[..., None] + d1 * s_ddot[..., None]
        except FloatingPointError:
            raise InvalidParameterError(f"speed = {self.speed:g} m/s is too high for a path of {L:g} m: the motion's "
                                        "rates and accelerations are beyond the float range") from None


@dataclass(frozen=True)
class WaypointTrajectory:
    """Straight segments through poses ``points`` (K, 3), at rest at every waypoint.

    Each segment is its own rest-to-rest :class:`Trajectory` (so the corners need no infinite
    acceleration); ``α`` is interpolated along each segment.
    """

    points: tuple
    speed: float
    law: str = "cubic"
    segments: tuple = field(init=False, repr=False)

    def __post_init__(self):
        pts, shape = as_batch("points", self.points, 3)
        if len(shape) != 1 or shape[0] < 2:
            raise InvalidParameterError(f"points must be at least two poses [x, y, alpha], got shape {(*shape, 3)}")
        for i in range(1, len(pts)):
            if np.allclose(pts[i - 1], pts[i]):
                raise InvalidParameterError(f"points[{i}] repeats the previous pose {pts[i].tolist()}")
        segments = tuple(Trajectory(Line(tuple(a), tuple(b)), self.speed, self.law)
                         for a, b in zip(pts[:-1], pts[1:], strict=True))
        object.__setattr__(self, "segments", segments)

    @property
    def duration(self) -> float:
        return sum(seg.duration for seg in self.segments)

    def desired(self, t):
        t = _times(t)
        starts = np.cumsum([0.0] + [seg.duration for seg in self.segments])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.segments) - 1)
        out = [np.empty((*t.shape, 3)) for _ in range(3)]
        for k, seg in enumerate(self.segments):
            mask = idx == k
            if np.any(mask):
                for o, v in zip(out, seg.desired(t[mask] - starts[k]), strict=True):
                    o[mask] = v
        return tuple(out)


@dataclass(frozen=True)
class TimedWaypoints:
    """Straight segments through poses ``points`` (K, d) of any dimension — ``(x, y, z)`` for the Delta,
    ``(x, y, z, roll, pitch, yaw)`` for a six-degree-of-freedom platform, ``(x, y, alpha)`` in the plane —
    each traversed in its own time ``durations[k]`` (s) with a rest-to-rest ``law``, at rest at every
    waypoint: the pick-and-place cycle of industry, whose segments have prescribed times.

    On segment ``k``, ``pose = p_k + σ(τ) (p_k+1 - p_k)``, ``τ = (t - t_k) / D_k``: every coordinate,
    orientation angles included, moves in proportion (a straight line in pose space). With
    ``orientation_path = "geodesic"`` (poses ``(x, y, z, roll, pitch, yaw)``) the orientation follows instead
    the shortest turn between the waypoints' (a geodesic of SO(3)): ``R(τ) = exp(σ(τ) [w]×) R_k``, ``w`` the
    rotation vector of ``R_k+1 R_kᵀ`` in the world frame — one axis, its angle in proportion to ``σ``, the
    angular velocity ``σ̇ w`` — given as roll, pitch and yaw kept continuous (:func:`geodesic_turns`) with their
    exact rates (:func:`~pkmlab.description.spatial.angle_rates`); a half turn, or a turn through or near gimbal
    lock (``pitch = ±π/2``), is refused when the waypoints are given.
    """

    points: tuple
    durations: tuple
    law: str = "quintic"
    orientation_path: str = "angles"
    _turns: GeodesicTurns | None = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        pts = real_array("points", self.points, "a list of poses")
        if pts.ndim != 2 or len(pts) < 2 or pts.shape[1] < 2 or not np.all(np.isfinite(pts)):
            raise InvalidParameterError(f"points must be at least two finite poses of 2 or more coordinates, got "
                                        f"{shown(self.points, 60)}")
        try:
            durations = real_array("durations", self.durations)
        except InvalidParameterError:
            durations = np.full(0, np.nan)  # refused below, with the rule
        if durations.shape != (len(pts) - 1,) or not np.all(np.isfinite(durations)) or np.any(durations <= 0):
            raise InvalidParameterError(f"durations must be {len(pts) - 1} positive times in s (one per segment), "
                                        f"got {shown(self.durations, 60)}")
        for i in range(1, len(pts)):
            if np.array_equal(pts[i - 1], pts[i]):
                raise InvalidParameterError(f"points[{i}] repeats the previous pose {pts[i].tolist()}")
        as_choice("law", self.law, ("cubic", "quintic"))
        as_choice("orientation_path", self.orientation_path, ORIENTATION_PATHS)
        if self.orientation_path == "geodesic" and pts.shape[1] != 6:
            raise InvalidParameterError("orientation_path = 'geodesic' needs poses (x, y, z, roll, pitch, yaw), the "
                                        "whole orientation of a rigid platform; got poses of "
                                        f"{pts.shape[1]} coordinates")
        object.__setattr__(self, "points", tuple(tuple(float(v) for v in p) for p in pts))
        object.__setattr__(self, "durations", tuple(float(d) for d in durations))
        if self.orientation_path == "geodesic":
            object.__setattr__(self, "_turns", geodesic_turns(pts[:, 3:]))

    @property
    def dimension(self) -> int:
        """The number of the poses' coordinates."""
        return len(self.points[0])

    @property
    def duration(self) -> float:
        return float(sum(self.durations))

    def desired(self, t):
        """``(pose, pose_dot, pose_ddot)``, each (..., d), at times ``t`` (at rest before 0 and after the end)."""
        t = _times(t)
        durations = np.asarray(self.durations)
        starts = np.concatenate([[0.0], np.cumsum(durations)])
        k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(durations) - 1)
        span = durations[k]
        sigma, d1, d2 = time_law(self.law, (t - starts[k]) / span)
        return self.on_segments(k, sigma, d1 / span, d2 / span**2)

    def on_segments(self, k, sigma, sigma_dot, sigma_ddot):
        """``(pose, pose_dot, pose_ddot)`` at fractions ``sigma`` (...) of segments ``k`` (...), moving along them
        at ``sigma_dot`` and ``sigma_ddot``: straight in pose space, or the geodesic turns."""
        pts = np.asarray(self.points)
        delta = pts[k + 1] - pts[k]
        out = (pts[k] + sigma[..., None] * delta, sigma_dot[..., None] * delta, sigma_ddot[..., None] * delta)
        if self.orientation_path == "geodesic":
            turned = geodesic_orientation(self._turns, k.reshape(-1), sigma.reshape(-1), sigma_dot.reshape(-1),
                                          sigma_ddot.reshape(-1))
            for o, v in zip(out, turned, strict=True):
                o[..., 3:] = v.reshape(*k.shape, 3)
        return out


def _nearest_angles(raw: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Of the angles ``(roll, pitch, yaw)`` (K, 3) of each orientation — ``raw``, its twin ``(roll + π, π - pitch,
    yaw + π)`` and both shifted by whole turns — the ones nearest ``reference`` (K, 3)."""
    twin = np.stack([raw[:, 0] + np.pi, np.pi - raw[:, 1], raw[:, 2] + np.pi], axis=-1)
    candidates = [c + 2 * np.pi * np.round((reference - c) / (2 * np.pi)) for c in (raw, twin)]
    nearer = np.linalg.norm(candidates[1] - reference, axis=1) < np.linalg.norm(candidates[0] - reference, axis=1)
    return np.where(nearer[:, None], candidates[1], candidates[0])


def _turned(rot: np.ndarray, axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``exp(angle [axis]×) rot`` (K, 3, 3), Rodrigues' formula for each row."""
    skew = np.zeros((len(axis), 3, 3))
    skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    skew -= skew.transpose(0, 2, 1)
    c, s = np.cos(angle)[:, None, None], np.sin(angle)[:, None, None]
    return (np.eye(3) + s * skew + (1.0 - c) * (skew @ skew)) @ rot


#: Steps per segment of the reference along which a geodesic's angles are kept continuous.
_GEODESIC_STEPS = 64
#: The smallest ``|cos pitch|`` a geodesic may reach: nearer gimbal lock, roll's and yaw's rates would exceed a
#: hundred times the angular velocity (they are infinite at the lock).
GIMBAL_MARGIN = 1e-2


@dataclass(frozen=True)
class GeodesicTurns:
    """The shortest turns between consecutive orientations (:func:`geodesic_turns`): for each segment ``j`` the
    start's rotation ``rot[j]`` (3, 3), the turn's unit axis ``axis[j]`` (3,, world frame) and ``angle[j]``, and
    ``reference[j]`` (steps + 1, 3), continuous roll, pitch and yaw at evenly spaced fractions of the turn."""

    rot: np.ndarray
    axis: np.ndarray
    angle: np.ndarray
    reference: np.ndarray


def _largest_along_turn(v_z, a, v, angle) -> float:
    """The largest ``|e_zᵀ exp(φ [a]×) v|`` for ``φ`` in ``[0, angle]``: by Rodrigues' formula the component is
    ``c + A cos φ + B sin φ``, ``c = a_z (a·v)``, ``A = v_z - c``, ``B = (a × v)_z``, extreme at its ends or where
    ``tan φ = B / A``."""
    c = a[2] * float(a @ v)
    big_a, big_b = v_z - c, float(np.cross(a, v)[2])
    phi = math.atan2(big_b, big_a)
    candidates = [0.0, angle] + [p for p in (phi % (2 * math.pi), (phi + math.pi) % (2 * math.pi)) if p <= angle]
    return max(abs(c + big_a * math.cos(p) + big_b * math.sin(p)) for p in candidates)


def geodesic_turns(angles) -> GeodesicTurns:
    """The shortest turns between consecutive orientations ``(roll, pitch, yaw)`` (K, 3) (:class:`TimedWaypoints`).

    The reference angles are continuous over the whole motion: from the first orientation's own, along each
    turn the representation nearest the step before (so a turn through yaw = π goes on to 3.4 rather than jump
    to -2.9; a later waypoint is reached in its orientation, its angles possibly a whole turn from those given).

    Raises
    ------
    InvalidParameterError
        A half turn (two shortest turns, no one axis), or a turn that passes within :data:`GIMBAL_MARGIN` of
        pitch = ±π/2, where roll and yaw are one turn: naming the segment's waypoints.
    """
    from ..description.spatial import orientations, orientations_angles

    rot = orientations(angles)
    turn = np.einsum("kij,klj->kil", rot[1:], rot[:-1])  # R_k+1 R_kᵀ, in the world frame
    axis = np.stack([turn[:, 2, 1] - turn[:, 1, 2], turn[:, 0, 2] - turn[:, 2, 0], turn[:, 1, 0] - turn[:, 0, 1]], -1)
    norm = np.linalg.norm(axis, axis=1)  # 2 sin(angle)
    angle = np.arctan2(norm / 2.0, (np.trace(turn, axis1=1, axis2=2) - 1.0) / 2.0)  # exact for small turns too
    half = np.flatnonzero((angle > 1e-9) & (norm < 1e-9 * max(1.0, float(angle.max()))))
    if half.size:
        j = int(half[0])
        raise InvalidParameterError(f"points[{j}] to points[{j + 1}]: a half turn, whose shortest turn has no one "
                                    "axis (two are as short): add a waypoint between them")
    axis = np.where(norm[:, None] > 0, axis / np.where(norm > 0, norm, 1.0)[:, None], 0.0)
    for j in range(len(turn)):
        largest = _largest_along_turn(rot[j, 2, 0], axis[j], rot[j, :, 0], float(angle[j]))
        if 1.0 - largest**2 < GIMBAL_MARGIN**2:  # cos² pitch, pitch = -asin(R[2, 0])
            raise InvalidParameterError(
                f"points[{j}] to points[{j + 1}]: the shortest turn passes through or near pitch = ±pi/2 (cos pitch "
                f"{math.sqrt(max(0.0, 1.0 - largest**2)):.2g} < {GIMBAL_MARGIN:g}), where roll and yaw are one turn "
                "(gimbal lock): add a waypoint away from it")
    steps = np.linspace(0.0, 1.0, _GEODESIC_STEPS + 1)
    references, start = [], np.asarray(angles[0], dtype=float)
    for j in range(len(turn)):
        raw = orientations_angles(_turned(np.broadcast_to(rot[j], (len(steps), 3, 3)),
                                          np.broadcast_to(axis[j], (len(steps), 3)), steps * angle[j]))
        walked = [start]
        for r in raw[1:]:
            walked.append(_nearest_angles(r[None], walked[-1][None])[0])
        references.append(np.array(walked))
        start = walked[-1]
    return GeodesicTurns(rot[:-1], axis, angle, np.array(references))


def geodesic_orientation(turns: GeodesicTurns, k, sigma, sigma_dot, sigma_ddot) -> tuple[np.ndarray, ...]:
    """``(roll, pitch, yaw)``, their rates and accelerations (K, 3) at fractions ``sigma`` (K,) of the turns
    ``k`` (K,) of :func:`geodesic_turns`, moving at ``sigma_dot`` and ``sigma_ddot`` (K,): the angles nearest the
    turn's continuous reference, with the exact rates of its angular velocity ``σ̇ θ a``."""
    from ..description.spatial import angle_rates, orientations_angles

    steps = np.linspace(0.0, 1.0, turns.reference.shape[1])
    reference = np.empty((len(k), 3))
    for j in np.unique(k):
        rows = k == j
        reference[rows] = np.stack([np.interp(sigma[rows], steps, turns.reference[j, :, c]) for c in range(3)], -1)
    current = _turned(turns.rot[k], turns.axis[k], sigma * turns.angle[k])
    best = _nearest_angles(orientations_angles(current), reference)
    w = turns.axis[k] * turns.angle[k][:, None]  # the turn's rotation vector, world frame
    rates, accelerations = angle_rates(best, sigma_dot[:, None] * w, sigma_ddot[:, None] * w)
    return best, rates, accelerations


@dataclass(frozen=True)
class SpatialCircle:
    """A circle of a spatial platform's point, ``turns`` times counter-clockwise about ``normal`` (right-hand
    rule) from ``start_angle``, its orientation held at ``orientation`` (the pose's other coordinates: ``()``
    for a translating platform, ``(roll, pitch, yaw)`` for a rigid one).

    The point is ``center + radius (cos ψ u + sin ψ v)``, ``ψ = start_angle + s / radius``, with ``u`` the
    world's x axis made normal to ``normal`` (its y axis where x is along ``normal``) and ``v = normal × u``: about
    ``z`` this is the planar :class:`Circle`'s convention (``start_angle = π``, the point of least x)."""

    center: tuple[float, float, float]
    radius: float
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    start_angle: float = math.pi
    orientation: tuple = ()
    turns: float = 1.0

    def __post_init__(self):
        _finite_vector("circle center", self.center, 3)
        _positive("circle radius", self.radius)
        _positive("circle turns", self.turns)
        as_real("circle start_angle", self.start_angle)
        normal = _finite_vector("circle normal", self.normal, 3)
        if not np.linalg.norm(normal) > 0:
            raise InvalidParameterError(f"circle normal must be a non-zero vector, got {list(self.normal)}")
        orientation = np.asarray(self.orientation, dtype=float).reshape(-1)
        if len(orientation) not in (0, 3) or not np.all(np.isfinite(orientation)):
            raise InvalidParameterError(f"circle orientation must be [] or [roll, pitch, yaw] (rad), got "
                                        f"{shown(self.orientation)}")
        object.__setattr__(self, "orientation", tuple(float(v) for v in orientation))
        if not math.isfinite(self.length):
            raise InvalidParameterError(f"circle radius × turns is too large: the length is {self.length}")

    @property
    def length(self) -> float:
        return 2 * math.pi * self.radius * self.turns

    @property
    def dimension(self) -> int:
        return 3 + len(self.orientation)

    def _frame(self) -> tuple[np.ndarray, np.ndarray]:
        n = np.asarray(self.normal, dtype=float)
        n = n / np.linalg.norm(n)
        ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = ref - (ref @ n) * n
        u /= np.linalg.norm(u)
        return u, np.cross(n, u)

    def at(self, s):
        """Pose, ``d/ds`` and ``d²/ds²`` (each (..., dimension)) at arc lengths ``s``."""
        s = np.asarray(s, dtype=float)
        r = self.radius
        u, v = self._frame()
        psi = (self.start_angle + s / r)[..., None]
        c, sn = np.cos(psi), np.sin(psi)
        rest = np.broadcast_to(np.asarray(self.orientation, dtype=float), (*s.shape, len(self.orientation)))
        zero = np.zeros_like(rest)
        pose = np.concatenate([np.asarray(self.center) + r * (c * u + sn * v), rest], axis=-1)
        d1 = np.concatenate([-sn * u + c * v, zero], axis=-1)
        d2 = np.concatenate([(-c * u - sn * v) / r, zero], axis=-1)
        return pose, d1, d2


@dataclass(frozen=True)
class Spline:
    """A smooth path through poses ``points`` (K, d) of any dimension, passing the point ``k`` at time ``t_k``
    (``durations`` between them, s) without stopping: in every coordinate the cubic spline of those knots
    that starts and ends at rest (zero velocity at both ends, continuous acceleration everywhere), at rest at
    its end points before 0 and after the end. Orientation angles are splined as coordinates (a path in pose
    space, as :class:`TimedWaypoints`)."""

    points: tuple
    durations: tuple

    def __post_init__(self):
        probe = TimedWaypoints(self.points, self.durations)  # the same checks of points and durations
        object.__setattr__(self, "points", probe.points)
        object.__setattr__(self, "durations", probe.durations)

    @property
    def dimension(self) -> int:
        return len(self.points[0])

    @property
    def duration(self) -> float:
        return float(sum(self.durations))

    def _spline(self):
        from scipy.interpolate import CubicSpline

        knots = np.concatenate([[0.0], np.cumsum(self.durations)])
        return CubicSpline(knots, np.asarray(self.points), axis=0, bc_type="clamped")

    def desired(self, t):
        """``(pose, pose_dot, pose_ddot)``, each (..., d), at times ``t`` (at rest before 0 and after the end)."""
        t = _times(t)
        spline = self._spline()
        inside = (t >= 0.0) & (t <= self.duration)
        clamped = np.clip(t, 0.0, self.duration)
        pose = spline(clamped)
        return pose, np.where(inside[..., None], spline(clamped, 1), 0.0), np.where(inside[..., None],
                                                                                    spline(clamped, 2), 0.0)


@dataclass(frozen=True)
class FourierTrajectory:
    """A periodic motion of the pose: in every coordinate ``i`` a finite Fourier series of ``period`` ``T``
    (``ω = 2π / T``) whose velocity is

        ``ṗ_i(t) = Σ_k a_ki cos(k ω t) + b_ki sin(k ω t)``,   ``k = 1 … harmonics``,

    integrated from ``p_i(0) = center_i`` (Swevers et al., "Optimal robot excitation and identification",
    1997). The coefficients ``a`` and ``b`` (harmonics, dimension) must start and end each period at rest,
    ``Σ_k a_ki = 0`` and ``Σ_k k b_ki = 0``, so that a run repeats it ``periods`` times without a jump and is at
    rest at ``center`` before 0 and after the end. The actuators, functions of the pose, are periodic too.
    """

    center: tuple
    period: float
    a: np.ndarray
    b: np.ndarray
    periods: int = 1

    def __post_init__(self):
        shape = shape_of(self.center)
        if shape is None or len(shape) != 1 or shape[0] < 1:
            raise InvalidParameterError(f"center must be a pose of 1 or more numbers, got {shown(self.center)}")
        center = np.array(_finite_vector("center", self.center, shape[0]))
        period = _positive("period", self.period)
        periods = as_count("periods", self.periods)
        dim = len(center)
        for name, value in (("a", self.a), ("b", self.b)):
            shape = shape_of(value)
            if shape is not None and len(shape) == 2 and shape[1] != dim:
                raise InvalidParameterError(f"{name} has {shape[1]} numbers per harmonic, but center is a pose of "
                                            f"{dim}: one per pose coordinate")
        a, b = (as_batch(name, value, dim)[0] for name, value in (("a", self.a), ("b", self.b)))
        if a.shape != b.shape:
            raise InvalidParameterError(f"a and b must have as many harmonics, got {a.shape[0]} and {b.shape[0]}")
        k = np.arange(1, a.shape[0] + 1)[:, None]
        scale = max(float(np.abs(a).max()), float(np.abs(b).max()), 1e-300)
        for name, rest in (("a", a.sum(axis=0)), ("b", (k * b).sum(axis=0))):
            i = int(np.argmax(np.abs(rest)))
            if abs(rest[i]) > REST_TOL * scale * a.shape[0]:
                law = "Σ_k a_k" if name == "a" else "Σ_k k b_k"
                raise InvalidParameterError(f"{name} of coordinate {i + 1} does not start at rest: {law} = "
                                            f"{rest[i]:.4g}, must be 0")
        for name, value in (("center", center), ("a", a), ("b", b)):
            value.flags.writeable = False
            object.__setattr__(self, name, value)
        object.__setattr__(self, "period", period)
        object.__setattr__(self, "periods", periods)

    @property
    def dimension(self) -> int:
        return len(self.center)

    @property
    def harmonics(self) -> int:
        return self.a.shape[0]

    @property
    def duration(self) -> float:
        return self.period * self.periods

    def desired(self, t):
        """``(pose, pose_dot, pose_ddot)``, each (..., dimension), at times ``t`` (at rest at ``center`` before 0
        and after the end)."""
        t = _times(t)
        outside = ((t < 0.0) | (t > self.duration))[..., None]
        t = np.where(outside[..., 0], 0.0, t)
        w = 2 * math.pi / self.period
        k = np.arange(1, self.harmonics + 1)
        phase = w * t[..., None] * k  # (..., harmonics)
        c, s = np.cos(phase), np.sin(phase)
        kw = (w * k)[:, None]
        pose = self.center + s @ (self.a / kw) - (c - 1.0) @ (self.b / kw)
        pose_dot, pose_ddot = c @ self.a + s @ self.b, c @ (self.b * kw) - s @ (self.a * kw)
        return (np.where(outside, self.center, pose), np.where(outside, 0.0, pose_dot),
                np.where(outside, 0.0, pose_ddot))


# ------------------------------------------------------------------ the path alone
@dataclass(frozen=True)
class PathGeometry:
    """A trajectory's path without its timing: ``at(u, piece=None)`` gives the pose and its first and second
    derivatives with respect to a parameter ``u`` (each (..., d)); ``pieces`` are the ``(u_start, u_end)`` between
    the points where the path must stop (its corners: the derivative ``x'`` jumps there). At a corner ``at`` takes
    the piece after it, unless ``piece`` (an index of ``pieces``) says which."""

    at: Callable
    pieces: tuple


def path_geometry(trajectory) -> PathGeometry:
    """The path of ``trajectory`` (:class:`PathGeometry`), by the parameter that keeps ``x'`` from vanishing
    where it can: a :class:`Trajectory`'s arc length (its time law dropped); a :class:`WaypointTrajectory`'s arc
    length along its segments, stopping at each waypoint; :class:`TimedWaypoints`' segment number plus the
    fraction of the segment ``u = k + σ`` (straight in pose space, or a geodesic turn), stopping at each
    waypoint; any other trajectory's own time (a :class:`Spline` passes its waypoints without stopping)."""
    if isinstance(trajectory, Trajectory):
        return PathGeometry(lambda u, piece=None: trajectory.path.at(u), ((0.0, float(trajectory.path.length)),))
    if isinstance(trajectory, WaypointTrajectory):
        paths = [seg.path for seg in trajectory.segments]
        starts = np.concatenate([[0.0], np.cumsum([p.length for p in paths])])

        def along(u, piece=None):
            u = np.asarray(u, dtype=float)
            k = (np.clip(np.searchsorted(starts, u, side="right") - 1, 0, len(paths) - 1) if piece is None
                 else np.full(u.shape, piece))
            out = [np.empty((*u.shape, 3)) for _ in range(3)]
            for j, path in enumerate(paths):
                rows = k == j
                if np.any(rows):
                    for o, v in zip(out, path.at(u[rows] - starts[j]), strict=True):
                        o[rows] = v
            return tuple(out)

        return PathGeometry(along, tuple(zip(starts[:-1], starts[1:], strict=True)))
    if isinstance(trajectory, TimedWaypoints):
        count = len(trajectory.points) - 1

        def segments(u, piece=None):
            u = np.asarray(u, dtype=float)
            k = np.clip(np.floor(u).astype(int), 0, count - 1) if piece is None else np.full(u.shape, piece)
            return trajectory.on_segments(k, u - k, np.ones(u.shape), np.zeros(u.shape))

        return PathGeometry(segments, tuple((float(k), float(k + 1)) for k in range(count)))
    return PathGeometry(lambda u, piece=None: trajectory.desired(u), ((0.0, float(trajectory.duration)),))


def paper_trajectory(speed: float = 0.2) -> Trajectory:
    """The paper's circle (conventions §4): centre (0.25, 0.21), radius 0.05, from the leftmost point."""
    return Trajectory(Circle((0.25, 0.21), 0.05, start_angle=math.pi, alpha=0.0), speed, "cubic")


# ------------------------------------------------------------------ actuator space
@dataclass(frozen=True)
class JointMotion:
    """Desired actuator motion at times ``t`` (N,): ``theta``, ``theta_dot``, ``theta_ddot`` (N, 3),
    with the configurations ``q`` (N, 7) and platform ``pose`` (N, 3) they come from, and where computed
    with them the singularity measure ``S`` (N,) along the path and the pose's rates ``pose_dot``, ``pose_ddot``
    (N, 3), which a redundantly actuated machine's run tracks."""

    t: np.ndarray
    q: np.ndarray
    pose: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    theta_ddot: np.ndarray
    S: np.ndarray | None = None
    pose_dot: np.ndarray | None = None
    pose_ddot: np.ndarray | None = None
