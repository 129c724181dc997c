"""`pkmlab ik`, `fk` and `dynamics` for every machine (`--mechanism NAME|FILE.toml`, the paper by default), with
one JSON contract per command for all of them:

* ik: {"mechanism", "pose_names", "solutions": [{"mode", "theta", "passive", "S"}, ...]}
* fk: {"mechanism", "pose_names", "solutions": [{"pose", "passive", "S"}, ...]}
* dynamics: {"mechanism", "pose_names", "tau_from", "solutions": [{"pose", "passive", "S", "M", "c", "g", "tau",
  "multipliers"}, ...]}

and one answer when there is none: exit code 1 and one line (or the JSON error object).
"""

import json
import math

import numpy as np
import pytest
from conftest import assert_user_error, run

from pkmlab.description.files import mechanism_to_toml
from pkmlab.description.presets import preset

POSES = {"paper": [0.2, 0.21, 0.0], "five_bar": [0.0, 0.35], "3rpr": [0.25, 0.21, -math.pi / 2],
         "3prr": [0.26, 0.2, 0.0], "delta": [0.05, -0.03, -0.75], "stewart": [0.0, 0.0, 0.85, 0.05, -0.03, 0.1]}
#: What each machine's description says: pose names, actuators, passive coordinates, signs of a working mode.
SHAPES = {"paper": (("x", "y", "alpha"), 3, 3, 3), "five_bar": (("x", "y"), 2, 2, 2),
          "3rpr": (("x", "y", "alpha"), 3, 3, 0), "3prr": (("x", "y", "alpha"), 3, 3, 3),
          "delta": (("x", "y", "z"), 3, 6, 3),
          "stewart": (("x", "y", "z", "roll", "pitch", "yaw"), 6, 12, 0)}
IK_KEYS, FK_KEYS = {"mode", "theta", "passive", "S"}, {"pose", "passive", "S"}
DYNAMICS_KEYS = {"pose", "passive", "S", "M", "c", "g", "tau", "multipliers"}


def run_json(capsys, *argv):
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


def gap(pose, other) -> float:
    """Largest difference of two poses, angles the short way round."""
    return max(abs(math.remainder(a - b, 2 * math.pi)) for a, b in zip(pose, other, strict=True))


@pytest.mark.parametrize("name", ["paper", "five_bar", "3rpr", "3prr", "delta"])
def test_ik_then_fk_gives_back_the_pose_for_every_working_mode(capsys, name):
    pose = POSES[name]
    solutions = run_json(capsys, "ik", "--mechanism", name, *pose)["solutions"]
    assert solutions and all(set(s) == IK_KEYS for s in solutions)
    assert len(solutions[0]["mode"]) == SHAPES[name][3]
    for s in solutions:
        assert len(s["theta"]) == SHAPES[name][1] and math.isfinite(s["S"])
        found = run_json(capsys, "fk", "--mechanism", name, *s["theta"])["solutions"]
        assert all(set(f) == FK_KEYS and len(f["pose"]) == len(pose) for f in found)
        # one assembly mode is the pose, with the passive coordinates of this working mode
        nearest = min(found, key=lambda f: gap(f["pose"], pose))
        assert gap(nearest["pose"], pose) < 1e-10
        assert gap(nearest["passive"], s["passive"]) < 1e-9


@pytest.mark.parametrize("name", ["paper", "five_bar", "delta"])
def test_fk_of_ik_round_trips_with_the_default_output_too(capsys, name):
    """The same round trip as the executable's user sees it: ik's table, then fk's table (six decimals)."""
    pose = POSES[name]
    argv = [] if name == "paper" else ["--mechanism", name]  # the paper is the default machine
    code, out, err = run(capsys, "ik", *argv, *pose)
    assert code == 0 and err == ""
    lines = out.strip().splitlines()
    n = SHAPES[name][1]
    assert lines[1].split()[:n + 1] == ["mode", *(f"theta{i + 1}" for i in range(n))]
    for row in lines[2:]:
        theta = row.split()[-(n + SHAPES[name][2] + 1):][:n]  # after the mode, which may have spaces
        code, out, err = run(capsys, "fk", *argv, "--", *theta)
        assert code == 0 and err == ""
        table = out.strip().splitlines()
        assert table[1].split()[:len(pose) + 1] == ["#", *SHAPES[name][0]]
        assert table[-1].startswith("method: ")  # the completeness statement closes the table
        poses = [[float(v) for v in line.split()[1:len(pose) + 1]] for line in table[2:-1]]
        assert min(gap(p, pose) for p in poses) < 1e-4  # the actuators were rounded to 6 decimals


def test_the_paper_is_the_default_and_answers_as_its_own_formulation(capsys):
    """The paper's machine by default, by name and through the paper's own 7-coordinate formulation
    (pkmlab.paper.kinematics, the oracle of its tests) give the same working modes, actuators and passive angles."""
    from pkmlab.paper import kinematics
    from pkmlab.paper.geometry import Planar3RRR

    default = run_json(capsys, "ik", 0.2, 0.21, 0)
    named = run_json(capsys, "ik", "--mechanism", "paper", 0.2, 0.21, 0)
    assert default == named and default["mechanism"] == "paper"
    own = kinematics.inverse_kinematics(Planar3RRR.paper(), [0.2, 0.21, 0.0])
    assert [s["mode"] for s in default["solutions"]] == own.modes.tolist()
    for s, q, s_own in zip(default["solutions"], own.q, own.S, strict=True):
        assert gap(s["theta"], q[:3]) < 1e-12 and gap(s["passive"], q[3:6]) < 1e-12
        assert s["S"] == pytest.approx(s_own, abs=1e-12)


def test_a_description_file_is_a_mechanism(capsys, tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(mechanism_to_toml(preset("3rpr")).replace("0.45]", "0.5]"))
    solutions = run_json(capsys, "ik", "--mechanism", path, 0.25, 0.21, -1.5)["solutions"]
    assert len(solutions) == 1 and solutions[0]["mode"] == []


@pytest.mark.parametrize("argv, expected", [
    (["ik", "--mechanism", "five_bar", 0.0, 0.35, 0.0], "the pose (x, y): 2 numbers"),
    (["fk", "--mechanism", "3rpr", 0.3, 0.3], "the actuator values: 3 numbers"),
    (["ik", 0.2, 0.21], "the pose (x, y, alpha): 3 numbers"),
    (["fk", 0.2, 0.21], "the actuator values: 3 numbers"),
    (["ik", "--mechanism", "five_bar", 0.0, 0.35, "--mode", "+"], "--mode: 2 signs for the five_bar"),
    (["ik", 0.2, 0.21, 0, "--mode", "+", "-"], "--mode: 3 signs for the paper"),
    (["ik", "--mechanism", "3rpr", 0.25, 0.21, -1.5, "--mode", "+"], "has one working mode: no --mode"),
    (["dynamics", 0.19, 3.11, -2.64, "--tau", 1.0], "--tau: 3 numbers"),
])
def test_a_wrong_count_of_numbers_is_a_malformed_command_line(capsys, argv, expected):
    with pytest.raises(SystemExit) as info:
        run(capsys, *argv)
    assert info.value.code == 2 and expected in capsys.readouterr().err


@pytest.mark.parametrize("argv, expected", [
    (["ik", "--mechanism", "scara", 0.0, 0.0, 0.0], "not a preset"),
    (["ik", "--mechanism", "five_bar", 0.0, 0.35, "--mode", "+", "x"], "--mode: a working mode is signs"),
    (["ik", "--mechanism", "3rpr", 0.25, 0.6, -1.57], "leg 1 needs its actuator at 0.696137 m, outside its stroke"),
    (["ik", "--mechanism", "missing.toml", 0.0, 0.0, 0.0], "missing.toml"),
])
def test_errors_are_one_line(capsys, argv, expected):
    message = assert_user_error(*run(capsys, *argv))
    assert expected in message, message


# ------------------------------------------------------------------ dynamics --mechanism
# ------------------------------------------------------------------ one contract for every machine
@pytest.mark.parametrize("name", sorted(POSES))
def test_every_preset_answers_ik_fk_and_dynamics_with_the_same_keys(capsys, name):
    pose_names, n, passive, signs = SHAPES[name]
    pose = POSES[name]
    ik = run_json(capsys, "ik", "--mechanism", name, *pose)
    assert set(ik) == {"mechanism", "pose_names", "solutions"} and ik["mechanism"] == name
    assert ik["pose_names"] == list(pose_names)
    for s in ik["solutions"]:
        assert set(s) == IK_KEYS and len(s["mode"]) == signs and len(s["theta"]) == n and len(s["passive"]) == passive
    theta = max(ik["solutions"], key=lambda s: abs(s["S"]))["theta"]
    fk = run_json(capsys, "fk", "--mechanism", name, *theta)
    assert set(fk) == {"mechanism", "pose_names", "solutions", "method"} and fk["pose_names"] == list(pose_names)
    assert "complete" in fk["method"]
    for s in fk["solutions"]:
        assert set(s) == FK_KEYS and len(s["pose"]) == len(pose_names) and len(s["passive"]) == passive
    dynamics = run_json(capsys, "dynamics", "--mechanism", name, *theta, "--rates", *[0.1] * n, "--near", *pose)
    assert set(dynamics) == {"mechanism", "pose_names", "tau_from", "solutions"}
    assert dynamics["pose_names"] == list(pose_names) and dynamics["tau_from"].startswith("c + g")
    (s,) = dynamics["solutions"]
    assert set(s) == DYNAMICS_KEYS and gap(s["pose"], pose) < 1e-9
    assert np.shape(s["M"]) == (n, n) and len(s["c"]) == len(s["g"]) == len(s["tau"]) == n
    np.testing.assert_allclose(s["tau"], np.add(s["c"], s["g"]), rtol=1e-15, atol=0)  # no --tau: zero acceleration
    assert len(s["multipliers"]) == (3 if name in ("delta", "stewart") else 2) * n  # a force per leg's closure


def test_dynamics_of_the_paper_is_its_own_formulations(capsys):
    """The paper's actuator-space model by default equals the paper's own 7-coordinate formulation
    (pkmlab.paper.dynamics), and its multipliers solve the full model's equations of motion (eq. 26)."""
    from pkmlab.paper import dynamics, kinematics
    from pkmlab.paper.geometry import Planar3RRR

    theta, rates, near = [0.189, 3.112, -2.642], [0.3, -0.2, 0.5], [0.2, 0.21, 0.0]
    result = run_json(capsys, "dynamics", *theta, "--theta-dot", *rates, "--near", *near)
    assert result["mechanism"] == "paper" and result["pose_names"] == ["x", "y", "alpha"]
    (record,) = result["solutions"]
    paper = Planar3RRR.paper()
    q = kinematics.forward_kinematics(paper, theta).nearest(near).q
    m_theta, c_theta = dynamics.actuator_space_model(paper, q, rates)
    np.testing.assert_allclose(record["M"], m_theta, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(record["c"], c_theta, rtol=1e-11, atol=1e-15)
    assert record["g"] == [0.0, 0.0, 0.0]  # the paper's machine lies in a horizontal plane
    assert record["S"] == pytest.approx(float(kinematics.singularity_measure(paper, q)), abs=1e-10)
    assert gap(record["passive"], q[3:6]) < 1e-10


def test_the_multipliers_are_the_libraries_and_vanish_at_rest_without_efforts(capsys):
    """--tau given: the multipliers are pkmlab.constrained_dynamics' at the state; the paper at rest under no
    effort (and no gravity) stays at rest, its loops closed by no force."""
    import pkmlab

    theta, rates, tau = [0.189, 3.112, -2.642], [0.3, -0.2, 0.5], [0.05, -0.02, 0.01]
    result = run_json(capsys, "dynamics", *theta, "--rates", *rates, "--tau", *tau, "--near", 0.2, 0.21, 0)
    assert result["tau_from"] == "--tau"
    (record,) = result["solutions"]
    assert record["tau"] == tau
    model = pkmlab.load("paper")
    q = pkmlab.forward_kinematics(model, theta).nearest([0.2, 0.21, 0.0]).q
    motion = pkmlab.constrained_dynamics(model, q, pkmlab.coordinate_rates(model, q, rates), tau)
    np.testing.assert_allclose(record["multipliers"], motion.multipliers, rtol=1e-12, atol=1e-14)
    at_rest = run_json(capsys, "dynamics", *theta, "--tau", 0, 0, 0)
    assert len(at_rest["solutions"]) == 2
    for record in at_rest["solutions"]:
        assert np.abs(record["multipliers"]).max() < 1e-13 and len(record["multipliers"]) == 6
    default = run_json(capsys, "dynamics", *theta)  # no --tau, at rest: tau = c + g = 0 for the paper
    assert [r["multipliers"] for r in default["solutions"]] == [r["multipliers"] for r in at_rest["solutions"]]


@pytest.mark.parametrize("name", ["five_bar", "delta"])
def test_the_multipliers_of_a_machine_held_still_carry_its_platforms_weight(capsys, tmp_path, name):
    """At rest under tau = c + g (no --tau: zero actuator acceleration, so nothing moves) each leg's multipliers
    are the force it exerts on the platform's attachment point (the chain's end minus the attachment point is
    the constraint, so dV/dpose = -sum of the legs' forces): together they carry the platform's weight."""
    import dataclasses

    machine = preset(name)
    if name == "five_bar":  # in a vertical plane
        machine = dataclasses.replace(machine, name="vertical five-bar", gravity=(0.0, -9.81))
    path = tmp_path / "machine.toml"
    path.write_text(mechanism_to_toml(machine))
    pose = {"five_bar": [0.02, 0.33], "delta": POSES["delta"]}[name]
    (solution, *_) = run_json(capsys, "ik", "--mechanism", path, *pose)["solutions"]
    (record,) = run_json(capsys, "dynamics", "--mechanism", path, *solution["theta"], "--near", *pose)["solutions"]
    dim = len(machine.gravity)
    forces = np.reshape(record["multipliers"], (len(machine.legs), dim))
    np.testing.assert_allclose(forces.sum(axis=0), machine.platform.mass * np.array(machine.gravity), atol=1e-9)
    assert np.abs(forces).max() > 0.1  # the legs do carry something


# ------------------------------------------------------------------ no answer: exit 1, one line, every machine
NO_ASSEMBLY = {"paper": [0.0, 0.0, 0.0], "five_bar": [math.pi, 0.0]}


def test_the_actuators_of_no_assembly_are_far_apart():
    # paper: every elbow at b_i + (l, 0); e1 and e2 are b = 0.52 apart while p1, p2 must be a = 0.125 apart within
    # r = 0.1667 of them. five-bar: elbows at (-0.1 - 0.25, 0) and (0.1 + 0.25, 0), 0.7 apart, farther than the
    # two distal links of 0.3 m reach.
    assert 0.52 - 2 * 0.1667 > 0.125
    assert (0.1 + 0.25) * 2 > 2 * 0.3
    assert [b.tip[0] for b in preset("five_bar").legs[0].bodies] == [0.25, 0.3]


@pytest.mark.parametrize("name", sorted(NO_ASSEMBLY))
@pytest.mark.parametrize("command", ["fk", "dynamics"])
def test_no_assembly_mode_is_exit_1_and_one_line(capsys, name, command):
    argv = [command, "--mechanism", name, *NO_ASSEMBLY[name]]
    message = assert_user_error(*run(capsys, *argv))
    assert message.startswith(f"pkmlab {command}: error: ") and "cannot be assembled" in message
    code, out, err = run(capsys, *argv, "--json")
    assert code == 1 and err == "" and out.count("\n") == 1
    error = json.loads(out)["error"]
    assert error["type"] == "AssemblyError" and "cannot be assembled" in error["message"]


@pytest.mark.parametrize("name, pose", [("paper", [5.0, 5.0, 0.0]), ("five_bar", [1.0, 1.0]),
                                        ("delta", [0.0, 0.0, -3.0])])
def test_no_reachable_working_mode_is_exit_1_and_one_line(capsys, name, pose):
    message = assert_user_error(*run(capsys, "ik", "--mechanism", name, *pose))
    assert "out of reach in every working mode" in message
    code, out, err = run(capsys, "ik", "--mechanism", name, *pose, "--json")
    assert code == 1 and err == "" and json.loads(out)["error"]["type"] == "UnreachablePoseError"


def test_gravity_effort_is_the_slope_of_the_potential_energy(capsys, tmp_path):
    """A five-bar in a vertical plane: g = dV/dtheta, V summed over the bodies at the forward kinematics."""
    import dataclasses

    import numpy as np

    from pkmlab.algorithms import assembly
    from pkmlab.model import mechanism_model as mm

    vertical = dataclasses.replace(preset("five_bar"), name="vertical five-bar", gravity=(0.0, -9.81))
    path = tmp_path / "vertical.toml"
    path.write_text(mechanism_to_toml(vertical))
    model = mm.MechanismModel.from_description(vertical)
    q0 = mm.inverse_kinematics(model, [0.02, 0.33], (1, -1))
    theta = q0[:2]
    (record,) = run_json(capsys, "dynamics", "--mechanism", path, *theta, "--near", 0.02, 0.33)["solutions"]
    masses = model.body_weights[:, 0]

    def potential(t):
        q = min((q for q, _s in assembly.assembly_modes(model, t)), key=lambda q: np.hypot(*(q[-2:] - q0[-2:])))
        poses = np.empty((model.kernels.N_BODIES, 3))
        model.kernels.body_poses(q, mm.trig_table(model, q), model.P, poses)
        return float(np.sum(masses * 9.81 * poses[:, 1]))

    h = 1e-6
    slope = [(potential(theta + h * e) - potential(theta - h * e)) / (2 * h) for e in np.eye(2)]
    np.testing.assert_allclose(record["g"], slope, rtol=1e-6, atol=1e-9)
    assert max(abs(v) for v in record["g"]) > 0.1  # it does hold something up


def test_dynamics_mechanism_errors(capsys):
    with pytest.raises(SystemExit) as info:
        run(capsys, "dynamics", "--mechanism", "five_bar", 2.2, 0.9, "--rates", 1.0)
    assert info.value.code == 2 and "--rates: 2 numbers" in capsys.readouterr().err
    message = assert_user_error(*run(capsys, "dynamics", "--mechanism", "five_bar", 2.2, 0.9, "--rates", "1e200", 0))
    assert "overflows" in message


def test_dynamics_mechanism_warns_near_a_singularity(capsys):
    from pkmlab.model import mechanism_model as mm

    model = mm.MechanismModel.from_preset("3rpr")
    q = mm.inverse_kinematics(model, [0.24, 0.17, 0.003], ())  # alpha = 0 is singular for this 3-RPR
    code, out, err = run(capsys, "dynamics", "--mechanism", "3rpr", *q[:3], "--near", 0.24, 0.17, 0.003, "--json")
    (record,) = json.loads(out)["solutions"]
    assert code == 0 and "near a gain-type singularity" in record["warning"] and "warning" in err
    assert "multipliers" in record["warning"]


def test_simulate_then_animate_a_five_bar_run(capsys, tmp_path):
    from pathlib import Path

    from pkmlab.description.files import load_mechanism

    example = Path(__file__).parents[1] / "examples" / "five_bar_circle.toml"
    out = tmp_path / "run"
    summary = run_json(capsys, "simulate", example, "--out", out, "--quiet")
    assert summary["working_mode"] == [1, -1] and len(summary["peak_effort"]) == 2
    assert "max_orientation_error_rad" not in summary  # a point has no orientation
    header = (out / "run.csv").read_text().splitlines()[0]
    assert header == "t,theta1,theta2,theta1_d,theta2_d,tau1,tau2,x,y,x_d,y_d,S"
    assert load_mechanism(out / "plant.toml") == preset("five_bar")
    assert (out / "machine.png").stat().st_size > 0 and not (out / "alpha.png").exists()
    gif = tmp_path / "run.gif"
    made = run_json(capsys, "animate", out, "--out", gif, "--stride", 200, "--quiet")
    assert made["frames"] == 7 and gif.stat().st_size > 0
    # the machine rebuilt from the recorded actuators puts the end point where the run recorded it
    assert made["max_centroid_deviation_m"] < 1e-9


def test_a_scenario_runs_on_another_machine_with_mechanism(capsys, tmp_path):
    from pathlib import Path

    example = Path(__file__).parents[1] / "examples" / "3prr_circle.toml"
    on_five_bar = run_json(capsys, "simulate", example, "--mechanism", "five_bar", "--out", tmp_path / "x", "--quiet",
                           "--no-figures")
    assert len(on_five_bar["working_mode"]) == 2 and on_five_bar["max_path_error_m"] < 1e-4
    assert "max_orientation_error_rad" not in on_five_bar  # the five-bar tracks the path's points only
    # the 3-RPR is singular everywhere at this path's alpha = 0: refused before simulating, nothing written
    code, _out, err = run(capsys, "simulate", example, "--mechanism", "3rpr", "--out", tmp_path / "y", "--quiet")
    assert code == 1 and "whole path lies within |S| < 0.05" in err and not (tmp_path / "y").exists()


@pytest.mark.parametrize("name", ["five_bar", "3rpr"])
def test_maps_of_other_machines(capsys, tmp_path, name):
    smap = run_json(capsys, "singularity-map", "--mechanism", name, "--resolution", 31, "--out",
                    tmp_path / "s.png", "--quiet", *(["--alpha", -1.5] if name == "3rpr" else []))
    assert smap["mode"] == ([1, 1] if name == "five_bar" else []) and 0 < smap["reachable_fraction"] < 1
    ws = run_json(capsys, "workspace", "--mechanism", name, "--resolution", 31, "--out", tmp_path / "w.png",
                  "--quiet")
    assert len(ws["areas"]) == (4 if name == "five_bar" else 1)
    assert all(a["area_m2"] > 0 for a in ws["areas"])


def test_animate_refuses_params_with_mechanism(capsys, tmp_path):
    from pathlib import Path

    example = Path(__file__).parents[1] / "examples" / "five_bar_circle.toml"
    out = tmp_path / "run"
    run_json(capsys, "simulate", example, "--out", out, "--quiet", "--no-figures")
    params = tmp_path / "p.toml"
    params.write_text('[manipulator]\npreset = "paper"\n')
    code, _out, err = run(capsys, "animate", out, "--mechanism", "five_bar", "--params", params, "--out",
                          tmp_path / "x.gif")
    assert code == 1 and "--params describes the paper's 3-RRR" in err and not (tmp_path / "x.gif").exists()


@pytest.mark.parametrize("command", ["singularity-map", "workspace"])
def test_an_orientation_for_a_platform_without_one_is_refused(tmp_path, capsys, command):
    """The five-bar's platform is a point (x, y): --alpha would be silently ignored, and the map titled with an
    orientation it does not have. Refused by name, nothing written; without --alpha the map is drawn."""
    out = tmp_path / "map.png"
    message = assert_user_error(*run(capsys, command, "--mechanism", "five_bar", "--alpha", "0.3", "--resolution",
                                     "21", "--out", out))
    assert "--alpha" in message and "no orientation" in message and not out.exists()
    code, stdout, _err = run(capsys, command, "--mechanism", "five_bar", "--resolution", "21", "--out", out)
    assert code == 0 and out.exists() and "alpha" not in stdout.splitlines()[0]


def test_ik_warns_of_a_solution_near_a_gain_type_singularity(capsys):
    """As the other commands do: ik at a pose where a working mode's |S| is tiny says so on stderr (one line
    naming the mode and |S|), and says nothing at a regular pose. The singular pose is found independently of
    the command: by bisection on x of the sign of S in one working mode."""
    import pkmlab

    model = pkmlab.load("paper")
    mode = (1, -1, 1)

    def s_at(x):
        return float(pkmlab.inverse_kinematics(model, [x, 0.21, 0.0], mode=mode, on_unreachable="nan").S)

    xs = np.linspace(0.05, 0.45, 161)
    s = np.array([s_at(x) for x in xs])
    k = next(i for i in range(len(xs) - 1) if np.isfinite(s[i:i + 2]).all() and s[i] * s[i + 1] < 0)
    lo, hi = xs[k], xs[k + 1]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if s_at(mid) * s_at(lo) > 0 else (lo, mid)
    assert abs(s_at(lo)) < 1e-6
    code, _out, err = run(capsys, "ik", repr(float(lo)), "0.21", "0", "--mode", "+", "-", "+")
    assert code == 0
    (warning,) = err.strip().splitlines()
    assert warning.startswith("pkmlab ik: warning: working mode (+, -, +) is near a gain-type singularity (|S| = ")
    code, _out, err = run(capsys, "ik", "0.2", "0.21", "0", "--mode", "+", "-", "+")
    assert code == 0 and err == ""
