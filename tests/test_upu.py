"""Legs that end in a universal joint: Tsai's translational 3-UPU of the catalogue (``examples/mechanisms``).

Its platform is held level by the universal joints at the platform, not by parallelograms: pkmlab checks that
they do (the computed mobility with the platform's orientation freed), closes each loop at the joint's centre
and gives the joint's angles as functions of the configuration.

Independent checks: the orientation closure (each leg's last body turned by its platform joint's two angles
is the platform's orientation) with the readable chain and rotations of :mod:`pkmlab.description.spatial`;
forward kinematics against a Newton multistart of 10,000 starts; rates against finite differences of the
inverse kinematics; and the dynamics against MuJoCo's hard-constraint solve of the machine as it is built —
each leg's platform joint two hinges, the platform a body welded to the legs — which is not the model pkmlab
derives (one point closure per leg, the platform translating).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from test_lower_mobility import _independent_residual

import pkmlab
from pkmlab.description.files import load_mechanism
from pkmlab.description.mobility import mobility
from pkmlab.description.spatial import (
    SpatialJoint,
    SpatialLeg,
    SpatialMechanism,
    SpatialPlatform,
    axis_rotation,
    leg_frames,
)
from pkmlab.errors import InvalidParameterError
from pkmlab.model import mechanism_model as mm

UPU = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "3upu.toml"
POSE = np.array([0.02, -0.01, 0.62])


@pytest.fixture(scope="module")
def upu():
    return pkmlab.load(UPU)


def _orientation_miss(model, q) -> float:
    """max |R_leg Rot(a1, q_a) Rot(a2, q_b) - I| over the legs: each platform joint's angles turn its leg's last
    body onto the level platform (the rotations composed here, from the angles pkmlab reports)."""
    angles = mm.platform_joint_angles(model, q)
    worst = 0.0
    for i, (leg, values) in enumerate(zip(model.description.legs, mm.leg_joint_values(model, q), strict=True)):
        a1, a2 = leg.joints[-1].axes
        rot = leg_frames(leg, values)[-1][1] @ axis_rotation(a1, angles[2 * i]) @ axis_rotation(a2, angles[2 * i + 1])
        worst = max(worst, float(np.abs(rot - np.eye(3)).max()))
    return worst


def test_the_3upu_is_a_translating_machine_of_mobility_three():
    m = load_mechanism(UPU)
    r = mobility(m)
    assert (r.mobility, r.rank, r.coordinates) == (3, 9, 12)
    assert m.platform.kind == "translating" and [leg.notation for leg in m.legs] == ["UP*U"] * 3
    assert mm.platform_joint_names(m) == ("q1_3a", "q1_3b", "q2_3a", "q2_3b", "q3_3a", "q3_3b")


def test_description_round_trips_through_toml():
    import tomllib

    from pkmlab.description.files import mechanism_from_dict
    from pkmlab.description.spatial import spatial_mechanism_to_toml

    m = load_mechanism(UPU)
    assert mechanism_from_dict(tomllib.loads(spatial_mechanism_to_toml(m))["mechanism"]) == m


def _with_leg(m, number: int, leg) -> SpatialMechanism:
    legs = list(m.legs)
    legs[number] = leg
    return SpatialMechanism(m.name, tuple(legs), m.platform, m.gravity)


def test_universal_joints_that_do_not_hold_the_platform_level_are_refused():
    m = load_mechanism(UPU)
    leg = m.legs[0]
    # the platform joint's axes swapped: its second axis no longer parallel to the base joint's first
    a, b = leg.joints[-1].axes
    swapped = replace(leg, joints=(*leg.joints[:-1], SpatialJoint("U", False, (b, a))))
    with pytest.raises(InvalidParameterError, match=r"leg 1 \(UP\*U\): its universal joint at the platform cannot "
                                                    r"turn the leg's last body onto the platform's fixed orientation"):
        mobility(_with_leg(m, 0, swapped))
    # every leg's axes the same (x, then y): each leg keeps its own platform joint feasible, but together they leave
    # the platform free to turn about x, a rotation their constraint couples (all across x) cannot stop
    same = tuple(replace(other, joints=(SpatialJoint("U", False, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))), other.joints[1],
                                        SpatialJoint("U", False, ((0.0, 1.0, 0.0), (1.0, 0.0, 0.0)))))
                 for other in m.legs)
    with pytest.raises(InvalidParameterError, match=r"do not hold it level: with its orientation free the computed "
                                                    r"mobility is 4, not 3"):
        mobility(SpatialMechanism(m.name, same, m.platform, m.gravity))


def test_on_a_rigid_platform_the_same_legs_hold_it_level_by_their_orientation_rows(upu):
    """Tsai's legs under a rigid platform controlled in x, y, z: each universal joint's orientation row (its axes
    perpendicular) replaces the translating platform's fixed orientation; the machine is the same — its
    parasitic roll, pitch and yaw stay 0, its actuators are the translating description's."""
    m = load_mechanism(UPU)
    p = m.platform
    rigid = SpatialMechanism(m.name, m.legs, SpatialPlatform("rigid", p.attachments, p.mass, p.com, p.inertia,
                                                             controlled=("x", "y", "z")), m.gravity)
    r = mobility(rigid)
    assert (r.mobility, r.rank, r.constraints) == (3, 12, 12)
    model = mm.MechanismModel.from_description(rigid)
    for pose in (POSE, POSE + [0.04, 0.03, -0.05]):
        q = mm.inverse_kinematics(model, pose, ())
        np.testing.assert_allclose(q[-6:-3], 0.0, atol=1e-12)  # roll, pitch, yaw: parasitic, level
        np.testing.assert_allclose(q[:3], mm.inverse_kinematics(upu, pose, ())[:3], atol=1e-12)


def test_a_leg_ending_in_an_actuated_universal_joint_is_refused():
    m = load_mechanism(UPU)
    actuated = replace(m.legs[0], joints=(*m.legs[0].joints[:-1], SpatialJoint("U", True, m.legs[0].joints[-1].axes)))
    with pytest.raises(InvalidParameterError, match="leg 1: its last joint carries the platform and must be a passive"):
        _with_leg(m, 0, SpatialLeg(actuated.base, actuated.joints, actuated.bodies, actuated.stroke))


def test_inverse_kinematics_closes_every_loop_and_keeps_the_platform_level(upu):
    q = mm.inverse_kinematics(upu, POSE, ())
    np.testing.assert_allclose(q[-3:], POSE, atol=0)
    assert _independent_residual(upu.description, q, upu.coordinates) < 1e-12
    assert _orientation_miss(upu, q) < 1e-12
    # level and on the axis, the symmetric machine's three legs are alike: equal slides
    q0 = mm.inverse_kinematics(upu, [0.0, 0.0, 0.6], ())
    assert np.ptp(q0[:3]) < 1e-12


def test_rates_against_finite_differences_of_the_inverse_kinematics(upu):
    direction = np.array([0.3, -0.2, 0.5])
    h = 1e-5
    q0 = mm.inverse_kinematics(upu, POSE, ())
    plus = mm.inverse_kinematics(upu, POSE + h * direction, ())
    minus = mm.inverse_kinematics(upu, POSE - h * direction, ())
    theta_dot, theta_ddot, k = mm.path_rates(upu, q0[None], direction[None], np.zeros((1, 3)))
    assert k == -1
    np.testing.assert_allclose(theta_dot[0], (plus[:3] - minus[:3]) / (2 * h), atol=1e-8)
    second = (plus[:3] - 2 * q0[:3] + minus[:3]) / h**2
    np.testing.assert_allclose(theta_ddot[0], second, atol=2e-4 * max(1.0, np.abs(second).max()))


def test_forward_kinematics_finds_both_assembly_modes_and_no_more(upu):
    """Three spheres: two assembly modes, mirror images through the base joints' plane, each level. The IK's
    configuration is one of them (FK∘IK), each gives back its own actuators (IK∘FK), and 10,000 Newton starts on
    the generated loop closures find no other."""
    q = mm.inverse_kinematics(upu, POSE, ())
    fk = pkmlab.forward_kinematics(upu, q[:3])
    assert int(fk.count) == 2
    found = fk.q.reshape(-1, len(upu.coordinates))
    assert any(np.abs(np.angle(np.exp(1j * (c - q)))).max() < 1e-9 for c in found)
    np.testing.assert_allclose(sorted(found[:, -1]), [-POSE[2], POSE[2]], atol=1e-12)
    for c in found:
        assert _independent_residual(upu.description, c, upu.coordinates) < 1e-12
        assert _orientation_miss(upu, c) < 1e-12
    up = found[np.argmax(found[:, -1])]
    np.testing.assert_allclose(mm.inverse_kinematics(upu, up[-3:], ())[:3], q[:3], atol=1e-12)
    multistart, converged = _translating_multistart(upu, q[:3])
    assert converged > 1000 and len(multistart) == 2
    assert all(any(np.abs(np.angle(np.exp(1j * (c - f)))).max() < 1e-7 for f in found) for c in multistart)


def _translating_multistart(model, theta, starts: int = 10_000):
    """:func:`test_lower_mobility._multistart` for a translating platform (no orientation to normalise)."""
    from test_catalogue_fk import newton_starts

    from pkmlab.algorithms.assembly import _polished
    from pkmlab.model.reach import spatial_extent

    rng = np.random.default_rng(1)
    n, N = model.n_actuators, len(model.coordinates)
    box = spatial_extent(model.description)
    q = np.empty((starts, N))
    q[:, :n] = theta
    q[:, n:N - 3] = rng.uniform(-np.pi, np.pi, (starts, N - 3 - n))
    q[:, N - 3:] = np.column_stack([rng.uniform(*box[c], starts) for c in range(3)])
    found = list(q[newton_starts(model, q)])
    # a universal joint's two angles reach one direction twice, (a, b) and (a + π, π - b), the body spun half a
    # turn about itself: the one with the second angle nearer zero, as pkmlab gives
    for q in found:
        for a in range(n, N - 3, 2):
            if abs(np.angle(np.exp(1j * q[a + 1]))) > np.pi / 2:
                q[a], q[a + 1] = q[a] + np.pi, np.pi - q[a + 1]
    return [c for c, _s in _polished(model, found)], len(found)


def test_tracking_run_keeps_the_platform_level_and_the_loops_closed(upu):
    """The catalogue's default run: tracked to within its sampled control's error; at every sample the loops are
    closed and the platform joints' angles keep the platform level, to round-off."""
    result = pkmlab.simulate(pkmlab.load_scenario(UPU.parent / "3upu_motion.toml"))
    assert result.summary()["max_path_error_m"] < 2e-5
    q = result.q[::20]
    assert max(_independent_residual(upu.description, qk, upu.coordinates) for qk in q) < 1e-10
    assert max(_orientation_miss(upu, qk) for qk in q) < 1e-10
    assert np.ptp(mm.platform_joint_angles(upu, q), axis=0).min() > 1e-3  # the joints did turn


def test_ik_on_the_command_line_reports_the_platform_joints(capsys):
    import json

    from pkmlab.cli import main

    assert main(["ik", "--mechanism", str(UPU), *map(str, POSE), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    (solution,) = report["solutions"]
    assert len(solution["passive"]) == 6 + 6  # the base joints' angles, then the platform joints'


# ------------------------------------------------------------------ the machine as built, in MuJoCo
def _as_built_mjcf(m) -> str:
    """The 3-UPU as built: in each leg's tree its base joint (two hinges), its slide and its platform joint (two
    hinges) carrying a third of the platform (its mass, mass centre and inertia: welded together the thirds are the
    platform); the thirds welded to the first. No point closure, no translating platform: the legs' joints alone
    hold the platform level."""
    def v(x):
        return " ".join(repr(float(c)) for c in np.ravel(x))

    def inertial(com, mass, tensor):
        t = np.asarray(tensor, dtype=float)
        six = [t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2]]
        return f'<inertial pos="{v(com)}" mass="{float(mass)!r}" fullinertia="{v(six)}"/>'

    p = m.platform
    lines, welds, motors = [], [], []
    for i, leg in enumerate(m.legs):
        (ua, ub), slide, (pa, pb) = leg.joints[0].axes, leg.joints[1].axes[0], leg.joints[2].axes
        b1, b2 = leg.bodies
        third = np.array(p.inertia) / 3
        lines += [f'<body name="l{i}b1" pos="{v(leg.base)}">', f'<joint name="l{i}ua" type="hinge" axis="{v(ua)}"/>',
                  f'<joint name="l{i}ub" type="hinge" axis="{v(ub)}"/>', inertial(b1.com, b1.mass, b1.inertia),
                  f'<body name="l{i}b2" pos="{v(b1.tip)}">', f'<joint name="l{i}s" type="slide" axis="{v(slide)}"/>',
                  inertial(b2.com, b2.mass, b2.inertia), f'<body name="l{i}p" pos="{v(b2.tip)}">',
                  f'<joint name="l{i}pa" type="hinge" axis="{v(pa)}"/>',
                  f'<joint name="l{i}pb" type="hinge" axis="{v(pb)}"/>',
                  inertial(np.subtract(p.com, p.attachments[i]), p.mass / 3, third), "</body></body></body>"]
        motors.append(f'<motor joint="l{i}s" gear="1"/>')
        if i:  # the pose of third i in third 0's frame: the attachment points' offset, no turn
            offset = np.subtract(p.attachments[i], p.attachments[0])
            welds.append(f'<weld body1="l0p" body2="l{i}p" relpose="{v(offset)} 1 0 0 0"/>')
    return (f'<mujoco><option gravity="{v(m.gravity)}"/><worldbody>{"".join(lines)}</worldbody>'
            f'<equality>{"".join(welds)}</equality><actuator>{"".join(motors)}</actuator></mujoco>')


def _as_built_state(model, q, q_dot):
    """MuJoCo's qpos and qvel of the as-built model: each leg's joints, then its platform joint's angles (their
    rates by central differences of the angles along ``q̇``)."""
    h = 1e-6
    angles = mm.platform_joint_angles(model, q)
    rates = (mm.platform_joint_angles(model, q + h * q_dot) - mm.platform_joint_angles(model, q - h * q_dot)) / (2 * h)
    values, speeds = mm.leg_joint_values(model, q), mm.leg_joint_values(model, q_dot)
    qpos = np.concatenate([[*values[i], *angles[2 * i:2 * i + 2]] for i in range(3)])
    qvel = np.concatenate([[*speeds[i], *rates[2 * i:2 * i + 2]] for i in range(3)])
    return qpos, qvel


def test_dynamics_equal_mujocos_hard_constraint_solve_of_the_machine_as_built(upu):
    """MuJoCo's mass matrix, bias forces and weld Jacobian of the as-built machine, the welds hard:
    ``[M Jᵀ; J 0] [q̈; λ] = [τ - bias; -J̇ q̇]`` (``J̇ q̇`` by central differences of ``J q̇`` along the motion), its
    slides' accelerations against pkmlab's actuator-space model — at rest to round-off, moving to the
    differences' error."""
    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_string(_as_built_mjcf(upu.description))
    d = mujoco.MjData(m)
    slides = [m.jnt_dofadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, f"l{i}s")] for i in range(3)]
    rng = np.random.default_rng(3)
    for moving, tolerance in ((False, 1e-12), (True, 1e-8)):
        pose = POSE + rng.normal(0.0, 0.02, 3)
        q = mm.inverse_kinematics(upu, pose, ())
        theta_dot = rng.normal(0.0, 0.3, 3) if moving else np.zeros(3)
        q_dot = pkmlab.coordinate_rates(upu, q, theta_dot)
        tau = rng.normal(0.0, 5.0, 3)
        qpos, qvel = _as_built_state(upu, q, q_dot)

        def weld_jacobian(position, qvel=qvel):
            d.qpos[:], d.qvel[:] = position, qvel
            mujoco.mj_forward(m, d)
            return d.efc_J.reshape(d.nefc, m.nv).copy()

        h = 1e-6
        bias_rate = (weld_jacobian(qpos + h * qvel) @ qvel - weld_jacobian(qpos - h * qvel) @ qvel) / (2 * h)
        J = weld_jacobian(qpos)
        assert d.nefc == 12 and np.abs(d.efc_pos).max() < 1e-12  # pkmlab's configuration closes the welds
        assert np.abs(J @ qvel).max() < 1e-8 * (1 + np.abs(qvel).max())
        d.ctrl[:] = tau
        mujoco.mj_forward(m, d)
        M = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M)
        kkt = np.block([[M, J.T], [J, np.zeros((len(J), len(J)))]])
        theirs = np.linalg.solve(kkt, np.concatenate([d.qfrc_actuator - d.qfrc_bias, -bias_rate]))[slides]
        Mt, c, g = mm.actuator_space_model(upu, q, theta_dot)
        ours = np.linalg.solve(Mt, tau - c - g)
        assert np.abs(theirs - ours).max() < tolerance * (1 + np.abs(ours).max())
