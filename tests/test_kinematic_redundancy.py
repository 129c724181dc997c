"""A kinematically redundant machine: the 3-PRRR of the catalogue (``examples/mechanisms/3prrr.toml``), a planar
machine whose legs have four joints and two actuators each — a slider on a side of the base and the first revolute
of an R*RR leg it carries.

Its controlled coordinates are the platform's pose and the sliders (``x, y, alpha, a1, a3, a5``): six, as its
actuators and its mobility (Grübler's count, 3 x 10 - 2 x 12). Independent checks: the loop closures by the
readable chain of :func:`~pkmlab.description.mechanism.leg_chain` (not the generated kernels); the forward
kinematics against a Newton multistart of 10,000 starts on the kernels' loop closures; the Jacobians against
central differences of the inverse kinematics; the run's passive motion on the loop closures and its tracking
against the time law's discretisation (the dynamics against MuJoCo's hard-constraint solve: ``test_mujoco_export``).
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from test_catalogue_fk import newton_starts

import pkmlab
from pkmlab.algorithms.assembly import assembly_modes
from pkmlab.description.files import load_mechanism
from pkmlab.description.mechanism import Joint, attachment_point, leg_chain
from pkmlab.errors import IncompleteSolutionWarning, InvalidParameterError
from pkmlab.model import mechanism_model as mm
from pkmlab.model.reach import planar_extent

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
PRRR = CATALOGUE / "3prrr.toml"
STARTS = 10_000


@pytest.fixture(scope="module")
def prrr():
    return pkmlab.load(PRRR)


def _poses(count: int, seed: int) -> np.ndarray:
    """Poses about the middle of the base with the sliders part-way along their sides."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0.22, 0.30, count), rng.uniform(0.13, 0.21, count),
                            rng.uniform(-0.3, 0.3, count), rng.uniform(0.05, 0.15, (count, 3))])


def _chain_residual(model, q) -> float:
    """How far each leg's end, by the readable chain at the leg's joint values, is from its attachment point."""
    m = model.description
    pose = mm.pose_of(model, q)[:3]
    worst = 0.0
    for i, (leg, values) in enumerate(zip(m.legs, mm.leg_joint_values(model, q), strict=True)):
        end = leg_chain(leg, values)[-1][0]
        worst = max(worst, float(np.abs(np.subtract(end, attachment_point(m, i, pose))).max()))
    return worst


def test_its_controlled_coordinates_are_the_pose_and_the_sliders(prrr):
    m = prrr.description
    assert m.notation == "3-P*R*RR" and m.dof == 6 and prrr.n_actuators == 6
    assert m.pose_names == ("x", "y", "alpha", "a1", "a3", "a5") and m.actuator_kinds == ("P", "R") * 3
    assert prrr.coordinates[:6] == ("a1", "a2", "a3", "a4", "a5", "a6")
    assert [leg.moving_base for leg in m.legs] == [1, 1, 1]
    assert len(mm.working_modes(prrr)) == 8  # each leg's elbow on either side, as its R*RR part's


def test_extra_actuators_not_at_the_base_and_a_wrong_count_are_refused_naming_the_leg():
    m = load_mechanism(PRRR)
    leg = m.legs[1]
    moved = replace(leg, joints=(Joint("P", False, leg.joints[0].axis), Joint("R", True), Joint("R", True), Joint("R")))
    with pytest.raises(InvalidParameterError, match=r"leg 2 \(PR\*R\*R\) has 4 joints, 1 more than an "
                                                    r"ordinary leg: the first, moving the ordinary leg's base, must be "
                                                    r"actuated"):
        replace(m, legs=(m.legs[0], moved, m.legs[2]))
    short = replace(leg, joints=(Joint("P", True, leg.joints[0].axis), Joint("R")), bodies=leg.bodies[:1])
    with pytest.raises(InvalidParameterError, match=r"mobility \(Grübler: 3 x 8 moving bodies - 2 x 10 joints = 4\) "
                                                    r"is not its 5 degrees of freedom \(3 for its pose x, y, alpha "
                                                    r"and 2 moving its legs' bases\)"):
        replace(m, legs=(m.legs[0], short, m.legs[2]))


def test_inverse_kinematics_in_every_working_mode_closes_the_readable_chain(prrr):
    for pose in _poses(3, 1):
        for mode in mm.working_modes(prrr):
            q = mm.inverse_kinematics(prrr, pose, mode)
            np.testing.assert_allclose(mm.pose_of(prrr, q), pose, atol=0)
            assert _chain_residual(prrr, q) < 1e-14
            # the sliders are where the pose puts them; each leg's elbow on the side its sign says
            m = prrr.description
            for i, (leg, values, sigma) in enumerate(zip(m.legs, mm.leg_joint_values(prrr, q), mode, strict=True)):
                (base, _), (elbow, _), (end, _) = leg_chain(leg, values)[1:]
                assert values[0] == pose[3 + i]
                cross = (end[0] - base[0]) * (elbow[1] - base[1]) - (end[1] - base[1]) * (elbow[0] - base[0])
                assert np.sign(cross) == sigma


def _multistart_poses(model, theta, starts: int = STARTS, seed: int = 5) -> tuple[np.ndarray, int]:
    """The distinct platform poses that damped Newton steps on the kernels' ``η = 0`` reach from ``starts`` random
    configurations at actuators ``theta`` (passive angles over a turn, the platform over the machine's region,
    every orientation), all starts stepped together; and how many converged."""
    n, N = model.n_actuators, len(model.coordinates)
    (x0, x1), (y0, y1) = planar_extent(model.description)
    rng = np.random.default_rng(seed)
    q = np.empty((starts, N))
    q[:, :n] = theta
    q[:, n:N - 3] = rng.uniform(-np.pi, np.pi, (starts, N - 3 - n))
    q[:, N - 3:] = np.column_stack([rng.uniform(x0, x1, starts), rng.uniform(y0, y1, starts),
                                    rng.uniform(-np.pi, np.pi, starts)])
    converged = newton_starts(model, q, 60)
    poses = q[converged][:, N - 3:]
    poses[:, 2] = np.angle(np.exp(1j * poses[:, 2]))
    distinct: list[np.ndarray] = []
    for p in poses:
        if all(np.abs(np.angle(np.exp(1j * (p - d)))).max() > 1e-7 for d in distinct):
            distinct.append(p)
    return np.array(distinct), int(converged.sum())


def test_forward_kinematics_finds_every_assembly_mode_a_newton_multistart_finds(prrr):
    pose = _poses(1, 2)[0]
    q = mm.inverse_kinematics(prrr, pose, mm.working_modes(prrr)[0])
    theta = q[:6]
    with warnings.catch_warnings():
        warnings.simplefilter("error", IncompleteSolutionWarning)
        found = assembly_modes(prrr, theta)
    for qj, _s in found:
        assert _chain_residual(prrr, qj) < 1e-12
        np.testing.assert_array_equal(qj[:6], theta)
    poses = np.array([qj[-3:] for qj, _s in found])
    assert np.abs(poses - pose[:3]).max(axis=1).min() < 1e-10  # FK∘IK: the pose solved for is among them
    multistart, converged = _multistart_poses(prrr, theta)
    assert converged > STARTS // 20 and len(multistart) >= 2
    for p in multistart:
        assert np.abs(np.angle(np.exp(1j * (poses - p)))).max(axis=1).min() < 1e-7, "a pose the solver missed"
    # IK∘FK: every assembly mode's pose, with the sliders, gives back the actuators in one of the working modes
    for qj, _s in found:
        back = [mm.inverse_kinematics(prrr, mm.pose_of(prrr, qj), mode)[:6] for mode in mm.working_modes(prrr)]
        assert min(np.abs(np.angle(np.exp(1j * (b - theta)))).max() for b in back) < 1e-10


def test_the_jacobians_are_the_inverse_kinematics_rates(prrr):
    """``velocity_jacobian`` (the controlled coordinates per actuator rate) inverts ``∂θ/∂pose`` by central
    differences of the inverse kinematics; the sliders' rows are the identity's."""
    mode = mm.working_modes(prrr)[3]
    for pose in _poses(2, 3):
        q = mm.inverse_kinematics(prrr, pose, mode)
        h = 1e-6
        d_theta = np.column_stack([(mm.inverse_kinematics(prrr, pose + h * e, mode)[:6]
                                    - mm.inverse_kinematics(prrr, pose - h * e, mode)[:6]) / (2 * h)
                                   for e in np.eye(6)])
        jv = pkmlab.velocity_jacobian(prrr, q)
        np.testing.assert_allclose(jv @ d_theta, np.eye(6), atol=1e-7)
        np.testing.assert_array_equal(jv[3:], np.eye(6)[[0, 2, 4]])


def test_the_default_run_tracks_its_path_and_keeps_the_legs_on_the_loop_closures():
    scenario = pkmlab.load_scenario(CATALOGUE / "3prrr_motion.toml")
    assert scenario.model.description == load_mechanism(PRRR)
    result = pkmlab.simulate(scenario)
    assert result.pose.shape[1] == 6 and result.tau.shape[1] == 6
    residual = max(_chain_residual(scenario.model, qk) for qk in result.q[::20])
    assert residual < 1e-12
    # computed torque at 1 ms: the error is the sampling's, first order in the sample time
    error = np.abs(result.pose - result.pose_d).max(axis=0)
    assert error[[0, 1, 3, 4, 5]].max() < 5e-5 and error[2] < 5e-4  # m, and rad for alpha
    half = pkmlab.simulate(scenario.replace(sample_time=scenario.sample_time / 2))
    ratio = np.abs(half.pose - half.pose_d).max(axis=0) / error
    assert np.all((0.35 < ratio) & (ratio < 0.65)), ratio


#: Two other kinematically redundant legs, as text changes of the 3-PRRR's file: a crank (its own body) under each
#: R*RR leg, whose ordinary part starts with a revolute; a slider carrying a second slider across it (the ordinary
#: part P*RR slides along the first slider's body, turned by the base's direction).
VARIANTS = {
    "R*R*RR": ([("P*R*RR", "R*R*RR"), ("{ tip = [0.0, 0.0], mass = 0.6, com = [0.0, 0.0], inertia = 0.0 }",
                                        "{ tip = [0.08, 0.0], mass = 0.3, com = [0.04, 0.0], inertia = 0.0002 }")],
               [0.3, -0.2, 0.1]),
    "P*P*RR": ([("P*R*RR", "P*P*RR"), ("{ tip = [0.25, 0.0], mass = 0.468, com = [0.125, 0.0], inertia = 0.002438 },"
                                        "\n  { tip = [0.1667, 0.0]",
                                        "{ tip = [0.0, 0.05], mass = 0.468, com = [0.0, 0.02], inertia = 0.0 },"
                                        "\n  { tip = [0.25, 0.0]")],
               [0.1, 0.12, 0.08]),
}


def _variant(legs: str, folder: Path):
    """The model of the 3-PRRR's file changed to legs ``legs`` (:data:`VARIANTS`), written in ``folder``."""
    text = PRRR.read_text()
    for old, new in VARIANTS[legs][0]:
        assert old in text
        text = text.replace(old, new)
    if legs.startswith("R"):
        text = "\n".join(line for line in text.splitlines() if not line.startswith("axis = "))
    path = folder / "variant.toml"
    path.write_text(text)
    return pkmlab.load(path)


@pytest.mark.parametrize("legs", sorted(VARIANTS))
def test_other_redundant_legs_close_their_chains_and_forward_kinematics_finds_them(legs, tmp_path):
    model = _variant(legs, tmp_path)
    assert model.description.notation == f"3-{legs}" and model.dof == 6
    pose = np.array([0.26, 0.17, 0.1, *VARIANTS[legs][1]])
    for mode in mm.working_modes(model)[:4]:
        q = mm.inverse_kinematics(model, pose, mode)
        np.testing.assert_allclose(mm.pose_of(model, q), pose, atol=0)
        assert _chain_residual(model, q) < 1e-14
        found = assembly_modes(model, q[:6])
        assert min(np.abs(np.angle(np.exp(1j * (qj - q)))).max() for qj, _s in found) < 1e-10


def test_the_command_line_takes_it_from_its_description_file_alone(prrr, tmp_path, capsys):
    """``ik``, ``fk``, ``dynamics``, ``simulate`` (on pkmlab's plant and on MuJoCo's), ``export-mjcf`` and ``view`` of
    the catalogue's file: the inverse kinematics' actuators give back its pose among the forward kinematics' modes,
    the dynamics' ``M`` is the API's, the export has a motor per actuator."""
    import json

    from pkmlab.cli import main

    def run(*args):
        assert main([*map(str, args), "--json"]) == 0
        return json.loads(capsys.readouterr().out)

    pose = [0.26, 0.17, 0.1, 0.1, 0.12, 0.08]
    ik = run("ik", "--mechanism", PRRR, *pose, "--mode", 1, -1, 1)
    theta = ik["solutions"][0]["theta"]
    fk = run("fk", "--mechanism", PRRR, *theta)
    assert min(np.abs(np.subtract(s["pose"], pose)).max() for s in fk["solutions"]) < 1e-9
    dynamics = run("dynamics", "--mechanism", PRRR, *theta, "--near", *pose)
    q = mm.inverse_kinematics(prrr, pose, (1, -1, 1))
    np.testing.assert_allclose(dynamics["solutions"][0]["M"], mm.actuator_space_model(prrr, q, np.zeros(6))[0],
                               rtol=1e-9)
    xml = tmp_path / "prrr.xml"
    run("export-mjcf", "--mechanism", PRRR, "--out", xml)
    assert xml.read_text().count("<motor ") == 6
    scenario = CATALOGUE / "3prrr_motion.toml"
    for plant in ("pkmlab", "mujoco"):
        summary = run("simulate", scenario, "--out", tmp_path / plant, "--no-figures", "--plant", plant)
        assert summary["max_path_error_m"] < 5e-5
    assert main(["view", str(tmp_path / "pkmlab"), "--out", str(tmp_path / "view.html")]) == 0
    assert (tmp_path / "view.html").stat().st_size > 0


def test_a_revolute_actuated_after_another_drives_its_absolute_angle_in_mujoco(tmp_path):
    """pkmlab's angles are absolute, MuJoCo's hinges relative: the second actuator of an R*R*RR leg is exported as a
    motor on the sum of the leg's hinges up to it, and MuJoCo's hard-constraint solve of the export gives pkmlab's
    accelerations (as for every machine of ``test_mujoco_export``)."""
    pytest.importorskip("mujoco")
    from test_mujoco_export import _actuator_accelerations, _hard_solve, _pkmlab_acceleration, _set, _states

    from pkmlab.interop import mujoco_export as mx

    model = _variant("R*R*RR", tmp_path)
    m, d = mx.load_mujoco(model)
    assert m.ntendon == 3 and m.nu == 6
    for q, q_dot, tau in _states(model, 3, 4):
        _set(model, m, d, q, q_dot, tau)
        theirs = _actuator_accelerations(model, q, _hard_solve(m, d, 3))
        ours = _pkmlab_acceleration(model, q, q_dot, tau)
        assert np.abs(theirs - ours).max() < 1e-10 * (1 + np.abs(ours).max())


def test_calibration_measures_the_platform_and_reads_the_sliders(prrr):
    """An instrument measures the platform's pose (x, y, alpha); the sliders are actuators, read like the others.
    Candidate poses move the sliders by lengths (not by the orientation's turn); the nominal machine predicts each
    pose's measurement as its inverse kinematics' pose."""
    from pkmlab.algorithms.calibration import predicted_measurements, reachable_poses
    from pkmlab.algorithms.kinematics import length_scale

    poses, qs = reachable_poses(prrr, 6, np.random.default_rng(0), span=0.1, turn=0.3)
    centre = mm.pose_of(prrr, mm.well_conditioned_configuration(prrr, mm.working_modes(prrr)[0]))
    assert np.abs(poses[:, 3:] - centre[3:]).max() <= 0.1 * length_scale(prrr)
    predicted = predicted_measurements(prrr, qs[:, :6], poses[:, :3], measure="pose")
    assert predicted.shape == (6, 3)
    np.testing.assert_allclose(predicted, poses[:, :3], atol=1e-10)
