"""Dynamics checked by invariants and by independent formulations (paper §3, conventions §6)."""

import json

import numpy as np
import pytest
import reference as ref
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from pkmlab.cli import main
from pkmlab.paper import dynamics as dy
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import WORKING_MODES
from pkmlab.paper.plant import FullPlant, ReducedPlant

SETTINGS = settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
states = st.tuples(
    st.floats(0.12, 0.40), st.floats(0.08, 0.36), st.floats(-0.6, 0.6), st.integers(0, 7), st.integers(0, 2**31)
)


def _state(model, drawn, margin=0.15):
    x, y, alpha, mode_index, seed = drawn
    ik = kin.inverse_kinematics(model, [x, y, alpha], mode=WORKING_MODES[mode_index], on_unreachable="nan")
    assume(np.isfinite(ik.S) and abs(ik.S) > margin)
    rng = np.random.default_rng(seed)
    return ik.q, rng.normal(size=3), rng.normal(size=3)


def _kinetic_energy_independent(q, qd):
    """T from the bodies' velocities written out by hand (eq. 20), paper parameters."""
    m_l, m_r, m_a = 0.468, 0.312, 0.234
    i_l, i_r, i_a = 2.438e-3, 0.722e-3, 0.305e-3
    L, R, A = ref.L, ref.R, ref.A
    T = 0.0
    for i in range(3):
        th, ph, dth, dph = q[i], q[3 + i], qd[i], qd[3 + i]
        v_l = L / 2 * dth * np.array([-np.sin(th), np.cos(th)])
        v_r = L * dth * np.array([-np.sin(th), np.cos(th)]) + R / 2 * dph * np.array([-np.sin(ph), np.cos(ph)])
        T += 0.5 * m_l * v_l @ v_l + 0.5 * i_l * dth**2 + 0.5 * m_r * v_r @ v_r + 0.5 * i_r * dph**2
    al, dal = q[6], qd[6]
    v_p1 = L * qd[0] * np.array([-np.sin(q[0]), np.cos(q[0])]) + R * qd[3] * np.array([-np.sin(q[3]), np.cos(q[3])])
    v_c = v_p1 + A / np.sqrt(3) * dal * np.array([-np.sin(al + np.pi / 6), np.cos(al + np.pi / 6)])
    return T + 0.5 * m_a * v_c @ v_c + 0.5 * i_a * dal**2


@SETTINGS
@given(drawn=states)
def test_mass_matrices_are_symmetric_positive_definite_and_give_the_kinetic_energy(paper, drawn):
    q, td, _ = _state(paper, drawn)
    M = dy.mass_matrix(paper, q)
    m_theta, _c = dy.actuator_space_model(paper, q, td)
    for mat in (M, m_theta):
        np.testing.assert_allclose(mat, mat.T, atol=1e-15)
        assert np.linalg.eigvalsh(mat).min() > 0
    qd = kin.coordinate_rates(paper, q, td)
    T = _kinetic_energy_independent(q, qd)
    assert 0.5 * qd @ M @ qd == pytest.approx(T, rel=1e-12)
    assert 0.5 * td @ m_theta @ td == pytest.approx(T, rel=1e-12)  # Mθ is M reflected on θ (eq. 35)


@SETTINGS
@given(drawn=states)
def test_christoffel_form_equals_the_direct_velocity_product(paper, drawn):
    q, td, _ = _state(paper, drawn)
    rng = np.random.default_rng(int(drawn[-1]))
    qd = rng.normal(size=7)  # eq. 24 holds for any q̇, not only admissible ones
    C = dy.coriolis_matrix(paper, q, qd)
    np.testing.assert_allclose(C @ qd, dy.velocity_product(paper, q, qd), atol=1e-14)
    # Ṁ - 2C is skew-symmetric in the full space; Ṁ by central differences along q̇
    def central(h):
        return (dy.mass_matrix(paper, q + h * qd) - dy.mass_matrix(paper, q - h * qd)) / (2 * h)

    m_dot = (4 * central(5e-5) - central(1e-4)) / 3  # Richardson: O(h⁴)
    N = m_dot - 2 * C
    np.testing.assert_allclose(N + N.T, 0, atol=1e-10)


@SETTINGS
@given(drawn=states)
def test_actuator_space_skew_symmetry(paper, drawn):
    """Ṁθ - 2Cθ is skew-symmetric, with Ṁθ by finite differences along the motion."""
    q, td, _ = _state(paper, drawn)
    c_theta = dy.actuator_space_coriolis_matrix(paper, q, td)
    np.testing.assert_allclose(c_theta @ td, dy.actuator_space_model(paper, q, td)[1], atol=1e-14)

    def m_theta_at(t):
        return dy.actuator_space_model(paper, kin.branch_following(paper, q, q[:3] + td * t), td)[0]

    def central(h):
        return (m_theta_at(h) - m_theta_at(-h)) / (2 * h)

    def skew_defect(h):  # Richardson-extrapolated Ṁθ, error O(h⁴)
        N = (4 * central(h / 2) - central(h)) / 3 - 2 * c_theta
        return np.abs(N + N.T).max(), np.abs(N).max()

    coarse, _ = skew_defect(4e-5)
    fine, scale = skew_defect(2e-5)
    # either already at the level of round-off, or still shrinking like h⁴ (a wrong Cθ would plateau)
    assert fine < 1e-8 * max(1.0, scale) or fine < coarse / 8


@SETTINGS
@given(drawn=states)
def test_reduced_and_full_models_give_the_same_accelerations(paper, drawn):
    q, td, tau = _state(paper, drawn)
    qd = kin.coordinate_rates(paper, q, td)
    qdd, lam = dy.constrained_accelerations(paper, q, qd, tau)
    theta_ddot = dy.forward_dynamics(paper, q, td, tau)
    np.testing.assert_allclose(theta_ddot, qdd[:3], rtol=1e-10, atol=1e-10 * np.abs(qdd[:3]).max())
    # the full solution respects the constraints at acceleration level (eq. 32) ...
    np.testing.assert_allclose(qdd, kin.coordinate_accelerations(paper, q, td, theta_ddot), rtol=1e-9, atol=1e-9)
    # ... and λ satisfies eq. (26) to round-off, in newtons
    M = dy.mass_matrix(paper, q)
    J = kin.constraint_jacobian(paper, q)
    residual = M @ qdd + dy.velocity_product(paper, q, qd) - np.r_[tau, 0, 0, 0, 0] - J.T @ lam
    assert np.abs(residual).max() < 1e-12 * max(1.0, np.abs(tau).max())
    np.testing.assert_allclose(dy.lagrange_multipliers(paper, q, qd, tau), lam, rtol=1e-9, atol=1e-12)
    # inverse dynamics inverts forward dynamics
    np.testing.assert_allclose(dy.inverse_dynamics(paper, q, td, theta_ddot), tau, rtol=1e-10, atol=1e-12)


def test_multipliers_are_the_joint_forces_of_a_static_load(paper):
    """At rest, λ are the forces in the loop-closing joints: check against statics by hand.

    With θ̇ = 0 and torques chosen to hold the mechanism still (θ̈ = 0), each passive link is a
    two-force member, so λ must be parallel to the passive links that meet at p2 and p3.
    """
    q = kin.inverse_kinematics(paper, [0.22, 0.2, 0.1], mode=(-1, 1, -1)).q
    tau = np.array([0.3, -0.2, 0.1])
    qdd, lam = dy.constrained_accelerations(paper, q, np.zeros(7), tau)
    assert np.all(np.isfinite(lam))
    # virtual work: the constraint forces do no work on admissible motions
    j_q_theta = kin.actuated_jacobian(paper, q)
    np.testing.assert_allclose(j_q_theta.T @ (kin.constraint_jacobian(paper, q).T @ lam), 0, atol=1e-12)


def test_free_motion_conserves_energy_and_both_plants_agree(paper):
    q0 = kin.inverse_kinematics(paper, [0.25, 0.21, 0.0], mode=(-1, 1, -1)).q
    td0 = np.array([0.4, 0.3, -0.4])  # free motion that stays clear of singularities (min |S| 0.36) for 1 s
    t = np.linspace(0, 1.0, 201)
    reduced = ReducedPlant(paper, rtol=1e-12, atol=1e-13).simulate(q0, td0, [0, 0, 0], 1.0, t_eval=t)
    T = dy.kinetic_energy(paper, reduced.q, reduced.q_dot)
    assert np.abs(T / T[0] - 1).max() <= 1e-9
    assert reduced.closure_violation.max() < 1e-14  # on the manifold at round-off level, by construction
    assert np.max([np.abs(ref.eta(q)).max() for q in reduced.q]) < 1e-14
    full = FullPlant(paper, rtol=1e-12, atol=1e-13).simulate(q0, kin.coordinate_rates(paper, q0, td0),
                                                               [0, 0, 0], 1.0, t_eval=t)
    T_full = dy.kinetic_energy(paper, full.q, full.q_dot)
    assert np.abs(T_full / T_full[0] - 1).max() <= 1e-9
    assert full.closure_violation.max() < 1e-10
    np.testing.assert_allclose(reduced.theta, full.theta, atol=1e-9)
    np.testing.assert_allclose(reduced.theta_dot, full.theta_dot, atol=1e-8)


def test_power_balance_under_torque(paper):
    """dT/dt = τ·θ̇: the constraint forces do no work (eq. 29-30)."""
    q0 = kin.inverse_kinematics(paper, [0.22, 0.2, 0.0], mode=(-1, 1, -1)).q

    def torque(t, theta, theta_dot):
        return np.array([0.05 * np.sin(3 * t), -0.03, 0.04 * np.cos(2 * t)])

    t = np.linspace(0, 0.5, 501)
    run = ReducedPlant(paper, rtol=1e-12, atol=1e-13).simulate(q0, [0.2, 0.1, -0.3], torque, 0.5, t_eval=t)
    T = dy.kinetic_energy(paper, run.q, run.q_dot)
    power = np.array([torque(tk, None, None) @ w for tk, w in zip(t, run.theta_dot, strict=True)])
    dt = t[1] - t[0]
    dT = (-T[4:] + 8 * T[3:-1] - 8 * T[1:-3] + T[:-4]) / (12 * dt)  # five-point stencil, O(dt⁴)
    np.testing.assert_allclose(dT, power[2:-2], atol=1e-8 * np.abs(power).max())
    # and integrated: T(t) - T(0) = ∫ τ·θ̇ dt (trapezoid, error O(dt²))
    work = np.concatenate([[0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    np.testing.assert_allclose(T - T[0], work, atol=1e-6 * np.abs(work).max())


def test_trajectories_of_both_plants_agree_under_torque(paper):
    q0 = kin.inverse_kinematics(paper, [0.25, 0.18, -0.1], mode=(-1, 1, -1)).q

    def torque(t, theta, theta_dot):
        return np.array([0.02, 0.05 * np.sin(5 * t), -0.02]) - 0.05 * theta_dot

    t = np.linspace(0, 1.0, 51)
    a = ReducedPlant(paper).simulate(q0, [0, 0, 0], torque, 1.0, t_eval=t)
    b = FullPlant(paper).simulate(q0, np.zeros(7), torque, 1.0, t_eval=t)
    np.testing.assert_allclose(a.q[:, :3], b.q[:, :3], atol=1e-8)
    np.testing.assert_allclose(np.angle(np.exp(1j * (a.q[:, 3:] - b.q[:, 3:]))), 0, atol=1e-8)


def test_general_mass_centres_and_inertias(paper):
    """Off-axis mass centres change the model but keep every invariant."""
    model = paper.replace(active_com=[[0.1, 0.01], [0.12, -0.02], [0.13, 0.0]],
                          passive_com=[[0.07, 0.005], [0.09, 0.0], [0.08, -0.01]],
                          platform_com=[0.05, 0.04], platform_inertia=4e-4)
    q = kin.inverse_kinematics(model, [0.22, 0.2, 0.05], mode=(-1, 1, -1)).q
    td, tau = np.array([0.5, -0.2, 0.4]), np.array([0.1, -0.05, 0.02])
    m_a, _ = dy.actuator_space_model(model, q, td)
    m_b, _ = dy.actuator_space_model(paper, q, td)
    assert np.abs(m_a - m_b).max() > 1e-5
    qd = kin.coordinate_rates(model, q, td)
    qdd, _lam = dy.constrained_accelerations(model, q, qd, tau)
    np.testing.assert_allclose(dy.forward_dynamics(model, q, td, tau), qdd[:3], rtol=1e-10, atol=1e-12)
    c = dy.actuator_space_coriolis_matrix(model, q, td)
    np.testing.assert_allclose(c @ td, dy.actuator_space_model(model, q, td)[1], atol=1e-14)


def test_batched_dynamics_equal_single(paper):
    ik = kin.inverse_kinematics(paper, [[0.2, 0.21, 0.0], [0.25, 0.2, 0.1]], mode=(-1, 1, -1))
    td = np.array([[0.1, 0.2, 0.3], [0.3, -0.1, 0.0]])
    m_theta, c_theta = dy.actuator_space_model(paper, ik.q, td)
    for k in range(2):
        m1, c1 = dy.actuator_space_model(paper, ik.q[k], td[k])
        np.testing.assert_array_equal(m_theta[k], m1)
        np.testing.assert_array_equal(c_theta[k], c1)


def test_cli_dynamics_json(paper, capsys):
    q = kin.inverse_kinematics(paper, [0.2, 0.21, 0.0], mode=(-1, 1, -1)).q
    theta = [repr(float(v)) for v in q[:3]]
    assert main(["dynamics", *theta, "--theta-dot", "0.3", "-0.2", "0.5", "--near", "0.2", "0.21", "0", "--json"]) == 0
    (out,) = json.loads(capsys.readouterr().out)["solutions"]
    # the actuator-space model, and a loop-closure force (x, y) per leg of the generic model (q = θ, φ, x, y, α)
    assert np.array(out["M"]).shape == (3, 3) and len(out["c"]) == len(out["g"]) == 3
    assert len(out["multipliers"]) == 6
    qd = kin.coordinate_rates(paper, q, [0.3, -0.2, 0.5])
    T = _kinetic_energy_independent(q, qd)
    td = np.array([0.3, -0.2, 0.5])
    assert 0.5 * td @ np.array(out["M"]) @ td == pytest.approx(T, rel=1e-10)
    assert main(["dynamics", *theta, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["solutions"]) == int(kin.forward_kinematics(paper, q[:3]).count)


def test_plant_accuracy_against_a_tighter_reference(paper):
    """The default tolerances (rtol 1e-11) keep the integration error far below 1e-8 rad over 1 s."""
    q0 = kin.inverse_kinematics(paper, [0.25, 0.21, 0.0], mode=(-1, 1, -1)).q

    def torque(t, theta, theta_dot):  # a forced, damped oscillation about the start (stays far from S = 0)
        return np.array([0.05 * np.sin(4 * t), 0.03, -0.04 * np.cos(3 * t)]) - 0.5 * (theta - q0[:3]) - 0.02 * theta_dot

    t = np.linspace(0, 1.0, 21)
    default = ReducedPlant(paper).simulate(q0, [0.2, -0.1, 0.3], torque, 1.0, t_eval=t)
    reference = ReducedPlant(paper, rtol=1e-13, atol=1e-14).simulate(q0, [0.2, -0.1, 0.3], torque, 1.0, t_eval=t)
    error = np.abs(default.theta - reference.theta).max()
    assert error < 1e-9
    loose = ReducedPlant(paper, rtol=1e-6, atol=1e-8).simulate(q0, [0.2, -0.1, 0.3], torque, 1.0, t_eval=t)
    assert np.abs(loose.theta - reference.theta).max() > error  # the tolerance is what controls the error
