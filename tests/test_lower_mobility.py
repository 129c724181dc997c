"""Spatial machines of any S-ended legs and of lower mobility: the computed mobility, the refusals it makes
possible, and the 3-PRS of the catalogue (parasitic motions, every working mode, a tracking run).

Independent checks: the mobility against the machines' known mobility (the Delta 3, the Stewart platform 6,
a 3-PRS 3 with each leg removing one freedom — the count a textbook gives); the configurations against the
chain of :func:`~pkmlab.description.spatial.leg_frames` and the rotation of
:func:`~pkmlab.description.spatial.orientation` (not the generated kernels); rates against finite
differences of the inverse kinematics.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.description.files import load_mechanism
from pkmlab.description.mobility import mobility
from pkmlab.description.presets import preset
from pkmlab.description.spatial import (
    SpatialMechanism,
    SpatialPlatform,
    attachment_point,
    full_poses,
    leg_frames,
)
from pkmlab.errors import InvalidParameterError
from pkmlab.model import mechanism_model as mm

PRS = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "3prs.toml"
POSE = np.array([0.45, 0.05, -0.03])  # z, roll, pitch


@pytest.fixture(scope="module")
def prs():
    return pkmlab.load(PRS)


def test_computed_mobility_of_known_machines():
    assert mobility(preset("delta")).mobility == 3
    assert mobility(preset("stewart")).mobility == 6
    r = mobility(load_mechanism(PRS))
    assert (r.mobility, r.rank, r.coordinates) == (3, 9, 12)
    assert r.leg_constraints == (1, 1, 1)  # a P-R-S leg leaves its spherical joint a surface: one constraint


def _three_ups(kind: str, controlled=None) -> SpatialMechanism:
    stewart = preset("stewart")
    p = stewart.platform
    return SpatialMechanism("3-UPS", stewart.legs[:3], SpatialPlatform(kind, p.attachments[:3], p.mass, p.com,
                                                                        p.inertia, controlled), stewart.gravity)


def test_three_ups_on_a_translating_platform_is_refused_with_its_mobility():
    """Three UP*S legs leave the platform six freedoms: held level by nothing, it is not a translating machine
    (it was accepted, simulated and exported before the mobility was computed)."""
    with pytest.raises(InvalidParameterError, match=r"computed mobility is 6 .*not 3") as error:
        pkmlab.load(_three_ups("translating"))
    assert "leg 1 (UP*S)" in str(error.value) and "\n" not in str(error.value)


def test_under_actuated_rigid_platform_is_refused():
    with pytest.raises(InvalidParameterError, match=r"computed mobility is 6, not the 3 of its controlled pose"):
        pkmlab.load(_three_ups("rigid", ("x", "y", "z")))


def test_controlled_coordinates_are_named_and_checked():
    with pytest.raises(InvalidParameterError,
                       match=r"on 3 legs moves in at most 3 of its pose's coordinates: name them"):
        _three_ups("rigid")
    with pytest.raises(InvalidParameterError, match=r"unknown name 'rol'.*roll"):
        _three_ups("rigid", ("z", "rol", "pitch"))
    with pytest.raises(InvalidParameterError, match=r"name one twice"):
        _three_ups("rigid", ("z", "z", "pitch"))


def test_controlled_coordinates_must_determine_the_pose():
    """A 3-PRS controlled in x, y, z: its sliders move the platform's height and tilt, not its x and y alone."""
    m = load_mechanism(PRS)
    p = m.platform
    wrong = SpatialMechanism(m.name, m.legs, SpatialPlatform(p.kind, p.attachments, p.mass, p.com, p.inertia,
                                                             ("x", "y", "yaw")), m.gravity)
    with pytest.raises(InvalidParameterError, match=r"controlled coordinates \(x, y, yaw\) do not determine"):
        mobility(wrong)


def test_description_round_trips_through_toml():
    from pkmlab.description.files import mechanism_from_dict
    from pkmlab.description.spatial import spatial_mechanism_to_toml

    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover
        import tomli as tomllib
    m = load_mechanism(PRS)
    again = mechanism_from_dict(tomllib.loads(spatial_mechanism_to_toml(m))["mechanism"])
    assert again == m and again.pose_names == ("z", "roll", "pitch")
    assert m.platform.parasitic_names == ("x", "y", "yaw")


def _independent_residual(m, q: np.ndarray, coordinates) -> float:
    """max |leg end - attachment| of configuration ``q``, from the readable chain and rotation."""
    whole = full_poses(m, q[-len(m.platform.q_pose_names):])
    values = dict(zip(coordinates, q, strict=True))
    worst = 0.0
    for i, leg in enumerate(m.legs):
        joint_values, passive = [], iter(n for n in coordinates if n.startswith(f"q{i + 1}_"))
        for joint in leg.joints[:-1]:  # the platform joint has no coordinate
            if joint.actuated:
                joint_values.append(values[f"a{i + 1}"])
            else:
                joint_values += [values[next(passive)] for _ in range(joint.coordinates)]
        end = leg_frames(leg, joint_values)[-1][0]
        worst = max(worst, float(np.abs(end - attachment_point(m, i, whole)).max()))
    return worst


def test_inverse_kinematics_of_every_working_mode_closes_the_loops(prs):
    m = prs.description
    modes = mm.working_modes(prs)
    assert len(modes) == 8  # each slider's link above or below: a quadratic per leg
    parasitic = []
    for mode in modes:
        q = mm.inverse_kinematics(prs, POSE, mode)
        np.testing.assert_allclose(q[-3:], POSE, atol=0)  # the controlled coordinates as asked
        assert _independent_residual(m, q, prs.coordinates) < 1e-12
        parasitic.append(q[-6:-3])
    # the parasitic motion is the pose's, whatever the legs' working modes
    np.testing.assert_allclose(np.array(parasitic) - parasitic[0], 0.0, atol=1e-12)
    assert np.abs(parasitic[0]).max() > 1e-6  # and it exists: a 3-PRS does drift when it tilts


def test_parasitic_motion_of_a_symmetric_3prs_vanishes_when_level(prs):
    """Level (roll = pitch = 0), the symmetric machine stays on its axis: x = y = yaw = 0."""
    q = mm.inverse_kinematics(prs, [0.5, 0.0, 0.0], (1, 1, 1))
    np.testing.assert_allclose(q[-6:-3], 0.0, atol=1e-12)
    assert len(set(np.round(q[:3], 12))) == 1  # the three sliders at one height


def test_rates_against_finite_differences_of_the_inverse_kinematics(prs):
    """The path's actuator rates (``∂η/∂u u̇ = -∂η/∂c ċ``) against central differences of the IK along a line."""
    direction = np.array([0.02, 0.1, -0.07])
    h = 1e-5
    q0 = mm.inverse_kinematics(prs, POSE, (1, 1, 1))
    plus = mm.inverse_kinematics(prs, POSE + h * direction, (1, 1, 1))
    minus = mm.inverse_kinematics(prs, POSE - h * direction, (1, 1, 1))
    theta_dot, _theta_ddot, k = mm.path_rates(prs, q0[None], direction[None], np.zeros((1, 3)))
    assert k == -1
    np.testing.assert_allclose(theta_dot[0], (plus[:3] - minus[:3]) / (2 * h), atol=1e-8)
    second = (plus[:3] - 2 * q0[:3] + minus[:3]) / h**2
    _rates, theta_ddot, _k = mm.path_rates(prs, q0[None], direction[None], np.zeros((1, 3)))
    np.testing.assert_allclose(theta_ddot[0], second, atol=2e-4 * max(1.0, np.abs(second).max()))


def test_unreachable_poses_say_why(prs):
    with pytest.raises(pkmlab.UnreachablePoseError, match=r"leg 1 needs its actuator at 5.17\d* m, outside its stroke"):
        mm.inverse_kinematics(prs, [5.0, 0.0, 0.0], (1, 1, 1))
    with pytest.raises(pkmlab.UnreachablePoseError, match=r"no configuration at z = 0.45, roll = 1.5, pitch = 0"):
        mm.inverse_kinematics(prs, [0.45, 1.5, 0.0], (1, 1, 1))


def test_singularity_measure_is_scaled_and_regular(prs):
    q = mm.inverse_kinematics(prs, POSE, (1, 1, 1))
    s = mm.singularity_measure(prs, q)
    assert 1e-3 < abs(s) <= 1.0
    # a different working mode is another configuration of the same pose, with its own measure
    other = mm.singularity_measure(prs, mm.inverse_kinematics(prs, POSE, (-1, 1, 1)))
    assert math.isfinite(other) and other != s


def test_tracking_run_of_the_3prs_keeps_its_parasitic_motion_on_the_loops(prs):
    """The catalogue's default run: tracked to within its sampled control's error, every sample of the plant on
    the loop closures (its parasitic x, y, yaw included) to round-off."""
    scenario = pkmlab.load_scenario(PRS.parent / "3prs_motion.toml")
    result = pkmlab.simulate(scenario)
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-4 and summary["max_orientation_error_rad"] < 1e-4
    q = result.q
    worst = max(_independent_residual(prs.description, qk, prs.coordinates) for qk in q[::25])
    assert worst < 1e-10
    assert np.ptp(q[:, prs.coordinates.index("yaw")]) > 1e-6  # the parasitic motion moved


# ------------------------------------------------------------------ forward kinematics, the general method
def _general(model, theta):
    from pkmlab.algorithms.assembly import general_spatial_assembly_modes

    return general_spatial_assembly_modes(model, theta)


def _same_set(first, second, tol=1e-9):
    """Every configuration of ``first`` in ``second`` and back (angles compared modulo 2π)."""
    def near(q, others):
        return any(np.abs(np.angle(np.exp(1j * (q - o)))).max() < tol for o in others)

    return all(near(q, second) for q in first) and all(near(q, first) for q in second)


def test_general_forward_kinematics_matches_the_deltas_three_spheres():
    from pkmlab.algorithms.assembly import assembly_modes

    delta = pkmlab.load("delta")
    q = mm.inverse_kinematics(delta, [0.05, -0.03, -0.75], (1, 1, 1))
    special = [c for c, _s in assembly_modes(delta, q[:3])]
    general = [c for c, _s in _general(delta, q[:3])]
    assert len(general) == len(special) == 2
    assert _same_set(general, special)


def _multistart(model, theta, starts: int, seed: int = 1):
    """Distinct configurations at actuators ``theta`` found by Newton's method on the generated kernels' ``η = 0``
    from ``starts`` random configurations (passive angles over a turn, the platform anywhere in its reach): a
    method independent of the polynomial system the homotopy tracks."""
    from test_catalogue_fk import newton_starts

    from pkmlab.algorithms.assembly import _polished
    from pkmlab.model.reach import spatial_extent

    rng = np.random.default_rng(seed)
    n, N = model.n_actuators, len(model.coordinates)
    box = spatial_extent(model.description)
    names = model.coordinates
    q = np.empty((starts, N))
    q[:, :n] = theta
    for c in range(n, N):
        q[:, c] = rng.uniform(*box["xyz".index(names[c])], starts) if names[c] in "xyz" else \
            rng.uniform(-np.pi, np.pi, starts)
    found = list(q[newton_starts(model, q)])  # damped steps, all starts at once: a start far away is walked in
    roll, pitch, yaw = (names.index(c) for c in ("roll", "pitch", "yaw"))
    for q in found:  # one orientation has two roll, pitch, yaw: the one with |pitch| <= pi/2, as pkmlab gives
        if np.cos(q[pitch]) < 0:
            q[roll], q[pitch], q[yaw] = q[roll] + np.pi, np.pi - q[pitch], q[yaw] + np.pi
    return [c for c, _s in _polished(model, found)], len(found)


def test_general_forward_kinematics_of_the_3prs_finds_every_assembly_mode():
    """Every configuration of the IK at this pose (two working modes) is among the FK's at its actuators; every
    FK configuration closes the loops (checked on the readable chain) at those actuators; and 10,000 Newton
    starts find no configuration the homotopy did not (they may find fewer, never more)."""
    from pkmlab.algorithms.general_fk import generic_solutions

    prs = pkmlab.load(PRS)
    sols, _p, _loops = generic_solutions(prs.description)
    assert len(sols) == 16  # the 3-PRS's forward kinematics has 16 complex solutions (Tsai's count for 3-PRS)
    for mode in [(1, 1, 1), (-1, 1, -1)]:
        q = mm.inverse_kinematics(prs, POSE, mode)
        found = [c for c, _s in _general(prs, q[:3])]
        assert any(np.abs(np.angle(np.exp(1j * (c - q)))).max() < 1e-9 for c in found)
        for c in found:
            np.testing.assert_array_equal(c[:3], q[:3])
            assert _independent_residual(prs.description, c, prs.coordinates) < 1e-11
    multistart, converged = _multistart(prs, q[:3], 10_000)
    assert converged > 100 and multistart
    assert all(any(np.abs(np.angle(np.exp(1j * (c - f)))).max() < 1e-7 for f in found) for c in multistart)
