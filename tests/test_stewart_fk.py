"""Forward kinematics of the general Stewart–Gough platform by homotopy continuation
(:mod:`pkmlab.algorithms.stewart_fk`): the soma-coordinate quadrics, Dietmaier's 40 real postures,
known poses of random platforms, and refused input."""

import warnings

import numpy as np
import pytest

from pkmlab.algorithms import stewart_fk
from pkmlab.algorithms.stewart_fk import assembly_modes
from pkmlab.errors import IncompleteSolutionWarning, InvalidParameterError

# Dietmaier's platform with 40 real postures: P. Dietmaier, "The Stewart-Gough platform of general
# geometry can have 40 real postures", Advances in Robot Kinematics: Analysis and Control (Lenarčič,
# Husty eds.), Kluwer, 1998. The numbers are the paper's as reproduced in PHCpack's demonstration
# system `stewgou40` (github.com/janverschelde/PHCpack, file src/Demo/stewgou40), which lists the
# 40 real solutions. There the base points are called a_i (a_1 at the origin, zeros omitted), the
# platform points b_i (b_1 at the platform's origin) and leg 1 has length L1 = 1; here the base
# points are b_i and the platform points a_i, as in assembly_modes.
DIETMAIER_BASE = np.array([
    [0.0, 0.0, 0.0],
    [1.107915, 0.0, 0.0],
    [0.549094, 0.756063, 0.0],
    [0.735077, -0.223935, 0.525991],
    [0.514188, -0.526063, -0.368418],
    [0.590473, 0.094733, -0.205018],
])
DIETMAIER_PLATFORM = np.array([
    [0.0, 0.0, 0.0],
    [0.542805, 0.0, 0.0],
    [0.956919, -0.528915, 0.0],
    [0.665885, -0.353482, 1.402538],
    [0.478359, 1.158742, 0.107672],
    [-0.137087, -0.235121, 0.353913],
])
DIETMAIER_LENGTHS = np.array([1.0, 0.645275, 1.086284, 1.503439, 1.281933, 0.771071])
# Three of PHCpack's listed solutions (nos. 2, 12 and 39, well conditioned): the platform origin
# p = n and the first two columns (a1, a2) of R, R = [a1, a2, a1 × a2].
DIETMAIER_SOLUTIONS = [
    ([0.863325713770891, 0.00564402867997359, -0.504615553547690],
     [0.191288333012351, 0.943756501770663, 0.269689523376340],
     [-0.727039337601767, -0.0483533608080227, 0.684891052707037]),
    ([0.636111780656805, 0.771451960369755, 0.0149557798623220],
     [0.403995111057654, -0.570369249047288, -0.715169119847010],
     [0.546802941037561, -0.476187161523352, 0.688659807795552]),
    ([0.489122174358057, 0.696229957966802, -0.525379238437142],
     [0.777174054077347, -0.215031454973226, 0.591406766144148],
     [-0.628581348446903, -0.220815627982680, 0.745738524432853]),
]


def random_rotation(rng) -> np.ndarray:
    q = rng.standard_normal(4)
    return stewart_fk.rotation_of_quaternion(q)


def leg_errors(base, platform, lengths, R, p) -> np.ndarray:
    return np.abs(np.linalg.norm(p + platform @ R.T - base, axis=1) - lengths)


def machine_size(base, platform, lengths) -> float:
    return max(np.linalg.norm(base - base.mean(axis=0), axis=1).max(),
               np.linalg.norm(platform - platform.mean(axis=0), axis=1).max(), np.max(lengths))


def pose_distance(R1, p1, R2, p2) -> float:
    return float(np.abs(R1 - R2).max() + np.abs(p1 - p2).max())


def solve_quietly(*args, **kwargs):
    """assembly_modes, with an IncompleteSolutionWarning turned into a failure."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", IncompleteSolutionWarning)
        return assembly_modes(*args, **kwargs)


def assert_valid(modes, base, platform, lengths):
    size = machine_size(base, platform, lengths)
    for R, p in modes:
        assert R.shape == (3, 3) and p.shape == (3,)
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
        assert leg_errors(base, platform, lengths, R, p).max() < 1e-10 * size
    for i in range(len(modes)):
        for j in range(i):
            assert pose_distance(*modes[i], *modes[j]) > 1e-6, (i, j)


# --------------------------------------------------------------------------- the formulation


def test_quadrics_are_the_leg_equations_times_e_squared():
    """x^T Q_i x = |e|² (|p + R a_i - b_i|² - rho_i²) and e·g = 0 at the soma coordinates of random poses,
    for random geometry and any scale of x (homogeneous coordinates)."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        base, platform = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
        lengths = rng.uniform(0.5, 2.0, 6)
        Q = stewart_fk._quadrics(base, platform, lengths)
        assert Q.shape == (7, 8, 8)
        np.testing.assert_array_equal(Q, np.swapaxes(Q, 1, 2))
        R, p = random_rotation(rng), rng.normal(size=3)
        x = stewart_fk._study_of(R, p)
        assert np.linalg.norm(x[:4]) == pytest.approx(1.0)
        scale = rng.uniform(-3, 3)
        values = np.einsum("kij,i,j->k", Q, scale * x, scale * x)
        legs = np.sum((p + platform @ R.T - base) ** 2, axis=1) - lengths**2
        np.testing.assert_allclose(values[:6], scale**2 * legs, rtol=0, atol=1e-12 * (1 + np.abs(legs).max()))
        assert abs(values[6]) < 1e-12
        # the pose comes back from its soma coordinates, whatever their scale and sign
        R2, p2 = stewart_fk._pose_of(scale * x)
        np.testing.assert_allclose(R2, R, atol=1e-12)
        np.testing.assert_allclose(p2, p, atol=1e-12)


def test_quadrics_off_the_study_quadric():
    """Q_6 is the Study quadric e·g; a point of it with e ≠ 0 is a pose, at which the leg quadrics are the
    leg equations times |e|² (here |e| ≠ 1)."""
    rng = np.random.default_rng(8)
    base, platform, lengths = rng.normal(size=(6, 3)), rng.normal(size=(6, 3)), rng.uniform(0.5, 2.0, 6)
    Q = stewart_fk._quadrics(base, platform, lengths)
    for _ in range(10):
        x = rng.normal(size=8)
        assert x[:4] @ x[4:] == pytest.approx(x @ Q[6] @ x)
        # project onto the Study quadric along g, keeping e: the leg quadrics then match the pose
        e, g = x[:4], x[4:]
        g = g - (e @ g) / (e @ e) * e
        y = np.concatenate((e, g))
        R, p = stewart_fk._pose_of(y)
        legs = np.sum((p + platform @ R.T - base) ** 2, axis=1) - lengths**2
        np.testing.assert_allclose(np.einsum("kij,i,j->k", Q[:6], y, y), (e @ e) * legs, atol=1e-11)


def test_polish_converges_quadratically_to_a_pose():
    rng = np.random.default_rng(9)
    base, platform = rng.normal(size=(6, 3)), 0.6 * rng.normal(size=(6, 3))
    R0, p0 = random_rotation(rng), np.array([0.2, 0.1, 1.5])
    lengths = np.linalg.norm(p0 + platform @ R0.T - base, axis=1)
    R, p = R0 @ stewart_fk._expm_so3(np.array([0.02, -0.01, 0.03])), p0 + 0.02
    errors = [leg_errors(base, platform, lengths, R, p).max()]
    for _ in range(4):  # one Newton step each
        R, p, err = stewart_fk._polish(base, platform, lengths, R, p, iterations=1)
        errors.append(err)
    assert errors[0] > 1e-2
    for before, after in zip(errors[:-1], errors[1:], strict=True):
        assert after < max(100 * before**2, 1e-15)
    assert pose_distance(R, p, R0, p0) < 1e-12


# --------------------------------------------------------------------------- Dietmaier's example


@pytest.fixture(scope="module")
def dietmaier_modes():
    return solve_quietly(DIETMAIER_BASE, DIETMAIER_PLATFORM, DIETMAIER_LENGTHS)


def test_dietmaier_has_40_real_postures(dietmaier_modes):
    assert len(dietmaier_modes) == 40
    assert_valid(dietmaier_modes, DIETMAIER_BASE, DIETMAIER_PLATFORM, DIETMAIER_LENGTHS)


def test_dietmaier_postures_match_published_solutions(dietmaier_modes):
    # PHCpack's polynomial system has rounded (10-digit) coefficients: agreement to about 1e-8
    for n, a1, a2 in DIETMAIER_SOLUTIONS:
        a1, a2 = np.array(a1), np.array(a2)
        R0, p0 = np.column_stack((a1, a2, np.cross(a1, a2))), np.array(n)
        assert min(pose_distance(R, p, R0, p0) for R, p in dietmaier_modes) < 1e-6


def test_dietmaier_in_other_units_and_frames(dietmaier_modes):
    """Millimetres, a base frame moved away and a platform frame moved: the same 40 postures."""
    rng = np.random.default_rng(3)
    Rb, ob = random_rotation(rng), np.array([250.0, -1200.0, 40.0])
    oa = np.array([-30.0, 55.0, 500.0])
    base = 1000 * DIETMAIER_BASE @ Rb.T + ob  # world point = Rb (1000 b) + ob
    platform = 1000 * DIETMAIER_PLATFORM + oa  # new platform frame: its origin moved by -oa
    lengths = 1000 * DIETMAIER_LENGTHS
    modes = solve_quietly(base, platform, lengths, seed=5)
    assert len(modes) == 40
    assert_valid(modes, base, platform, lengths)
    for R, p in dietmaier_modes:  # each posture, expressed in the new frames, is found
        R1, p1 = Rb @ R, Rb @ (1000 * p) + ob - Rb @ R @ oa
        assert min(pose_distance(R2, p2 / 1000, R1, p1 / 1000) for R2, p2 in modes) < 1e-8


def test_deterministic_for_a_seed(dietmaier_modes):
    again = assembly_modes(DIETMAIER_BASE, DIETMAIER_PLATFORM, DIETMAIER_LENGTHS, seed=0)
    assert len(again) == len(dietmaier_modes)
    for (R1, p1), (R2, p2) in zip(again, dietmaier_modes, strict=True):
        np.testing.assert_array_equal(R1, R2)
        np.testing.assert_array_equal(p1, p2)


# --------------------------------------------------------------------------- random platforms


@pytest.mark.parametrize("k", range(5))
def test_random_platform_known_pose_is_found(k):
    rng = np.random.default_rng(100 + k)
    base = rng.normal(size=(6, 3)) * [1.0, 1.0, 0.3]
    platform = 0.5 * rng.normal(size=(6, 3)) * [1.0, 1.0, 0.3]
    R0 = random_rotation(rng)
    p0 = np.array([0, 0, 1.2]) + 0.3 * rng.normal(size=3)
    lengths = np.linalg.norm(p0 + platform @ R0.T - base, axis=1)
    modes = solve_quietly(base, platform, lengths, seed=k)
    assert 1 <= len(modes) <= 40
    assert len(modes) % 2 == 0  # 40 complex solutions, the non-real ones in conjugate pairs
    assert_valid(modes, base, platform, lengths)
    assert min(pose_distance(R, p, R0, p0) for R, p in modes) < 1e-9


def test_planar_platform_finds_pose_and_its_mirror_image():
    """Planar base and platform (in z = 0): the reflection in the base plane of a pose is a pose."""
    b, a = np.deg2rad([0, 100, 120, 220, 240, 340]), np.deg2rad([40, 80, 160, 200, 280, 320])
    base = np.c_[np.cos(b), np.sin(b), np.zeros(6)]
    platform = 0.5 * np.c_[np.cos(a), np.sin(a), np.zeros(6)]
    R0, p0 = stewart_fk.rotation_of_quaternion([0.9, 0.1, -0.2, 0.3]), np.array([0.1, -0.05, 0.8])
    lengths = np.linalg.norm(p0 + platform @ R0.T - base, axis=1)
    modes = solve_quietly(base, platform, lengths)
    assert_valid(modes, base, platform, lengths)
    M = np.diag([1.0, 1.0, -1.0])
    for R, p in [(R0, p0), (M @ R0 @ M, M @ p0)]:
        assert min(pose_distance(R2, p2, R, p) for R2, p2 in modes) < 1e-9


def test_legs_too_short_to_assemble():
    rng = np.random.default_rng(4)
    base, platform = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    assert solve_quietly(base, platform, np.full(6, 1e-3)) == []


def test_architecturally_singular_platform_warns():
    """Similar planar hexagons (platform = rotated, scaled base): every pose is singular and the poses form
    curves, not the 40 points the method counts on; it must say that it cannot vouch for the result."""
    b = np.deg2rad([0, 100, 120, 220, 240, 340])
    base = np.c_[np.cos(b), np.sin(b), np.zeros(6)]
    platform = 0.5 * np.c_[np.cos(b + 1), np.sin(b + 1), np.zeros(6)]
    lengths = np.linalg.norm([0.1, -0.05, 0.8] + platform - base, axis=1)
    with pytest.warns(IncompleteSolutionWarning, match="may be missing"):
        modes = assembly_modes(base, platform, lengths)
    assert_valid(modes, base, platform, lengths)


# --------------------------------------------------------------------------- refused input


@pytest.mark.parametrize("base, platform, lengths, seed, match", [
    (np.zeros((5, 3)), np.zeros((6, 3)), np.ones(6), 0, "base"),
    (np.zeros((6, 3)), np.zeros((6, 2)), np.ones(6), 0, "platform"),
    (np.zeros((6, 3)), np.zeros(18), np.ones(6), 0, "platform"),
    (np.zeros((6, 3)), np.zeros((6, 3)), np.ones(5), 0, "lengths"),
    (np.zeros((6, 3)), np.zeros((6, 3)), np.ones((6, 1)), 0, "lengths"),
    (np.full((6, 3), np.nan), np.zeros((6, 3)), np.ones(6), 0, "finite"),
    (np.zeros((6, 3)), np.full((6, 3), np.inf), np.ones(6), 0, "finite"),
    (np.zeros((6, 3)), np.zeros((6, 3)), [1, 1, 1, 1, 1, np.nan], 0, "positive"),
    (np.zeros((6, 3)), np.zeros((6, 3)), [1, 1, 1, 1, 1, np.inf], 0, "positive"),
    (np.zeros((6, 3)), np.zeros((6, 3)), [1, 1, 1, 1, 1, 0], 0, "positive"),
    (np.zeros((6, 3)), np.zeros((6, 3)), [1, 1, 1, -1, 1, 1], 0, "positive"),
    ("points", np.zeros((6, 3)), np.ones(6), 0, "base"),
    (np.zeros((6, 3)), [[1, 2, 3]] * 5 + [[1, 2]], np.ones(6), 0, "platform"),
    (np.zeros((6, 3)), np.zeros((6, 3)), None, 0, "lengths"),
    (np.zeros((6, 3)), np.zeros((6, 3)), np.ones(6), 1.5, "seed"),
    (np.zeros((6, 3)), np.zeros((6, 3)), np.ones(6), True, "seed"),
    (np.zeros((6, 3)), np.zeros((6, 3)), np.ones(6), -1, "seed"),
])
def test_bad_input_is_refused(base, platform, lengths, seed, match):
    with pytest.raises(InvalidParameterError, match=match):
        assembly_modes(base, platform, lengths, seed=seed)


def test_the_fast_path_and_the_general_method_find_dietmaiers_forty_postures_alike():
    """The 128-path soma-coordinate homotopy (the fast path) and the general method's parameter homotopy of 40 paths
    on another polynomial system (the Cayley parameters of the rotation, the legs' spheres) give the same 40 real
    configurations of the description file of Dietmaier's platform, and both close its loops."""
    from pathlib import Path

    import pkmlab
    from pkmlab.algorithms.assembly import assembly_modes as machine_assembly_modes
    from pkmlab.algorithms.assembly import general_spatial_assembly_modes

    model = pkmlab.load(Path(__file__).resolve().parents[1] / "examples" / "stewart_dietmaier.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("error", IncompleteSolutionWarning)
        fast = [q for q, _s in machine_assembly_modes(model, DIETMAIER_LENGTHS)]
        general = [q for q, _s in general_spatial_assembly_modes(model, DIETMAIER_LENGTHS)]
    assert len(fast) == len(general) == 40
    for q in general:
        assert np.abs(pkmlab.constraint_residual(model, q)).max() < 1e-11
        gaps = [np.abs(np.angle(np.exp(1j * (q - f)))).max() for f in fast]
        assert min(gaps) < 1e-8


def test_the_general_methods_generic_instance_holds_every_solution_other_seeds_find():
    """Monodromy's stopping rule can stop short (the Stewart preset's instance from some seeds has 22 or 26 of its
    solutions): the general method merges two seeds' instances. Independent instances from three other seeds,
    carried to its parameters by a parameter homotopy, find no solution it lacks, and together find all of it."""
    import pkmlab
    from pkmlab.algorithms import general_fk
    from pkmlab.numerics import homotopy

    description = pkmlab.load("stewart").description
    family, n, m, _layout, _names = general_fk._family(description)
    solutions, p1, _loops = general_fk.solve_generic_instance(description)
    found = []
    for seed in (3, 4, 5):
        other, p2, _ = homotopy.generic_instance(family, n, m, np.random.default_rng(seed))
        ends = homotopy.parameter_homotopy(family, other, p2, p1)
        found.append(ends.x[ends.regular])
    union = homotopy.distinct(np.vstack(found), family.scale)
    for x in union:
        assert np.linalg.norm(solutions - x, axis=1).min() < 1e-7 * family.scale
    assert len(union) == len(solutions)
