"""A leg that carries two actuators: the paper's 3-RRR with its first leg's elbow driven too
(``examples/mechanisms/3rrr_elbow.toml``, legs ``R*R*R + R*RR + R*RR``), four actuators for three degrees of freedom;
a leg that both moves its base and carries two actuators (a 3-PRRR's first leg ``P*R*R*R``); and a spatial one, the
3-RRS with its first leg's knee driven (``examples/mechanisms/3rrs_knee.toml``, ``R*R*S + R*RS + R*RS``, a platform of
lower mobility).

Independent checks: the loop closures by the readable chain of :func:`~pkmlab.description.mechanism.leg_chain`; the
actuation Jacobian against central differences of the inverse kinematics; forward kinematics from subsets of the
actuators against the pose the inverse kinematics started from; the pose-space dynamics against MuJoCo's
hard-constraint solve of the exported model (where the driven elbow is a motor on a tendon holding the distal link's
absolute angle); the paper's 3-RRR's own singularity measure along a turn through its forward singularity; MuJoCo's
plant running the same scenario.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest

import pkmlab
from pkmlab.description import spatial
from pkmlab.description.files import load_mechanism, mechanism_to_toml
from pkmlab.description.mechanism import Joint, attachment_point, leg_chain
from pkmlab.description.mobility import mobility
from pkmlab.description.spatial import SpatialJoint, full_poses, leg_frames
from pkmlab.errors import InvalidParameterError, SingularityError
from pkmlab.interop import mujoco_export as mx
from pkmlab.model import mechanism_model as mm

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
ELBOW = CATALOGUE / "3rrr_elbow.toml"
KNEE = CATALOGUE / "3rrs_knee.toml"
MODE = (1, 1, 1)


@pytest.fixture(scope="module")
def elbow():
    return pkmlab.load(ELBOW)


def _chain_residual(model, q) -> float:
    m = model.description
    pose = mm.pose_of(model, q)[:len(m.platform.pose_names)]
    return max(float(np.abs(np.subtract(leg_chain(leg, values)[-1][0], attachment_point(m, i, pose))).max())
               for i, (leg, values) in enumerate(zip(m.legs, mm.leg_joint_values(model, q), strict=True)))


def _poses(count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.22, 0.30, count), rng.uniform(0.12, 0.20, count),
                            rng.uniform(-0.4, 0.4, count)])


def _jacobian_error(model, pose, mode, h: float = 1e-6) -> float:
    """How far ``W = ∂θ/∂x`` of :func:`pkmlab.pose_coordinate_jacobian` is from the central difference of the inverse
    kinematics at ``pose`` in working mode ``mode``, relative to its largest entry."""
    n = model.n_actuators
    W = pkmlab.pose_coordinate_jacobian(model, mm.inverse_kinematics(model, pose, mode))[:n]
    differenced = np.column_stack([(mm.inverse_kinematics(model, pose + h * e, mode)[:n]
                                    - mm.inverse_kinematics(model, pose - h * e, mode)[:n]) / (2 * h)
                                   for e in np.eye(model.dof)])
    return float(np.abs(W - differenced).max() / np.abs(W).max())


def test_a_leg_of_two_actuators_is_read_as_actuation_redundancy(elbow, tmp_path):
    """Its second actuator moves no base (the leg has an ordinary leg's three joints): the machine keeps the
    platform's three coordinates and has one internal effort; the file form round-trips."""
    m = elbow.description
    assert m.notation == "R*R*R + R*RR + R*RR" and elbow.n_actuators == 4 and m.dof == 3
    assert m.actuation_redundancy == 1 and m.redundancy_names == () and m.pose_names == ("x", "y", "alpha")
    assert m.actuators == ((0, 0), (0, 1), (1, 0), (2, 0)) and m.actuator_kinds == ("R",) * 4
    leg = m.legs[0]
    assert (leg.moving_base, leg.actuated, leg.extra_actuated) == (0, 0, (1,))
    assert len(mm.working_modes(elbow)) == 8
    path = tmp_path / "again.toml"
    path.write_text(mechanism_to_toml(m))
    assert load_mechanism(path) == m


def test_inverse_kinematics_gives_both_actuators_of_the_leg_and_their_jacobian(elbow):
    """In every working mode the legs close on the platform by the readable chain, the elbow's actuator is the
    distal link's absolute angle, and ``W = ∂θ/∂x`` is the central difference of the inverse kinematics."""
    for pose in _poses(3, 1):
        for mode in mm.working_modes(elbow):
            q = mm.inverse_kinematics(elbow, pose, mode)
            assert _chain_residual(elbow, q) < 1e-14
            # the two actuators are the two links' absolute angles, read off the generated joints' positions
            base, elbow_point, end = mm.joint_positions(elbow, q)[0, :3]
            angles = [np.arctan2(*(elbow_point - base)[::-1]), np.arctan2(*(end - elbow_point)[::-1])]
            assert np.abs(np.angle(np.exp(1j * (q[:2] - angles)))).max() < 1e-12
        assert _jacobian_error(elbow, pose, MODE) < 1e-8


def test_forward_kinematics_from_either_actuator_of_the_leg_finds_the_pose(elbow):
    """From (a1, a3, a4), the paper's 3-RRR (the default: each leg's own actuator), and from (a2, a3, a4), leg 1 held
    by its elbow: the pose the inverse kinematics started from, the other actuator's residual zero, or its offset
    when it reads otherwise. Two actuators of one leg are refused in one line naming them."""
    pose = np.array([0.27, 0.16, -0.2])
    q = mm.inverse_kinematics(elbow, pose, MODE)
    for subset, offset in ((None, [0.0, 0.01, 0.0, 0.0]), ((1, 2, 3), [-0.01, 0.0, 0.0, 0.0])):
        found = pkmlab.forward_kinematics(elbow, q[:4], actuators=subset)
        assert found.solved == ((0, 2, 3) if subset is None else subset)
        nearest = _nearest(found, pose)
        assert np.abs(found.pose[nearest] - pose).max() < 1e-12
        assert np.abs(found.residual[nearest]).max() < 1e-12
        assert all(_chain_residual(elbow, qj) < 1e-12 for qj in found.q[:len(found)])
        moved = pkmlab.forward_kinematics(elbow, q[:4] + offset, actuators=subset)  # the other actuator misread
        nearest = _nearest(moved, pose)
        assert np.abs(moved.pose[nearest] - pose).max() < 1e-12
        assert moved.residual[nearest] == pytest.approx(offset, abs=1e-12)
    with pytest.raises(InvalidParameterError, match=r"^actuators a1 and a2 are both leg 1's: forward kinematics "
                                                    r"from a subset takes one actuator per leg$"):
        pkmlab.forward_kinematics(elbow, q[:4], actuators=(0, 1, 2))


def _nearest(found, pose) -> int:
    """The assembly mode of ``found`` nearest ``pose``."""
    return int(np.argmin(np.abs(found.pose[:len(found)] - pose).max(axis=1)))


def test_the_command_line_reports_the_residual_of_the_actuator_it_does_not_solve(capsys):
    """``pkmlab fk`` of the elbow machine solves a1, a3, a4 (each leg's own): its table's residual column is a2's,
    carrying the offset given to a2."""
    from pkmlab.cli import main

    q = mm.inverse_kinematics(pkmlab.load(ELBOW), [0.27, 0.16, -0.2], MODE)
    theta = q[:4] + [0.0, 0.01, 0.0, 0.0]
    assert main(["fk", *map(str, theta), "--mechanism", str(ELBOW)]) == 0
    out = capsys.readouterr().out
    header = next(line for line in out.splitlines() if line.startswith("#"))
    assert header.split()[-1] == "residual2"
    rows = [line.split() for line in out.splitlines() if line[:1].isdigit()]
    assert any(abs(float(row[-1]) - 0.01) < 1e-9 for row in rows)


def _mujoco_accelerations(model, q, q_dot, tau, legs: int):
    from test_mujoco_export import _hard_solve

    m, d = mx.load_mujoco(model)
    assert m.nu == model.n_actuators
    d.qpos[:] = mx.qpos_from_q(model, q)
    d.qvel[:] = mx.qvel_from_q_dot(model, q, q_dot)
    d.ctrl[:] = tau
    mujoco.mj_forward(m, d)
    return mx.q_dot_from_qvel(model, q, _hard_solve(m, d, legs))


def test_mujocos_hard_constraint_solve_gives_the_accelerations_of_the_distributed_efforts(elbow):
    """Efforts distributed for a platform acceleration (a preload added): MuJoCo's accelerations of the exported
    model, its elbow motor on a tendon, are pkmlab's to 1e-12, and pkmlab's give the platform the acceleration asked
    for."""
    rng = np.random.default_rng(4)
    for pose in _poses(3, 4):
        q = mm.inverse_kinematics(elbow, pose, MODE)
        pose_dot = rng.normal(0.0, [0.2, 0.2, 1.0])
        q_dot = pkmlab.pose_coordinate_jacobian(elbow, q) @ pose_dot
        model_x = pkmlab.pose_space_model(elbow, q, pose_dot)
        pose_ddot = np.array([0.5, -0.3, 2.0])
        force = model_x.M @ pose_ddot + model_x.c + model_x.g
        tau = pkmlab.distribute_efforts(model_x.W, force, "preload", preload=[1.0, -1.0, 1.0, -1.0]).tau
        ours = pkmlab.constrained_dynamics(elbow, q, q_dot, tau).q_ddot
        assert np.abs(mm.pose_of(elbow, ours) - pose_ddot).max() < 1e-12 * np.abs(pose_ddot).max()
        theirs = _mujoco_accelerations(elbow, q, q_dot, tau, 3)
        assert np.abs(theirs - ours).max() < 1e-12 * (1 + np.abs(ours).max())


def test_the_driven_elbow_carries_the_platform_through_the_3rrrs_forward_singularity(elbow):
    """``examples/mechanisms/3rrr_elbow_motion.toml``: the platform turned from -0.6 to -1.3 rad at the middle of
    the workspace, where the paper's 3-RRR's ``S`` changes sign (its run of this path is refused before running).
    The machine whose first elbow is driven keeps its actuation measure above 2 all along (measured 2.05), and its
    computed-torque run tracks the turn to the order of the paper's nominal case (path error below it, orientation
    error within 2.5 times) with efforts below 0.2 N m, its legs on their loop closures."""
    paper = pkmlab.load("paper")
    s = np.linspace(0.0, 1.0, 101)
    poses = np.column_stack([np.full_like(s, 0.26), np.full_like(s, 0.15), -0.6 - 0.7 * s])
    measure = pkmlab.singularity_measure(paper, np.array([mm.inverse_kinematics(paper, p, MODE) for p in poses]))
    assert measure.min() < 0 < measure.max()
    q = np.array([mm.inverse_kinematics(elbow, p, MODE) for p in poses])
    assert pkmlab.actuation_singularity_measure(elbow, q).min() > 2.0
    scenario = pkmlab.load_scenario(CATALOGUE / "3rrr_elbow_motion.toml")
    with pytest.raises(SingularityError, match="gain-type singularity"):
        pkmlab.simulate(scenario.replace(model=paper))
    result = pkmlab.simulate(scenario)
    run, nominal = result.summary(), pkmlab.simulate(pkmlab.paper_scenario("nominal")).summary()
    assert run["max_path_error_m"] < nominal["max_path_error_m"]
    assert run["max_orientation_error_rad"] < 2.5 * nominal["max_orientation_error_rad"]
    assert max(run["peak_effort"]) < 0.2 and run["min_abs_S"] > 2.0
    assert max(_chain_residual(elbow, qk) for qk in result.q[::50]) < 1e-12
    for k in range(0, len(result.t), 100):  # the least 2-norm: no internal effort
        W = pkmlab.pose_coordinate_jacobian(elbow, result.q[k])[:4]
        internal = np.linalg.svd(W.T)[2][-1]
        assert abs(internal @ result.tau[k]) <= 1e-12 * np.abs(result.tau[k]).max()


def test_the_mujoco_plant_runs_the_driven_elbow_as_pkmlabs_plant_does():
    """The same scenario on MuJoCo (four motors, the elbow's on its tendon; the loop closures MuJoCo's stiff
    equality constraints): the platform within 1e-5 m and 1e-5 rad of pkmlab's plant, the efforts within 1e-4 of
    their peak."""
    from pkmlab.interop.mujoco_plant import simulate_mujoco

    scenario = pkmlab.load_scenario(CATALOGUE / "3rrr_elbow_motion.toml")
    ours, theirs = pkmlab.simulate(scenario), simulate_mujoco(scenario)
    assert np.linalg.norm(ours.pose[:, :2] - theirs.pose[:, :2], axis=1).max() < 1e-5
    assert np.abs(ours.pose[:, 2] - theirs.pose[:, 2]).max() < 1e-5
    assert np.abs(ours.tau - theirs.tau).max() < 1e-4 * np.abs(ours.tau).max()


@pytest.fixture(scope="module")
def prrr_two():
    """The catalogue's 3-PRRR with its first leg's elbow driven too: leg 1 ``P*R*R*R`` moves its base (a1) and
    carries two actuators in its ordinary part (a2, a3)."""
    m = load_mechanism(CATALOGUE / "3prrr.toml")
    leg = m.legs[0]
    joints = (*leg.joints[:2], Joint("R", True), leg.joints[3])
    return pkmlab.load(replace(m, legs=(replace(leg, joints=joints), *m.legs[1:])))


def test_a_leg_may_move_its_base_and_carry_two_actuators(prrr_two):
    """Kinematic and actuation redundancy at once: the sliders are controlled coordinates, the elbow an extra
    actuator; its legs close, MuJoCo's hard-constraint accelerations are pkmlab's to 1e-12, and forward kinematics
    solves from the sliders and one actuator of each leg's ordinary part."""
    m = prrr_two.description
    assert m.notation == "P*R*R*R + P*R*RR + P*R*RR" and prrr_two.n_actuators == 7 and m.dof == 6
    assert m.pose_names == ("x", "y", "alpha", "a1", "a4", "a6") and m.actuation_redundancy == 1
    assert [(leg.moving_base, leg.actuated, leg.extra_actuated) for leg in m.legs] == [(1, 1, (2,)), (1, 1, ()),
                                                                                      (1, 1, ())]
    rng = np.random.default_rng(6)
    for pose in ([0.26, 0.17, 0.1, 0.08, 0.12, 0.10], [0.24, 0.15, -0.2, 0.12, 0.06, 0.09]):
        q = mm.inverse_kinematics(prrr_two, pose, MODE)
        assert _chain_residual(prrr_two, q) < 1e-14
        q_dot = pkmlab.pose_coordinate_jacobian(prrr_two, q) @ rng.normal(0.0, 0.1, 6)
        tau = rng.normal(0.0, 1.0, 7)
        ours = pkmlab.constrained_dynamics(prrr_two, q, q_dot, tau).q_ddot
        theirs = _mujoco_accelerations(prrr_two, q, q_dot, tau, 3)
        assert np.abs(theirs - ours).max() < 1e-12 * (1 + np.abs(ours).max())
        found = pkmlab.forward_kinematics(prrr_two, q[:7])
        nearest = _nearest(found, pose)
        assert np.abs(found.pose[nearest] - pose).max() < 1e-12 and np.abs(found.residual[nearest]).max() < 1e-12
    found = pkmlab.forward_kinematics(prrr_two, q[:7], actuators=(0, 1, 3, 4, 5, 6))  # the 3-PRRR's actuators
    nearest = _nearest(found, pose)
    assert np.abs(found.pose[nearest] - pose).max() < 1e-12 and np.abs(found.residual[nearest]).max() < 1e-12
    with pytest.raises(InvalidParameterError, match=r"^actuators a2 and a3 are both leg 1's: forward kinematics from "
                                                    r"a subset takes one actuator per leg$"):
        pkmlab.forward_kinematics(prrr_two, q[:7], actuators=(0, 1, 2, 4, 5, 6))


@pytest.fixture(scope="module")
def knee():
    return pkmlab.load(KNEE)


def _spatial_residual(model, q) -> float:
    """max |leg end - attachment point| of ``q`` by the readable chain (:func:`leg_frames`) and the platform's whole
    pose."""
    m = model.description
    whole = full_poses(m, q[-len(m.platform.q_pose_names):])
    return max(float(np.abs(leg_frames(leg, values)[-1][0] - spatial.attachment_point(m, i, whole)).max())
               for i, (leg, values) in enumerate(zip(m.legs, mm.leg_joint_values(model, q), strict=True)))


def test_a_spatial_leg_may_carry_two_actuators(knee):
    """The 3-RRS with its first knee driven: four actuators (the knee a relative angle), its computed mobility the
    platform's three controlled coordinates; in every working mode it reaches its legs close by the readable chain,
    and the knee's actuator is the angle the link turns from the crank about the hinge, read off the generated
    joints' positions; ``W`` is the central difference of the inverse kinematics."""
    m = knee.description
    assert m.notation == "R*R*S + R*RS + R*RS" and knee.n_actuators == 4 and m.dof == 3
    assert m.actuation_redundancy == 1 and m.pose_names == ("z", "roll", "pitch")
    assert knee.coordinates[:4] == ("a1", "a2", "a3", "a4") and m.actuators[:2] == ((0, 0), (0, 1))
    assert mobility(m).mobility == 3
    pose = np.array([0.34, 0.05, -0.03])
    hinge = np.array(m.legs[0].joints[1].axes[0])
    reached = 0
    for mode in mm.working_modes(knee):
        try:
            q = mm.inverse_kinematics(knee, pose, mode)
        except pkmlab.UnreachablePoseError:
            continue
        reached += 1
        assert _spatial_residual(knee, q) < 1e-12
        base, knee_point, end = mm.joint_positions(knee, q)[0, :3]
        crank, link = knee_point - base, end - knee_point
        turn = np.arctan2(hinge @ np.cross(crank, link), crank @ link) - np.pi / 2  # (at zero: the link upright)
        assert abs(np.angle(np.exp(1j * (q[1] - turn)))) < 1e-12
    assert reached == 8  # (measured: every mode reaches this pose)
    assert _jacobian_error(knee, pose, (-1, -1, -1)) < 1e-7


def test_the_spatial_leg_of_two_actuators_is_modelled_as_mujoco_says_and_solved_as_the_3rrs(knee):
    """MuJoCo's hard-constraint joint accelerations (the legs' joints map linearly; the platform's orientation
    rates do not) under any efforts of the four actuators are pkmlab's to 1e-12; forward kinematics from the three
    legs' own actuators (the 3-RRS's) finds the pose, the knee's residual zero."""
    rng = np.random.default_rng(8)
    pose = np.array([0.34, 0.05, -0.03])
    q = mm.inverse_kinematics(knee, pose, (-1, -1, -1))
    q_dot = pkmlab.pose_coordinate_jacobian(knee, q) @ rng.normal(0.0, 0.1, 3)
    for tau in rng.normal(0.0, 1.0, (3, 4)):
        ours = pkmlab.constrained_dynamics(knee, q, q_dot, tau).q_ddot
        theirs = _mujoco_accelerations(knee, q, q_dot, tau, 3)
        joints = len(q) - len(knee.description.platform.q_pose_names)
        assert np.abs(theirs[:joints] - ours[:joints]).max() < 1e-12 * (1 + np.abs(ours).max())
    found = pkmlab.forward_kinematics(knee, q[:4])
    nearest = _nearest(found, pose)
    assert np.abs(found.pose[nearest] - pose).max() < 1e-10 and np.abs(found.residual[nearest]).max() < 1e-10


def test_the_knee_driven_3rrs_runs_as_the_3rrs_does_and_as_mujoco_runs_it(knee):
    """``examples/mechanisms/3rrs_knee_motion.toml`` (the 3-RRS's default motion, the same sampling): its path error
    within 10 % of the 3-RRS's, its orientation error within twice (measured: 2.88e-6 m against 2.90e-6 m, 1.54e-5
    rad against 9.9e-6 rad), its legs on their loop closures, its least-norm efforts free of internal parts;
    MuJoCo's plant runs it to 1e-6 m and 1e-5 rad of pkmlab's, the efforts within 1e-4 of their peak."""
    from pkmlab.interop.mujoco_plant import simulate_mujoco

    scenario = pkmlab.load_scenario(CATALOGUE / "3rrs_knee_motion.toml")
    result = pkmlab.simulate(scenario)
    twin = pkmlab.simulate(pkmlab.load_scenario(CATALOGUE / "3rrs_motion.toml")).summary()
    run = result.summary()
    assert run["max_path_error_m"] < 1.1 * twin["max_path_error_m"]
    assert run["max_orientation_error_rad"] < 2.0 * twin["max_orientation_error_rad"]
    assert max(_spatial_residual(knee, qk) for qk in result.q[::100]) < 1e-10
    for k in range(0, len(result.t), 200):
        W = pkmlab.pose_coordinate_jacobian(knee, result.q[k])[:4]
        internal = np.linalg.svd(W.T)[2][-1]
        assert abs(internal @ result.tau[k]) <= 1e-12 * np.abs(result.tau[k]).max()
    theirs = simulate_mujoco(scenario)
    assert np.abs(result.pose[:, 0] - theirs.pose[:, 0]).max() < 1e-6
    assert np.abs(result.pose[:, 1:] - theirs.pose[:, 1:]).max() < 1e-5
    assert np.abs(result.tau - theirs.tau).max() < 1e-4 * np.abs(result.tau).max()


@pytest.mark.parametrize("name", ["3rrr_elbow_motion.toml", "3rrs_knee_motion.toml"])
def test_a_run_of_legs_of_two_actuators_is_rebuilt_for_its_views_from_its_recorded_poses(name, tmp_path):
    """A redundantly actuated machine's run folder (``pkmlab simulate --no-figures``), read for its views
    (``pkmlab view``): the configurations rebuilt from its recorded poses are the run's own, every joint where the
    run put it; a recorded actuator the poses do not hold is refused in one line naming the sample."""
    from pkmlab.cli import main
    from pkmlab.errors import AssemblyError
    from pkmlab.views.animation import rebuild_configurations
    from pkmlab.views.folder import read_view

    scenario = pkmlab.load_scenario(CATALOGUE / name)
    result = pkmlab.simulate(scenario)
    out = tmp_path / "run"
    assert main(["simulate", str(CATALOGUE / name), "--out", str(out), "--no-figures"]) == 0
    view = read_view(out, "run")
    joints = mm.joint_positions(scenario.model, result.q[view.samples])
    assert np.abs(view.joints - joints).max() < 1e-8  # (the CSV's printed digits)
    theta = result.theta.copy()
    theta[7, 1] += 1e-3
    with pytest.raises(AssemblyError, match=r"^sample 8: the recorded actuators do not hold the recorded pose"):
        rebuild_configurations(scenario.model, theta, result.pose[0], result.pose)


def test_legs_whose_actuators_cannot_hold_them_are_refused_naming_the_leg():
    """A leg whose joints beyond an ordinary leg's are passive, one whose ordinary part has no actuator, and a
    spatial leg whose universal joint is starred: each one line naming the leg."""
    m = load_mechanism(CATALOGUE / "3prrr.toml")
    leg = m.legs[2]
    for joints, expected in (
            ((Joint("P", True, leg.joints[0].axis), Joint("R"), Joint("R"), Joint("R")),
             r"leg 3 \(P\*RRR\): the ordinary leg its first joint moves \(RRR\) has no actuated joint"),
            ((Joint("P", False, leg.joints[0].axis), Joint("R", True), Joint("R", True), Joint("R")),
             r"leg 3 \(PR\*R\*R\) has 4 joints, 1 more than an ordinary leg: the first, moving the ordinary leg's "
             r"base, must be actuated")):
        with pytest.raises(InvalidParameterError, match=expected) as refused:
            replace(m, legs=(*m.legs[:2], replace(leg, joints=joints)))
        assert "\n" not in str(refused.value)
    delta = pkmlab.load("delta").description
    leg = delta.legs[1]
    joints = (leg.joints[0], SpatialJoint("U", True, leg.joints[1].axes), leg.joints[2])
    with pytest.raises(InvalidParameterError, match=r"^leg 2, joint 2: an actuated U joint; only R and P joints are "
                                                    r"actuated"):
        replace(delta, legs=(delta.legs[0], replace(leg, joints=joints), delta.legs[2]))
