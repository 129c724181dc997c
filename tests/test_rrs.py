"""The 3-RRS of the catalogue (``examples/mechanisms/3rrs.toml``): cranks on hinges at the base, links on
parallel hinges, spherical joints on a platform that moves in z, roll and pitch.

Independent checks: each leg's closed form against the readable chain of
:func:`~pkmlab.description.spatial.leg_frames` (both roots reach the point, the "knee out" one's elbow farther
from the machine's axis, computed here from the chain); the forward kinematics' 16 complex solutions — the
3-RPS's count, since with its cranks held each spherical joint turns on a circle about a fixed hinge as a
3-RPS's does — and a Newton multistart of 10,000 starts that finds no assembly mode the homotopy did not; rates
against finite differences of the inverse kinematics; the default run's plant on the loop closures at every
sample. MuJoCo's hard-constraint solve of the exported machine is checked with the catalogue's others in
``test_mujoco_export.py``.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from test_lower_mobility import _general, _independent_residual, _multistart

import pkmlab
from pkmlab.description import spatial_legs
from pkmlab.description.files import load_mechanism
from pkmlab.description.mobility import mobility
from pkmlab.description.spatial import SpatialJoint, leg_frames
from pkmlab.model import mechanism_model as mm

RRS = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "3rrs.toml"
POSE = np.array([0.34, 0.05, -0.03])  # z, roll, pitch


@pytest.fixture(scope="module")
def rrs():
    return pkmlab.load(RRS)


def test_the_3rrs_has_mobility_three_each_leg_one_constraint():
    r = mobility(load_mechanism(RRS))
    assert (r.mobility, r.leg_constraints) == (3, (1, 1, 1))


def test_both_roots_of_each_leg_reach_the_point_and_knee_out_is_farther_from_the_axis():
    m = load_mechanism(RRS)
    rng = np.random.default_rng(3)
    # the legs as described, and with each link's hinge axis reversed (the same line, turning the other way)
    flipped = [replace(leg, joints=(leg.joints[0], SpatialJoint("R", False, (tuple(-np.array(leg.joints[1].axes[0])),)),
                                    leg.joints[2])) for leg in m.legs]
    for i, leg in [*enumerate(m.legs), *enumerate(flipped)]:
        a = np.array(leg.joints[0].axes[0])
        # points the leg reaches: its own chain at random crank and link angles
        angles = rng.uniform(-0.6, 0.6, size=(20, 2))
        points = np.array([leg_frames(leg, v)[-1][0] for v in angles])
        assert np.ptp((points - np.array(leg.base)) @ a) < 1e-15  # in the link's plane
        elbows = {}
        for sigma in (1, -1):
            solved = spatial_legs.leg_inverse_kinematics_batch(leg, i, points, sigma)
            assert not solved.bad.any()
            reached = np.array([leg_frames(leg, v)[-1][0] for v in solved.coordinates])
            np.testing.assert_allclose(reached, points, atol=1e-14)
            elbows[sigma] = np.array([leg_frames(leg, v)[1][0] for v in solved.coordinates])  # the crank's tip
        radius = {s: np.linalg.norm(e[:, :2], axis=1) for s, e in elbows.items()}  # the machine's axis is z
        assert np.all(radius[1] > radius[-1])
        # the chain's own angles are one of the two roots
        solved = spatial_legs.leg_inverse_kinematics_batch(leg, i, points, -1)
        np.testing.assert_allclose(np.angle(np.exp(1j * (solved.coordinates - angles))), 0.0, atol=1e-12)


def test_points_the_leg_cannot_reach_are_named_and_skew_hinges_solved_by_the_general_method():
    m = load_mechanism(RRS)
    leg = m.legs[0]
    solved = spatial_legs.leg_inverse_kinematics_batch(leg, 0, np.array([[0.02, 0.15, 0.3], [0.0, 0.3, 0.9]]), 1)
    assert solved.bad.all()
    assert "leg 1 (R*RS) cannot reach the point (0.02, 0.15, 0.3): it is off the plane its link moves" in solved.why(0)
    assert "its link of 0.35 m cannot join the circle of its crank's tip" in solved.why(1)
    # the link's hinge turned out of parallel: its spherical joint no longer moves in a plane but on a surface,
    # which the general method solves (here two branches, the crank's larger angle +1); the chain's own angles
    # are found again at points of it, in one of the two
    skewed = replace(leg, joints=(leg.joints[0], SpatialJoint("R", False, ((-0.8, 0.6, 0.0),)), leg.joints[2]))
    assert not spatial_legs.has_closed_form(skewed) and spatial_legs.working_modes(skewed) == (1, -1)
    angles = np.random.default_rng(5).uniform(-0.8, 0.8, size=(30, 2))
    points = np.array([leg_frames(skewed, v)[-1][0] for v in angles])
    both = [spatial_legs.leg_inverse_kinematics_batch(skewed, 0, points, sigma) for sigma in (1, -1)]
    assert not any(solved.bad.any() for solved in both)
    assert np.all(both[0].coordinates[:, 0] > both[1].coordinates[:, 0])
    for solved in both:
        reached = np.array([leg_frames(skewed, v)[-1][0] for v in solved.coordinates])
        np.testing.assert_allclose(reached, points, atol=1e-14)
    error = np.minimum(*[np.abs(np.angle(np.exp(1j * (solved.coordinates - angles)))).max(axis=1) for solved in both])
    assert error.max() < 1e-12
    off = spatial_legs.leg_inverse_kinematics_batch(skewed, 0, points[:1] + [[0.0, 0.0, 0.01]], 1)
    assert off.bad[0] and off.why(0).startswith("leg 1 (R*RS) cannot reach the point")


def test_inverse_kinematics_of_every_working_mode_closes_the_loops(rrs):
    modes = mm.working_modes(rrs)
    assert len(modes) == 8  # each crank in or out: two roots per leg
    for mode in modes:
        q = mm.inverse_kinematics(rrs, POSE, mode)
        np.testing.assert_allclose(q[-3:], POSE, atol=0)
        assert _independent_residual(rrs.description, q, rrs.coordinates) < 1e-12


def test_rates_against_finite_differences_of_the_inverse_kinematics(rrs):
    q = mm.inverse_kinematics(rrs, POSE, (-1, -1, -1))
    pose_rate = np.array([0.1, -0.3, 0.2])
    h = 1e-6
    plus, minus = (mm.inverse_kinematics(rrs, POSE + s * h * pose_rate, (-1, -1, -1)) for s in (1, -1))
    fd = (plus - minus) / (2 * h)
    q_dot = pkmlab.coordinate_rates(rrs, q, fd[:3])
    np.testing.assert_allclose(q_dot, fd, atol=1e-7)


def test_forward_kinematics_finds_its_sixteen_assembly_modes_and_no_more(rrs):
    from pkmlab.algorithms.general_fk import generic_solutions

    sols, _p, _loops = generic_solutions(rrs.description)
    assert len(sols) == 16
    q = mm.inverse_kinematics(rrs, POSE, (-1, -1, -1))
    found = [c for c, _s in _general(rrs, q[:3])]
    assert any(np.abs(np.angle(np.exp(1j * (c - q)))).max() < 1e-9 for c in found)
    for c in found:
        np.testing.assert_array_equal(c[:3], q[:3])
        assert _independent_residual(rrs.description, c, rrs.coordinates) < 1e-11
    multistart, converged = _multistart(rrs, q[:3], 10_000)
    assert converged > 100 and multistart
    assert all(any(np.abs(np.angle(np.exp(1j * (c - f)))).max() < 1e-7 for f in found) for c in multistart)


def test_the_default_run_is_tracked_on_the_loop_closures(rrs):
    result = pkmlab.simulate(pkmlab.load_scenario(RRS.parent / "3rrs_motion.toml"))
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-5 and summary["max_orientation_error_rad"] < 1e-4
    worst = max(_independent_residual(rrs.description, qk, rrs.coordinates) for qk in result.q[::25])
    assert worst < 1e-10
    assert np.ptp(result.q[:, rrs.coordinates.index("yaw")]) > 1e-6  # the parasitic motion moved

