"""The Delta robot (``delta`` preset) against an independent statement of its geometry and energy
(tests/reference_delta.py), and the invariants every mechanism must satisfy."""

from __future__ import annotations

import numpy as np
import pytest
import reference_delta as ref
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from pkmlab.algorithms import assembly
from pkmlab.description.presets import preset
from pkmlab.errors import InvalidParameterError, UnreachablePoseError
from pkmlab.model import mechanism_model as mm
from pkmlab.model.mechanism_model import MechanismModel
from pkmlab.numerics.angles import wrapped_angle

MODEL = MechanismModel.from_preset("delta")
MODES = mm.working_modes(MODEL)
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
# the whole region below the base, where knee out and knee in differ by a millimetre at least
positions = st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(-1.15, -0.05))


def configuration(p, mode):
    try:
        q = mm.inverse_kinematics(MODEL, p, mode)
    except UnreachablePoseError:
        assume(False)
    assume(ref.knee_gap(p) > 1e-3)
    assume(abs(mm.singularity_measure(MODEL, q)) > 0.05)
    return q


def forward(theta, p_near):
    """The reference's assembly mode nearest ``p_near`` (to follow it by finite differences)."""
    found = ref.positions(theta)
    return min(found, key=lambda p: np.linalg.norm(p - p_near))


def test_eight_working_modes_knee_out_first():
    assert len(MODES) == 8 and MODES[0] == (1, 1, 1) and MODES[-1] == (-1, -1, -1)
    q = mm.inverse_kinematics(MODEL, [0.03, 0.02, -0.7], (1, 1, 1))
    elbows = ref.elbows(q[:3])
    other = ref.elbows(mm.inverse_kinematics(MODEL, [0.03, 0.02, -0.7], (-1, -1, -1))[:3])
    # knee out: each elbow farther from the z axis than in the other branch
    assert np.all(np.hypot(elbows[:, 0], elbows[:, 1]) > np.hypot(other[:, 0], other[:, 1]))


@SETTINGS
@given(positions, st.sampled_from(MODES))
def test_inverse_kinematics_against_reference(p, mode):
    q = configuration(p, mode)
    # angles compared the shorter way round: a crank at a half turn is -π to one and π to the other
    assert np.allclose(wrapped_angle(q[:3] - ref.inverse_kinematics(p, tuple(s > 0 for s in mode))), 0.0, atol=1e-12)
    assert np.max(np.abs(mm.constraint_residual(MODEL, q))) < 1e-12
    assert np.allclose(q[-3:], p)


@SETTINGS
@given(positions, st.sampled_from(MODES))
def test_forward_kinematics_of_inverse_finds_the_pose_and_both_assembly_modes(p, mode):
    q = configuration(p, mode)
    found = assembly.assembly_modes(MODEL, q[:3])
    expected = ref.positions(q[:3])  # an independent count: the three spheres' real intersections
    assert len(found) == len(expected) == 2
    for (qf, s), pe in zip(found, expected, strict=True):
        assert np.allclose(qf[-3:], pe, atol=1e-10)
        assert np.max(np.abs(mm.constraint_residual(MODEL, qf))) < 1e-12
        assert s == pytest.approx(ref.singularity_measure(q[:3], pe), abs=1e-12)
    assert min(np.linalg.norm(qf[-3:] - p) for qf, _s in found) < 1e-10


@SETTINGS
@given(positions, st.sampled_from(MODES))
def test_constraint_jacobian_against_finite_differences(p, mode):
    q = configuration(p, mode)
    jac = mm.constraint_jacobian(MODEL, q)
    h = 1e-6
    fd = np.column_stack([(mm.constraint_residual(MODEL, q + h * e) - mm.constraint_residual(MODEL, q - h * e))
                          / (2 * h) for e in np.eye(len(q))])
    assert np.allclose(jac, fd, atol=1e-8)


@SETTINGS
@given(positions, st.sampled_from(MODES), st.lists(st.floats(-3, 3), min_size=3, max_size=3))
def test_actuator_space_model_against_the_energy(p, mode, rates):
    q = configuration(p, mode)
    theta, theta_dot = q[:3], np.array(rates)
    M, c, g = mm.actuator_space_model(MODEL, q, theta_dot)
    assert np.allclose(M, M.T, atol=1e-15) and np.all(np.linalg.eigvalsh(M) > 0)
    assert np.allclose(M, ref.mass_matrix(theta, p), atol=1e-13)
    h = 1e-6
    grad_v, m_dot, grad_t = np.zeros(3), np.zeros((3, 3)), np.zeros(3)
    for i, e in enumerate(np.eye(3)):
        hi, lo = theta + h * e, theta - h * e
        phi, plo = forward(hi, p), forward(lo, p)
        grad_v[i] = (ref.potential(hi, phi) - ref.potential(lo, plo)) / (2 * h)
        grad_t[i] = 0.5 * theta_dot @ (ref.mass_matrix(hi, phi) - ref.mass_matrix(lo, plo)) @ theta_dot / (2 * h)
    hi, lo = theta + h * theta_dot, theta - h * theta_dot
    m_dot = (ref.mass_matrix(hi, forward(hi, p)) - ref.mass_matrix(lo, forward(lo, p))) / (2 * h)
    assert np.allclose(g, grad_v, atol=1e-7)  # g = ∂V/∂θ
    # Lagrange: c = Ṁ θ̇ - ∂T/∂θ
    assert np.allclose(c, m_dot @ theta_dot - grad_t, atol=1e-6 * (1 + np.abs(theta_dot).max() ** 2))


@SETTINGS
@given(positions, st.sampled_from(MODES), st.lists(st.floats(-3, 3), min_size=3, max_size=3),
       st.lists(st.floats(-20, 20), min_size=3, max_size=3))
def test_power_balance_with_gravity(p, mode, rates, efforts):
    """τ·θ̇ = dT/dt + dV/dt along the motion the model predicts under τ."""
    q = configuration(p, mode)
    theta, theta_dot, tau = q[:3], np.array(rates), np.array(efforts)
    M, c, g = mm.actuator_space_model(MODEL, q, theta_dot)
    theta_ddot = np.linalg.solve(M, tau - c - g)
    h = 1e-6
    hi, lo = theta + h * theta_dot, theta - h * theta_dot
    phi, plo = forward(hi, p), forward(lo, p)
    m_dot = (ref.mass_matrix(hi, phi) - ref.mass_matrix(lo, plo)) / (2 * h)
    dT = theta_dot @ M @ theta_ddot + 0.5 * theta_dot @ m_dot @ theta_dot
    dV = (ref.potential(hi, phi) - ref.potential(lo, plo)) / (2 * h)
    assert tau @ theta_dot == pytest.approx(dT + dV, abs=1e-6 * (1 + np.abs(tau @ theta_dot)))


@SETTINGS
@given(positions, st.sampled_from(MODES), st.lists(st.floats(-3, 3), min_size=3, max_size=3),
       st.lists(st.floats(-20, 20), min_size=3, max_size=3))
def test_reduced_model_equals_full_multiplier_model(p, mode, rates, efforts):
    q = configuration(p, mode)
    theta_dot, tau = np.array(rates), np.array(efforts)
    M, c, g = mm.actuator_space_model(MODEL, q, theta_dot)
    theta_ddot = np.linalg.solve(M, tau - c - g)
    jac = mm.constraint_jacobian(MODEL, q)
    passive = np.linalg.solve(jac[:, 3:], -jac[:, :3] @ theta_dot)
    q_dot = np.concatenate([theta_dot, passive])
    q_ddot, _lam = mm.constrained_accelerations(MODEL, q, q_dot, tau)
    assert np.allclose(q_ddot[:3], theta_ddot, atol=1e-9 * (1 + np.abs(theta_ddot).max()))


def test_gravity_effort_does_the_work_of_lifting():
    """g = ∂V/∂θ, checked by virtual work: moving the arms by δθ lifts the bodies by δV = g·δθ, with the
    platform's motion from the reference's three-sphere solution; on the axis the three efforts are equal
    and hold the arms up (θ is positive down)."""
    for p in ([0.0, 0.0, -0.75], [0.21, -0.13, -0.9], [-0.35, 0.2, -0.6]):
        q = mm.inverse_kinematics(MODEL, p, (1, 1, 1))
        _M, _c, g = mm.actuator_space_model(MODEL, q, np.zeros(3))
        step = np.array([1.0, -0.6, 0.3]) * 1e-6
        theta = q[:3]
        lifted = ref.potential(theta + step, forward(theta + step, p)) - ref.potential(theta - step,
                                                                                        forward(theta - step, p))
        assert g @ (2 * step) == pytest.approx(lifted, rel=1e-6)
    q = mm.inverse_kinematics(MODEL, [0.0, 0.0, -0.75], (1, 1, 1))
    g = mm.actuator_space_model(MODEL, q, np.zeros(3))[2]
    assert np.allclose(g, g[0]) and g[0] < 0


def test_bad_poses_name_the_leg():
    with pytest.raises(UnreachablePoseError, match="leg 1 .*R\\*US"):
        mm.inverse_kinematics(MODEL, [0.05, -0.03, -0.2], (1, 1, 1))
    with pytest.raises(InvalidParameterError, match=r"pose must be \(x, y, z\)"):
        mm.inverse_kinematics(MODEL, [0.0, 0.0, float("nan")], (1, 1, 1))
    with pytest.raises(InvalidParameterError, match="theta must be 3 finite values"):
        assembly.assembly_modes(MODEL, [0.1, 0.2])


def test_singularity_measure_is_bounded_and_keeps_its_sign_down_the_axis():
    """S is a determinant of unit vectors (|S| <= 1); straight below the base, in the knee-out mode, the
    forearms never become coplanar, so S keeps one sign all the way down."""
    zs = np.linspace(-0.3, -1.1, 161)
    s = np.array([mm.singularity_measure(MODEL, mm.inverse_kinematics(MODEL, [0.0, 0.0, z], (1, 1, 1)))
                  if _reachable([0.0, 0.0, z]) else np.nan for z in zs])
    ok = np.isfinite(s)
    assert ok.sum() > 50
    assert np.all(np.abs(s[ok]) <= 1.0 + 1e-12)
    assert np.all(s[ok] < 0)


def _reachable(p):
    try:
        mm.inverse_kinematics(MODEL, p, (1, 1, 1))
    except UnreachablePoseError:
        return False
    return True


def test_description_refuses_degenerate_universal_joint():
    from dataclasses import replace

    from pkmlab.description.spatial import SpatialJoint, SpatialMechanism

    delta = preset("delta")
    leg = delta.legs[1]
    skew = replace(leg, joints=(leg.joints[0], SpatialJoint("U", False, (leg.joints[0].axes[0],
                                                                         leg.joints[0].axes[0])), leg.joints[2]))
    with pytest.raises(InvalidParameterError, match="leg 2, joint 2 \\(U\\): its two axes must be perpendicular"):
        SpatialMechanism("bad", (delta.legs[0], skew, delta.legs[2]), delta.platform, delta.gravity)


# ------------------------------------------------------------------ the pick-and-place cycle
from pathlib import Path  # noqa: E402

from pkmlab import load_scenario, simulate  # noqa: E402
from pkmlab.control.trajectory import TimedWaypoints  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "delta_pick_and_place.toml"


@pytest.fixture(scope="module")
def cycle():
    return simulate(load_scenario(EXAMPLE))


def test_pick_and_place_reports_what_every_machine_reports(cycle):
    s = cycle.summary()
    assert set(s) == {"max_path_error_m", "rms_path_error_m", "max_joint_error", "peak_effort", "min_abs_S",
                      "working_mode", "max_joint_error_rad", "peak_torque_Nm"}  # no orientation: it translates
    assert (s["max_joint_error_rad"], s["peak_torque_Nm"]) == (s["max_joint_error"], s["peak_effort"])
    assert cycle.columns[10:17] == ("x", "y", "z", "x_d", "y_d", "z_d", "S")
    assert s["working_mode"] == [1, 1, 1] and len(s["peak_effort"]) == 3
    # the path error is the distance in space between the actual and the desired point
    assert s["max_path_error_m"] == pytest.approx(np.linalg.norm(cycle.pose - cycle.pose_d, axis=1).max())
    # the cycle ends where it began, at rest
    assert np.allclose(cycle.pose_d[0], [-0.1525, 0.0, -0.75]) and np.allclose(cycle.pose_d[-1], cycle.pose_d[0])
    assert cycle.t[-1] == pytest.approx(0.5)


def test_pick_and_place_starts_gravity_compensated(cycle):
    """At rest on the start's IK, the first effort is the gravity effort g = ∂V/∂θ (the quintic starts with
    no acceleration, and there is no error yet), checked against the reference's potential energy."""
    theta = cycle.theta[0]
    p = cycle.pose[0]
    h, grad = 1e-6, np.zeros(3)
    for i, e in enumerate(np.eye(3)):
        grad[i] = (ref.potential(theta + h * e, forward(theta + h * e, p))
                   - ref.potential(theta - h * e, forward(theta - h * e, p))) / (2 * h)
    assert np.allclose(cycle.tau[0], grad, atol=1e-6)
    assert np.allclose(cycle.theta[0], ref.inverse_kinematics(p))


def test_pick_and_place_plant_is_integrated_far_below_the_tracking_error(cycle):
    fine = simulate(load_scenario(EXAMPLE).replace(substeps=8))
    assert np.abs(fine.q - cycle.q).max() < 1e-9
    assert cycle.summary()["max_path_error_m"] > 1e4 * np.abs(fine.pose - cycle.pose).max()


def test_continuous_time_control_with_the_exact_model_tracks_to_integration_level():
    scenario = load_scenario(EXAMPLE)
    first = TimedWaypoints(scenario.trajectory.points[:3], scenario.trajectory.durations[:2])
    run = simulate(scenario.replace(trajectory=first, sample_time=0.0))
    assert run.summary()["max_path_error_m"] < 1e-9


def test_a_path_out_of_reach_names_the_time_and_the_leg():
    scenario = load_scenario(EXAMPLE)
    far = TimedWaypoints(((0.0, 0.0, -0.75), (0.0, 0.0, -0.3)), (0.2,))
    with pytest.raises(UnreachablePoseError, match=r"t = 0\.\d+ s.*leg \d \(R\*US\)"):
        simulate(scenario.replace(trajectory=far))


def test_a_planar_path_is_refused_for_the_delta():
    from pkmlab.control.trajectory import paper_trajectory

    with pytest.raises(InvalidParameterError, match="delta is spatial"):
        load_scenario(EXAMPLE).replace(trajectory=paper_trajectory())


def test_the_controllers_own_model_may_differ_from_the_plant():
    from pkmlab.description.spatial import scaled_spatial_mechanism

    scenario = load_scenario(EXAMPLE)
    plant = MechanismModel.from_description(scaled_spatial_mechanism(preset("delta"), mass=1.15))
    run = simulate(scenario.replace(plant=plant))
    nominal = simulate(scenario).summary()["max_path_error_m"]
    assert nominal < run.summary()["max_path_error_m"] < 0.01


# ------------------------------------------------------------------ the command line
def test_cli_simulate_animate_and_workspace(tmp_path, capsys):
    import json

    from pkmlab.cli import main

    out = tmp_path / "run"
    assert main(["simulate", str(EXAMPLE), "--out", str(out), "--json"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["working_mode"] == [1, 1, 1] and "max_orientation_error_rad" not in summary
    assert {"machine.png", "path.png", "path_error.png", "torques.png", "singularity_along_path.png"} <= {
        p.name for p in out.iterdir()}
    capsys.readouterr()
    gif = tmp_path / "run.gif"
    assert main(["animate", str(out), "--out", str(gif), "--stride", "200", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["frames"] == 6 and report["max_centroid_deviation_m"] < 1e-9 and gif.stat().st_size > 0
    figure = tmp_path / "slices.png"
    assert main(["workspace", "--mechanism", "delta", "--z", "-0.6", "-0.9", "--resolution", "41", "--out",
                 str(figure), "--json"]) == 0
    slices = json.loads(capsys.readouterr().out)["slices"]
    # the reachable area shrinks as the platform goes down towards the forearms' full stretch
    assert [s["z"] for s in slices] == [-0.6, -0.9] and slices[0]["area_m2"] > slices[1]["area_m2"] > 0
    assert figure.stat().st_size > 0


def test_cli_refuses_an_orientation_for_the_delta(tmp_path, capsys):
    from pkmlab.cli import main

    out = tmp_path / "x.png"
    assert main(["workspace", "--mechanism", "delta", "--alpha", "0.3", "--out", str(out)]) == 1
    assert "--alpha is a planar platform's orientation" in capsys.readouterr().err and not out.exists()


def test_scenario_errors_name_the_file_and_the_key(tmp_path):
    from pkmlab.errors import PkmlabError

    text = EXAMPLE.read_text()
    bad = tmp_path / "short.toml"
    bad.write_text(text.replace("[-0.1525, 0.0, -0.725],\n  [0.1525, 0.0, -0.725],",
                                "[-0.1525, 0.0],\n  [0.1525, 0.0],", 1))
    with pytest.raises(PkmlabError, match=r"short\.toml: \[trajectory\]\.points\[1\] must be 3 numbers"):
        load_scenario(bad)
    flat = tmp_path / "flat.toml"  # the heights dropped: (x, z) pairs that differ, but two coordinates
    flat.write_text(text.replace(", 0.0, -0.75]", ", -0.75]").replace(", 0.0, -0.725]", ", -0.725]"))
    with pytest.raises(PkmlabError, match=r"flat\.toml: the trajectory's poses have 2 coordinates, but the delta's"):
        load_scenario(flat)


def test_a_heavier_plant_from_the_scenario_file(tmp_path):
    path = tmp_path / "heavy.toml"
    path.write_text(EXAMPLE.read_text() + "\n[plant]\nmass_scale = 1.15\n")
    scenario = load_scenario(path)
    legs = zip(scenario.plant.description.legs, preset("delta").legs, strict=True)
    assert all(p.bodies[0].mass == pytest.approx(1.15 * d.bodies[0].mass) for p, d in legs)
    assert scenario.plant.description.platform.mass == pytest.approx(0.345)
    run = simulate(scenario).summary()
    assert 1e-4 < run["max_path_error_m"] < 1e-2  # the controller's model is lighter than the machine


def test_a_universal_joint_that_cannot_turn_the_forearm_is_a_leg_that_cannot_reach():
    """A forearm whose tip is not across both axes of its universal joint reaches only some directions:
    inverse kinematics says so for the leg, and never returns a configuration that does not close."""
    from dataclasses import replace

    from pkmlab.description.spatial import SpatialMechanism

    delta = preset("delta")
    legs = []
    for leg in delta.legs:
        w = np.array(leg.bodies[0].tip) / 0.35
        forearm = replace(leg.bodies[1], tip=tuple(0.3 * w + np.array([0.0, 0.0, -0.74])))
        legs.append(replace(leg, bodies=(leg.bodies[0], forearm)))
    model = MechanismModel.from_description(SpatialMechanism("tilted", tuple(legs), delta.platform, delta.gravity))
    refused = 0
    for p in np.random.default_rng(1).uniform([-0.6, -0.6, -1.1], [0.6, 0.6, -0.05], (300, 3)):
        try:
            q = mm.inverse_kinematics(model, p, (1, 1, 1))
        except UnreachablePoseError as exc:
            refused += "universal joint cannot turn" in str(exc)
            continue
        assert np.max(np.abs(mm.constraint_residual(model, q))) < 1e-10
    assert refused > 0
