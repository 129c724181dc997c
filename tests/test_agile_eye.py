"""An overconstrained machine: the Agile Eye of the catalogue (``examples/mechanisms/agile_eye.toml``), a spherical
3-RRR whose legs end in revolute joints at the platform.

Its 15 loop-closure rows (3 point rows and 2 orientation rows per leg) have rank 9 at every configuration; the
model keeps the 9 point rows and checks that the others hold (:mod:`pkmlab.description.mobility`). Independent
checks: the platform turns about the centre where every axis meets (the geometry, not anything pkmlab was told);
each platform joint's axis is the same line in the leg's last body and in the platform (rotations composed with
the readable chain of :mod:`pkmlab.description.spatial`); the forward kinematics' count against the literature's
(8 assembly modes, Bonev, Chablat and Wenger 2006) and a Newton multistart (``test_catalogue_fk.py``); the
dynamics against MuJoCo's hard-constraint solve (``test_mujoco_export.py``).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from test_lower_mobility import _independent_residual

import pkmlab
from pkmlab.description import mobility as mob
from pkmlab.description.files import load_mechanism
from pkmlab.description.spatial import SpatialJoint, SpatialMechanism, full_poses, leg_frames, orientation
from pkmlab.errors import InvalidParameterError
from pkmlab.model import mechanism_model as mm

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
EYE = CATALOGUE / "agile_eye.toml"


@pytest.fixture(scope="module")
def eye():
    return pkmlab.load(EYE)


def _poses(count: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-0.4, 0.4, (count, 3))


def _axes_agree(model, q) -> float:
    """max over the legs of |R_leg a - R a|: each platform joint's axis, carried by the leg's last body and by the
    platform, is one line."""
    m = model.description
    rot = orientation(*full_poses(m, q[-6:])[3:])
    worst = 0.0
    for leg, values in zip(m.legs, mm.leg_joint_values(model, q), strict=True):
        a = np.array(leg.joints[-1].axes[0])
        worst = max(worst, float(np.abs(leg_frames(leg, values)[-1][1] @ a - rot @ a).max()))
    return worst


def test_its_closures_are_dependent_and_the_model_keeps_its_point_rows(eye):
    result = mob.mobility(eye.description)
    assert (result.coordinates, result.constraints, result.rank, result.mobility) == (12, 15, 9, 3)
    assert result.kept == tuple(range(9)) and mob.orientation_rows(eye.description) == ()
    assert eye.kernels.N_CONSTRAINTS == 9


def test_the_platform_turns_about_the_centre_in_every_working_mode(eye):
    m = eye.description
    modes = mm.working_modes(eye)
    assert len(modes) == 8
    assert mm.platform_joint_angles(eye, mm.inverse_kinematics(eye, [0.0, 0.0, 0.0], modes[0])).shape == (0,)
    for pose in _poses(2, 1):
        for mode in modes:
            q = mm.inverse_kinematics(eye, pose, mode)
            whole = full_poses(m, q[-6:])
            np.testing.assert_allclose(whole[3:], pose, atol=0)
            np.testing.assert_allclose(whole[:3], 0.0, atol=1e-12)  # x, y, z parasitic: the centre
            assert _independent_residual(m, q, eye.coordinates) < 1e-12
            assert _axes_agree(eye, q) < 1e-12 and np.abs(mm.set_aside_residual(eye, q)).max() < 1e-12
    # off the closures, the batch of orientation rows inverse kinematics checks is the description's residual's
    x = np.concatenate([*map(np.array, mm.leg_joint_values(eye, q)), full_poses(m, q[-6:])]) + 0.05
    np.testing.assert_allclose(mob.orientation_residuals(m, x[None])[0], mob.residual(m, x)[9:], atol=1e-14)
    assert np.abs(mob.residual(m, x)[9:]).max() > 1e-3


def test_forward_kinematics_gives_its_eight_assembly_modes_each_about_the_centre(eye):
    for pose in _poses(3, 2):
        q = mm.inverse_kinematics(eye, pose, mm.working_modes(eye)[0])
        found = pkmlab.forward_kinematics(eye, q[:3])
        assert found.count == 8
        assert np.abs(found.q[:, -6:-3]).max() < 1e-12  # every one turns about the centre
        assert max(_axes_agree(eye, qk) for qk in found.q) < 1e-10
        assert np.abs(np.angle(np.exp(1j * (found.q[:, -3:] - pose)))).max(axis=1).min() < 1e-10


def test_a_platform_joint_whose_axis_misses_the_centre_is_refused_with_the_computed_mobility():
    m = load_mechanism(EYE)
    leg = m.legs[0]
    tilted = np.array(leg.joints[-1].axes[0]) + [0.0, 0.2, 0.0]
    leg = replace(leg, joints=(*leg.joints[:-1], SpatialJoint("R", False, (tuple(tilted / np.linalg.norm(tilted)),))))
    with pytest.raises(InvalidParameterError, match=r"^Agile Eye: its computed mobility is 2, not the 3 of its "
                                                    r"controlled pose \(roll, pitch, yaw\)") as refused:
        mob.mobility(SpatialMechanism(m.name, (leg, *m.legs[1:]), m.platform, m.gravity))
    assert "\n" not in str(refused.value)


def test_a_leg_ending_in_a_revolute_joint_needs_a_rigid_platform():
    from pkmlab.description.spatial import SpatialPlatform

    m = load_mechanism(EYE)
    p = m.platform
    with pytest.raises(InvalidParameterError, match=r"leg 1 \(R\*RR\) ends in a revolute joint, which carries a "
                                                    "rigid platform only"):
        SpatialMechanism(m.name, m.legs, SpatialPlatform("translating", p.attachments, p.mass, p.com, p.inertia),
                         m.gravity)


def test_its_run_tracks_the_orientation_about_the_centre_to_the_samplings_first_order(eye):
    """The orientation error of a sampled-data run is the effort held over each sample: it halves with the sample
    time (0.11 mrad at 1 ms)."""
    scenario = pkmlab.load_scenario(CATALOGUE / "agile_eye_motion.toml")
    result = pkmlab.simulate(scenario)
    finer = pkmlab.simulate(scenario.replace(sample_time=scenario.sample_time / 2))
    ratio = result.orientation_error.max() / finer.orientation_error.max()
    assert result.orientation_error.max() < 2e-4 and 1.8 < ratio < 2.2
    np.testing.assert_allclose(result.q[:, 6:9], 0.0, atol=1e-10)  # x, y, z
    assert max(_axes_agree(eye, q) for q in result.q[::50]) < 1e-10
    import matplotlib

    matplotlib.use("Agg")
    from pkmlab.views.plotting import plot_path_3d

    ax = plot_path_3d(result)  # its path is in the angles it controls, labelled so
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()) == ("roll (rad)", "pitch (rad)", "yaw (rad)")


def test_a_run_without_a_tracked_position_animates_and_calibration_is_refused(eye, tmp_path, capsys):
    from pkmlab.algorithms.calibration import geometric_parameters
    from pkmlab.cli import main

    with pytest.raises(InvalidParameterError, match=r"^Agile Eye: its platform is carried by universal or revolute "
                                                    "joints whose axes its motion needs as they are"):
        geometric_parameters(eye)
    assert main(["simulate", str(CATALOGUE / "agile_eye_motion.toml"), "--out", str(tmp_path / "run"),
                 "--no-figures"]) == 0
    capsys.readouterr()
    # its run records roll, pitch, yaw only: the animation draws the machine rebuilt from its actuators
    assert main(["animate", str(tmp_path / "run"), "--out", str(tmp_path / "eye.gif"), "--stride", "450"]) == 0
    assert "3 frames" in capsys.readouterr().out and (tmp_path / "eye.gif").stat().st_size > 0
