"""Stability of the sampled-data loop: the spectral-radius check before a run, the reason given
when a run diverges, and numbers in messages that never contradict the limit they are compared with.

The formula of :func:`pkmlab.control.controller.sampled_data_spectral_radius` is checked against the exact
zero-order-hold discretisation (a matrix exponential) and against the Jury stability conditions
of a second-order characteristic polynomial, worked out by hand below.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from conftest import assert_user_error, run
from scipy.linalg import expm

import pkmlab
import pkmlab.simulation.run as simulation
from pkmlab.control.controller import (
    ControllerSpec,
    largest_stable_kp,
    largest_stable_sample_time,
    sampled_data_spectral_radius,
)
from pkmlab.errors import SingularityError, UnstableControlError
from pkmlab.formats.scenario import paper_scenario
from pkmlab.simulation.run import simulate
from pkmlab.simulation.scenario import choose_working_mode


# ------------------------------------------------------------------ the formula, independently
def _zoh_closed_loop(kp, kv, ts, mu):
    """``A`` of the double integrator ``ë = u`` under ``u_k = -μ (kp e_k + kv ė_k)`` held over ``Ts``,
    from the matrix exponential of the augmented system ``d/dt (e, ė, u) = (ė, u, 0)``."""
    phi = expm(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]) * ts)
    a_d, b_d = phi[:2, :2], phi[:2, 2:]
    return a_d - b_d @ (mu * np.array([[kp, kv]]))


def test_spectral_radius_is_that_of_the_exact_zero_order_hold_discretisation():
    rng = np.random.default_rng(3)
    for _ in range(200):
        kp, kv = 10 ** rng.uniform(-2, 8), 10 ** rng.uniform(-2, 4)
        ts, mu = 10 ** rng.uniform(-5, -1), 10 ** rng.uniform(-2, 2)
        expected = np.abs(np.linalg.eigvals(_zoh_closed_loop(kp, kv, ts, mu))).max()
        assert sampled_data_spectral_radius(kp, kv, ts, mu) == pytest.approx(expected, rel=1e-7)
    # vectorised over μ
    mus = np.array([0.3, 1.0, 40.0])
    rho = sampled_data_spectral_radius(1000.0, 63.0, 1e-3, mus)
    assert rho.shape == (3,)
    for m, r in zip(mus, rho, strict=True):
        assert r == pytest.approx(np.abs(np.linalg.eigvals(_zoh_closed_loop(1000.0, 63.0, 1e-3, m))).max())


def test_stability_limits_follow_the_jury_conditions():
    """``z² - (2 - a - b) z + (1 + a - b)`` (``a = μ kp Ts²/2``, ``b = μ kv Ts``) has both roots in the unit
    disc iff ``|1 + a - b| < 1`` and ``|2 - a - b| < 2 + a - b``, i.e. ``a < b < 2``; with ``kv = 2√kp``:
    ``kp < 16/Ts²`` and ``kp < 1/(μ Ts)²``; with fixed gains: ``Ts < 2 kv/kp`` and ``Ts < 2/(μ kv)``."""
    for ts in (1e-4, 1e-3, 5e-3):
        for mu in ([1.0], [0.5, 1.0], [0.1, 20.0, 48.9], [1e-3]):
            expected = min(16.0 / ts**2, 1.0 / (max(mu) * ts) ** 2)
            assert largest_stable_kp(ts, mu) == pytest.approx(expected, rel=1e-6)
    for kp, kv in ((1000.0, 63.2456), (1e6, 2000.0), (1e12, 2e6), (100.0, 1000.0)):
        for mu in ([1.0], [0.4, 1.1], [48.9]):
            expected = min(2.0 * kv / kp, 2.0 / (max(mu) * kv))
            assert largest_stable_sample_time(kp, kv, mu) == pytest.approx(expected, rel=1e-6)
    assert largest_stable_sample_time(1000.0, 0.0, [1.0]) is None  # no damping: unstable at any Ts
    # kp → 0: a double eigenvalue at 1 (marginal), never above it
    assert sampled_data_spectral_radius(0.0, 0.0, 1e-3, 1.0) == pytest.approx(1.0)
    assert sampled_data_spectral_radius(1e-6, 2e-3, 1e-3, 1.0) <= 1.0


# ------------------------------------------------------------------ refused before running
UNSTABLE = {
    "computed torque kp = 1e12": (ControllerSpec("computed_torque", kp=1e12), r"computed torque with kp = 1e\+12"),
    "PD kp = 1000": (ControllerSpec("pd", kp=1000.0), r"PD with kp = 1000,"),
}


@pytest.fixture
def no_loop(monkeypatch):
    """Fail the test if the compiled loop is entered: a refusal must come before simulating."""
    def loop(*args):
        raise AssertionError("the run was simulated")

    kernels = paper_scenario("nominal").model.kernels
    monkeypatch.setattr(kernels, "sampled_data_loop", loop)


@pytest.mark.parametrize("controller, named", UNSTABLE.values(), ids=UNSTABLE)
def test_unstable_gains_are_refused_before_simulating(no_loop, controller, named):
    scenario = paper_scenario("nominal").replace(controller=controller)
    with pytest.raises(UnstableControlError) as info:
        simulate(scenario)
    message = str(info.value)
    assert "\n" not in message
    assert re.search(r"the sampled-data loop is unstable: " + named, message), message
    assert "Ts = 1 ms" in message and "spectral radius" in message
    assert "singularity" not in message and "branch" not in message
    assert isinstance(info.value, pkmlab.UnstableControlError)


def test_the_refusal_names_a_stable_gain_at_this_sample_time():
    message = str(pytest.raises(UnstableControlError, simulate,
                                paper_scenario("nominal").replace(controller=ControllerSpec(kp=1e12))).value)
    # plant = model: every modal gain is 1, and the limit is kp = 1/Ts² (Jury, above)
    assert "kp <= 1e+06 with kv = 2*sqrt(kp)" in message
    pd = str(pytest.raises(UnstableControlError, simulate,
                           paper_scenario("nominal").replace(controller=ControllerSpec("pd", kp=1000.0))).value)
    kp_max = float(re.search(r"kp <= ([0-9.e+]+)", pd).group(1))
    assert 100.0 < kp_max < 1000.0
    simulate(paper_scenario("nominal").replace(controller=ControllerSpec("pd", kp=0.95 * kp_max)))


@pytest.mark.parametrize("toml_controller, named", [
    ('type = "computed_torque"\nkp = 1e12', "kp = 1e+12"),
    ('type = "pd"\nkp = 1000.0', "kp = 1000,"),
])
def test_the_cli_refuses_unstable_gains_and_writes_nothing(tmp_path, capsys, toml_controller, named):
    path = tmp_path / "unstable.toml"
    path.write_text("[trajectory]\ntype = \"circle\"\ncenter = [0.25, 0.21]\nradius = 0.05\nspeed = 0.2\n\n"
                    f"[controller]\n{toml_controller}\nsample_time = 0.001\n")
    out = tmp_path / "out"
    message = assert_user_error(*run(capsys, "simulate", path, "--out", out))
    assert "unstable" in message and named in message and "Ts = 1 ms" in message, message
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ["unstable.toml"]


@pytest.mark.parametrize("name", ["nominal", "disturbed", "fast"])
def test_the_papers_cases_are_not_refused(name):
    scenario = paper_scenario(name)
    prep = simulation.prepare_run(scenario)  # runs the check
    assert prep.kp == 1000.0 and scenario.sample_time == 1e-3


def test_a_batch_gives_the_refusal_of_each_run():
    nominal = paper_scenario("nominal")
    runs = [nominal, nominal.replace(controller=ControllerSpec(kp=1e12), name="stiff")]
    results = pkmlab.simulate_batch(runs, on_error="return")
    assert isinstance(results[0], pkmlab.SimulationResult)
    assert isinstance(results[1], UnstableControlError)
    assert str(results[1]).startswith("run 1 (stiff): the sampled-data loop is unstable")


# ------------------------------------------------------------------ what the simulation actually does
def test_the_bound_matches_what_the_simulation_does(monkeypatch):
    """Plant = model: the limit is kp = 1e6 at Ts = 1 ms. Just below it the run tracks; just above it the
    check refuses, and with the check bypassed the run diverges and says so (not a singularity)."""
    nominal = paper_scenario("nominal")
    below = nominal.replace(controller=ControllerSpec(kp=0.95e6))
    above = nominal.replace(controller=ControllerSpec(kp=1.05e6))
    assert simulate(below).summary()["max_joint_error_rad"] < 1e-6
    with pytest.raises(UnstableControlError, match="unstable"):
        simulate(above)
    monkeypatch.setattr(simulation, "_check_sampled_data_stability", lambda scenario, prep: None)
    with pytest.raises(UnstableControlError) as info:
        simulate(above)
    message = str(info.value)
    assert re.match(r"run stopped at t = [0-9.]+ s: the run diverged \(the joint error grew from", message), message
    assert "unstable" in message and "kp = 1.05e+06" in message and "singularity" not in message
    # and kp = 1e12 and the PD law at 1 ms, which used to be blamed on a singularity
    for controller, _named in UNSTABLE.values():
        with pytest.raises(UnstableControlError, match=r"the run diverged .* unstable"):
            simulate(nominal.replace(controller=controller))
    # a batch gives the same error per run
    results = pkmlab.simulate_batch([below, above.replace(name="above")], on_error="return")
    assert isinstance(results[0], pkmlab.SimulationResult)
    assert isinstance(results[1], UnstableControlError) and "run 1 (above): run stopped at" in str(results[1])
    assert "diverged" in str(results[1])


# ------------------------------------------------------------------ numbers that contradict their limit
def test_a_value_just_below_its_limit_is_never_shown_equal_to_it():
    from pkmlab._format import apart

    assert apart(0.04996, 0.05) == ("0.04996", "0.05")
    assert apart(0.0512, 0.05) == ("0.0512", "0.05")
    value, limit = apart(1.0 + 3e-12, 1.0)
    assert float(value) > float(limit)
    assert apart(10_000_001, 1e7)[0] == "10000001"


def test_the_preflight_margin_message_does_not_contradict_itself():
    """The path's min |S| in mode (+, +, +) is 0.47978…: with a margin of 0.48 it used to read
    "comes within 0.48 of a gain-type singularity (margin 0.48)"."""
    scenario = paper_scenario("nominal").replace(working_mode=(1, 1, 1), singularity_margin=0.0)
    t = simulation.sample_times(scenario)
    _mode, min_s = choose_working_mode(scenario, t)
    margin = float(f"{min_s:.3g}")
    assert margin > min_s  # the case that rounds up onto the margin
    with pytest.raises(SingularityError) as info:
        choose_working_mode(scenario.replace(singularity_margin=margin), t)
    shown = re.search(r"comes within ([0-9.e+-]+) of a gain-type singularity \(margin ([0-9.e+-]+)\)", str(info.value))
    assert float(shown.group(1)) < float(shown.group(2)), str(info.value)


def test_a_motion_just_shorter_than_a_sample_is_not_shown_as_one_sample():
    from pkmlab.formats.scenario import scenario_from_dict

    speed = 0.01 / 0.0009996  # a 1 cm line lasting 0.9996 ms: ".3g" shows it as "0.001 s"
    data = {"trajectory": {"type": "line", "start": [0.25, 0.2, 0.0], "end": [0.26, 0.2, 0.0], "speed": speed}}
    with pytest.raises(pkmlab.InvalidParameterError) as info:
        scenario_from_dict(data, "short.toml")
    shown = re.search(r"would last ([0-9.e+-]+) s, less than one sample \(([0-9.e+-]+) s\)", str(info.value))
    assert shown and float(shown.group(1)) < float(shown.group(2)), str(info.value)
    assert math.isclose(float(shown.group(1)), 0.0009996, rel_tol=1e-3)


BIGLIDE = """
[mechanism]
name = "biglide"
gravity = [0.0, 0.0]

[mechanism.platform]
kind = "point"
mass = 0.2

[[mechanism.leg]]
base = [-0.2, 0.0]
joints = "P*RR"
axis = 1.5707963
stroke = [0.0, 0.6]
bodies = [{ tip = [0.0, 0.0], mass = 0.5 },
          { tip = [0.25, 0.0], mass = 0.2, com = [0.125, 0.0], inertia = 0.001 }]

[[mechanism.leg]]
base = [0.2, 0.0]
joints = "P*RR"
axis = 1.5707963
stroke = [0.0, 0.6]
bodies = [{ tip = [0.0, 0.0], mass = 0.5 },
          { tip = [0.25, 0.0], mass = 0.2, com = [0.125, 0.0], inertia = 0.001 }]
"""


@pytest.mark.parametrize("kp", [1e9, 1e10])
def test_continuous_gains_too_stiff_to_integrate_are_refused_before_the_run(tmp_path, kp):
    """A biglide under continuous-time control with kp = 1e9 ran for minutes without ending: refused before it
    starts, with the true reason and a kp that passes the same check."""
    from pkmlab.formats.scenario import load_scenario
    from pkmlab.simulation.run import MAX_TIME_CONSTANTS, prepare_run

    (tmp_path / "biglide.toml").write_text(BIGLIDE)
    (tmp_path / "run.toml").write_text('[mechanism]\nfile = "biglide.toml"\n[trajectory]\ntype = "circle"\n'
                                       "center = [0.0, 0.35]\nradius = 0.03\nspeed = 0.1\n[controller]\n"
                                       f'type = "computed_torque"\nkp = {kp:g}\nsample_time = 0\n')
    scenario = load_scenario(tmp_path / "run.toml")
    with pytest.raises(UnstableControlError, match=r"continuous-time computed torque with kp = 1e\+(09|10), .* is too "
                                                   r"stiff to integrate: .* lower the gains \(kp <= ([\d.e+]+) with "
                                                   r"kv = 2\*sqrt\(kp\)\) or use sampled-data control") as info:
        prepare_run(scenario)
    # the rate: a critically damped double root, sqrt(kp) (the model is the plant), over the run's 1.885 s
    rate, duration = math.sqrt(kp), 2 * math.pi * 0.03 / 0.1
    assert f"{rate * duration:.3g} of its time constants" in str(info.value)
    suggested = float(re.search(r"kp <= ([\d.e+]+)", str(info.value)).group(1))
    assert math.sqrt(suggested) * duration <= MAX_TIME_CONSTANTS
    spec = scenario.controller
    prepare_run(scenario.replace(controller=type(spec)(spec.kind, kp=suggested)))  # within the limit: accepted
