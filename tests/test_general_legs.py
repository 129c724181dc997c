"""Legs with no closed form of their own: pkmlab's general method — each leg's locus (a circle or a
line), its inverse kinematics by the roots of the gap to it, forward kinematics by a sweep of the
platform's orientation. Checked against the closed forms of the presets' leg types, and on a 3-R*PR
machine read from its own file against a multi-start Newton search and the geometry of its legs' lines."""

import math
import warnings

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms import assembly
from pkmlab.description import leg_types as lt
from pkmlab.description.files import load_mechanism
from pkmlab.description.presets import PLANAR_PRESETS, preset
from pkmlab.formats.scenario import scenario_from_dict
from pkmlab.model import mechanism_model as mm
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.simulation.run import simulate

# actuated revolutes at the paper's base pivots, a passive slide along each leg: a 3-R*PR
R_PR = """
[mechanism]
name = "3-R*PR"

[mechanism.platform]
kind = "rigid"
attachments = [[-0.0625, -0.036084391824351615], [0.0625, -0.036084391824351615], [0.0, 0.07216878364870323]]
mass = 0.234
inertia = 0.305e-3

[[mechanism.leg]]
base = [0.0, 0.0]
joints = "R*PR"
bodies = [{ tip = [0.02, 0.0], mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 },
          { tip = [0.0, 0.0], mass = 0.25, com = [-0.06, 0.0], inertia = 0.6e-3 }]

[[mechanism.leg]]
base = [0.52, 0.0]
joints = "R*PR"
bodies = [{ tip = [0.02, 0.0], mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 },
          { tip = [0.0, 0.0], mass = 0.25, com = [-0.06, 0.0], inertia = 0.6e-3 }]

[[mechanism.leg]]
base = [0.26, 0.45033320996790803]
joints = "R*PR"
bodies = [{ tip = [0.02, 0.0], mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 },
          { tip = [0.0, 0.0], mass = 0.25, com = [-0.06, 0.0], inertia = 0.6e-3 }]
"""


@pytest.fixture(scope="module")
def r_pr(tmp_path_factory):
    path = tmp_path_factory.mktemp("machine") / "r_pr.toml"
    path.write_text(R_PR)
    return path, mm.MechanismModel.from_description(load_mechanism(path))


def _wrapped_gap(a, b, angles):
    d = np.abs(a - b)
    return np.where(angles, np.abs(np.angle(np.exp(1j * (a - b)))), d)


@pytest.mark.parametrize("name", sorted(PLANAR_PRESETS))
def test_the_general_leg_method_finds_exactly_the_closed_forms_solutions(name):
    rng = np.random.default_rng(11)
    m = preset(name)
    for i, leg in enumerate(m.legs):
        angles = np.array([j.kind == "R" for j in leg.joints[:-1]])
        points = np.array(leg.base) + rng.uniform(-0.45, 0.45, (300, 2))
        closed = [lt.SOLVERS[leg.notation](leg, i, points, sigma) for sigma in (lt.working_modes(leg) or (1,))]
        general = [lt._general(leg, i, points, sigma) for sigma in (1, -1)]
        for k in range(len(points)):
            mine = {tuple(np.round(g.coordinates[k], 9)) for g in general if not g.bad[k]}
            theirs = [c.coordinates[k] for c in closed if not c.bad[k]]
            # every closed-form solution is one of the general method's, and no more of them
            assert len(mine) == len({tuple(np.round(c, 9)) for c in theirs}), (name, i, k)
            for c in theirs:
                assert min(_wrapped_gap(np.array(g), c, angles).max() for g in mine) < 1e-9


@pytest.mark.parametrize("joints", ["R*PR", "RR*R", "PR*R", "R*RR", "P*RR", "RP*R"])
def test_every_leg_of_the_general_method_ends_at_its_point_in_both_working_modes(joints):
    """Any three-joint leg (its actuator anywhere, skewed links and a slanted rail): each solution's chain
    (:func:`~pkmlab.description.mechanism.leg_chain`, the plain statement of the conventions) ends at the point,
    the two working modes are distinct solutions with the gap to the locus rising and falling through them,
    and a point is refused exactly when no actuator value of that mode exists (sampled densely)."""
    from pkmlab.description.mechanism import Body, Joint, Leg, leg_chain

    kinds = joints.replace("*", "")
    actuated = joints.index("*") - 1
    leg = Leg((0.1, -0.05), tuple(Joint(k, i == actuated, 0.4 if k == "P" and i == 0 else None)
                                  for i, k in enumerate(kinds)),
              (Body((0.3, 0.07), 1.0, (0.1, 0.0), 1e-3), Body((0.22, -0.05), 1.0, (0.1, 0.0), 1e-3)))
    locus = lt.Locus(leg, 0)
    rng = np.random.default_rng(2)
    points = np.array(leg.base) + rng.uniform(-0.7, 0.7, (200, 2))
    lo, hi = locus.domain()
    samples = np.linspace(lo, hi, 8001)
    every_gap = locus.gap(samples[None, :], points[:, None, :])
    for sigma in (1, -1):
        solved = lt._general(leg, 0, points, sigma)
        assert (~solved.bad).sum() > 20  # not a vacuous check: points reached in each mode
        for k, gaps in enumerate(every_gap):
            crossings = np.flatnonzero(np.sign(gaps[:-1]) * np.sign(gaps[1:]) < 0)
            wanted = [c for c in crossings if (gaps[c + 1] > gaps[c]) == (sigma > 0)]
            if solved.bad[k]:
                assert len(wanted) != 1, (joints, sigma, k)
                continue
            end = np.array(leg_chain(leg, solved.coordinates[k])[-1][0])
            assert np.abs(end - points[k]).max() < 1e-12, (joints, sigma, k)
            a = solved.coordinates[k, leg.actuated]
            assert len(wanted) == 1 and samples[wanted[0]] - 1e-9 <= a <= samples[wanted[0] + 1] + 1e-9


@pytest.mark.parametrize("name", sorted(PLANAR_PRESETS))
def test_the_general_forward_kinematics_finds_the_polynomials_assembly_modes(name):
    model = mm.MechanismModel.from_preset(name)
    rng = np.random.default_rng(5)
    centre = {"paper": [0.2, 0.2, 0.0], "five_bar": [0.0, 0.35], "3rpr": [0.25, 0.2, -1.2],
              "3prr": [0.26, 0.15, 0.0]}[name]
    modes, checked = mm.working_modes(model), 0
    for trial in range(80):
        if checked == 6:
            break
        pose = np.array(centre) + rng.normal(0.0, 0.03, len(centre))
        try:
            q = mm.inverse_kinematics(model, pose, modes[trial % len(modes)])
        except pkmlab.UnreachablePoseError:
            continue
        closed = assembly.assembly_modes(model, q[:model.n_actuators])
        general, doubt = assembly.general_assembly_modes(model, q[:model.n_actuators])
        assert doubt == "" and len(general) == len(closed)
        for qc, _s in closed:
            gaps = [np.abs(np.angle(np.exp(1j * (qg - qc)))).max() for qg, _s in general]
            assert min(gaps) < 1e-9
        checked += 1
    assert checked == 6


def test_the_general_forward_kinematics_reports_a_double_root_once():
    """At alpha = 0 the 3-RPR preset is singular: the pose is a double root, which no sign change shows."""
    model = mm.MechanismModel.from_preset("3rpr")
    q = mm.inverse_kinematics(model, [0.24, 0.17, 0.0], ())
    found, _doubt = assembly.general_assembly_modes(model, q[:3])
    near = [s for s in found if np.hypot(*(s[0][-3:-1] - [0.24, 0.17])) < 1e-5]
    assert len(near) == 1


def _newton_search(model, theta, starts, rng):
    """Assembly modes by Newton's method from many random starts: an independent, polynomial-free search."""
    found = []
    for _ in range(starts):
        q = np.array([*theta, *rng.uniform(-math.pi, math.pi, 3), *rng.uniform(0.0, 0.45, 2), rng.uniform(-3, 3)])
        q[3:6] = rng.uniform(-0.6, 0.6, 3)  # the slides
        for _ in range(40):
            eta = mm.constraint_residual(model, q)
            if np.max(np.abs(eta)) < 1e-13:
                break
            q[3:] -= np.linalg.lstsq(mm.constraint_jacobian(model, q)[:, 3:], eta, rcond=None)[0]
        if np.all(np.isfinite(q)) and np.max(np.abs(mm.constraint_residual(model, q))) < 1e-12:
            pose = q[-3:].copy()
            pose[2] = math.remainder(pose[2], 2 * math.pi)
            if all(np.max(np.abs(pose - p)) > 1e-7 for p in found):
                found.append(pose)
    return found


def test_a_3_rpr_with_actuated_revolutes_round_trips_in_every_working_mode(r_pr):
    _path, model = r_pr
    assert len(mm.working_modes(model)) == 8
    pose = np.array([0.26, 0.17, 0.3])
    rng = np.random.default_rng(3)
    for mode in mm.working_modes(model):
        q = mm.inverse_kinematics(model, pose, mode)
        assert np.max(np.abs(mm.constraint_residual(model, q))) < 1e-14
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no doubt about completeness here
            modes = assembly.assembly_modes(model, q[:3])
        poses = [p[-3:] for p, _s in modes]
        assert min(np.abs(np.angle(np.exp(1j * (p - pose)))).max() for p in poses) < 1e-12
        # every assembly mode a many-start Newton search finds is among them
        for other in _newton_search(model, q[:3], 150, rng):
            assert min(np.abs(np.angle(np.exp(1j * (p - other)))).max() for p in poses) < 1e-8


def test_a_3_rpr_with_actuated_revolutes_has_the_singularity_of_its_legs_lines(r_pr):
    """With its actuator held, an R*PR leg pushes the platform across its slide, through its attachment
    point: S vanishes where the three such lines meet (written out here from the geometry)."""
    _path, model = r_pr
    m = model.description
    rng = np.random.default_rng(8)
    size = 0.125
    for _ in range(20):
        pose = np.array([0.26, 0.17, 0.0]) + rng.normal(0.0, [0.03, 0.03, 0.6])
        q = mm.inverse_kinematics(model, pose, (1, -1, 1))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        rows = []
        for i in range(3):
            ax, ay = m.platform.attachments[i]
            r = np.array([c * ax - s * ay, s * ax + c * ay])  # attachment point from the tracked point
            u = np.array([-math.sin(q[i]), math.cos(q[i])])  # across the slide, along which the leg points
            rows.append([u[0], u[1], r[0] * u[1] - r[1] * u[0]])
        expected = np.linalg.det(np.array(rows)) / size
        assert abs(mm.singularity_measure(model, q)) == pytest.approx(abs(expected), rel=1e-9, abs=1e-12)


def test_a_3_rpr_with_actuated_revolutes_is_controlled_from_its_file(r_pr):
    path, _model = r_pr
    scenario = scenario_from_dict({
        "mechanism": {"file": str(path)},
        "trajectory": {"type": "circle", "center": [0.26, 0.17], "radius": 0.02, "alpha": 0.3, "speed": 0.1},
        "controller": {"kp": 1000.0, "sample_time": 0.001},
    }, str(path.parent / "scenario.toml"))
    result = simulate(scenario)
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-4 and summary["min_abs_S"] > 0.1
    np.testing.assert_allclose(result.pose[:, :2], result.pose_d[:, :2], atol=1e-4)


def test_a_leg_whose_actuator_does_not_move_its_end_is_refused():
    from pkmlab.description.mechanism import Body, Joint, Leg

    leg = Leg((0.0, 0.0), (Joint("P", True, axis=0.0), Joint("P"), Joint("R")),
              (Body((0.0, 0.0), 0.5, (0.0, 0.0), 1e-3), Body((0.1, 0.0), 0.2, (0.05, 0.0), 1e-3)), stroke=(0.0, 0.5))
    solved = lt.leg_inverse_kinematics_batch(leg, 1, np.array([[0.3, 0.0], [0.3, 0.1]]), 1)
    assert solved.bad.all()
    assert "leg 2 (P*PR)" in solved.why(1)


def test_an_rr_star_r_legs_line_is_its_first_link_and_S_vanishes_with_det_j_eta_phi():
    """An RR*R leg holds its second body's angle: its first link, pinned at both ends, is a two-force member,
    so the leg pushes the platform along the line base -> elbow (through its attachment point). S must then
    vanish exactly where the passive coordinates stop being determined (det Jηφ = 0)."""
    from pkmlab.description.mechanism import Body, Joint, Leg, Mechanism
    from pkmlab.description.presets import equilateral_base, equilateral_platform

    legs = tuple(Leg(b, (Joint("R"), Joint("R", True), Joint("R")),
                     (Body((0.25, 0.0), 0.4, (0.12, 0.0), 2e-3), Body((0.17, 0.0), 0.3, (0.08, 0.0), 7e-4)))
                 for b in equilateral_base())
    model = mm.MechanismModel.from_description(Mechanism("3-RR*R", legs, equilateral_platform()))
    m = model.description
    rng = np.random.default_rng(4)
    signs, seen = [], 0
    for _ in range(60):
        pose = np.array([0.26, 0.15, 0.0]) + rng.normal(0.0, [0.03, 0.03, 0.8])
        try:
            q = mm.inverse_kinematics(model, pose, (1, -1, 1))
        except pkmlab.UnreachablePoseError:
            continue
        seen += 1
        c, s = math.cos(pose[2]), math.sin(pose[2])
        rows = []
        for i, (ax, ay) in enumerate(m.platform.attachments):
            r = np.array([c * ax - s * ay, s * ax + c * ay])
            u = np.array([math.cos(q[3 + i]), math.sin(q[3 + i])])  # the first link's direction (passive angle)
            rows.append([u[0], u[1], r[0] * u[1] - r[1] * u[0]])
        expected = np.linalg.det(np.array(rows)) / 0.125
        measured = mm.singularity_measure(model, q)
        assert abs(measured) == pytest.approx(abs(expected), rel=1e-9, abs=1e-12)
        det = np.linalg.det(mm.constraint_jacobian(model, q)[:, 3:])
        signs.append(np.sign(measured * det))
    assert seen >= 20 and len(set(signs)) == 1  # S and det Jηφ change sign together


def test_branch_following_refuses_a_step_rather_than_land_in_another_assembly_mode():
    """A short step near a singularity where the chord iteration diverges: Newton's method, started from the far
    point it reached, used to converge to a configuration whole turns away in another assembly mode."""
    model = Planar3RRR.paper()
    q_prev = np.array([0.35857836, 3.26478706, -2.08201745, 1.89909434, 1.83196474, -0.01415614, -1.17227581])
    # onto the manifold to round-off: the assembly mode at these actuators nearest the rounded configuration
    q_prev = kin.forward_kinematics(model, q_prev[:3]).nearest(kin.platform_pose(model, q_prev)).q
    target = q_prev[:3] + np.array([0.005037, 0.00186, 0.001426])
    try:
        q = kin.branch_following(model, q_prev, target)
    except pkmlab.BranchFollowingError:
        return
    assert np.abs(np.angle(np.exp(1j * (q - q_prev)))).max() < 0.2  # if it follows, it stays near


def test_branch_following_refuses_a_step_size_that_is_not_positive():
    model = mm.MechanismModel.from_preset("five_bar")
    q = mm.inverse_kinematics(model, [0.0, 0.35], (1, -1))
    for bad in (0.0, -0.05, float("nan")):
        with pytest.raises(pkmlab.InvalidParameterError, match="max_step"):
            pkmlab.branch_following(model, q, q[:2] + 0.01, max_step=bad)


def test_the_cli_solves_a_machine_of_general_legs_both_ways(r_pr, capsys):
    """``pkmlab ik`` then ``pkmlab fk`` with ``--mechanism FILE``: every working mode's actuators lead back to
    the pose, JSON as for the presets."""
    import json

    from conftest import run

    path, _model = r_pr
    pose = [0.26, 0.17, 0.3]
    code, out, err = run(capsys, "ik", "--mechanism", path, "--json", *pose)
    assert code == 0 and err == ""
    solutions = json.loads(out)["solutions"]
    assert len(solutions) == 8
    for sol in solutions:
        code, out, err = run(capsys, "fk", "--mechanism", path, "--json", "--", *sol["theta"])
        assert code == 0 and err == ""
        poses = [s["pose"] for s in json.loads(out)["solutions"]]
        assert min(max(abs(a - b) for a, b in zip(p, pose, strict=True)) for p in poses) < 1e-9


def test_the_executable_solves_a_machine_of_a_new_structure_interpreted(r_pr):
    """``pkmlab ik --mechanism FILE`` started from a shell runs interpreted (no Numba), a structure that pkmlab does
    not ship included (its kernels generated into the cache folder): the compiled kernels' solutions."""
    from conftest import one_shot

    path, model = r_pr
    pose = [0.26, 0.17, 0.3]
    result, numba_imported = one_shot("ik", "--mechanism", path, *pose)
    assert not numba_imported
    solutions = result["solutions"]
    assert len(solutions) == 8
    for sol in solutions:
        q = mm.inverse_kinematics(model, pose, tuple(sol["mode"]))
        np.testing.assert_allclose(sol["theta"], q[:3], rtol=0, atol=1e-14)


def test_forward_kinematics_by_the_general_method_refuses_actuators_outside_their_strokes():
    """Two telescopic legs (strokes 0.10-0.45 m) and one R*PR leg: the general method serves the machine, and a
    leg length outside its stroke is refused before it, as for the presets."""
    from pkmlab.description.mechanism import Body, Joint, Leg, Mechanism
    from pkmlab.description.presets import equilateral_base, equilateral_platform, preset

    telescopic = preset("3rpr").legs
    bodies = (Body((0.02, 0.0), 0.5, (0.08, 0.0), 1.5e-3), Body((0.0, 0.0), 0.25, (-0.06, 0.0), 0.6e-3))
    r_pr = Leg(equilateral_base()[2], (Joint("R", True), Joint("P"), Joint("R")), bodies)
    model = mm.MechanismModel.from_description(Mechanism("mixed", (*telescopic[:2], r_pr), equilateral_platform()))
    with pytest.raises(pkmlab.InvalidParameterError, match=r"leg 1: actuator value 0.5 m is outside its stroke"):
        assembly.assembly_modes(model, [0.5, 0.3, 1.0])
    q = mm.inverse_kinematics(model, [0.25, 0.2, -1.2], (1,))
    poses = [p[-3:] for p, _s in assembly.assembly_modes(model, q[:3])]
    assert min(np.abs(p - [0.25, 0.2, -1.2]).max() for p in poses) < 1e-9
