"""Time-optimal timing of a path under actuator limits (``pkmlab.time_optimal``, ``[timing]`` in scenario files).

Independent checks: with velocity limits alone the optimal path speed is known in closed form at each grid
point, ``u̇ = min_j v_j / |θ'_j|`` (``u`` the circle's arc length, ``θ'`` from central differences of the
inverse kinematics, not from the loop closures' derivatives the module uses), whose duration the timing must
equal; with effort limits alone on a machine without gravity in its plane the problem is homogeneous — limits
four times larger halve the duration; the limits hold at the grid's times on the desired motion that a run
computes from the retimed poses (its own inverse kinematics, rates and ``pkmlab.inverse_dynamics``), and one
is nearly active almost everywhere (the timing is bang-bang, not merely feasible); the timing is no slower
than the best uniform speed-up of the original that meets the same limits (a bisection); its derivatives
against central differences; a Delta's pick-and-place stops at every corner.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.control.trajectory import paper_trajectory
from pkmlab.errors import InvalidParameterError, PkmlabError
from pkmlab.formats.scenario import scenario_from_dict
from pkmlab.model import mechanism_model as mm

MODE = (-1, 1, -1)


@pytest.fixture(scope="module")
def paper():
    return pkmlab.load("paper")


def _motion(model, trajectory, t, mode=MODE):
    """A run's desired actuator motion at ``t``: inverse kinematics, rates, and the inverse dynamics' efforts."""
    pose, pose_dot, pose_ddot = trajectory.desired(t)
    q, _s, failure = mm.path_inverse_kinematics(model, pose, mode)
    assert failure is None
    theta_dot, theta_ddot, k = mm.path_rates(model, q, pose_dot, pose_ddot)
    assert k < 0
    tau = np.array([pkmlab.inverse_dynamics(model, qq, w, a) for qq, w, a in zip(q, theta_dot, theta_ddot,
                                                                                 strict=True)])
    return theta_dot, theta_ddot, tau


def test_with_velocity_limits_alone_the_speed_is_the_closed_form_bound(paper):
    trajectory = paper_trajectory(0.2)
    limit = np.array([1.5, 2.0, 2.5])
    retimed = pkmlab.time_optimal(trajectory, paper, MODE, velocity=limit, grid=200)
    u = retimed.u
    h = 1e-6
    np.testing.assert_allclose(u, np.linspace(0.0, trajectory.path.length, 201), rtol=1e-15)  # the arc length
    theta = [mm.path_inverse_kinematics(paper, trajectory.path.at(u + s * h)[0], MODE)[0][:, :3] for s in (1, -1)]
    d_theta = (theta[0] - theta[1]) / (2 * h)  # dθ/du by central differences
    speed = np.min(limit / np.abs(d_theta[1:-1]), axis=1)
    np.testing.assert_allclose(retimed.u_dot[1:-1], speed, rtol=1e-6)
    u_dot = np.concatenate([[0.0], speed, [0.0]])
    duration = np.sum(2 * np.diff(u) / (u_dot[:-1] + u_dot[1:]))
    assert retimed.duration == pytest.approx(duration, rel=1e-6)
    assert retimed.duration < trajectory.duration


def test_effort_limits_four_times_larger_halve_the_duration(paper):
    trajectory = paper_trajectory(0.2)
    slow = pkmlab.time_optimal(trajectory, paper, MODE, effort=0.2, grid=200)
    fast = pkmlab.time_optimal(trajectory, paper, MODE, effort=0.8, grid=200)
    assert fast.duration == pytest.approx(slow.duration / 2, rel=1e-6)


def test_the_limits_hold_on_the_grid_and_one_is_active_almost_everywhere(paper):
    trajectory = paper_trajectory(0.2)
    retimed = pkmlab.time_optimal(trajectory, paper, MODE, velocity=2.0, effort=[0.5, 0.5, 0.4], grid=400)
    theta_dot, _theta_ddot, tau = _motion(paper, retimed, retimed.t_grid)
    velocity, effort = np.abs(theta_dot).max(axis=1) / 2.0, np.max(np.abs(tau) / [0.5, 0.5, 0.4], axis=1)
    assert velocity.max() <= 1 + 1e-6 and effort.max() <= 1 + 1e-6
    active = np.maximum(velocity, effort)[1:-1] > 0.98
    assert active.mean() > 0.9
    assert {kind for kind, _j in retimed.binding} == {"velocity", "effort"}
    # between the grid's points, to its discretisation
    _w, _a, tau = _motion(paper, retimed, np.linspace(0.0, retimed.duration, 1501))
    assert np.max(np.abs(tau) / [0.5, 0.5, 0.4]) < 1.01


def test_no_uniform_speed_up_of_the_original_is_faster(paper):
    trajectory = paper_trajectory(0.2)
    limits = dict(velocity=2.0, acceleration=60.0, effort=0.5)
    retimed = pkmlab.time_optimal(trajectory, paper, MODE, **limits, grid=400)
    t = np.linspace(0.0, trajectory.duration, 201)
    theta_dot, theta_ddot, _tau = _motion(paper, trajectory, t)
    pose, _, _ = trajectory.desired(t)
    q = mm.path_inverse_kinematics(paper, pose, MODE)[0]

    def feasible(k):  # the original k times faster: rates × k, accelerations and efforts × k² (no gravity)
        tau = np.array([pkmlab.inverse_dynamics(paper, qq, k * w, k * k * a)
                        for qq, w, a in zip(q, theta_dot, theta_ddot, strict=True)])
        return (np.abs(k * theta_dot).max() <= 2.0 and np.abs(k * k * theta_ddot).max() <= 60.0
                and np.abs(tau).max() <= 0.5)

    low, high = 0.1, 10.0
    for _ in range(30):
        mid = np.sqrt(low * high)
        low, high = (mid, high) if feasible(mid) else (low, mid)
    assert retimed.duration < trajectory.duration / low


def test_the_retimed_derivatives_are_exact(paper):
    retimed = pkmlab.time_optimal(paper_trajectory(0.2), paper, MODE, velocity=2.0, effort=0.5, grid=100)
    t = np.linspace(0.01, retimed.duration - 0.01, 77)
    h = 1e-6
    pose, velocity, acceleration = retimed.desired(t)
    plus, minus = retimed.desired(t + h), retimed.desired(t - h)
    np.testing.assert_allclose(velocity, (plus[0] - minus[0]) / (2 * h), atol=1e-8)
    np.testing.assert_allclose(acceleration, (plus[1] - minus[1]) / (2 * h), atol=2e-4)  # a jump within h is rare
    # it starts to move at 0: the acceleration there is the first interval's
    np.testing.assert_allclose(retimed.desired(np.array([0.0]))[2], retimed.desired(np.array([1e-12]))[2],
                               rtol=1e-6)
    assert np.abs(retimed.desired(np.array([0.0]))[2]).max() > 0
    at_rest = retimed.desired(np.array([-1.0, retimed.duration + 1.0]))
    np.testing.assert_allclose(at_rest[0], retimed.original.desired(np.array([0.0, 1e9]))[0], atol=1e-15)
    assert not at_rest[1].any() and not at_rest[2].any()


def _scenario(**timing):
    return {"trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2},
            "controller": {"type": "computed_torque", "kp": 1000.0, "sample_time": 0.001},
            "timing": timing}


def test_a_scenario_file_runs_its_path_on_the_time_optimal_timing():
    scenario = scenario_from_dict(_scenario(velocity=2.0, effort=[0.5, 0.5, 0.5]), "fast.toml")
    assert isinstance(scenario.trajectory, pkmlab.TimeOptimal) and scenario.working_mode == MODE
    result = pkmlab.simulate(scenario)
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-4
    # the feedforward at its limit; the feedback adds a little where the timing's acceleration jumps
    assert max(summary["peak_effort"]) < 0.5 * 1.1
    assert result.t[-1] == pytest.approx(scenario.trajectory.duration, abs=1e-3)


def test_bad_timing_tables_are_refused_by_key():
    with pytest.raises(pkmlab.PkmlabError, match=r"bad.toml: unknown key 'torque' in \[timing\] \(valid keys: "
                                                 r"velocity, acceleration, effort, grid\)"):
        scenario_from_dict(_scenario(torque=0.5), "bad.toml")
    with pytest.raises(pkmlab.PkmlabError, match=r"\[timing\] needs at least one limit"):
        scenario_from_dict(_scenario(grid=100), "bad.toml")
    with pytest.raises(InvalidParameterError, match=r"\[timing\].velocity must be one number or 3, one per actuator"):
        scenario_from_dict(_scenario(velocity=[1.0, 2.0]), "bad.toml")
    with pytest.raises(InvalidParameterError, match=r"\[timing\].effort\[1\] must be a positive number, got -0.5"):
        scenario_from_dict(_scenario(effort=[0.5, -0.5, 0.5]), "bad.toml")
    with pytest.raises(InvalidParameterError, match=r"\[timing\].grid must be an integer from 10 to 100000"):
        scenario_from_dict(_scenario(velocity=1.0, grid=4), "bad.toml")


def test_a_delta_pose_gravity_alone_overloads_is_refused_naming_the_actuator_and_time():
    delta = {"mechanism": {"preset": "delta"},
             "trajectory": {"type": "waypoints", "points": [[0.0, 0.0, -0.75], [0.05, 0.0, -0.72]],
                            "durations": [0.3]},
             "timing": {"effort": 0.01}}
    with pytest.raises(PkmlabError, match=r"bad.toml: \[timing\]: actuator 1 needs 1.4\d* to hold the pose "
                                          r"\(0, 0, -0.75\) against gravity, above its effort limit 0.01"):
        scenario_from_dict(delta, "bad.toml")
    with pytest.raises(InvalidParameterError, match=r"needs limits: give velocity, acceleration or effort"):
        pkmlab.time_optimal(paper_trajectory(0.2), pkmlab.load("paper"), MODE)
    with pytest.raises(InvalidParameterError, match=r'mode must be one of the machine.s working modes, not "auto"'):
        pkmlab.time_optimal(paper_trajectory(0.2), pkmlab.load("paper"), "auto", velocity=1.0)


def test_a_delta_pick_and_place_stops_at_every_corner_within_its_limits():
    """Straight segments meet at corners: each is timed from rest to rest, against gravity."""
    delta = pkmlab.load("delta")
    scenario = pkmlab.load_scenario(Path(__file__).resolve().parents[1] / "examples" / "delta_pick_and_place.toml")
    original = scenario.trajectory
    retimed = pkmlab.time_optimal(original, delta, (1, 1, 1), velocity=8.0, acceleration=400.0, effort=25.0,
                                  grid=300)
    assert retimed.duration < original.duration
    corners = np.flatnonzero(np.isin(retimed.u, np.arange(len(original.points))))
    assert len(corners) == len(original.points)
    np.testing.assert_array_equal(retimed.u_dot[corners], 0.0)
    pose, velocity, _ = retimed.desired(retimed.t_grid[corners])
    np.testing.assert_allclose(pose, original.points, atol=1e-15)
    assert not velocity.any()
    # every grid point, as the interval after it sees it and, a millionth of the interval before it, as that one
    # does (at a corner: the segment it ends)
    t = retimed.t_grid
    for times in (t, t[1:] - 1e-6 * np.diff(t)):
        theta_dot, theta_ddot, tau = _motion(delta, retimed, times, (1, 1, 1))
        assert np.abs(theta_dot).max() <= 8.0 * (1 + 1e-5) and np.abs(tau).max() <= 25.0 * (1 + 1e-5)
        assert np.abs(theta_ddot).max() <= 400.0 * (1 + 1e-5)
    assert max(np.abs(tau).max() / 25.0, np.abs(theta_ddot).max() / 400.0) > 0.99


def test_a_study_sweeps_the_limits_of_a_time_optimal_timing():
    """``[timing]`` keys are study axes like any other: larger effort limits, a shorter run (fewer samples) whose
    feedforward reaches them."""
    from pkmlab.study import Study, sweep

    base = Path(__file__).resolve().parents[1] / "examples" / "time_optimal_circle.toml"
    table = sweep(Study.create(base, grid={"timing.effort": [0.3, 0.6]}), workers=0)
    assert list(table["status"]) == ["ok", "ok"]
    slow, fast = table.itertuples()
    assert fast.samples < slow.samples
    assert 0.3 <= slow.peak_effort < 0.3 * 1.1 and 0.6 <= fast.peak_effort < 0.6 * 1.1
