"""The compiled rotations of rows (numerics.rotations) against SciPy's rotations, and their inverses by round trips."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pkmlab.description.spatial_legs import rotate, turn_onto, universal_angles

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
