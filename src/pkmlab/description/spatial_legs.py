"""Closed-form inverse kinematics of spatial legs, and the Delta's forward kinematics.

Legs of a :class:`~pkmlab.description.spatial.SpatialMechanism` that pkmlab solves in closed form:

* ``R*US`` — an actuated arm, then a forearm from a universal joint at the arm's tip to a spherical
  joint on the platform (the Delta's leg). The arm angle is a root of ``α cos θ + β sin θ = γ``:
  two working modes. ``σ = +1`` is the root whose elbow (the arm's tip) lies farther from the
  machine's central axis — the line through the centroid of the legs' base points, normal to their
  plane (the Delta's z axis): "knee out". Where both elbows are as far (a measure-zero set), the root
  with the larger ``θ - centre`` below is taken. An arm turning about an axis parallel to the central axis
  (a 4-RUU's crank) would have both elbows as far along a whole surface, where "knee out" swaps with no
  singularity: its ``σ = +1`` is the root counter-clockwise (about the arm's axis) from the plane through that
  axis and the point — the two roots meet only in that plane, at the leg's own singularity.
* ``UP*S`` — a universal joint on the base, an actuated prismatic joint, a spherical joint on the
  platform (the Stewart–Gough platform's leg): the slide is the larger root of a quadratic (one
  working mode).
* ``P*US`` — an actuated slider, then a rod from a universal joint on it to the platform (a 6-PUS): the
  slide is a root of a quadratic, two working modes, ``σ = +1`` the larger (the slider farther along its
  axis).
* ``P*RS`` — an actuated slider, a passive revolute joint, a link to the platform (a 3-PRS): the point must
  lie on the surface the link sweeps — a plane normal to the hinge when the slide is across it, where the
  slide is a root of a quadratic (two working modes, ``σ = +1`` the larger); otherwise the plane fixes the
  slide (one working mode).
* ``RP*S`` — a passive revolute joint on the base, an actuated prismatic joint, a spherical joint on the
  platform (a 3-RPS): the point must lie in the plane the hinge turns the leg in (when the slide is across
  the hinge; the slide the larger root of a quadratic, one working mode) or on the cone it sweeps otherwise.
* ``R*RS`` — an actuated crank, a passive hinge parallel to the crank's at its tip, a link to the platform (a
  3-RRS): the point must lie in the plane normal to the hinges that the link moves in, where crank and link
  are a planar two-link arm — the crank angle a root of ``α cos θ + β sin θ = γ`` as for the R*US leg, two
  working modes told apart as the R*US leg's ("knee out" ``σ = +1``). A leg whose hinges are not parallel is
  refused.

A leg of two joint coordinates before its spherical joint (P*RS, RP*S) does not reach a neighbourhood of
points but a surface: its platform's pose has parasitic coordinates that keep every attachment point on its
leg's surface (:mod:`pkmlab.model.parasitic`).

A universal joint's two angles turn its body's tip onto a given direction; of the two solutions (the
body spun half a turn about itself), pkmlab takes the one whose second angle is nearer zero.
Functions act on many points at once, ``(K, 3)``.
"""

from __future__ import annotations

import numpy as np

from ..numerics.rotations import crank_rows, rotate_rows, turn_onto_rows, universal_rows
from . import general_legs
from .leg_types import Solved, mark_outside_stroke
from .spatial import SpatialLeg, SpatialMechanism

SOLVED = ("R*US", "UP*S", "P*US", "P*RS", "RP*S", "R*RS")
#: An arm's axis whose cosine with the central axis is this close to ±1 is parallel to it (its working modes are
#: labelled by the side of the point's plane, module docstring).
PARALLEL = 1e-9


def position_notation(leg: SpatialLeg) -> str:
    """The leg's notation with its platform joint made spherical: the leg whose closed form solves it, since a
    platform joint's angles do not move its centre (a UP*U leg reaches it as a UP*S leg does)."""
    return leg.notation[:-1] + "S"


def _leg(leg: SpatialLeg, number: int) -> str:
    """How messages name a leg: ``"leg 2 (UP*S)"``."""
    return f"leg {number + 1} ({leg.notation})"


def has_closed_form(leg: SpatialLeg) -> bool:
    """Whether pkmlab solves ``leg`` in closed form (module docstring); every other leg is solved by the general
    method (:mod:`pkmlab.description.general_legs`). A leg of two actuators is solved as its own actuator's
    (:meth:`~pkmlab.description.mechanism.JointChain.own_actuator_only`), here and below."""
    leg = leg.own_actuator_only()
    notation = position_notation(leg)
    if notation == "R*RS":
        return abs(abs(float(np.dot(leg.joints[0].axes[0], leg.joints[1].axes[0]))) - 1.0) <= 1e-9
    return notation in SOLVED


def working_modes(leg: SpatialLeg) -> tuple:
    """``(+1, -1)`` for a leg with two inverse-kinematic branches (R*US, P*US, a P*RS whose slide is across its
    hinge), ``()`` for one; a leg of the general method has its own
    (:func:`pkmlab.description.general_legs.working_modes`: up to four, as pairs of signs)."""
    leg = leg.own_actuator_only()
    if not has_closed_form(leg):
        return general_legs.working_modes(leg)
    notation = position_notation(leg)
    if notation in ("R*US", "P*US", "R*RS"):
        return (1, -1)
    if notation == "P*RS" and _across(np.array(leg.joints[1].axes[0]), np.array(leg.joints[0].axes[0])):
        return (1, -1)
    return ()


def _rows(v, k: int | None = None) -> np.ndarray:
    """``v`` as C-ordered float64: one vector (3,) repeated as ``k`` rows (K, 3) if ``k`` is given, else as it is."""
    v = np.asarray(v, dtype=float)
    return np.ascontiguousarray(np.broadcast_to(v, (k, 3)) if v.ndim == 1 and k is not None else v)


def rotate(axis, angle, v):
    """Rodrigues' rotation of vectors ``v`` (K, 3), or of one vector (3,) for every row, by ``angle`` (K,) about the
    unit ``axis`` (3,) (compiled: :func:`pkmlab.numerics.rotations.rotate_rows`)."""
    angle = np.ascontiguousarray(angle, dtype=float)
    out = np.empty((len(angle), 3))
    rotate_rows(_rows(axis), angle, _rows(v, len(angle)), out)
    return out


def turn_onto(axis: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The angle (K,) of the turn about the unit ``axis`` that takes the parts of ``v`` (3,) or (K, 3) across
    the axis onto the direction of those of ``w`` (K, 3)."""
    w = _rows(w)
    out = np.empty(len(w))
    turn_onto_rows(_rows(axis), _rows(v, len(w)), w, out)
    return out


def universal_angles(axes, tip, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The angles ``(q1, q2)`` of a universal joint (perpendicular ``axes``) with
    ``Rot(a1, q1) Rot(a2, q2) tip = v`` (``v`` (K, 3) of the tip's length; one ``tip`` (3,) or one per row), and
    where no angle does it (:func:`pkmlab.numerics.rotations.universal_rows`)."""
    v = _rows(v)
    k = len(v)
    q1, q2, bad = np.empty(k), np.empty(k), np.empty(k, dtype=np.bool_)
    universal_rows(_rows(axes[0]), _rows(axes[1]), _rows(tip, k), v, q1, q2, bad, np.empty((k, 3)))
    return q1, q2, bad


def central_axis(mechanism: SpatialMechanism) -> tuple[np.ndarray, np.ndarray]:
    """The machine's central axis: a point (the centroid of the legs' base points) and a unit direction
    (normal to the plane of the base points; ``e_z`` when they are on one line or fewer than three)."""
    bases = np.array([leg.base for leg in mechanism.legs])
    centre = bases.mean(axis=0)
    if len(bases) >= 3:
        _u, sv, vt = np.linalg.svd(bases - centre)
        if sv[1] > 1e-12 * max(sv[0], 1e-300):
            return centre, vt[2]
    return centre, np.array([0.0, 0.0, 1.0])


def forearm_angles(leg: SpatialLeg, theta: np.ndarray, points: np.ndarray, elbow: np.ndarray | None = None):
    """The universal joint's angles ``(q1, q2, bad)`` of an R*US leg whose arm is at ``theta`` (K,) and whose
    spherical joint is at ``points`` (K, 3): the forearm's direction in the arm's frame (the arm's turn
    undone) turned onto by the universal joint. ``elbow`` (K, 3), the arm's tip, is computed unless given."""
    axis = np.array(leg.joints[0].axes[0])
    if elbow is None:
        elbow = np.array(leg.base) + rotate(axis, theta, leg.bodies[0].tip)
    return universal_angles(leg.joints[1].axes, leg.bodies[1].tip, rotate(axis, -theta, points - elbow))


def _rus(leg: SpatialLeg, number: int, points: np.ndarray, sigma: int, axis) -> Solved:
    arm_joint = leg.joints[0]
    axis_r = np.array(arm_joint.axes[0])
    arm, forearm = leg.bodies
    tip = np.array(arm.tip)
    along = (tip @ axis_r) * axis_r
    across = tip - along
    length = float(np.linalg.norm(forearm.tip))
    d = points - np.array(leg.base) - along
    # |d - Rot(axis, θ) across| = L_forearm:  α cos θ + β sin θ = γ
    alpha, beta = d @ across, d @ np.cross(axis_r, across)
    gamma = (np.einsum("ki,ki->k", d, d) + across @ across - length**2) / 2
    rho = np.hypot(alpha, beta)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = gamma / rho
    bad = ~(np.abs(ratio) <= 1.0)
    theta, elbow = _crank_root(leg, alpha, beta, ratio, along, across, sigma, axis)
    q1, q2, u_bad = forearm_angles(leg, theta, points, elbow)

    reach_bad = bad.copy()

    def why(k):
        where = ", ".join(f"{c:.4g}" for c in points[k])
        if reach_bad[k]:
            return (f"{_leg(leg, number)} cannot reach the point ({where}): its forearm of {length:.4g} m cannot "
                    "join the circle of its arm's tip")
        return (f"{_leg(leg, number)}: its universal joint cannot turn the forearm towards the point ({where})")

    bad = bad | u_bad
    bad, why = mark_outside_stroke(leg, number, theta, bad, why)
    return Solved(np.column_stack([theta, q1, q2]), bad, why)


def _crank_root(leg: SpatialLeg, alpha, beta, ratio, along, across, sigma: int, axis):
    """The crank angle ``θ`` (K,) of working mode ``sigma`` of the roots of ``α cos θ + β sin θ = γ``
    (``ratio = γ / √(α² + β²)``), and its elbow (K, 3): ``σ = +1`` the root whose elbow is farther from the
    machine's central ``axis`` ("knee out")."""
    axis_r = np.array(leg.joints[0].axes[0])
    by_side = abs(float(axis_r @ np.asarray(axis[1]))) > 1.0 - PARALLEL  # by the side of the point's plane (module doc)
    theta, elbow = np.empty(len(alpha)), np.empty((len(alpha), 3))
    crank_rows(axis_r, _rows(np.array(leg.base) + along), _rows(across), _rows(alpha), _rows(beta), _rows(ratio),
               sigma, _rows(axis[0]), _rows(axis[1]), by_side, theta, elbow)
    return theta, elbow


def _ups(leg: SpatialLeg, number: int, points: np.ndarray, _sigma: int, _axis) -> Solved:
    universal, slide = leg.joints[0], leg.joints[1]
    cylinder, rod = leg.bodies
    d = np.array(slide.axes[0])
    offset = np.array(cylinder.tip) + np.array(rod.tip)
    v = points - np.array(leg.base)
    span2 = np.einsum("ki,ki->k", v, v)
    # |offset + s d| = |v|: s² + 2 s (d·offset) + |offset|² - |v|² = 0, the larger root
    b = d @ offset
    disc = b * b - offset @ offset + span2
    bad = ~(disc >= 0.0)
    s = -b + np.sqrt(np.maximum(disc, 0.0))
    q1, q2, u_bad = universal_angles(universal.axes, offset + s[:, None] * d, v)
    reach_bad = bad.copy()

    def why(k):
        where = ", ".join(f"{c:.4g}" for c in points[k])
        if reach_bad[k]:
            return f"{_leg(leg, number)} cannot reach the point ({where}): it is closer than the leg's offset"
        return f"{_leg(leg, number)}: its universal joint cannot turn the leg towards the point ({where})"

    bad, why = mark_outside_stroke(leg, number, s, bad | u_bad, why)
    return Solved(np.column_stack([q1, q2, s]), bad, why)


def _slide_root(b: np.ndarray, c: np.ndarray, sigma: int) -> tuple[np.ndarray, np.ndarray]:
    """The root ``s`` of ``s² - 2 b s + c = 0`` of sign ``sigma`` (+1 the larger), and where none is real."""
    disc = b * b - c
    bad = ~(disc >= 0.0)
    return b + sigma * np.sqrt(np.maximum(disc, 0.0)), bad


def _pus(leg: SpatialLeg, number: int, points: np.ndarray, sigma: int, _axis) -> Solved:
    slide, universal = leg.joints[0], leg.joints[1]
    slider, rod = leg.bodies
    d = np.array(slide.axes[0])
    length = float(np.linalg.norm(rod.tip))
    v = points - np.array(leg.base) - np.array(slider.tip)
    # |v - s d| = |rod|: s² - 2 (d·v) s + |v|² - |rod|² = 0
    s, bad = _slide_root(v @ d, np.einsum("ki,ki->k", v, v) - length**2, sigma)
    q1, q2, u_bad = universal_angles(universal.axes, rod.tip, v - s[:, None] * d)
    reach_bad = bad.copy()

    def why(k):
        where = ", ".join(f"{c:.4g}" for c in points[k])
        if reach_bad[k]:
            return (f"{_leg(leg, number)} cannot reach the point ({where}): it is farther than its rod of "
                    f"{length:.4g} m from the slider's line")
        return f"{_leg(leg, number)}: its universal joint cannot turn the rod towards the point ({where})"

    bad, why = mark_outside_stroke(leg, number, s, bad | u_bad, why)
    return Solved(np.column_stack([s, q1, q2]), bad, why)


#: A plane within this of the point (relative to the leg's size) holds it: the point is on the leg's surface.
ON_SURFACE = 1e-9


def _across(axis: np.ndarray, d: np.ndarray) -> bool:
    """Whether the slide ``d`` is across the revolute ``axis`` (perpendicular): then the leg's point moves in a
    plane normal to the axis, and its slide is a root of a quadratic (two roots, or one kept)."""
    return abs(float(d @ axis)) < 1e-9


def _prs(leg: SpatialLeg, number: int, points: np.ndarray, sigma: int, _axis) -> Solved:
    slide, hinge = leg.joints[0], leg.joints[1]
    slider, link = leg.bodies
    d, a = np.array(slide.axes[0]), np.array(hinge.axes[0])
    t = np.array(link.tip)
    size = max(float(np.linalg.norm(t)) + float(np.linalg.norm(slider.tip)), 1e-300)
    v = points - np.array(leg.base) - np.array(slider.tip)  # = s d + Rot(a, φ) t
    if _across(a, d):
        off = np.abs(v @ a - t @ a) > ON_SURFACE * size  # the point must lie in the link's plane
        t_across = t - (t @ a) * a
        w = v - np.outer(v @ a, a)
        # |w - s d| = |t across a|: a quadratic in s
        s, bad = _slide_root(w @ d, np.einsum("ki,ki->k", w, w) - t_across @ t_across, sigma)
    else:
        s = (v @ a - t @ a) / (d @ a)  # the plane normal to the hinge through the link fixes the slide
        r = v - s[:, None] * d
        across = np.linalg.norm(r - np.outer(r @ a, a), axis=1)
        off = np.abs(across - np.linalg.norm(t - (t @ a) * a)) > ON_SURFACE * size
        bad = np.zeros(len(points), dtype=bool)
    phi = turn_onto(a, t, v - s[:, None] * d)
    reach_bad = bad | off

    def why(k):
        where = ", ".join(f"{c:.4g}" for c in points[k])
        if off[k]:
            return (f"{_leg(leg, number)} cannot reach the point ({where}): it is off the surface its link "
                    "sweeps (a pose the leg does not allow)")
        return (f"{_leg(leg, number)} cannot reach the point ({where}): its link of {np.linalg.norm(t):.4g} m "
                "cannot join the slider's line")

    bad, why = mark_outside_stroke(leg, number, s, reach_bad, why)
    return Solved(np.column_stack([s, phi]), bad, why)


def _rps(leg: SpatialLeg, number: int, points: np.ndarray, _sigma: int, _axis) -> Solved:
    hinge, slide = leg.joints[0], leg.joints[1]
    first, rod = leg.bodies
    a, d = np.array(hinge.axes[0]), np.array(slide.axes[0])
    c = np.array(first.tip) + np.array(rod.tip)  # = Rot(a, φ)⁻¹ (point - base) - s d
    size = max(float(np.linalg.norm(c)), float(np.linalg.norm(points - np.array(leg.base), axis=1).max()), 1e-300)
    v = points - np.array(leg.base)
    if _across(a, d):
        off = np.abs(v @ a - c @ a) > ON_SURFACE * size
        # |c + s d| = |v|: s² + 2 (c·d) s + |c|² - |v|² = 0, the larger root (the leg pointing out of its hinge)
        s, bad = _slide_root(-(c @ d), c @ c - np.einsum("ki,ki->k", v, v), 1)
    else:
        s = (v @ a - c @ a) / (d @ a)
        r = c + s[:, None] * d
        off = np.abs(np.linalg.norm(r, axis=1) - np.linalg.norm(v, axis=1)) > ON_SURFACE * size
        bad = np.zeros(len(points), dtype=bool)
    phi = turn_onto(a, c + s[:, None] * d, v)
    reach_bad = bad | off

    def why(k):
        where = ", ".join(f"{c_:.4g}" for c_ in points[k])
        if off[k]:
            return (f"{_leg(leg, number)} cannot reach the point ({where}): it is off the plane its hinge "
                    "turns the leg in (a pose the leg does not allow)")
        return f"{_leg(leg, number)} cannot reach the point ({where}): it is closer than the leg's offset"

    bad, why = mark_outside_stroke(leg, number, s, reach_bad, why)
    return Solved(np.column_stack([phi, s]), bad, why)


def _rrs(leg: SpatialLeg, number: int, points: np.ndarray, sigma: int, axis) -> Solved:
    crank_joint, hinge = leg.joints[0], leg.joints[1]
    crank, link = leg.bodies
    a = np.array(crank_joint.axes[0])
    t1, t2 = np.array(crank.tip), np.array(link.tip)
    along = (t1 @ a) * a
    u1, u2 = t1 - along, t2 - (t2 @ a) * a
    size = max(float(np.linalg.norm(t1)) + float(np.linalg.norm(t2)), 1e-300)
    v = points - np.array(leg.base)
    off = np.abs(v @ a - t1 @ a - t2 @ a) > ON_SURFACE * size  # the point must lie in the link's plane
    w = v - np.outer(v @ a, a)
    # |w - Rot(a, θ) u1| = |u2|:  α cos θ + β sin θ = γ (the R*US leg's equation in the plane)
    alpha, beta = w @ u1, w @ np.cross(a, u1)
    gamma = (np.einsum("ki,ki->k", w, w) + u1 @ u1 - u2 @ u2) / 2
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = gamma / np.hypot(alpha, beta)
    bad = ~(np.abs(ratio) <= 1.0)
    theta, _elbow = _crank_root(leg, alpha, beta, ratio, along, u1, sigma, axis)
    b = np.array(hinge.axes[0])  # ±a: the link turns about its own hinge's direction
    phi = turn_onto(b, t2, rotate(a, -theta, w) - u1)  # Rot(b, φ) u2 = Rot(a, -θ) w - u1
    reach_bad = bad | off

    def why(k):
        where = ", ".join(f"{c:.4g}" for c in points[k])
        if off[k]:
            return (f"{_leg(leg, number)} cannot reach the point ({where}): it is off the plane its link moves "
                    "in (a pose the leg does not allow)")
        return (f"{_leg(leg, number)} cannot reach the point ({where}): its link of {np.linalg.norm(u2):.4g} m "
                "cannot join the circle of its crank's tip")

    bad, why = mark_outside_stroke(leg, number, theta, reach_bad, why)
    return Solved(np.column_stack([theta, phi]), bad, why)


def leg_inverse_kinematics_batch(leg: SpatialLeg, number: int, points, sigma: int = 1, axis=None,
                                 follow: bool = False) -> Solved:
    """The leg's joint coordinates (K, 3 or 2), in the order of its joints, for its platform joint at ``points``
    (K, 3) in working mode ``sigma`` (a pair of signs for a leg of four branches); unreachable rows flagged in
    ``bad`` (``why(k)`` says why). ``axis`` is the machine's :func:`central_axis`, which tells an R*US leg's
    working modes apart (default: the z axis). A leg without a closed form is solved by the general method
    (:mod:`pkmlab.description.general_legs`), which follows its branch by continuity along ``points`` that are a
    path when ``follow`` is set (the closed forms' modes are continuous away from singularities)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    leg = leg.own_actuator_only()
    if not has_closed_form(leg):
        return general_legs.general_inverse_kinematics_batch(leg, number, points, sigma, follow)
    if axis is None:
        axis = (np.zeros(3), np.array([0.0, 0.0, 1.0]))
    solver = {"R*US": _rus, "UP*S": _ups, "P*US": _pus, "P*RS": _prs, "RP*S": _rps,
              "R*RS": _rrs}[position_notation(leg)]
    return solver(leg, number, points, sigma, axis)


def delta_forward_kinematics(mechanism: SpatialMechanism, theta) -> list[np.ndarray]:
    """Every position of a translating platform on three R*US legs at the actuator angles: the platform
    point lies at the forearm's length from each elbow, shifted by the leg's attachment point — three
    spheres, which meet in at most two points (below and above the elbows). Returns the positions,
    lowest first; a touching pair (the spheres tangent, a singular pose) is returned once."""
    centres, radii = [], []
    for leg, angle, a in zip(mechanism.legs, theta, mechanism.platform.attachments, strict=True):
        axis = np.array(leg.joints[0].axes[0])
        elbow = np.array(leg.base) + rotate(axis, np.array([float(angle)]), np.array([leg.bodies[0].tip]))[0]
        centres.append(elbow - np.array(a))
        radii.append(float(np.linalg.norm(leg.bodies[1].tip)))
    c1, c2, c3 = centres
    r1, r2, r3 = radii
    # trilateration in the frame of the three centres
    ex = c2 - c1
    d = np.linalg.norm(ex)
    ex = ex / d
    i = ex @ (c3 - c1)
    ey = c3 - c1 - i * ex
    ey_norm = np.linalg.norm(ey)
    if d == 0 or ey_norm < 1e-12 * max(d, 1.0):
        return []  # the centres are aligned: a circle of poses or none (a singular pair of actuator sets)
    ey = ey / ey_norm
    ez = np.cross(ex, ey)
    j = ey @ (c3 - c1)
    x = (r1**2 - r2**2 + d**2) / (2 * d)
    y = (r1**2 - r3**2 + i**2 + j**2) / (2 * j) - i / j * x
    z2 = r1**2 - x**2 - y**2
    scale = r1**2
    if z2 < -1e-12 * scale:
        return []
    base = c1 + x * ex + y * ey
    if z2 <= 1e-12 * scale:
        return [base]
    z = np.sqrt(z2)
    found = sorted([base + z * ez, base - z * ez], key=lambda p: p[2])
    return found
