"""Inverse kinematics of any spatial leg without a closed form, by homotopy continuation: every real solution
of the leg's serial chain for its platform joint's centre, with reproducible working-mode labels.

**The system.** The leg's joints before its platform joint — revolute (one angle), universal (two) or
prismatic (one slide) — carry its platform joint's centre to ``p(q)``; given the centre ``v``, the
unknowns are each angle's cosine and sine (with ``c² + s² = 1``) and each slide, and the equations
``p(q) − v = 0``. A leg of three joint coordinates (``R*RRS``, ``RR*RS``, ``P*RRS``…) has finitely many
solutions (at most four for three revolute joints); a leg of two (an ``R*RS`` whose hinges are skew…)
reaches only a surface, where its three equations have a solution: two random combinations of them make
the system square, and the third is checked at each solution found.

**The method** is the one of the machines' forward kinematics (:mod:`pkmlab.algorithms.general_fk`): the
solutions at a generic complex centre are found once per leg by monodromy
(:func:`pkmlab.numerics.homotopy.generic_instance`) and kept in the cache folder; every solve is a parameter
homotopy from them to the real centres asked for — all points of a batch tracked at once, on every core —
its real endpoints polished by Newton's method, and a point where a path failed solved again along a
detour. Every real solution is found: each isolated solution at a centre ends a path from the generic ones
(the coefficient-parameter theorem).

**Working modes.** A leg's *branches* are its solutions at a generic centre: one, two, or up to four. They
are told apart by signs, as the closed forms' branches are:

* ``σ₁`` — the sign of ``det ∂p/∂q`` (the leg's coordinates in joint order, axes as described): which side
  of the leg's own (serial) singularities the solution lies on. A centre reached at all is reached by as
  many solutions of each sign (two branches: one each).
* ``σ₂`` (a leg of four branches) — of the two solutions of one ``σ₁``, ``+1`` the one with the larger
  actuator value (angles in ``(−π, π]``).

A leg of two coordinates has no such determinant: its branches are ordered by their actuator value, ``+1``
the larger (four branches: ``σ₁`` and ``σ₂`` the two bits of the rank). Unlike ``σ₁``, the order by actuator
value can swap between poses without a singularity (two branches with the same actuator value): a trajectory
takes the working mode of its first pose and follows that branch by continuity (``follow`` of
:func:`general_inverse_kinematics_batch`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidParameterError
from ..numerics import homotopy
from ..numerics.angles import wrapped_angle
from .leg_types import Solved, mark_outside_stroke

#: Seed of the generic instance and of the random combinations (the same leg gets the same labels everywhere).
SEED = 20261205

#: Largest imaginary part (relative to the solution's size) of an endpoint taken as real.
IMAG_TOL = 1e-7

#: Largest distance (relative to the leg's size) of a solution's centre from the point asked for.
RESIDUAL_TOL = 1e-8

#: Most branches pkmlab labels (two signs).
MAX_BRANCHES = 4


def _name(leg, number: int) -> str:
    return f"leg {number + 1} ({leg.notation})"


def _rotation(sp, axis, c, s):
    k = sp.Matrix([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = sp.Matrix(axis)
    return c * sp.eye(3) + s * k + (1 - c) * (a * a.T)


def symbolic_chain(leg, values: dict, joints, start):
    """Walk ``leg``'s ``joints`` (indices) from the point ``start`` with their ``values`` (per joint: the
    ``(cos, sin)`` pair of each angle, or the slide): the point reached and the frame, as SymPy matrices (the
    chain of :func:`~pkmlab.description.spatial.leg_frames` with an angle's cosine and sine for the angle)."""
    import sympy as sp

    point, rot = sp.Matrix(start), sp.eye(3)
    for k in joints:
        joint, body = leg.joints[k], leg.bodies[k]
        if joint.kind == "P":
            point = point + values[k][0] * (rot * sp.Matrix(joint.axes[0]))
        else:
            for axis, (c, s) in zip(joint.axes, values[k], strict=True):
                rot = rot * _rotation(sp, axis, c, s)
        point = point + rot * sp.Matrix(body.tip)
    return point, rot


def _coordinates(leg) -> int:
    return sum(j.coordinates for j in leg.joints[:-1])


def _size(leg) -> float:
    return max(float(np.linalg.norm(leg.base)) + sum(float(np.linalg.norm(b.tip)) for b in leg.bodies), 1e-3)


def leg_points(leg, coordinates: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The platform joint's centre (K, 3) at the leg's joint ``coordinates`` (K, m), real or complex, and its
    Jacobian ``∂p/∂q`` (K, 3, m): a turn about the world axis ``w`` at ``o`` moves the centre by
    ``w × (p − o)``, a slide along ``u`` by ``u`` (the chain of :func:`~pkmlab.description.spatial.leg_frames`,
    many configurations at once)."""
    q = np.asarray(coordinates)
    K = q.shape[0]
    dtype = np.result_type(q.dtype, float)
    point = np.broadcast_to(np.asarray(leg.base, dtype=dtype), (K, 3)).copy()
    rot = np.broadcast_to(np.eye(3, dtype=dtype), (K, 3, 3)).copy()
    moves, column = [], 0  # (kind, world axis (K, 3), origin (K, 3))
    for joint, body in zip(leg.joints[:-1], leg.bodies, strict=True):
        origin = point
        if joint.kind == "P":
            axis = rot @ np.asarray(joint.axes[0], dtype=float)
            origin = point + q[:, column, None] * axis
            moves.append(("P", axis, origin))
            column += 1
        else:
            for a in joint.axes:
                a = np.asarray(a, dtype=float)
                moves.append(("R", rot @ a, point))
                k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
                c, s = np.cos(q[:, column])[:, None, None], np.sin(q[:, column])[:, None, None]
                rot = rot @ (np.eye(3) + s * k + (1 - c) * (k @ k))
                column += 1
        point = origin + rot @ np.asarray(body.tip, dtype=float)
    jac = np.stack([axis if kind == "P" else np.cross(axis, point - o) for kind, axis, o in moves], axis=-1)
    return point, jac


@dataclass(frozen=True)
class GeneralLeg:
    """What pkmlab keeps of a (canonical) leg it solves by the general method: its family of systems (a
    straight-line program of ``(z, v, b)``: the unknowns, the centre, the offsets), the names of the unknowns,
    the solutions at the generic parameters ``p_generic``, the leg's branches (its solutions at a generic centre
    it reaches) and the monodromy loops run."""

    family: homotopy.Family
    names: tuple[str, ...]
    solutions: np.ndarray
    p_generic: np.ndarray
    branches: int
    loops: int

    @property
    def signs(self) -> int:
        """How many signs tell the branches apart: 0 (one branch), 1 (two), 2 (three or four)."""
        return 0 if self.branches <= 1 else 1 if self.branches == 2 else 2


def _key(leg) -> str:
    """A digest of what the leg's system depends on (its joints, axes and bodies' tips) and :data:`SEED`."""
    import hashlib

    shape = [(j.kind, j.axes) for j in leg.joints[:-1]], [b.tip for b in leg.bodies], leg.base
    return hashlib.sha1(f"{SEED}\n{shape!r}".encode()).hexdigest()[:20]


def _combination(m: int) -> np.ndarray | None:
    """The rows that square the system of a leg of ``m`` coordinates: None for three, two random complex rows of
    unit norm for two."""
    if m == 3:
        return None
    rng = np.random.default_rng(SEED)
    rows = rng.standard_normal((2, 3)) + 1j * rng.standard_normal((2, 3))
    return rows / np.linalg.norm(rows, axis=1)[:, None]


def joint_unknowns(joint, suffix: str):
    """A joint's unknowns in a polynomial system, named with ``suffix``: a slide ``l{suffix}``, or each angle as
    its cosine and sine ``c{suffix}a``, ``s{suffix}a`` (``b`` for a universal joint's second) with
    ``c² + s² − 1 = 0``. Returns ``(values, unknowns, equations)``: ``values`` as :func:`symbolic_chain` takes
    them."""
    import sympy as sp

    if joint.kind == "P":
        v = sp.Symbol(f"l{suffix}")
        return (v,), [v], []
    pairs, unknowns, equations = [], [], []
    for a in range(joint.coordinates):
        c, s = sp.symbols(f"c{suffix}{'ab'[a]} s{suffix}{'ab'[a]}")
        unknowns += [c, s]
        equations.append(c * c + s * s - 1)
        pairs.append((c, s))
    return tuple(pairs), unknowns, equations


def _system(leg):
    """``(equations, unknowns, centre symbols)`` of the leg's system (module docstring), SymPy."""
    import sympy as sp

    values, unknowns, equations = {}, [], []
    for k, joint in enumerate(leg.joints[:-1]):
        values[k], more, circles = joint_unknowns(joint, f"{k + 1}")
        unknowns += more
        equations += circles
    centre = sp.Matrix(sp.symbols("vx vy vz"))
    end, _rot = symbolic_chain(leg, values, range(len(leg.joints) - 1), leg.base)
    position = end - centre
    rows = _combination(_coordinates(leg))
    if rows is not None:
        position = sp.Matrix(rows.tolist()) * position
    return [*position, *equations], unknowns, list(centre)


def _to_coordinates(leg, names, z: np.ndarray) -> np.ndarray:
    """The leg's joint coordinates (K, m) of solutions ``z`` (K, n): each angle from its cosine and sine (complex
    for complex ``z``)."""
    index = {name: k for k, name in enumerate(names)}
    columns = []
    for k, joint in enumerate(leg.joints[:-1]):
        if joint.kind == "P":
            columns.append(z[:, index[f"l{k + 1}"]])
        else:
            for ab in "ab"[:joint.coordinates]:
                c, s = z[:, index[f"c{k + 1}{ab}"]], z[:, index[f"s{k + 1}{ab}"]]
                # a complex solution's angle is complex: c + i s = e^{iφ}
                columns.append(np.arctan2(s, c) if np.isrealobj(z) else -1j * np.log(c + 1j * s))
    return np.column_stack(columns)


def check_leg(leg, number: int) -> None:
    """Refuse, naming the leg, one the general method cannot take: fewer than two or more than three joint
    coordinates before its platform joint (a leg of more has a motion of its own with its platform held; the
    computed mobility refuses it first)."""
    m = _coordinates(leg)
    if m not in (2, 3):
        raise InvalidParameterError(f"{_name(leg, number)}: pkmlab solves the inverse kinematics of a leg of two or "
                                    f"three joint coordinates before its platform joint, not {m}")


@functools.lru_cache(maxsize=64)
def canonical_frame(leg) -> tuple[object, np.ndarray]:
    """``leg`` seen from its own frame — its base at the origin, its first axis along ``x``, its first vector not
    along that axis (a tip or an axis, in the chain's order) in the ``xy`` plane — and that frame ``F`` (3, 3),
    columns the frame's axes in the world: a leg's joint coordinates at a centre ``v`` are the canonical leg's at
    ``Fᵀ (v − base)``. The legs of a symmetric machine, turned copies of one another, have one canonical leg and
    share its generic instance. Its numbers are rounded to 1e-9 (a turned copy's are equal to round-off, or to the
    digits a file gives); the solutions are polished on the leg itself (:func:`real_solutions`)."""
    import dataclasses

    vectors = [np.asarray(v, dtype=float) for joint, body in zip(leg.joints[:-1], leg.bodies, strict=True)
               for v in (*joint.axes, body.tip)]
    e1 = vectors[0] / np.linalg.norm(vectors[0])
    across = [v - (v @ e1) * e1 for v in vectors[1:]]
    e2 = next((v / np.linalg.norm(v) for v in across if np.linalg.norm(v) > 1e-9), None)
    if e2 is None:  # every vector along the first axis: any plane will do
        e2 = np.cross(e1, [1.0, 0.0, 0.0] if abs(e1[0]) < 0.9 else [0.0, 1.0, 0.0])
        e2 /= np.linalg.norm(e2)
    frame = np.column_stack([e1, e2, np.cross(e1, e2)])

    def local(v):
        return tuple(float(c) + 0.0 for c in np.round(frame.T @ np.asarray(v, dtype=float), 9))

    joints = tuple(dataclasses.replace(j, axes=tuple(local(a) for a in j.axes)) for j in leg.joints)
    bodies = tuple(dataclasses.replace(b, tip=local(b.tip), mass=1.0, com=(0.0, 0.0, 0.0),
                                       inertia=((0.0,) * 3,) * 3) for b in leg.bodies)
    return dataclasses.replace(leg, base=(0.0, 0.0, 0.0), joints=joints, bodies=bodies, stroke=None), frame


def general_leg(leg) -> GeneralLeg:
    """The :class:`GeneralLeg` of ``leg``'s canonical leg (:func:`canonical_frame`): its family built and its
    generic instance solved (by monodromy, once per installation: kept in the cache folder)."""
    check_leg(leg, 0)
    return _general_leg(canonical_frame(leg)[0])


@functools.lru_cache(maxsize=64)
def _general_leg(leg) -> GeneralLeg:
    key = _key(leg)
    equations, unknowns, centre = _system(leg)
    n = len(unknowns)
    family = homotopy.offset_family(f"general_leg-{key}", equations, unknowns, centre)
    names = tuple(str(u) for u in unknowns)

    def solve():
        rng = np.random.default_rng(SEED)
        solutions, p_generic, loops = homotopy.generic_instance(family, n, 3, rng)
        return {"solutions": solutions, "parameters": p_generic, "loops": np.array(loops),
                "branches": np.array(_branches(leg, family, names, solutions, p_generic, rng))}

    data = homotopy.cached_arrays(
        f"legs/{key}", solve, f"a {leg.notation} leg: solving its inverse kinematics at a generic point, once "
        "(monodromy, seconds; kept in the cache)")
    branches = int(data["branches"])
    return GeneralLeg(family, names, data["solutions"], data["parameters"], branches, int(data["loops"]))


def _branches(leg, family, names, solutions, p_generic, rng) -> int:
    """How many solutions the leg has at a generic centre it reaches: the generic instance's count for a leg of
    three coordinates; for one of two, those of the squared system at the centre of a random complex
    configuration that put the centre there (the others solve only the two combinations)."""
    m = _coordinates(leg)
    if m == 3:
        return len(solutions)
    q = rng.standard_normal((1, m)) + 1j * rng.standard_normal((1, m))
    centre = leg_points(leg, q)[0]
    target = np.concatenate([centre[0], np.zeros(family.n)])
    ends = homotopy.parameter_homotopy(family, solutions, p_generic, target)
    z = homotopy.distinct(ends.x[ends.regular], family.scale)
    return int(np.sum(_residual(leg, names, z, centre) <= RESIDUAL_TOL))


def _residual(leg, names, z: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """How far (relative to the leg's size) the centre of each solution ``z`` (K, n) is from ``centres``."""
    coordinates = _to_coordinates(leg, names, z)
    return np.linalg.norm(leg_points(leg, coordinates)[0] - centres, axis=1) / _size(leg)


#: Solves along a detour for the points of a batch where a path failed.
DETOURS = 2


def real_solutions(leg, points) -> list[np.ndarray]:
    """Every real solution of the leg at each centre of ``points`` (K, 3): a list of K arrays (k, m) of joint
    coordinates in joint order (an angle in ``(−π, π]``), none repeated, each polished by Newton's method on
    the leg's own chain. The last batch's are kept (every working mode of one pose asks for the same points)."""
    return [q for q, _labels in _labelled_solutions(leg, points)]


def _labelled_solutions(leg, points) -> list[tuple[np.ndarray, list[tuple[int, ...]]]]:
    """:func:`real_solutions` and their :func:`mode_labels`, at each centre."""
    points = np.ascontiguousarray(points, dtype=float).reshape(-1, 3)
    return _solved(leg, points.tobytes())


@functools.lru_cache(maxsize=8)
def _solved(leg, data: bytes):
    world = np.frombuffer(data).reshape(-1, 3)
    canonical, frame = canonical_frame(leg)
    found = _canonical_solutions(canonical, (world - np.asarray(leg.base)) @ frame)
    counts = np.array([len(q) for q in found])
    # every point's solutions at once: polished on the leg itself, then their determinants
    every = _polish(leg, np.concatenate(found), np.repeat(world, counts, axis=0))
    det = np.linalg.det(leg_points(leg, every)[1]) if _coordinates(leg) == 3 and len(every) else np.zeros(len(every))
    ends = np.cumsum(counts)
    return [(every[e - c:e], mode_labels(leg, every[e - c:e], det[e - c:e])) for c, e in zip(counts, ends, strict=True)]


def _polish(leg, q: np.ndarray, centre: np.ndarray, iterations: int = 2) -> np.ndarray:
    """``q`` (k, m) after Newton's (Gauss–Newton's for two coordinates) corrections on the leg's chain towards
    ``centre`` (3,) or (k, 3): the canonical leg's solutions on the leg itself."""
    for _ in range(iterations if len(q) else 0):
        point, jac = leg_points(leg, q)
        q = q - (np.linalg.pinv(jac) @ (point - centre)[..., None])[..., 0]
    return _wrap(leg, q)


def _wrap(leg, q: np.ndarray) -> np.ndarray:
    """The angles of ``q`` (k, m) in ``(−π, π]``, slides as they are."""
    out = q.copy()
    column = 0
    for joint in leg.joints[:-1]:
        for _ in range(joint.coordinates):
            if joint.kind != "P":
                out[:, column] = wrapped_angle(q[:, column])
            column += 1
    return out


def _canonical_solutions(leg, points: np.ndarray) -> list[np.ndarray]:
    g = _general_leg(leg)
    K, N, n = len(points), len(g.solutions), g.family.n
    targets = np.concatenate([points, np.zeros((K, n))], axis=1)
    found: list[list[np.ndarray]] = [[] for _ in range(K)]
    rows = np.arange(K)
    rng = np.random.default_rng(SEED + 1)
    for attempt in range(1 + DETOURS):
        if not len(rows):
            break
        start, p0 = np.tile(g.solutions, (len(rows), 1)), g.p_generic
        if attempt:  # a detour: the generic solutions carried to other generic parameters first
            via = g.p_generic + (rng.standard_normal(len(g.p_generic)) + 1j * rng.standard_normal(len(g.p_generic)))
            middle = homotopy.parameter_homotopy(g.family, g.solutions, g.p_generic, via)
            if not middle.regular.all():
                continue
            start, p0 = np.tile(middle.x, (len(rows), 1)), via
        ends = homotopy.parameter_homotopy(g.family, start, p0, np.repeat(targets[rows], N, axis=0))
        ok = (ends.reached & (ends.regular | ends.diverged)).reshape(len(rows), N)
        owner = np.repeat(rows, N)  # the point of each path
        size = np.maximum(np.abs(ends.x).max(axis=1), 1.0)
        real = ok.ravel() & ~ends.diverged & (np.abs(ends.x.imag).max(axis=1) <= IMAG_TOL * size)
        z, owner = ends.x[real].real, owner[real]
        if len(z):
            keep = _residual(leg, g.names, z, points[owner]) <= RESIDUAL_TOL
            for k, q in zip(owner[keep], _to_coordinates(leg, g.names, z[keep]), strict=True):
                found[k].append(q)
        rows = rows[~ok.all(axis=1)]
    return [_distinct(np.array(f).reshape(-1, _coordinates(leg))) for f in found]


def _distinct(q: np.ndarray) -> np.ndarray:
    out: list[np.ndarray] = []
    for v in q:
        d = wrapped_angle(np.array(out) - v) if out else None  # angles compared modulo 2π
        if d is None or np.abs(d).max(axis=1).min() > 1e-7:
            out.append(v)
    return np.array(out).reshape(-1, q.shape[1])


def working_modes(leg) -> tuple:
    """The leg's working modes: ``()`` for one branch, ``(1, -1)`` for two, the four pairs
    ``((1, 1), (1, -1), (-1, 1), (-1, -1))`` for three or four (module docstring)."""
    g = general_leg(leg)
    if g.branches > MAX_BRANCHES:
        raise InvalidParameterError(f"a {leg.notation} leg has {g.branches} inverse-kinematic branches; pkmlab "
                                    f"labels at most {MAX_BRANCHES}")
    return () if g.signs == 0 else (1, -1) if g.signs == 1 else ((1, 1), (1, -1), (-1, 1), (-1, -1))


def mode_labels(leg, q: np.ndarray, det: np.ndarray | None = None) -> list[tuple[int, ...]]:
    """The working mode of each of the leg's real solutions ``q`` (k, m) at one centre (module docstring);
    ``det`` (k,), their ``det ∂p/∂q``, is computed unless given."""
    signs = general_leg(leg).signs
    if signs == 0 or not len(q):
        return [() for _ in q]
    column = sum(j.coordinates for j in leg.joints[:leg.actuated])
    actuator = q[:, column]
    if _coordinates(leg) == 2:
        rank = np.argsort(np.argsort(-actuator, kind="stable"), kind="stable")
        if signs == 1:
            return [(1 if r == 0 else -1,) for r in rank]
        return [(1 if r < 2 else -1, 1 if r % 2 == 0 else -1) for r in rank]
    det = np.linalg.det(leg_points(leg, q)[1]) if det is None else det
    first = np.where(det > 0, 1, -1)
    if signs == 1:
        return [(int(s),) for s in first]
    labels = []
    for k in range(len(q)):
        same = first == first[k]
        larger = np.sum(same & (actuator > actuator[k]))
        labels.append((int(first[k]), 1 if larger == 0 else -1))
    return labels


def general_inverse_kinematics_batch(leg, number: int, points: np.ndarray, sigma, follow: bool = False):
    """The leg's joint coordinates (K, m) in working mode ``sigma`` (an int for one sign, a pair for two) for its
    platform joint at ``points`` (K, 3), as the closed forms return them
    (:class:`~pkmlab.description.leg_types.Solved`: the rows no solution of that mode reaches flagged, with
    the reason).

    ``follow``: the points are a path, sampled finely; its branch is the mode's at its first point (and after a
    point the leg cannot reach), then at each point the solution nearest the one before — the branch followed
    by continuity, where a label by actuator value could swap without a singularity (module docstring)."""
    check_leg(leg, number)
    modes = working_modes(leg)
    wanted = () if not modes else (sigma,) if isinstance(sigma, int | np.integer) else tuple(sigma)
    if modes and wanted not in [m if isinstance(m, tuple) else (m,) for m in modes]:
        raise InvalidParameterError(f"{_name(leg, number)}: working mode {sigma} is none of its modes "
                                    f"{list(modes)}")
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    m = _coordinates(leg)
    out = np.full((len(points), m), np.nan)
    reached: list[list[tuple[int, ...]]] = []
    previous = None
    for k, (q, labels) in enumerate(_labelled_solutions(leg, points)):
        reached.append(labels)
        match = [i for i, label in enumerate(labels) if tuple(label) == wanted]
        if follow and previous is not None and len(q):
            out[k] = q[np.argmin(np.abs(_wrap(leg, q - previous)).max(axis=1))]
        elif match:
            out[k] = q[match[0]]
        previous = out[k] if np.isfinite(out[k]).all() else None
    bad = ~np.isfinite(out).all(axis=1)

    def why(k):
        where = ", ".join(f"{c:.4g}" for c in points[k])
        if not reached[k]:
            return f"{_name(leg, number)} cannot reach the point ({where})"
        modes_there = ", ".join("(" + ", ".join(f"{s:+d}" for s in label) + ")" for label in reached[k])
        return (f"{_name(leg, number)} reaches the point ({where}) in working modes {modes_there}, not in "
                f"({', '.join(f'{s:+d}' for s in wanted)})")

    column = sum(j.coordinates for j in leg.joints[:leg.actuated])
    bad, why = mark_outside_stroke(leg, number, out[:, column], bad, why)
    return Solved(out, bad, why)
