"""Symbolic derivation of a spatial mechanism's kinematics, generated as compiled kernels.

The spatial counterpart of :mod:`pkmlab.codegen.planar`, for a
:class:`~pkmlab.description.spatial.SpatialMechanism`, in the coordinates

    q = (actuator values, passive joint coordinates leg by leg, pose)

with the pose ``(x, y, z)`` of a translating platform or ``(x, y, z, roll, pitch, yaw)`` of a rigid one.
It derives, with SymPy:

* the loop-closure constraints ``η(q) = 0`` — for each leg, the centre of its platform joint (the
  end of its chain) minus its platform attachment point, x, y then z (3 per leg: a universal joint
  under a translating platform closes the loop at its centre too, its angles following from the
  leg's, :mod:`pkmlab.description.spatial`); their Jacobian and
  the bias ``J̇ηq q̇`` (paper eqs. 14–17, 32);
* for every body (the legs' bodies, then the platform) the velocity of its mass centre (3 rows) and
  its angular velocity in its own frame ``ω`` (3 rows), both linear in ``q̇``: their Jacobian
  ``J_b = ∂(v, ω)/∂q̇`` and bias ``J̇_b q̇`` — with the 3×3 inertia tensors, everything the compiled
  core's actuator-space model (eq. 35 with gravity and the gyroscopic terms of spatial bodies) needs;
* the legs' lines of action (the line from each leg's last passive rotary joint to its spherical
  joint, a two-force member for the R*US and UP*S legs of the Delta and the Stewart–Gough
  platform), every joint's position (for drawing) and the structural non-zeros of ``J_b``.

Angular velocities follow the chain: through a revolute joint of axis ``a`` and angle ``q``,
``ω_next = Rot(a, q)ᵀ ω + a q̇`` in the next body's frame; a prismatic joint keeps ``ω``.

Run ``python -m pkmlab.codegen.spatial`` to regenerate the shipped modules (``--check`` as
:mod:`pkmlab.codegen.planar`).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ..description.spatial import SpatialMechanism
from .planar import GENERATED_DIR, jacobian_and_bias, module_header, regenerate, write_module

_INERTIA = ("xx", "yy", "zz", "xy", "xz", "yz")


def structure(mechanism: SpatialMechanism) -> str:
    """``"RaUS_RaUS_RaUS_translating"`` for the Delta (``a`` marks the actuated joint); a platform of lower
    mobility adds its controlled coordinates (``"PaRS_PaRS_PaRS_rigid_z_roll_pitch"``)."""
    name = "_".join(leg.notation.replace("*", "a") for leg in mechanism.legs) + "_" + mechanism.platform.kind
    return name + "".join(f"_{c}" for c in mechanism.platform.pose_names) if mechanism.platform.parasitic_names \
        else name


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
    return True


def coordinate_names(mechanism: SpatialMechanism) -> tuple[str, ...]:
    """``a1..an`` (actuators), ``q<leg>_<joint>`` (passive joints; a U joint's two are ``…a``, ``…b``), the pose."""
    names = [f"a{i + 1}" for i in range(len(mechanism.legs))]
    for i, leg in enumerate(mechanism.legs):
        for k, joint in enumerate(leg.joints[:-1]):  # the platform joint has no coordinate
            if joint.actuated:
                continue
            names += [f"q{i + 1}_{k + 1}a", f"q{i + 1}_{k + 1}b"] if joint.kind == "U" else [f"q{i + 1}_{k + 1}"]
    return (*names, *mechanism.platform.q_pose_names)


def coordinate_angles(mechanism: SpatialMechanism) -> tuple[bool, ...]:
    angles = [leg.joints[leg.actuated].kind == "R" for leg in mechanism.legs]
    for leg in mechanism.legs:
        for joint in leg.joints[:-1]:
            if not joint.actuated:
                angles += [joint.kind != "P"] * joint.coordinates
    return (*angles, *(name in ("roll", "pitch", "yaw") for name in mechanism.platform.q_pose_names))


def _body_names(mechanism: SpatialMechanism) -> list[str]:
    return [f"body{i + 1}_{k + 1}" for i, leg in enumerate(mechanism.legs) for k in range(len(leg.bodies))]


def parameter_names(mechanism: SpatialMechanism) -> tuple[str, ...]:
    """Names of the packed parameter vector, in order (:func:`pack`)."""
    names = []
    for i, leg in enumerate(mechanism.legs):
        names += [f"base{i + 1}_{c}" for c in "xyz"]
        for k, joint in enumerate(leg.joints):
            for a in range(len(joint.axes)):
                names += [f"axis{i + 1}_{k + 1}{'ab'[a]}_{c}" for c in "xyz"]
        for k in range(len(leg.bodies)):
            pre = f"body{i + 1}_{k + 1}"
            names += [f"{pre}_tip_{c}" for c in "xyz"] + [f"{pre}_com_{c}" for c in "xyz"]
            names += [f"{pre}_mass"] + [f"{pre}_inertia_{c}" for c in _INERTIA]
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
    for leg in mechanism.legs:
        values += [*leg.base]
        for joint in leg.joints:
            for axis in joint.axes:
                values += [*axis]
        for body in leg.bodies:
            values += [*body.tip, *body.com, body.mass, *_inertia_values(body.inertia)]
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


def derive(mechanism: SpatialMechanism) -> dict:
    """The symbolic kinematics of ``mechanism``'s structure: ``{"q", "q_dot", "P", "eta" (3 per leg),
    "bodies": [(position (3), velocity (3), ω (3)), ...], "joints", "lines", "size"}``."""
    import sympy as sp

    names = coordinate_names(mechanism)
    q = sp.symbols(" ".join(names), real=True)
    q_dot = sp.symbols(" ".join(f"{n}_dot" for n in names), real=True)
    rate = dict(zip(q, q_dot, strict=True))
    P = dict(zip(parameter_names(mechanism), sp.symbols(" ".join(parameter_names(mechanism)), real=True),
                 strict=True))

    def vec(prefix):
        return sp.Matrix([P[f"{prefix}_{c}"] for c in "xyz"])

    def tensor(prefix):
        xx, yy, zz, xy, xz, yz = (P[f"{prefix}_inertia_{c}"] for c in _INERTIA)
        return sp.Matrix([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])

    def velocity(expr):  # d/dt of an expression of q
        return sp.Matrix([sum(sp.diff(e, v) * rate[v] for v in q) for e in expr])

    n = len(mechanism.legs)
    n_pose = len(mechanism.platform.q_pose_names)
    named = dict(zip(mechanism.platform.q_pose_names, q[len(q) - n_pose:], strict=True))
    pose = [named[c] for c in mechanism.platform.full_pose_names]
    point_p = sp.Matrix(pose[:3])
    if mechanism.platform.kind == "rigid":
        roll, pitch, yaw = pose[3:]
        rx, ry, rz = _rotation(sp, (1, 0, 0), roll), _rotation(sp, (0, 1, 0), pitch), _rotation(sp, (0, 0, 1), yaw)
        platform_rot = rz * ry * rx
        omega_platform = (rx.T * ry.T * sp.Matrix([0, 0, rate[yaw]]) + rx.T * sp.Matrix([0, rate[pitch], 0])
                          + sp.Matrix([rate[roll], 0, 0]))
    else:
        platform_rot, omega_platform = sp.eye(3), sp.zeros(3, 1)
    passive = iter(q[n:len(q) - n_pose])
    lines_of_action = measures_lines(mechanism)
    eta, bodies, joints, lines = [], [], [], []
    for i, leg in enumerate(mechanism.legs):
        point, rot, omega = vec(f"base{i + 1}"), sp.eye(3), sp.zeros(3, 1)
        joints.append([])
        rotary = None  # where the leg's last passive rotary joint is
        for k, (joint, _body) in enumerate(zip(leg.joints, leg.bodies, strict=False)):
            joints[i].append(point)
            axes = [vec(f"axis{i + 1}_{k + 1}{'ab'[a]}") for a in range(len(joint.axes))]
            values = [q[i]] if joint.actuated else [next(passive) for _ in range(joint.coordinates)]
            origin = point
            if joint.kind == "P":
                origin = point + values[0] * (rot * axes[0])
            else:
                for axis, value in zip(axes, values, strict=True):
                    turn = _rotation(sp, axis, value)
                    rot = rot * turn
                    omega = turn.T * omega + axis * rate[value]
                if not joint.actuated:
                    rotary = point
            pre = f"body{i + 1}_{k + 1}"
            com = origin + rot * vec(f"{pre}_com")
            bodies.append((com, velocity(com), omega))
            point = origin + rot * vec(f"{pre}_tip")
        target = point_p + platform_rot * vec(f"attach{i + 1}")
        eta += list(point - target)
        joints[i].append(target)
        if lines_of_action:
            lines += [*(target - point_p), *(target - rotary)]
    com = point_p + platform_rot * vec("platform_com")
    bodies.append((com, velocity(com), omega_platform))
    if mechanism.platform.kind == "rigid":
        pairs = [(i, j) for i in range(n) for j in range(i)]
        size = sum(sp.sqrt(sum((P[f"attach{i + 1}_{c}"] - P[f"attach{j + 1}_{c}"]) ** 2 for c in "xyz"))
                   for i, j in pairs) / len(pairs)
    else:
        size = sp.Integer(1)
    return {"q": q, "q_dot": q_dot, "P": P, "eta": eta, "bodies": bodies, "joints": joints, "lines": lines,
            "size": size, "tensor": tensor}


def _indices(mechanism: SpatialMechanism, what: str) -> tuple[int, ...]:
    names = parameter_names(mechanism)
    if what == "gravity":
        return tuple(names.index(f"gravity_{c}") for c in "xyz")
    suffix = "_mass" if what == "mass" else "_inertia_xx"
    return tuple(names.index(f"{b}{suffix}") for b in [*_body_names(mechanism), "platform"])


def generate_source(mechanism: SpatialMechanism) -> str:
    """The text of the generated module of ``mechanism``'s structure."""
    import sympy as sp

    d = derive(mechanism)
    q, q_dot = d["q"], d["q_dot"]
    nq, m, nb, n = len(q), len(d["eta"]), len(d["bodies"]), len(mechanism.legs)
    j_eta, b_eta = jacobian_and_bias(d["eta"], q, q_dot)
    point = [list(coordinate_names(mechanism)).index(c) for c in "xyz"]
    for i in range(n):  # the compiled core eliminates the tracked point with these unit pivots
        for r in range(3):
            assert [j_eta[3 * i + r, point[c]] for c in range(3)] == [-int(r == c) for c in range(3)]
    rows = [e for _pos, v, w in d["bodies"] for e in [*v, *w]]  # linear in q_dot: J = d/dqd, bias = d/dq q_dot
    j_body = sp.Matrix(rows).jacobian(q_dot)
    b_body = sp.Matrix(rows).jacobian(q) * sp.Matrix(q_dot)
    nonzero = [(b, r, c) for b in range(nb) for r in range(6) for c in range(nq) if j_body[6 * b + r, c] != 0]
    width = max(len(leg.joints) for leg in mechanism.legs)
    header = module_header(
        "spatial", mechanism, structure(mechanism), coordinate_names(mechanism), coordinate_angles(mechanism),
        parameter_names(mechanism), (nq, m, nb),
        "# in space: 3 linear and 3 angular (body frame) rows per body Jacobian, lines of action of 6 (or the room "
        "for Jηq)", (3, 3, 6, 6 if d["lines"] else -(-m * nq // n)),
        "# where each body's mass and inertia tensor (xx, yy, zz, xy, xz, yz) and the gravity are in P",
        [_indices(mechanism, what) for what in ("mass", "inertia", "gravity")], nonzero,
        layout=(len(mechanism.platform.q_pose_names), [c - n for c in point], bool(d["lines"])))
    points, where = [], []
    for i, leg_points in enumerate(d["joints"]):
        padded = leg_points + [leg_points[-1]] * (width - len(leg_points))
        points += [c for point in padded for c in point]
        where += [f"{i}, {k}, {c}" for k in range(width) for c in range(3)]
    kernels = [
        ("constraints", "q, sc, P, out", "Write the loop-closure residual eta(q) (N_CONSTRAINTS,) into out.",
         d["eta"], [str(k) for k in range(m)]),
        ("constraint_jacobian", "q, sc, P, out",
         "Write J_eta_q = d eta / dq (N_CONSTRAINTS, N_COORDINATES) into out.",
         list(j_eta), [f"{r}, {c}" for r in range(m) for c in range(nq)]),
        ("constraint_bias", "q, sc, q_dot, P, out", "Write dJ_eta_q/dt q_dot (N_CONSTRAINTS,) into out.",
         list(b_eta), [str(k) for k in range(m)]),
        ("body_poses", "q, sc, P, out", "Write each body's mass-centre position (N_BODIES, 3) into out.",
         [e for pos, _v, _w in d["bodies"] for e in pos], [f"{b}, {k}" for b in range(nb) for k in range(3)]),
        ("body_jacobians", "q, sc, P, out",
         "Write each body's d(v, omega)/dqd (N_BODIES, 6, N_COORDINATES) into out (omega in the body's frame).",
         list(j_body), [f"{b}, {k}, {c}" for b in range(nb) for k in range(6) for c in range(nq)]),
        ("body_jacobian_values", "q, sc, P, out", "Write the non-zeros of the bodies' Jacobians (N_JB,) into out "
         "(positions: JB_BODY, JB_ROW, JB_COL).", [j_body[6 * b + r, c] for b, r, c in nonzero],
         [str(z) for z in range(len(nonzero))]),
        ("body_bias", "q, sc, q_dot, P, out", "Write each body's dJ_b/dt q_dot (N_BODIES, 6) into out.",
         list(b_body), [f"{b}, {k}" for b in range(nb) for k in range(6)]),
        ("joint_points", "q, sc, P, out", "Write every joint's position (N_ACTUATORS, JOINTS_PER_LEG, 3) into out, "
         "base to platform.", points, where),
        *([("leg_lines", "q, sc, P, out", "Write each leg's line of action (N_ACTUATORS, 6): its attachment point "
            "minus the tracked point, and its direction (unnormalised).", d["lines"],
            [f"{i}, {k}" for i in range(n) for k in range(6)])] if d["lines"] else []),
        ("platform_size", "P", "The mean distance between the platform's attachment points (1 when it translates).",
         [d["size"]], ["return"]),
    ]
    return write_module(header, q, q_dot, coordinate_names(mechanism), coordinate_angles(mechanism),
                        parameter_names(mechanism), n, kernels)


def generated_path(mechanism: SpatialMechanism) -> Path:
    return GENERATED_DIR / f"spatial_{structure(mechanism)}.py"


def main(argv: list[str] | None = None) -> int:
    from ..description.presets import SPATIAL_PRESETS

    return regenerate(argv, SPATIAL_PRESETS, sys.modules[__name__], "pkmlab.codegen.spatial")


if __name__ == "__main__":
    sys.exit(main())
