"""Symbolic derivation of a spatial mechanism's kinematics, generated as compiled kernels.

The spatial counterpart of :mod:`pkmlab.codegen.planar`, for a
:class:`~pkmlab.description.spatial.SpatialMechanism`, in the coordinates

    q = (actuator values, passive joint coordinates leg by leg, pose)

with the pose ``(x, y, z)`` of a translating platform or ``(x, y, z, roll, pitch, yaw)`` of a rigid one.
It derives, with SymPy:

* the loop-closure constraints ``η(q) = 0`` — for each leg, the centre of its platform joint (the
  end of its chain) minus its platform attachment point, x, y then z (3 per leg: a universal joint
  under a translating platform closes the loop at its centre too, its angles following from the
  leg's, :mod:`pkmlab.description.spatial`), then, after every leg's, each leg's orientation rows under a rigid
  platform (:mod:`pkmlab.description.mobility`; from row ``LEG_ETA[leg]`` on): a universal joint's one, its two
  axes perpendicular, a revolute joint's two, its axis in the leg's last body across the two directions
  ``across`` its axis in the platform (parameters, as the axes are). The rows an overconstrained machine sets
  aside are not generated: a spherical wrist's legs ending in revolute joints close at their points alone, a
  3-CRR's keep one of their two. Their Jacobian and the bias ``J̇ηq q̇`` (paper eqs. 14–17, 32);
* for every body (the legs' bodies, then the platform) the velocity of its mass centre (3 rows) and
  its angular velocity in its own frame ``ω`` (3 rows), both linear in ``q̇``: their Jacobian
  ``J_b = ∂(v, ω)/∂q̇`` and bias ``J̇_b q̇`` — with the 3×3 inertia tensors, everything the compiled
  core's actuator-space model (eq. 35 with gravity and the gyroscopic terms of spatial bodies) needs;
* the legs' lines of action (the line from each leg's last passive rotary joint to its spherical
  joint, a two-force member for the R*US and UP*S legs of the Delta and the Stewart–Gough
  platform), every joint's position (for drawing) and the structural non-zeros of ``J_b``.

Angular velocities follow the chain: through a revolute joint of axis ``a`` and angle ``q``,
``ω_next = Rot(a, q)ᵀ ω + a q̇`` in the next body's frame; a prismatic joint keeps ``ω``.

A leg's points are written in Horner's form, ``base + R1 (v1 + R2 (v2 + ...))``, each frame's vectors (a body's
tip, a prismatic joint's stroke along its axis) summed in that frame and turned once by Rodrigues' formula on the
vector (:func:`_turn`), never multiplied into rotation matrices: products of rotations about axes that are
parameters, and their derivatives, grow with every joint. Over the 15 spatial structures of the presets and the
catalogue, the products of matrices count 1.6 times the operations in the five per-sample kernels (the Delta's
constraint Jacobian 1,413 against 657 a call, its bias 2,691 against 1,305), for the same non-zeros and the same
values to round-off (1.7e-15 of their scale, every kernel at random configurations).

A leg's rows depend on its own coordinates, its own parameters and the platform's pose only, and legs of one
type (one notation) differ by their parameters alone. So each type of leg is derived once (:func:`derive_leg`),
and every kernel is a loop over the legs of each type, reading a leg's coordinates and parameters at its
offsets, then the platform's rows: code of one leg's size, whatever the number of legs. The Stewart platform's
kernels compile in 6 s instead of 29, and a new structure is derived in seconds.

Run ``python -m pkmlab.codegen.spatial`` to regenerate the shipped modules (``--check`` as
:mod:`pkmlab.codegen.planar`).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..description.mobility import PLATFORM_JOINT_ROWS, across, all_orientation_rows, kept_leg_rows, orientation_rows
from ..description.spatial import SpatialMechanism
from .planar import (
    GENERATED_DIR,
    Block,
    independent_columns,
    jacobian,
    jacobian_and_bias,
    module_header,
    regenerate,
    write_module,
)

_INERTIA = ("xx", "yy", "zz", "xy", "xz", "yz")


def structure(mechanism: SpatialMechanism) -> str:
    """``"RaUS_RaUS_RaUS_translating"`` for the Delta (``a`` marks the actuated joint); a platform of lower
    mobility adds its controlled coordinates (``"PaRS_PaRS_PaRS_rigid_z_roll_pitch"``), an overconstrained
    machine which of its legs' orientation rows are kept (``"..._rows_000"``: none of the Agile Eye's)."""
    name = "_".join(leg.notation.replace("*", "a") for leg in mechanism.legs) + "_" + mechanism.platform.kind
    name = name + "".join(f"_{c}" for c in mechanism.platform.pose_names) if mechanism.platform.parasitic_names \
        else name
    orient = all_orientation_rows(mechanism)
    kept = kept_leg_rows(mechanism)
    if sum(map(len, kept)) < len(orient):  # some rows set aside: say whose are kept (1: all, x or y: one) or not (0)
        ends = dict.fromkeys(i for i, _k in orient)
        name += "_rows_" + "".join(
            "0" if not kept[i] else "1" if len(kept[i]) == PLATFORM_JOINT_ROWS[mechanism.legs[i].joints[-1].kind]
            else "xy"[kept[i][0]] for i in ends)
    return name


def measures_lines(mechanism: SpatialMechanism) -> bool:
    """Whether the singularity measure is the determinant of the legs' lines of action: a platform on as many
    legs as its pose has coordinates, every leg a two-force member from its last passive rotary joint, a
    universal joint, to its spherical joint (the Delta, the Stewart–Gough platform, a 6-RUS or 6-PUS); else the
    scaled determinant of ``Jηφ`` (:func:`pkmlab.codegen.core.branch_following.passive_determinant`)."""
    if mechanism.platform.parasitic_names:
        return False
    for leg in mechanism.legs:
        rotary = [j for j in leg.joints[:-1] if j.kind != "P" and not j.actuated]
        if not rotary or rotary[-1].kind != "U":
            return False
    return not orientation_rows(mechanism)  # a universal joint at a rigid platform carries moments too


def _leg_coordinate_names(leg, tag: str) -> list[str]:
    """The names of a leg's passive coordinates (``q<tag>_<joint>``; a U joint's two are ``…a``, ``…b``)."""
    names = []
    for k, joint in enumerate(leg.joints[:-1]):  # the platform joint has no coordinate
        if not joint.actuated:
            names += [f"q{tag}_{k + 1}a", f"q{tag}_{k + 1}b"] if joint.kind == "U" else [f"q{tag}_{k + 1}"]
    return names


def coordinate_names(mechanism: SpatialMechanism) -> tuple[str, ...]:
    """``a1..an`` (actuators), ``q<leg>_<joint>`` (passive joints; a U joint's two are ``…a``, ``…b``), the pose."""
    names = [f"a{i + 1}" for i in range(len(mechanism.actuators))]
    for i, leg in enumerate(mechanism.legs):
        names += _leg_coordinate_names(leg, str(i + 1))
    return (*names, *mechanism.platform.q_pose_names)


def _leg_angles(leg) -> list[bool]:
    """Which of a leg's passive coordinates are angles."""
    return [joint.kind != "P" for joint in leg.joints[:-1] if not joint.actuated for _ in range(joint.coordinates)]


def _actuator_angles(leg) -> list[bool]:
    """Whether each of a leg's actuators is an angle (a revolute joint), base to platform."""
    return [leg.joints[k].kind == "R" for k in leg.actuated_joints]


def _local_actuators(leg) -> list[str]:
    """The names of a leg's actuators in its type's derivation: ``a`` (its own), then ``a2``, ``a3``… (a leg of
    several)."""
    return ["a" if k == 0 else f"a{k + 1}" for k in range(len(leg.actuated_joints))]


def coordinate_angles(mechanism: SpatialMechanism) -> tuple[bool, ...]:
    angles = [a for leg in mechanism.legs for a in _actuator_angles(leg)]
    for leg in mechanism.legs:
        angles += _leg_angles(leg)
    return (*angles, *(name in ("roll", "pitch", "yaw") for name in mechanism.platform.q_pose_names))


def _body_names(mechanism: SpatialMechanism) -> list[str]:
    return [f"body{i + 1}_{k + 1}" for i, leg in enumerate(mechanism.legs) for k in range(len(leg.bodies))]


def _leg_parameter_names(leg, tag: str, rows: tuple[int, ...] = ()) -> list[str]:
    """The names of a leg's parameters, in their order in ``P``: its base point, its joints' axes, its bodies',
    then, for a leg ending in a revolute joint some of whose orientation rows are kept (``rows``), the two
    directions across its axis the rows measure it against (:func:`_across_values`)."""
    names = [f"base{tag}_{c}" for c in "xyz"]
    for k, joint in enumerate(leg.joints):
        for a in range(len(joint.axes)):
            names += [f"axis{tag}_{k + 1}{'ab'[a]}_{c}" for c in "xyz"]
    for k in range(len(leg.bodies)):
        pre = f"body{tag}_{k + 1}"
        names += [f"{pre}_tip_{c}" for c in "xyz"] + [f"{pre}_com_{c}" for c in "xyz"]
        names += [f"{pre}_mass"] + [f"{pre}_inertia_{c}" for c in _INERTIA]
    if rows and leg.joints[-1].kind == "R":
        names += [f"across{tag}_{k}_{c}" for k in (1, 2) for c in "xyz"]
    return names


def _across_values(leg) -> list[float]:
    """The two unit directions across a revolute platform joint's axis, as the description's rows take them
    (:func:`pkmlab.description.mobility.across`): data of the description, as its axes are."""
    return [float(v) for b in across(leg.joints[-1].axes[0]) for v in b]


def parameter_names(mechanism: SpatialMechanism) -> tuple[str, ...]:
    """Names of the packed parameter vector, in order (:func:`pack`)."""
    names = []
    for i, (leg, rows) in enumerate(zip(mechanism.legs, kept_leg_rows(mechanism), strict=True)):
        names += _leg_parameter_names(leg, str(i + 1), rows)
    for i in range(len(mechanism.legs)):
        names += [f"attach{i + 1}_{c}" for c in "xyz"]
    names += [f"platform_com_{c}" for c in "xyz"] + ["platform_mass"] + [f"platform_inertia_{c}" for c in _INERTIA]
    names += [f"gravity_{c}" for c in "xyz"]
    return tuple(names)


def _inertia_values(tensor) -> list[float]:
    t = np.asarray(tensor, dtype=float)
    return [t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2]]


def pack(mechanism: SpatialMechanism) -> np.ndarray:
    """The parameter vector of ``mechanism`` read by its generated kernels (:func:`parameter_names`)."""
    values = []
    for leg, rows in zip(mechanism.legs, kept_leg_rows(mechanism), strict=True):
        values += [*leg.base]
        for joint in leg.joints:
            for axis in joint.axes:
                values += [*axis]
        for body in leg.bodies:
            values += [*body.tip, *body.com, body.mass, *_inertia_values(body.inertia)]
        if rows and leg.joints[-1].kind == "R":
            values += _across_values(leg)
    for point in mechanism.platform.attachments:
        values += [*point]
    p = mechanism.platform
    values += [*p.com, p.mass, *_inertia_values(p.inertia), *mechanism.gravity]
    return np.array(values, dtype=float)


def _rotation(sp, axis, angle):
    """Rodrigues' rotation by ``angle`` about the unit vector ``axis`` (symbols)."""
    k = sp.Matrix([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = sp.Matrix(axis)
    return sp.cos(angle) * sp.eye(3) + sp.sin(angle) * k + (1 - sp.cos(angle)) * (a * a.T)


def _turn(sp, axis, angle, v, sign=1):
    """The vector ``v`` turned by ``angle`` about the unit vector ``axis`` (``sign`` -1: turned back), by Rodrigues'
    formula on the vector, ``c v ± s (a × v) + (1 - c)(a · v) a``: a chain's frames turn the few vectors they
    carry, never multiplied into rotation matrices whose products and derivatives grow with every joint."""
    c, s = sp.cos(angle), sp.sin(angle)
    return c * v + sign * s * axis.cross(v) + (1 - c) * axis.dot(v) * axis


def _turned(sp, turns, v):
    """``R v`` for the rotation ``R`` of the chain ``turns`` (``(axis, angle)``, base to tip): one turn at a time,
    tip to base."""
    for axis, angle in reversed(turns):
        v = _turn(sp, axis, angle, v)
    return v


def _symbols(sp, names):
    return list(sp.symbols(" ".join(names), real=True, seq=True)) if names else []


def _platform(sp, mechanism: SpatialMechanism):
    """The platform's symbols: its pose coordinates and their rates (in ``q``'s order), the tracked point, its
    rotation (a function turning a vector of its frame into the base's: ``R v = Rz (Ry (Rx v))``, by roll, pitch
    and yaw), its angular velocity in its own frame."""
    names = mechanism.platform.q_pose_names
    pose, pose_dot = _symbols(sp, names), _symbols(sp, [f"{n}_dot" for n in names])
    named, rate = dict(zip(names, pose, strict=True)), dict(zip(names, pose_dot, strict=True))
    full = mechanism.platform.full_pose_names
    point = sp.Matrix([named[c] for c in full[:3]])
    if mechanism.platform.kind == "rigid":
        rx, ry, rz = (_rotation(sp, axis, named[c]) for axis, c in zip(((1, 0, 0), (0, 1, 0), (0, 0, 1)),
                                                                         ("roll", "pitch", "yaw"), strict=True))
        def rot(v):
            return rz * (ry * (rx * v))

        omega = (rx.T * ry.T * sp.Matrix([0, 0, rate["yaw"]]) + rx.T * sp.Matrix([0, rate["pitch"], 0])
                 + sp.Matrix([rate["roll"], 0, 0]))
    else:
        def rot(v):
            return v

        omega = sp.zeros(3, 1)
    return pose, pose_dot, point, rot, omega


def leg_types(mechanism: SpatialMechanism) -> list[str]:
    """Each leg's type, what its kernels are derived once for: its notation, with ``"+row"`` where the model keeps
    its universal joint's orientation row, ``"+row1"``, ``"+row2"`` or ``"+row12"`` which of its revolute joint's
    (an overconstrained machine may keep the rows of some legs of one notation and set aside the others': a
    4-RUU's)."""
    def tag(leg, rows):
        if not rows:
            return ""
        return "+row" if leg.joints[-1].kind == "U" else "+row" + "".join(str(k + 1) for k in rows)

    return [leg.notation + tag(leg, rows) for leg, rows in zip(mechanism.legs, kept_leg_rows(mechanism), strict=True)]


def derive_leg(mechanism: SpatialMechanism, leg, rows: tuple[int, ...] = ()) -> dict:
    """The symbolic kinematics of one leg of ``mechanism``, in the names of any leg of its type (with the
    orientation rows ``rows`` it keeps: :func:`leg_types`).

    The leg's coordinates are ``a`` (its actuator; ``a2``… a leg's others), its passive ones ``q_<joint>`` and the
    platform's pose; its
    parameters ``base_x``, ``axis_<joint><a|b>_x``, ``body_<k>_tip_x``..., and ``attach_x``... (its platform
    attachment point). Returns ``{"q", "q_dot": the leg's coordinates and rates, then the pose's; "P": its
    parameters' symbols by name; "eta": its point rows (3), then its orientation row if it has one;
    "bodies": [(position (3), velocity (3), ω (3)), ...]; "joints": every joint's position, base to platform;
    "lines" (6, or none)}``."""
    import sympy as sp

    pose, pose_dot, point_p, platform_rot, _ = _platform(sp, mechanism)
    names = [*_local_actuators(leg), *_leg_coordinate_names(leg, "")]
    own, own_dot = _symbols(sp, names), _symbols(sp, [f"{n}_dot" for n in names])
    rate = dict(zip(own, own_dot, strict=True))
    parameters = [*_leg_parameter_names(leg, "", rows), *(f"attach_{c}" for c in "xyz")]
    P = dict(zip(parameters, _symbols(sp, parameters), strict=True))

    def vec(prefix):
        return sp.Matrix([P[f"{prefix}_{c}"] for c in "xyz"])

    def velocity(expr):  # d/dt of an expression of the leg's coordinates
        return sp.Matrix([sum(sp.diff(e, v) * rate[v] for v in own) for e in expr])

    # the leg's point so far, in Horner's form: levels[0] + R1 (levels[1] + R2 (levels[2] + ...)), a level per turn
    # of its chain, each a vector in its frame: rotations are linear, so every vector a frame adds is turned once
    levels, turns, omega = [vec("base")], [], sp.zeros(3, 1)

    def world(extra=None):  # the point so far, plus the vector extra of the last frame, in the base's frame
        v = levels[-1] if extra is None else levels[-1] + extra
        for (axis, angle), below in zip(reversed(turns), reversed(levels[:-1]), strict=True):
            v = below + _turn(sp, axis, angle, v)
        return v

    actuators, passive = iter(own[:len(leg.actuated_joints)]), iter(own[len(leg.actuated_joints):])
    joints, bodies = [], []
    rotary = None  # where the leg's last passive rotary joint is
    for k, (joint, _body) in enumerate(zip(leg.joints, leg.bodies, strict=False)):
        joints.append(world())
        axes = [vec(f"axis_{k + 1}{'ab'[a]}") for a in range(len(joint.axes))]
        values = [next(actuators)] if joint.actuated else [next(passive) for _ in range(joint.coordinates)]
        if joint.kind == "P":  # along its axis, in the frame before it
            levels[-1] = levels[-1] + values[0] * axes[0]
        else:
            for axis, value in zip(axes, values, strict=True):
                turns.append((axis, value))
                levels.append(sp.zeros(3, 1))
                omega = _turn(sp, axis, value, omega, -1) + axis * rate[value]  # in the new frame
            if not joint.actuated:
                rotary = joints[-1]
        com = world(vec(f"body_{k + 1}_com"))
        bodies.append((com, velocity(com), omega))
        levels[-1] = levels[-1] + vec(f"body_{k + 1}_tip")
    point = world()
    target = point_p + platform_rot(vec("attach"))
    joints.append(target)
    lines = [*(target - point_p), *(target - rotary)] if measures_lines(mechanism) else []
    eta = list(point - target)
    k = len(leg.joints)
    if rows and leg.joints[-1].kind == "U":  # its two axes perpendicular
        eta.append((_turned(sp, turns, vec(f"axis_{k}a")).T * platform_rot(vec(f"axis_{k}b")))[0])
    elif rows:  # its axis turned by the leg across each kept direction turned by the platform
        eta += [(_turned(sp, turns, vec(f"axis_{k}a")).T * platform_rot(vec(f"across_{r + 1}")))[0] for r in rows]
    return {"q": (*own, *pose), "q_dot": (*own_dot, *pose_dot), "P": P, "eta": eta,
            "bodies": bodies, "joints": joints, "lines": lines, "acts": len(leg.actuated_joints)}


def derive(mechanism: SpatialMechanism) -> dict:
    """The symbolic kinematics of ``mechanism``'s structure: one derivation per type of leg (:func:`derive_leg`,
    by :func:`leg_types`), and the platform's — ``{"legs": {type: derive_leg(...)}, "q", "q_dot": the
    machine's coordinates, "P": its parameters' symbols by name, "platform": (position (3), velocity (3), ω (3))
    of its mass centre, "size": the platform's (the mean distance between its attachment points, 1 when it
    translates)}``."""
    import sympy as sp

    names = coordinate_names(mechanism)
    q, q_dot = _symbols(sp, names), _symbols(sp, [f"{n}_dot" for n in names])
    P = dict(zip(parameter_names(mechanism), _symbols(sp, parameter_names(mechanism)), strict=True))
    pose, pose_dot, point_p, platform_rot, omega = _platform(sp, mechanism)
    assert list(pose) == q[len(q) - len(pose):]
    com = point_p + platform_rot(sp.Matrix([P[f"platform_com_{c}"] for c in "xyz"]))
    com_velocity = sp.Matrix([sum(sp.diff(e, v) * r for v, r in zip(pose, pose_dot, strict=True)) for e in com])
    n = len(mechanism.legs)
    if mechanism.platform.kind == "rigid":
        pairs = [(i, j) for i in range(n) for j in range(i)]
        size = sum(sp.sqrt(sum((P[f"attach{i + 1}_{c}"] - P[f"attach{j + 1}_{c}"]) ** 2 for c in "xyz"))
                   for i, j in pairs) / len(pairs)
    else:
        size = sp.Integer(1)
    legs = {}
    for leg, kind, rows in zip(mechanism.legs, leg_types(mechanism), kept_leg_rows(mechanism), strict=True):
        if kind not in legs:
            legs[kind] = derive_leg(mechanism, leg, rows)
    return {"legs": legs, "q": q, "q_dot": q_dot, "P": P, "platform": (com, com_velocity, omega), "size": size}


def _indices(mechanism: SpatialMechanism, what: str) -> tuple[int, ...]:
    names = parameter_names(mechanism)
    if what == "gravity":
        return tuple(names.index(f"gravity_{c}") for c in "xyz")
    suffix = "_mass" if what == "mass" else "_inertia_xx"
    return tuple(names.index(f"{b}{suffix}") for b in [*_body_names(mechanism), "platform"])


def _plus(base: str, k: int) -> str:
    return f"{base} + {k}" if k else base


def _column(c: int, acts: int, own: int, ja, iq, pose0: int):
    """The column in ``q`` of a leg's local coordinate ``c`` (its ``acts`` actuators, its ``own`` passive ones, then
    the pose's): a number for numbers ``ja`` (where its actuators start) and ``iq`` (where its passive ones start),
    an expression for names."""
    if c < acts:
        return _plus(ja, c) if isinstance(ja, str) else ja + c
    if c < acts + own:
        return _plus(iq, c - acts) if isinstance(iq, str) else iq + c - acts
    return pose0 + c - acts - own


def generate_source(mechanism: SpatialMechanism) -> str:
    """The text of the generated module of ``mechanism``'s structure.

    Every kernel but ``platform_size`` runs one loop over the legs of each type, whose body is one leg's
    derivation (each leg's own coordinates, parameters, bodies and Jacobian non-zeros found at its offsets
    ``LEG_Q``, ``LEG_P``, ``LEG_ATTACH``, ``LEG_BODY``, ``LEG_JB``), then, for the bodies' kernels, writes the
    platform's rows: code the size of one leg, not of the machine — a Stewart platform's kernels are a sixth of
    what they would be unrolled, and compile in proportion."""
    import sympy as sp

    d = derive(mechanism)
    q, q_dot = d["q"], d["q_dot"]
    n, nq, n_pose = len(mechanism.legs), len(q), len(mechanism.platform.q_pose_names)
    kept = kept_leg_rows(mechanism)
    ends = any(kept)
    # the row of eta where each leg's kept orientation rows start (after every leg's point rows)
    leg_eta = [3 * n + sum(map(len, kept[:i])) if kept[i] else -1 for i in range(n)]
    m, nb = 3 * n + sum(map(len, kept)), sum(len(leg.bodies) for leg in mechanism.legs) + 1
    pose0 = nq - n_pose
    names, parameters = coordinate_names(mechanism), parameter_names(mechanism)
    # where each leg's own coordinates, parameters, attachment point, bodies and Jacobian non-zeros start
    leg_q, leg_p, leg_attach, leg_body, leg_jb = [], [], [], [], []
    # per type of leg, in its local coordinates: Jηq and its bias, the bodies' Jacobians and bias, the count of its
    # passive coordinates, its bodies' Jacobians' non-zeros (body, row, local column)
    local = {}
    for notation, t in d["legs"].items():
        rows = sp.Matrix([e for _pos, v, w in t["bodies"] for e in [*v, *w]])
        j_eta, b_eta = jacobian_and_bias(t["eta"], t["q"], t["q_dot"])
        j_body = jacobian(rows, t["q_dot"])
        local[notation] = {"j_eta": j_eta, "b_eta": b_eta, "j_body": j_body,
                           "b_body": jacobian(rows, t["q"]) * sp.Matrix(t["q_dot"]), "acts": t["acts"],
                           "own": len(t["q"]) - n_pose - t["acts"],
                           "nonzero": [(k, r, c) for k in range(len(t["bodies"])) for r in range(6)
                                       for c in range(len(t["q"])) if j_body[6 * k + r, c] != 0]}
    nonzero = []
    types = leg_types(mechanism)
    n_a = len(mechanism.actuators)
    # where each leg's actuators start in q (its number, but on a machine of legs of several actuators)
    leg_a = [sum(len(other.actuated_joints) for other in mechanism.legs[:i]) for i in range(n)]
    several = n_a != n
    ja = "ja" if several else "leg"

    def at(i, c):  # the column in q of leg i's local coordinate c
        return _column(c, local[types[i]]["acts"], local[types[i]]["own"], leg_a[i], leg_q[i], pose0)

    for i in range(n):
        leg_q.append(n_a + sum(local[other]["own"] for other in types[:i]))
        leg_p.append(parameters.index(f"base{i + 1}_x"))
        leg_attach.append(parameters.index(f"attach{i + 1}_x"))
        leg_body.append(sum(len(other.bodies) for other in mechanism.legs[:i]))
        leg_jb.append(len(nonzero))
        nonzero += [(leg_body[i] + k, r, at(i, c)) for k, r, c in local[types[i]]["nonzero"]]
    point = [list(names).index(c) for c in "xyz"]
    for t in d["legs"].values():  # the compiled core eliminates the tracked point with these unit pivots
        j = sp.Matrix(t["eta"]).jacobian([t["q"][len(t["q"]) - nq + c] for c in point])
        assert j[:3, :] == -sp.eye(3), "a leg's closure moves with the tracked point as -I"
        assert j[3:, :].is_zero_matrix, "an orientation row does not move with the tracked point"
    com, com_velocity, omega = d["platform"]
    platform_rows = [*com_velocity, *omega]
    platform_jacobian = jacobian(platform_rows, q_dot[pose0:])
    platform_bias = jacobian(platform_rows, q[pose0:]) * sp.Matrix(q_dot[pose0:])
    nonzero += [(nb - 1, r, pose0 + c) for r in range(6) for c in range(n_pose) if platform_jacobian[r, c] != 0]
    width = max(len(leg.joints) for leg in mechanism.legs)
    lines_of_action = measures_lines(mechanism)
    header = module_header(
        "spatial", mechanism, structure(mechanism), names, coordinate_angles(mechanism), parameters, (nq, m, nb),
        "# in space: 3 linear and 3 angular (body frame) rows per body Jacobian, lines of action of 6 (or the room "
        "for Jηq)", (3, 3, 6, 6 if lines_of_action else -(-m * nq // n)),
        "# where each body's mass and inertia tensor (xx, yy, zz, xy, xz, yz) and the gravity are in P",
        [_indices(mechanism, what) for what in ("mass", "inertia", "gravity")], nonzero,
        layout=(n_pose, [c - n_a for c in point], lines_of_action), point_rows=3 * n,
        pattern={(3 * i + r if r < 3 else leg_eta[i] + r - 3, at(i, c))
                 for i in range(n) for r in range(local[types[i]]["j_eta"].rows)
                 for c in range(local[types[i]]["j_eta"].cols) if local[types[i]]["j_eta"][r, c] != 0})
    header += ["# where each leg's passive coordinates (in q), parameters and attachment point (in P), bodies and "
               "bodies' Jacobians' non-zeros start",
               f"LEG_Q = {tuple(leg_q)!r}", f"LEG_P = {tuple(leg_p)!r}", f"LEG_ATTACH = {tuple(leg_attach)!r}",
               f"LEG_BODY = {tuple(leg_body)!r}", f"LEG_JB = {tuple(leg_jb)!r}"]
    if several:
        header += ["# where each leg's actuators start in q (legs of several actuators)", f"LEG_A = {tuple(leg_a)!r}"]
    if ends:
        header += ["# the row of eta of each leg's first orientation row (-1: none)", f"LEG_ETA = {tuple(leg_eta)!r}"]
    groups = {}
    for i, kind in enumerate(types):
        groups.setdefault(kind, []).append(i)
    loops = {}
    for g, (notation, members) in enumerate(groups.items()):
        if len(groups) == 1:
            loops[notation] = "for leg in range(N_LEGS):"
        else:
            header.append(f"LEGS_{g} = {tuple(members)!r}  # the legs {notation}")
            loops[notation] = f"for leg in LEGS_{g}:"

    def column(notation, c):  # the column of a local coordinate in the loop over the legs of a type
        return _column(c, local[notation]["acts"], local[notation]["own"], ja, "iq", pose0)

    # per type of leg, the lines that bind its names in a pass of the loop (each kept where used), and the names
    # of the trig table's entries of its angles
    unpacks = {}
    for notation, t in d["legs"].items():
        unpack = ["iq = LEG_Q[leg]", "ip = LEG_P[leg]", "ia = LEG_ATTACH[leg]", "ib = LEG_BODY[leg]",
                  "jb = LEG_JB[leg]", *(["ie = LEG_ETA[leg]"] if ends else []),
                  *(["ja = LEG_A[leg]"] if several else [])]
        trig = {}
        first = mechanism.legs[groups[notation][0]]
        angles = [*_actuator_angles(first), *_leg_angles(first)]
        for k, (symbol, angle) in enumerate(zip(t["q"], angles, strict=False)):  # its own coordinates
            name, where = str(symbol), column(notation, k)
            unpack.append(f"{name} = q[{where}]")
            if angle:
                c, s = sp.symbols(f"c_{name} s_{name}", real=True)
                trig[sp.cos(symbol)], trig[sp.sin(symbol)] = c, s
                unpack += [f"c_{name} = sc[{where}, 0]", f"s_{name} = sc[{where}, 1]"]
            unpack.append(f"{name}_dot = q_dot[{where}]")
        own_parameters = [name for name in t["P"] if not name.startswith("attach_")]
        unpack += [f"{name} = P[{_plus('ip', k)}]" for k, name in enumerate(own_parameters)]
        unpack += [f"attach_{c} = P[{_plus('ia', k)}]" for k, c in enumerate("xyz")]
        unpacks[notation] = (tuple(unpack), trig)

    def leg_blocks(kernel):
        """One block per type of leg: ``kernel(t, notation)`` gives its outputs and indices."""
        return [Block(*kernel(t, notation), loops[notation], *unpacks[notation]) for notation, t in d["legs"].items()]


    def row(r):  # a leg's r-th row of eta: its point rows, then its orientation rows
        return _plus("3 * leg", r) if r < 3 else _plus("ie", r - 3)

    def constraints(t, _notation):
        return t["eta"], [row(r) for r in range(len(t["eta"]))]

    def constraint_jacobian(t, notation):
        j = local[notation]["j_eta"]
        entries = [(r, c) for r in range(len(t["eta"])) for c in range(len(t["q"])) if j[r, c] != 0]
        return [j[r, c] for r, c in entries], [f"{row(r)}, {column(notation, c)}" for r, c in entries]

    def constraint_bias(t, notation):
        return list(local[notation]["b_eta"]), [row(r) for r in range(len(t["eta"]))]

    def body_poses(t, _notation):
        return ([e for pos, _v, _w in t["bodies"] for e in pos],
                [f"{_plus('ib', k)}, {c}" for k in range(len(t["bodies"])) for c in range(3)])

    def body_jacobians(_t, notation):
        j, entries = local[notation]["j_body"], local[notation]["nonzero"]
        return ([j[6 * k + r, c] for k, r, c in entries],
                [f"{_plus('ib', k)}, {r}, {column(notation, c)}" for k, r, c in entries])

    def body_jacobian_values(_t, notation):
        j, entries = local[notation]["j_body"], local[notation]["nonzero"]
        return [j[6 * k + r, c] for k, r, c in entries], [_plus("jb", z) for z in range(len(entries))]

    def body_bias(t, notation):
        return (list(local[notation]["b_body"]),
                [f"{_plus('ib', k)}, {r}" for k in range(len(t["bodies"])) for r in range(6)])

    def joint_points(t, _notation):
        padded = t["joints"] + [t["joints"][-1]] * (width - len(t["joints"]))  # short legs repeat their end
        return [c for p in padded for c in p], [f"leg, {k}, {c}" for k in range(width) for c in range(3)]

    def leg_lines(t, _notation):
        return t["lines"], [f"leg, {k}" for k in range(6)]

    platform = nb - 1
    platform_nonzero = [(r, c) for r in range(6) for c in range(n_pose) if platform_jacobian[r, c] != 0]
    kernels = [
        ("constraints", "q, sc, P, out", "Write the loop-closure residual eta(q) (N_CONSTRAINTS,) into out.",
         leg_blocks(constraints)),
        ("constraint_jacobian", "q, sc, P, out",
         "Write J_eta_q = d eta / dq (N_CONSTRAINTS, N_COORDINATES) into out.", leg_blocks(constraint_jacobian), True),
        ("constraint_bias", "q, sc, q_dot, P, out", "Write dJ_eta_q/dt q_dot (N_CONSTRAINTS,) into out.",
         leg_blocks(constraint_bias)),
        ("body_poses", "q, sc, P, out", "Write each body's mass-centre position (N_BODIES, 3) into out.",
         [*leg_blocks(body_poses), Block(list(com), [f"{platform}, {c}" for c in range(3)])]),
        ("body_jacobians", "q, sc, P, out",
         "Write each body's d(v, omega)/dqd (N_BODIES, 6, N_COORDINATES) into out (omega in the body's frame).",
         [*leg_blocks(body_jacobians), Block([platform_jacobian[r, c] for r, c in platform_nonzero],
                                             [f"{platform}, {r}, {pose0 + c}" for r, c in platform_nonzero])], True),
        ("body_jacobian_values", "q, sc, P, out", "Write the non-zeros of the bodies' Jacobians (N_JB,) into out "
         "(positions: JB_BODY, JB_ROW, JB_COL).",
         [*leg_blocks(body_jacobian_values),
          Block([platform_jacobian[r, c] for r, c in platform_nonzero],
                [str(len(nonzero) - len(platform_nonzero) + z) for z in range(len(platform_nonzero))])]),
        ("body_bias", "q, sc, q_dot, P, out", "Write each body's dJ_b/dt q_dot (N_BODIES, 6) into out.",
         [*leg_blocks(body_bias), Block(list(platform_bias), [f"{platform}, {r}" for r in range(6)])]),
        ("joint_points", "q, sc, P, out", "Write every joint's position (N_LEGS, JOINTS_PER_LEG, 3) into out, "
         "base to platform.", leg_blocks(joint_points)),
        *([("leg_lines", "q, sc, P, out", "Write each leg's line of action (N_LEGS, 6): its attachment point "
            "minus the tracked point, and its direction (unnormalised).", leg_blocks(leg_lines))]
          if lines_of_action else []),
        ("platform_size", "P", "The mean distance between the platform's attachment points (1 when it translates).",
         [Block([d["size"]], ["return"])]),
    ]
    return write_module(header, q, q_dot, names, coordinate_angles(mechanism), parameters,
                        independent_columns(mechanism, names), kernels)


def generated_path(mechanism: SpatialMechanism) -> Path:
    return GENERATED_DIR / f"spatial_{structure(mechanism)}.py"


def main(argv: list[str] | None = None) -> int:
    from ..description.presets import SPATIAL_PRESETS

    return regenerate(argv, SPATIAL_PRESETS, sys.modules[__name__], "pkmlab.codegen.spatial")


if __name__ == "__main__":
    sys.exit(main())
