"""Closed-loop control of any described mechanism on its structure's compiled loop (pkmlab.codegen.core).

Independent checks: the generic pipeline on the paper's preset against pkmlab's own 3-RRR loop;
continuous-time computed torque with the exact model tracking to integration level; the energy
balance of every sample of a sampled-data run (the held effort's work equals the change of
kinetic plus potential energy, with gravity); a batch equal to its runs done alone; a
user-described machine end to end from its TOML file; bad scenarios refused before simulating.
"""

import math
from pathlib import Path

import numpy as np
import pytest

from pkmlab.algorithms import assembly
from pkmlab.control.trajectory import Circle, Trajectory, paper_trajectory
from pkmlab.errors import InvalidParameterError, SingularityError, UnreachablePoseError
from pkmlab.formats.scenario import load_scenario, paper_scenario, scenario_from_dict
from pkmlab.model import mechanism_model as mm
from pkmlab.model.mechanism_model import MechanismModel, actuator_space_model
from pkmlab.simulation.run import simulate, simulate_batch
from pkmlab.simulation.scenario import Scenario

EXAMPLES = {
    "five_bar": ("five_bar_circle", Circle((0.0, 0.35), 0.06, start_angle=math.pi), 0.3),
    "3rpr": ("3rpr_circle", Circle((0.25, 0.21), 0.05, start_angle=math.pi, alpha=-math.pi / 2), 0.2),
    "3prr": ("3prr_circle", Circle((0.26, 0.15), 0.03, start_angle=math.pi), 0.1),
}

# A user's own machine: a five-bar with unequal legs working in the vertical plane (gravity along -y),
# its links' mass centres off their middles.
USER_FIVE_BAR = """
[mechanism]
name = "lab five-bar"
gravity = [0.0, -9.81]

[mechanism.platform]
kind = "point"
mass = 0.15

[[mechanism.leg]]
base = [-0.12, 0.0]
joints = "R*RR"
bodies = [
  { tip = [0.24, 0.0], mass = 0.35, com = [0.10, 0.0], inertia = 2.0e-3 },
  { tip = [0.31, 0.0], mass = 0.22, com = [0.14, 0.0], inertia = 1.7e-3 },
]

[[mechanism.leg]]
base = [0.09, 0.0]
joints = "R*RR"
bodies = [
  { tip = [0.27, 0.0], mass = 0.30, com = [0.12, 0.0], inertia = 1.8e-3 },
  { tip = [0.29, 0.0], mass = 0.20, com = [0.15, 0.0], inertia = 1.5e-3 },
]
"""

USER_SCENARIO = """
[mechanism]
file = "lab_five_bar.toml"

[trajectory]
type = "circle"
center = [0.0, 0.36]
radius = 0.05
speed = 0.25

[controller]
kp = 1000.0
sample_time = 0.001

[simulation]
substeps = 2
"""


def test_the_generic_loop_on_the_paper_preset_gives_the_paper_machines_numbers():
    # the same machine through two independent implementations: pkmlab's hand-written 3-RRR kernels and
    # the generic loop on the kernels generated from the paper's description
    for case, speed in (("nominal", 0.2), ("fast", 0.4)):
        reference = simulate(paper_scenario(case))
        result = simulate(Scenario(MechanismModel.from_preset("paper"), paper_trajectory(speed)))
        assert result.working_mode == reference.working_mode
        np.testing.assert_allclose(result.theta, reference.theta, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.tau, reference.tau, rtol=0, atol=1e-11 * np.abs(reference.tau).max())
        np.testing.assert_allclose(result.pose, reference.pose, rtol=0, atol=1e-12)
        np.testing.assert_allclose(result.S, reference.S, rtol=0, atol=1e-12)
        s, r = result.summary(), reference.summary()
        for key in ("max_path_error_m", "rms_path_error_m", "max_orientation_error_rad", "min_abs_S"):
            assert s[key] == pytest.approx(r[key], rel=1e-9)


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_continuous_time_computed_torque_with_the_exact_model_tracks_to_integration_level(name):
    _file, circle, speed = EXAMPLES[name]
    # a quarter of the default circle: the adaptive integrator calls the controller from Python at every stage
    quarter = Circle(circle.center, circle.radius, circle.start_angle, circle.alpha, turns=0.25)
    scenario = Scenario(MechanismModel.from_preset(name), Trajectory(quarter, speed, "cubic"), sample_time=0.0)
    result = simulate(scenario)
    # ë + kv ė + kp e = 0 from e = ė = 0: the error is the integrator's (rtol 1e-12), far below the sampled
    # loop's micrometres
    assert result.summary()["max_path_error_m"] < 1e-9
    sampled = simulate(scenario.replace(sample_time=1e-3)).summary()["max_path_error_m"]
    assert sampled > 100 * result.summary()["max_path_error_m"]


def _energy(model, q, theta_dot):
    """Kinetic energy ½ θ̇ᵀ Mθ θ̇ and potential energy -Σ m g·c (bodies' mass centres from the kernels)."""
    k = model.kernels
    poses = np.empty((k.N_BODIES, 3))
    k.body_poses(q, mm.trig_table(model, q), model.P, poses)
    m_theta, _c, _g = actuator_space_model(model, q, theta_dot)
    masses = np.array([model.P[i] for i in k.MASS_INDEX])
    gravity = np.array(model.description.gravity)
    return 0.5 * theta_dot @ m_theta @ theta_dot, -float(masses @ (poses[:, :2] @ gravity))


@pytest.mark.parametrize("name", ["lab five-bar", *EXAMPLES, "paper"])
def test_every_sample_of_a_run_balances_work_and_energy(tmp_path, name):
    if name == "lab five-bar":  # a user's machine in the vertical plane, from its TOML file
        (tmp_path / "lab_five_bar.toml").write_text(USER_FIVE_BAR)
        (tmp_path / "lab.toml").write_text(USER_SCENARIO)
        scenario = load_scenario(tmp_path / "lab.toml")
        assert scenario.model.description.gravity == (0.0, -9.81)
    elif name == "paper":
        scenario = Scenario(MechanismModel.from_preset("paper"), paper_trajectory(0.4), substeps=2)
    else:
        _file, circle, speed = EXAMPLES[name]
        scenario = Scenario(MechanismModel.from_preset(name), Trajectory(circle, speed, "cubic"), substeps=2)
    result = simulate(scenario)
    model = scenario.model
    energy = np.array([_energy(model, q, w) for q, w in zip(result.q, result.theta_dot, strict=True)])
    total = energy.sum(axis=1)
    # the effort held over sample k does the work τ_k · (θ_k+1 - θ_k) exactly
    work = np.einsum("ki,ki->k", result.tau[:-1], np.diff(result.theta, axis=0))
    scale = np.abs(work).max()
    assert scale > 1e-6  # the run does work: there is something to balance
    np.testing.assert_allclose(np.diff(total), work, rtol=0, atol=1e-7 * scale)
    if name == "lab five-bar":  # the controller compensates gravity: the efforts hold the machine's weight
        assert np.abs(result.tau).max() > 0.5
    assert result.summary()["max_path_error_m"] < 1e-4


def test_a_batch_gives_each_run_as_done_alone():
    name, circle, speed = "3prr", *EXAMPLES["3prr"][1:]
    base = Scenario(MechanismModel.from_preset(name), Trajectory(circle, speed, "cubic"))
    from pkmlab.control.controller import ControllerSpec
    from pkmlab.description.mechanism import scaled_mechanism

    plant = MechanismModel.from_description(scaled_mechanism(base.model.description, 1.15, 1.0))
    runs = [base, base.replace(controller=ControllerSpec(kp=400.0)), base.replace(plant=plant)]
    batch = simulate_batch(runs)
    for alone, together in zip(map(simulate, runs), batch, strict=True):
        np.testing.assert_array_equal(alone.q, together.q)
        np.testing.assert_array_equal(alone.tau, together.tau)
    # the heavier plant needs more effort from the same nominal model
    assert batch[2].summary()["max_path_error_m"] > batch[0].summary()["max_path_error_m"]


def test_a_plant_of_another_structure_is_refused():
    with pytest.raises(InvalidParameterError, match="structure"):
        Scenario(MechanismModel.from_preset("3prr"), paper_trajectory(0.2), plant=MechanismModel.from_preset("3rpr"))


def test_the_3rpr_at_alpha_zero_is_refused_as_singular_everywhere():
    data = {"mechanism": {"preset": "3rpr"},
            "trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2, "alpha": 0.0}}
    with pytest.raises(SingularityError, match="whole path"):
        simulate(scenario_from_dict(data, "alpha0.toml"))


def test_a_path_out_of_a_stroke_names_the_leg_and_the_time():
    data = {"mechanism": {"preset": "3rpr"},
            "trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.2, "speed": 0.2,
                           "alpha": -math.pi / 2}}
    with pytest.raises(UnreachablePoseError, match=r"t = .* leg \d"):
        simulate(scenario_from_dict(data, "wide.toml"))


def test_a_working_mode_that_the_machine_does_not_have_is_refused():
    data = {"mechanism": {"preset": "five_bar"}, "simulation": {"working_mode": "+-+"},
            "trajectory": {"type": "circle", "center": [0.0, 0.35], "radius": 0.06, "speed": 0.3}}
    with pytest.raises(InvalidParameterError, match=r"working_mode.*\+\+, \+-, -\+, --"):
        scenario_from_dict(data, "modes.toml")
    data["simulation"]["working_mode"] = [1, -1]
    assert scenario_from_dict(data, "modes.toml").working_mode == (1, -1)


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_the_example_files_are_the_default_runs(name):
    from pathlib import Path

    file, circle, speed = EXAMPLES[name]
    scenario = load_scenario(Path(__file__).parents[1] / "examples" / f"{file}.toml")
    assert scenario.model == MechanismModel.from_preset(name)
    assert scenario.trajectory == Trajectory(circle, speed, "cubic")
    assert (scenario.controller.kp, scenario.sample_time) == (1000.0, 1e-3)
    summary = simulate(scenario).summary()
    keys = {"max_path_error_m", "rms_path_error_m", "max_joint_error", "peak_effort", "min_abs_S", "working_mode"}
    # the same rule for every machine: an orientation where the pose has alpha, the units of its actuators' kind
    revolute = {"max_joint_error_rad", "peak_torque_Nm"}
    prismatic = {"max_joint_error_m", "peak_force_N"}
    orientation = {"max_orientation_error_rad", "max_alpha_error_rad"}
    expected = {"five_bar": keys | revolute, "3rpr": keys | orientation | prismatic,
                "3prr": keys | orientation | prismatic}[name]
    assert set(summary) == expected
    assert len(summary["peak_effort"]) == len(scenario.model.description.legs)
    assert summary["max_path_error_m"] < 1e-4


# A structure pkmlab ships no kernels for (one leg of each type): generated at first use, then cached.
MIXED = """
[mechanism]
name = "one leg of each kind"

[mechanism.platform]
kind = "rigid"
attachments = [[-0.0625, -0.036], [0.0625, -0.036], [0.0, 0.072]]
mass = 0.234
inertia = 0.000305

[[mechanism.leg]]
base = [0.0, 0.0]
joints = "R*RR"
bodies = [{ tip = [0.25, 0.0], mass = 0.468, com = [0.125, 0.0], inertia = 2.438e-3 },
          { tip = [0.1667, 0.0], mass = 0.312, com = [0.08335, 0.0], inertia = 0.722e-3 }]

[[mechanism.leg]]
base = [0.52, 0.0]
joints = "RP*R"
stroke = [0.1, 0.45]
bodies = [{ tip = [0.0, 0.0], mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 },
          { tip = [0.0, 0.0], mass = 0.25, com = [-0.06, 0.0], inertia = 0.6e-3 }]

[[mechanism.leg]]
base = [0.26, 0.45]
joints = "P*RR"
axis = 4.18879
stroke = [0.0, 0.52]
bodies = [{ tip = [0.0, 0.0], mass = 0.6 },
          { tip = [0.25, 0.0], mass = 0.25, com = [0.125, 0.0], inertia = 0.8e-3 }]
"""


def test_a_machine_of_a_new_structure_is_generated_and_controlled(tmp_path):


    (tmp_path / "mixed.toml").write_text(MIXED)
    scenario_file = tmp_path / "mixed_run.toml"
    scenario_file.write_text('[mechanism]\nfile = "mixed.toml"\n\n[trajectory]\ntype = "circle"\n'
                             "center = [0.25, 0.2]\nradius = 0.02\nspeed = 0.1\nalpha = 0.1\n")
    scenario = load_scenario(scenario_file)
    model = scenario.model
    assert model.description.notation == "R*RR + RP*R + P*RR"
    # FK∘IK: the configuration of every working mode that reaches the pose (a slider may need more than
    # its stroke in some) is among the assembly modes of its actuators
    reached = 0
    for mode in mm.working_modes(model):
        try:
            q = mm.inverse_kinematics(model, [0.25, 0.2, 0.1], mode)
        except UnreachablePoseError as exc:
            assert "leg 3" in str(exc) and "stroke" in str(exc)
            continue
        reached += 1
        poses = [sol for sol, _s in assembly.assembly_modes(model, q[:3])]
        assert min(np.abs(p[-3:] - q[-3:]).max() for p in poses) < 1e-9
    assert reached >= 2
    result = simulate(scenario)
    summary = result.summary()
    assert summary["max_path_error_m"] < 1e-4 and len(summary["working_mode"]) == 2


@pytest.mark.parametrize("name", list(EXAMPLES))
def test_desired_actuator_rates_match_differences_of_inverse_kinematics(name):
    from pkmlab.model.mechanism_model import inverse_kinematics, path_rates

    _file, circle, speed = EXAMPLES[name]
    trajectory = Trajectory(circle, speed, "cubic")
    model = MechanismModel.from_preset(name)
    mode = simulate(Scenario(model, trajectory)).working_mode
    dof, n, h = model.description.dof, model.n_actuators, 1e-4
    for t in np.linspace(0.1, trajectory.duration - 0.1, 5):
        pose, pose_dot, pose_ddot = (np.asarray(a)[:, :dof] for a in trajectory.desired([t - h, t, t + h]))
        theta = np.array([inverse_kinematics(model, p, mode)[:n] for p in pose])
        q = inverse_kinematics(model, pose[1], mode)[None, :]
        rate, acceleration, k = path_rates(model, q, pose_dot[1:2], pose_ddot[1:2])
        assert k == -1
        np.testing.assert_allclose(rate[0], (theta[2] - theta[0]) / (2 * h), rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(acceleration[0], (theta[2] - 2 * theta[1] + theta[0]) / h**2, rtol=1e-4,
                                   atol=1e-4)


def test_a_platform_that_can_be_assembled_nowhere_is_refused_naming_the_leg():
    import dataclasses

    from pkmlab.description.mechanism import Body
    from pkmlab.description.presets import preset

    paper = preset("paper")
    tiny = (Body((0.05, 0.0), 0.1, (0.025, 0.0), 1e-4), Body((0.05, 0.0), 0.1, (0.025, 0.0), 1e-4))
    short = dataclasses.replace(paper, legs=tuple(dataclasses.replace(leg, bodies=tiny) for leg in paper.legs))
    with pytest.raises(InvalidParameterError, match=r"assembled nowhere: leg 2 reaches .* together with legs 1\.\.1"):
        MechanismModel.from_description(short)
    # one leg too far away is enough: the two others reach together, the third cannot join them
    legs = (*paper.legs[:2], dataclasses.replace(paper.legs[2], base=(0.26, 2.0)))
    with pytest.raises(InvalidParameterError, match=r"leg 3 reaches .* together with legs 1\.\.2"):
        MechanismModel.from_description(dataclasses.replace(paper, legs=legs))


def test_an_orientation_asked_of_a_point_is_refused_not_ignored():
    data = {"mechanism": {"preset": "five_bar"},
            "trajectory": {"type": "circle", "center": [0.0, 0.35], "radius": 0.06, "speed": 0.3, "alpha": 0.3}}
    with pytest.raises(InvalidParameterError, match=r"tracks a point \(x, y\).*alpha = 0\.3 rad at t = 0\.0000 s"):
        simulate(scenario_from_dict(data, "tilted.toml"))


def test_the_working_mode_tie_rule_is_within_1e_9_of_the_best(monkeypatch):
    # conventions §3: the largest min |S|; modes within 1e-9 of it tie, and the first of them wins — even when
    # a mode in between is within 1e-9 of both its neighbours (a chain of near-ties)

    from pkmlab.simulation.run import sample_times
    from pkmlab.simulation.scenario import choose_working_mode

    scenario = load_scenario(Path(__file__).parents[1] / "examples" / "five_bar_circle.toml")
    min_s = {(1, 1): 0.5, (1, -1): 0.5 + 0.6e-9, (-1, 1): 0.5 + 1.2e-9, (-1, -1): 0.1}
    modes = list(min_s)

    def configurations(model, poses, mode, follow=False, branches=None, rows=None):  # each names its mode
        return np.full((len(poses), 1), float(modes.index(tuple(mode))))[slice(None) if rows is None else rows], None

    def measures(model, q):
        return np.full(len(q), min_s[modes[int(q[0, 0])]])

    monkeypatch.setattr(mm, "working_modes", lambda model: modes)
    monkeypatch.setattr(mm, "path_configurations", configurations)
    monkeypatch.setattr(mm, "configuration_measures", measures)
    mode, best = choose_working_mode(scenario, sample_times(scenario))
    assert mode == (1, -1) and best == min_s[(1, -1)]


@pytest.mark.parametrize("name", ["paper", "five_bar_circle.toml", "3rpr_circle.toml", "delta_pick_and_place.toml"])
def test_the_working_mode_is_the_one_every_modes_whole_path_gives(name):
    """conventions §3 by brute force — every mode's inverse kinematics and |S| along the whole path, the largest
    min |S| (the first mode within 1e-9 of it) — against the choice, which measures each path's sparse samples first
    and stops a mode there; the same in pieces (a long run's), and with the modes' min |S| the same numbers."""
    from pkmlab.simulation.run import sample_times
    from pkmlab.simulation.scenario import best_working_mode

    scenario = paper_scenario("nominal") if name == "paper" else load_scenario(
        Path(__file__).parents[1] / "examples" / name)
    model, t = scenario.model, sample_times(scenario)
    pose = np.ascontiguousarray(np.asarray(scenario.trajectory.desired(t)[0], dtype=float)[:, :model.dof])
    lowest = {}
    for mode in mm.working_modes(model):
        _q, s, failure = mm.path_inverse_kinematics(model, pose, mode, follow=True)
        if failure is None:
            lowest[tuple(mode)] = float(np.abs(s).min())
    top = max(lowest.values())
    expected = next(mode for mode, value in lowest.items() if value >= top - 1e-9)
    mode, min_s, q = best_working_mode(scenario, t, pose)
    assert (mode, min_s) == (expected, lowest[expected])
    np.testing.assert_array_equal(q, mm.path_inverse_kinematics(model, pose, expected, follow=True)[0])
    assert best_working_mode(scenario, t, pose, piece=97)[:2] == (expected, lowest[expected])


@pytest.mark.parametrize("name", ["paper", "delta_pick_and_place.toml"])
def test_the_configurations_of_some_poses_are_those_rows_of_every_poses(name):
    """Inverse kinematics asked for some rows of a path (the working mode's choice measures every 16th sample first)
    gives those rows of the whole path's configurations bit for bit, NaN where a leg cannot reach, and the whole
    path's failures: a pose out of reach among the rows not asked for is still the first failure."""
    from pkmlab.simulation.run import sample_times

    scenario = paper_scenario("nominal") if name == "paper" else load_scenario(
        Path(__file__).parents[1] / "examples" / name)
    model, t = scenario.model, sample_times(scenario)
    pose = np.asarray(scenario.trajectory.desired(t)[0], dtype=float)[:, :model.dof]
    pose = np.ascontiguousarray(np.insert(pose, [5, 31], pose[[5, 31]] + 10.0, axis=0))  # out of reach: rows 5, 32
    rows = slice(None, None, 16)
    for mode in mm.working_modes(model):
        q, unreachable, first = mm.inverse_kinematics_batch(model, pose, mode, follow=True)
        some, some_unreachable, some_first = mm.inverse_kinematics_batch(model, pose, mode, follow=True,
                                                                         branches={}, rows=rows)
        np.testing.assert_array_equal(some, q[rows])
        assert np.isnan(some[2]).all() and not np.isnan(some[1]).any()  # row 32 asked for (the third), row 5 not
        np.testing.assert_array_equal(some_unreachable, unreachable)
        assert some_first[:2] == first[:2] == (5, first[1])


def test_a_working_mode_spelt_with_floats_is_kept_as_ints():
    data = {"mechanism": {"preset": "five_bar"}, "simulation": {"working_mode": [1.0, -1.0]},
            "trajectory": {"type": "circle", "center": [0.0, 0.35], "radius": 0.06, "speed": 0.3}}
    mode = scenario_from_dict(data, "floats.toml").working_mode
    assert mode == (1, -1) and all(type(v) is int for v in mode)
