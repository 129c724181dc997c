"""Legs that end in a universal joint under a rigid platform: the 3-UPU wrist of the catalogue
(``examples/mechanisms/3upu_wrist.toml``).

Each such joint closes its loop by its centre (3 rows) and by its two axes kept perpendicular (one orientation
row, :mod:`pkmlab.description.mobility`). Independent checks: the platform turns about the wrist's centre (the
geometry of its axes, not anything pkmlab was told); each platform joint's angles turn its leg's last body
onto the platform (rotations composed with the readable chain of :mod:`pkmlab.description.spatial`); the
generated kernels' closures equal the description layer's numeric ones, and their Jacobian finite differences;
the dynamics against MuJoCo's hard-constraint solve is in ``test_mujoco_export.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_lower_mobility import _independent_residual

import pkmlab
from pkmlab.description import mobility as mob
from pkmlab.description.spatial import axis_rotation, full_poses, leg_frames, orientation
from pkmlab.model import mechanism_model as mm

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
WRIST = EXAMPLES / "3upu_wrist.toml"
CENTRE = np.array([0.0, 0.0, 0.5])


@pytest.fixture(scope="module")
def wrist():
    return pkmlab.load(WRIST)


def _poses(count: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-0.3, 0.3, (count, 3))


def test_its_closures_are_independent_and_its_mobility_three(wrist):
    result = mob.mobility(wrist.description)
    # 3 legs of 3 joint coordinates and a whole pose: 15 coordinates; 3 point rows and 1 orientation row per leg
    assert (result.coordinates, result.constraints, result.rank, result.mobility) == (15, 12, 12, 3)
    assert result.leg_constraints == (1, 1, 1)
    assert wrist.kernels.N_CONSTRAINTS == 12 and wrist.kernels.POINT_ROWS == 9


def test_the_platform_turns_about_the_wrists_centre(wrist):
    m = wrist.description
    for pose in _poses(6, 1):
        q = mm.inverse_kinematics(wrist, pose, ())
        whole = full_poses(m, q[-6:])
        np.testing.assert_allclose(whole[3:], pose, atol=0)
        np.testing.assert_allclose(whole[:3], CENTRE, atol=1e-12)  # x, y, z parasitic: held at the centre
        assert _independent_residual(m, q, wrist.coordinates) < 1e-12
        # each platform joint's two angles turn its leg's last body onto the platform's orientation
        angles = mm.platform_joint_angles(wrist, q)
        for i, (leg, values) in enumerate(zip(m.legs, mm.leg_joint_values(wrist, q), strict=True)):
            a1, a2 = leg.joints[-1].axes
            turned = leg_frames(leg, values)[-1][1] @ axis_rotation(a1, angles[2 * i]) @ axis_rotation(
                a2, angles[2 * i + 1])
            assert np.abs(turned - orientation(*pose)).max() < 1e-12


def _whole_x(model, q) -> np.ndarray:
    """The description layer's coordinates of ``q``: legs' joint coordinates leg by leg, then the whole pose."""
    m = model.description
    return np.concatenate([*map(np.array, mm.leg_joint_values(model, q)), full_poses(m, q[-6:])])


def test_the_generated_closures_are_the_descriptions_and_their_jacobian_their_derivative(wrist):
    """Off the closures too: the SymPy-generated kernels against the description layer's chain, row by row
    (both order the point rows first); the kernels' Jacobian against central differences."""
    rng = np.random.default_rng(2)
    for pose in _poses(3, 3):
        q = mm.inverse_kinematics(wrist, pose, ()) + rng.normal(0.0, 0.02, 15)
        eta = mm.constraint_residual(wrist, q)
        assert np.abs(eta).max() > 1e-3
        x = _whole_x(wrist, q)
        np.testing.assert_allclose(eta, mob.residual(wrist.description, x), atol=1e-14)
        # the batch of orientation rows inverse kinematics checks: the same rows
        np.testing.assert_allclose(mob.orientation_residuals(wrist.description, x[None])[0], eta[9:], atol=1e-14)
        jac, h = mm.constraint_jacobian(wrist, q), 1e-6
        numeric = np.column_stack([(mm.constraint_residual(wrist, q + h * e) - mm.constraint_residual(wrist, q - h * e))
                                   / (2 * h) for e in np.eye(15)])
        np.testing.assert_allclose(jac, numeric, atol=1e-8)


def test_its_run_tracks_the_orientation_with_the_centre_held(wrist):

    result = pkmlab.simulate(pkmlab.load_scenario(EXAMPLES / "3upu_wrist_motion.toml"))
    # within the time law's discretisation at a 1 ms sample (the 3-PRS's run: a few 1e-5)
    assert 0 < result.orientation_error.max() < 1e-4
    np.testing.assert_allclose(result.q[:, 9:12], np.broadcast_to(CENTRE, (len(result.q), 3)), atol=1e-10)
    assert max(_independent_residual(wrist.description, q, wrist.coordinates) for q in result.q[::50]) < 1e-10
