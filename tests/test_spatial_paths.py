"""Paths for spatial machines beyond waypoints: a circle in any plane of the platform's point, and a spline
through waypoints that does not stop at them.

Independent checks: positions against the circle's definition (on the sphere of its radius about the centre,
in the plane normal to its axis) and the planar :class:`~pkmlab.control.trajectory.Circle` about z; every
derivative against central finite differences; the spline through its points at their times, at rest at its
ends, its acceleration continuous at the inner knots; a run of the Stewart platform along a circle tracked.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import pkmlab
from pkmlab.control.trajectory import Circle, SpatialCircle, Spline, Trajectory
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


def test_a_stewart_platform_follows_a_circle_in_a_tilted_plane():
    scenario = scenario_from_dict(_stewart_circle(normal=[0.0, math.sin(0.3), math.cos(0.3)]), "circle.toml")
    result = pkmlab.simulate(scenario)
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-4
    # the tracked point went round: its distance from the centre is the radius, in the tilted plane
    offset = result.pose[:, :3] - np.array([0.0, 0.0, 0.85])
    assert np.abs(np.linalg.norm(offset, axis=1) - 0.02).max() < 1e-4
    assert np.abs(offset @ np.array([0.0, math.sin(0.3), math.cos(0.3)])).max() < 1e-4
