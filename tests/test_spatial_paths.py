"""Paths for spatial machines beyond waypoints: a circle in any plane of the platform's point, and a spline
through waypoints that does not stop at them.

Independent checks: positions against the circle's definition (on the sphere of its radius about the centre,
in the plane normal to its axis) and the planar :class:`~pkmlab.control.trajectory.Circle` about z; every
derivative against central finite differences; the spline through its points at their times, at rest at its
ends, its acceleration continuous at the inner knots; a run of the Stewart platform along a circle tracked;
geodesic orientation paths against SciPy's spherical interpolation (Slerp), their angles continuous through
yaw = π, and a Stewart run turning along them.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

import pkmlab
from pkmlab.control.trajectory import Circle, SpatialCircle, Spline, TimedWaypoints, Trajectory
from pkmlab.errors import FileFormatError, InvalidParameterError
from pkmlab.formats.scenario import scenario_from_dict


def _finite_differences(desired, t, h=1e-6, h2=1e-4):
    """Central differences of the pose: its rate (step ``h``) and its acceleration (the longer step ``h2``,
    whose round-off ``eps |p| / h2²`` is small)."""
    p_plus, _, _ = desired(t + h)
    p_minus, _, _ = desired(t - h)
    q_plus, _, _ = desired(t + h2)
    q_minus, _, _ = desired(t - h2)
    p, _, _ = desired(t)
    return (p_plus - p_minus) / (2 * h), (q_plus - 2 * p + q_minus) / h2**2


def test_a_spatial_circle_lies_on_its_circle_and_its_derivatives_are_exact():
    normal = np.array([0.3, -0.2, 0.9])
    path = SpatialCircle((0.1, -0.05, 0.8), 0.04, tuple(normal), start_angle=0.4, orientation=(0.05, -0.02, 0.1))
    trajectory = Trajectory(path, 0.1, "quintic")
    t = np.linspace(0.05, trajectory.duration - 0.05, 37)
    pose, velocity, acceleration = trajectory.desired(t)
    offset = pose[:, :3] - np.array(path.center)
    np.testing.assert_allclose(np.linalg.norm(offset, axis=1), 0.04, rtol=1e-14)
    np.testing.assert_allclose(offset @ (normal / np.linalg.norm(normal)), 0.0, atol=1e-15)
    np.testing.assert_array_equal(pose[:, 3:], np.broadcast_to([0.05, -0.02, 0.1], (len(t), 3)))
    fd_velocity, fd_acceleration = _finite_differences(trajectory.desired, t)
    np.testing.assert_allclose(velocity, fd_velocity, atol=1e-9)
    np.testing.assert_allclose(acceleration, fd_acceleration, atol=1e-6)
    # counter-clockwise about its normal (the right-hand rule)
    assert np.all(np.cross(offset, velocity[:, :3]) @ normal > 0)


def test_a_spatial_circle_about_z_is_the_planar_circle():
    planar = Trajectory(Circle((0.25, 0.21), 0.05), 0.2, "cubic")
    spatial = Trajectory(SpatialCircle((0.25, 0.21, -0.7), 0.05), 0.2, "cubic")
    t = np.linspace(0.0, planar.duration, 11)
    for k, (a, b) in enumerate(zip(planar.desired(t), spatial.desired(t), strict=True)):
        np.testing.assert_allclose(b[:, :2], a[:, :2], atol=1e-15)
        np.testing.assert_allclose(b[:, 2], -0.7 if k == 0 else 0.0, atol=1e-15)  # z: held


def test_a_spline_passes_its_points_without_stopping():
    points = ((0.0, 0.0, 0.85, 0.0, 0.0, 0.0), (0.03, -0.02, 0.88, 0.05, 0.0, 0.1),
              (0.0, 0.03, 0.9, 0.0, -0.05, 0.0), (0.0, 0.0, 0.85, 0.0, 0.0, 0.0))
    spline = Spline(points, (0.4, 0.3, 0.5))
    knots = np.array([0.0, 0.4, 0.7, 1.2])
    pose, velocity, _ = spline.desired(knots)
    np.testing.assert_allclose(pose, points, atol=1e-15)
    np.testing.assert_allclose(velocity[[0, -1]], 0.0, atol=1e-15)  # at rest at its ends
    assert np.all(np.linalg.norm(velocity[1:-1], axis=1) > 1e-3)  # not at the inner points
    # exact derivatives, and an acceleration continuous across the inner knots
    t = np.linspace(0.01, 1.19, 50)
    _, v, a = spline.desired(t)
    fd_v, fd_a = _finite_differences(spline.desired, t)
    np.testing.assert_allclose(v, fd_v, atol=1e-8)
    np.testing.assert_allclose(a, fd_a, atol=1e-5)
    for k in knots[1:-1]:
        _, _, left = spline.desired(np.array([k - 1e-9]))
        _, _, right = spline.desired(np.array([k + 1e-9]))
        np.testing.assert_allclose(left, right, atol=1e-6)
    # at rest outside [0, T]
    before, v_before, a_before = spline.desired(np.array([-0.3, 2.0]))
    np.testing.assert_allclose(before, [points[0], points[-1]], atol=1e-15)
    assert not v_before.any() and not a_before.any()


def _stewart_circle(**extra):
    trajectory = {"type": "circle", "center": [0.0, 0.0, 0.85], "radius": 0.02, "speed": 0.1,
                  "orientation": [0.0, 0.0, 0.0], "time_law": "quintic", **extra}
    return {"mechanism": {"preset": "stewart"}, "trajectory": trajectory,
            "controller": {"type": "computed_torque", "kp": 2500.0, "sample_time": 0.001}}


def test_scenario_files_give_spatial_circles_and_splines():
    scenario = scenario_from_dict(_stewart_circle(normal=[0.0, 1.0, 1.0]), "circle.toml")
    assert isinstance(scenario.trajectory.path, SpatialCircle) and scenario.trajectory.dimension == 6
    spline = {"mechanism": {"preset": "delta"},
              "trajectory": {"type": "spline", "points": [[0, 0, -0.75], [0.05, 0, -0.72], [0, 0.05, -0.75]],
                             "durations": [0.2, 0.2]}}
    assert isinstance(scenario_from_dict(spline, "spline.toml").trajectory, Spline)
    with pytest.raises(FileFormatError, match=r"alpha.*planar circle's"):
        scenario_from_dict(_stewart_circle(alpha=0.1), "bad.toml")
    with pytest.raises(InvalidParameterError, match=r"orientation must be 3 numbers \[roll, pitch, yaw\]"):
        scenario_from_dict({**_stewart_circle(), "trajectory": {**_stewart_circle()["trajectory"],
                                                                "orientation": [0.0, 0.0]}}, "bad.toml")
    delta = {"mechanism": {"preset": "delta"}, "trajectory": _stewart_circle()["trajectory"]}
    with pytest.raises(InvalidParameterError, match=r"6 coordinates, but the delta.s pose is \(x, y, z\)"):
        scenario_from_dict(delta, "bad.toml")
    with pytest.raises(FileFormatError, match=r"durations is missing"):
        scenario_from_dict({"mechanism": {"preset": "delta"}, "trajectory": {"type": "spline", "points": [
            [0, 0, -0.75], [0.05, 0, -0.72]]}}, "bad.toml")


def test_the_report_of_a_spline_run_describes_its_timing(tmp_path):
    from pkmlab.report import simulation_report

    scenario = scenario_from_dict({"mechanism": {"preset": "delta"}, "trajectory": {
        "type": "spline", "points": [[0, 0, -0.75], [0.05, 0, -0.72], [0, 0.05, -0.75]], "durations": [0.2, 0.2]}},
        "spline.toml")
    simulation_report(scenario, tmp_path / "out", figures=False)
    report = (tmp_path / "out" / "REPORT.md").read_text()
    assert "3 waypoints from [0.0, 0.0, -0.75]" in report and "a cubic spline through them" in report


def test_a_stewart_platform_follows_a_circle_in_a_tilted_plane():
    scenario = scenario_from_dict(_stewart_circle(normal=[0.0, math.sin(0.3), math.cos(0.3)]), "circle.toml")
    result = pkmlab.simulate(scenario)
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-4
    # the tracked point went round: its distance from the centre is the radius, in the tilted plane
    offset = result.pose[:, :3] - np.array([0.0, 0.0, 0.85])
    assert np.abs(np.linalg.norm(offset, axis=1) - 0.02).max() < 1e-4
    assert np.abs(offset @ np.array([0.0, math.sin(0.3), math.cos(0.3)])).max() < 1e-4


# ------------------------------------------------------------------ geodesic orientation paths
def _rotations(angles):
    """R = Rz(yaw) Ry(pitch) Rx(roll) by SciPy (extrinsic x, y, z), independent of pkmlab's."""
    return Rotation.from_euler("xyz", np.asarray(angles).reshape(-1, 3)).as_matrix()


GEODESIC_POINTS = ((0.0, 0.0, 0.85, 0.0, 0.0, 0.0), (0.03, -0.02, 0.88, 0.25, -0.2, 0.6),
                   (0.0, 0.02, 0.86, -0.1, 0.3, -0.4))


def test_a_geodesic_orientation_path_is_slerp_with_exact_angle_rates():
    waypoints = TimedWaypoints(GEODESIC_POINTS, (0.4, 0.5), "quintic", orientation_path="geodesic")
    straight = TimedWaypoints(GEODESIC_POINTS, (0.4, 0.5), "quintic")
    t = np.linspace(0.0, 0.9, 91)
    pose, velocity, acceleration = waypoints.desired(t)
    # positions as the straight path's; orientations as SciPy's spherical interpolation at the same fraction
    reference = straight.desired(t)[0]
    np.testing.assert_array_equal(pose[:, :3], reference[:, :3])
    for k, (start, span) in enumerate(((0.0, 0.4), (0.4, 0.5))):
        inside = (t >= start) & (t <= start + span)
        sigma = (reference[inside, 0] - GEODESIC_POINTS[k][0]) / (GEODESIC_POINTS[k + 1][0] - GEODESIC_POINTS[k][0])
        slerp = Slerp([0.0, 1.0], Rotation.from_euler("xyz", [GEODESIC_POINTS[k][3:], GEODESIC_POINTS[k + 1][3:]]))
        np.testing.assert_allclose(_rotations(pose[inside, 3:]), slerp(sigma).as_matrix(), atol=1e-12)
    # the waypoints are reached, and a geodesic differs from the straight line in angles
    np.testing.assert_allclose(_rotations(pose[[0, 40, 90], 3:]), _rotations(np.array(GEODESIC_POINTS)[:, 3:]),
                               atol=1e-12)
    assert np.abs(pose[:, 3:] - reference[:, 3:]).max() > 1e-3
    # the angles' rates and accelerations are those of the motion (central differences)
    inner = np.concatenate([np.linspace(0.01, 0.39, 20), np.linspace(0.41, 0.89, 20)])
    fd_velocity, fd_acceleration = _finite_differences(waypoints.desired, inner)
    _, v, a = waypoints.desired(inner)
    np.testing.assert_allclose(v, fd_velocity, atol=1e-8)
    np.testing.assert_allclose(a, fd_acceleration, atol=1e-5)
    # the angular velocity they give is about the turn's one axis (world frame)
    turn = Rotation.from_euler("xyz", GEODESIC_POINTS[1][3:]) * Rotation.from_euler("xyz", GEODESIC_POINTS[0][3:]).inv()
    axis = turn.as_rotvec() / np.linalg.norm(turn.as_rotvec())
    pose, v, _ = waypoints.desired(np.linspace(0.02, 0.38, 7))
    for (_, pitch, yaw), rates in zip(pose[:, 3:], v[:, 3:], strict=True):
        roll_axis = _rotations([0.0, pitch, yaw])[0] @ [1.0, 0.0, 0.0]
        pitch_axis = _rotations([0.0, 0.0, yaw])[0] @ [0.0, 1.0, 0.0]
        omega = rates[0] * roll_axis + rates[1] * pitch_axis + rates[2] * np.array([0.0, 0.0, 1.0])
        np.testing.assert_allclose(np.cross(omega, axis), 0.0, atol=1e-12)


def test_geodesic_angles_stay_continuous_through_a_half_turn_of_yaw():
    # yaw 2.9 to -2.9: the shortest turn goes through yaw = pi (0.48 rad), not back through 0
    points = ((0.0, 0.0, 0.85, 0.05, 0.0, 2.9), (0.0, 0.0, 0.85, 0.05, 0.0, -2.9))
    waypoints = TimedWaypoints(points, (0.5,), orientation_path="geodesic")
    pose, _, _ = waypoints.desired(np.linspace(0.0, 0.5, 201))
    assert np.abs(np.diff(pose[:, 3:], axis=0)).max() < 0.01
    np.testing.assert_allclose(pose[-1, 5], -2.9 + 2 * math.pi, atol=1e-12)  # the end's yaw, a whole turn on
    np.testing.assert_allclose(_rotations(pose[-1, 3:]), _rotations(points[1][3:]), atol=1e-12)


def test_a_tiny_geodesic_turn_is_followed_exactly():
    points = ((0.0, 0.0, 0.85, 0.1, -0.05, 0.2), (0.0, 0.0, 0.86, 0.1, -0.05, 0.2 + 1e-7))
    waypoints = TimedWaypoints(points, (0.5,), orientation_path="geodesic")
    pose, velocity, _ = waypoints.desired(np.array([0.25, 0.5]))
    np.testing.assert_allclose(pose[1, 3:], points[1][3:], atol=1e-15)
    np.testing.assert_allclose(velocity[0, 3:], [0.0, 0.0, 1e-7 * 1.875 / 0.5], rtol=1e-6, atol=1e-16)  # peak 15/8


def test_geodesic_orientation_paths_are_refused_where_they_have_no_meaning():
    with pytest.raises(InvalidParameterError, match=r"needs poses \(x, y, z, roll, pitch, yaw\).*of 3 coordinates"):
        TimedWaypoints(((0.0, 0.0, -0.75), (0.05, 0.0, -0.72)), (0.3,), orientation_path="geodesic")
    with pytest.raises(InvalidParameterError, match=r"orientation_path"):
        TimedWaypoints(GEODESIC_POINTS, (0.4, 0.5), orientation_path="slerp")
    with pytest.raises(InvalidParameterError, match=r"points\[0\] to points\[1\]: a half turn"):
        TimedWaypoints(((0.0, 0.0, 0.85, 0.0, 0.0, 0.0), (0.0, 0.0, 0.85, 0.0, 0.0, math.pi)), (0.5,),
                       orientation_path="geodesic")
    # pitch 1.3 on by 0.6 about y goes over the pole: the end's angles are (pi, pi - 1.9, pi)
    over_the_pole = ((0.0, 0.0, 0.85, 0.0, 1.3, 0.0), (0.0, 0.0, 0.85, math.pi, math.pi - 1.9, math.pi))
    with pytest.raises(InvalidParameterError, match=r"points\[1\] to points\[2\]: .*near pitch = ±pi/2 .*gimbal lock"):
        TimedWaypoints(((0.0, 0.0, 0.85, 0.0, 0.0, 0.0),) + over_the_pole, (0.5, 0.5), orientation_path="geodesic")
    # stopping short of it (pitch 1.3 to 1.5) is a turn like any other
    TimedWaypoints((over_the_pole[0], (0.0, 0.0, 0.85, 0.0, 1.5, 0.0)), (0.5,), orientation_path="geodesic")


def _stewart_waypoints(**extra):
    return {"mechanism": {"preset": "stewart"},
            "trajectory": {"type": "waypoints", "points": [list(p) for p in GEODESIC_POINTS],
                           "durations": [0.4, 0.5], **extra},
            "controller": {"type": "computed_torque", "kp": 2500.0, "sample_time": 0.001}}


def test_a_stewart_platform_turns_along_geodesics_from_a_scenario_file():
    scenario = scenario_from_dict(_stewart_waypoints(orientation_path="geodesic"), "geodesic.toml")
    assert scenario.trajectory.orientation_path == "geodesic"
    assert scenario_from_dict(_stewart_waypoints(), "straight.toml").trajectory.orientation_path == "angles"
    with pytest.raises(InvalidParameterError, match=r"orientation_path.*did you mean 'geodesic'"):
        scenario_from_dict(_stewart_waypoints(orientation_path="geodesik"), "bad.toml")
    delta = {"mechanism": {"preset": "delta"}, "trajectory": {
        "type": "waypoints", "points": [[0, 0, -0.75], [0.05, 0, -0.72]], "durations": [0.3],
        "orientation_path": "geodesic"}}
    with pytest.raises(InvalidParameterError, match=r"orientation_path = \"geodesic\".*not 3 numbers"):
        scenario_from_dict(delta, "bad.toml")
    half_turn = _stewart_waypoints(orientation_path="geodesic")
    half_turn["trajectory"]["points"][1][3:] = [0.0, 0.0, math.pi]
    with pytest.raises(InvalidParameterError, match=r"bad.toml: \[trajectory\].points\[0\] to points\[1\]: a half"):
        scenario_from_dict(half_turn, "bad.toml")
    result = pkmlab.simulate(scenario)
    assert result.summary()["max_path_error_m"] < 1e-4
    # the platform turned as SciPy's spherical interpolation says, to the tracking error
    halfway = np.argmin(np.abs(result.t - 0.2))
    slerp = Slerp([0.0, 1.0], Rotation.from_euler("xyz", [GEODESIC_POINTS[0][3:], GEODESIC_POINTS[1][3:]]))
    expected = slerp([0.5]).as_matrix()[0]  # the quintic law is half-way at half the time
    assert np.linalg.norm(_rotations(result.pose[halfway, 3:])[0] - expected) < 1e-3
