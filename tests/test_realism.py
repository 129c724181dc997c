"""Realistic plants and sensors: the drives' equation checked on the run it produced (the recorded motion through
the public inverse dynamics, the noise redrawn from the documented seed), the sensors' readings and the delayed
controller recomputed from them by the public API, the ideal plant untouched, and the identification of the
drives' friction and armature from a run of such a plant."""

from __future__ import annotations

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms.identification import filter_measurements
from pkmlab.control.excitation import excitation_trajectory
from pkmlab.formats.measurements import read_measurement_log
from pkmlab.formats.scenario import scenario_from_dict
from pkmlab.simulation.realism import Drives, Sensors
from pkmlab.simulation.run import prepare_run

NOMINAL = pkmlab.paper_scenario("nominal")
MODEL = NOMINAL.model


def _actuator_accelerations(result, ts):
    """Each sample's mean acceleration over the sample after it, and the state at its middle."""
    a = np.diff(result.theta_dot, axis=0) / ts
    return a, 0.5 * (result.theta_dot[1:] + result.theta_dot[:-1])


def test_the_plant_obeys_its_drives_equation_with_the_seeded_noise():
    ts = 2e-4
    drives = Drives(gear_ratio=2.0, armature=2e-4, viscous=0.01, coulomb=0.004, coulomb_rate=0.05,
                    effort_limit=0.04, effort_noise=0.002)
    scenario = NOMINAL.replace(drives=drives, sample_time=ts, seed=7)
    result = pkmlab.simulate(scenario)
    n = MODEL.n_actuators
    limit = 2.0 * 0.04
    assert np.abs(result.tau).max() > limit  # the command saturates somewhere
    noise = np.random.default_rng([7, 0]).standard_normal((result.t.size, n)) * 0.002
    applied = (np.clip(result.tau, -limit, limit) + noise)[:-1]
    a, rate = _actuator_accelerations(result, ts)
    q_mid = pkmlab.follow_path(MODEL, result.q[0], 0.5 * (result.theta[1:] + result.theta[:-1]))
    rigid = pkmlab.inverse_dynamics(MODEL, q_mid, rate, a)
    drive = 4 * 2e-4 * a + 0.01 * rate + 0.004 * np.tanh(rate / 0.05)
    scale = np.abs(applied).max()
    assert np.abs(applied - rigid - drive).max() < 2e-3 * scale
    assert np.abs(applied - rigid).max() > 20 * np.abs(applied - rigid - drive).max()  # the drive terms matter


def test_the_ideal_plant_has_no_readings_and_its_columns_are_unchanged():
    result = pkmlab.simulate(NOMINAL)
    assert result.theta_measured is None and not any(c.endswith("_m") for c in result.columns)
    same = pkmlab.simulate(NOMINAL.replace(drives=None, sensors=None, seed=3))
    assert np.array_equal(same.tau, result.tau) and np.array_equal(same.q, result.q)


@pytest.mark.parametrize("rates", ["difference", "backward2"])
def test_the_controller_computes_from_delayed_quantised_readings(rates):
    ts, res, delay = 1e-3, 2 * np.pi / 40_000, 2
    scenario = NOMINAL.replace(sensors=Sensors(resolution=res, delay=delay, rates=rates))
    result = pkmlab.simulate(scenario)
    m = result.theta_measured
    assert np.allclose(m / res, np.round(m / res), atol=1e-6, rtol=0)
    assert np.abs(m - result.theta).max() <= res / 2 * (1 + 1e-9)
    d = prepare_run(scenario).desired
    spec = scenario.controller
    for k in (5, 400, 1200):
        j = k - delay
        rate = (m[j] - m[j - 1]) / ts if rates == "difference" else (3 * m[j] - 4 * m[j - 1] + m[j - 2]) / (2 * ts)
        q = pkmlab.branch_following(MODEL, result.q[j], m[j], singularity_guard=1e-6)
        v = d.theta_ddot[k] - spec.kp * (m[j] - d.theta[k]) - spec.velocity_gain * (rate - d.theta_dot[k])
        expected = pkmlab.inverse_dynamics(MODEL, q, rate, v)
        assert np.allclose(result.tau[k], expected, rtol=1e-9, atol=1e-12 * np.abs(result.tau).max())


def test_the_noise_is_the_seeds():
    scenario = NOMINAL.replace(sensors=Sensors(noise=1e-5), drives=Drives(effort_noise=1e-3))
    first, again = pkmlab.simulate(scenario), pkmlab.simulate(scenario)
    other = pkmlab.simulate(scenario.replace(seed=1))
    assert np.array_equal(first.theta_measured, again.theta_measured) and np.array_equal(first.tau, again.tau)
    assert not np.array_equal(first.theta_measured, other.theta_measured)
    readings = first.theta + np.random.default_rng([0, 1]).standard_normal(first.theta.shape) * 1e-5
    assert np.allclose(first.theta_measured, readings, atol=1e-15, rtol=0)
    batch = pkmlab.simulate_batch([scenario, scenario.replace(seed=1), NOMINAL])
    assert np.array_equal(batch[0].tau, first.tau) and np.array_equal(batch[1].tau, other.tau)
    assert batch[2].theta_measured is None


def test_the_drives_friction_and_armature_are_identified_from_a_run(tmp_path):
    """An excitation run on a plant with drives and an encoder: identified with drives, its armature and
    friction come back (the smooth Coulomb law's band is far below the motion's rates), each within 3σ of its
    own reported σ (kept, the rows about the rates' reversals bias them: 3–9 % and 2–4σ, the viscous high, the
    Coulomb low)."""
    excitation = excitation_trajectory(MODEL, harmonics=3, iterations=15, period=4.0, seed=1)
    drives = Drives(armature=1e-3, viscous=0.02, coulomb=0.005, coulomb_rate=1e-4)
    scenario = pkmlab.Scenario(MODEL, excitation.trajectory, working_mode=excitation.mode, drives=drives,
                               sensors=Sensors(resolution=2 * np.pi / 2**20), seed=2)
    log = read_measurement_log(pkmlab.simulate(scenario).to_csv(tmp_path / "run.csv"), MODEL)
    data = filter_measurements(MODEL, log.t, log.theta, log.tau, pose=log.pose, mode=excitation.mode)
    result = pkmlab.identify(MODEL, *data.states, data.tau, drives=True)
    names = list(result.names)
    for j in range(MODEL.n_actuators):
        for name, truth in (("fv", 0.02), ("fc", 0.005)):
            k = names.index(f"drive{j + 1}.{name}")
            assert result.estimate[k] == pytest.approx(truth, rel=0.05), (j, name)
            assert abs(result.estimate[k] - truth) < 3 * result.sigma[k], (j, name)


def test_stick_slip_friction_holds_the_machine_at_rest_until_an_effort_exceeds_it():
    """Karnopp's law at rest: with every actuator stuck the friction that holds actuator ``i`` is its effort
    (no rates, no gravity), so the machine stays exactly where it is while every ``|τ_i| <= fc`` and moves after
    the first command with an ``|τ_i| > fc``; the smooth law of the same ``fc`` creeps from the first sample."""
    fc = 0.2
    result = pkmlab.simulate(NOMINAL.replace(drives=Drives(coulomb=fc, coulomb_rate=1e-3, stick_slip=True)))
    moving = np.any(result.theta != result.theta[0], axis=1)
    start = int(np.argmax(moving))
    assert start > 5 and moving[start:].sum() > 0.9 * (moving.size - start)
    assert np.all(result.theta_dot[:start] == 0.0)
    assert np.abs(result.tau[:start - 1]).max() <= fc
    assert np.abs(result.tau[start - 1]).max() > fc
    smooth = pkmlab.simulate(NOMINAL.replace(drives=Drives(coulomb=fc, coulomb_rate=1e-3)))
    assert np.all(smooth.theta[1] != smooth.theta[0])


def test_an_actuator_held_by_stick_slip_friction_leaves_the_others_to_the_rigid_dynamics():
    """Actuator 1 held by a friction it never overcomes: it does not move, and the other two obey the rigid
    actuator-space dynamics (the public inverse dynamics of the recorded motion) with their effort alone."""
    ts = 2e-4
    drives = Drives(coulomb=(1e3, 0.0, 0.0), coulomb_rate=1e-3, stick_slip=True)
    result = pkmlab.simulate(NOMINAL.replace(drives=drives, sample_time=ts))
    assert np.all(result.theta[:, 0] == result.theta[0, 0]) and np.all(result.theta_dot[:, 0] == 0.0)
    assert np.abs(result.theta[:, 1:] - result.theta[0, 1:]).max(axis=0).min() > 0.05
    a, rate = _actuator_accelerations(result, ts)
    q_mid = pkmlab.follow_path(MODEL, result.q[0], 0.5 * (result.theta[1:] + result.theta[:-1]))
    rigid = pkmlab.inverse_dynamics(MODEL, q_mid, rate, a)
    applied = result.tau[:-1]
    scale = np.abs(applied[:, 1:]).max()
    assert np.abs(applied[:, 1:] - rigid[:, 1:]).max() < 2e-3 * scale
    assert np.abs(applied[:, 0] - rigid[:, 0]).max() > 0.1 * scale  # actuator 1's friction holds it


def test_small_stick_slip_friction_is_tracked_as_the_smooth_law():
    """Away from rest the two laws are the same friction ``fc sign(θ̇)`` (the smooth one to ``tanh``'s
    saturation): computed torque's path error agrees to 1 %."""
    stick = pkmlab.simulate(NOMINAL.replace(drives=Drives(coulomb=0.02, coulomb_rate=1e-3, stick_slip=True)))
    smooth = pkmlab.simulate(NOMINAL.replace(drives=Drives(coulomb=0.02, coulomb_rate=1e-3)))
    ideal = pkmlab.simulate(NOMINAL)
    error = stick.summary()["max_path_error_m"]
    assert error == pytest.approx(smooth.summary()["max_path_error_m"], rel=0.01)
    assert error > 3 * ideal.summary()["max_path_error_m"]


def test_continuous_time_computed_torque_with_the_drives_model_is_exact():
    """Continuous-time control of a plant with geared drives, armature and smooth friction: computed torque that
    compensates the same drives tracks to the integrator's tolerance; without the compensation it does not."""
    drives = Drives(gear_ratio=3.0, armature=2e-5, viscous=0.01, coulomb=0.004, coulomb_rate=0.05)
    fast = NOMINAL.trajectory.__class__(path=NOMINAL.trajectory.path, speed=0.6, law=NOMINAL.trajectory.law)
    scenario = NOMINAL.replace(sample_time=0.0, trajectory=fast, drives=drives)
    exact = pkmlab.simulate(scenario.replace(controller_drives=drives)).summary()["max_path_error_m"]
    uncompensated = pkmlab.simulate(scenario).summary()["max_path_error_m"]
    assert exact < 1e-11 and uncompensated > 1e-5


@pytest.mark.parametrize("drives, sensors, message", [
    (Drives(coulomb=0.01, stick_slip=True), None, r"its drives' stick-slip Coulomb friction switches within a step"),
    (Drives(coulomb=0.01, coulomb_rate=0.0), None, r"its drives' exact \(coulomb_rate = 0\) Coulomb friction"),
    (Drives(effort_noise=1e-3), None, r"effort_noise is drawn once per sample"),
    (None, Sensors(resolution=1e-4), r"sensors read the plant once per sample"),
])
def test_continuous_time_refuses_what_has_no_samples_or_no_smooth_law(drives, sensors, message):
    with pytest.raises(pkmlab.PkmlabError, match=message):
        NOMINAL.replace(sample_time=0.0, drives=drives, sensors=sensors)


def test_stick_slip_needs_its_window():
    with pytest.raises(pkmlab.PkmlabError, match=r"stick_slip friction needs coulomb_rate > 0"):
        Drives(coulomb=0.1, coulomb_rate=0.0, stick_slip=True)
    with pytest.raises(pkmlab.PkmlabError, match=r"stick_slip must be true or false, got 1"):
        Drives(stick_slip=1)


@pytest.mark.parametrize("tables, message", [
    ({"plant": {"viscous": -0.1}}, r"\[plant\]\.viscous must be a non-negative number"),
    ({"plant": {"coulomb": [0.1, 0.1]}}, r"\[plant\]\.coulomb must be one number or 3, one per actuator"),
    ({"sensors": {"rates": "tacho"}},
     r"\[sensors\]\.rates = \"tacho\" is not known; choose one of: difference, backward2, exact"),
    ({"sensors": {"delay": 1.5}}, r"\[sensors\]\.delay must be an integer number of samples"),
    ({"sensors": {"resolutoin": 1e-4}}, r"unknown key 'resolutoin' in \[sensors\].*resolution"),
    ({"sensors": {"noise": 1e-5}, "controller": {"sample_time": 0.0}}, r"apply to sampled-data control"),
    ({"simulation": {"seed": -1}}, r"\[simulation\]\.seed must be a non-negative integer"),
    ({"plant": {"stick_slip": "yes"}}, r"\[plant\]\.stick_slip must be true or false, got \"yes\""),
    ({"plant": {"stick_slip": True, "coulomb_rate": 0.0}},
     r"\[plant\]: stick_slip friction needs coulomb_rate > 0"),
])
def test_bad_drive_and_sensor_keys_are_refused_by_key(tables, message):
    data = {"trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2}, **tables}
    with pytest.raises(pkmlab.PkmlabError, match=message):
        scenario_from_dict(data, "x.toml")


def test_a_scenario_file_declares_drives_and_sensors():
    scenario = scenario_from_dict({"trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05,
                                                  "speed": 0.2},
                                   "plant": {"gear_ratio": 10.0, "armature": [1e-5, 2e-5, 1e-5], "effort_limit": 0.02,
                                             "coulomb_rate": 0.0},
                                   "sensors": {"resolution": 1e-4, "delay": 1, "rates": "exact"},
                                   "simulation": {"seed": 4}}, "x.toml")
    assert scenario.drives.table(3)[:, 0].tolist() == pytest.approx([1e-3, 2e-3, 1e-3])
    assert scenario.drives.table(3)[:, 4].tolist() == [0.2, 0.2, 0.2]
    assert scenario.sensors == Sensors(resolution=1e-4, delay=1, rates="exact") and scenario.seed == 4


def test_computed_torque_adds_its_model_of_the_drives():
    """The recorded command is the rigid model's computed torque (recomputed by the public inverse dynamics)
    plus the compensation ``Ia v + fv θ̇ + fc tanh(θ̇ / v_c)``."""
    model_drives = Drives(armature=(1e-4, 2e-4, 3e-4), viscous=0.01, coulomb=0.002, coulomb_rate=0.05)
    scenario = NOMINAL.replace(controller_drives=model_drives, drives=Drives(viscous=0.01, coulomb=0.002))
    result = pkmlab.simulate(scenario)
    d = prepare_run(scenario).desired
    spec = scenario.controller
    for k in (3, 500, 1100):
        rate = result.theta_dot[k]
        v = (d.theta_ddot[k] - spec.kp * (result.theta[k] - d.theta[k])
             - spec.velocity_gain * (rate - d.theta_dot[k]))
        rigid = pkmlab.inverse_dynamics(MODEL, result.q[k], rate, v)
        expected = rigid + np.array([1e-4, 2e-4, 3e-4]) * v + 0.01 * rate + 0.002 * np.tanh(rate / 0.05)
        assert np.allclose(result.tau[k], expected, rtol=1e-9, atol=1e-12)


def test_controller_drives_are_read_from_the_controller_table_and_need_computed_torque():
    data = {"trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2},
            "controller": {"viscous": [0.01, 0.02, 0.01], "coulomb_rate": 0.0}}
    scenario = scenario_from_dict(data, "x.toml")
    assert scenario.controller_drives.table(3)[:, 1].tolist() == [0.01, 0.02, 0.01]
    with pytest.raises(pkmlab.PkmlabError, match=r"a pd controller has no model to add them to"):
        scenario_from_dict({**data, "controller": {**data["controller"], "type": "pd", "kp": 10.0}}, "x.toml")
    with pytest.raises(pkmlab.PkmlabError, match=r"unknown key 'effort_limit' in \[controller\]"):
        scenario_from_dict({**data, "controller": {"effort_limit": 1.0}}, "x.toml")
