"""The dynamics of any described mechanism, written once on its generated kernels: the paper's
3-RRR as pkmlab's own 3-RRR model gives it, and for every preset the invariants — symmetric
positive-definite mass matrices, the reduced model against the full multiplier model, gravity
as the gradient of the potential energy."""

import dataclasses
import math

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms import assembly
from pkmlab.description.presets import preset
from pkmlab.model import mechanism_model as mm
from pkmlab.paper import dynamics as paper_dynamics
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR

# a pose of each preset well inside its workspace, and a guess of its leg coordinates near one branch
POSES = {
    "paper": ([0.22, 0.2, 0.1], None),
    "five_bar": ([0.02, 0.36], [1.9, 1.2, 0.6, 2.4]),
    "3rpr": ([0.25, 0.21, -math.pi / 2], [0.3, 0.3, 0.3, 0.7, 2.8, -1.5]),
    "3prr": ([0.26, 0.15, 0.0], [0.2, 0.2, 0.2, 1.5, 0.0, -1.9]),
}


def configuration(name):
    """A configuration on the loop-closure manifold: the pose fixed, the other coordinates by Newton."""
    model = mm.MechanismModel.from_preset(name)
    pose, guess = POSES[name]
    if name == "paper":  # pkmlab's 3-RRR inverse kinematics: q = (theta, phi, alpha)
        q_old = kin.inverse_kinematics(Planar3RRR.paper(), pose, mode=(-1, 1, -1)).q
        return model, np.array([*q_old[:6], *pose]), q_old
    q = np.array([*guess, *pose], dtype=float)
    free = len(q) - len(pose)
    for _ in range(60):
        eta = mm.constraint_residual(model, q)
        if np.max(np.abs(eta)) < 1e-15:
            break
        q[:free] -= np.linalg.solve(mm.constraint_jacobian(model, q)[:, :free], eta)
    assert np.max(np.abs(mm.constraint_residual(model, q))) < 1e-13
    return model, q, None


def test_the_paper_preset_has_pkmlabs_3rrr_dynamics():
    model, q, q_old = configuration("paper")
    paper = Planar3RRR.paper()
    for theta_dot in ([0.0, 0.0, 0.0], [0.3, -0.2, 0.5], [-1.1, 0.7, 0.2]):
        m_theta, c_theta, g_theta = mm.actuator_space_model(model, q, theta_dot)
        m_ref, c_ref = paper_dynamics.actuator_space_model(paper, q_old, theta_dot)
        np.testing.assert_allclose(m_theta, m_ref, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(c_theta, c_ref, rtol=1e-11, atol=1e-15)
        assert np.all(g_theta == 0.0)  # the horizontal plane


@pytest.mark.parametrize("name", sorted(POSES))
def test_mass_matrices_are_symmetric_positive_definite(name):
    model, q, _ = configuration(name)
    M, _h, _g = mm.full_space_model(model, q, np.zeros_like(q))
    m_theta, _c, _gt = mm.actuator_space_model(model, q, np.zeros(model.n_actuators))
    for A in (M, m_theta):
        np.testing.assert_allclose(A, A.T, atol=1e-15)
        assert np.linalg.eigvalsh(A).min() > 0


@pytest.mark.parametrize("name", sorted(POSES))
def test_reduced_model_equals_the_full_multiplier_model(name):
    """theta_ddot from eq. (35) is the actuated part of q_ddot from eq. (26), with gravity on."""
    model, q, _ = configuration(name)
    heavy = mm.MechanismModel.from_description(dataclasses.replace(model.description, gravity=(0.0, -9.81)))
    rng = np.random.default_rng(2)
    for m in (model, heavy):
        j, n = mm.constraint_jacobian(m, q), m.n_actuators
        j_q_theta = np.vstack([np.eye(n), -np.linalg.solve(j[:, n:], j[:, :n])])  # eqs. (15), (31)
        for _ in range(5):
            theta_dot, tau = rng.normal(size=m.n_actuators), rng.normal(size=m.n_actuators)
            m_theta, c_theta, g_theta = mm.actuator_space_model(m, q, theta_dot)
            reduced = np.linalg.solve(m_theta, tau - c_theta - g_theta)
            q_ddot, _lam = mm.constrained_accelerations(m, q, j_q_theta @ theta_dot, tau)
            np.testing.assert_allclose(q_ddot[:m.n_actuators], reduced, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("name", sorted(POSES))
def test_gravity_is_the_gradient_of_the_potential_energy(name):
    model, q, _ = configuration(name)
    heavy = mm.MechanismModel.from_description(dataclasses.replace(model.description, gravity=(0.0, -9.81)))
    masses = heavy.body_weights[:, 0]

    def potential(q):
        poses = np.empty((heavy.kernels.N_BODIES, 3))
        heavy.kernels.body_poses(q, mm.trig_table(heavy, q), heavy.P, poses)
        return float(np.sum(masses * 9.81 * poses[:, 1]))  # V = sum m g y

    h = 1e-6
    fd = np.array([(potential(q + h * e) - potential(q - h * e)) / (2 * h) for e in np.eye(len(q))])
    np.testing.assert_allclose(mm.gravity_vector(heavy, q), fd, atol=1e-7)
    # gθ = Jqθᵀ ∂V/∂q, with Jqθ = [I; -Jηφ⁻¹ Jηθ] (eqs. 15, 31) from the constraint Jacobian
    n = heavy.n_actuators
    j = mm.constraint_jacobian(heavy, q)
    j_q_theta = np.vstack([np.eye(n), -np.linalg.solve(j[:, n:], j[:, :n])])
    np.testing.assert_allclose(mm.actuator_space_model(heavy, q, np.zeros(heavy.n_actuators))[2], j_q_theta.T @ fd,
                               atol=1e-7)


def test_bad_arguments_are_named():
    model = mm.MechanismModel.from_preset("five_bar")
    with pytest.raises(pkmlab.InvalidParameterError, match="q must be the 6 coordinates"):
        mm.constraint_residual(model, [0.0, 1.0])
    with pytest.raises(pkmlab.InvalidParameterError, match="description must be a Mechanism"):
        mm.MechanismModel.from_description("five_bar")
    with pytest.raises(pkmlab.InvalidParameterError, match="unknown mechanism preset"):
        mm.MechanismModel.from_preset("scara")
    assert preset("five_bar") == model.description


# ------------------------------------------------------------------ inverse kinematics in closed form
IK_POSES = {"paper": [0.2, 0.21, 0.0], "five_bar": [0.0, 0.35], "3rpr": [0.25, 0.21, -math.pi / 2],
            "3prr": [0.26, 0.2, 0.0]}


@pytest.mark.parametrize("name", sorted(IK_POSES))
def test_inverse_kinematics_closes_every_loop_in_every_working_mode(name):
    from pkmlab.description.mechanism import leg_chain

    model = mm.MechanismModel.from_preset(name)
    modes = mm.working_modes(model)
    assert len(modes) == {"paper": 8, "five_bar": 4, "3rpr": 1, "3prr": 8}[name]
    reached = 0
    for mode in modes:
        try:
            q = mm.inverse_kinematics(model, IK_POSES[name], mode)
        except pkmlab.UnreachablePoseError as exc:
            assert "stroke" in str(exc) and name == "3prr"
            continue
        reached += 1
        np.testing.assert_allclose(mm.constraint_residual(model, q), 0.0, atol=1e-15)
        legs = model.description.legs
        two_branch = [i for i, leg in enumerate(legs) if leg.notation != "RP*R"]
        for sigma, i in zip(mode, two_branch, strict=True):
            leg = legs[i]
            coords = [q[i] if j.actuated else None for j in leg.joints[:-1]]
            passive = iter(q[model.n_actuators + sum(len(lg.joints) - 2 for lg in legs[:i]):])
            coords = [c if c is not None else next(passive) for c in coords]
            chain = leg_chain(leg, coords)
            end = np.array(chain[-1][0])
            if leg.notation == "R*RR":  # sigma = +1: the elbow left of base -> attachment point
                d, e = end - np.array(leg.base), np.array(chain[1][0]) - np.array(leg.base)
                assert np.sign(d[0] * e[1] - d[1] * e[0]) == sigma
    assert reached > 0


def test_inverse_kinematics_of_the_paper_preset_is_pkmlabs():
    model = mm.MechanismModel.from_preset("paper")
    ik = kin.inverse_kinematics(Planar3RRR.paper(), [0.23, 0.19, 0.2])
    for mode, q_old in zip(mm.working_modes(model), ik.q, strict=True):
        q = mm.inverse_kinematics(model, [0.23, 0.19, 0.2], mode)
        np.testing.assert_allclose(np.angle(np.exp(1j * (q[:6] - q_old[:6]))), 0.0, atol=1e-12)


def test_the_3prr_working_mode_picks_the_farther_slider():
    model = mm.MechanismModel.from_preset("3prr")
    pose = [0.26, 0.2, 0.0]
    far = mm.inverse_kinematics(model, pose, (1, 1, 1))
    # flip leg 1 only, where the nearer root stays on the rail
    for mode in ((-1, 1, 1), (1, -1, 1), (1, 1, -1)):
        try:
            near = mm.inverse_kinematics(model, pose, mode)
        except pkmlab.UnreachablePoseError:
            continue
        k = mode.index(-1)
        assert near[k] < far[k]


def test_unreachable_poses_name_the_leg_and_the_stroke():
    model = mm.MechanismModel.from_preset("3rpr")
    with pytest.raises(pkmlab.UnreachablePoseError, match=r"leg \d needs its actuator at .* outside its stroke "
                                                          r"\[0.1, 0.45\] m"):
        mm.inverse_kinematics(model, [0.25, 0.6, -math.pi / 2], ())
    # leg 2 at (0.1, 0): sqrt(0.6^2 + 0.3^2) = 0.67082 m away, beyond 0.25 + 0.30
    with pytest.raises(pkmlab.UnreachablePoseError, match="leg 2: the attachment point is 0.67082 m from its base, "
                                                          "beyond its reach"):
        mm.inverse_kinematics(mm.MechanismModel.from_preset("five_bar"), [-0.5, 0.3], (1, 1))
    with pytest.raises(pkmlab.InvalidParameterError, match="one sign"):
        mm.inverse_kinematics(mm.MechanismModel.from_preset("five_bar"), [0.0, 0.35], (1,))


# ------------------------------------------------------------------ singularity measure
def test_the_paper_presets_S_is_the_papers():
    model = mm.MechanismModel.from_preset("paper")
    paper = Planar3RRR.paper()
    for pose in ([0.2, 0.21, 0.0], [0.28, 0.17, -0.5], [0.24, 0.25, 0.9]):
        for mode, s_old in zip(mm.working_modes(model), kin.inverse_kinematics(paper, pose).S, strict=True):
            q = mm.inverse_kinematics(model, pose, mode)
            assert mm.singularity_measure(model, q) == pytest.approx(float(s_old), rel=1e-12, abs=1e-14)


def test_3rpr_is_singular_everywhere_at_alpha_zero_and_S_vanishes_with_det_J_eta_phi():
    """Similar base and platform: at alpha = 0 the three legs meet in one point wherever the platform is."""
    model = mm.MechanismModel.from_preset("3rpr")
    for x, y in ((0.25, 0.21), (0.22, 0.16), (0.3, 0.2)):
        q = mm.inverse_kinematics(model, [x, y, 0.0], ())
        assert abs(mm.singularity_measure(model, q)) < 1e-12
        j = mm.constraint_jacobian(model, q)[:, model.n_actuators:]
        assert abs(np.linalg.det(j)) < 1e-12 * np.linalg.norm(j) ** j.shape[0]
        q = mm.inverse_kinematics(model, [x, y, -math.pi / 2], ())
        assert abs(mm.singularity_measure(model, q)) > 0.1


def test_five_bar_S_is_the_sine_between_its_distal_links():
    model = mm.MechanismModel.from_preset("five_bar")
    q = mm.inverse_kinematics(model, [0.0, 0.35], (1, -1))
    phi1, phi2 = q[2], q[3]  # the distal links' absolute angles (passive coordinates)
    assert mm.singularity_measure(model, q) == pytest.approx(math.sin(phi1 - phi2), abs=1e-15)


# ------------------------------------------------------------------ forward kinematics
def test_five_bar_forward_kinematics_finds_both_assembly_modes_and_ik_round_trips():
    model = mm.MechanismModel.from_preset("five_bar")
    for point in ([0.0, 0.35], [0.05, 0.3], [-0.06, 0.4]):
        for mode in mm.working_modes(model):
            q = mm.inverse_kinematics(model, point, mode)
            solutions = assembly.five_bar_assembly_modes(model, q[:2])
            assert len(solutions) == 2  # two circles meet twice away from the singularity
            for s in solutions:
                np.testing.assert_allclose(mm.constraint_residual(model, s), 0.0, atol=1e-15)
            # FK of IK: one assembly mode is the pose itself
            assert min(np.hypot(*(s[-2:] - point)) for s in solutions) < 1e-14


@pytest.mark.parametrize("name", sorted(IK_POSES))
def test_branch_following_tracks_inverse_kinematics_along_a_path(name):
    """Driven by the actuators of the IK of a path, branch following stays on that IK's branch."""
    model = mm.MechanismModel.from_preset(name)
    mode = mm.working_modes(model)[0] if name != "3prr" else (1, 1, 1)
    start = np.array(IK_POSES[name])
    path = [start + t * np.array([0.02, 0.01, 0.05][:len(start)]) for t in np.linspace(0.0, 1.0, 11)]
    q = mm.inverse_kinematics(model, path[0], mode)
    for pose in path[1:]:
        expected = mm.inverse_kinematics(model, pose, mode)
        q = pkmlab.branch_following(model, q, expected[:model.n_actuators])
        np.testing.assert_allclose(np.angle(np.exp(1j * (q - expected))), 0.0, atol=1e-10)


def test_branch_following_stops_at_a_singularity():
    """The 3-RPR turned through alpha = 0 (singular there, wherever the platform is): refused on the way."""
    model = mm.MechanismModel.from_preset("3rpr")
    q = mm.inverse_kinematics(model, [0.25, 0.21, -0.3], ())
    with pytest.raises(pkmlab.BranchFollowingError, match="gain-type singularity"):
        for alpha in np.linspace(-0.3, 0.3, 13)[1:]:
            q = pkmlab.branch_following(model, q, mm.inverse_kinematics(model, [0.25, 0.21, alpha], ())[:3])


def test_the_planar_machine_tutorial_example_runs(tmp_path, monkeypatch):
    """The example of docs/tutorials/your-machine.md, "A planar machine", runs as it is written."""
    from pathlib import Path

    page = (Path(__file__).resolve().parent.parent / "docs" / "tutorials" / "your-machine.md").read_text()
    section = page[page.index("## A planar machine"):]
    block = section[section.index("```python\n") + len("```python\n"):]
    monkeypatch.chdir(tmp_path)
    namespace = {}
    exec(block[: block.index("```")], namespace)  # noqa: S102 - the tutorial's own example
    assert namespace["mine"] == preset("3rpr") and namespace["reduced"].M.shape == (2, 2)
    assert len(namespace["both"]) == 2


# ------------------------------------------------------------------ forward kinematics: every assembly mode
def circles_of(mechanism, theta):
    """Each leg's circle for the platform's attachment point, written from the leg formulas (independent
    of pkmlab's leg_types): R*RR elbow b + l u(theta), radius r; RP*R centre b, radius rho; P*RR slider
    pivot b + s u(beta), radius r."""
    out = []
    for leg, t in zip(mechanism.legs, theta, strict=True):
        b = np.array(leg.base)
        if leg.notation == "R*RR":
            out.append((b + leg.bodies[0].tip[0] * np.array([math.cos(t), math.sin(t)]), leg.bodies[1].tip[0]))
        elif leg.notation == "RP*R":
            out.append((b, t))
        else:
            beta = leg.joints[0].axis
            out.append((b + t * np.array([math.cos(beta), math.sin(beta)]), leg.bodies[1].tip[0]))
    return out


def independent_count(mechanism, theta, n=20000):
    """How many placements put every attachment point on its circle — by scanning alpha, no polynomial:
    vertex 1 on circles 1 and (2 shifted by the platform), then the sign changes of leg 3's misfit."""
    (c1, r1), (c2, r2), (c3, r3) = circles_of(mechanism, theta)
    att = np.array(mechanism.platform.attachments)
    alpha = np.linspace(-math.pi, math.pi, n, endpoint=False)
    rot = np.stack([np.stack([np.cos(alpha), -np.sin(alpha)], -1), np.stack([np.sin(alpha), np.cos(alpha)], -1)], -2)
    v2, v3 = rot @ (att[1] - att[0]), rot @ (att[2] - att[0])
    centre = c2 - v2  # vertex 1 lies on this circle of radius r2 too
    d = centre - c1
    dist = np.hypot(d[:, 0], d[:, 1])
    along = (r1**2 - r2**2 + dist**2) / (2 * dist)
    h = np.sqrt(np.where(r1**2 - along**2 >= 0, r1**2 - along**2, np.nan))
    count, misfit = 0, []
    for sign in (1.0, -1.0):
        normal = np.stack([-d[:, 1], d[:, 0]], -1) / dist[:, None]
        p1 = c1 + along[:, None] * d / dist[:, None] + sign * h[:, None] * normal
        f = np.hypot(*(p1 + v3 - c3).T) - r3
        g = np.roll(f, -1)
        count += int(np.sum(np.isfinite(f) & np.isfinite(g) & (np.sign(f) != np.sign(g))))
        misfit.append(f)
    # the two branches join where circles 1 and 2 touch: a root in that turn shows as a sign change
    # between the branches at the last sample before the join
    finite = np.isfinite(h)
    ends = finite & ~(np.roll(finite, 1) & np.roll(finite, -1))
    return count + int(np.sum(ends & (np.sign(misfit[0]) != np.sign(misfit[1]))))


def test_the_paper_presets_assembly_modes_are_pkmlabs():
    model = mm.MechanismModel.from_preset("paper")
    rng = np.random.default_rng(4)
    for _ in range(10):
        theta = rng.uniform(-math.pi, math.pi, 3)
        ours = assembly.assembly_modes(model, theta)
        ref = kin.forward_kinematics(Planar3RRR.paper(), theta)
        assert len(ours) == len(ref)
        for (q, s), sol in zip(ours, ref, strict=True):
            np.testing.assert_allclose(q[-3:], sol.pose, atol=1e-10)
            assert s == pytest.approx(sol.S, abs=1e-10)


def _six_modes(mechanism, rng, draw, tries=4000):
    """Actuator values with 6 real assembly modes, well apart (the test looks for them itself)."""
    model = mm.MechanismModel.from_description(mechanism)
    for _ in range(tries):
        theta = draw(rng)
        if independent_count(mechanism, theta, 4000) == 6:
            solutions = assembly.assembly_modes(model, theta)
            if len(solutions) == 6 and min(abs(s) for _q, s in solutions) > 0.02:
                return model, theta, solutions
    raise AssertionError("no input with 6 assembly modes found")


def test_3prr_has_inputs_with_six_assembly_modes_and_fk_finds_them_all():
    m = preset("3prr")
    model, theta, solutions = _six_modes(m, np.random.default_rng(1), lambda r: r.uniform(0.0, 0.52, 3))
    assert independent_count(m, theta) == 6
    for q, _s in solutions:
        np.testing.assert_allclose(mm.constraint_residual(model, q), 0.0, atol=1e-12)


def test_a_3rpr_whose_platform_is_not_similar_to_its_base_has_six_assembly_modes():
    base = preset("3rpr")
    platform = dataclasses.replace(base.platform, attachments=((-0.3, 0.0), (0.3, 0.0), (0.0, 0.1)))
    legs = tuple(dataclasses.replace(leg, stroke=(0.05, 0.8)) for leg in base.legs)
    m = dataclasses.replace(base, name="my 3-RPR", platform=platform, legs=legs)
    model, theta, solutions = _six_modes(m, np.random.default_rng(2), lambda r: r.uniform(0.05, 0.8, 3))
    assert independent_count(m, theta) == 6 and len(solutions) == 6


def test_the_3rpr_preset_similar_triangles_have_at_most_four_assembly_modes():
    base = preset("3rpr")  # its geometry, with longer strokes: the 4-mode region needs long legs
    model = mm.MechanismModel.from_description(
        dataclasses.replace(base, legs=tuple(dataclasses.replace(leg, stroke=(0.05, 0.8)) for leg in base.legs)))
    rng = np.random.default_rng(3)
    counts = []
    for _ in range(400):
        theta = rng.uniform(0.05, 0.8, 3)
        n = independent_count(model.description, theta, 8000)
        solutions = assembly.assembly_modes(model, theta)
        if min((abs(s) for _q, s in solutions), default=1.0) > 0.02:
            assert len(solutions) == n
        counts.append(len(solutions))
    assert max(counts) <= 4 and 4 in counts


@pytest.mark.parametrize("name", sorted(IK_POSES))
def test_forward_kinematics_of_inverse_kinematics_finds_the_pose(name):
    model = mm.MechanismModel.from_preset(name)
    for mode in mm.working_modes(model):
        try:
            q = mm.inverse_kinematics(model, IK_POSES[name], mode)
        except pkmlab.UnreachablePoseError:
            continue
        poses = [sol[-model.description.dof:] for sol, _s in assembly.assembly_modes(model, q[:model.n_actuators])]
        assert min(np.max(np.abs(np.angle(np.exp(1j * (p - q[-len(p):]))))) for p in poses) < 1e-10


def test_double_roots_at_a_singularity_are_one_assembly_mode():
    """At alpha = 0 the 3-RPR preset is singular: its pose is a double root of the polynomial, reported once."""
    model = mm.MechanismModel.from_preset("3rpr")
    q = mm.inverse_kinematics(model, [0.24, 0.17, 0.0], ())
    found = assembly.assembly_modes(model, q[:3])
    near = [s for s in found if np.hypot(*(s[0][-3:-1] - [0.24, 0.17])) < 1e-5]
    assert len(near) == 1


def test_forward_kinematics_refuses_actuators_outside_their_strokes():
    with pytest.raises(pkmlab.InvalidParameterError, match=r"leg 1: actuator value -0.3 m is outside its stroke"):
        assembly.assembly_modes(mm.MechanismModel.from_preset("3rpr"), [-0.3, 0.3, 0.3])


def test_S_of_3rpr_and_3prr_is_the_formula_of_their_specification():
    """S = sin(d1 - alpha) sin(d2 - d3) + sin(d1 - d2) sin(alpha + 2 pi/3 - d3), d_i the legs' last angles:
    psi_i = angle of b_i -> p_i for the 3-RPR, phi_i = angle of C_i -> p_i for the 3-PRR (written out here)."""
    rng = np.random.default_rng(8)
    b = np.array([(0.0, 0.0), (0.52, 0.0), (0.26, math.sqrt(3) / 2 * 0.52)])
    beta = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)
    for name in ("3rpr", "3prr"):
        model = mm.MechanismModel.from_preset(name)
        checked = 0
        while checked < 30:
            pose = [rng.uniform(0.15, 0.35), rng.uniform(0.1, 0.3), rng.uniform(-math.pi, math.pi)]
            mode = () if name == "3rpr" else (1, 1, 1)
            try:
                q = mm.inverse_kinematics(model, pose, mode)
            except pkmlab.UnreachablePoseError:
                continue
            x, y, alpha = pose
            p1 = np.array([x, y]) - 0.125 / math.sqrt(3) * np.array([math.cos(alpha + math.pi / 6),
                                                                     math.sin(alpha + math.pi / 6)])
            p = [p1, p1 + 0.125 * np.array([math.cos(alpha), math.sin(alpha)]),
                 p1 + 0.125 * np.array([math.cos(alpha + math.pi / 3), math.sin(alpha + math.pi / 3)])]
            if name == "3rpr":
                d = [math.atan2(*(p[i] - b[i])[::-1]) for i in range(3)]
            else:
                c = [b[i] + q[i] * np.array([math.cos(beta[i]), math.sin(beta[i])]) for i in range(3)]
                d = [math.atan2(*(p[i] - c[i])[::-1]) for i in range(3)]
            s = (math.sin(d[0] - alpha) * math.sin(d[1] - d[2])
                 + math.sin(d[0] - d[1]) * math.sin(alpha + 2 * math.pi / 3 - d[2]))
            assert mm.singularity_measure(model, q) == pytest.approx(s, abs=1e-12)
            checked += 1


def test_3rpr_kinetic_energy_from_its_specification():
    """T = 1/2 rho_dot' M rho_dot against the kinetic energy of the bodies as the specification places them:
    cylinder 0.50 kg at 0.08 m from b_i (1.5e-3), rod 0.25 kg at 0.06 m from p_i towards b_i (0.6e-3), the
    platform 0.234 kg at its centroid (0.305e-3) — velocities by central differences along a pose motion."""
    model = mm.MechanismModel.from_preset("3rpr")
    b = np.array([(0.0, 0.0), (0.52, 0.0), (0.26, math.sqrt(3) / 2 * 0.52)])
    pose0, pose_dot = np.array([0.25, 0.21, -1.3]), np.array([0.3, -0.2, 0.7])

    def bodies(pose):
        x, y, alpha = pose
        p1 = np.array([x, y]) - 0.125 / math.sqrt(3) * np.array([math.cos(alpha + math.pi / 6),
                                                                 math.sin(alpha + math.pi / 6)])
        p = [p1, p1 + 0.125 * np.array([math.cos(alpha), math.sin(alpha)]),
             p1 + 0.125 * np.array([math.cos(alpha + math.pi / 3), math.sin(alpha + math.pi / 3)])]
        out, rho = [], []
        for i in range(3):
            d = p[i] - b[i]
            psi, r = math.atan2(d[1], d[0]), math.hypot(*d)
            u = d / r
            out += [(b[i] + 0.08 * u, psi), (b[i] + (r - 0.06) * u, psi)]
            rho.append(r)
        out.append((np.array([x, y]), alpha))
        return out, np.array(rho)

    h = 1e-6
    plus, rho_plus = bodies(pose0 + h * pose_dot)
    minus, rho_minus = bodies(pose0 - h * pose_dot)
    data = [(0.50, 1.5e-3), (0.25, 0.6e-3)] * 3 + [(0.234, 0.305e-3)]
    energy = 0.0
    for (m, inertia), (c1, a1), (c0, a0) in zip(data, plus, minus, strict=True):
        v, w = (c1 - c0) / (2 * h), (a1 - a0) / (2 * h)
        energy += 0.5 * m * v @ v + 0.5 * inertia * w * w
    rho_dot = (rho_plus - rho_minus) / (2 * h)
    q = mm.inverse_kinematics(model, pose0, ())
    m_theta = mm.actuator_space_model(model, q, np.zeros(3))[0]
    assert 0.5 * rho_dot @ m_theta @ rho_dot == pytest.approx(energy, rel=1e-7)


def test_a_shipped_structure_whose_module_fails_to_import_is_an_error_not_a_new_structure(monkeypatch, tmp_path):
    """bind takes a structure whose kernel module pkmlab ships as shipped: a failure to import that module (a
    dependency of its missing, say) is raised as it is, instead of the structure being derived again as one new to
    the installation, into the cache folder under the shipped module's name."""
    import importlib
    import importlib.util

    from pkmlab import _compile_cache

    description = pkmlab.load("five_bar").description
    name = mm.kernels_name(description)
    assert name.startswith(mm.SHIPPED_KERNELS)
    real_import = importlib.import_module

    def failing(module, package=None):
        if importlib.util.resolve_name(module, package) == name:  # (however bind names it)
            raise ModuleNotFoundError("No module named 'a_missing_dependency'", name="a_missing_dependency")
        return real_import(module, package)

    monkeypatch.setattr(mm.importlib, "import_module", failing)
    monkeypatch.setattr(_compile_cache, "CACHE_DIR", tmp_path)
    with pytest.raises(ModuleNotFoundError, match="a_missing_dependency"):
        mm.bind(description)
    assert not (tmp_path / "kernels").exists()
