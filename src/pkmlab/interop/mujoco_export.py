"""Any described mechanism as a MuJoCo model (MJCF), and the map between MuJoCo's coordinates and pkmlab's.

MuJoCo simulates kinematic *trees*; a closed chain is a tree plus equality constraints that close its
loops. pkmlab writes every mechanism the same way:

* each leg is a chain of bodies from the world, one body per body of the description, each moved by its
  joint: a ``hinge`` for ``R``, a ``slide`` for ``P``, two hinges in the same body for ``U`` (applied in
  order, the second about its axis as the first turn carries it — pkmlab's universal joint);
* the platform is a body of its own, a child of the world, moved by its pose's coordinates: slides
  along x and y and a hinge about z (a rigid planar platform, ``x, y, alpha``), slides along x and y (a
  planar point with its payload), slides along x, y and z (a translating spatial platform), or a free
  joint (a six-degree-of-freedom platform: position and quaternion);
* every leg is closed on the platform by an ``<equality><connect>`` between a site at the end of its
  chain and a site at its platform attachment point (3 scalar rows; in the plane the z row is satisfied
  identically). The spherical joint that ends a spatial leg is exactly such a point constraint; the
  planar revolute that carries a platform is one too, its angle being free. A universal joint that carries a
  rigid platform is that point constraint and its two axes kept perpendicular: a spatial tendon between a site
  :data:`AXIS_SITE` along its first axis (on the leg's last body) and one as far along its second (on the
  platform), its length held at ``√2`` times that distance by an ``<equality><tendon>``; a revolute joint is two
  point constraints on its axis, the second ``connect`` :data:`AXIS_SITE` along it (rows that, like the
  machine's own, depend on the others: MuJoCo's solver takes them as they are). MuJoCo's constraints are
  soft; by default they get the stiffest setting it accepts (``closures="stiff"``), with which MuJoCo's
  machine behaves like the rigid one, or MuJoCo's own defaults (``closures="soft"``), with which the loops
  open by up to a few millimetres — the file says which, in a comment before them;
* one ``motor`` (gear 1, unlimited) on each actuated joint: its control is the actuator effort in N·m
  or N; gravity as the description says; contacts off.

Masses, mass centres and inertias are the description's, in each body's frame. Two facts of MuJoCo shape
the export, and both are stated in the written file:

* a planar body's inertia about z is its moment of inertia; MuJoCo wants a full tensor, so the body is
  given ``(I/2, I/2, I)`` — a flat plate, whose moments about x and y never enter planar motion;
* MuJoCo refuses a tensor with a zero principal moment (a thin rod along its axis, a slider that never
  turns). Such a moment is raised to :data:`INERTIA_FLOOR` times the body's largest one (or to
  :data:`INERTIA_FLOOR` kg m² when all are zero). For a body that never turns about that axis (a slider;
  a platform that only translates) this changes nothing; for a rod spinning about itself (the Delta's
  forearms) it adds at most that fraction of its transverse inertia.

Coordinates. MuJoCo's joint values are relative (each joint turns its body with respect to its parent);
a planar description's angles are absolute. :func:`qpos_from_q` and :func:`q_from_qpos` map pkmlab's
configuration ``q = (actuators, passive joints, pose)`` to MuJoCo's ``qpos`` (legs in order, joints in
order, then the platform) and back; :func:`qvel_from_q_dot` maps the rates. ``mujoco`` itself is an
optional dependency (``pip install pkmlab[mujoco]``): this module writes the text without it, and only
:func:`load_mujoco` imports it.
"""

from __future__ import annotations

import collections
import contextlib
import copy
import functools
import math
import threading
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import InvalidParameterError, PkmlabError

#: A principal moment of inertia below this fraction of the body's largest (kg m² when all are zero) is
#: raised to it: MuJoCo refuses tensors with a zero principal moment.
INERTIA_FLOOR = 1e-9

#: MuJoCo's defaults for the equality constraints, and the stiffest setting pkmlab uses (impedance at
#: MuJoCo's cap 0.9999, time constant twice a 1 ms step, critical damping).
DEFAULT_SOLREF, DEFAULT_SOLIMP = (0.02, 1.0), (0.9, 0.95, 0.001, 0.5, 2.0)
STIFF_SOLREF, STIFF_SOLIMP = (0.002, 1.0), (0.9999, 0.9999, 0.001, 0.5, 2.0)

#: The loop closures by name, ``(solref, solimp)``: ``"stiff"`` (the default of the export and of the MuJoCo
#: plant: the closures then behave like the rigid machine) and ``"soft"`` (MuJoCo's own defaults).
CLOSURES = {"stiff": (STIFF_SOLREF, STIFF_SOLIMP), "soft": (DEFAULT_SOLREF, DEFAULT_SOLIMP)}

#: What each setting does, as the exported file says it. The figures were measured on pkmlab's default runs of
#: its six presets (pkmlab's controller, MuJoCo's RK4 at the sample time or 1 ms, whichever is smaller): the
#: largest loop-closure violation, and the largest distance of the tracked point from the same run on
#: pkmlab's rigid plant.
CLOSURE_NOTES = {
    "stiff": "pkmlab's stiff setting (impedance at MuJoCo's cap 0.9999, time constant twice a 1 ms step, critical "
             "damping): MuJoCo's closures then behave like the rigid machine (in pkmlab's default runs of its six "
             "presets the loops stay closed to 1e-7 m and the tracked point within 2e-7 m of pkmlab's rigid "
             "plant). closures=\"soft\" exports MuJoCo's defaults instead.",
    "soft": "MuJoCo's defaults: soft constraints, the loops may open by about 0.03 to 3 mm as the machine moves "
            "(pkmlab's default runs of its six presets: 0.4 mm for the five-bar, 3 mm for the Delta against "
            "gravity), and the tracked point strays up to 7 mm from the rigid machine's. closures=\"stiff\" "
            "(pkmlab's default) makes them behave like the rigid machine.",
}


#: How far from a universal joint's centre (m) the two sites of its axes' tendon are (module docstring).
AXIS_SITE = 0.1


def closure_settings(closures: str) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """``(solref, solimp)`` of the loop closures named ``closures``: ``"stiff"`` or ``"soft"``
    (:data:`CLOSURES`)."""
    if not (isinstance(closures, str) and closures in CLOSURES):
        raise InvalidParameterError(f"closures must be 'stiff' or 'soft', got {closures!r}")
    return CLOSURES[closures]


def _spatial(description) -> bool:
    return bool(getattr(description, "spatial", False))


def _numbers(values) -> str:
    return " ".join(repr(float(v)) for v in values)


def _floored(tensor) -> tuple[np.ndarray, bool]:
    """The tensor with its principal moments raised to the floor, and whether any was."""
    t = np.asarray(tensor, dtype=float)
    moments, axes = np.linalg.eigh(t)
    floor = INERTIA_FLOOR * moments.max() if moments.max() > 0 else INERTIA_FLOOR
    if moments.min() >= floor:
        return t, False
    return axes @ np.diag(np.maximum(moments, floor)) @ axes.T, True


def _inertial(mass: float, com, tensor, notes: list, where: str) -> str:
    t, floored = _floored(tensor)
    if floored:
        notes.append(where)
    full = (t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2])
    return f'<inertial pos="{_numbers(com)}" mass="{float(mass)!r}" fullinertia="{_numbers(full)}"/>'


def _planar_tensor(inertia: float) -> np.ndarray:
    return np.diag([inertia / 2, inertia / 2, inertia])


def _platform_joints(m) -> tuple[str, ...]:
    """The pose coordinates the platform's own joints move (all but a six-DOF platform's, which is free)."""
    return m.pose_names if _spatial(m) else m.platform.pose_names


def joint_names(model) -> tuple[str, ...]:
    """MuJoCo's joints in tree order (the order of ``qpos``'s legs part, then the platform's): leg ``i``'s
    joint ``k`` is ``leg<i>_j<k>`` (a universal joint's two hinges ``…a``, ``…b``)."""
    m = model.description
    names = []
    for i, leg in enumerate(m.legs):
        for k, joint in enumerate(leg.joints[:-1]):
            base = f"leg{i + 1}_j{k + 1}"
            names += [base + "a", base + "b"] if joint.kind == "U" else [base]
    if _spatial(m) and m.platform.kind == "rigid":
        return (*names, "platform_free")
    return (*names, *(f"platform_{n}" for n in _platform_joints(m)))


def mjcf(model, q=None, *, timestep: float = 0.001, integrator: str = "RK4", closures: str = "stiff",
         solref=None, solimp=None, drives=None) -> str:
    """The MJCF text of a :class:`~pkmlab.model.mechanism_model.MechanismModel` (module docstring), with a keyframe
    ``"pkmlab"`` at configuration ``q`` (default :func:`home_configuration`). ``closures`` sets the
    loop-closure constraints: ``"stiff"`` (default, :data:`STIFF_SOLREF`, :data:`STIFF_SOLIMP`: they then
    behave like the rigid machine) or ``"soft"`` (MuJoCo's defaults, :data:`DEFAULT_SOLREF`,
    :data:`DEFAULT_SOLIMP`); ``solref`` or ``solimp``, when given, replaces that setting's own. An XML
    comment before the constraints says which settings the file uses, and why.

    ``drives`` (a :class:`~pkmlab.simulation.realism.Drives`, optional) puts the drives on the actuated joints as
    MuJoCo models them (:func:`drive_attributes`); their effort limit and noise are the controller's side (the
    MuJoCo plant applies them to the command)."""
    m = model.description
    drive_attrs = drive_attributes(model, drives)
    named_solref, named_solimp = closure_settings(closures)
    solref = named_solref if solref is None else tuple(float(v) for v in solref)
    solimp = named_solimp if solimp is None else tuple(float(v) for v in solimp)
    if integrator not in ("RK4", "Euler", "implicit", "implicitfast"):
        raise InvalidParameterError(f"integrator must be RK4, Euler, implicit or implicitfast, got {integrator!r}")
    if not (isinstance(timestep, float | int) and math.isfinite(timestep) and timestep > 0):
        raise InvalidParameterError(f"timestep must be a positive number of seconds, got {timestep!r}")
    if not _spatial(m) and m.platform.kind == "point" and m.platform.mass <= 0:
        raise InvalidParameterError(f"{m.name}: a point platform without a payload has no mass for MuJoCo to move "
                                    "(give its payload a mass)")
    q = home_configuration(model) if q is None else np.asarray(q, dtype=float)
    qpos = qpos_from_q(model, q)
    notes: list[str] = []
    gravity = (*m.gravity, 0.0) if not _spatial(m) else m.gravity
    body_lines, actuators, equalities, tendons = [], [], [], []
    joints = iter(joint_names(model))
    held = _held(m)
    numbers = iter(range(model.n_actuators))  # the actuators a1, a2, ... leg by leg, base to platform
    for i, leg in enumerate(m.legs):
        depth = 2
        opened = 0
        for k, (joint, body) in enumerate(zip(leg.joints, leg.bodies, strict=False)):
            pad = "  " * depth
            name = f"leg{i + 1}_body{k + 1}"
            if k == 0:
                pos = (*leg.base, 0.0) if not _spatial(m) else leg.base
            else:
                before = leg.bodies[k - 1].tip
                pos = (*before, 0.0) if not _spatial(m) else before
            quat = ""
            if not _spatial(m) and joint.kind == "P" and k == 0:  # a rail: the body's frame along it
                quat = f' quat="{_numbers((math.cos(joint.axis / 2), 0.0, 0.0, math.sin(joint.axis / 2)))}"'
            body_lines.append(f'{pad}<body name="{name}" pos="{_numbers(pos)}"{quat}>')
            if _spatial(m):
                axes = joint.axes
            else:
                axes = ((0.0, 0.0, 1.0),) if joint.kind == "R" else ((1.0, 0.0, 0.0),)
            for axis in axes:
                jname = next(joints)
                kind = "slide" if joint.kind == "P" else "hinge"
                a = next(numbers) if joint.actuated else None
                extra = drive_attrs[a] if joint.actuated else ""
                body_lines.append(f'{pad}  <joint name="{jname}" type="{kind}" axis="{_numbers(axis)}"{extra}/>')
                hinges = [f"leg{i + 1}_j{j + 1}" for j in range(k) if leg.joints[j].kind == "R"]
                if joint.actuated and joint.kind == "R" and hinges and not _spatial(m):
                    # pkmlab's effort turns the body's absolute angle, MuJoCo's hinges are relative: the motor acts
                    # on their sum (a fixed tendon), the generalised force of the absolute angle on each hinge
                    tendons += [f'    <fixed name="absolute{a + 1}">',
                                *(f'      <joint joint="{h}" coef="1"/>' for h in (*hinges, jname)), "    </fixed>"]
                    actuators.append(f'    <motor name="actuator{a + 1}" tendon="absolute{a + 1}" gear="1"/>')
                elif joint.actuated:
                    actuators.append(f'    <motor name="actuator{a + 1}" joint="{jname}" gear="1"/>')
            if _spatial(m):
                body_lines.append(f"{pad}  " + _inertial(body.mass, body.com, body.inertia, notes,
                                                          f"leg {i + 1}, body {k + 1}"))
            else:
                body_lines.append(f"{pad}  " + _inertial(body.mass, (*body.com, 0.0), _planar_tensor(body.inertia),
                                                          notes, f"leg {i + 1}, body {k + 1}"))
            depth += 1
            opened += 1
        last = leg.bodies[-1]
        tip = (*last.tip, 0.0) if not _spatial(m) else last.tip
        body_lines.append(f'{"  " * depth}<site name="leg{i + 1}_end" pos="{_numbers(tip)}"/>')
        if i in held:  # a point on its first axis (a revolute joint's only one)
            axis = np.array(tip) + AXIS_SITE * np.array(leg.joints[-1].axes[0])
            body_lines.append(f'{"  " * depth}<site name="leg{i + 1}_axis" pos="{_numbers(axis)}"/>')
        for _ in range(opened):
            depth -= 1
            body_lines.append(f'{"  " * depth}</body>')
        equalities.append(f'    <connect name="close{i + 1}" site1="leg{i + 1}_end" site2="platform_a{i + 1}" '
                          f'solref="{_numbers(solref)}" solimp="{_numbers(solimp)}"/>')
    platform = m.platform
    body_lines.append('    <body name="platform" pos="0 0 0">')
    if _spatial(m) and platform.kind == "rigid":
        body_lines.append('      <freejoint name="platform_free"/>')
    else:
        axes = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}
        for name in _platform_joints(m):
            kind, axis = ("hinge", (0, 0, 1)) if name == "alpha" else ("slide", axes[name])
            body_lines.append(f'      <joint name="platform_{name}" type="{kind}" axis="{_numbers(axis)}"/>')
    if _spatial(m):
        body_lines.append("      " + _inertial(platform.mass, platform.com, platform.inertia, notes, "platform"))
        attachments = platform.attachments
    else:
        tensor = _planar_tensor(platform.inertia) if platform.kind == "rigid" else np.zeros((3, 3))
        body_lines.append("      " + _inertial(platform.mass, (*platform.com, 0.0), tensor, notes, "platform"))
        attachments = [(*a, 0.0) for a in platform.attachments]
    for i, a in enumerate(attachments):
        body_lines.append(f'      <site name="platform_a{i + 1}" pos="{_numbers(a)}"/>')
    for i in held:
        joint = m.legs[i].joints[-1]
        axis = np.array(attachments[i]) + AXIS_SITE * np.array(joint.axes[-1])
        body_lines.append(f'      <site name="platform_axis{i + 1}" pos="{_numbers(axis)}"/>')
        if joint.kind == "R":
            equalities.append(f'    <connect name="axis{i + 1}" site1="leg{i + 1}_axis" site2="platform_axis{i + 1}" '
                              f'solref="{_numbers(solref)}" solimp="{_numbers(solimp)}"/>')
            continue
        tendons += [f'    <spatial name="hold{i + 1}">', f'      <site site="leg{i + 1}_axis"/>',
                    f'      <site site="platform_axis{i + 1}"/>', "    </spatial>"]
        # MuJoCo holds a tendon at its length in qpos0 (every joint 0, the platform at the origin) plus polycoef[0]
        equalities.append(f'    <tendon name="hold{i + 1}" tendon1="hold{i + 1}" '
                          f'polycoef="{_numbers((math.sqrt(2.0) * AXIS_SITE - _axis_length0(m, i), 0, 0, 0, 0))}" '
                          f'solref="{_numbers(solref)}" solimp="{_numbers(solimp)}"/>')
    body_lines.append("    </body>")
    comment = [f"pkmlab: the {m.name} ({m.notation}), {len(m.legs)} legs closed on the platform by connect "
               "constraints; " + ("joint values as pkmlab's (relative), the platform's pose last"
                                  + (" (position, quaternion)" if m.platform.kind == "rigid" else "") if _spatial(m)
                                  else "joint values relative where pkmlab's planar angles are absolute") +
               ": see pkmlab.interop.mujoco_export.qpos_from_q."]
    if not _spatial(m):
        comment.append("Planar bodies carry (I/2, I/2, I): their moments about x and y never enter planar motion.")
    if notes:
        comment.append(f"Principal moments of inertia raised to {INERTIA_FLOOR:g} x the body's largest (MuJoCo "
                       f"refuses zero ones): {'; '.join(notes)}.")
    lines = [f"<!-- {c.replace('--', '-')} -->" for c in comment]
    lines += [f"<mujoco model={quoteattr(m.name)}>",
              '  <compiler angle="radian" autolimits="true"/>',
              f'  <option timestep="{float(timestep)!r}" integrator="{integrator}" gravity="{_numbers(gravity)}" '
              'solver="Newton" tolerance="1e-10" iterations="50">',
              '    <flag contact="disable"/>', "  </option>",
              "  <worldbody>", *body_lines, "  </worldbody>",
              *(["  <tendon>", *tendons, "  </tendon>"] if tendons else []),
              "  <equality>", _closure_comment(closures, solref, solimp), *equalities, "  </equality>",
              "  <actuator>", *actuators, "  </actuator>",
              "  <keyframe>", f'    <key name="pkmlab" qpos="{_numbers(qpos)}"/>', "  </keyframe>",
              "</mujoco>"]
    return "\n".join(lines) + "\n"


def _held(m) -> tuple[int, ...]:
    """The legs whose universal or revolute joint carries a rigid platform (module docstring): every one, whether
    the model keeps its orientation rows or sets them aside."""
    if not _spatial(m):
        return ()
    from ..description.mobility import orientation_legs

    return orientation_legs(m)


def _axis_length0(m, leg: int) -> float:
    """The length of leg ``leg``'s axes' tendon in MuJoCo's ``qpos0``: the leg at its zero configuration, the
    platform at the origin, unturned."""
    from ..description.spatial import leg_coordinate_count, leg_frames

    chain = m.legs[leg]
    end = leg_frames(chain, np.zeros(leg_coordinate_count(chain)))[-1][0]
    a1, a2 = (np.array(a) for a in chain.joints[-1].axes)
    return float(np.linalg.norm(end + AXIS_SITE * a1 - np.array(m.platform.attachments[leg]) - AXIS_SITE * a2))


def drive_attributes(model, drives) -> list[str]:
    """Each actuated joint's MJCF attributes for ``drives`` (a :class:`~pkmlab.simulation.realism.Drives` or None:
    none): the reflected armature as ``armature``, viscous friction as ``damping`` and Coulomb friction as
    ``frictionloss`` — MuJoCo's dry friction, a stick–slip law solved with the constraints, so only stick–slip
    friction (``stick_slip``) has its counterpart there. Refused where MuJoCo's joint value is not pkmlab's
    actuator (a planar leg's actuated revolute after its first joint: MuJoCo's angle is relative)."""
    n = model.n_actuators
    if drives is None:
        return [""] * n
    table, k_ = drives.table(n), model.kernels
    m = model.description
    if np.any(table[:, k_.COULOMB] > 0) and not drives.stick_slip:
        law = "exact sign" if drives.coulomb_rate == 0 else "smooth tanh"
        raise InvalidParameterError(f"MuJoCo's Coulomb friction (frictionloss) is stick-slip friction, not pkmlab's "
                                    f"{law} law: declare the drives' stick_slip = true, or run on pkmlab's plant")
    for i, k in m.actuators:  # a revolute after another: its MuJoCo angle is relative, pkmlab's absolute
        if not _spatial(m) and m.legs[i].joints[k].kind == "R" and any(j.kind == "R" for j in m.legs[i].joints[:k]):
            raise InvalidParameterError(f"leg {i + 1}: its actuated revolute is joint {k + 1}, whose MuJoCo angle is "
                                        "relative and pkmlab's absolute: drives on it are not exported")
    names = {"armature": k_.ARMATURE, "damping": k_.VISCOUS, "frictionloss": k_.COULOMB}
    return ["".join(f' {name}="{float(table[i, c])!r}"' for name, c in names.items() if table[i, c] > 0)
            for i in range(n)]


def _closure_comment(closures: str, solref, solimp) -> str:
    """The XML comment that says which loop-closure settings the file uses, and why."""
    values = f'solref="{_numbers(solref)}" solimp="{_numbers(solimp)}"'
    used = next((name for name, settings in CLOSURES.items() if settings == (solref, solimp)), None)
    if used is None:
        why = (f"given by the caller in place of the {closures} setting's (pkmlab's stiff setting, which behaves "
               f"like the rigid machine: solref=\"{_numbers(STIFF_SOLREF)}\" solimp=\"{_numbers(STIFF_SOLIMP)}\"; "
               f"MuJoCo's defaults: solref=\"{_numbers(DEFAULT_SOLREF)}\" solimp=\"{_numbers(DEFAULT_SOLIMP)}\").")
    else:
        why = CLOSURE_NOTES[used]
    text = f"Loop closures ({used or 'custom'}): {values}, {why}"
    return f"    <!-- {text.replace('--', '-')} -->"


def _n_pose(m) -> int:
    """How many of ``q``'s last coordinates are the platform's pose (its parasitic ones included)."""
    return len(m.platform.q_pose_names) if _spatial(m) else len(m.platform.pose_names)


def _whole_pose(m, q: np.ndarray) -> np.ndarray:
    """The platform's whole pose of ``q`` (or of its rates), in the order of its kind's pose names."""
    if not _spatial(m):
        return q[len(q) - _n_pose(m):]
    from ..description.spatial import full_poses

    return full_poses(m, q[len(q) - _n_pose(m):])


def _quaternion(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """The unit quaternion (w, x, y, z) of ``Rz(yaw) Ry(pitch) Rx(roll)``."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr, cy * sp * cr + sy * cp * sr,
                     sy * cp * cr - cy * sp * sr])


def qpos_from_q(model, q) -> np.ndarray:
    """MuJoCo's ``qpos`` of pkmlab's configuration ``q``: the legs' joint values (planar angles made relative
    to the body before: ``φ - θ``), then the platform's pose (a quaternion for a six-DOF platform)."""
    m = model.description
    q = np.asarray(q, dtype=float)
    if q.shape != (len(model.coordinates),):
        raise InvalidParameterError(f"q must be the {len(model.coordinates)} coordinates "
                                    f"({', '.join(model.coordinates)}), got shape {q.shape}")
    from ..model.mechanism_model import leg_joint_values

    out = []
    for leg, values in zip(m.legs, leg_joint_values(model, q), strict=True):
        if _spatial(m):
            out += values
            continue
        direction = 0.0  # the absolute angle of the body before the joint (the world's, then a rail's)
        for k, (joint, value) in enumerate(zip(leg.joints, values, strict=False)):
            if joint.kind == "R":
                out.append(value - direction)
                direction = value
            else:
                out.append(value)
                if k == 0:
                    direction = joint.axis
    pose = _whole_pose(m, q)
    if _spatial(m) and m.platform.kind == "rigid":
        return np.array([*out, *pose[:3], *_quaternion(*pose[3:])])
    return np.array([*out, *pose])


def _legs_from_mujoco(model, values: np.ndarray, rates: bool) -> tuple[list, int]:
    """pkmlab's actuators then passive joint coordinates (or their rates) from MuJoCo's leg values (..., its
    ``qpos`` or ``qvel``), each an array (...); and how many of ``values`` the legs take."""
    m = model.description
    actuators, passive, k = [], [], 0
    for leg in m.legs:
        direction = 0.0  # the absolute angle (rate) of the body before the joint
        for j, joint in enumerate(leg.joints[:-1]):
            count = getattr(joint, "coordinates", 1)
            got = [values[..., k + c] for c in range(count)]
            k += count
            if not _spatial(m):
                if joint.kind == "R":
                    got = [got[0] + direction]
                    direction = got[0]
                elif j == 0:
                    direction = 0.0 if rates else joint.axis  # a rail's angle is constant
            if joint.actuated:
                actuators.append(got[0])
            else:
                passive += got
    return [*actuators, *passive], k


def q_from_qpos(model, qpos) -> np.ndarray:
    """The inverse of :func:`qpos_from_q`, of one ``qpos`` or of many (..., its size)."""
    m = model.description
    qpos = np.asarray(qpos, dtype=float)
    legs, k = _legs_from_mujoco(model, qpos, rates=False)
    rest = qpos[..., k:]
    if _spatial(m) and m.platform.kind == "rigid":
        unit = rest[..., 3:7] / np.linalg.norm(rest[..., 3:7], axis=-1, keepdims=True)
        w, x, y, z = (unit[..., c] for c in range(4))
        roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
        yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        rest = np.concatenate([rest[..., :3], np.stack([roll, pitch, yaw], axis=-1)], axis=-1)
    if _spatial(m):
        from ..description.spatial import q_poses

        rest = q_poses(m, rest)
    return np.concatenate([np.stack(legs, axis=-1), rest], axis=-1)


def actuator_rates(model, qvel) -> np.ndarray:
    """pkmlab's actuator rates ``θ̇`` of MuJoCo's ``qvel`` (..., its size): the first of
    :func:`q_dot_from_qvel`'s, which depend on the legs' joints' rates alone."""
    actuators = _legs_from_mujoco(model, np.asarray(qvel, dtype=float), rates=True)[0][:model.n_actuators]
    return np.stack(actuators, axis=-1)


def affine_map(model) -> tuple[np.ndarray, np.ndarray] | None:
    """``(A, b)`` with ``q = A qpos + b`` and ``q̇ = A qvel`` — :func:`q_from_qpos` and :func:`q_dot_from_qvel`
    as one matrix, for a loop that maps every sample — or None for a six-DOF platform (its quaternion does
    not map linearly)."""
    m = model.description
    if _spatial(m) and m.platform.kind == "rigid":
        return None
    size = len(model.coordinates)
    b = q_from_qpos(model, np.zeros(size))
    a = np.column_stack([q_from_qpos(model, e) - b for e in np.eye(size)])
    return a, b


def independent_map(model, nq: int, nv: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(A, b, V)``: the compiled core's independent coordinates (the actuators, or a redundantly actuated
    machine's pose) ``A qpos + b`` and their rates ``V qvel``, for MuJoCo's ``qpos`` of ``nq`` and ``qvel`` of
    ``nv`` — or None where they do not map linearly (a redundantly actuated six-DOF platform's pose: its
    quaternion). A six-DOF platform's actuators are values of its legs' joints, which come first in both."""
    maps = _independent_map(model, nq, nv)
    return None if maps is None else tuple(a.copy() for a in maps)


@functools.lru_cache(maxsize=8)
def _independent_map(model, nq: int, nv: int):
    """:func:`independent_map`, kept for the next run of the same machine (it probes the maps column by column)."""
    independent = list(model.kernels.INDEPENDENT)
    affine = affine_map(model)
    if affine is not None:
        a, b = affine[0][independent], affine[1][independent]
        return a, b, a
    if model.description.actuation_redundancy:
        return None
    offset, k = _legs_from_mujoco(model, np.zeros(nq), rates=False)
    legs = np.column_stack([_legs_from_mujoco(model, e, rates=True)[0] for e in np.eye(k)])[independent]
    a, v = np.zeros((len(independent), nq)), np.zeros((len(independent), nv))
    a[:, :k], v[:, :k] = legs, legs
    return a, np.array(offset)[independent], v


def q_dot_from_qvel(model, q, qvel) -> np.ndarray:
    """The inverse of :func:`qvel_from_q_dot`: pkmlab's rates ``q̇`` at ``q`` of MuJoCo's ``qvel``."""
    m = model.description
    qvel = np.asarray(qvel, dtype=float)
    legs, k = _legs_from_mujoco(model, qvel, rates=True)
    rest = qvel[k:]
    if _spatial(m) and m.platform.kind == "rigid":
        from ..description.spatial import orientation, q_poses

        roll, pitch, _yaw = _whole_pose(m, np.asarray(q, dtype=float))[3:]
        rx, ry = orientation(roll, 0.0, 0.0), orientation(0.0, pitch, 0.0)
        # ω = E (roll, pitch, yaw rates), the map of qvel_from_q_dot, inverted
        e = np.column_stack([[1.0, 0.0, 0.0], rx.T @ [0.0, 1.0, 0.0], rx.T @ ry.T @ [0.0, 0.0, 1.0]])
        rest = q_poses(m, np.array([*rest[:3], *np.linalg.solve(e, rest[3:])]))
    return np.array([*legs, *rest])


def qvel_from_q_dot(model, q, q_dot) -> np.ndarray:
    """MuJoCo's ``qvel`` of pkmlab's rates ``q̇`` at ``q``: the relative rates of :func:`qpos_from_q` (a linear
    map of ``q̇`` in the plane); a free joint's angular velocity in the platform's own frame."""
    m = model.description
    q_dot = np.asarray(q_dot, dtype=float)
    if not (_spatial(m) and m.platform.kind == "rigid"):
        # every entry of qpos is linear in q: its rates are the same map (a rail's constant angle drops out)
        return qpos_from_q(model, q_dot) - qpos_from_q(model, np.zeros_like(q_dot))
    from ..description.spatial import orientation

    legs = qpos_from_q(model, q_dot)[:-7]
    roll, pitch, _yaw = _whole_pose(m, np.asarray(q, dtype=float))[3:]
    whole_rates = _whole_pose(m, q_dot)
    rates = whole_rates[3:]
    # ω in the platform frame from the z-y'-x'' rates (as the spatial derivation writes it)
    rx, ry = orientation(roll, 0.0, 0.0), orientation(0.0, pitch, 0.0)
    omega = rx.T @ ry.T @ np.array([0.0, 0.0, rates[2]]) + rx.T @ np.array([0.0, rates[1], 0.0]) + np.array(
        [rates[0], 0.0, 0.0])
    return np.array([*legs, *whole_rates[:3], *omega])


def home_configuration(model, mode=None) -> np.ndarray:
    """A configuration to export the machine in (:func:`pkmlab.model.mechanism_model.well_conditioned_configuration`),
    in working mode ``mode`` (one sign per two-branch leg; default: the first working mode)."""
    from ..algorithms.kinematics import as_working_mode
    from ..model import mechanism_model as mm

    mode = mm.working_modes(model)[0] if mode is None else as_working_mode(model, mode, "mode")
    return mm.well_conditioned_configuration(model, tuple(int(s) for s in mode))


def load_mujoco(model, q=None, **options):
    """``(MjModel, MjData)`` of :func:`mjcf`, the data at the keyframe ``"pkmlab"`` (``q``). Needs ``mujoco``
    (``pip install pkmlab[mujoco]``)."""
    try:
        import mujoco
    except ImportError:
        raise PkmlabError("MuJoCo is not installed: pip install 'pkmlab[mujoco]' (or pip install mujoco)") from None
    q = None if q is None else np.asarray(q, dtype=float)
    key = _key(model, q, options)
    if key is None:  # an option given as a list: not kept
        mj_model = mujoco.MjModel.from_xml_string(mjcf(model, q, **options))
    else:
        mj_model = copy.copy(_compiled(key))  # (a copy: the caller may change it)
    data = mujoco.MjData(mj_model)
    mujoco.mj_resetDataKeyframe(mj_model, data, 0)
    mujoco.mj_forward(mj_model, data)
    return mj_model, data


def _key(model, q, options: dict):
    """The key of :func:`load_mujoco`'s arguments: ``(model, q's shape and bytes or None, the options)``, None where an
    option cannot be hashed."""
    key = (model, None if q is None else (q.shape, q.tobytes()), tuple(sorted(options.items())))
    try:
        hash(key)
    except TypeError:
        return None
    return key


#: Finished runs' models and data (:func:`pooled_mujoco`), by :func:`load_mujoco`'s key: at most
#: :data:`IDLE_KEPT` keys, the least recently used dropped first.
_IDLE: collections.OrderedDict = collections.OrderedDict()
_IDLE_LOCK = threading.Lock()
IDLE_KEPT = 4


@contextlib.contextmanager
def pooled_mujoco(model, q=None, **options):
    """:func:`load_mujoco` for a run that gives its ``(MjModel, MjData)`` back when it ends: the next run of the same
    machine from the same configuration with the same options takes them, the data reset to the keyframe — the state
    a new ``MjData`` starts in (:func:`mujoco.mj_resetDataKeyframe`, then ``mj_forward``) — instead of new ones. A
    new ``MjData`` costs about 0.7 ms (MuJoCo maps its arena, 14 MB of address space for the Delta), a copy of the
    compiled model 0.4, a reset 0.05: a millisecond of a run of a thousand steps. One run uses a pair at a time
    (threads included). The block must not change the model (the next run would inherit the change: take
    :func:`load_mujoco`'s own copy for that), nor keep the data past its end (the next run's)."""
    import mujoco

    q = None if q is None else np.asarray(q, dtype=float)
    key = _key(model, q, options)
    pair = None
    if key is not None:
        with _IDLE_LOCK:
            pair = _IDLE.pop(key, None)
    if pair is None:
        pair = load_mujoco(model, q, **options)
    else:
        mujoco.mj_resetDataKeyframe(pair[0], pair[1], 0)
        mujoco.mj_forward(pair[0], pair[1])
    try:
        yield pair
    finally:
        if key is not None:
            with _IDLE_LOCK:
                _IDLE[key] = pair
                _IDLE.move_to_end(key)
                while len(_IDLE) > IDLE_KEPT:
                    _IDLE.popitem(last=False)


#: Runs holding MuJoCo's log (:func:`mujoco_log_held`): how many, and the log settings the first of them found.
_LOG_HELD = {"runs": 0, "kept": None}
_LOG_LOCK = threading.Lock()


@contextlib.contextmanager
def mujoco_log_held(mujoco):
    """MuJoCo's warnings neither printed nor written to ``MUJOCO_LOG.TXT`` in the working folder while pkmlab loads and
    steps its models (MuJoCo's log settings, ``mujoco.MjLogConfig``, are the process's: held from the first run in,
    of runs in threads, to the last out, and set back then as they were). MuJoCo still counts each warning in its
    data (``MjData.warning``), where pkmlab reads them: a state MuJoCo found bad stops the run in one line, another
    warning is said once (:func:`say_mujoco_warnings`). A MuJoCo without log settings (an older release) logs as it
    always did."""
    settings = getattr(mujoco, "MjLogConfig", None)
    if settings is None:
        yield
        return
    with _LOG_LOCK:
        if _LOG_HELD["runs"] == 0:
            config = settings.get()
            _LOG_HELD["kept"] = (config.logto_file, config.logto_console)
            config.logto_file = config.logto_console = False
            config.set()
        _LOG_HELD["runs"] += 1
    try:
        yield
    finally:
        with _LOG_LOCK:
            _LOG_HELD["runs"] -= 1
            if _LOG_HELD["runs"] == 0:
                config = settings.get()
                config.logto_file, config.logto_console = _LOG_HELD["kept"]
                config.set()


def say_mujoco_warnings(mujoco, data, said_otherwise=()) -> None:
    """Each warning MuJoCo counted in ``data`` (other than the kinds ``said_otherwise``) as a ``RuntimeWarning`` naming
    it and how often: the models pkmlab exports have no contacts and a fixed number of constraints, so that any is
    worth a report."""
    import warnings

    for kind, counted in enumerate(data.warning):
        if counted.number > 0 and kind not in said_otherwise:
            text = mujoco.mju_warningText(kind, counted.lastinfo).rstrip(".")
            warnings.warn(f"MuJoCo warned {counted.number} time(s) during the run: {text}", RuntimeWarning,
                          stacklevel=3)


@functools.lru_cache(maxsize=8)
def _compiled(key):
    """MuJoCo's model (``MjModel``) of :func:`mjcf`'s document of ``key = (model, q's shape and bytes or None, the
    options)``, kept for the next run of the same machine from the same configuration: writing the document and
    MuJoCo's compiling it take about two milliseconds, a copy of the result a fifth of one. A model is its description
    (its parameters are packed from it), which the key compares."""
    import mujoco

    model, q, options = key
    q = None if q is None else np.frombuffer(q[1]).reshape(q[0])
    return mujoco.MjModel.from_xml_string(mjcf(model, q, **dict(options)))
