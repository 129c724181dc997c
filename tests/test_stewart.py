"""The user-described Stewart–Gough platform (examples/stewart_6ups.toml, six UP*S legs of two bodies each):
its kinematics against the legs' geometry, its dynamics against the kinetic and potential energy of every
body, branch following, and a tracked six-degree-of-freedom motion."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from pkmlab import branch_following, load_scenario, simulate
from pkmlab.algorithms import assembly
from pkmlab.description.files import load_mechanism
from pkmlab.description.presets import preset
from pkmlab.description.spatial import leg_frames, orientation
from pkmlab.errors import BranchFollowingError, InvalidParameterError, UnreachablePoseError
from pkmlab.model import mechanism_model as mm
from pkmlab.model.mechanism_model import MechanismModel

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
MACHINE = load_mechanism(EXAMPLES / "stewart_6ups.toml")
MODEL = MechanismModel.from_description(MACHINE)
SETTINGS = settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
poses = st.tuples(st.floats(-0.08, 0.08), st.floats(-0.08, 0.08), st.floats(0.75, 0.95),
                  st.floats(-0.2, 0.2), st.floats(-0.2, 0.2), st.floats(-0.4, 0.4))
B = np.array([leg.base for leg in MACHINE.legs])
A = np.array(MACHINE.platform.attachments)


def configuration(pose):
    try:
        q = mm.inverse_kinematics(MODEL, pose, ())
    except UnreachablePoseError:
        assume(False)
    assume(abs(mm.singularity_measure(MODEL, q)) > 0.05)
    return q


def test_the_example_file_is_the_preset():
    assert MACHINE == preset("stewart")
    assert MACHINE.notation == "6-UP*S" and MACHINE.pose_names == ("x", "y", "z", "roll", "pitch", "yaw")


@SETTINGS
@given(poses)
def test_inverse_kinematics_gives_the_leg_lengths(pose):
    q = configuration(pose)
    points = np.array(pose[:3]) + A @ orientation(*pose[3:]).T
    assert np.allclose(q[:6], np.linalg.norm(points - B, axis=1), atol=1e-12)
    assert np.max(np.abs(mm.constraint_residual(MODEL, q))) < 1e-12


@SETTINGS
@given(poses)
def test_singularity_measure_is_the_normalised_determinant_of_the_legs_plucker_lines(pose):
    q = configuration(pose)
    p, rot = np.array(pose[:3]), orientation(*pose[3:])
    r = A @ rot.T
    u = (p + r - B) / np.linalg.norm(p + r - B, axis=1)[:, None]
    pairs = [(i, j) for i in range(6) for j in range(i)]
    size = np.mean([np.linalg.norm(A[i] - A[j]) for i, j in pairs])
    expected = np.linalg.det(np.column_stack([u, np.cross(r, u) / size]))
    assert abs(mm.singularity_measure(MODEL, q)) == pytest.approx(abs(expected), abs=1e-12)


def _bodies(q):
    """Every body's mass centre and orientation at q: the legs' from the chain's plain statement, then the
    platform's."""
    out, passive = [], iter(q[6:18])
    for i, leg in enumerate(MACHINE.legs):
        coords = [next(passive), next(passive), q[i]]
        for (origin, rot), body in zip(leg_frames(leg, coords), leg.bodies, strict=False):
            out.append((origin + rot @ np.array(body.com), rot, body))
    rot = orientation(*q[21:24])
    out.append((q[18:21] + rot @ np.array(MACHINE.platform.com), rot, MACHINE.platform))
    return out


def _energy(q, q_dot, h=1e-6):
    """Kinetic energy Σ ½ m |v|² + ½ ωᵀ I ω (ω in the body frame, from Rᵀ Ṙ) by central differences, and
    the potential energy."""
    plus, minus, here = _bodies(q + h * q_dot), _bodies(q - h * q_dot), _bodies(q)
    kinetic = potential = 0.0
    gravity = np.array(MACHINE.gravity)
    for (cp, rp, _b), (cm, rm, _b2), (c, r, body) in zip(plus, minus, here, strict=True):
        v = (cp - cm) / (2 * h)
        w = r.T @ (rp - rm) / (2 * h)
        omega = np.array([w[2, 1], w[0, 2], w[1, 0]])
        kinetic += 0.5 * body.mass * v @ v + 0.5 * omega @ np.array(body.inertia) @ omega
        potential -= body.mass * gravity @ c
    return kinetic, potential


def _rates(q, theta_dot):
    jac = mm.constraint_jacobian(MODEL, q)
    return np.concatenate([theta_dot, np.linalg.solve(jac[:, 6:], -jac[:, :6] @ theta_dot)])


@SETTINGS
@given(poses, st.lists(st.floats(-0.5, 0.5), min_size=6, max_size=6))
def test_mass_matrix_is_the_kinetic_energy_of_every_body(pose, rates):
    q = configuration(pose)
    theta_dot = np.array(rates)
    M, _c, _g = mm.actuator_space_model(MODEL, q, theta_dot)
    assert np.allclose(M, M.T, atol=1e-13) and np.all(np.linalg.eigvalsh(M) > 0)
    kinetic, _v = _energy(q, _rates(q, theta_dot))
    assert 0.5 * theta_dot @ M @ theta_dot == pytest.approx(kinetic, rel=1e-7, abs=1e-10)


def _follow(q, theta):
    return branch_following(MODEL, q, theta, singularity_guard=1e-3)


def test_gravity_effort_is_the_gradient_of_the_potential_energy():
    q = mm.inverse_kinematics(MODEL, [0.03, -0.02, 0.88, 0.08, -0.05, 0.2], ())
    _M, _c, g = mm.actuator_space_model(MODEL, q, np.zeros(6))
    h = 1e-6
    grad = [(_energy(_follow(q, q[:6] + h * e), np.zeros(24))[1]
             - _energy(_follow(q, q[:6] - h * e), np.zeros(24))[1]) / (2 * h) for e in np.eye(6)]
    assert np.allclose(g, grad, atol=1e-6)
    assert np.all(g > 0)  # extending a leg lifts the platform (∂V/∂ρ > 0): each leg pushes to hold it


def test_power_balance_with_gravity():
    """τ·θ̇ = dT/dt + dV/dt along the motion the model predicts under τ, with T and V of every body."""
    rng = np.random.default_rng(4)
    q = mm.inverse_kinematics(MODEL, [-0.02, 0.04, 0.82, -0.1, 0.06, -0.25], ())
    theta_dot, tau = rng.uniform(-0.3, 0.3, 6), rng.uniform(-50, 150, 6)
    M, c, g = mm.actuator_space_model(MODEL, q, theta_dot)
    theta_ddot = np.linalg.solve(M, tau - c - g)
    h = 1e-5
    # T and V at θ ± h θ̇ moving with θ̇ ± h θ̈: d/dt by central differences along the motion
    values = []
    for sign in (1, -1):
        qs = _follow(q, q[:6] + sign * h * theta_dot)
        values.append(_energy(qs, _rates(qs, theta_dot + sign * h * theta_ddot)))
    d_t = (values[0][0] - values[1][0]) / (2 * h)
    d_v = (values[0][1] - values[1][1]) / (2 * h)
    assert tau @ theta_dot == pytest.approx(d_t + d_v, rel=1e-5, abs=1e-6)


@SETTINGS
@given(poses, st.lists(st.floats(-0.5, 0.5), min_size=6, max_size=6),
       st.lists(st.floats(-100, 200), min_size=6, max_size=6))
def test_reduced_model_equals_full_multiplier_model(pose, rates, efforts):
    q = configuration(pose)
    theta_dot, tau = np.array(rates), np.array(efforts)
    M, c, g = mm.actuator_space_model(MODEL, q, theta_dot)
    theta_ddot = np.linalg.solve(M, tau - c - g)
    q_ddot, _lam = mm.constrained_accelerations(MODEL, q, _rates(q, theta_dot), tau)
    assert np.allclose(q_ddot[:6], theta_ddot, atol=1e-8 * (1 + np.abs(theta_ddot).max()))


def test_branch_following_forward_kinematics_and_its_singularity():
    """Newton on the constraints from the previous configuration follows the assembly mode; turning the
    platform about z towards the torsion singularity (S = 0 near yaw = 1.57 rad) stops with a clear error."""
    start = mm.inverse_kinematics(MODEL, [0.0, 0.0, 0.85, 0.0, 0.0, 0.0], ())
    goal = mm.inverse_kinematics(MODEL, [0.04, -0.03, 0.9, 0.1, -0.05, 0.3], ())
    reached = _follow(start, goal[:6])
    assert np.allclose(reached[18:], goal[18:], atol=1e-10)
    q = start
    with pytest.raises(BranchFollowingError, match=r"gain-type singularity .*limit singularity_guard = 0.01"):
        for yaw in np.linspace(0.0, 1.65, 34):  # the actuators of the turning platform, step by step
            target = mm.inverse_kinematics(MODEL, [0.0, 0.0, 0.85, 0.0, 0.0, yaw], ())[:6]
            q = branch_following(MODEL, q, target, singularity_guard=0.01)
    assert 1.4 < q[-1] < 1.6  # followed until close to the singularity


def test_poses_at_gimbal_lock_and_out_of_stroke_are_refused():
    with pytest.raises(InvalidParameterError, match="gimbal lock"):
        mm.inverse_kinematics(MODEL, [0.0, 0.0, 0.85, 0.0, np.pi / 2, 0.0], ())
    with pytest.raises(UnreachablePoseError, match=r"leg \d needs its actuator at .* outside its stroke"):
        mm.inverse_kinematics(MODEL, [0.0, 0.0, 1.4, 0.0, 0.0, 0.0], ())


def test_a_short_six_degree_of_freedom_motion_is_tracked():
    run = simulate(load_scenario(EXAMPLES / "stewart_motion.toml"))
    s = run.summary()
    assert set(s) >= {"max_path_error_m", "max_orientation_error_rad", "peak_effort", "min_abs_S"}
    assert s["max_path_error_m"] < 1e-4 and s["max_orientation_error_rad"] < 1e-3
    assert run.columns[-13:] == ("x", "y", "z", "roll", "pitch", "yaw", "x_d", "y_d", "z_d", "roll_d", "pitch_d",
                                 "yaw_d", "S")
    # at rest at the start: the efforts hold the platform against gravity
    _M, _c, g = mm.actuator_space_model(MODEL, run.q[0], np.zeros(6))
    assert np.allclose(run.tau[0], g, atol=1e-6)


# ------------------------------------------------------------------ forward kinematics: every assembly mode
def _multistart_poses(lengths, starts=3000, seed=2):
    """An independent count of the real assembly modes: Newton's method on the six leg equations in (p, roll,
    pitch, yaw) from many random starts, the distinct converged poses (told apart by their platform points)."""
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-1, 1, (starts, 2)), rng.uniform(-1.2, 1.2, starts),
                         rng.uniform(-np.pi, np.pi, (starts, 3)) * [1, 0.5, 1]])

    def residual(x):
        from pkmlab.description.spatial import orientations

        points = x[:, None, :3] + np.einsum("kij,lj->kli", orientations(x[:, 3:]), A)
        return np.linalg.norm(points - B, axis=2) - lengths, points

    for _ in range(40):
        r, _p = residual(x)
        jac = np.empty((len(x), 6, 6))
        for j in range(6):
            step = np.zeros(6)
            step[j] = 1e-7
            jac[:, :, j] = (residual(x + step)[0] - r) / 1e-7
        with np.errstate(all="ignore"):
            dx = np.linalg.solve(jac + 1e-12 * np.eye(6), r[..., None])[..., 0]
        x = x - np.clip(dx, -0.3, 0.3)
    r, points = residual(x)
    good = np.all(np.abs(r) < 1e-10, axis=1)
    distinct = []
    for p in points[good]:
        if all(np.abs(p - other).max() > 1e-6 for other in distinct):
            distinct.append(p)
    return distinct


def test_forward_kinematics_finds_every_assembly_mode_of_the_hexapod():
    pose = [0.03, -0.02, 0.88, 0.08, -0.05, 0.2]
    q = mm.inverse_kinematics(MODEL, pose, ())
    found = assembly.assembly_modes(MODEL, q[:6])
    assert min(np.abs(qf[18:] - pose).max() for qf, _s in found) < 1e-10  # FK∘IK
    for qf, s in found:
        assert np.max(np.abs(mm.constraint_residual(MODEL, qf))) < 1e-12
        assert np.allclose(qf[:6], q[:6]) and s == pytest.approx(mm.singularity_measure(MODEL, qf))
    points = [qf[18:21] + A @ orientation(*qf[21:24]).T for qf, _s in found]
    independent = _multistart_poses(q[:6])
    assert len(independent) == len(found) == 8
    for p in independent:
        assert min(np.abs(p - other).max() for other in points) < 1e-8


def test_dietmaiers_platform_has_forty_real_assembly_modes_from_the_command_line(capsys):
    import json

    from pkmlab.cli import main

    lengths = [1.0, 0.645275, 1.086284, 1.503439, 1.281933, 0.771071]
    assert main(["fk", "--mechanism", str(EXAMPLES / "stewart_dietmaier.toml"), *map(str, lengths), "--json"]) == 0
    solutions = json.loads(capsys.readouterr().out)["solutions"]
    assert len(solutions) == 40
    machine = load_mechanism(EXAMPLES / "stewart_dietmaier.toml")
    base, attach = np.array([leg.base for leg in machine.legs]), np.array(machine.platform.attachments)
    for sol in solutions:
        p, angles = np.array(sol["pose"][:3]), sol["pose"][3:]
        legs = np.linalg.norm(p + attach @ orientation(*angles).T - base, axis=1)
        assert np.allclose(legs, lengths, atol=1e-9)


def test_continuous_time_control_with_the_exact_model_tracks_to_integration_level():
    from pkmlab.control.trajectory import TimedWaypoints

    scenario = load_scenario(EXAMPLES / "stewart_motion.toml")
    short = TimedWaypoints(((0.0, 0.0, 0.85, 0.0, 0.0, 0.0), (0.01, -0.01, 0.86, 0.02, -0.01, 0.03)), (0.15,))
    s = simulate(scenario.replace(trajectory=short, sample_time=0.0)).summary()
    assert s["max_path_error_m"] < 1e-9 and s["max_orientation_error_rad"] < 1e-9


def test_orientation_error_is_exact_for_small_and_large_turns():
    """The angle between two orientations, to round-off also when tiny (where arccos of the trace is not)."""
    from dataclasses import replace

    run = simulate(load_scenario(EXAMPLES / "stewart_motion.toml"))
    pose_d = np.tile([0.0, 0.0, 0.85, 0.3, -0.2, 0.5], (3, 1))
    pose = pose_d.copy()
    for k, angle in enumerate((1e-9, 0.0, 2.5)):
        rot = orientation(*pose_d[k, 3:]) @ orientation(angle, 0.0, 0.0)  # a turn about the platform's x axis
        pose[k, 3:] = [np.arctan2(rot[2, 1], rot[2, 2]), -np.arcsin(rot[2, 0]), np.arctan2(rot[1, 0], rot[0, 0])]
    fake = replace(run, pose=pose, pose_d=pose_d)
    assert np.allclose(fake.orientation_error, [1e-9, 0.0, 2.5], rtol=1e-6, atol=1e-15)
