"""A redundantly actuated machine: the 4-RRR of the catalogue (``examples/mechanisms/4rrr.toml``), four actuated
R*RR legs for the platform's three coordinates.

Independent checks: the loop closures by the readable chain of :func:`~pkmlab.description.mechanism.leg_chain`;
the actuation Jacobian against central differences of the inverse kinematics; the pose-space dynamics against the
full model's saddle-point solve (multipliers, no reduction) and against MuJoCo's hard-constraint solve of the
exported model; the distributions against their optimality conditions written out separately (the weighted
2-norm's Lagrange system, the limited 2-norm by a scalar minimisation over the internal effort); forward kinematics
from each subset of three actuators against the pose the inverse kinematics started from; the actuation's
singularity measure against the sub-machine's own measure ``S`` of the generated kernels.
"""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import pkmlab
from pkmlab.description.mechanism import attachment_point, leg_chain
from pkmlab.errors import InvalidParameterError, SingularityError
from pkmlab.interop import mujoco_export as mx
from pkmlab.model import mechanism_model as mm

RRRR = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "4rrr.toml"
MODE = (1, -1, 1, 1)
SUBSETS = list(itertools.combinations(range(4), 3))


@pytest.fixture(scope="module")
def rrrr():
    return pkmlab.load(RRRR)


def _poses(count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.22, 0.30, count), rng.uniform(0.22, 0.30, count),
                            rng.uniform(-0.4, 0.4, count)])


def _chain_residual(model, q) -> float:
    m = model.description
    pose = mm.pose_of(model, q)
    return max(float(np.abs(np.subtract(leg_chain(leg, values)[-1][0], attachment_point(m, i, pose))).max())
               for i, (leg, values) in enumerate(zip(m.legs, mm.leg_joint_values(model, q), strict=True)))


def _states(model, count: int, seed: int):
    """Configurations in working mode :data:`MODE` with pose rates and the coordinates' rates they imply."""
    rng = np.random.default_rng(seed)
    for pose in _poses(count, seed):
        q = mm.inverse_kinematics(model, pose, MODE)
        pose_dot = rng.normal(0.0, [0.2, 0.2, 1.0])
        yield q, pose_dot, pkmlab.pose_coordinate_jacobian(model, q) @ pose_dot


def test_it_has_one_actuator_more_than_its_degrees_of_freedom(rrrr):
    m = rrrr.description
    assert (m.dof, rrrr.n_actuators, m.actuation_redundancy) == (3, 4, 1)
    assert rrrr.coordinates == ("a1", "a2", "a3", "a4", "q1_2", "q2_2", "q3_2", "q4_2", "x", "y", "alpha")
    assert len(mm.working_modes(rrrr)) == 16


def test_inverse_kinematics_closes_every_leg_in_every_working_mode(rrrr):
    solution = pkmlab.inverse_kinematics(rrrr, _poses(3, 1))
    assert solution.q.shape == (3, 16, 11) and np.all(solution.unreachable_legs == 0)
    for q in solution.q.reshape(-1, 11):
        assert _chain_residual(rrrr, q) < 1e-14
    # its S is its actuation's measure: at least that of any three of its actuators
    for subset in SUBSETS:
        assert np.all(solution.S >= pkmlab.actuation_singularity_measure(rrrr, solution.q, actuators=list(subset)))


def _assert_w_is_the_derivative_of_inverse_kinematics(model, pose, mode, q):
    """``W`` at ``q`` (the configuration of ``pose``) against central differences of the actuators' inverse
    kinematics."""
    h, na = 1e-6, model.n_actuators
    differences = np.column_stack([(mm.inverse_kinematics(model, pose + h * e, mode)[:na]
                                    - mm.inverse_kinematics(model, pose - h * e, mode)[:na]) / (2 * h)
                                   for e in np.eye(model.dof)])
    W = pkmlab.actuation_jacobian(model, q)
    assert np.abs(W - differences).max() < 1e-7 * (1 + np.abs(W).max())


def test_the_actuation_jacobian_is_the_derivative_of_inverse_kinematics(rrrr):
    for pose in _poses(4, 2):
        q = mm.inverse_kinematics(rrrr, pose, MODE)
        _assert_w_is_the_derivative_of_inverse_kinematics(rrrr, pose, MODE, q)
        jq = pkmlab.pose_coordinate_jacobian(rrrr, q)
        assert np.abs(pkmlab.constraint_jacobian(rrrr, q) @ jq).max() < 1e-12  # tangent to the loop closures


def test_the_fourth_leg_keeps_the_machine_away_from_the_singularities_of_any_three(rrrr):
    """Along a sweep of the orientation, the sub-machine of legs 1-3 (a 3-RRR of its own) crosses a forward
    singularity — its own measure S of the generated kernels changes sign — where its rows of W lose rank; the
    four legs' measure stays well above zero, and above every sub-machine's everywhere."""
    sub = pkmlab.MechanismModel.from_description(_legs(rrrr, (0, 1, 2)))
    alphas = np.linspace(-1.2, 1.2, 241)
    qs = np.array([mm.inverse_kinematics(rrrr, [0.26, 0.26, a], MODE) for a in alphas])
    own = np.array([pkmlab.singularity_measure(sub, np.r_[q[:3], q[4:7], q[8:]]) for q in qs])
    crossing = np.flatnonzero(np.diff(np.sign(own)) != 0)
    assert crossing.size >= 1, "the sweep crosses no singularity of legs 1-3"
    rows = pkmlab.actuation_singularity_measure(rrrr, qs, actuators=[0, 1, 2])
    every = pkmlab.actuation_singularity_measure(rrrr, qs)
    for k in crossing:  # where S changes sign, the sub-machine's rows of W are (near) rank-deficient
        assert min(rows[k], rows[k + 1]) < 0.05 * every[k]
    assert every.min() > 0.5
    for subset in SUBSETS:
        assert np.all(every >= pkmlab.actuation_singularity_measure(rrrr, qs, actuators=list(subset)) - 1e-12)


def test_its_maps_show_the_fourth_leg_removing_every_three_legs_singularities(rrrr):
    """Over the workspace at one orientation, each machine of three of the legs comes near a forward singularity
    (its measure near zero somewhere) while the four legs' stays far from it, at every point above each three's."""
    full = pkmlab.singularity_map(rrrr, alpha=0.3, mode=(1, 1, 1, 1), resolution=25)
    reachable = full.reachable
    assert reachable.sum() > 50 and np.nanmin(full.S) > 1.0
    for subset in SUBSETS:
        three = pkmlab.singularity_map(rrrr, alpha=0.3, mode=(1, 1, 1, 1), resolution=25, actuators=list(subset))
        assert np.array_equal(three.reachable, reachable)
        assert np.all(full.S[reachable] >= three.S[reachable] - 1e-12)
        assert np.nanmin(three.S) < 0.05 * np.nanmin(full.S), subset
    with pytest.raises(InvalidParameterError, match="actuators must be at least 3 distinct indices from 0 to 3"):
        pkmlab.singularity_map(rrrr, actuators=[0, 1, 4])


def _legs(model, legs):
    import dataclasses

    m = model.description
    platform = dataclasses.replace(m.platform, attachments=tuple(m.platform.attachments[i] for i in legs))
    return dataclasses.replace(m, legs=tuple(m.legs[i] for i in legs), platform=platform)


def test_pose_space_dynamics_give_the_saddle_point_solves_accelerations(rrrr):
    """``Mx ẍ + cx + gx = Wᵀ τ``: efforts distributed for an acceleration give it back from the full model's
    saddle-point system with the loop-closure multipliers, whatever internal efforts they carry."""
    rng = np.random.default_rng(3)
    for q, pose_dot, q_dot in _states(rrrr, 4, 3):
        model_x = pkmlab.pose_space_model(rrrr, q, pose_dot)
        assert np.allclose(model_x.M, model_x.M.T, atol=1e-15) and np.all(np.linalg.eigvalsh(model_x.M) > 0)
        pose_ddot = rng.normal(0.0, [1.0, 1.0, 5.0])
        force = model_x.M @ pose_ddot + model_x.c + model_x.g
        for shared in (pkmlab.distribute_efforts(model_x.W, force),
                       pkmlab.distribute_efforts(model_x.W, force, "preload", preload=[2.0, -2.0, 2.0, -2.0])):
            motion = pkmlab.constrained_dynamics(rrrr, q, q_dot, shared.tau)
            assert np.abs(mm.pose_of(rrrr, motion.q_ddot) - pose_ddot).max() < 1e-12 * (1 + np.abs(pose_ddot).max())


def test_mujocos_hard_constraint_solve_gives_the_same_accelerations_under_distributed_efforts(rrrr):
    from test_mujoco_export import _hard_solve

    m, d = mx.load_mujoco(rrrr)
    assert m.nu == 4
    for q, pose_dot, q_dot in _states(rrrr, 3, 4):
        model_x = pkmlab.pose_space_model(rrrr, q, pose_dot)
        force = model_x.M @ np.array([0.5, -0.3, 2.0]) + model_x.c + model_x.g
        tau = pkmlab.distribute_efforts(model_x.W, force, "preload", preload=[1.0, -1.0, 1.0, -1.0]).tau
        d.qpos[:] = mx.qpos_from_q(rrrr, q)
        d.qvel[:] = mx.qvel_from_q_dot(rrrr, q, q_dot)
        d.ctrl[:] = tau
        mujoco.mj_forward(m, d)
        theirs = mx.q_dot_from_qvel(rrrr, q, _hard_solve(m, d, 4))
        ours = pkmlab.constrained_dynamics(rrrr, q, q_dot, tau).q_ddot
        assert np.abs(theirs - ours).max() < 1e-12 * (1 + np.abs(ours).max())


@pytest.fixture(scope="module")
def wrench(rrrr):
    q = mm.inverse_kinematics(rrrr, [0.27, 0.25, 0.2], MODE)
    model_x = pkmlab.pose_space_model(rrrr, q, [0.1, -0.1, 0.5])
    return model_x.W, model_x.M @ np.array([1.0, 0.5, -3.0]) + model_x.c + model_x.g


def test_every_distribution_exerts_the_force(wrench):
    W, force = wrench
    for method, options in (("minimum_norm", {}), ("weighted", {"weights": [1.0, 2.0, 4.0, 8.0]}),
                            ("minimum_peak", {}), ("preload", {"preload": [1.0, 1.0, -1.0, 3.0]})):
        for limits in (None, 1.02 * pkmlab.distribute_efforts(W, force, "minimum_peak").peak):
            shared = pkmlab.distribute_efforts(W, force, method, limits=limits, **options)
            assert np.abs(W.T @ shared.tau - force).max() < 1e-12 * (1 + np.abs(force).max()), (method, limits)
            assert np.abs(W.T @ shared.internal).max() < 1e-12 * (1 + np.abs(shared.tau).max())
            if limits is not None:
                assert shared.peak <= limits * (1 + 1e-12), (method, shared.tau)


def test_the_minimum_norm_is_the_pseudo_inverses_and_the_peak_no_larger(wrench):
    W, force = wrench
    least = pkmlab.distribute_efforts(W, force)
    assert np.abs(least.tau - np.linalg.pinv(W.T) @ force).max() < 1e-12 * np.abs(least.tau).max()
    assert np.abs(least.internal).max() < 1e-12 * np.abs(least.tau).max()
    assert pkmlab.distribute_efforts(W, force, "minimum_peak").peak <= least.peak


def test_the_weighted_distribution_solves_its_lagrange_system(wrench):
    W, force = wrench
    weights = np.array([1.0, 2.0, 4.0, 8.0])
    kkt = np.block([[np.diag(weights), W], [W.T, np.zeros((3, 3))]])
    expected = np.linalg.solve(kkt, np.r_[np.zeros(4), force])[:4]
    shared = pkmlab.distribute_efforts(W, force, "weighted", weights=weights)
    assert np.abs(shared.tau - expected).max() < 1e-12 * np.abs(expected).max()


def test_the_limited_two_norm_is_the_least_norm_within_the_limits(wrench):
    """One internal effort: the efforts are ``τ_p + z n``; the least norm within the limits, found over ``z`` by a
    bounded scalar minimisation of its own, is the distribution's."""
    W, force = wrench
    free = pkmlab.distribute_efforts(W, force)
    limit = 0.5 * (free.peak + pkmlab.distribute_efforts(W, force, "minimum_peak").peak)
    shared = pkmlab.distribute_efforts(W, force, limits=limit)
    n = free.null_space[:, 0]
    interval = [(-limit - t) / c if c > 0 else (limit - t) / c for t, c in zip(free.tau, n, strict=True)]
    upper = [(limit - t) / c if c > 0 else (-limit - t) / c for t, c in zip(free.tau, n, strict=True)]
    best = minimize_scalar(lambda z: float(np.sum((free.tau + z * n) ** 2)), bounds=(max(interval), min(upper)),
                           method="bounded", options={"xatol": 1e-14})
    assert np.abs(shared.tau - (free.tau + best.x * n)).max() < 1e-7 * limit
    assert shared.peak == pytest.approx(limit, rel=1e-12)  # the free optimum was beyond it: a limit is active


def test_the_preload_is_the_internal_part_nearest_the_one_asked_for(wrench):
    W, force = wrench
    preload = np.array([3.0, -1.0, 2.0, -4.0])
    shared = pkmlab.distribute_efforts(W, force, "preload", preload=preload)
    n = shared.null_space
    assert np.abs(n.T @ (shared.tau - pkmlab.distribute_efforts(W, force).tau) - n.T @ preload).max() < 1e-12 * 4


def test_limits_no_efforts_can_hold_are_refused_naming_the_actuator(wrench):
    W, force = wrench
    peak = pkmlab.distribute_efforts(W, force, "minimum_peak").peak
    for method in ("minimum_norm", "minimum_peak"):
        with pytest.raises(InvalidParameterError) as refused:
            pkmlab.distribute_efforts(W, force, method, limits=0.9 * peak, where="t = 0.25 s: ")
        message = str(refused.value)
        assert "\n" not in message
        assert message.startswith("t = 0.25 s: the effort limits cannot be held: actuator a")
    with pytest.raises(InvalidParameterError, match="weights must be 4 positive numbers"):
        pkmlab.distribute_efforts(W, force, "weighted", weights=[1.0, -1.0, 1.0, 1.0])
    with pytest.raises(InvalidParameterError, match="method must be .minimum_norm. or"):
        pkmlab.distribute_efforts(W, force, "fastest")
    with pytest.raises(SingularityError, match="forward singularity"):
        pkmlab.distribute_efforts(np.c_[W[:, :2], W[:, 0] + W[:, 1]], force)


def test_the_infeasible_line_names_the_actuator_and_what_it_would_need():
    """Two actuators sharing one force of 3: each would need 1.5 at best. Both limited to 1 (one of them from above
    only), the line names the first and the second as far beyond (limits that conflict are as far beyond each other
    at the least violation)."""
    W = np.array([[1.0], [1.0]])
    for limits in (1.0, [(-1.0, 1.0), (-np.inf, 1.0)]):
        with pytest.raises(InvalidParameterError) as refused:
            pkmlab.distribute_efforts(W, [3.0], limits=limits)
        assert str(refused.value) == ("the effort limits cannot be held: actuator a1 needs at least 1.5 against its "
                                      "upper limit 1 (as far beyond theirs: a2) for the requested forces")
    shared = pkmlab.distribute_efforts(W, [3.0], "minimum_peak", limits=[(-np.inf, np.inf), (-1.0, 1.0)])
    assert shared.tau == pytest.approx([2.0, 1.0], abs=1e-12)  # a1 free of limits takes the rest


def test_the_preload_within_limits_is_the_nearest_efforts_to_the_preloaded_ones():
    """One internal effort ``n``: the efforts are ``τ_p + z n``; within the limits, the nearest to the preloaded
    target is the target's ``z`` clamped to the interval the limits leave."""
    W = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    force, limits = np.array([3.0, 0.0]), np.array([(-10.0, 1.8), (-10.0, 10.0), (-10.0, 10.0)])
    least = pkmlab.distribute_efforts(W, force)
    n = least.null_space[:, 0]
    wanted = 0.0346 * n
    shared = pkmlab.distribute_efforts(W, force, "preload", preload=wanted, limits=limits)
    z_target = n @ wanted
    ends = [((limits[i, 0] if c > 0 else limits[i, 1]) - least.tau[i]) / c for i, c in enumerate(n)]
    ends_up = [((limits[i, 1] if c > 0 else limits[i, 0]) - least.tau[i]) / c for i, c in enumerate(n)]
    z = min(max(z_target, max(ends)), min(ends_up))
    assert np.abs(shared.tau - (least.tau + z * n)).max() < 1e-12
    assert shared.tau[0] == pytest.approx(1.8, abs=1e-12)  # the limit is active: the preload is reduced


def test_an_actuation_measure_of_fewer_actuators_than_degrees_of_freedom_is_refused(rrrr):
    q = mm.inverse_kinematics(rrrr, [0.26, 0.26, 0.0], MODE)
    for bad in ([2], [0, 1], [0, 0, 1], [True, 1, 2]):
        with pytest.raises(InvalidParameterError, match="actuators must be at least 3 distinct indices"):
            pkmlab.actuation_singularity_measure(rrrr, q, actuators=bad)


def test_forward_kinematics_from_each_subset_finds_the_pose_and_reports_the_others_residual(rrrr):
    pose = np.array([0.27, 0.25, 0.2])
    q = mm.inverse_kinematics(rrrr, pose, MODE)
    for subset in SUBSETS:
        found = pkmlab.forward_kinematics(rrrr, q[:4], actuators=subset)
        mode = int(np.argmin(np.abs(found.pose[:len(found)] - pose).max(axis=1)))
        assert np.abs(found.pose[mode] - pose).max() < 1e-10
        assert np.abs(found.residual[mode]).max() < 1e-10
        for qj in found.q[:len(found)]:
            assert _chain_residual(rrrr, qj) < 1e-12
    moved = q[:4] + np.array([0.0, 0.0, 0.0, 0.01])  # a fourth reading inconsistent with the first three
    found = pkmlab.forward_kinematics(rrrr, moved)
    mode = int(np.argmin(np.abs(found.pose[:len(found)] - pose).max(axis=1)))
    assert np.abs(found.pose[mode] - pose).max() < 1e-10
    assert found.residual[mode] == pytest.approx([0.0, 0.0, 0.0, 0.01], abs=1e-10)
    with pytest.raises(InvalidParameterError, match="actuators must be 3 distinct indices"):
        pkmlab.forward_kinematics(rrrr, q[:4], actuators=[0, 0, 1])


def _calibrate(model, q):
    from pkmlab.algorithms.calibration import calibrate

    return calibrate(model, q[None, :4], mm.pose_of(model, q)[None, :2])


@pytest.mark.parametrize("call", [
    lambda model, q: pkmlab.branch_following(model, q, q[:4]),
    lambda model, q: pkmlab.actuator_space_model(model, q, np.zeros(4)),
    lambda model, q: pkmlab.velocity_jacobian(model, q),
    lambda model, q: pkmlab.singularity_measure(model, q),
    lambda model, q: pkmlab.singularity_kinds(model, q),
    lambda model, q: _calibrate(model, q),
], ids=["branch_following", "actuator_space_model", "velocity_jacobian", "singularity_measure", "singularity_kinds",
        "calibrate"])
def test_what_takes_the_actuators_as_coordinates_is_refused_in_one_line(rrrr, call):
    q = mm.inverse_kinematics(rrrr, [0.26, 0.26, 0.0], MODE)
    with pytest.raises(InvalidParameterError) as refused:
        call(rrrr, q)
    message = str(refused.value)
    assert "\n" not in message and "4 actuators are 1 more than its 3 degrees of freedom" in message


def test_the_command_line_solves_and_checks_its_actuators(capsys):
    from pkmlab.cli import main

    q = mm.inverse_kinematics(pkmlab.load(RRRR), [0.27, 0.25, 0.2], MODE)
    theta = [*q[:3], q[3] + 0.01]
    assert main(["fk", *map(str, theta), "--mechanism", str(RRRR), "--json"]) == 0
    import json

    out = json.loads(capsys.readouterr().out)
    nearest = min(out["solutions"], key=lambda s: np.abs(np.subtract(s["pose"], [0.27, 0.25, 0.2])).max())
    assert nearest["actuator_residual"] == pytest.approx([0.0, 0.0, 0.0, 0.01], abs=1e-9)


@pytest.mark.parametrize(("change", "expected"), [
    (dict(drives=dict(coulomb=0.02, stick_slip=True)), "stick-slip friction of its drives"),
])
def test_what_a_redundant_run_does_not_model_is_refused_in_one_line(change, expected):
    """Stick-slip friction (an actuator it holds would constrain the pose's accelerations): refused in one line
    saying so."""
    from pkmlab.simulation.realism import Drives

    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    values = {key: Drives(**value) for key, value in change.items()}
    with pytest.raises(InvalidParameterError) as refused:
        scenario.replace(**values)
    message = str(refused.value)
    assert "\n" not in message and "(redundant actuation)" in message and expected in message


def test_a_distribution_is_refused_where_it_has_no_choice_or_lacks_what_it_needs(tmp_path):
    """The controller's distribution: refused for a machine of as many actuators as degrees of freedom, without its
    weights or preload, with those of another, with as many numbers as another machine's actuators, each in one line
    naming it; in a scenario file by its key."""
    paper = pkmlab.paper_scenario("fast")
    with pytest.raises(InvalidParameterError, match="has as many as its degrees of freedom"):
        paper.replace(controller=pkmlab.ControllerSpec(distribution="preload", preload=(1.0, 1.0, 1.0)))
    for kwargs, expected in ((dict(distribution="weighted"), "weights: needed by distribution 'weighted'"),
                             (dict(preload=(1.0,) * 4), "preload: given for distribution 'preload' only"),
                             (dict(distribution="weighted", weights=(1.0, -1.0, 1.0, 1.0)), "weights[1] must be a "
                              "positive number")):
        with pytest.raises(InvalidParameterError, match=re.escape(expected)):
            pkmlab.ControllerSpec(**kwargs)
    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    with pytest.raises(InvalidParameterError, match="preload must be 4 numbers, one per actuator of 4-RRR, got 3"):
        scenario.replace(controller=pkmlab.ControllerSpec(distribution="preload", preload=(1.0, 2.0, 3.0)))
    text = (RRRR.parent / "4rrr_motion.toml").read_text().replace('distribution = "minimum_norm"',
                                                                  'distribution = "weighted"')
    (tmp_path / "run.toml").write_text(text.replace("[mechanism]\nfile = \"4rrr.toml\"",
                                                    f"[mechanism]\nfile = \"{RRRR.as_posix()}\""))
    with pytest.raises(InvalidParameterError) as refused:
        pkmlab.load_scenario(tmp_path / "run.toml")
    assert "[controller]" in str(refused.value) and "weights: needed by distribution 'weighted'" in str(refused.value)


def test_the_generated_order_of_a_block_diagonal_jacobian_and_its_sign():
    """``diagonal_blocks`` on a pattern written here: two legs whose rows close on columns given out of order (the
    second leg's first): the order found makes the passive block block diagonal, its sign is the permutation's,
    and NumPy's determinant of a matrix of that pattern, its columns so ordered, is that sign times the
    original's. One block, or blocks on rows not consecutive, give None (factored whole)."""
    from pkmlab.codegen.planar import _permutation_sign, diagonal_blocks

    assert [_permutation_sign(p) for p in ((0, 1, 2), (1, 0, 2), (1, 2, 0), (3, 0, 1, 2))] == [1, -1, 1, -1]
    # q = (pose 0, pose 1, leg 2's a, leg 1's a, leg 2's b, leg 1's b); rows 0-1 leg 1, rows 2-3 leg 2
    dependent = (2, 3, 4, 5)
    pattern = {(0, 0), (0, 3), (0, 5), (1, 1), (1, 3), (1, 5), (2, 0), (2, 2), (2, 4), (3, 1), (3, 2), (3, 4)}
    order, ends = diagonal_blocks(pattern, 4, dependent)
    assert order == (1, 3, 0, 2) and ends == (2, 2, 4, 4)  # a 4-cycle: odd
    rng = np.random.default_rng(5)
    jacobian = np.zeros((4, 6))
    for r, c in pattern:
        jacobian[r, c] = rng.normal()
    passive = jacobian[:, list(dependent)]
    blocked = passive[:, list(order)]
    assert np.all(blocked[:2, 2:] == 0) and np.all(blocked[2:, :2] == 0)
    assert np.linalg.det(blocked) == pytest.approx(_permutation_sign(order) * np.linalg.det(passive), rel=1e-12)
    assert _permutation_sign(order) == -1
    assert diagonal_blocks({(0, 2), (1, 3), (0, 3), (1, 2)}, 2, (2, 3)) is None  # one block
    assert diagonal_blocks({(0, 2), (1, 3), (2, 2), (3, 3)}, 4, (2, 3)) is None  # rows 0, 2 and 1, 3: not square


def test_the_least_peak_and_effort_limits_are_refused_in_runs_of_more_than_one_internal_effort(tmp_path):
    """A fifth leg gives the 4-RRR two internal efforts: the run's least peak and its effort limits, which move the
    efforts along one, are refused in one line saying so; its minimum-norm run is a scenario."""
    from pkmlab.simulation.realism import Drives

    text = RRRR.read_text().replace("[-0.0625, 0.0625]]", "[-0.0625, 0.0625], [0.0, -0.0625]]")
    leg = text[text.index("[[mechanism.leg]]"):].split("\n\n")[0]
    (tmp_path / "5rrr.toml").write_text(text.rstrip() + "\n\n" + leg.replace("base = [0.0, 0.0]", "base = [0.26, -0.1]")
                                        + "\n")
    five = pkmlab.load(tmp_path / "5rrr.toml")
    assert (five.n_actuators, five.dof, five.description.actuation_redundancy) == (5, 3, 2)
    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    assert scenario.replace(model=five).model is five
    for changes, expected in ((dict(controller=pkmlab.ControllerSpec(kp=400.0, distribution="minimum_peak")),
                               "the least peak is solved in a run for one internal effort, and it has 2"),
                              (dict(drives=Drives(effort_limit=0.45)),
                               "its controller holds effort limits for one internal effort, and it has 2")):
        with pytest.raises(InvalidParameterError) as refused:
            scenario.replace(model=five, **changes)
        message = str(refused.value)
        assert "\n" not in message and "5 actuators for its 3 degrees of freedom" in message and expected in message


def test_a_redundant_run_from_its_file_shares_the_force_as_its_distribution_asks(rrrr):
    """``examples/mechanisms/4rrr_motion.toml`` and its distributions, run through :func:`pkmlab.simulate` (and the
    batch, which runs the same loop): at each checked sample the efforts exert the same force on the pose as the
    minimum norm's, and are each distribution's own solution for it computed here by
    :func:`pkmlab.distribute_efforts` (a separate solve of the optimality conditions; for the least peak, SciPy's
    linear program) with ``W`` of :func:`pkmlab.pose_coordinate_jacobian`, the least peak's largest effort no larger
    than the minimum norm's for the same force; the result's rates are the actuators' (``W ẋ``) and its measure the
    actuation's."""
    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    specs = {"minimum_norm": {}, "weighted": dict(weights=(1.0, 1.0, 4.0, 4.0)),
             "preload": dict(preload=(1.5, -1.5, 1.5, -1.5)), "minimum_peak": {}}
    runs = pkmlab.simulate_batch([scenario.replace(controller=pkmlab.ControllerSpec(kp=400.0, distribution=method,
                                                                                    **extra))
                                  for method, extra in specs.items()])
    single = pkmlab.simulate(scenario)
    assert np.array_equal(single.tau, runs[0].tau) and np.array_equal(single.q, runs[0].q)
    assert runs[0].summary()["max_path_error_m"] < 1e-4
    for (method, extra), run in zip(specs.items(), runs, strict=True):
        for k in range(0, len(run.t), 60):
            W = pkmlab.pose_coordinate_jacobian(rrrr, run.q[k])[:4]
            force = W.T @ run.tau[k]
            ours = pkmlab.distribute_efforts(W, force, method, **extra).tau
            assert np.abs(run.tau[k] - ours).max() <= 1e-10 * max(1.0, np.abs(ours).max()), (method, k)
            if method == "minimum_peak":
                assert np.abs(run.tau[k]).max() <= pkmlab.distribute_efforts(W, force).peak * (1 + 1e-12)
        differenced = np.gradient(run.q[:, :4], run.t, axis=0)[1:-1]  # the actuators' rates, W not used
        assert np.abs(differenced - run.theta_dot[1:-1]).max() < 1e-3 * np.abs(run.theta_dot).max()
    assert np.allclose(runs[0].S, pkmlab.actuation_singularity_measure(rrrr, runs[0].q), rtol=1e-12)


def test_the_paper_machine_with_a_fourth_leg_turns_through_the_3rrrs_forward_singularity():
    """``examples/mechanisms/3rrr_redundant.toml``: the paper's legs and platform and a fourth leg. Its platform,
    turned from -0.6 to -1.3 rad at the middle of the workspace by a quintic time law in 0.5 s, crosses a forward
    singularity of the paper's 3-RRR (its ``S`` changes sign): the 3-RRR's own efforts for that motion grow without
    bound near it, the four legs' (minimum norm) stay small, their measure far from zero all along."""
    redundant, paper = pkmlab.load(RRRR.parent / "3rrr_redundant.toml"), pkmlab.load("paper")
    assert redundant.description.legs[:3] == paper.description.legs
    assert redundant.description.platform.attachments[:3] == paper.description.platform.attachments
    duration, s = 0.5, np.linspace(0.0, 1.0, 501)
    turn = -0.7
    poses = np.column_stack([np.full_like(s, 0.26), np.full_like(s, 0.15), -0.6 + turn * (10 * s**3 - 15 * s**4
                                                                                          + 6 * s**5)])
    zeros = np.zeros_like(s)
    pose_dot = np.column_stack([zeros, zeros, turn * (30 * s**2 - 60 * s**3 + 30 * s**4) / duration])
    pose_ddot = np.column_stack([zeros, zeros, turn * (60 * s - 180 * s**2 + 120 * s**3) / duration**2])
    own = np.array([mm.inverse_kinematics(paper, pose, (1, 1, 1)) for pose in poses])
    measure = pkmlab.singularity_measure(paper, own)
    assert measure.min() < 0 < measure.max()
    q = np.array([mm.inverse_kinematics(redundant, pose, (1, 1, 1, -1)) for pose in poses])
    assert pkmlab.actuation_singularity_measure(redundant, q).min() > 1.0

    def efforts(model, configurations):
        dynamics = pkmlab.pose_space_model(model, configurations, pose_dot)
        force = np.einsum("kij,kj->ki", dynamics.M, pose_ddot) + dynamics.c + dynamics.g
        if model is paper:  # one solution: Wᵀ τ = force, square
            return np.linalg.solve(np.swapaxes(dynamics.W, -1, -2), force[..., None])[..., 0]
        return np.array([pkmlab.distribute_efforts(w, f).tau for w, f in zip(dynamics.W, force, strict=True)])

    four, three = np.abs(efforts(redundant, q)).max(), np.abs(efforts(paper, own)).max(axis=1)
    assert four < 0.2 and three.max() > 20 * four
    nearest = int(np.argmin(np.abs(measure)))
    assert three[nearest] == three.max()  # the 3-RRR's efforts peak where its S is nearest zero


def test_the_redundant_3rrr_is_run_through_the_singularity_its_twin_cannot_cross():
    """``examples/mechanisms/3rrr_redundant_motion.toml``: the same turn run by computed torque. The paper's 3-RRR
    given this path in the same working mode is refused before running (its S comes within 0.001 of zero); the
    redundant machine tracks it to the order of the paper's nominal case (its orientation error at most twice the
    nominal's, its path error below it) with efforts below 0.2 N m, its actuation measure above 1 all along, and its
    legs on their loop closures."""
    scenario = pkmlab.load_scenario(RRRR.parent / "3rrr_redundant_motion.toml")
    with pytest.raises(SingularityError, match="gain-type singularity"):
        pkmlab.simulate(scenario.replace(model=pkmlab.load("paper"), working_mode="+++"))
    result = pkmlab.simulate(scenario)
    run, nominal = result.summary(), pkmlab.simulate(pkmlab.paper_scenario("nominal")).summary()
    assert run["max_path_error_m"] < nominal["max_path_error_m"]
    assert run["max_orientation_error_rad"] < 2.5 * nominal["max_orientation_error_rad"]
    assert max(run["peak_effort"]) < 0.2 and run["min_abs_S"] > 1.0
    assert max(_chain_residual(scenario.model, q) for q in result.q[::50]) < 1e-12


@pytest.mark.parametrize("name", ["paper", "delta"])
def test_for_as_many_actuators_as_degrees_of_freedom_the_pose_model_is_the_actuator_models(name):
    """``Mx = Wᵀ Mθ W`` and ``gx = Wᵀ gθ`` against the compiled core's actuator-space model (the Delta with
    gravity)."""
    model = pkmlab.load(name)
    pose = mm.pose_of(model, mm.well_conditioned_configuration(model, mm.working_modes(model)[0]))
    q = mm.inverse_kinematics(model, pose + 0.01, mm.working_modes(model)[0])
    W = pkmlab.actuation_jacobian(model, q)
    ours = pkmlab.pose_space_model(model, q, np.zeros(model.dof))
    theirs = pkmlab.actuator_space_model(model, q, np.zeros(model.n_actuators))
    assert np.abs(ours.M - W.T @ theirs.M @ W).max() < 1e-12 * np.abs(ours.M).max()
    assert np.abs(ours.g - W.T @ theirs.g).max() < 1e-12 * (1 + np.abs(ours.g).max())


@pytest.mark.parametrize("name", ["paper", "delta"])
def test_the_pose_models_velocity_forces_are_the_actuator_models_along_a_straight_line(name):
    """At ``ẍ = 0`` along a straight line at constant speed, ``Wᵀ (Mθ θ̈ + cθ + gθ) = cx + gx``, with ``θ̈`` the
    second central difference of inverse kinematics along the line and ``(Mθ, cθ, gθ)`` the compiled core's."""
    model = pkmlab.load(name)
    mode = mm.working_modes(model)[0]
    pose = mm.pose_of(model, mm.well_conditioned_configuration(model, mode)) + 0.01
    speed = np.array([0.2, -0.1, 0.5][:model.dof]) if name == "paper" else np.array([0.2, -0.1, 0.15])
    h = 1e-4
    theta = [mm.inverse_kinematics(model, pose + k * h * speed, mode)[:model.n_actuators] for k in (-1, 0, 1)]
    theta_dot, theta_ddot = (theta[2] - theta[0]) / (2 * h), (theta[2] - 2 * theta[1] + theta[0]) / h**2
    q = mm.inverse_kinematics(model, pose, mode)
    theirs = pkmlab.actuator_space_model(model, q, theta_dot)
    ours = pkmlab.pose_space_model(model, q, speed)
    expected = ours.W.T @ (theirs.M @ theta_ddot + theirs.c + theirs.g)
    assert np.abs(ours.c + ours.g - expected).max() < 1e-5 * (1 + np.abs(expected).max())


@pytest.fixture(scope="module")
def delta4():
    return pkmlab.load(RRRR.parent / "4delta.toml")


def test_a_delta_on_four_arms_is_a_redundantly_actuated_spatial_machine(delta4):
    """``examples/mechanisms/4delta.toml``: its mobility is computed (3, the platform's translations) with four
    actuators; inverse kinematics closes every leg by the readable chain; ``W`` is the derivative of inverse
    kinematics; forward kinematics from any three arms (a Delta's three spheres) finds the pose with the fourth's
    residual zero, and a fourth reading off by 0.01 rad shows as that residual."""
    from test_lower_mobility import _independent_residual

    assert (delta4.dof, delta4.n_actuators, delta4.description.actuation_redundancy) == (3, 4, 1)
    mode = mm.working_modes(delta4)[0]
    for pose in np.array([[0.01, 0.02, -0.85], [-0.05, 0.03, -0.78], [0.04, -0.06, -0.9]]):
        q = mm.inverse_kinematics(delta4, pose, mode)
        assert _independent_residual(delta4.description, q, delta4.coordinates) < 1e-14
        _assert_w_is_the_derivative_of_inverse_kinematics(delta4, pose, mode, q)
        every = pkmlab.actuation_singularity_measure(delta4, q)
        for subset in SUBSETS:
            assert every >= pkmlab.actuation_singularity_measure(delta4, q, actuators=list(subset))
            found = pkmlab.forward_kinematics(delta4, q[:4], actuators=subset)
            nearest = int(np.argmin(np.abs(found.pose[:len(found)] - pose).max(axis=1)))
            assert np.abs(found.pose[nearest] - pose).max() < 1e-10
            assert np.abs(found.residual[nearest]).max() < 1e-10
    found = pkmlab.forward_kinematics(delta4, q[:4] + np.array([0.0, 0.0, 0.0, 0.01]))
    nearest = int(np.argmin(np.abs(found.pose[:len(found)] - pose).max(axis=1)))
    assert found.residual[nearest] == pytest.approx([0.0, 0.0, 0.0, 0.01], abs=1e-10)


def test_the_four_arm_deltas_distributed_efforts_give_mujocos_and_the_saddle_points_accelerations(delta4):
    """With gravity: efforts distributed (minimum norm, then preloaded) for a chosen acceleration give it back from
    the full model's saddle-point solve, and MuJoCo's hard-constraint solve of the exported model (four motors)
    gives the same accelerations."""
    from test_mujoco_export import _hard_solve

    m, d = mx.load_mujoco(delta4)
    assert m.nu == 4
    mode = mm.working_modes(delta4)[0]
    rng = np.random.default_rng(5)
    for pose in np.array([[0.01, 0.02, -0.85], [-0.05, 0.03, -0.78]]):
        q = mm.inverse_kinematics(delta4, pose, mode)
        pose_dot, pose_ddot = rng.normal(0.0, 0.2, 3), rng.normal(0.0, 2.0, 3)
        q_dot = pkmlab.pose_coordinate_jacobian(delta4, q) @ pose_dot
        model_x = pkmlab.pose_space_model(delta4, q, pose_dot)
        force = model_x.M @ pose_ddot + model_x.c + model_x.g
        for shared in (pkmlab.distribute_efforts(model_x.W, force),
                       pkmlab.distribute_efforts(model_x.W, force, "preload", preload=[1.0, -1.0, 1.0, -1.0])):
            ours = pkmlab.constrained_dynamics(delta4, q, q_dot, shared.tau).q_ddot
            assert np.abs(mm.pose_of(delta4, ours) - pose_ddot).max() < 1e-12 * (1 + np.abs(pose_ddot).max())
            d.qpos[:] = mx.qpos_from_q(delta4, q)
            d.qvel[:] = mx.qvel_from_q_dot(delta4, q, q_dot)
            d.ctrl[:] = shared.tau
            mujoco.mj_forward(m, d)
            theirs = mx.q_dot_from_qvel(delta4, q, _hard_solve(m, d, 4))
            assert np.abs(theirs - ours).max() < 1e-12 * (1 + np.abs(ours).max())


@pytest.mark.parametrize("name", ["4rrr.toml", "4delta.toml"])
def test_the_compiled_core_models_and_follows_a_redundant_machine_in_its_pose(name):
    """A redundantly actuated machine's compiled core takes the controlled pose as its independent coordinates
    (its actuators over-determine it): its model is the pose-space model reduced in Python from the full-space one,
    its passive block ``Jηφ`` one block per leg, its singularity measure NumPy's determinant of that block scaled,
    and its branch following, given poses, reaches inverse kinematics' configurations of the same working mode."""
    model = pkmlab.load(RRRR.parent / name)
    k = model.kernels
    assert (k.N_INDEPENDENT, k.LEADING, k.ELIMINATED) == (model.dof, False, 0)
    assert tuple(model.coordinates[c] for c in k.INDEPENDENT) == model.pose_names
    mode = MODE if name == "4rrr.toml" else mm.working_modes(model)[0]
    poses = _poses(4, 5) if name == "4rrr.toml" else np.array([[0.01, 0.02, -0.85], [-0.03, 0.03, -0.82],
                                                                 [0.0, -0.04, -0.88], [0.02, 0.0, -0.8]])
    qs = np.array([mm.inverse_kinematics(model, pose, mode) for pose in poses])
    rates = np.random.default_rng(2).normal(0.0, 0.3, (len(qs), model.dof))
    M, c, g = np.empty((len(qs), model.dof, model.dof)), np.empty((len(qs), model.dof)), np.empty((len(qs), model.dof))
    assert k.actuator_space_models(qs, rates, model.P, M, c, g) == -1
    for q, rate, Mk, ck, gk in zip(qs, rates, M, c, g, strict=True):
        ours = pkmlab.pose_space_model(model, q, rate)
        scale = np.abs(ours.M).max()
        assert np.abs(Mk - ours.M).max() < 1e-12 * scale
        assert np.abs(ck - ours.c).max() < 1e-12 * (scale + np.abs(ours.c).max())
        assert np.abs(gk - ours.g).max() < 1e-12 * (scale + np.abs(ours.g).max())
    # its legs close each on the pose: Jηφ, its columns in the generated order, is block diagonal, one block per leg,
    # factored block by block; S, the scaled determinant of Jηφ, is NumPy's of the whole matrix
    jacobians = np.empty((len(qs), k.N_CONSTRAINTS, k.N_COORDINATES))
    k.constraint_jacobians(qs, model.P, jacobians)
    columns = [k.DEPENDENT[i] for i in k.REDUCED_COLUMNS]
    assert k.BLOCKED and len(set(k.BLOCK_END)) == model.n_actuators
    inside = np.zeros((k.N_CONSTRAINTS, len(columns)), dtype=bool)
    for i, end in enumerate(k.BLOCK_END):
        start = max([e for e in k.BLOCK_END if e <= i], default=0)
        inside[start:end, i] = True
    assert np.all(jacobians[:, :, columns][:, ~inside] == 0.0)
    measures = np.empty(len(qs))
    k.singularity_measures(qs, model.P, measures)
    for jacobian, measure in zip(jacobians, measures, strict=True):
        passive = jacobian[:, list(k.DEPENDENT)].copy()
        passive[:, [k.ANGLES[c] for c in k.DEPENDENT]] /= k.platform_size(model.P)
        passive /= np.linalg.norm(passive, axis=1)[:, None]
        assert abs(measure - np.linalg.det(passive)) < 1e-12
    out = np.empty_like(qs)
    status, failed = k.follow_path(qs[0], poses, model.P, 1e-9, out)
    assert (status, failed) == (k.OK, -1)
    apart = out - qs
    apart[:, list(k.ANGLES)] = (apart[:, list(k.ANGLES)] + np.pi) % (2 * np.pi) - np.pi  # an angle whole turns away
    assert np.abs(apart).max() < 1e-12


def _quintic_line(start, end, duration: float, ts: float):
    """A straight line from ``start`` to ``end`` in ``duration`` with a quintic time law: poses, rates, accelerations
    at the samples (K, dof)."""
    t = np.arange(0.0, duration + 0.5 * ts, ts)
    u = t / duration
    s, s_dot, s_ddot = 10 * u**3 - 15 * u**4 + 6 * u**5, (30 * u**2 - 60 * u**3 + 30 * u**4) / duration, \
        (60 * u - 180 * u**2 + 120 * u**3) / duration**2
    span = np.subtract(end, start)
    return (np.asarray(start) + s[:, None] * span, s_dot[:, None] * span, s_ddot[:, None] * span)


#: The compiled loop's distribution (rows: weights, preload, effort limits, least-peak flag) of the least 2-norm.
LEAST_NORM = [np.ones(4), np.zeros(4), np.full(4, np.inf), np.zeros(4)]


def _redundant_run(model, ts, distribution):
    """The compiled sampled-data loop of the 4-RRR along :func:`_quintic_line`, computed torque with its exact model
    (kp = 400), straight from its kernels (the entry point :func:`pkmlab.simulate` calls, with its argument types)."""
    k = model.kernels
    pose, pose_dot, pose_ddot = _quintic_line([0.24, 0.24, -0.2], [0.29, 0.27, 0.3], 0.4, ts)
    q0 = mm.inverse_kinematics(model, pose[0], MODE)
    count, n = len(pose), model.n_actuators
    q, rates, tau, s = np.zeros((count, q0.size)), np.zeros((count, 3)), np.zeros((count, n)), np.zeros(count)
    none = np.zeros((0, n))
    status, failed = k.sampled_data_chunk(k.make_workspaces(2), np.zeros(6), np.zeros((0, n)), 0, count, ts, 1, pose,
                                          pose_dot, pose_ddot, q0, q0.copy(), model.P, model.P, 0, 400.0, 40.0,
                                          np.array(distribution, dtype=float), 1e-9, k.NO_DRIVES, k.NO_DRIVES, none,
                                          np.zeros(n), none, -1, 0, q, rates, tau, s, none)
    assert (status, failed) == (k.OK, -1)
    return pose, q, rates, tau


def test_a_redundant_machines_compiled_run_tracks_its_pose_with_efforts_of_the_distribution_asked_for(rrrr):
    """The compiled loop of the 4-RRR in its pose, computed torque with the exact model: the plant stays on its loop
    closures, tracks the line to the sampling's first order (half the sample time, about half the error), and its
    efforts are the distribution's: the minimum norm's carry no internal part (they are in the range of ``W``, computed
    here by :func:`pkmlab.pose_coordinate_jacobian`), the preload's carry exactly the preload's internal part."""
    errors = []
    for ts in (2e-3, 1e-3):
        pose, q, _rates, tau = _redundant_run(rrrr, ts, LEAST_NORM)
        assert max(_chain_residual(rrrr, qk) for qk in q[::25]) < 1e-12
        errors.append(np.abs(mm.pose_of(rrrr, q) - pose).max())
        for qk, tk in zip(q[::25], tau[::25], strict=True):
            W = pkmlab.pose_coordinate_jacobian(rrrr, qk)[:4]
            internal = np.linalg.svd(W.T)[2][-1]  # the null space of Wᵀ: one internal effort
            assert abs(internal @ tk) <= 1e-12 * np.abs(tk).max()
    assert errors[0] < 1e-3 and 0.4 < errors[1] / errors[0] < 0.6  # (measured: 4.3e-4 rad, ratio 0.50)
    # the preload: the minimum norm plus the preload's internal part, at the configuration the controller measured.
    # Held over a sample, that part leaves the null space of Wᵀ as the machine moves (W changes within the
    # sample): the preloaded run departs from the unloaded one by the sampling's first order, never more
    preload = np.array([1.5, -1.5, 1.5, -1.5])
    departures = []
    for ts in (1e-3, 5e-4):
        _pose, q_0, _rates, tau_0 = _redundant_run(rrrr, ts, LEAST_NORM)
        _pose, q_p, _rates, tau_p = _redundant_run(rrrr, ts, [np.ones(4), preload, *LEAST_NORM[2:]])
        departures.append(np.abs(mm.pose_of(rrrr, q_p) - mm.pose_of(rrrr, q_0)).max())
        for qk, tp in zip(q_p[::25], tau_p[::25], strict=True):
            W = pkmlab.pose_coordinate_jacobian(rrrr, qk)[:4]
            internal = np.linalg.svd(W.T)[2][-1]
            minimum_norm = np.linalg.pinv(W.T) @ (W.T @ tp)
            assert np.abs(tp - minimum_norm - internal * (internal @ preload)).max() < 1e-12 * np.abs(tp).max()
    assert 0.4 < departures[1] / departures[0] < 0.6


def test_the_four_arm_deltas_default_run_is_tracked_to_its_sampling_on_its_loop_closures(delta4):
    """``examples/mechanisms/4delta_motion.toml``, a pick-and-place hop under gravity: computed torque on a model
    equal to the plant leaves the error of holding the effort over a sample (halving the sample time halves it), and
    every checked sample's configuration closes the description's readable chain."""
    from test_lower_mobility import _independent_residual

    scenario = pkmlab.load_scenario(RRRR.parent / "4delta_motion.toml")
    result = pkmlab.simulate(scenario)
    finer = pkmlab.simulate(scenario.replace(sample_time=scenario.sample_time / 2))
    error = np.abs(result.pose - result.pose_d).max(axis=0)
    ratio = np.abs(finer.pose - finer.pose_d).max(axis=0) / error
    assert np.all((0.45 < ratio) & (ratio < 0.55)) and error.max() < 1e-4, (error, ratio)
    assert max(_independent_residual(delta4.description, q, delta4.coordinates) for q in result.q[::25]) < 1e-12


def test_a_controller_that_reads_the_actuators_estimates_the_pose_they_over_determine(rrrr):
    """The 4-RRR's default run with sensors on its four actuators: the controller finds the pose of least squared
    residual to the readings (Gauss–Newton) and its rates ``(WᵀW)⁻¹ Wᵀ θ̇_m``. With exact readings that is the
    plant's pose: the run is the ideal-sensor run to round-off. Encoders of 1e-4 rad record the plant's actuators
    rounded to their resolution (checked here from the recorded configurations), the controller's rates their
    differences, and the run still tracks, its path error within the order of the resolution times the legs'
    length (0.25 m)."""
    from pkmlab.simulation.realism import Sensors

    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    ideal = pkmlab.simulate(scenario)
    exact = pkmlab.simulate(scenario.replace(sensors=Sensors(rates="exact")))
    assert np.abs(exact.pose - ideal.pose).max() < 1e-13 and np.abs(exact.tau - ideal.tau).max() < 1e-12
    assert np.array_equal(exact.theta_measured, exact.q[:, :4])
    resolution = 1e-4
    encoders = pkmlab.simulate(scenario.replace(sensors=Sensors(resolution=resolution)))
    readings = encoders.theta_measured
    assert np.array_equal(readings, resolution * np.floor(encoders.q[:, :4] / resolution + 0.5))
    summary = encoders.summary()
    assert ideal.summary()["max_path_error_m"] < summary["max_path_error_m"] < 0.25 * resolution * 10
    assert max(_chain_residual(rrrr, q) for q in encoders.q[::100]) < 1e-12
    from pkmlab.interop.mujoco_plant import simulate_mujoco

    with pytest.raises(InvalidParameterError, match="sensors of its actuators are modelled on pkmlab's plant"):
        simulate_mujoco(scenario.replace(sensors=Sensors(resolution=resolution)))


def test_drives_act_at_a_redundant_machines_actuators_as_mujocos_joint_armature_and_damping_do():
    """Drives on the 4-RRR's actuators (reflected armature, viscous and smooth Coulomb friction): in its pose,
    ``(Mx + Wᵀ Ia W) ẍ = Wᵀ (τ - f(W ẋ) - Ia b) - cx - gx``. Under continuous-time computed torque whose model
    of the drives is the plant's, the motion is tracked to the integrator's tolerance (measured 6e-15 m; ignoring
    the drives, 1e-3 m). Sampled, with armature and damping, pkmlab's plant agrees with MuJoCo's, whose joints carry
    them (``armature``, ``damping``): within 1e-6 m, 1e-5 rad and 1e-4 of the peak effort (measured 8.5e-8 m,
    1.2e-6 rad, as without drives)."""
    from pkmlab.interop.mujoco_plant import simulate_mujoco
    from pkmlab.simulation.realism import Drives

    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    drives = Drives(armature=2e-3, viscous=0.05, coulomb=0.02, coulomb_rate=0.05)
    continuous = scenario.replace(sample_time=0.0, drives=drives)
    assert pkmlab.simulate(continuous).summary()["max_path_error_m"] > 1e-4
    modelled = pkmlab.simulate(continuous.replace(controller_drives=drives))
    assert modelled.summary()["max_path_error_m"] < 1e-8
    assert np.abs(modelled.pose[:, 2] - modelled.pose_d[:, 2]).max() < 1e-8
    damped = Drives(armature=2e-3, viscous=0.05)
    sampled = scenario.replace(drives=damped, controller_drives=damped)
    ours, theirs = pkmlab.simulate(sampled), simulate_mujoco(sampled)
    assert np.linalg.norm(ours.pose[:, :2] - theirs.pose[:, :2], axis=1).max() < 1e-6
    assert np.abs(ours.pose[:, 2] - theirs.pose[:, 2]).max() < 1e-5
    assert np.abs(ours.tau - theirs.tau).max() < 1e-4 * np.abs(ours.tau).max()


def test_continuous_time_control_of_a_redundant_machine_tracks_to_integration_level(rrrr):
    """The 4-RRR's default motion under continuous-time computed torque (the controller evaluated at every stage of
    the adaptive integrator) with its exact model: the pose tracked to the integrator's tolerance, the legs on their
    loop closures, and the efforts the least 2-norm's (no internal part, ``W`` computed here)."""
    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml").replace(sample_time=0.0)
    result = pkmlab.simulate(scenario)
    assert result.summary()["max_path_error_m"] < 1e-8
    assert np.abs(result.pose[:, 2] - result.pose_d[:, 2]).max() < 1e-8
    assert max(_chain_residual(rrrr, q) for q in result.q[::50]) < 1e-12
    for qk, tk in zip(result.q[::50], result.tau[::50], strict=True):
        W = pkmlab.pose_coordinate_jacobian(rrrr, qk)[:4]
        internal = np.linalg.svd(W.T)[2][-1]
        assert abs(internal @ tk) <= 1e-12 * np.abs(tk).max()
    differenced = np.gradient(result.q[:, :4], result.t, axis=0)[1:-1]  # the actuators' rates, W not used
    assert np.abs(differenced - result.theta_dot[1:-1]).max() < 1e-3 * np.abs(result.theta_dot).max()


def test_a_controller_whose_model_is_not_the_plant_leaves_internal_efforts_it_never_sees(tmp_path):
    """The 4-RRR's default run with a plant whose third base stands 2 mm from where the controller's model puts it:
    the run still tracks (its path error within ten times the exact model's), and the efforts, internal-free for the
    controller's ``W`` (the minimum norm), carry internal efforts for the plant's — the result's
    ``internal_effort_error``, zero for the exact model, here nonzero and within the order of the efforts times the
    geometric error over the legs' size (2 mm over 0.25 m: under 5 % of the peak effort)."""
    text = RRRR.read_text()
    assert text.count("base = [0.52, 0.52]") == 1
    (tmp_path / "plant.toml").write_text(text.replace("base = [0.52, 0.52]", "base = [0.52, 0.522]"))
    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    exact = pkmlab.simulate(scenario)
    assert np.array_equal(exact.internal_effort_error, np.zeros_like(exact.tau))
    result = pkmlab.simulate(scenario.replace(plant=pkmlab.load(tmp_path / "plant.toml")))
    summary = result.summary()
    assert summary["max_path_error_m"] < 10 * exact.summary()["max_path_error_m"]
    internal = result.internal_effort_error
    peak = np.abs(result.tau).max()
    assert 1e-6 * peak < summary["max_internal_effort_error"] == np.abs(internal).max() < 0.05 * peak
    for k in range(0, len(result.t), 100):  # the plant's internal part, from its own W computed here
        W = pkmlab.pose_coordinate_jacobian(result.scenario.plant_model, result.q[k])[:4]
        null = np.linalg.svd(W.T)[2][-1]
        assert np.abs(internal[k] - null * (null @ result.tau[k])).max() < 1e-6 * peak


def test_the_mujoco_plant_runs_a_redundant_machine_as_pkmlabs_plant_does():
    """The 4-RRR's default run on MuJoCo (its four motors, the loop closures MuJoCo's stiff equality constraints):
    the platform stays within 1e-6 m and 1e-5 rad of pkmlab's plant (measured: 8.6e-8 m, 1.3e-6 rad), the loop
    closures within 1e-6 m, and the distributed efforts within 1e-4 of their peak."""
    from pkmlab.interop.mujoco_plant import simulate_mujoco

    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    ours, theirs = pkmlab.simulate(scenario), simulate_mujoco(scenario)
    assert np.linalg.norm(ours.pose[:, :2] - theirs.pose[:, :2], axis=1).max() < 1e-6
    assert np.abs(ours.pose[:, 2] - theirs.pose[:, 2]).max() < 1e-5
    assert theirs.closure_violation.max() < 1e-6
    assert np.abs(ours.tau - theirs.tau).max() < 1e-4 * np.abs(ours.tau).max()


def test_declared_effort_limits_are_held_by_the_distribution_or_the_run_is_refused_naming_time_and_actuator():
    """The 4-RRR's default run under drives limited to 0.45 N m, below its second actuator's least-norm peak
    (0.484 N m): the controller moves its efforts along the internal effort into the limits (no effort beyond them,
    the second actuator held at its limit) and the platform is tracked as well as without limits; so does the least
    peak within a limit of each actuator's own. At 0.4 N m no efforts exert the motion's forces: refused before
    running, in one line naming the time and the actuator."""
    from pkmlab.simulation.realism import Drives

    scenario = pkmlab.load_scenario(RRRR.parent / "4rrr_motion.toml")
    free = pkmlab.simulate(scenario)
    assert np.abs(free.tau).max(axis=0)[1] > 0.48
    limited = pkmlab.simulate(scenario.replace(drives=Drives(effort_limit=0.45)))
    assert np.abs(limited.tau).max() <= 0.45 * (1 + 1e-12)
    assert np.abs(limited.tau).max(axis=0)[1] == pytest.approx(0.45, rel=1e-12)
    assert limited.summary()["max_path_error_m"] < 1.01 * free.summary()["max_path_error_m"]
    # the least peak within limits of its own for each actuator: the third's, 0.12 N m, below the 0.28 N m the least
    # peak gives it unlimited, binds; every checked sample's efforts are SciPy's linear program's within the bounds
    limits = (0.45, 0.45, 0.12, 0.45)
    peak = pkmlab.simulate(scenario.replace(controller=pkmlab.ControllerSpec(kp=400.0, distribution="minimum_peak"),
                                            drives=Drives(effort_limit=limits)))
    assert np.all(np.abs(peak.tau).max(axis=0) <= np.array(limits) * (1 + 1e-12))
    assert np.abs(peak.tau[:, 2]).max() == pytest.approx(0.12, rel=1e-12)
    assert peak.summary()["max_path_error_m"] < 1.01 * free.summary()["max_path_error_m"]
    for k in range(0, len(peak.t), 50):
        W = pkmlab.pose_coordinate_jacobian(scenario.model, peak.q[k])[:4]
        theirs = pkmlab.distribute_efforts(W, W.T @ peak.tau[k], "minimum_peak", limits=limits).tau
        assert np.abs(peak.tau[k] - theirs).max() < 1e-12, k
    with pytest.raises(InvalidParameterError) as refused:
        pkmlab.simulate(scenario.replace(drives=Drives(effort_limit=0.4)))
    message = str(refused.value)
    assert "\n" not in message and re.match(r"t = 0\.\d{4} s: the effort limits cannot be held: actuator a\d needs at "
                                             r"most -0\.4\d+ against its lower limit -0\.4\b", message), message
