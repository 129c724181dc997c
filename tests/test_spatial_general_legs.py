"""Spatial legs with no closed form, solved by the general method (``pkmlab.description.general_legs``): every
real solution of the leg's chain by a parameter homotopy, and its working-mode labels.

Independent checks: each solution's centre by the readable chain of
:func:`~pkmlab.description.spatial.leg_frames` (not the homotopy's polynomials); FK∘IK — a random configuration's
own angles are among the solutions at its centre; the solution count against a Newton multistart of 4,000
starts per point on the readable chain (it may find fewer, never more); the topological pairing of the
determinant's signs (a centre is reached by as many solutions of each sign); labels unchanged when the leg is
turned as a whole, and when a point is solved alone or among others.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.description import general_legs, spatial_legs
from pkmlab.description.spatial import SpatialBody, SpatialJoint, SpatialLeg, axis_rotation, leg_frames
from pkmlab.errors import InvalidParameterError


def _unit(v):
    v = np.asarray(v, dtype=float)
    return tuple(float(c) for c in v / np.linalg.norm(v))


def _skew_rrr_leg() -> SpatialLeg:
    """An actuated hinge, two passive hinges and a spherical joint, every axis skew to the others and every body
    offset: a general 3R positioning chain (four solutions at most: no closed form)."""
    rng = np.random.default_rng(11)
    axes = [_unit(rng.standard_normal(3)) for _ in range(3)]
    tips = [tuple(float(c) for c in 0.2 * rng.standard_normal(3)) for _ in range(3)]
    joints = (SpatialJoint("R", True, (axes[0],)), SpatialJoint("R", False, (axes[1],)),
              SpatialJoint("R", False, (axes[2],)), SpatialJoint("S", False, ()))
    bodies = tuple(SpatialBody(t, 0.1, (0.0, 0.0, 0.0), ((1e-4, 0, 0), (0, 1e-4, 0), (0, 0, 1e-4))) for t in tips)
    return SpatialLeg((0.1, -0.05, 0.02), joints, bodies)


TILTED = Path(__file__).resolve().parents[1] / "examples" / "3rrs_tilted.toml"


@pytest.fixture(scope="module")
def leg():
    return _skew_rrr_leg()


def _centre(leg, q) -> np.ndarray:
    return leg_frames(leg, q)[-1][0]


def _configurations(count: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, size=(count, 3))


def test_every_solution_reaches_the_point_and_the_configuration_is_found_again(leg):
    q = _configurations(300, 1)
    points = np.array([_centre(leg, v) for v in q])
    found = general_legs.real_solutions(leg, points)
    for k, sols in enumerate(found):
        assert len(sols) in (2, 4)  # even: the solutions come in pairs of opposite determinant signs
        for s in sols:
            np.testing.assert_allclose(_centre(leg, s), points[k], atol=1e-14)
        assert np.abs(np.angle(np.exp(1j * (sols - q[k])))).max(axis=1).min() < 1e-10
    assert general_legs.general_leg(leg).branches == 4
    assert {len(s) for s in found} == {2, 4}  # both counts occur over the random points


def _centres(leg, q: np.ndarray) -> np.ndarray:
    """The readable chain of :func:`leg_frames` for a leg of revolute joints, many configurations (K, 3) at once."""
    point = np.broadcast_to(np.array(leg.base, dtype=float), (len(q), 3))
    rot = np.broadcast_to(np.eye(3), (len(q), 3, 3))
    for k, (joint, body) in enumerate(zip(leg.joints[:-1], leg.bodies, strict=True)):
        a = np.array(joint.axes[0])
        cross = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
        s, c = np.sin(q[:, k])[:, None, None], np.cos(q[:, k])[:, None, None]
        rot = rot @ (np.eye(3) + s * cross + (1 - c) * (cross @ cross))  # Rodrigues
        point = point + rot @ np.array(body.tip)
    return point


def _multistart(leg, point, starts: int, seed: int) -> list[np.ndarray]:
    """Distinct solutions at ``point`` by Newton's method on the readable chain (Jacobian by central differences)
    from ``starts`` random configurations, all at once."""
    q = np.random.default_rng(seed).uniform(-np.pi, np.pi, (starts, 3))
    h = 1e-7
    with np.errstate(all="ignore"):
        for _ in range(30):
            r = _centres(leg, q) - point
            jac = np.stack([(_centres(leg, q + h * e) - _centres(leg, q - h * e)) / (2 * h) for e in np.eye(3)],
                           axis=-1)
            ok = np.abs(np.linalg.det(jac)) > 1e-12
            q[ok] -= np.linalg.solve(jac[ok], r[ok][..., None])[..., 0]
    converged = np.isfinite(q).all(axis=1)
    converged[converged] = np.abs(_centres(leg, q[converged]) - point).max(axis=1) < 1e-13
    found: list[np.ndarray] = []
    for v in np.angle(np.exp(1j * q[converged])):
        if not any(np.abs(np.angle(np.exp(1j * (v - f)))).max() < 1e-7 for f in found):
            found.append(v)
    return found


def test_a_newton_multistart_finds_no_solution_the_homotopy_did_not(leg):
    q = _configurations(3, 7)
    points = np.array([_centre(leg, v) for v in q])
    for k, sols in enumerate(general_legs.real_solutions(leg, points)):
        starts = _multistart(leg, points[k], 4000, seed=k)
        assert starts  # the multistart converges somewhere
        assert len(starts) <= len(sols)
        for s in starts:
            assert np.abs(np.angle(np.exp(1j * (sols - s)))).max(axis=1).min() < 1e-7


def test_labels_pair_the_determinant_signs_and_name_each_solution_once(leg):
    points = np.array([_centre(leg, v) for v in _configurations(200, 3)])
    for sols in general_legs.real_solutions(leg, points):
        det = [np.linalg.det(np.column_stack([
            (_centre(leg, s + 1e-7 * e) - _centre(leg, s - 1e-7 * e)) / 2e-7 for e in np.eye(3)])) for s in sols]
        assert sum(d > 0 for d in det) == sum(d < 0 for d in det)
        labels = general_legs.mode_labels(leg, sols)
        assert len(set(labels)) == len(labels)
        assert [label[0] for label in labels] == [1 if d > 0 else -1 for d in det]
        for sign in (1, -1):  # of the two of one sign, +1 the larger actuator angle
            pair = [k for k, label in enumerate(labels) if label[0] == sign]
            if len(pair) == 2:
                larger = max(pair, key=lambda k: sols[k][0])
                assert labels[larger][1] == 1


def test_each_working_mode_returns_its_labelled_solution_and_says_where_a_mode_is_missing(leg):
    assert spatial_legs.working_modes(leg) == ((1, 1), (1, -1), (-1, 1), (-1, -1))
    points = np.array([_centre(leg, v) for v in _configurations(60, 4)])
    found = general_legs.real_solutions(leg, points)
    for mode in spatial_legs.working_modes(leg):
        solved = spatial_legs.leg_inverse_kinematics_batch(leg, 2, points, mode)
        for k, sols in enumerate(found):
            labels = general_legs.mode_labels(leg, sols)
            if mode in labels:
                assert not solved.bad[k]
                np.testing.assert_array_equal(solved.coordinates[k], sols[labels.index(mode)])
            else:
                assert solved.bad[k]
                assert solved.why(k).startswith(f"leg 3 ({leg.notation}) reaches the point (")
                assert f"not in ({mode[0]:+d}, {mode[1]:+d})" in solved.why(k)
    far = spatial_legs.leg_inverse_kinematics_batch(leg, 0, np.array([[5.0, 0.0, 0.0]]), (1, 1))
    assert far.bad[0] and far.why(0) == "leg 1 (R*RRS) cannot reach the point (5, 0, 0)"
    with pytest.raises(InvalidParameterError, match=r"working mode \(1, 0\) is none of its modes"):
        spatial_legs.leg_inverse_kinematics_batch(leg, 0, points[:1], (1, 0))


def test_labels_do_not_depend_on_the_batch_or_on_turning_the_leg_as_a_whole(leg):
    points = np.array([_centre(leg, v) for v in _configurations(20, 5)])
    together = general_legs.real_solutions(leg, points)
    alone = general_legs.real_solutions(leg, points[7:8])[0]
    np.testing.assert_allclose(alone, together[7], atol=1e-13)
    turn = axis_rotation(_unit([0.3, -0.4, 0.8]), 1.1)
    # every body's frame is the world's at zero angles: the whole leg turned turns every axis and tip
    turned = replace(leg, base=tuple(turn @ np.array(leg.base)),
                     joints=tuple(replace(j, axes=tuple(tuple(turn @ np.array(a)) for a in j.axes))
                                  for j in leg.joints),
                     bodies=tuple(replace(b, tip=tuple(turn @ np.array(b.tip))) for b in leg.bodies))
    assert general_legs.canonical_frame(turned)[0] == general_legs.canonical_frame(leg)[0]
    for mode in spatial_legs.working_modes(leg):
        here = spatial_legs.leg_inverse_kinematics_batch(leg, 0, points, mode)
        there = spatial_legs.leg_inverse_kinematics_batch(turned, 0, points @ turn.T, mode)
        np.testing.assert_array_equal(here.bad, there.bad)
        np.testing.assert_allclose(here.coordinates[~here.bad], there.coordinates[~there.bad], atol=1e-12)


def test_a_leg_of_one_or_four_coordinates_is_refused_naming_it(leg):
    extra = replace(leg, joints=(*leg.joints[:3], SpatialJoint("R", False, (_unit([1, 1, 0]),)), leg.joints[3]),
                    bodies=(*leg.bodies, leg.bodies[-1]))
    with pytest.raises(InvalidParameterError, match=r"^leg 2 \(R\*RRRS\): pkmlab solves the inverse kinematics of a "
                                                    r"leg of two or three joint coordinates before its platform "
                                                    r"joint, not 4$"):
        spatial_legs.leg_inverse_kinematics_batch(extra, 1, np.zeros((1, 3)), 1)


def test_a_tilted_3rrs_goes_through_inverse_and_forward_kinematics_and_its_default_run():
    """``examples/3rrs_tilted.toml``: the catalogue's 3-RRS with each link's hinge tilted out of parallel with its
    crank's, so no leg has a closed form. Its inverse kinematics (the parasitic motion, then each leg by the general
    method) closes the loops by the readable chain; its forward kinematics at those actuators finds the
    configuration again, and a Newton multistart of 10,000 starts on the kernels' loop closures finds no assembly
    mode it did not; its default run is tracked with its parasitic motion on the loop closures."""
    from test_catalogue_fk import _contains, _multistart_poses, _pose_columns
    from test_lower_mobility import _independent_residual

    from pkmlab.model import mechanism_model as mm
    from pkmlab.model.parasitic import home_configuration

    tilted = pkmlab.load(TILTED)
    assert all(not spatial_legs.has_closed_form(leg) for leg in tilted.description.legs)
    pose = home_configuration(tilted)[-3:] + np.array([0.01, 0.02, -0.02])
    for mode in mm.working_modes(tilted):
        q = mm.inverse_kinematics(tilted, pose, mode)
        np.testing.assert_allclose(q[-3:], pose, atol=0)
        assert _independent_residual(tilted.description, q, tilted.coordinates) < 1e-12
        found = pkmlab.forward_kinematics(tilted, q[:3])
        assert np.abs(np.angle(np.exp(1j * (found.q - q)))).max(axis=1).min() < 1e-9
        for c in found.q:
            assert _independent_residual(tilted.description, c, tilted.coordinates) < 1e-11
    multistart, converged = _multistart_poses(tilted, q[:3], 10_000)  # all starts stepped together
    assert converged > 500 and len(multistart) >= 1
    assert all(_contains(found.q[:, _pose_columns(tilted)], p) for p in multistart), "a pose the homotopy missed"
    result = pkmlab.simulate(pkmlab.load_scenario(TILTED.parent / "3rrs_tilted_motion.toml"))
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-5 and summary["max_orientation_error_rad"] < 1e-4
    assert max(_independent_residual(tilted.description, qk, tilted.coordinates) for qk in result.q[::25]) < 1e-10


def test_a_machine_of_too_many_complex_assembly_modes_is_refused_saying_so(monkeypatch):
    """A machine whose forward-kinematics system has more complex solutions than the general method takes on (six
    R*RRS legs: thousands, an hour of monodromy) is refused in one line once monodromy passes the bound — here the
    tilted 3-RRS (64 for its offset system) under a bound of 10."""
    from pkmlab.algorithms import general_fk

    monkeypatch.setattr(general_fk, "MAX_GENERIC", 10)
    tilted = pkmlab.load(TILTED)
    with pytest.raises(pkmlab.AssemblyError) as refused:
        general_fk.solve_generic_instance(tilted.description)  # what generic_solutions computes and keeps
    message = str(refused.value)
    assert "\n" not in message
    assert message.startswith("3-RRS tilted: its forward-kinematics system has more than 10 complex solutions at "
                              "generic actuator values (")
