"""The one API, the same for every machine: pkmlab.load and the algorithms re-exported at the top level.

Independent checks only: FK∘IK round trips, finite differences of branch following for the Jacobians,
the actuator-space model against the reduction of the full-space model computed in NumPy (a second
formulation), power balance of the constrained model, the paper's own 7-coordinate formulation
(``pkmlab.paper.kinematics``, ``pkmlab.paper.dynamics``) for the paper's machine, and batches against single calls.
"""

from __future__ import annotations

import numpy as np
import pytest

import pkmlab
from pkmlab.description.presets import preset
from pkmlab.paper import dynamics as paper_dynamics
from pkmlab.paper import kinematics as paper_kinematics
from pkmlab.paper.geometry import Planar3RRR

#: A pose of each preset that every working mode reaches far from singularities, and actuator rates.
POSES = {
    "paper": [0.20, 0.21, 0.0],
    "five_bar": [0.0, 0.35],
    "3rpr": [0.25, 0.2, 0.3],
    "3prr": [0.26, 0.2, 0.1],
    "delta": [0.05, -0.03, -0.75],
    "stewart": [0.0, 0.0, 0.85, 0.05, -0.03, 0.1],
}


@pytest.fixture(scope="module")
def models():
    return {name: pkmlab.load(name) for name in POSES}


def _regular_solutions(model, pose):
    ik = pkmlab.inverse_kinematics(model, pose, on_unreachable="nan")
    keep = ik.reachable & (np.abs(np.nan_to_num(ik.S)) > 0.05)
    assert keep.any()
    return ik.q[keep], ik.modes[keep]


def _rates(model):
    return np.linspace(0.2, -0.3, model.n_actuators) * (0.2 if model.description.legs[0].joints[
        model.description.legs[0].actuated].kind == "P" else 1.0)


# ------------------------------------------------------------------ load
def test_load_takes_a_preset_a_file_a_description_and_a_model(tmp_path, models):
    from pkmlab.description.files import mechanism_to_toml

    path = tmp_path / "mine.toml"
    path.write_text(mechanism_to_toml(preset("five_bar")))
    for source in ("five_bar", path, str(path), preset("five_bar"), models["five_bar"]):
        model = pkmlab.load(source)
        assert isinstance(model, pkmlab.MechanismModel)
        np.testing.assert_array_equal(model.P, models["five_bar"].P)
    assert pkmlab.load(models["delta"]) is models["delta"]


@pytest.mark.parametrize("bad", ["five-bar", "mine.txt", 3, None, Planar3RRR.paper()])
def test_load_refuses_what_is_not_a_machine_in_one_line(bad):
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^source must be a preset") as info:
        pkmlab.load(bad)
    assert "\n" not in str(info.value)


def test_load_names_a_missing_description_file(tmp_path):
    with pytest.raises(pkmlab.PkmlabError, match="nowhere.toml"):
        pkmlab.load(tmp_path / "nowhere.toml")


def test_the_paper_preset_is_the_paper_machine(models):
    """The ``paper`` preset and the paper's own model are the same machine, number for number: the generic
    coordinates carry the paper's 7 (θ, φ, α) plus the centroid (x, y)."""
    paper = Planar3RRR.paper()
    model = models["paper"]
    pose = POSES["paper"]
    for mode in paper_kinematics.inverse_kinematics(paper, pose).modes:
        old = paper_kinematics.inverse_kinematics(paper, pose, mode=mode)
        new = pkmlab.inverse_kinematics(model, pose, mode=mode)
        np.testing.assert_allclose(new.theta, old.theta, atol=1e-12)
        np.testing.assert_allclose(new.q[3:6], old.phi, atol=1e-12)
        np.testing.assert_allclose(new.q[8], old.q[6], atol=1e-12)
        np.testing.assert_allclose(new.S, old.S, rtol=1e-10)


# ------------------------------------------------------------------ kinematics
@pytest.mark.parametrize("name", list(POSES))
def test_forward_kinematics_recovers_every_working_mode_of_inverse_kinematics(models, name):
    model, pose = models[name], np.array(POSES[name])
    qs, _modes = _regular_solutions(model, pose)
    fk = pkmlab.forward_kinematics(model, qs[:, :model.n_actuators])
    assert fk.count.shape == (len(qs),) and np.all(fk.count >= 1)
    for k, q in enumerate(qs):
        n = int(fk.count[k])
        # one assembly mode is the IK's configuration itself: pose and passive coordinates
        gap = np.abs(np.angle(np.exp(1j * (fk.q[k, :n] - q)))).max(axis=1)
        assert gap.min() < 1e-8
        np.testing.assert_allclose(np.abs(pkmlab.constraint_residual(model, fk.q[k, :n])).max(), 0, atol=1e-11)
    single = pkmlab.forward_kinematics(model, qs[0, :model.n_actuators])
    np.testing.assert_allclose(single.nearest(pose).pose, pose, atol=1e-9)
    assert len(single) == int(fk.count[0]) and single[0].q.shape == (len(model.coordinates),)


def test_inverse_kinematics_is_batched_over_leading_axes(models):
    model = models["paper"]
    poses = np.array([[[0.20, 0.21, 0.0], [0.24, 0.25, 0.3]], [[0.28, 0.17, -0.5], [0.22, 0.2, 0.1]]])
    ik = pkmlab.inverse_kinematics(model, poses)
    assert ik.q.shape == (2, 2, 8, 9) and ik.S.shape == (2, 2, 8) and ik.modes.shape == (8, 3)
    for index in np.ndindex(2, 2):
        one = pkmlab.inverse_kinematics(model, poses[index])
        np.testing.assert_array_equal(ik.q[index], one.q)
        np.testing.assert_array_equal(ik.S[index], one.S)
    # every solution is on the loop closure and puts the platform at the pose
    np.testing.assert_allclose(pkmlab.constraint_residual(model, ik.q), 0, atol=1e-12)
    np.testing.assert_allclose(ik.q[..., -3:], np.broadcast_to(poses[:, :, None, :], ik.q[..., -3:].shape))


def test_an_unreachable_pose_names_its_leg_or_gives_nan(models):
    model = models["five_bar"]
    with pytest.raises(pkmlab.UnreachablePoseError, match=r"leg \d") as info:
        pkmlab.inverse_kinematics(model, [[0.0, 0.35], [0.0, 2.0]])
    assert info.value.index == (1,)
    ik = pkmlab.inverse_kinematics(model, [[0.0, 0.35], [0.0, 2.0]], on_unreachable="nan")
    assert ik.reachable[0].all() and not ik.reachable[1].any()
    assert np.all(ik.unreachable_legs[1] == 0b11) and np.isnan(ik.q[1]).all()


def test_a_machine_with_one_working_mode_has_one_empty_mode(models):
    ik = pkmlab.inverse_kinematics(models["3rpr"], POSES["3rpr"])
    assert ik.modes.shape == (1, 0) and ik.q.shape == (1, 9)
    one = pkmlab.inverse_kinematics(models["3rpr"], POSES["3rpr"], mode=())
    np.testing.assert_array_equal(one.q, ik.q[0])


def test_no_assembly_mode_is_a_count_of_zero(models):
    fk = pkmlab.forward_kinematics(models["five_bar"], [[2.25, 0.89], [0.0, 3.14159]])
    assert fk.count[0] >= 1
    far = pkmlab.forward_kinematics(models["paper"], [0.0, 0.0, 0.0])
    assert int(far.count) == 0 and len(far) == 0
    with pytest.raises(IndexError):
        far.nearest(POSES["paper"])


def _follow(model, q, direction, h):
    theta = q[:model.n_actuators]
    return (pkmlab.branch_following(model, q, theta + h * direction),
            pkmlab.branch_following(model, q, theta - h * direction))


@pytest.mark.parametrize("name", list(POSES))
def test_jacobians_are_the_derivatives_of_branch_following(models, name):
    model = models[name]
    q = _regular_solutions(model, POSES[name])[0][0]
    n, na = len(model.coordinates), model.n_actuators
    J = pkmlab.coordinate_jacobian(model, q)
    assert J.shape == (n, na)
    np.testing.assert_array_equal(J[:na], np.eye(na))
    h = 1e-6
    numeric = np.column_stack([np.subtract(*_follow(model, q, e, h)) / (2 * h) for e in np.eye(na)])
    np.testing.assert_allclose(J, numeric, atol=1e-6 * max(1.0, np.abs(J).max()))
    np.testing.assert_allclose(pkmlab.velocity_jacobian(model, q), J[n - model.dof:])
    # η(q) = 0 along the manifold: Jηq Jqθ = 0
    np.testing.assert_allclose(pkmlab.constraint_jacobian(model, q) @ J, 0, atol=1e-12 * max(1.0, np.abs(J).max()))


@pytest.mark.parametrize("name", ["paper", "3prr", "delta"])
def test_acceleration_bias_is_the_second_derivative_along_a_motion(models, name):
    """q(t) = follow(θ0 + θ̇ t): its second difference at t = 0 is J̇qθ θ̇ (θ̈ = 0)."""
    model = models[name]
    q = _regular_solutions(model, POSES[name])[0][0]
    theta_dot = _rates(model)
    h = 1e-4
    plus, minus = _follow(model, q, theta_dot, h)
    numeric = (plus - 2 * q + minus) / h**2
    bias = pkmlab.acceleration_bias(model, q, theta_dot)
    np.testing.assert_allclose(bias, numeric, atol=1e-5 * max(1.0, np.abs(bias).max()))
    theta_ddot = np.linspace(1.0, -1.0, model.n_actuators)
    np.testing.assert_allclose(pkmlab.coordinate_accelerations(model, q, theta_dot, theta_ddot),
                               pkmlab.coordinate_jacobian(model, q) @ theta_ddot + bias, atol=1e-12)
    np.testing.assert_allclose(pkmlab.coordinate_rates(model, q, theta_dot),
                               pkmlab.coordinate_jacobian(model, q) @ theta_dot, atol=1e-14)


def test_the_singularity_measure_is_the_papers_eq_19(models):
    paper = Planar3RRR.paper()
    old = paper_kinematics.inverse_kinematics(paper, [[0.2, 0.21, 0.0], [0.24, 0.25, 0.9]])
    new = pkmlab.inverse_kinematics(models["paper"], [[0.2, 0.21, 0.0], [0.24, 0.25, 0.9]])
    np.testing.assert_allclose(pkmlab.singularity_measure(models["paper"], new.q), old.S, rtol=1e-10)


def test_branch_following_is_batched_and_refuses_a_singularity_in_one_line(models):
    model = models["paper"]
    qs = pkmlab.inverse_kinematics(model, [[0.2, 0.21, 0.0], [0.24, 0.25, 0.3]], mode=(1, -1, 1)).q
    target = qs[:, :3] + 0.01
    both = pkmlab.branch_following(model, qs, target)
    for k in range(2):
        np.testing.assert_array_equal(both[k], pkmlab.branch_following(model, qs[k], target[k]))
    np.testing.assert_allclose(both[:, :3], target)
    np.testing.assert_allclose(pkmlab.constraint_residual(model, both), 0, atol=1e-12)
    with pytest.raises(pkmlab.BranchFollowingError, match=r"^cannot follow the assembly mode.*at index \(1,\)"):
        pkmlab.branch_following(model, qs, [target[0], target[1] + [0.0, 0.0, 3.0]], singularity_guard=0.5)


# ------------------------------------------------------------------ dynamics
@pytest.mark.parametrize("name", list(POSES))
def test_the_actuator_space_model_is_the_reduced_full_space_model(models, name):
    """Mθ = Jqθᵀ M Jqθ, cθ = Jqθᵀ (M J̇qθ θ̇ + C q̇), gθ = Jqθᵀ g (eq. 35): the compiled core's body-by-body
    sums against the full model assembled in NumPy."""
    model = models[name]
    qs, _ = _regular_solutions(model, POSES[name])
    theta_dot = _rates(model)
    reduced = pkmlab.actuator_space_model(model, qs, theta_dot)
    J = pkmlab.coordinate_jacobian(model, qs)
    full = pkmlab.full_space_model(model, qs, pkmlab.coordinate_rates(model, qs, theta_dot))
    bias = pkmlab.acceleration_bias(model, qs, theta_dot)
    Jt = np.swapaxes(J, -1, -2)
    scale = np.abs(reduced.M).max()
    np.testing.assert_allclose(reduced.M, Jt @ full.M @ J, atol=1e-11 * scale)
    np.testing.assert_allclose(reduced.c, (Jt @ (full.M @ bias[..., None] + full.c[..., None]))[..., 0],
                               atol=1e-10 * max(scale, np.abs(reduced.c).max()))
    np.testing.assert_allclose(reduced.g, (Jt @ full.g[..., None])[..., 0],
                               atol=1e-11 * max(1.0, np.abs(reduced.g).max()))
    assert np.all(np.linalg.eigvalsh(reduced.M) > 0)


@pytest.mark.parametrize("name", list(POSES))
def test_constrained_dynamics_agrees_with_the_reduced_model_and_balances_power(models, name):
    model = models[name]
    q = _regular_solutions(model, POSES[name])[0][0]
    theta_dot = _rates(model)
    q_dot = pkmlab.coordinate_rates(model, q, theta_dot)
    tau = np.linspace(0.3, -0.2, model.n_actuators) + pkmlab.actuator_space_model(model, q, theta_dot).g
    motion = pkmlab.constrained_dynamics(model, q, q_dot, tau)
    theta_ddot = pkmlab.forward_dynamics(model, q, theta_dot, tau)
    np.testing.assert_allclose(motion.q_ddot[:model.n_actuators], theta_ddot, rtol=1e-9,
                               atol=1e-9 * np.abs(theta_ddot).max())
    # the accelerations keep the loop closed (second derivative of η = 0)
    np.testing.assert_allclose(motion.q_ddot, pkmlab.coordinate_accelerations(model, q, theta_dot, theta_ddot),
                               atol=1e-8 * np.abs(motion.q_ddot).max())
    # power: the efforts' power is the rate of kinetic plus potential energy; the multipliers do no work
    full = pkmlab.full_space_model(model, q, q_dot)
    power = q_dot @ (full.M @ motion.q_ddot + full.c + full.g)
    assert power == pytest.approx(tau @ theta_dot, rel=1e-9, abs=1e-12)
    # the multipliers balance the bodies' equations (eq. 26): M q̈ + C q̇ + g = Q + Jηqᵀ λ
    Q = np.zeros(len(q))
    Q[:model.n_actuators] = tau
    j_eta = pkmlab.constraint_jacobian(model, q)
    residual = full.M @ motion.q_ddot + full.c + full.g - Q - j_eta.T @ motion.multipliers
    np.testing.assert_allclose(residual, 0, atol=1e-9 * max(1.0, np.abs(motion.multipliers).max()))
    # inverse dynamics undoes forward dynamics
    np.testing.assert_allclose(pkmlab.inverse_dynamics(model, q, theta_dot, theta_ddot), tau, atol=1e-10)


def test_the_paper_machine_has_the_papers_reduced_dynamics(models):
    """Mθ and Cθ θ̇ in actuator space do not depend on the coordinates: the paper's 7-coordinate model
    (its eqs. 20-35 written independently in ``pkmlab.paper.dynamics``) gives the same numbers."""
    paper = Planar3RRR.paper()
    pose = [[0.2, 0.21, 0.0], [0.28, 0.17, -0.5], [0.24, 0.25, 0.9]]
    old_q = paper_kinematics.inverse_kinematics(paper, pose, mode=(-1, 1, -1)).q
    new_q = pkmlab.inverse_kinematics(models["paper"], pose, mode=(-1, 1, -1)).q
    theta_dot = np.array([0.3, -0.2, 0.5])
    m_old, c_old = paper_dynamics.actuator_space_model(paper, old_q, theta_dot)
    new = pkmlab.actuator_space_model(models["paper"], new_q, theta_dot)
    np.testing.assert_allclose(new.M, m_old, rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(new.c, c_old, rtol=1e-9, atol=1e-14)
    np.testing.assert_array_equal(new.g, 0.0)  # the paper's machine lies in the horizontal plane


def test_dynamics_are_batched_over_leading_axes(models):
    model = models["delta"]
    qs, _ = _regular_solutions(model, POSES["delta"])
    qs = qs[:4].reshape(2, 2, -1)
    theta_dot = np.array([[0.1, 0.2, -0.3]])  # broadcast against (2, 2)
    batch = pkmlab.actuator_space_model(model, qs, theta_dot)
    assert batch.M.shape == (2, 2, 3, 3) and batch.c.shape == (2, 2, 3)
    for index in np.ndindex(2, 2):
        one = pkmlab.actuator_space_model(model, qs[index], theta_dot[0])
        np.testing.assert_array_equal(batch.M[index], one.M)
        np.testing.assert_array_equal(batch.g[index], one.g)
    tau = pkmlab.inverse_dynamics(model, qs, theta_dot, np.zeros(3))
    np.testing.assert_allclose(tau, batch.c + batch.g, atol=1e-12)


# ------------------------------------------------------------------ refusals
def test_a_configuration_off_the_loop_closure_is_refused_naming_its_residual(models):
    model = models["paper"]
    q = pkmlab.inverse_kinematics(model, POSES["paper"], mode=(1, -1, 1)).q.copy()
    q[0] += 0.3
    for call in (lambda: pkmlab.actuator_space_model(model, q, np.zeros(3)),
                 lambda: pkmlab.coordinate_jacobian(model, q),
                 lambda: pkmlab.velocity_jacobian(model, q),
                 lambda: pkmlab.singularity_measure(model, q),
                 lambda: pkmlab.constrained_dynamics(model, q, np.zeros(9), np.zeros(3))):
        with pytest.raises(pkmlab.InvalidParameterError, match=r"^q is off the loop closure: max \|eta\(q\)\| = "):
            call()


def test_the_papers_own_formulation_refuses_a_configuration_off_the_loop_closure_too():
    """``pkmlab.paper``'s functions of the closed chain (Jacobians, rates, S, the constrained and reduced models,
    branch following) refuse what the unified API refuses; the full-space model and the residual itself, defined
    for any seven numbers, do not."""
    from pkmlab.paper import dynamics as dyn
    from pkmlab.paper import kinematics as kin
    from pkmlab.paper.geometry import Planar3RRR

    paper = Planar3RRR.paper()
    q = kin.inverse_kinematics(paper, POSES["paper"], mode=(1, -1, 1)).q.copy()
    q[0] += 0.3
    zero = np.zeros(3)
    for name, call in (("q", lambda: kin.velocity_jacobian(paper, q)), ("q", lambda: kin.passive_jacobian(paper, q)),
                       ("q", lambda: kin.singularity_measure(paper, q)),
                       ("q", lambda: kin.coordinate_rates(paper, q, zero)),
                       ("q", lambda: dyn.actuator_space_model(paper, q, zero)),
                       ("q", lambda: dyn.actuator_space_coriolis_matrix(paper, q, zero)),
                       ("q", lambda: dyn.forward_dynamics(paper, q, zero, zero)),
                       ("q", lambda: dyn.constrained_accelerations(paper, q, np.zeros(7), zero)),
                       ("q_previous", lambda: kin.branch_following(paper, q, q[:3]))):
        with pytest.raises(pkmlab.InvalidParameterError, match=rf"^{name} is off the loop closure: max \|eta"):
            call()
    assert np.abs(kin.constraint_residual(paper, q)).max() > 0.01
    assert np.isfinite(dyn.mass_matrix(paper, q)).all()


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e200])
def test_the_papers_own_formulation_refuses_rates_that_are_not_finite_or_overflow(bad):
    from pkmlab.paper import dynamics as dyn
    from pkmlab.paper import kinematics as kin
    from pkmlab.paper.geometry import Planar3RRR

    paper = Planar3RRR.paper()
    q = kin.inverse_kinematics(paper, POSES["paper"], mode=(1, -1, 1)).q
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^theta_dot"):
        dyn.actuator_space_model(paper, q, [bad, 0.0, 0.0])
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^(q_dot|theta_dot)"):
        dyn.constrained_accelerations(paper, q, np.full(7, bad), [0.0, 0.0, 0.0])


@pytest.mark.parametrize("bad", [np.nan, np.inf, 1e200])
def test_rates_that_are_not_finite_or_overflow_are_refused(models, bad):
    model = models["paper"]
    q = pkmlab.inverse_kinematics(model, POSES["paper"], mode=(1, -1, 1)).q
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^theta_dot"):
        pkmlab.actuator_space_model(model, q, [bad, 0.0, 0.0])


def test_an_overflow_says_only_pkmlabs_line_even_interpreted():
    """The command line's one-shot commands run the kernels interpreted, where NumPy warns of an overflow: the
    refusal is pkmlab's one line, no RuntimeWarning before it."""
    import subprocess
    import sys

    code = ("import pkmlab\nm = pkmlab.load('paper')\nq = pkmlab.inverse_kinematics(m, [0.25, 0.21, 0.0]).q[0]\n"
            "try:\n    pkmlab.actuator_space_model(m, q, [1e200, 0.0, 0.0])\nexcept pkmlab.InvalidParameterError as e:"
            "\n    print(e)\n")
    run = subprocess.run([sys.executable, "-W", "default", "-c", code], capture_output=True, text=True,
                         env={**__import__("os").environ, "PKMLAB_INTERPRETED": "1"}, timeout=120)
    assert run.stdout.strip() == "theta_dot overflows the model (values too large)"
    assert "Warning" not in run.stderr, run.stderr


def test_a_singular_configuration_is_refused_by_the_reduced_model(models):
    """The five-bar in working mode (+, -) crosses a gain-type singularity (the distal links aligned,
    S = sin(φ1 - φ2) = 0) on the vertical x = 0.05 m between y = 0.10 and 0.16 m: bisected to |S| < 1e-6."""
    model = models["five_bar"]

    def solution(y):
        return pkmlab.inverse_kinematics(model, [0.05, y], mode=(1, -1))

    lo, hi = 0.10, 0.16
    assert np.sign(solution(lo).S) != np.sign(solution(hi).S)
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if np.sign(solution(mid).S) == np.sign(solution(lo).S) else (lo, mid)
    singular = solution(lo)
    assert abs(singular.S) < 1e-6
    with pytest.raises(pkmlab.SingularityError, match="gain-type singularity"):
        pkmlab.actuator_space_model(model, singular.q, np.zeros(2))


def test_a_wrong_model_is_named(models):
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^model must be a pkmlab model"):
        pkmlab.inverse_kinematics(Planar3RRR.paper(), POSES["paper"])
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^pose must have 3 components"):
        pkmlab.inverse_kinematics(models["paper"], [0.2, 0.21])
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^mode must be"):
        pkmlab.inverse_kinematics(models["paper"], POSES["paper"], mode=(1, 1))
