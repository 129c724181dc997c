"""The compiled rotations of rows (numerics.rotations) against SciPy's rotations, and their inverses by round trips."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pkmlab.description.spatial_legs import rotate, turn_onto, universal_angles
from pkmlab.numerics.rotations import crank_rows

K = 400


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _turned(axis, angle, v):  # SciPy's rotation by the rotation vector axis · angle, an independent formula
    return Rotation.from_rotvec(angle[:, None] * axis).apply(v)


def test_rotate_is_scipys_rotation_of_each_row():
    rng = np.random.default_rng(3)
    axis, angle, v = _unit(rng.normal(size=3)), rng.uniform(-7, 7, K), rng.normal(size=(K, 3))
    assert np.allclose(rotate(axis, angle, v), _turned(axis, angle, v), rtol=0, atol=1e-14)
    # one vector for every row, as the legs' tips are passed
    assert np.allclose(rotate(axis, angle, v[0]), _turned(axis, angle, np.tile(v[0], (K, 1))), rtol=0, atol=1e-14)


def test_turn_onto_finds_the_angle_that_aligns_the_parts_across_the_axis():
    rng = np.random.default_rng(4)
    axis, v, w = _unit(rng.normal(size=3)), rng.normal(size=(K, 3)), rng.normal(size=(K, 3))
    angle = turn_onto(axis, v, w)
    assert np.all(np.abs(angle) <= np.pi)
    across = lambda x: x - (x @ axis)[:, None] * axis  # noqa: E731
    turned, target = _unit(across(_turned(axis, angle, v))), _unit(across(w))
    assert np.allclose(turned, target, rtol=0, atol=1e-12)


@pytest.mark.parametrize("tips", ["one", "per row"])
def test_universal_angles_turn_the_tip_onto_every_reachable_direction(tips):
    rng = np.random.default_rng(5)
    a1 = _unit(rng.normal(size=3))
    a2 = _unit(np.cross(a1, rng.normal(size=3)))  # perpendicular axes
    tip = rng.normal(size=3) if tips == "one" else rng.normal(size=(K, 3))
    rows = np.broadcast_to(tip, (K, 3)).copy()
    q1, q2 = rng.uniform(-np.pi, np.pi, K), rng.uniform(-np.pi / 2, np.pi / 2, K)
    v = _turned(a1, q1, _turned(a2, q2, rows))
    p1, p2, bad = universal_angles((a1, a2), tip, v)
    assert not bad.any()
    assert np.allclose(_turned(a1, p1, _turned(a2, p2, rows)), v, rtol=0, atol=1e-12)
    # of the two roots q2 that reach each direction, the one nearer zero: no farther than the one drawn
    assert np.all(np.abs(p2) <= np.abs(q2) + 1e-9)
    # a direction whose component along a1 is beyond the tip's reach is refused
    far = v + 3.0 * np.linalg.norm(rows, axis=1)[:, None] * a1
    assert universal_angles((a1, a2), tip, far)[2].all()


@pytest.mark.parametrize("sigma", [1, -1])
def test_the_crank_takes_the_root_of_its_working_mode(sigma):
    """A crank's two roots of ``α cos θ + β sin θ = γ`` (its tip on a sphere about a point): each tip the crank's turn
    of its arm (SciPy's rotation), on the sphere; the knee out (``σ = +1``) the root farther from the central line,
    ``σ = -1`` the nearer; out of reach (|ratio| > 1) the nearest angle, NaN kept."""
    rng = np.random.default_rng(6)
    axis, across = _unit(rng.normal(size=3)), rng.normal(size=3)
    across -= (across @ axis) * axis  # the arm's part across its axis
    start = rng.normal(size=3)
    centre, sphere = rng.normal(size=(K, 3)), rng.uniform(0.5, 2.0, K)
    d = centre - start  # |d - Rot(axis, θ) across| = sphere: α cos θ + β sin θ = γ
    alpha, beta = d @ across, d @ np.cross(axis, across)
    ratio = (np.einsum("ki,ki->k", d, d) + across @ across - sphere**2) / 2 / np.hypot(alpha, beta)
    ratio[:3] = [1.5, -1.5, np.nan]
    point, direction = rng.normal(size=3), _unit(rng.normal(size=3))
    theta, elbow = np.empty(K), np.empty((K, 3))
    crank_rows(axis, start, across, alpha, beta, ratio, sigma, point, direction, False, theta, elbow)
    reach = np.abs(ratio) <= 1
    assert np.isnan(theta[2]) and np.isnan(elbow[2]).all()
    # out of reach, the nearest angle: the double root of ratio ±1, atan2(β, α) and the opposite direction
    nearest = np.arctan2(beta[:2], alpha[:2]) + np.array([0.0, np.pi])
    assert np.allclose(np.angle(np.exp(1j * (theta[:2] - nearest))), 0.0, atol=1e-12)
    assert np.all(np.abs(theta[:2]) <= np.pi)
    solved = ~np.isnan(theta)
    tips = start + _turned(axis, theta[solved], np.tile(across, (solved.sum(), 1)))
    assert np.allclose(elbow[solved], tips, rtol=0, atol=1e-13)
    assert np.allclose(np.linalg.norm(elbow - centre, axis=1)[reach], sphere[reach], rtol=0, atol=1e-12)
    # the other root: the same sphere, the other side of the central line's distance
    root = np.arctan2(beta, alpha)
    other = 2 * root - theta  # the roots are symmetric about atan2(β, α)
    other_tip = start + _turned(axis, other, np.tile(across, (K, 1)))
    off = lambda x: np.linalg.norm((x - point) - np.outer((x - point) @ direction, direction), axis=1)  # noqa: E731
    farther = off(elbow) >= off(other_tip) - 1e-12
    assert np.all(farther[reach] if sigma > 0 else ~farther[reach] | np.isclose(off(elbow), off(other_tip))[reach])
    # by the side: the first root for +1, the second for -1, whatever the distances
    crank_rows(axis, start, across, alpha, beta, ratio, sigma, point, direction, True, theta, elbow)
    half = np.arccos(np.clip(ratio, -1, 1))
    assert np.allclose(np.angle(np.exp(1j * (theta - root - sigma * half)))[reach], 0.0, atol=1e-12)
