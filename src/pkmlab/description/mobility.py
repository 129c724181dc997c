"""The mobility of a spatial machine, computed: the dimension of its configuration space near generic
configurations, not a joint count.

A machine's configurations are its legs' joint coordinates and its platform's whole pose, ``x`` (every
coordinate, actuated or not, the pose as :attr:`~pkmlab.description.spatial.SpatialPlatform.full_pose_names`),
bound by the loop closures ``η(x) = 0``: each leg's platform joint at its platform attachment point (3
equations per leg, its *point rows*), then the *orientation rows* of the legs that end in a universal or a
revolute joint under a rigid platform: a universal joint's two axes perpendicular, ``(R_leg a₁)·(R a₂) = 0`` (its
first axis turning with the leg's last body, its second with the platform: one row; the joint can then turn the
body onto the platform), a revolute joint's axis the same in both, ``(R_leg a)·(R b₁) = (R_leg a)·(R b₂) = 0``
(``b₁``, ``b₂`` across ``a``: two rows). Near a generic configuration these define a manifold of dimension

    mobility = dim x - rank ∂η/∂x,

the definition the Grübler–Kutzbach count approximates; the count is wrong for overconstrained machines
(whose constraints are dependent at every configuration, as the 3-UPU's), the rank is not. The rank is
taken at a few configurations found by projecting random starts onto ``η = 0`` (Gauss–Newton,
minimum-norm steps), the largest of them (a rank can only drop at special configurations), with the
columns of angles scaled by the machine's size so that metres and radians weigh alike.

**Overconstrained machines.** Where the rows are dependent at every configuration (a spherical 3-RRR, the
Agile Eye, whose orientation rows all follow from its point rows), the model keeps an independent set: every
point row, and the orientation rows of the legs of the types (notations) that add to the rank — or, where no
choice of whole types does, of as many single legs as do (a 4-RUU keeps two of its four legs' rows) — or, where
no choice of whole legs does, single rows (a 3-CRR keeps one of each leg's two: any two legs' four rows repeat
one) (:func:`kept_leg_rows`), chosen at a generic configuration. Near it the kept rows define the same manifold
(the same dimension, and it lies in theirs); the rows set aside are checked to vanish at generic configurations
of the kept ones (:func:`check_kept_rows`), and a machine whose rows no choice makes independent is refused.

A description is accepted when its mobility is the number of its controlled pose coordinates (its actuators may
be more: redundant actuation), its constraints are independent (or kept so), its actuators determine its
configuration (locked, they leave no motion), and its controlled coordinates do too (no motion leaves them
unchanged). Each refusal
is one line giving the computed numbers and each leg's share: the number of the platform's freedoms a
leg removes (its rows less the rank of their Jacobian in the leg's own coordinates: ``3 -`` the rank of its end
point's Jacobian, for a leg ending in a spherical joint).
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidParameterError

#: Relative size of the singular values counted in a rank.
RANK_TOL = 1e-8
#: Projections onto η = 0: random starts tried, Gauss–Newton iterations per start.
STARTS, ITERATIONS = 12, 80
#: Configurations whose ranks are compared.
SAMPLES = 3


@dataclass(frozen=True)
class Mobility:
    """The computed mobility of a machine and what it is made of.

    ``mobility`` is ``coordinates - rank``; ``leg_constraints`` the number of the platform's freedoms each leg
    removes; ``configuration`` one generic configuration found (legs' joint coordinates leg by leg, then the
    whole pose); ``kept`` the rows of ``η`` the model keeps (every one where they are independent; None where no
    choice of leg types, single legs or single rows makes them so, module docstring)."""

    mobility: int
    rank: int
    coordinates: int
    constraints: int
    leg_constraints: tuple[int, ...]
    configuration: np.ndarray
    actuated_rank: int
    controlled_rank: int
    kept: tuple[int, ...] | None = None

    @property
    def summary(self) -> str:
        """E.g. ``"rank 9 of 15 coordinates; each leg removes 0 of the platform's freedoms"``."""
        shares = sorted(set(self.leg_constraints))
        if len(shares) == 1:
            legs = f"each leg removes {shares[0]} of the platform's freedoms"
        else:
            legs = "; ".join(f"legs {', '.join(str(i + 1) for i, c in enumerate(self.leg_constraints) if c == s)} "
                             f"remove {s} each" for s in shares) + " of the platform's freedoms"
        return f"the constraint Jacobian has rank {self.rank} in {self.coordinates} coordinates; {legs}"


def _layout(mechanism):
    from .spatial import leg_coordinate_count

    counts = [leg_coordinate_count(leg) for leg in mechanism.legs]
    starts = np.cumsum([0, *counts])
    return counts, starts, len(mechanism.platform.full_pose_names)


def _size(mechanism) -> float:
    reach = max(sum(float(np.linalg.norm(b.tip)) for b in leg.bodies) for leg in mechanism.legs)
    spread = max(float(np.linalg.norm(np.subtract(a, b))) for a in mechanism.platform.attachments
                 for b in mechanism.platform.attachments)
    return max(reach, spread, 1e-3)


def _leg_end(leg, coordinates) -> tuple[np.ndarray, np.ndarray]:
    """The centre of the leg's platform joint at its joint coordinates, and its Jacobian (3, coordinates)
    (:func:`_leg_twist`)."""
    point, _rot, linear, _angular = _leg_twist(leg, coordinates)
    return point, linear


def _leg_twist(leg, coordinates) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The centre of the leg's platform joint at its joint coordinates, its last body's orientation, and the
    Jacobians (3, coordinates) of the centre's velocity and of the last body's angular velocity (world frame): a
    turn about the world axis ``w`` at ``o`` moves the centre by ``w × (end - o)`` and turns the body by
    ``w``, a slide along ``u`` moves it by ``u`` (the chain of :func:`~pkmlab.description.spatial.leg_frames`)."""
    from .spatial import axis_rotation

    values = iter(float(c) for c in coordinates)
    point, rot = np.array(leg.base, dtype=float), np.eye(3)
    moves = []  # (kind, world axis, origin)
    for joint, body in zip(leg.joints, leg.bodies, strict=False):
        origin = point
        if joint.kind == "P":
            axis = rot @ np.array(joint.axes[0])
            origin = point + next(values) * axis
            moves.append(("P", axis, origin))
        else:
            for a in joint.axes:
                axis = rot @ np.array(a)
                moves.append(("R", axis, point))
                rot = rot @ axis_rotation(a, next(values))
        point = origin + rot @ np.array(body.tip)
    if not moves:
        return point, rot, np.zeros((3, 0)), np.zeros((3, 0))
    linear = np.column_stack([axis if kind == "P" else np.cross(axis, point - o) for kind, axis, o in moves])
    angular = np.column_stack([np.zeros(3) if kind == "P" else axis for kind, axis, _o in moves])
    return point, rot, linear, angular


#: Orientation rows of each platform joint under a rigid platform (module docstring).
PLATFORM_JOINT_ROWS = {"S": 0, "U": 1, "R": 2}


def all_orientation_rows(mechanism) -> tuple[tuple[int, int], ...]:
    """Every orientation row of ``mechanism`` (module docstring) as ``(leg, k)``, leg by leg: they follow every
    leg's point rows in ``η``."""
    if mechanism.platform.kind != "rigid":
        return ()
    return tuple((i, k) for i, leg in enumerate(mechanism.legs)
                 for k in range(PLATFORM_JOINT_ROWS[leg.joints[-1].kind]))


def orientation_legs(mechanism) -> tuple[int, ...]:
    """The legs that have orientation rows (module docstring): those ending in a universal or revolute joint under a
    rigid platform, in order."""
    return tuple(sorted({i for i, _k in all_orientation_rows(mechanism)}))


def kept_rows(mechanism) -> tuple[int, ...]:
    """The rows of ``η`` the model of ``mechanism`` keeps (module docstring; every row of a machine whose rows are
    independent), in order."""
    return _computed(mechanism, 0).kept or ()


def orientation_rows(mechanism) -> tuple[int, ...]:
    """The legs some of whose orientation rows the model keeps (module docstring), in order: every leg ending in a
    universal or revolute joint under a rigid platform unless its rows depend on the others."""
    return tuple(i for i, rows in enumerate(kept_leg_rows(mechanism)) if rows)


def kept_leg_rows(mechanism) -> tuple[tuple[int, ...], ...]:
    """Which of each leg's orientation rows the model keeps, leg by leg: ``(0,)`` for a universal joint's row,
    ``(0, 1)``, ``(0,)`` or ``(1,)`` for a revolute joint's two (:func:`across` their axes), ``()`` for none."""
    orient = all_orientation_rows(mechanism)
    if not orient:
        return ((),) * len(mechanism.legs)
    return _leg_masks(mechanism, kept_rows(mechanism))


def _leg_masks(mechanism, kept) -> tuple[tuple[int, ...], ...]:
    """Each leg's orientation rows (its ``k``s) among the rows ``kept`` of ``η``."""
    n_point = 3 * len(mechanism.legs)
    orient = all_orientation_rows(mechanism)
    return tuple(tuple(k for r, (j, k) in enumerate(orient) if j == i and n_point + r in kept)
                 for i in range(len(mechanism.legs)))


def leg_rows(mechanism, leg: int) -> list[int]:
    """The rows of ``η`` of leg ``leg`` (0-based): its point rows, then its orientation rows."""
    n_point = 3 * len(mechanism.legs)
    extra = [n_point + r for r, (i, _k) in enumerate(all_orientation_rows(mechanism)) if i == leg]
    return [3 * leg, 3 * leg + 1, 3 * leg + 2, *extra]


def _row_axes(joint) -> list[tuple]:
    """The pairs ``(a, b)`` of a platform joint's orientation rows ``(R_leg a)·(R b) = 0``: a universal joint's two
    axes; a revolute joint's axis with each of :func:`across` it."""
    return [joint.axes] if joint.kind == "U" else [(joint.axes[0], b) for b in across(joint.axes[0])]


def across(axis) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors across the unit ``axis`` and across each other: a revolute platform joint's rows'
    ``b₁``, ``b₂`` (the first across the world axis least along ``axis``)."""
    a = np.asarray(axis, dtype=float)
    b1 = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
    b1 /= np.linalg.norm(b1)
    return b1, np.cross(a, b1)


def orientation_residuals(mechanism, x: np.ndarray) -> np.ndarray:
    """The orientation rows of ``η`` (module docstring) at many configurations ``x`` (K, n) at once, (K, rows):
    :func:`residual`'s last rows, each leg's last body turned by its joints' rotations in a batch."""
    from .spatial import orientations

    x = np.asarray(x, dtype=float)
    orient = all_orientation_rows(mechanism)
    out = np.empty((len(x), len(orient)))
    if not orient:
        return out
    _counts, starts, _n_pose = _layout(mechanism)
    platform = orientations(x[:, starts[-1] + 3:starts[-1] + 6])
    for i in orientation_legs(mechanism):
        leg = mechanism.legs[i]
        rot, column = np.broadcast_to(np.eye(3), (len(x), 3, 3)), starts[i]
        for joint in leg.joints[:-1]:
            if joint.kind == "P":
                column += 1
                continue
            for axis in joint.axes:
                rot = rot @ _axis_rotations(axis, x[:, column])
                column += 1
        rows = [r for r, (j, _k) in enumerate(orient) if j == i]
        for r, (a, b) in zip(rows, _row_axes(leg.joints[-1]), strict=True):
            out[:, r] = np.einsum("ki,ki->k", rot @ np.array(a), platform @ np.array(b))
    return out


def _axis_rotations(axis, angles: np.ndarray) -> np.ndarray:
    """Rodrigues' rotations (K, 3, 3) by ``angles`` (K,) about the unit ``axis``."""
    a = np.asarray(axis, dtype=float)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    c, s = np.cos(angles)[:, None, None], np.sin(angles)[:, None, None]
    return c * np.eye(3) + s * k + (1 - c) * np.outer(a, a)


def residual(mechanism, x: np.ndarray) -> np.ndarray:
    """``η(x)`` (module docstring): each leg's platform joint minus its attachment point (3 per leg), then the
    orientation rows."""
    return _residual_and_jacobian(mechanism, x)[0]


def jacobian(mechanism, x: np.ndarray) -> np.ndarray:
    """``∂η/∂x``: the legs' columns exact, the orientation's by central differences of ``R a`` (1e-7 rad)."""
    return _residual_and_jacobian(mechanism, x)[1]


def _residual_and_jacobian(mechanism, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    from .spatial import orientation

    counts, starts, n_pose = _layout(mechanism)
    pose = x[starts[-1]:]
    n = len(mechanism.legs)
    orient = all_orientation_rows(mechanism)
    eta, jac = np.zeros(3 * n + len(orient)), np.zeros((3 * n + len(orient), len(x)))
    rigid = n_pose == 6
    rot = orientation(*pose[3:6]) if rigid else np.eye(3)
    turns = []
    if rigid:
        h = 1e-7
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            turns.append((orientation(*(pose[3:6] + e)) - orientation(*(pose[3:6] - e))) / (2 * h))
    for i, leg in enumerate(mechanism.legs):
        end, leg_rot, j_leg, j_turn = _leg_twist(leg, x[starts[i]:starts[i + 1]])
        a = np.array(mechanism.platform.attachments[i])
        rows = slice(3 * i, 3 * i + 3)
        eta[rows] = end - pose[:3] - rot @ a
        jac[rows, starts[i]:starts[i + 1]] = j_leg
        jac[rows, starts[-1]:starts[-1] + 3] = -np.eye(3)
        for k, d_rot in enumerate(turns):
            jac[rows, starts[-1] + 3 + k] = -d_rot @ a
        # (R_leg a)·(R b) = 0: the leg's turns move a, the platform's b
        rows_i = [3 * n + r for r, (j, _k) in enumerate(orient) if j == i]
        if not rows_i:
            continue
        for r, (a, b) in zip(rows_i, _row_axes(leg.joints[-1]), strict=True):
            u1, u2 = leg_rot @ np.array(a), rot @ np.array(b)
            eta[r] = u1 @ u2
            jac[r, starts[i]:starts[i + 1]] = np.cross(j_turn.T, u1) @ u2
            for k, d_rot in enumerate(turns):
                jac[r, starts[-1] + 3 + k] = u1 @ (d_rot @ np.array(b))
    return eta, jac


def _angle_columns(mechanism) -> np.ndarray:
    flags = []
    for leg in mechanism.legs:
        for joint in leg.joints[:-1]:
            flags += [joint.kind != "P"] * joint.coordinates
    flags += [name in ("roll", "pitch", "yaw") for name in mechanism.platform.full_pose_names]
    return np.array(flags, dtype=bool)


def _start(mechanism, rng: np.random.Generator, size: float) -> np.ndarray:
    """A random start near the zero configuration: small angles, prismatic joints mid-stroke or half the
    machine's size out, the platform where its attachment points best meet the legs' ends."""
    x = []
    for leg in mechanism.legs:
        for k, joint in enumerate(leg.joints[:-1]):
            if joint.kind == "P":
                if k == leg.actuated and leg.stroke is not None:  # (the stroke is the leg's own actuator's)
                    lo, hi = leg.stroke
                    x.append(lo + (hi - lo) * rng.uniform(0.3, 0.7))
                else:
                    x.append(size * rng.uniform(0.3, 0.7))
            else:
                x += list(rng.uniform(-0.3, 0.3, joint.coordinates))
    x = np.array(x)
    _counts, starts, n_pose = _layout(mechanism)
    ends = [_leg_end(leg, x[starts[i]:starts[i + 1]])[0] for i, leg in enumerate(mechanism.legs)]
    centre = np.mean([e - np.array(a) for e, a in zip(ends, mechanism.platform.attachments, strict=True)], axis=0)
    pose = np.zeros(n_pose)
    pose[:3] = centre
    return np.concatenate([x, pose])


def project(mechanism, x: np.ndarray, size: float, rows=slice(None)) -> np.ndarray | None:
    """``x`` moved onto ``η = 0`` (its ``rows``) by Gauss–Newton's minimum-norm steps (halved while they do not
    reduce the residual); None when it does not get there."""
    scale = np.where(_angle_columns(mechanism), size, 1.0)  # columns in metres per unit of the coordinate
    value = np.linalg.norm(residual(mechanism, x)[rows])
    for _ in range(ITERATIONS):
        if value < 1e-11 * size:
            return x
        j = jacobian(mechanism, x)[rows] / scale
        step = np.linalg.lstsq(j, -residual(mechanism, x)[rows], rcond=None)[0] / scale
        for _ in range(12):
            trial = x + step
            trial_value = np.linalg.norm(residual(mechanism, trial)[rows])
            if trial_value < value:
                break
            step = step / 2
        else:
            return None
        x, value = trial, trial_value
    return x if value < 1e-11 * size else None


def _kept_rows(m, j: np.ndarray, rank: int) -> tuple[int, ...] | None:
    """The rows of ``η`` the model keeps (module docstring) from the scaled Jacobian ``j`` at a generic
    configuration of rank ``rank``: every point row, and the orientation rows of as many leg types as can be kept
    independent — else of as many single legs, the first in order; None where no choice makes the kept rows
    independent and of that rank."""
    n_point = 3 * len(m.legs)
    orient = all_orientation_rows(m)
    notations = list(dict.fromkeys(m.legs[i].notation for i, _k in orient))
    legs = list(dict.fromkeys(i for i, _k in orient))
    # whole types first (every leg of a type alike: one derivation serves them), then single legs
    choices = [*(({i for i in legs if m.legs[i].notation in chosen}) for size in range(len(notations), -1, -1)
                 for chosen in itertools.combinations(notations, size)),
               *(set(chosen) for size in range(len(legs), -1, -1) for chosen in itertools.combinations(legs, size))]
    for chosen in choices:
        rows = [*range(n_point), *(n_point + r for r, (i, _k) in enumerate(orient) if i in chosen)]
        if len(rows) == rank and _rank(j[rows]) == rank:
            return tuple(rows)
    return _kept_single_rows(m, j, rank)


def _kept_single_rows(m, j: np.ndarray, rank: int) -> tuple[int, ...] | None:
    """Where no choice of whole legs' rows is independent (a leg ending in a revolute joint whose two rows the
    others half repeat: a 3-CRR's), single rows: each leg keeps some of its rows (:func:`kept_leg_rows`), the
    choices of the fewest kinds of leg first (a kind, its notation and which rows it keeps, is one derivation),
    then in order. None where no choice is independent and of rank ``rank``."""
    n_point = 3 * len(m.legs)
    orient = all_orientation_rows(m)
    legs = list(dict.fromkeys(i for i, _k in orient))
    counts = [PLATFORM_JOINT_ROWS[m.legs[i].joints[-1].kind] for i in legs]
    options = [[subset for size in range(count, -1, -1) for subset in itertools.combinations(range(count), size)]
               for count in counts]
    wanted = rank - n_point
    choices = [c for c in itertools.product(*options) if sum(map(len, c)) == wanted]
    choices.sort(key=lambda c: len({(m.legs[i].notation, s) for i, s in zip(legs, c, strict=True)}))
    for choice in choices:
        chosen = {(i, k) for i, subset in zip(legs, choice, strict=True) for k in subset}
        rows = [*range(n_point), *(n_point + r for r, row in enumerate(orient) if row in chosen)]
        if _rank(j[rows]) == rank:
            return tuple(rows)
    return None


def _nearby(m, x: np.ndarray, rng: np.random.Generator, size: float, count: int, rows=slice(None)) -> list:
    """Up to ``count`` configurations near ``x``: random nudges (0.05 rad, 5 % of the machine's size) projected
    onto ``η = 0`` (its ``rows``, :func:`project`), from at most :data:`STARTS` tries."""
    scale = np.where(_angle_columns(m), 1.0, size)
    found = []
    for _ in range(STARTS):
        if len(found) == count:
            break
        nudged = project(m, x + rng.normal(0.0, 0.05, x.shape) * scale, size, rows)
        if nudged is not None:
            found.append(nudged)
    return found


def check_kept_rows(mechanism, result: Mobility, seed: int = 0) -> None:
    """The rows the model sets aside (module docstring) vanish at generic configurations of the kept ones (the
    configurations near ``result``'s that Gauss–Newton reaches on the kept rows alone): else the kept rows
    describe another machine, refused naming a leg whose rows fail."""
    m = mechanism
    rows = list(result.kept)
    aside = [r for r in range(result.constraints) if r not in rows]
    if not aside:
        return
    rng = np.random.default_rng(seed + 2)
    size = _size(m)
    orient = all_orientation_rows(m)
    n_point = 3 * len(m.legs)
    # configurations of the kept rows alone (result's own closes every row)
    checked = _nearby(m, result.configuration, rng, size, SAMPLES, rows)
    if not checked:
        raise InvalidParameterError(f"{m.name}: no configuration of its kept loop closures was found near its "
                                    f"generic one ({STARTS} tries): the rows it sets aside cannot be checked")
    for x in checked:
        miss = np.abs(residual(m, x)[aside])
        if miss.max() > 1e-9:
            leg = orient[aside[int(np.argmax(miss))] - n_point][0]
            raise InvalidParameterError(
                f"{m.name}: leg {leg + 1} ({m.legs[leg].notation}): its platform joint's orientation rows, dependent "
                "on the other loop closures at a generic configuration, do not hold where the others do (missed by "
                f"{miss.max():.3g} rad): the machine's closures have no independent set pkmlab can keep")


def _rank(matrix: np.ndarray) -> int:
    if matrix.size == 0:
        return 0
    sv = np.linalg.svd(matrix, compute_uv=False)
    return int(np.sum(sv > RANK_TOL * max(sv[0], 1e-300)))


def mobility(mechanism, *, check: bool = True, seed: int = 0) -> Mobility:
    """The computed mobility of a spatial ``mechanism`` (module docstring), refused when ``check`` and it is not
    the description's.

    Raises
    ------
    InvalidParameterError
        A translating platform on legs that cannot hold its orientation (:func:`check_parallelograms`); no
        configuration could be found (the legs cannot meet the platform near their zero configuration); or,
        with ``check``, the mobility is not the number of actuators, the constraints are dependent with no
        independent set to keep (or the rows set aside do not hold), the locked actuators leave a motion, or the
        controlled coordinates do not determine the configuration.
    """
    if check and mechanism.platform.kind == "translating":
        check_parallelograms(mechanism)
    result = _computed(mechanism, seed)
    if check:
        _check(mechanism, result)
        check_kept_rows(mechanism, result, seed)
        if mechanism.platform.kind == "translating" and any(leg.joints[-1].kind == "U" for leg in mechanism.legs):
            check_platform_joints(mechanism, result, seed)
    return result


@functools.lru_cache(maxsize=64)
def _computed(m, seed: int) -> Mobility:
    """:func:`mobility` without its checks, once per description: loading a machine computes it, and its home
    configuration (:mod:`pkmlab.model.parasitic`) is the one found here."""
    rng = np.random.default_rng(seed)
    size = _size(m)
    _counts, starts, _n_pose = _layout(m)
    found = []
    for _ in range(STARTS):
        x = project(m, _start(m, rng, size), size)
        if x is not None:
            found.append(x)
            break
    if not found:
        raise InvalidParameterError(f"{m.name}: its legs cannot be joined to the platform near their zero "
                                    "configuration (no configuration found from "
                                    f"{STARTS} starts): check the legs' lengths, bases and attachment points")
    angles = _angle_columns(m)
    while len(found) < SAMPLES:  # other generic configurations, near the first
        nudge = rng.normal(0.0, 0.05, found[0].shape) * np.where(angles, 1.0, size)
        x = project(m, found[0] + nudge, size)
        found.append(x if x is not None else found[0])
    scale = np.where(angles, 1.0 / size, 1.0)
    n_coordinates = len(found[0])
    actuated = [starts[i] + sum(jt.coordinates for jt in leg.joints[:k]) for i, leg in enumerate(m.legs)
                for k in leg.actuated_joints]
    pose_names = m.platform.full_pose_names
    controlled = [starts[-1] + pose_names.index(c) for c in m.platform.pose_names]

    rows = [leg_rows(m, i) for i in range(len(m.legs))]

    def ranks_at(j):
        shares = tuple(len(rows[i]) - _rank(j[rows[i], starts[i]:starts[i + 1]]) for i in range(len(m.legs)))
        return (_rank(j), _rank(np.delete(j, actuated, axis=1)), _rank(np.delete(j, controlled, axis=1)), shares)

    # every rank can only drop at special configurations: each is the largest over the samples (one sample may
    # be special in one way only, e.g. a machine whose legs the projection makes parallel)
    samples = [ranks_at(jacobian(m, x) * scale) for x in found]
    rank, actuated_rank, controlled_rank = (max(r[k] for r in samples) for k in range(3))
    shares = tuple(min(r[3][i] for r in samples) for i in range(len(m.legs)))
    best = int(np.argmax([sum(r[:3]) for r in samples]))
    x = found[best]
    x.setflags(write=False)  # shared by every caller of the cached result
    # the rows kept, chosen at a sample of the whole rank
    kept = _kept_rows(m, jacobian(m, next(y for y, r in zip(found, samples, strict=True) if r[0] == rank)) * scale,
                      rank)
    return Mobility(n_coordinates - rank, rank, n_coordinates, sum(map(len, rows)), shares, x, actuated_rank,
                    controlled_rank, kept)


def check_parallelograms(mechanism) -> None:
    """A translating platform keeps its orientation only if every leg's forearm is a parallelogram, a body between
    a universal joint and the spherical joint (:mod:`pkmlab.description.spatial`); a leg of another kind leaves
    the platform free to turn, which the refusal measures: the mobility of the same legs on a rigid platform."""
    from .spatial import POSE_NAMES, SpatialMechanism, SpatialPlatform

    m = mechanism
    for i, leg in enumerate(m.legs):
        if len(leg.joints) >= 2 and leg.joints[-2].kind == "U" and not leg.joints[-2].actuated:
            continue
        if leg.joints[-1].kind == "U":  # held by its platform joint, or refused by check_platform_joints
            continue
        p = m.platform
        free = SpatialMechanism(m.name, m.legs, SpatialPlatform("rigid", p.attachments, p.mass, p.com, p.inertia,
                                                                controlled=POSE_NAMES["rigid"][:len(m.legs)]),
                                m.gravity)
        computed = mobility(free, check=False)
        raise InvalidParameterError(
            f"leg {i + 1} ({leg.notation}) cannot hold a translating platform's orientation: only a parallelogram "
            "forearm (a leg ending in a universal joint, its body and the spherical joint, like the Delta's R*US) "
            f"does. On these legs the platform's computed mobility is {computed.mobility} ({computed.summary}), "
            f"not {len(p.pose_names)}: describe it as a rigid platform")


_TSAI = ("Tsai's 3-UPU has each leg's two inner axes parallel, and its base joint's first axis parallel to its "
         "platform joint's second")


def orientation_free_closures(mechanism, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """The loop closures of a translating platform on legs some of which end in a universal joint, with the
    platform's orientation freed, at the configuration ``x`` (the legs' joint coordinates leg by leg, then the
    position): their Jacobian, whose columns are the legs' coordinates, the platform joints' two angles per
    such leg (:func:`~pkmlab.description.spatial.platform_joint_angles` at ``x``), the position and the
    platform's angular velocity (world frame), and whose rows are each leg's 3 position closures, then 3
    orientation closures (the angular velocity of the leg's last body turned by its platform joint, less the
    platform's) after each leg that ends in a U; which columns are angles; and each such leg's miss (how far
    its joint is from turning the leg's last body onto the level platform)."""
    from .spatial import axis_rotation, platform_joint_angles

    m = mechanism
    _counts, starts, _n_pose = _layout(m)
    ends = [i for i, leg in enumerate(m.legs) if leg.joints[-1].kind == "U"]
    n_joint = starts[-1] + 2 * len(ends)
    rows, misses = [], []
    for i, leg in enumerate(m.legs):
        _point, rot, linear, angular = _leg_twist(leg, x[starts[i]:starts[i + 1]])
        a = np.array(m.platform.attachments[i])
        position = np.zeros((3, n_joint + 6))
        position[:, starts[i]:starts[i + 1]] = linear
        position[:, n_joint:n_joint + 3] = -np.eye(3)
        position[:, n_joint + 3:] = np.cross(a, np.eye(3)).T  # column k: d(-R a)/dω_k = a × e_k
        rows.append(position)
        if i not in ends:
            continue
        q1, _q2, miss = platform_joint_angles(leg, rot)
        misses.append(miss)
        a1, a2 = (np.array(v) for v in leg.joints[-1].axes)
        turn = np.zeros((3, n_joint + 6))
        turn[:, starts[i]:starts[i + 1]] = angular
        k = starts[-1] + 2 * ends.index(i)
        turn[:, k] = rot @ a1
        turn[:, k + 1] = rot @ axis_rotation(a1, q1) @ a2
        turn[:, n_joint + 3:] = -np.eye(3)
        rows.append(turn)
    angles = np.concatenate([_angle_columns(m)[:starts[-1]], np.ones(2 * len(ends), dtype=bool),
                             np.zeros(3, dtype=bool), np.ones(3, dtype=bool)])
    return np.vstack(rows), angles, misses


_TSAI = ("Tsai's 3-UPU has each leg's two inner axes parallel, and its base joint's first axis parallel to its "
         "platform joint's second")


def check_platform_joints(mechanism, result: Mobility, seed: int = 0) -> None:
    """A translating platform on legs that end in universal joints (a 3-UPU) stays level only if, at every
    configuration of its legs, each such joint can turn its leg's last body onto the platform, and the joints
    together leave the platform no turn: with its orientation freed (:func:`orientation_free_closures`), the
    mobility must stay the number of its actuators. Both are measured at generic configurations of the legs
    (those of ``result`` and two near it); each refusal names the leg or the computed mobility.

    Tsai's 3-UPU meets both when each leg's two inner axes are parallel, and its base joint's first axis is
    parallel to its platform joint's second."""
    m = mechanism
    rng = np.random.default_rng(seed + 1)
    size = _size(m)
    found = [np.array(result.configuration), *_nearby(m, result.configuration, rng, size, SAMPLES - 1)]
    ends = [i for i, leg in enumerate(m.legs) if leg.joints[-1].kind == "U"]
    dof = len(m.platform.pose_names)
    for x in found:
        j, angle_columns, misses = orientation_free_closures(m, x)
        for i, miss in zip(ends, misses, strict=True):
            if miss > 1e-8:
                leg = m.legs[i]
                raise InvalidParameterError(
                    f"leg {i + 1} ({leg.notation}): its universal joint at the platform cannot turn the leg's last "
                    f"body onto the platform's fixed orientation as the leg moves (missed by {miss:.3g} rad at a "
                    f"generic configuration): its axes do not keep a translating platform level ({_TSAI})")
        # angle columns weighed as lever arms of the machine's size, every row of unit length (the orientation
        # closures are in radians, the position closures in metres): a rank whose tolerance means the same in both
        j = j * np.where(angle_columns, 1.0 / size, 1.0)
        free = j.shape[1] - _rank(j / np.maximum(np.linalg.norm(j, axis=1), 1e-300)[:, None])
        if free != dof:
            raise InvalidParameterError(
                f"{m.name}: its universal joints at the platform do not hold it level: with its orientation free the "
                f"computed mobility is {free}, not {dof} (the platform can turn as it moves; {_TSAI})")


def _check(m, r: Mobility) -> None:
    names = m.platform.pose_names
    dof = len(names)
    if r.mobility != dof:
        kind = "more" if r.mobility > dof else "fewer"
        raise InvalidParameterError(
            f"{m.name}: its computed mobility is {r.mobility}, not the {dof} of its controlled pose "
            f"({', '.join(names)}) and actuators — {kind} freedoms than it controls ({r.summary})")
    if r.kept is None:
        raise InvalidParameterError(
            f"{m.name}: its {r.constraints} loop-closure equations are dependent (rank {r.rank}) and no choice of "
            "its legs' orientation rows leaves an independent set with every point row (its point rows are "
            "dependent): an overconstrained machine pkmlab does not model yet")
    locked = r.coordinates - len(m.actuators) - r.actuated_rank  # freedoms left with every actuator locked
    if locked > 0:
        raise InvalidParameterError(
            f"{m.name}: with its actuators locked it can still move ({locked} freedom(s)): an "
            "actuated joint cannot move the platform (check which joint of each leg is starred)")
    if r.controlled_rank < r.rank:
        raise InvalidParameterError(
            f"{m.name}: its controlled coordinates ({', '.join(names)}) do not determine its pose: it can move "
            f"with them held ({r.rank - r.controlled_rank} freedom(s)); control others among "
            f"{', '.join(m.platform.full_pose_names)}")
