"""Kinematic calibration: a known perturbation of the geometry recovered from poses measured with noise — checked
on held-out poses through the calibrated machine's own inverse kinematics —, exactly without noise, what the
poses cannot determine reported as fixed (a passive link's tip across its length, which only turns a joint no
instrument sees; every fixed column in the span of the identified ones), D-optimal poses observing more than
random ones, and bad input refused by name."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms import calibration as cal


def _perturbed(model, rng, size=1e-3):
    return cal.perturbed_geometry(model, rng, size)


def _poses(true, offsets, count, rng, span=0.1):
    """``count`` poses of the true machine away from singularities, and the readings its actuators give there."""
    poses, q = cal.reachable_poses(true, count, rng, span=span, turn=3 * span)
    return poses, q[:, :true.n_actuators] - offsets


def _position_error(model, offsets, poses, thetas):
    """Held-out check by the calibrated machine's inverse kinematics: how far (m) each measured pose's point is
    from where the calibrated machine puts it at the readings (its forward kinematics nearest the pose)."""
    point = [i for i, n in enumerate(model.pose_names) if n in ("x", "y", "z")]
    errors = []
    for pose, theta in zip(poses, thetas, strict=True):
        fk = pkmlab.forward_kinematics(model, theta + offsets)
        points = fk.pose[: int(fk.count)][:, point]
        errors.append(np.linalg.norm(points - pose[point], axis=1).min())
    return np.array(errors)


def test_a_delta_is_calibrated_to_the_measurement_noise():
    """Every point off by up to 1 mm, every joint axis and actuator zero by up to 0.5° (54 parameters), 60 random
    poses measured with 10 µm noise: 50 held-out poses within 2x the noise."""
    rng = np.random.default_rng(0)
    model = pkmlab.load("delta")
    true, offsets = _perturbed(model, rng)
    poses, thetas = _poses(true, offsets, 110, rng)
    noise = 1e-5
    measured = poses + noise * rng.standard_normal(poses.shape)
    result = cal.calibrate(model, thetas[:60], measured[:60])
    assert result.rms_before > 50 * noise
    assert result.rms_after < 1.3 * noise
    errors = _position_error(result.model, result.offsets, poses[60:], thetas[60:])
    assert errors.max() <= 2 * noise, errors.max()


def test_noise_free_poses_give_an_exact_machine():
    rng = np.random.default_rng(1)
    model = pkmlab.load("paper")
    true, offsets = _perturbed(model, rng)
    poses, thetas = _poses(true, offsets, 50, rng)
    result = cal.calibrate(model, thetas[:30], poses[:30, :2])
    assert result.rms_after < 1e-10
    errors = _position_error(result.model, result.offsets, poses[30:], thetas[30:])
    assert errors.max() < 1e-9
    # a passive link's tip across its length only turns a passive joint's zero: nothing measured sees it
    assert {"body1_2_tip_y", "body2_2_tip_y", "body3_2_tip_y"} <= set(result.fixed)
    assert all(result.aliases[f"body{j}_2_tip_y"] == {} for j in (1, 2, 3))
    # an actuator's zero turns its link: the tip of a link of length l across it by l per radian
    for j, leg in enumerate(model.description.legs, start=1):
        length = float(np.hypot(*leg.bodies[0].tip))
        assert result.aliases[f"offset{j}"].keys() == {f"body{j}_1_tip_y"}
        assert result.aliases[f"offset{j}"][f"body{j}_1_tip_y"] == pytest.approx(length, rel=1e-5)
    assert len(result.summary()["singular_values"]) == len(result.names) - len(result.fixed)


def test_the_fixed_parameters_are_combinations_of_the_identified_ones():
    rng = np.random.default_rng(2)
    model = pkmlab.load("delta")
    poses, thetas = _poses(model, np.zeros(3), 30, rng)
    J = cal.calibration_jacobian(model, thetas, poses)
    result = cal.calibrate(model, thetas, poses)
    fixed = [result.names.index(n) for n in result.fixed]
    kept = [i for i in range(len(result.names)) if i not in fixed]
    for i in fixed:  # each fixed column is explained by the identified ones
        coefficients = np.linalg.lstsq(J[:, kept], J[:, i], rcond=None)[0]
        assert np.linalg.norm(J[:, kept] @ coefficients - J[:, i]) <= 1e-5 * np.linalg.norm(J, 2)
    assert np.linalg.matrix_rank(J[:, kept], tol=1e-6 * np.linalg.norm(J, 2)) == len(kept)


def test_d_optimal_poses_observe_more_than_random_ones():
    rng = np.random.default_rng(3)
    model = pkmlab.load("delta")
    poses, thetas = _poses(model, np.zeros(3), 200, rng)
    J = cal.calibration_jacobian(model, thetas, poses)
    keep = cal._independent(J)
    rows = J[:, keep].reshape(200, 3, keep.size)

    def logdet(indices):
        return np.linalg.slogdet(np.einsum("kij,kil->jl", rows[indices], rows[indices]))[1]

    chosen = cal.select_poses(model, thetas, poses, 12)
    assert len(set(chosen.tolist())) == 12
    random = [logdet(rng.choice(200, 12, replace=False)) for _ in range(20)]
    assert logdet(chosen) > max(random)


@pytest.mark.parametrize("change, message", [
    (lambda t, m: (t[:3], m[:3]), r"too few measurements: 9 measured coordinates"),
    (lambda t, m: (t, m[:-1]), r"measured has 19 poses but theta 20"),
    (lambda t, m: (t, m[:, :2]), r"measured must be one row per pose of the tracked point \(x, y, z\)"),
    (lambda t, m: (t, m * 1000), r"the measurements are .* \(RMS\) from where the described machine puts them, "
                                 r"more than its size \(0.8 m\): are they in metres and radians"),
])
def test_bad_calibration_input_is_refused_by_name(change, message):
    rng = np.random.default_rng(4)
    model = pkmlab.load("delta")
    poses, thetas = _poses(model, np.zeros(3), 20, rng)
    theta, measured = change(thetas, poses)
    with pytest.raises(pkmlab.PkmlabError, match=message):
        cal.calibrate(model, theta, measured)


def test_readings_that_do_not_assemble_the_machine_name_their_pose():
    rng = np.random.default_rng(5)
    model = pkmlab.load("paper")
    poses, thetas = _poses(model, np.zeros(3), 12, rng)
    thetas[5] = [0.0, 0.0, 0.0]  # the paper's machine cannot be assembled there
    with pytest.raises(pkmlab.PkmlabError, match=r"pose 5: the readings theta = \[0.0, 0.0, 0.0\] assemble"):
        cal.calibrate(model, thetas, poses[:, :2])


def _pkmlab(*args, cwd):
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "pkmlab.cli", *args], capture_output=True, text=True, cwd=cwd)


def test_pkmlab_calibrate_writes_a_calibrated_description(tmp_path):
    import json

    rng = np.random.default_rng(6)
    model = pkmlab.load("delta")
    true, offsets = _perturbed(model, rng)
    poses, thetas = _poses(true, offsets, 60, rng)
    table = np.column_stack([thetas[:40], poses[:40]])
    rows = ["theta1,theta2,theta3,x,y,z"] + [",".join(repr(float(v)) for v in row) for row in table]
    (tmp_path / "poses.csv").write_text("\n".join(rows) + "\n")
    held = ["theta1,theta2,theta3,x,y,z"] + [",".join(repr(float(v)) for v in row)
                                            for row in np.column_stack([thetas[40:], poses[40:]])]
    (tmp_path / "held.csv").write_text("\n".join(held) + "\n")
    done = _pkmlab("calibrate", "poses.csv", "--mechanism", "delta", "--validate", "held.csv", "--out", "cal",
                   "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    assert out == json.loads((tmp_path / "cal" / "calibration.json").read_text()) and out["rms_after"] < 1e-9
    calibrated = pkmlab.load(str(tmp_path / "cal" / "calibrated.toml"))
    errors = _position_error(calibrated, np.array(out["offsets"]), poses[40:], thetas[40:])
    assert errors.max() < 1e-8
    # the report's held-out check agrees with this one's (forward kinematics nearest each pose)
    described = _position_error(model, np.zeros(3), poses[40:], thetas[40:])
    check = out["validation"]
    assert check["poses"] == 20 and check["max_point_error_after"] < 1e-8
    assert check["max_point_error_before"] == pytest.approx(described.max(), rel=1e-6)
    assert (tmp_path / "cal" / "validation.png").stat().st_size > 10_000
    (tmp_path / "bad.csv").write_text("theta1,theta2,theta3,x,y\n0.1,0.2,0.3,0.0,0.0\n")
    bad = _pkmlab("calibrate", "poses.csv", "--validate", "bad.csv", "--mechanism", "delta", "--out", "cal2",
                  cwd=tmp_path)
    assert bad.returncode == 1 and len(bad.stderr.strip().splitlines()) == 1 and "missing column z" in bad.stderr
    assert not (tmp_path / "cal2").exists()


def test_a_machine_as_built_is_the_description_with_its_geometry_moved():
    model = pkmlab.load("five_bar")
    built, offsets = cal.perturbed_geometry(model, np.random.default_rng(4), size=1e-3)
    index = [model.kernels.PARAMETERS.index(n) for n in cal.geometric_parameters(model) if not n.startswith("offset")]
    moved = built.P[index] - model.P[index]
    assert 0 < np.abs(moved).max() <= 1e-3 and np.abs(offsets).max() <= np.deg2rad(0.5)
    others = np.setdiff1d(np.arange(len(model.P)), index)
    assert np.array_equal(built.P[others], model.P[others])  # masses, inertias, axes: as described
    with pytest.raises(pkmlab.PkmlabError, match="'offset1' is not a geometric parameter"):
        cal.with_geometry(model, {"offset1": 0.1})
    with pytest.raises(pkmlab.PkmlabError, match="only 0 of 3 poses .* reachable with"):
        cal.reachable_poses(model, 3, np.random.default_rng(0), margin=1e6)


def test_a_turned_rail_is_calibrated_exactly_from_noise_free_poses():
    """A 3-PRR whose first rail is 0.5° off its described angle: the rail's angle comes back, and the held-out
    poses with it (the machine as built checked on its description's own field)."""
    model = pkmlab.load("3prr")
    built = cal.with_geometry(model, {"rail1_angle": np.deg2rad(0.5)})
    assert built.description.legs[0].joints[0].axis == pytest.approx(model.description.legs[0].joints[0].axis
                                                                     + np.deg2rad(0.5), abs=1e-15)
    poses, thetas = _poses(built, np.zeros(3), 50, np.random.default_rng(5))
    result = cal.calibrate(model, thetas[:30], poses[:30], measure="pose")
    assert result.rms_before > 1e-4 and result.rms_after < 1e-10
    assert result.estimate[result.names.index("rail1_angle")] == pytest.approx(np.deg2rad(0.5), abs=1e-9)
    assert _position_error(result.model, result.offsets, poses[30:], thetas[30:]).max() < 1e-9


def test_spatial_axes_turn_as_rotations_and_are_calibrated_exactly():
    """A Delta with every hinge axis tilted and every universal joint turned by up to 0.5° (nothing else
    moved): each turned axis is the described one rotated by the rotation vector of its turns (SciPy's
    rotation, a second formulation), a universal joint's axes stay perpendicular, and noise-free poses give the
    machine back exactly."""
    from scipy.spatial.transform import Rotation

    model = pkmlab.load("delta")
    rng = np.random.default_rng(6)
    turns = {n: float(rng.uniform(-1, 1) * np.deg2rad(0.5)) for n in cal.geometric_parameters(model)
             if "_tilt_" in n or "_turn_" in n}
    built = cal.with_geometry(model, turns)
    for i, (leg, described) in enumerate(zip(built.description.legs, model.description.legs, strict=True)):
        hinge, u_joint = described.joints[0], described.joints[1]
        a = np.array(hinge.axes[0])
        e = np.eye(3)[int(np.argmin(np.abs(a)))]
        u = np.cross(a, e) / np.linalg.norm(np.cross(a, e))
        omega = turns[f"axis{i + 1}_1_tilt_u"] * u + turns[f"axis{i + 1}_1_tilt_v"] * np.cross(a, u)
        assert np.allclose(leg.joints[0].axes[0], Rotation.from_rotvec(omega).apply(a), atol=1e-15)
        omega = np.array([turns[f"axis{i + 1}_2_turn_{c}"] for c in "xyz"])
        for turned, axis in zip(leg.joints[1].axes, u_joint.axes, strict=True):
            assert np.allclose(turned, Rotation.from_rotvec(omega).apply(axis), atol=1e-15)
        assert abs(np.dot(*leg.joints[1].axes)) < 1e-12
    poses, thetas = _poses(built, np.zeros(3), 60, rng)
    result = cal.calibrate(model, thetas[:40], poses[:40])
    assert result.rms_before > 1e-5 and result.rms_after < 1e-10
    assert _position_error(result.model, result.offsets, poses[40:], thetas[40:]).max() < 1e-9


def test_the_3rrs_parallel_hinges_turn_as_one_and_the_3upu_axes_are_kept():
    """The 3-RRS's parallel hinges turn as one (a machine as built is still a 3-RRS), and the 3-UPU's axes, which
    keep its platform level, are not turned at all."""
    mechanisms = Path(__file__).parents[1] / "examples" / "mechanisms"
    rrs = pkmlab.load(mechanisms / "3rrs.toml")
    names = cal.geometric_parameters(rrs)
    assert {"axis1_1_2_tilt_u", "axis1_1_2_tilt_v"} <= set(names) and "axis1_1_tilt_u" not in names
    built, _ = cal.perturbed_geometry(rrs, np.random.default_rng(7))
    for leg, described in zip(built.description.legs, rrs.description.legs, strict=True):
        first, second = leg.joints[0].axes[0], leg.joints[1].axes[0]
        assert abs(abs(np.dot(first, second)) - 1) < 1e-12  # still parallel
        assert abs(np.dot(first, described.joints[0].axes[0])) < 1 - 1e-9  # and turned
    upu = pkmlab.load(mechanisms / "3upu.toml")
    assert not any("_tilt_" in n or "_turn_" in n for n in cal.geometric_parameters(upu))
