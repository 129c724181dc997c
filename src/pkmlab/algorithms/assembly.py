"""Forward kinematics of one configuration: every assembly mode ``[(q, S), ...]`` of a machine at given
actuator values (the paper's §2.2.2 for its 3-RRR, and every machine pkmlab models).

:func:`assembly_modes` chooses the method from the machine: three legs holding their platform vertices on
circles — the degree-6 polynomial of :mod:`~pkmlab.algorithms.three_circles`; a point platform on two legs —
two loci meeting; the Delta — three spheres; a platform on six ``UP*S`` legs — polynomial homotopy
continuation (:mod:`~pkmlab.algorithms.stewart_fk`); any other planar machine — a sweep of the platform's
orientation (:func:`general_assembly_modes`). Each candidate is polished by Newton's method on ``η = 0``.
The batched public form is :func:`pkmlab.forward_kinematics`.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InvalidParameterError, SingularityError
from ..model.mechanism_model import (
    MechanismModel,
    constraint_jacobian,
    constraint_residual,
    inverse_kinematics_batch,
    set_aside_residual,
    singularity_measure,
)
from ..numerics.angles import wrapped_angle, wrapped_where

#: Largest row an overconstrained machine sets aside (rad or m) at an assembly mode of its own: the others of its
#: kept rows miss them by far more.
SET_ASIDE_TOL = 1e-9


def newton_passive(model: MechanismModel, q: np.ndarray, tol: float, iterations: int = 30) -> bool:
    """Newton's method on ``η = 0`` for the passive coordinates of ``q`` (in place); True once
    ``max |η| < tol``, False when ``iterations`` steps were not enough."""
    na = model.n_actuators
    for _ in range(iterations):
        eta = constraint_residual(model, q)
        if np.max(np.abs(eta)) < tol:
            return True
        q[na:] -= np.linalg.lstsq(constraint_jacobian(model, q)[:, na:], eta, rcond=None)[0]
    return False


def five_bar_assembly_modes(model: MechanismModel, theta) -> list[np.ndarray]:
    """Both assembly modes of a point platform on two legs (the five-bar's two R*RR legs, or any leg
    types of :mod:`~pkmlab.description.leg_types`): the end point is where the two legs' circles
    (:func:`~pkmlab.description.leg_types.leg_circle`, about the elbows ``E_i`` for the five-bar)
    meet — none, one or two configurations."""
    from ..description.leg_types import leg_circle, leg_coordinates

    if model.description.platform.kind != "point" or len(model.description.legs) != 2:
        raise InvalidParameterError(f"{model.description.notation} is not a point platform on two legs")
    theta = np.asarray(theta, dtype=float)
    m, own, base = ordinary_machine(model, theta)
    circles = [leg_circle(leg, t) for leg, t in zip(m.legs, own, strict=True)]
    elbows = [np.array(c) for c, _r in circles]
    radii = [r for _c, r in circles]
    d = elbows[1] - elbows[0]
    dist = float(np.hypot(*d))
    if dist == 0 and radii[0] == radii[1]:
        raise SingularityError(f"actuators {theta.tolist()}: both elbows coincide and the links are equal: "
                               "a continuum of assembly modes")
    if dist == 0 or dist > radii[0] + radii[1] or dist < abs(radii[0] - radii[1]):
        return []
    along = (radii[0] ** 2 - radii[1] ** 2 + dist**2) / (2 * dist)
    across = math.sqrt(max(radii[0] ** 2 - along**2, 0.0))
    ex, n = d / dist, np.array([-d[1], d[0]]) / dist
    out = []
    for sign in ((1.0, -1.0) if across > 0 else (1.0,)):
        point = elbows[0] + along * ex + sign * across * n
        out.append(configuration(model, theta, base, [leg_coordinates(leg, t, point) for leg, t in
                                                      zip(m.legs, own, strict=True)], point))
    return out


def ordinary_machine(model: MechanismModel, theta: np.ndarray):
    """The machine of one actuator per leg that ``model``'s is at actuator values ``theta`` (each kinematically
    redundant leg's ordinary part on the base its first actuators put it on: what its forward kinematics solves),
    each leg's own actuator's value ``(legs,)`` and its base actuators' values (a list of ``(moving_base,)``); the
    description itself for a machine of one actuator per leg. (A redundantly actuated machine's forward kinematics
    solves the sub-machine of a subset of its actuators, one per leg.)"""
    from ..description.mechanism import Mechanism, moving_base, ordinary_part

    m = model.description
    legs, own, base, k = [], [], [], 0
    for leg in m.legs:
        values = np.asarray(theta[k:k + len(leg.actuated_joints)], dtype=float)
        k += len(leg.actuated_joints)
        own.append(float(values[leg.actuated_joints.index(leg.actuated)]))
        base.append(values[:leg.moving_base])
        if leg.moving_base:
            origin, direction = moving_base(leg, values[None, :leg.moving_base])
            leg = ordinary_part(leg, origin[0], float(direction[0]))
        legs.append(leg)
    if not m.redundancy_names:
        return m, np.array(own), base
    return Mechanism(m.name, tuple(legs), m.platform, m.gravity), np.array(own), base


def configuration(model: MechanismModel, theta: np.ndarray, base, coordinates, pose) -> np.ndarray:
    """``q`` of actuator values ``theta`` and the platform's ``pose`` from each leg's joint coordinates as the
    :func:`ordinary_machine`'s leg gives them (``coordinates``, one list per leg), its base actuators' values
    ``base`` before them."""
    passive = []
    for leg, values, coords in zip(model.description.legs, base, coordinates, strict=True):
        passive += [v for k, v in enumerate([*values, *coords]) if k not in leg.actuated_joints]
    return np.array([*theta, *passive, *pose], dtype=float)


def fk_method(model: MechanismModel) -> str:
    """The method :func:`assembly_modes` uses for ``model``: ``"soma"`` (six UP*S legs, the Stewart–Gough
    platform), ``"three_spheres"`` (a translating platform on R*US legs, the Delta), ``"general_spatial"`` (any
    other spatial machine), ``"orientation_sweep"`` (a planar machine with a leg of no closed form),
    ``"two_circles"`` (a point platform: the five-bar) or ``"sextic"`` (a planar three-leg machine on circles)."""
    from ..description.leg_types import SOLVERS
    from ..description.mechanism import ordinary_part

    m = model.description
    if getattr(m, "spatial", False):
        if m.platform.kind == "rigid" and len(m.legs) == 6 and all(leg.notation == "UP*S" for leg in m.legs):
            return "soma"
        if m.platform.kind == "translating" and all(leg.notation == "R*US" for leg in m.legs):
            return "three_spheres"
        return "general_spatial"
    if any(ordinary_part(leg).notation not in SOLVERS for leg in m.legs):
        return "orientation_sweep"
    return "two_circles" if m.platform.kind == "point" else "sextic"


#: What each method of :func:`fk_method` finds and guarantees.
METHOD_STATEMENTS = {
    "soma": "every real pose of the six leg lengths: a total-degree homotopy of 128 paths on the soma-coordinate "
            "quadrics (up to 40 poses), checked for jumps and conjugate pairs: complete unless a warning says "
            "otherwise",
    "three_spheres": "both intersections of three spheres (closed form): complete",
    "general_spatial": "a parameter homotopy from the {solutions} complex solutions of a generic instance (found by "
                       "monodromy, {loops} loops): complete unless a warning says otherwise",
    "orientation_sweep": "the loci's intersections along a sweep of the platform's orientation, every sign change "
                         "and dip refined: complete unless a warning says otherwise",
    "two_circles": "both intersections of two circles (closed form): complete",
    "sextic": "every real root of one degree-6 polynomial (the paper's eq. 12, Gosselin's general form): complete",
}


def method_statement(model: MechanismModel) -> str:
    """Which method :func:`assembly_modes` uses for ``model``, and what it guarantees: the completeness statement
    that ``pkmlab fk`` prints beside the assembly modes (a solve that cannot keep the guarantee warns with
    :class:`~pkmlab.errors.IncompleteSolutionWarning`)."""
    method = fk_method(model)
    if method != "general_spatial":
        return METHOD_STATEMENTS[method]
    from .general_fk import generic_solutions

    solutions, _p, loops = generic_solutions(model.description)
    return METHOD_STATEMENTS[method].format(solutions=len(solutions), loops=loops)


def assembly_modes(model: MechanismModel, theta) -> list[tuple[np.ndarray, float]]:
    """Every assembly mode ``[(q, S), ...]`` (sorted by the platform's angle) at ``actuators``.

    A rigid platform on three legs each holding its attachment point on a circle
    (:func:`~pkmlab.description.leg_types.leg_circle`: the leg types with a closed form): the roots of
    one degree-6 polynomial (:func:`~pkmlab.algorithms.three_circles.three_circles`, the paper's eq. 12 in
    Gosselin's general form), each polished by Newton's method on ``η = 0``; a five-bar: two circles.
    Any other machine: the general method of :func:`general_assembly_modes`, which warns
    (:class:`~pkmlab.errors.IncompleteSolutionWarning`) where it cannot guarantee that it found every
    assembly mode.
    """
    theta = _actuator_values(model, theta)
    if model.description.actuation_redundancy:  # (forward_kinematics solves it from a subset of its actuators)
        raise InvalidParameterError(f"the {model.name}'s {model.n_actuators} actuators are "
                                    f"{model.description.actuation_redundancy} more than its {model.dof} degrees of "
                                    "freedom: its assembly modes are those of a subset of them "
                                    "(forward_kinematics(..., actuators=))")
    method = fk_method(model)
    if method == "soma":
        return _stewart_assembly_modes(model, theta)
    if method == "three_spheres":
        return _delta_assembly_modes(model, theta)
    if method == "general_spatial":
        return general_spatial_assembly_modes(model, theta)
    if method == "orientation_sweep":
        solutions, doubt = general_assembly_modes(model, theta)
        if doubt:
            import warnings

            from ..errors import IncompleteSolutionWarning

            warnings.warn(f"forward kinematics at actuators {np.round(np.asarray(theta, float), 6).tolist()}: "
                          f"{doubt}: an assembly mode there may be missing", IncompleteSolutionWarning, stacklevel=2)
        return solutions
    from ..description.leg_types import leg_circle, leg_coordinates
    from ..description.mechanism import attachment_point
    from .three_circles import OK, three_circles_from_python

    if method == "two_circles":
        return [(q, singularity_measure(model, q)) for q in five_bar_assembly_modes(model, theta)]
    m, own, base = ordinary_machine(model, theta)
    circles = [leg_circle(leg, t) for leg, t in zip(m.legs, own, strict=True)]
    centres = np.array([c for c, _r in circles])
    radii = np.array([r for _c, r in circles])
    a = np.array(m.platform.attachments)
    vertices = np.array([*(a[1] - a[0]), *(a[2] - a[0])])
    alphas, p1 = np.empty(6), np.empty((6, 2))
    count, status = three_circles_from_python(centres, radii, vertices, alphas, p1)
    if status != OK:
        raise SingularityError(f"actuators {theta.tolist()}: the forward-kinematics polynomial vanishes "
                               "identically (a continuum of assembly modes)")
    configurations = []
    for j in range(count):
        alpha = alphas[j]
        c, s = math.cos(alpha), math.sin(alpha)
        x, y = p1[j] - (c * a[0, 0] - s * a[0, 1], s * a[0, 0] + c * a[0, 1])
        pose = np.array([x, y, alpha])
        configurations.append(configuration(model, theta, base, [
            leg_coordinates(leg, own[i], attachment_point(m, i, pose)) for i, leg in enumerate(m.legs)], pose))
    return _polished(model, configurations)


def _delta_assembly_modes(model: MechanismModel, theta: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Every assembly mode of a translating platform on three R*US legs (the Delta): the two points where three
    spheres meet (:func:`~pkmlab.description.spatial_legs.delta_forward_kinematics`), the forearms'
    universal-joint angles from them, each polished by Newton's method on ``η = 0``."""
    from ..description.spatial_legs import delta_forward_kinematics, forearm_angles

    m = model.description
    points = delta_forward_kinematics(m, theta)
    if not points:
        return _polished(model, [])
    points = np.array(points)
    passive = np.empty((len(points), 2 * len(m.legs)))
    for i, leg in enumerate(m.legs):  # each leg's forearm at every point at once
        q1, q2, _ = forearm_angles(leg, np.full(len(points), theta[i]), points + np.array(m.platform.attachments[i]))
        passive[:, 2 * i], passive[:, 2 * i + 1] = q1, q2
    return _polished(model, [np.array([*theta, *row, *point]) for row, point in zip(passive, points, strict=True)])


def general_spatial_assembly_modes(model: MechanismModel, theta) -> list[tuple[np.ndarray, float]]:
    """Every real assembly mode of any spatial machine by the general method of
    :mod:`~pkmlab.algorithms.general_fk` (a parameter homotopy on its loop-closure polynomials), each polished
    by Newton's method on ``η = 0``; an :class:`~pkmlab.errors.IncompleteSolutionWarning` where paths failed or
    ended at singular solutions. The Delta's and the Stewart platform's fast paths are checked against it."""
    import warnings

    from ..errors import IncompleteSolutionWarning
    from .general_fk import general_assembly_modes as solve

    theta = np.asarray(theta, dtype=float)
    found = solve(model, theta)
    if found.doubt:
        warnings.warn(f"forward kinematics at actuators {np.round(theta, 6).tolist()}: {found.doubt}: an assembly "
                      "mode there may be missing", IncompleteSolutionWarning, stacklevel=3)
    # an overconstrained machine's rows set aside hold at its own assembly modes, not at the others of its kept rows
    return [(q, s) for q, s in _polished(model, found.configurations)
            if np.abs(set_aside_residual(model, q)).max(initial=0.0) < SET_ASIDE_TOL]


def _stewart_assembly_modes(model: MechanismModel, theta: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Every real assembly mode of a platform on six UP*S legs (the general Stewart–Gough platform, up to 40):
    each leg's slide gives the distance from its universal joint's centre to its spherical joint, and
    :func:`~pkmlab.algorithms.stewart_fk.assembly_modes` (polynomial homotopy continuation) returns every
    real pose at those six distances; each becomes a configuration by the legs' inverse kinematics (the
    universal joints' angles), polished by Newton's method on ``η = 0``. Sorted by the pose's last
    coordinate (yaw)."""
    from ..description.spatial import orientation_angles, orientations
    from .stewart_fk import assembly_modes as platform_poses

    m = model.description
    lengths = []
    for leg, s in zip(m.legs, theta, strict=True):
        offset = np.array(leg.bodies[0].tip) + np.array(leg.bodies[1].tip)
        lengths.append(float(np.linalg.norm(offset + s * np.array(leg.joints[1].axes[0]))))
    configurations = []
    poses = platform_poses(np.array([leg.base for leg in m.legs]), np.array(m.platform.attachments),
                           np.array(lengths))
    for rot, p in poses:
        pose = np.array([*p, *orientation_angles(rot)])
        if not np.allclose(orientations(pose[None, 3:])[0], rot, atol=1e-9):
            continue  # at gimbal lock: no roll, pitch, yaw (said below, with the poses lost)
        q, _unreachable, failure = inverse_kinematics_batch(model, pose[None, :], ())
        if failure is None:
            q = q[0]
            q[:len(m.legs)] = theta
            configurations.append(q)
    found = _polished(model, configurations)
    if len(found) < len(poses):
        import warnings

        from ..errors import IncompleteSolutionWarning

        warnings.warn(f"forward kinematics at actuators {np.round(theta, 6).tolist()}: {len(poses) - len(found)} of "
                      f"the {len(poses)} poses could not be given coordinates (a universal joint at its own "
                      "singularity, a leg along its first axis; or pitch = ±pi/2, gimbal lock)",
                      IncompleteSolutionWarning, stacklevel=3)
    return found


def _actuator_values(model: MechanismModel, theta) -> np.ndarray:
    """The actuator values of a forward-kinematics request: one finite value per leg, within its stroke."""
    m = model.description
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (model.n_actuators,) or not np.all(np.isfinite(theta)):
        raise InvalidParameterError(f"theta must be {model.n_actuators} finite values, got "
                                    f"{np.asarray(theta).tolist()}")
    for k, (i, joint) in enumerate(m.actuators):
        leg, t = m.legs[i], theta[k]
        if (joint == leg.actuated and leg.stroke is not None and leg.joints[joint].kind == "P"
                and not leg.stroke[0] <= t <= leg.stroke[1]):
            raise InvalidParameterError(f"leg {i + 1}: actuator value {t:g} m is outside its stroke "
                                        f"[{leg.stroke[0]:g}, {leg.stroke[1]:g}] m")
    return theta


def _polished(model: MechanismModel, configurations) -> list[tuple[np.ndarray, float]]:
    """The distinct assembly modes ``[(q, S), ...]`` among approximate ``configurations``: each polished by
    Newton's method on ``η = 0`` (dropped if that fails), its passive angles wrapped to (-π, π], sorted by
    the pose's last coordinate."""
    na, solutions = model.n_actuators, []
    angular = np.array(model.kernels.ANGLES)
    angular[:na] = False  # the actuators stay as given
    for q in configurations:
        q = q.copy()
        newton_passive(model, q, 1e-15)  # polish
        if np.max(np.abs(constraint_residual(model, q))) > 1e-12:
            continue
        q[angular] = wrapped_angle(q[angular])
        # a double root (at a singularity) is found only to about sqrt(eps): closer than 1e-6 is one mode
        if all(np.max(np.abs(wrapped_where(q - other, model.kernels.ANGLES))) > 1e-6 for other, _s in solutions):
            solutions.append((q, singularity_measure(model, q)))
    return sorted(solutions, key=lambda sol: sol[0][-1])


#: The general forward kinematics samples the platform's orientation at this many points in a turn.
FK_SAMPLES = 2881


def _intersections(first, second, touching: float = 0.0):
    """Points (..., 2 branches, 2) common to two loci given as ``(kind, A (..., 2), B (..., 2))`` (a circle of
    centre ``A`` and radius ``|B|``, or the line through ``A`` along ``B``); NaN where there is none. The
    branches keep their identity as the loci move (the sign of the square root). Loci that miss each other
    by less than ``touching`` (m) are taken as tangent: one point, on both branches."""
    kind1, a1, b1 = first
    kind2, a2, b2 = second
    if kind1 == "line" and kind2 == "circle":
        return _intersections(second, first, touching)

    def root(square, scale):  # √square, with a round-off's worth below zero read as zero
        return np.sqrt(np.where((square < 0) & (square > -touching * scale), 0.0, square))
    with np.errstate(invalid="ignore", divide="ignore"):
        if kind1 == "circle" and kind2 == "circle":
            r1, r2 = np.hypot(*np.moveaxis(b1, -1, 0)), np.hypot(*np.moveaxis(b2, -1, 0))
            d = a2 - a1
            dist = np.hypot(d[..., 0], d[..., 1])
            along = (r1 * r1 - r2 * r2 + dist * dist) / (2 * dist)
            across = root(r1 * r1 - along * along, 2 * np.maximum(r1, 1e-300))
            e = d / dist[..., None]
            n = np.stack([-e[..., 1], e[..., 0]], axis=-1)
            base = a1 + along[..., None] * e
            return np.stack([base + across[..., None] * n, base - across[..., None] * n], axis=-2)
        if kind1 == "circle":  # the line a2 + t b2 on the circle (a1, |b1|)
            w = a2 - a1
            uu = (b2 * b2).sum(axis=-1)
            half = (b2 * w).sum(axis=-1)
            disc = root(half * half - uu * ((w * w).sum(axis=-1) - (b1 * b1).sum(axis=-1)),
                        2 * uu * np.hypot(*np.moveaxis(b1, -1, 0)))
            return np.stack([a2 + ((-half + disc) / uu)[..., None] * b2, a2 + ((-half - disc) / uu)[..., None] * b2],
                            axis=-2)
        cross = b1[..., 0] * b2[..., 1] - b1[..., 1] * b2[..., 0]  # two lines: one point, or none if parallel
        w = a2 - a1
        t = (w[..., 0] * b2[..., 1] - w[..., 1] * b2[..., 0]) / cross
        point = np.where(np.abs(cross)[..., None] > 0, a1 + t[..., None] * b1, np.nan)
        return np.stack([point, np.full_like(point, np.nan)], axis=-2)


def general_assembly_modes(model: MechanismModel, theta) -> tuple[list[tuple[np.ndarray, float]], str]:
    """Every assembly mode of any machine whose legs hold their ends on circles or lines
    (:class:`~pkmlab.description.leg_types.Locus`), and a doubt: ``""`` when the method guarantees that it
    found all of them, else where it cannot.

    A point platform on two legs: the intersections of their two loci (complete). A rigid platform on three
    legs: for each orientation ``α`` of a fine grid over a turn, the attachment point ``p1`` is where leg 1's
    locus meets leg 2's moved by ``-R(α)(a2 - a1)`` (at most two branches), and ``f(α)``, how far
    ``p1 + R(α)(a3 - a1)`` is off leg 3's locus, vanishes at the assembly modes: every sign change of ``f``
    along a branch is refined by bisection in ``α``; every dip of ``|f|`` between samples of one sign is
    searched for its bottom, which holds two roots closer than the grid's step or a double root (a
    singularity: one assembly mode); a root between a branch's last sample and its end (two loci tangent)
    is bisected there. Each is polished by Newton's method on ``η = 0``. What remains unsure is said: ``f``
    nearly zero exactly where a branch ends.
    """
    from ..description.leg_types import Locus
    from ..description.mechanism import attachment_points

    theta = _actuator_values(model, theta)
    m, own, base = ordinary_machine(model, theta)
    loci = [Locus(leg, i) for i, leg in enumerate(m.legs)]
    shapes = [(locus.kind, *locus.at(t)) for locus, t in zip(loci, own, strict=True)]
    doubt, candidates = "", []
    if m.platform.kind == "point":
        reach = max(float(np.hypot(*shape[2])) if shape[0] == "circle" else 1.0 for shape in shapes)
        for point in _intersections(*shapes, touching=1e-12 * reach):
            if np.all(np.isfinite(point)):
                candidates.append(np.array([*point, 0.0]))
    else:
        a = np.array(m.platform.attachments)
        kind3, c3, b3 = shapes[2]
        scale = np.hypot(*b3) if kind3 == "circle" else 1.0

        def branches(alpha):
            c, s = np.cos(alpha)[..., None], np.sin(alpha)[..., None]

            def turn(v):
                return np.concatenate([c * v[0] - s * v[1], s * v[0] + c * v[1]], axis=-1)

            kind2, a2, b2 = shapes[1]
            moved = a2 - turn(a[1] - a[0])
            p1 = _intersections(shapes[0], (kind2, moved, np.broadcast_to(b2, moved.shape)))
            q3 = p1 + turn(a[2] - a[0])[..., None, :]
            d = q3 - c3
            off = ((d * d).sum(axis=-1) - (b3 * b3).sum()) / (2 * scale) if kind3 == "circle" else \
                (b3[0] * d[..., 1] - b3[1] * d[..., 0]) / np.hypot(*b3)
            return p1, off  # (..., 2, 2), (..., 2)

        grid = np.linspace(-np.pi, np.pi, FK_SAMPLES)
        _p1, f = branches(grid)  # (G, 2)
        size = float(np.ptp(a, axis=0).max()) or 1.0

        def value(alpha, b):
            return branches(np.array(alpha))[1][b]

        def root(b, start, end):
            """Bisection on branch ``b`` between orientations where ``f`` has opposite signs (``end`` may be
            where the branch ends): the pose there."""
            f_start = value(start, b)
            for _ in range(60):
                mid = 0.5 * (start + end)
                f_mid = value(mid, b)
                if np.isfinite(f_mid) and np.sign(f_mid) == np.sign(f_start):
                    start, f_start = mid, f_mid
                else:
                    end = mid
            alpha = 0.5 * (start + end) if np.isfinite(value(0.5 * (start + end), b)) else start
            p1 = branches(np.array(alpha))[0][b]
            c, s = math.cos(alpha), math.sin(alpha)
            return np.array([p1[0] - (c * a[0, 0] - s * a[0, 1]), p1[1] - (s * a[0, 0] + c * a[0, 1]), alpha])

        for b in range(2):
            fb = f[:, b]
            finite = np.isfinite(fb)
            both = finite[:-1] & finite[1:]
            for k in np.flatnonzero(both & (np.sign(fb[:-1]) * np.sign(fb[1:]) <= 0) & (fb[:-1] != fb[1:])):
                candidates.append(root(b, grid[k], grid[k + 1]))
            # where the branch ends (two legs' loci become tangent), between the last sample and the end
            for k in np.flatnonzero(finite[:-1] != finite[1:]):
                inside, outside = (k, k + 1) if finite[k] else (k + 1, k)
                last, gone = grid[inside], grid[outside]
                for _ in range(60):  # the end of the branch
                    mid = 0.5 * (last + gone)
                    last, gone = (mid, gone) if np.isfinite(value(mid, b)) else (last, mid)
                f_end = value(last, b)
                if np.sign(f_end) != np.sign(fb[inside]):
                    candidates.append(root(b, grid[inside], last))
                elif abs(f_end) < 1e-7 * size and not doubt:
                    doubt = f"|f| nearly vanishes at alpha = {last:.6g} rad, where two legs' loci become tangent"
            # what the grid cannot see: f dipping towards zero between samples of one sign, where two roots
            # may lie closer than the grid's step, or one double root (at a singularity)
            inner = both[:-1] & both[1:]
            dips = np.flatnonzero(inner & (np.abs(fb[1:-1]) <= np.abs(fb[:-2])) & (np.abs(fb[1:-1]) <= np.abs(fb[2:]))
                                  & (np.sign(fb[:-2]) == np.sign(fb[1:-1])) & (np.sign(fb[1:-1]) == np.sign(fb[2:])))
            for k in dips + 1:
                sign = np.sign(fb[k])
                lo, hi = grid[k - 1], grid[k + 1]
                for _ in range(80):  # golden section for the dip's bottom
                    x1, x2 = hi - 0.618034 * (hi - lo), lo + 0.618034 * (hi - lo)
                    if sign * value(x1, b) < sign * value(x2, b):
                        hi = x2
                    else:
                        lo = x1
                bottom = 0.5 * (lo + hi)
                depth = sign * value(bottom, b)
                if depth < 0:  # two roots in one step of the grid
                    candidates += [root(b, grid[k - 1], bottom), root(b, bottom, grid[k + 1])]
                elif depth < 1e-10 * size:  # a double root: one assembly mode, at a singularity
                    candidates.append(root(b, bottom, bottom))
    configurations = []
    for pose in candidates:
        pose = pose[:m.dof]
        legs = []
        for i, (leg, locus) in enumerate(zip(m.legs, loci, strict=True)):
            coords = [0.0, 0.0]
            coords[leg.actuated] = own[i]
            coords[locus.passive] = float(locus.passive_coordinate(own[i], attachment_points(m, i, pose[None, :]))[0])
            legs.append(coords)
        configurations.append(configuration(model, theta, base, legs, pose))
    return _polished(model, configurations), doubt
