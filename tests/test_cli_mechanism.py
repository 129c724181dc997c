"""`pkmlab ik` and `pkmlab fk` for every machine (`--mechanism NAME|FILE.toml`), with their JSON contracts:
ik gives {"solutions": [{"mode", "actuators", "S"}]}, fk {"solutions": [{"pose", "S"}]}."""

import json
import math

import pytest
from conftest import assert_user_error, run

from pkmlab.mechanisms.description import mechanism_to_toml
from pkmlab.mechanisms.presets import preset

POSES = {"paper": [0.2, 0.21, 0.0], "five_bar": [0.0, 0.35], "3rpr": [0.25, 0.21, -math.pi / 2],
         "3prr": [0.26, 0.2, 0.0]}


def run_json(capsys, *argv):
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


@pytest.mark.parametrize("name", sorted(POSES))
def test_ik_then_fk_gives_back_the_pose_for_every_working_mode(capsys, name):
    pose = POSES[name]
    solutions = run_json(capsys, "ik", "--mechanism", name, *pose)["solutions"]
    assert solutions and all(set(s) == {"mode", "actuators", "S"} for s in solutions)
    assert len(solutions[0]["mode"]) == {"paper": 3, "five_bar": 2, "3rpr": 0, "3prr": 3}[name]
    for s in solutions:
        assert len(s["actuators"]) == len(pose) and math.isfinite(s["S"])
        found = run_json(capsys, "fk", "--mechanism", name, *s["actuators"])["solutions"]
        assert all(set(f) == {"pose", "S"} and len(f["pose"]) == len(pose) for f in found)
        gaps = [max(abs(math.remainder(a - b, 2 * math.pi)) for a, b in zip(f["pose"], pose, strict=True))
                for f in found]
        assert min(gaps) < 1e-10


def test_the_paper_through_mechanism_gives_todays_angles(capsys):
    today = run_json(capsys, "ik", 0.2, 0.21, 0)["solutions"]
    generic = run_json(capsys, "ik", "--mechanism", "paper", 0.2, 0.21, 0)["solutions"]
    assert [s["mode"] for s in generic] == [s["mode"] for s in today]
    for a, b in zip(generic, today, strict=True):
        assert all(abs(math.remainder(x - y, 2 * math.pi)) < 1e-12 for x, y in zip(a["actuators"], b["theta"],
                                                                                     strict=True))


def test_a_description_file_is_a_mechanism(capsys, tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(mechanism_to_toml(preset("3rpr")).replace("0.45]", "0.5]"))
    solutions = run_json(capsys, "ik", "--mechanism", path, 0.25, 0.21, -1.5)["solutions"]
    assert len(solutions) == 1 and solutions[0]["mode"] == []


@pytest.mark.parametrize("argv, expected", [
    (["ik", "--mechanism", "five_bar", 0.0, 0.35, 0.0], "the pose (x, y): 2 numbers"),
    (["fk", "--mechanism", "3rpr", 0.3, 0.3], "the actuator values: 3 numbers"),
    (["ik", 0.2, 0.21], "(x y alpha): 3 numbers"),
])
def test_a_wrong_count_of_numbers_is_a_malformed_command_line(capsys, argv, expected):
    with pytest.raises(SystemExit) as info:
        run(capsys, *argv)
    assert info.value.code == 2 and expected in capsys.readouterr().err


@pytest.mark.parametrize("argv, expected", [
    (["ik", "--mechanism", "scara", 0.0, 0.0, 0.0], "not a preset"),
    (["ik", "--mechanism", "five_bar", 0.0, 0.35, "--mode", "+"], "--mode must be one of"),
    (["ik", "--mechanism", "3rpr", 0.25, 0.6, -1.57], "leg 1 needs its actuator at 0.696137 m, outside its stroke"),
    (["ik", "--mechanism", "missing.toml", 0.0, 0.0, 0.0], "missing.toml"),
])
def test_errors_are_one_line(capsys, argv, expected):
    message = assert_user_error(*run(capsys, *argv))
    assert expected in message, message


# ------------------------------------------------------------------ dynamics --mechanism
def test_dynamics_of_the_paper_through_mechanism_is_todays(capsys):
    argv = [0.189, 3.112, -2.642, "--theta-dot", 0.3, -0.2, 0.5, "--near", 0.2, 0.21, 0]
    today = run_json(capsys, "dynamics", *argv)
    generic = run_json(capsys, "dynamics", "--mechanism", "paper", *argv)
    assert set(generic) == {"M", "c", "g", "S", "pose"}
    for a, b in zip(generic["M"], today["M_theta"], strict=True):
        assert all(abs(x - y) <= 1e-12 * abs(y) + 1e-15 for x, y in zip(a, b, strict=True))
    assert all(abs(x - y) <= 1e-11 * abs(y) + 1e-15 for x, y in zip(generic["c"], today["c_theta"], strict=True))
    assert generic["g"] == [0.0, 0.0, 0.0] and abs(generic["S"] - today["S"]) < 1e-10


def test_gravity_effort_is_the_slope_of_the_potential_energy(capsys, tmp_path):
    """A five-bar in a vertical plane: g = dV/dtheta, V summed over the bodies at the forward kinematics."""
    import dataclasses

    import numpy as np

    from pkmlab import mechanism_model as mm

    vertical = dataclasses.replace(preset("five_bar"), name="vertical five-bar", gravity=(0.0, -9.81))
    path = tmp_path / "vertical.toml"
    path.write_text(mechanism_to_toml(vertical))
    model = mm.MechanismModel.from_description(vertical)
    q0 = mm.inverse_kinematics(model, [0.02, 0.33], (1, -1))
    theta = q0[:2]
    record = run_json(capsys, "dynamics", "--mechanism", path, *theta, "--near", 0.02, 0.33)
    masses = model.body_weights[:, 0]

    def potential(t):
        q = min((q for q, _s in mm.forward_kinematics(model, t)), key=lambda q: np.hypot(*(q[-2:] - q0[-2:])))
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
    from pkmlab import mechanism_model as mm

    model = mm.MechanismModel.from_preset("3rpr")
    q = mm.inverse_kinematics(model, [0.24, 0.17, 0.003], ())  # alpha = 0 is singular for this 3-RPR
    code, out, err = run(capsys, "dynamics", "--mechanism", "3rpr", *q[:3], "--near", 0.24, 0.17, 0.003, "--json")
    assert code == 0 and "near a gain-type singularity" in json.loads(out)["warning"] and "warning" in err


def test_simulate_then_animate_a_five_bar_run(capsys, tmp_path):
    from pathlib import Path

    from pkmlab.mechanisms.description import load_mechanism

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
