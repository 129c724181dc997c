"""Kinematics checked against independent statements of the paper's equations."""

import numpy as np
import pytest
import reference as ref
from conftest import random_reachable_poses
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import pkmlab
from pkmlab.errors import BranchFollowingError, InvalidParameterError, UnreachablePoseError
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import WORKING_MODES, Planar3RRR

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
poses = st.tuples(
    st.floats(0.08, 0.44), st.floats(0.02, 0.40), st.floats(-1.0, 1.0)
).map(np.array)


def cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def angle_diff(a, b):
    return np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b))))


# ------------------------------------------------------------------ inverse kinematics
@SETTINGS
@given(pose=poses)
def test_inverse_kinematics_satisfies_loop_closure_and_reaches_the_pose(paper, pose):
    ik = kin.inverse_kinematics(paper, pose, on_unreachable="nan")
    for mode, q in zip(ik.modes, ik.q, strict=True):
        if np.isnan(q).any():
            continue
        assert np.max(np.abs(ref.eta(q))) < 1e-12
        np.testing.assert_allclose(ref.pose(q), pose, atol=1e-12)
        # conventions §3: σ_i = +1 when the elbow lies to the left of b_i → p_i
        e = ref.BASE + ref.L * np.stack([np.cos(q[:3]), np.sin(q[:3])], axis=-1)
        p = e + ref.R * np.stack([np.cos(q[3:6]), np.sin(q[3:6])], axis=-1)
        np.testing.assert_array_equal(np.sign(cross2(p - ref.BASE, e - ref.BASE)), mode)


def test_inverse_kinematics_all_modes_are_distinct(paper):
    ik = kin.inverse_kinematics(paper, [0.2, 0.21, 0.0])
    assert ik.q.shape == (8, 7)
    assert len({tuple(np.round(q, 9)) for q in ik.q}) == 8
    assert ik.modes.tolist() == [list(m) for m in WORKING_MODES]


def test_inverse_kinematics_batch_equals_single(paper):
    rng = np.random.default_rng(3)
    batch = random_reachable_poses(rng, paper, 12).reshape(3, 4, 3)
    ik = kin.inverse_kinematics(paper, batch, on_unreachable="nan")
    assert ik.q.shape == (3, 4, 8, 7)
    single = kin.inverse_kinematics(paper, batch[2, 1], on_unreachable="nan")
    np.testing.assert_array_equal(ik.q[2, 1], single.q)


def test_unreachable_pose_names_the_legs(paper):
    # vertex 2 placed 0.5 m from b2: beyond l + r = 0.4167 m, the other legs within reach
    with pytest.raises(UnreachablePoseError, match="leg") as info:
        kin.inverse_kinematics(paper, [0.9, 0.1, 0.0])
    assert info.value.legs == (1, 2, 3)
    # only leg 3 out of reach: below the base line, p3 is 0.428 m from b3
    with pytest.raises(UnreachablePoseError) as info:
        kin.inverse_kinematics(paper, [0.26, -0.05, 0.0], mode=(1, 1, 1))
    assert info.value.legs == (3,)
    assert "leg 3" in str(info.value)


def test_unreachable_in_a_batch_reports_the_index(paper):
    batch = np.array([[0.2, 0.21, 0.0], [0.26, -0.05, 0.0]])
    with pytest.raises(UnreachablePoseError, match=r"at index \(1,\)"):
        kin.inverse_kinematics(paper, batch)


@pytest.mark.parametrize("bad", [[np.nan, 0.2, 0.0], [0.2, np.inf, 0.0], [0.2, 0.2], "abc"])
def test_bad_pose_is_refused(paper, bad):
    with pytest.raises(InvalidParameterError):
        kin.inverse_kinematics(paper, bad)


# ------------------------------------------------------------------ forward kinematics
@SETTINGS
@given(pose=poses)
def test_forward_of_inverse_is_identity_for_every_working_mode(paper, pose):
    ik = kin.inverse_kinematics(paper, pose, on_unreachable="nan")
    ok = ~np.isnan(ik.S) & (np.abs(ik.S) > 0.02)
    assume(ok.any())
    fk = kin.forward_kinematics(paper, ik.theta[ok])
    for j, q in enumerate(ik.q[ok]):
        n = fk.count[j]
        err = np.max(np.abs(angle_diff(fk.q[j, :n, 3:], q[3:])), axis=1)
        assert err.min() <= 1e-10, (q, fk.q[j, :n])
        k = int(np.argmin(err))
        np.testing.assert_allclose(fk.pose[j, k, :2], pose[:2], atol=1e-10)
        assert abs(angle_diff(fk.pose[j, k, 2], pose[2])) <= 1e-10


@SETTINGS
@given(theta=st.tuples(*[st.floats(-np.pi, np.pi)] * 3).map(np.array))
def test_every_forward_solution_closes_the_loops(paper, theta):
    fk = kin.forward_kinematics(paper, theta)
    for sol in fk:
        assert np.max(np.abs(ref.eta(sol.q))) <= 1e-12
        np.testing.assert_array_equal(sol.q[:3], theta)
        np.testing.assert_allclose(ref.pose(sol.q), sol.pose, atol=1e-12)


def test_number_of_assembly_modes_matches_an_independent_scan(paper):
    rng = np.random.default_rng(11)
    thetas = np.concatenate([
        rng.uniform(-np.pi, np.pi, (60, 3)),
        kin.inverse_kinematics(paper, random_reachable_poses(rng, paper, 20), mode=(-1, 1, -1),
                                  on_unreachable="nan").theta,
    ])
    thetas = thetas[np.isfinite(thetas).all(axis=1)]
    counts = kin.forward_kinematics(paper, thetas).count
    expected = [ref.count_assembly_modes(t) for t in thetas]
    np.testing.assert_array_equal(counts, expected)
    assert counts.max() >= 2


def test_six_assembly_modes_are_all_found(paper):
    """Search θ until the independent scan counts six real solutions; FK must find all six."""
    rng = np.random.default_rng(2024)
    found = []
    for _ in range(20000):
        theta = rng.uniform(-np.pi, np.pi, 3)
        if ref.count_assembly_modes(theta, n_alpha=4000) == 6 and ref.count_assembly_modes(theta) == 6:
            found.append(theta)
            if len(found) == 3:
                break
    assert found, "the search found no θ with six assembly modes"
    fk = kin.forward_kinematics(paper, np.array(found))
    np.testing.assert_array_equal(fk.count, 6)
    for j in range(len(found)):
        alphas = fk.q[j, :, 6]
        assert np.min(np.abs(angle_diff(alphas[:, None], alphas[None, :])) + 10 * np.eye(6)) > 1e-6
        for q in fk.q[j]:
            assert np.max(np.abs(ref.eta(q))) <= 1e-12


def test_per_leg_geometry_round_trip():
    model = Planar3RRR.from_params(l=[0.25, 0.24, 0.27], r=[0.17, 0.16, 0.18], a=0.11)
    kw = dict(l=model.active_lengths, r=model.passive_lengths, a=0.11)
    rng = np.random.default_rng(5)
    tested = 0
    for pose in random_reachable_poses(rng, model, 15):
        ik = kin.inverse_kinematics(model, pose, on_unreachable="nan")
        for q, s in zip(ik.q, ik.S, strict=True):
            if np.isnan(s) or abs(s) < 0.02:
                continue
            assert np.max(np.abs(ref.eta(q, **kw))) < 1e-12
            fk = kin.forward_kinematics(model, q[:3])
            assert fk.count == ref.count_assembly_modes(q[:3], **kw)
            assert np.min(np.max(np.abs(angle_diff(fk.q[: fk.count, 3:], q[3:])), axis=1)) < 1e-10
            tested += 1
    assert tested > 20


def test_root_near_alpha_pi_is_found(paper):
    """A configuration with α = π exactly makes the sextic's leading coefficient vanish."""
    rng = np.random.default_rng(8)
    for _ in range(200):
        pose = np.array([rng.uniform(0.15, 0.35), rng.uniform(0.1, 0.3), np.pi])
        ik = kin.inverse_kinematics(paper, pose, on_unreachable="nan")
        good = np.flatnonzero(np.abs(ik.S) > 0.05)
        if good.size:
            q = ik.q[good[0]]
            break
    else:
        pytest.skip("no reachable pose at α = π")
    for shift in (0.0, 1e-9, -1e-7):
        theta = q[:3].copy()
        fk = kin.forward_kinematics(paper, theta if shift == 0 else theta + shift)
        err = np.abs(angle_diff(fk.q[: fk.count, 6], np.pi))
        assert err.min() < 1e-5 + 10 * abs(shift)
        assert fk.count == ref.count_assembly_modes(fk.q[0, :3])


def _towards_singularity(paper):
    """A start configuration and a θ step along which |S| decreases fastest (on its branch)."""
    theta0 = kin.inverse_kinematics(paper, [0.2, 0.21, 0.0], mode=(1, -1, 1)).theta
    q = kin.forward_kinematics(paper, theta0).nearest([0.2, 0.21, 0.0]).q
    grad = np.zeros(3)
    for i in range(3):
        d = np.zeros(3)
        d[i] = 1e-6
        s_plus = kin.singularity_measure(paper, kin.branch_following(paper, q, theta0 + d))
        s_minus = kin.singularity_measure(paper, kin.branch_following(paper, q, theta0 - d))
        grad[i] = (abs(s_plus) - abs(s_minus)) / 2e-6
    return q, -grad / np.linalg.norm(grad)


def test_near_double_root_is_resolved(paper):
    """Close to a gain-type singularity two assembly modes nearly coincide; both are found."""
    q0, direction = _towards_singularity(paper)
    theta0 = q0[:3]
    count0 = int(kin.forward_kinematics(paper, theta0).count)
    lo, hi = 0.0, None
    for s in np.linspace(0, 2.0, 2001)[1:]:
        if kin.forward_kinematics(paper, theta0 + s * direction).count != count0:
            hi = s
            break
        lo = s
    assert hi is not None, "no fold met along the steepest-descent direction of |S|"
    for _ in range(45):  # bisect to the fold
        mid = 0.5 * (lo + hi)
        if kin.forward_kinematics(paper, theta0 + mid * direction).count == count0:
            lo = mid
        else:
            hi = mid
    theta = theta0 + lo * direction
    fk = kin.forward_kinematics(paper, theta)
    assert count0 == ref.count_assembly_modes(theta0)
    assert fk.count == count0
    # two modes nearly merged (a dense α scan cannot even separate them), yet both are found
    assert np.min(np.abs(fk.S[: fk.count])) < 1e-3
    alphas = fk.q[: fk.count, 6]
    gaps = np.abs(angle_diff(alphas[:, None], alphas[None, :]))[np.triu_indices(fk.count, 1)]
    assert 0 < gaps.min() < 1e-3
    for q in fk.q[: fk.count]:
        assert np.max(np.abs(ref.eta(q))) <= 1e-12


# ------------------------------------------------------------------ branch following
def test_branch_following_tracks_the_ik_branch_around_the_paper_circle(paper):
    s = np.linspace(0, 2 * np.pi, 400)
    path = np.stack([0.25 + 0.05 * np.cos(np.pi + s), 0.21 + 0.05 * np.sin(np.pi + s), 0 * s], axis=-1)
    for mode in WORKING_MODES:
        ik = kin.inverse_kinematics(paper, path, mode=mode)
        q = ik.q[0]
        for k in range(1, len(path)):
            q = kin.branch_following(paper, q, ik.theta[k])
            assert np.max(np.abs(angle_diff(q[3:], ik.q[k, 3:]))) < 1e-10


def test_branch_following_is_one_of_the_assembly_modes_and_the_nearest(paper):
    rng = np.random.default_rng(4)
    for pose in random_reachable_poses(rng, paper, 10, margin=0.2):
        ik = kin.inverse_kinematics(paper, pose, on_unreachable="nan")
        q0 = ik.q[int(np.nanargmax(np.abs(ik.S)))]
        theta1 = q0[:3] + rng.normal(scale=0.01, size=3)
        q1 = kin.branch_following(paper, q0, theta1)
        fk = kin.forward_kinematics(paper, theta1)
        dist = np.max(np.abs(angle_diff(fk.q[: fk.count, 3:], q1[3:])), axis=1)
        assert dist.min() < 1e-10
        dist0 = np.max(np.abs(angle_diff(fk.q[: fk.count, 3:], q0[3:])), axis=1)
        assert np.argmin(dist) == np.argmin(dist0)


def test_branch_following_refuses_to_cross_a_gain_type_singularity(paper):
    """March θ towards the fold where two modes merge: following must stop with an error."""
    q, direction = _towards_singularity(paper)
    sign = np.sign(kin.singularity_measure(paper, q))
    theta = q[:3].copy()
    with pytest.raises(BranchFollowingError, match="singularity"):
        for _ in range(5000):
            theta = theta + 1e-3 * direction
            q_new = kin.branch_following(paper, q, theta)
            assert np.max(np.abs(ref.eta(q_new))) < 1e-12
            assert np.sign(kin.singularity_measure(paper, q_new)) == sign
            q = q_new


# ------------------------------------------------------------------ velocity kinematics
def _branch(paper, q):
    return lambda th: kin.branch_following(paper, q, th)


@settings(max_examples=25, deadline=None)
@given(pose=poses)
def test_jacobians_match_central_differences(paper, pose):
    ik = kin.inverse_kinematics(paper, pose, on_unreachable="nan")
    good = np.flatnonzero(np.abs(ik.S) > 0.1)
    assume(good.size)
    q = ik.q[good[0]]
    # Jηq against differences of the independent loop-closure equations
    np.testing.assert_allclose(kin.constraint_jacobian(paper, q), ref.numeric_jacobian(ref.eta, q), atol=1e-8)
    # Jφθ, Jqθ, Jv against differences of the forward kinematics (branch following)
    follow = _branch(paper, q)
    num_q = ref.numeric_jacobian(lambda th: follow(th), q[:3])
    np.testing.assert_allclose(kin.actuated_jacobian(paper, q), num_q, atol=1e-7)
    np.testing.assert_allclose(kin.passive_jacobian(paper, q), num_q[3:], atol=1e-7)
    num_pose = ref.numeric_jacobian(lambda th: ref.pose(follow(th)), q[:3])
    np.testing.assert_allclose(kin.platform_jacobian(paper, q), num_pose, atol=1e-7)
    np.testing.assert_allclose(kin.velocity_jacobian(paper, q), num_pose[:2], atol=1e-7)


@settings(max_examples=25, deadline=None)
@given(pose=poses, seed=st.integers(0, 2**31))
def test_rates_and_accelerations_match_differences_along_a_motion(paper, pose, seed):
    ik = kin.inverse_kinematics(paper, pose, on_unreachable="nan")
    good = np.flatnonzero(np.abs(ik.S) > 0.1)
    assume(good.size)
    q0 = ik.q[good[0]]
    # away from singularities: where a unit actuated rate moves a passive joint at tens of rad/s, the
    # differences' truncation error (∝ the fifth derivative) outgrows the tolerances below
    assume(np.abs(kin.passive_jacobian(paper, q0)).max() < 10)
    rng = np.random.default_rng(seed)
    td, tdd = rng.normal(size=3), rng.normal(size=3)

    def differences(theta_of_t, h):
        """Central first and second differences of q(t), Richardson-extrapolated (O(h⁴))."""
        def at(hh):
            qm, qp = (kin.branch_following(paper, q0, theta_of_t(t)) for t in (-hh, hh))
            return angle_diff(qp, qm) / (2 * hh), (angle_diff(qp, q0) - angle_diff(q0, qm)) / hh**2
        (d1, d2), (e1, e2) = at(h), at(h / 2)
        return (4 * e1 - d1) / 3, (4 * e2 - d2) / 3

    qd_num, qdd_num = differences(lambda t: q0[:3] + td * t + 0.5 * tdd * t * t, 1e-4)
    np.testing.assert_allclose(kin.coordinate_rates(paper, q0, td), qd_num, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(kin.passive_rates(paper, q0, td), qd_num[3:], rtol=1e-6, atol=1e-8)
    # second differences carry ~1e-6 rad/s² of round-off (h = 1e-4): atol 1e-5
    np.testing.assert_allclose(kin.coordinate_accelerations(paper, q0, td, tdd), qdd_num, rtol=1e-5, atol=1e-5)
    # the bias term alone (θ̈ = 0): J̇qθ θ̇
    _qd, bias_num = differences(lambda t: q0[:3] + td * t, 1e-4)
    np.testing.assert_allclose(kin.acceleration_bias(paper, q0, td), bias_num, rtol=1e-5, atol=1e-5)


def test_batched_jacobians_equal_single(paper):
    rng = np.random.default_rng(6)
    ik = kin.inverse_kinematics(paper, random_reachable_poses(rng, paper, 6), mode=(-1, 1, -1),
                                   on_unreachable="nan")
    qs = ik.q[np.isfinite(ik.S) & (np.abs(ik.S) > 0.05)]
    batch = kin.actuated_jacobian(paper, qs)
    for j, q in enumerate(qs):
        np.testing.assert_array_equal(batch[j], kin.actuated_jacobian(paper, q))


# ------------------------------------------------------------------ singularity
@SETTINGS
@given(x=st.floats(0.1, 0.42), y=st.floats(0.05, 0.38), alpha=st.floats(-0.8, 0.8),
       mode=st.sampled_from([tuple(m) for m in WORKING_MODES]))
def test_singularity_measure_matches_eq_19_and_the_determinant(paper, x, y, alpha, mode):
    """At configurations of the machine (the measure refuses any other): eq. (19)'s closed form, and the
    determinant of the constraint Jacobian by finite differences."""
    ik = kin.inverse_kinematics(paper, [x, y, alpha], mode=mode, on_unreachable="nan")
    assume(np.isfinite(ik.S))
    q = ik.q
    s = kin.singularity_measure(paper, q)
    assert s == pytest.approx(ref.S_closed_form(q), abs=1e-12)
    det = np.linalg.det(ref.numeric_jacobian(ref.eta, q)[:, 3:])
    assert s == pytest.approx(-det / (ref.A * ref.R**3), abs=1e-6)
    assert kin.forward_singularity_determinant(paper, q) == pytest.approx(det, abs=1e-9)


def test_singularity_map_values_and_zero_contour(paper):
    smap = pkmlab.singularity_map(pkmlab.load("paper"), alpha=0.0, mode=(1, -1, 1), resolution=41)
    assert smap.S.shape == (41, 41)
    j, i = 20, 20
    ik = kin.inverse_kinematics(paper, [smap.x[i], smap.y[j], 0.0], mode=(1, -1, 1), on_unreachable="nan")
    if np.isfinite(ik.S):
        assert smap.S[j, i] == pytest.approx(ref.S_closed_form(ik.q), abs=1e-12)
    finite = smap.S[np.isfinite(smap.S)]
    assert finite.min() < 0 < finite.max()  # the S = 0 contour crosses this map
    assert np.isnan(smap.S).any() and smap.reachable.sum() > 100
