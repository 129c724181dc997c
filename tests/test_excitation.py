"""Excitation trajectories: the Fourier series against its own finite differences, the optimised motion against
every limit it claims (checked on a finer grid by the public functions, independently of the optimiser's own
evaluation), its condition number recomputed from the regressor, and the loop a user runs — excite, simulate,
identify — giving the machine's base parameters back."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms.identification import scaled_condition_number
from pkmlab.control.excitation import excitation_trajectory
from pkmlab.control.trajectory import FourierTrajectory
from pkmlab.errors import InvalidParameterError
from pkmlab.formats.scenario import fourier_table, scenario_from_dict

PAPER = pkmlab.load("paper")


def _pkmlab(*args, cwd):
    return subprocess.run([sys.executable, "-m", "pkmlab.cli", *args], capture_output=True, text=True, cwd=cwd)


def _rest_coefficients(rng, harmonics, dimension):
    a, b = rng.uniform(-1, 1, (2, harmonics, dimension))
    a[0] = -a[1:].sum(axis=0)
    b[0] = -(np.arange(2, harmonics + 1)[:, None] * b[1:]).sum(axis=0)
    return a, b


def test_the_fourier_series_is_its_own_derivative_and_at_rest_at_each_period():
    rng = np.random.default_rng(4)
    a, b = _rest_coefficients(rng, 4, 3)
    tr = FourierTrajectory((0.2, 0.1, 0.5), 2.0, a, b, periods=2)
    t = np.linspace(0.0, tr.duration, 40_001)
    pose, pose_dot, pose_ddot = tr.desired(t)
    h = t[1] - t[0]
    assert np.abs(np.gradient(pose, h, axis=0) - pose_dot)[1:-1].max() < 1e-5 * np.abs(pose_dot).max()
    assert np.abs(np.gradient(pose_dot, h, axis=0) - pose_ddot)[1:-1].max() < 1e-5 * np.abs(pose_ddot).max()
    for k in (0, 20_000, 40_000):  # t = 0, one period, the end: the centre, at rest
        assert np.allclose(pose[k], tr.center, atol=1e-12)
        assert np.allclose(pose_dot[k], 0.0, atol=1e-12) and np.allclose(pose_ddot[k], 0.0, atol=1e-11)
    after = tr.desired([-1.0, tr.duration + 1.0])
    assert np.allclose(after[0], tr.center) and not np.any(after[1]) and np.allclose(after[2], 0.0, atol=1e-11)


def test_a_series_that_does_not_start_at_rest_is_refused_by_coordinate():
    a, b = _rest_coefficients(np.random.default_rng(1), 3, 2)
    a[2, 1] += 0.1
    with pytest.raises(InvalidParameterError, match=r"a of coordinate 2 does not start at rest"):
        FourierTrajectory((0.0, 0.0), 1.0, a, b)


@pytest.fixture(scope="module")
def excitation():
    return excitation_trajectory(PAPER, harmonics=3, iterations=25, velocity=0.4, seed=1)


def test_the_excitation_holds_every_limit_on_a_finer_grid(excitation):
    motion = excitation.motion(PAPER, rate=2000.0)
    limits = excitation.limits
    assert np.all(np.abs(motion.pose - excitation.trajectory.center) <= limits["excursion"] * (1 + 1e-12))
    S = pkmlab.singularity_measure(PAPER, motion.q)  # the public measure, not the optimiser's
    assert np.abs(S).min() >= limits["singularity_margin"]
    # the actuators' rates by differences of their values, not by the optimiser's derivatives
    h = motion.t[1] - motion.t[0]
    rates = np.gradient(motion.theta, h, axis=0)
    assert np.abs(rates).max() <= 0.4 * (1 + 1e-4)
    assert np.allclose(rates[1:-1], motion.theta_dot[1:-1], atol=1e-5)
    fk = pkmlab.forward_kinematics(PAPER, motion.theta[1234])  # the poses are the machine's
    assert np.nanmin(np.linalg.norm(fk.pose - motion.pose[1234], axis=-1)) < 1e-9


def test_the_excitation_lowers_the_condition_number_it_reports(excitation):
    motion = excitation.motion(PAPER, rate=100.0)
    base = pkmlab.base_parameters(PAPER)
    Y = base.regressor(pkmlab.dynamics_regressor(PAPER, motion.q, motion.theta_dot, motion.theta_ddot))
    cond = scaled_condition_number(np.swapaxes(Y, 0, 1).reshape(-1, base.rank))
    assert cond == pytest.approx(excitation.condition_number, rel=0.05)
    assert excitation.condition_number < 0.5 * excitation.start_condition_number


def test_an_effort_limit_is_held_by_the_models_efforts():
    result = excitation_trajectory(PAPER, harmonics=2, iterations=10, effort=0.01, seed=2)
    motion = result.motion(PAPER, rate=500.0)
    tau = pkmlab.inverse_dynamics(PAPER, motion.q, motion.theta_dot, motion.theta_ddot)
    assert np.abs(tau).max() <= 0.01 * (1 + 1e-3)


def test_the_scenario_table_reads_back_to_the_same_motion(excitation):
    table = fourier_table(excitation.trajectory)
    scenario = scenario_from_dict({"trajectory": json.loads(json.dumps(table))}, "x.toml")
    t = np.linspace(0, excitation.trajectory.duration, 101)
    for mine, read in zip(excitation.trajectory.desired(t), scenario.trajectory.desired(t), strict=True):
        assert np.array_equal(mine, read)


@pytest.mark.parametrize("change, message", [
    ({"speed": 0.2}, r"\[trajectory\]\.speed does not apply to a fourier trajectory"),
    ({"center": [0.25, 0.21]}, r"\[trajectory\]\.center must be 3 numbers \[x, y, alpha\]"),
    ({"period": 0.0}, r"\[trajectory\]\.period must be a positive number"),
    ({"periods": 1.5}, r"\[trajectory\]\.periods must be a positive integer"),
    ({"b": [[0.0, 0.0, 0.0]]}, r"\[trajectory\]\.b must have as many harmonics as a \(2\), got 1"),
    ({"a": [[0.01, 0.0, 0.0], [0.0, 0.0, 0.0]]}, r"a of coordinate 1 does not start at rest"),
])
def test_a_bad_fourier_table_is_refused_by_key(change, message):
    table = {"type": "fourier", "center": [0.25, 0.21, 0.0], "period": 4.0, "a": [[0.01, 0, 0], [-0.01, 0, 0]],
             "b": [[0.0, 0.02, 0.0], [0.0, -0.01, 0.0]]}
    with pytest.raises(pkmlab.PkmlabError, match=message):
        scenario_from_dict({"trajectory": {**table, **change}}, "x.toml")


def test_excite_simulate_identify_gives_the_base_parameters_back(tmp_path):
    """The loop of a user with a machine: the written scenario run on a plant equal to the model, its log
    identified: the base parameters to a few parts in 10⁴ of the largest (the log's filtering is all that
    separates them)."""
    done = _pkmlab("excite", "--out", "exc", "--harmonics", "3", "--iterations", "15", "--period", "4", "--json",
                   cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    summary = json.loads(done.stdout)
    assert json.loads((tmp_path / "exc" / "excitation.json").read_text()) == summary
    header = (tmp_path / "exc" / "excitation.csv").read_text().splitlines()[0]
    assert header.startswith("t,theta1,theta2,theta3,theta_dot1") and header.endswith("x,y,alpha,S")
    run = _pkmlab("simulate", "exc/excitation.toml", "--out", "run", "--no-figures", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    ident = _pkmlab("identify", "run/run.csv", "--json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    rows = json.loads(ident.stdout)["base_parameters"]
    base = pkmlab.base_parameters(PAPER)
    truth = base.of(pkmlab.inertial_parameters(PAPER))
    assert [r["name"] for r in rows] == list(base.names)
    estimate = np.array([r["estimate"] for r in rows])
    assert np.abs(estimate - truth).max() < 5e-4 * np.abs(truth).max()


@pytest.mark.parametrize("args, code, message", [
    (["--excursion", "-0.01"], 1, r"excursion must be a positive number"),
    (["--velocity", "1", "2"], 1, r"velocity must be a positive number or 3, one per actuator"),
    (["--center", "0.2", "0.2"], 2, r"argument --center: the paper's pose is x y alpha: 3 numbers, got 2"),
    (["--center", "0.9", "0.9", "0"], 1, r"the centre \[0.9, 0.9, 0.0\] is not reachable"),
    (["--harmonics", "1"], 1, r"harmonics must be"),
    (["--mechanism", "paper", "--params", "p.toml"], 1, r"give --mechanism FILE.toml"),
])
def test_excite_refuses_bad_options_in_one_line_and_writes_nothing(tmp_path, args, code, message):
    done = _pkmlab("excite", "--out", "exc", *args, cwd=tmp_path)
    assert done.returncode == code and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert re.search(message, lines[-1]), done.stderr
    if code == 1:
        assert len(lines) == 1 and lines[0].startswith("pkmlab excite: error: ")
    assert list(tmp_path.iterdir()) == []
