"""Dynamic identification: the base parameters estimated from efforts, checked against the model's own
parameters (noise-free data must give them back), against the spread of repeated noisy draws (the reported σ),
against analytic derivatives of a known motion (the log filter), and refused, by name, where the data cannot
determine them."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms.identification import decimation, scaled_condition_number
from pkmlab.model import mechanism_model as mm

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
PAPER = pkmlab.load("paper")
FIVE_BAR = pkmlab.load("five_bar")


def fourier_motion(model, seconds=10.0, rate=1000.0, harmonics=5, amplitude=0.12, seed=3):
    """A finite Fourier series per actuator about a well-conditioned configuration, with its exact rates and
    accelerations (written out here, independently of the filter under test)."""
    q0 = mm.well_conditioned_configuration(model, mm.working_modes(model)[0])
    na = model.n_actuators
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 1.0 / rate)
    wf = 2 * np.pi / seconds  # one period over the log
    k = np.arange(1, harmonics + 1)[:, None]
    a, b = (rng.uniform(-1, 1, (harmonics, na)) * amplitude / k for _ in range(2))
    phase = wf * k * t  # (harmonics, N)
    theta = q0[:na] + ((a / (wf * k)).T @ np.sin(phase) - (b / (wf * k)).T @ (np.cos(phase) - 1.0)).T
    theta_dot = (a.T @ np.cos(phase) + b.T @ np.sin(phase)).T
    theta_ddot = ((-a * wf * k).T @ np.sin(phase) + (b * wf * k).T @ np.cos(phase)).T
    q = pkmlab.follow_path(model, q0, theta)
    return t, q, theta_dot, theta_ddot


@pytest.mark.parametrize("name", ["paper", "five_bar", "3prr", "delta", CATALOGUE / "3prs.toml"],
                         ids=["paper", "five_bar", "3prr", "delta", "3prs"])
def test_noise_free_efforts_give_the_base_parameters_back(name):
    model = pkmlab.load(name)
    states = pkmlab.random_states(model, 120, seed=2)
    tau = pkmlab.inverse_dynamics(model, *states)
    result = pkmlab.identify(model, *states, tau)
    truth = result.base.of(pkmlab.inertial_parameters(model))
    assert np.abs(result.estimate - truth).max() <= 1e-9 * np.abs(truth).max()
    assert np.abs(result.residual).max() <= 1e-10 * np.abs(tau).max()
    assert not set(result.base.unidentifiable) & {term for n in result.names for term in n.split()}


#: Noisy draws of one experiment: the spread of their estimates is known to 1/√(2 (DRAWS − 1)).
DRAWS = 300


@pytest.mark.parametrize("model", [PAPER, FIVE_BAR], ids=["paper", "five_bar"])
def test_sigma_is_the_spread_of_repeated_noisy_draws(model):
    """Each actuator with its own noise level: the weighted estimate's σ against the empirical standard deviation
    over 300 draws (a relative sampling error of about 4 %, a fifth of the tolerance), and each actuator's noise
    level recovered."""
    states = pkmlab.random_states(model, 150, seed=5)
    tau = pkmlab.inverse_dynamics(model, *states)
    base = pkmlab.base_parameters(model)
    levels = np.array([0.02, 0.06, 0.01][:model.n_actuators])
    rng = np.random.default_rng(11)
    runs = [pkmlab.identify(model, *states, tau + levels * rng.standard_normal(tau.shape), base=base)
            for _ in range(DRAWS)]
    spread = np.std([r.estimate for r in runs], axis=0, ddof=1)
    reported = np.mean([r.sigma for r in runs], axis=0)
    assert np.all(np.abs(reported / spread - 1.0) < 0.2), reported / spread
    assert np.all(np.abs(np.mean([r.effort_sigma for r in runs], axis=0) / levels - 1.0) < 0.05)
    truth = base.of(pkmlab.inertial_parameters(model))
    assert np.all(np.abs(np.mean([r.estimate for r in runs], axis=0) - truth) < 4 * spread / np.sqrt(DRAWS))


def test_weighting_by_each_actuators_noise_beats_ordinary_least_squares():
    """The weighted estimate's σ is at most the unweighted one's when one actuator is far noisier."""
    states = pkmlab.random_states(PAPER, 150, seed=6)
    tau = pkmlab.inverse_dynamics(PAPER, *states)
    levels = np.array([0.01, 0.2, 0.01])
    noisy = tau + levels * np.random.default_rng(1).standard_normal(tau.shape)
    weighted = pkmlab.identify(PAPER, *states, noisy)
    W = weighted.base.regressor(pkmlab.dynamics_regressor(PAPER, *states))
    W = np.swapaxes(W, 0, 1).reshape(-1, weighted.base.rank)
    # ordinary least squares' covariance under the true noise: (WᵀW)⁻¹ Wᵀ Σ W (WᵀW)⁻¹
    inv = np.linalg.inv(W.T @ W)
    sigma_rows = np.repeat(levels, len(tau))
    ols_sigma = np.sqrt(np.diag(inv @ (W.T * sigma_rows**2) @ W @ inv))
    assert np.all(weighted.sigma <= ols_sigma * 1.05)
    assert np.median(ols_sigma / weighted.sigma) > 1.5


def test_a_logged_motion_is_filtered_to_its_exact_rates_and_accelerations():
    t, q, theta_dot, theta_ddot = fourier_motion(PAPER)
    tau = pkmlab.inverse_dynamics(PAPER, q, theta_dot, theta_ddot)
    data = pkmlab.filter_measurements(PAPER, t, q[:, :3], tau, decimate=1, efforts="sampled", reversals="keep")
    assert np.abs(data.q - q).max() < 1e-9
    assert np.abs(data.theta_dot - theta_dot).max() < 1e-5 * np.abs(theta_dot).max()
    assert np.abs(data.theta_ddot - theta_ddot).max() < 1e-3 * np.abs(theta_ddot).max()
    kept = pkmlab.filter_measurements(PAPER, t, q[:, :3], tau, efforts="sampled", reversals="keep")
    d = decimation(51, 4)
    assert d == 15 and np.array_equal(kept.t, t[::d]) and np.array_equal(kept.q, data.q[::d])
    result = pkmlab.identify(PAPER, *kept.states, kept.tau)
    truth = result.base.of(pkmlab.inertial_parameters(PAPER))
    big = np.abs(truth) > 1e-3 * np.abs(truth).max()
    assert np.all(np.abs(result.estimate - truth)[big] < 1e-3 * np.abs(truth)[big])
    # a held-out motion's efforts, predicted
    t2, q2, td2, tdd2 = fourier_motion(PAPER, seconds=4.0, seed=8)
    held_out = pkmlab.inverse_dynamics(PAPER, q2, td2, tdd2)
    assert np.abs(result.predict(PAPER, q2, td2, tdd2) - held_out).max() < 1e-3 * np.abs(held_out).max()


def test_rows_whose_filter_window_holds_a_rate_reversal_are_dropped():
    """By default the rows whose window (51 samples at 1 kHz, the default 50 ms) holds a change of sign of an
    actuator's rate are left out — judged here on the exact rates: a kept row's window has none, a dropped row's
    window, a sample wider either side, has one; the others of the decimated rows are all kept."""
    t, q, theta_dot, theta_ddot = fourier_motion(PAPER)
    tau = pkmlab.inverse_dynamics(PAPER, q, theta_dot, theta_ddot)
    every = pkmlab.filter_measurements(PAPER, t, q[:, :3], tau, efforts="sampled", reversals="keep")
    kept = pkmlab.filter_measurements(PAPER, t, q[:, :3], tau, efforts="sampled")
    rows = np.searchsorted(t, every.t)
    dropped = ~np.isin(every.t, kept.t)
    assert 0 < dropped.sum() < len(rows) // 2 and np.array_equal(kept.q, every.q[~dropped])
    signs = np.sign(theta_dot)
    for row, drop in zip(rows, dropped, strict=True):
        lo = min(max(row - 25, 0), len(t) - 51)
        window = signs[lo:lo + 51] if not drop else signs[max(lo - 2, 0):lo + 53]
        reverses = bool(np.any(window != window[0], axis=0).any())
        assert reverses == drop, (row, drop)
    rest = np.repeat(q[:1, :3], 500, axis=0)
    for noise in (0.0, 1e-7):  # a machine at rest: its rate zero, or reversed by every wiggle of its noise
        readings = rest + np.random.default_rng(1).standard_normal(rest.shape) * noise
        with pytest.raises(pkmlab.InvalidParameterError, match="reversal"):
            pkmlab.filter_measurements(PAPER, t[:500], readings, tau[:500], q_start=q[0])


@pytest.mark.parametrize("rate, polyorder", [(10000.0, 4), (1000.0, 6)])
def test_a_rest_in_the_middle_of_a_log_is_left_out_whatever_the_filter(rate, polyorder):
    """Readings held constant for 0.3 s amid a motion: each row whose window lies in the rest is left out (the
    filter's rate of constant readings is its round-off, which grows with its window and order), the rows well
    away from it are all kept."""
    t, q, _theta_dot, _theta_ddot = fourier_motion(PAPER, seconds=1.0, rate=rate)
    k0, held = len(t) // 3, int(0.3 * rate)
    theta = np.concatenate([q[:k0, :3], np.repeat(q[k0 - 1:k0, :3], held, axis=0), q[k0:, :3]])
    times = np.arange(len(theta)) / rate
    every = pkmlab.filter_measurements(PAPER, times, theta, np.zeros_like(theta), q_start=q[0], polyorder=polyorder,
                                       reversals="keep")
    kept = pkmlab.filter_measurements(PAPER, times, theta, np.zeros_like(theta), q_start=q[0], polyorder=polyorder)
    half = 0.025 + 2.0 / rate  # half the default window, and a sample either side
    resting = (every.t > (k0 - 1) / rate + half) & (every.t < (k0 + held) / rate - half)
    assert resting.sum() >= 3 and not np.isin(every.t[resting], kept.t).any()
    assert np.isin(kept.t, every.t[~resting]).all()


def test_the_reported_sigma_of_a_filtered_noisy_log_is_its_spread():
    """Filtering correlates the noise from sample to sample; decimation to the filter's bandwidth keeps the
    reported σ honest (without it, about four times too small)."""
    t, q, theta_dot, theta_ddot = fourier_motion(PAPER)
    tau = pkmlab.inverse_dynamics(PAPER, q, theta_dot, theta_ddot)
    base = pkmlab.base_parameters(PAPER)
    rng = np.random.default_rng(4)
    runs = []
    for _ in range(60):
        data = pkmlab.filter_measurements(PAPER, t, q[:, :3], tau + 0.01 * rng.standard_normal(tau.shape),
                                          q_start=q[0], efforts="sampled")
        runs.append(pkmlab.identify(PAPER, *data.states, data.tau, base=base))
    ratio = np.mean([r.sigma for r in runs], axis=0) / np.std([r.estimate for r in runs], axis=0, ddof=1)
    assert abs(np.exp(np.mean(np.log(ratio))) - 1.0) < 0.2, ratio
    assert np.all((ratio > 0.6) & (ratio < 1.6)), ratio


def test_drive_friction_and_armature_are_identified_and_regrouped():
    states = pkmlab.random_states(FIVE_BAR, 200, seed=7)
    fv, fc, armature = np.array([0.05, 0.08]), np.array([0.02, 0.01]), np.array([1e-3, 2e-3])
    q, theta_dot, theta_ddot = states
    tau = (pkmlab.inverse_dynamics(FIVE_BAR, *states) + fv * theta_dot + fc * np.sign(theta_dot)
           + armature * theta_ddot)
    result = pkmlab.identify(FIVE_BAR, *states, tau, drives=True)
    values = dict(zip(result.names, result.estimate, strict=True))
    assert values["drive1.fv"] == pytest.approx(0.05, rel=1e-9) and values["drive2.fc"] == pytest.approx(0.01,
                                                                                                         rel=1e-9)
    # the armature turns with the proximal link: only their sum is seen
    regrouped = [n for n in result.names if "drive1.Ia" in n]
    assert len(regrouped) == 1 and regrouped[0].startswith("body1_1.Izz")
    pi = np.concatenate([pkmlab.inertial_parameters(FIVE_BAR), [1e-3, 0.05, 0.02, 2e-3, 0.08, 0.01]])
    assert np.allclose(result.estimate, result.base.of(pi), rtol=1e-9, atol=1e-12)


def test_smooth_coulomb_friction_is_identified_with_its_own_model_and_biased_by_a_sign():
    """Near rest, where an excitation starts and ends, fc tanh(θ̇ / v_c) is not fc sign(θ̇): identified with the
    plant's model the drives come back exactly; fitted with a sign, they do not."""
    q, theta_dot, theta_ddot = pkmlab.random_states(FIVE_BAR, 200, seed=11)
    theta_dot = theta_dot * 2e-3  # rates of the order of the friction's band
    band, fv, fc, armature = 1e-3, np.array([0.05, 0.08]), np.array([0.02, 0.01]), np.array([1e-3, 2e-3])
    tau = (pkmlab.inverse_dynamics(FIVE_BAR, q, theta_dot, theta_ddot) + fv * theta_dot
           + fc * np.tanh(theta_dot / band) + armature * theta_ddot)
    smooth = pkmlab.identify(FIVE_BAR, q, theta_dot, theta_ddot, tau, drives=True, coulomb_rate=band)
    pi = np.concatenate([pkmlab.inertial_parameters(FIVE_BAR), [1e-3, 0.05, 0.02, 2e-3, 0.08, 0.01]])
    assert np.allclose(smooth.estimate, smooth.base.of(pi), rtol=1e-8, atol=1e-12)
    assert np.allclose(smooth.predict(FIVE_BAR, q, theta_dot, theta_ddot), tau, rtol=0, atol=1e-12)
    sign = pkmlab.identify(FIVE_BAR, q, theta_dot, theta_ddot, tau, drives=True)
    values = dict(zip(sign.names, sign.estimate, strict=True))
    assert abs(values["drive2.fc"] / 0.01 - 1) > 0.1
    with pytest.raises(pkmlab.PkmlabError, match="coulomb_rate"):
        pkmlab.identify(FIVE_BAR, q, theta_dot, theta_ddot, tau, drives=True, coulomb_rate=-1.0)


def test_data_that_do_not_excite_a_parameter_are_refused_by_name():
    q, theta_dot, theta_ddot = pkmlab.random_states(PAPER, 50, seed=1)
    at_rest = np.zeros_like(theta_dot)
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^the data do not excite base parameter 'body1_1\.Izz"):
        pkmlab.identify(PAPER, q, at_rest, at_rest, at_rest)
    # one actuator never accelerates and never moves: its link's inertia cannot be told
    theta_dot[:, 0] = theta_ddot[:, 0] = 0.0
    tau = pkmlab.inverse_dynamics(PAPER, q, theta_dot, theta_ddot)
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^the data do not (excite|determine) base parameter"):
        pkmlab.identify(PAPER, q, theta_dot, theta_ddot, tau)
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^too few samples: 2 × 3 efforts for 13"):
        pkmlab.identify(PAPER, q[:2], theta_dot[:2], theta_ddot[:2], tau[:2])
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^base must be the base parameters of this model"):
        pkmlab.identify(PAPER, q, theta_dot, theta_ddot, tau, base=pkmlab.base_parameters(FIVE_BAR))


def test_scaled_condition_number_ignores_units():
    W = np.random.default_rng(0).standard_normal((40, 3))
    assert scaled_condition_number(W * [1.0, 1e6, 1e-6]) == pytest.approx(scaled_condition_number(W), rel=1e-9)
    assert scaled_condition_number(np.column_stack([W[:, 0], W[:, 0], W[:, 1]])) > 1e12


def test_follow_path_agrees_with_branch_following_and_names_the_row_it_cannot_reach():
    t, q, _, _ = fourier_motion(FIVE_BAR, seconds=2.0, rate=200.0)
    step = pkmlab.branch_following(FIVE_BAR, q[:-1], q[1:, :2])
    assert np.abs(step - q[1:]).max() < 1e-10
    theta = q[:, :2].copy()
    theta[150:] += 3.0  # a jump that could land on another branch unseen
    with pytest.raises(pkmlab.BranchFollowingError, match=r"^theta at row 150 jumps by 3 from the row before it"):
        pkmlab.follow_path(FIVE_BAR, q[0], theta)
    theta = q[:, :2] + np.clip(np.arange(len(q)) - 100, 0, None)[:, None] * [0.01, 0.0]  # drifts out of reach
    with pytest.raises(pkmlab.BranchFollowingError, match=r"^theta at row 1\d\d .* cannot be reached from the row"):
        pkmlab.follow_path(FIVE_BAR, q[0], theta)


def test_the_log_filter_refuses_bad_time_by_row():
    t, q, theta_dot, theta_ddot = fourier_motion(FIVE_BAR, seconds=1.0)
    tau = np.zeros_like(theta_dot)
    back = t.copy()
    back[400] = back[398]
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^t at row 400 .* is not after the row before it"):
        pkmlab.filter_measurements(FIVE_BAR, back, q[:, :2], tau)
    jitter = t.copy()
    jitter[300:] += 0.0005
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^t at row 300: a step of 0\.0015 s .*fixed sampling"):
        pkmlab.filter_measurements(FIVE_BAR, jitter, q[:, :2], tau)
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^too few samples: 20 rows, and the filter's window"):
        pkmlab.filter_measurements(FIVE_BAR, t[:20], q[:20, :2], tau[:20])


# ------------------------------------------------------------------ the command line
def _write_log(path, model, t, theta, tau, pose=None, extra=""):
    n = model.n_actuators
    header = ["t", *(f"theta{j + 1}" for j in range(n)), *(f"tau{j + 1}" for j in range(n))]
    columns = [t[:, None], theta, tau]
    if pose is not None:
        header += list(model.pose_names)
        columns.append(pose)
    rows = np.hstack(columns)
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in rows)
                    + "\n" + extra)
    return path


def _pkmlab(*args, cwd):
    return subprocess.run([sys.executable, "-m", "pkmlab.cli", *args], capture_output=True, text=True, cwd=cwd)


@pytest.fixture(scope="module")
def paper_log():
    t, q, theta_dot, theta_ddot = fourier_motion(PAPER, seconds=4.0)
    tau = pkmlab.inverse_dynamics(PAPER, q, theta_dot, theta_ddot)
    tau += 0.002 * np.random.default_rng(0).standard_normal(tau.shape)
    return t, q, tau


def test_identify_reads_a_log_and_writes_its_results(tmp_path, paper_log):
    t, q, tau = paper_log
    log = _write_log(tmp_path / "log.csv", PAPER, t, q[:, :3], tau, pose=q[:, -3:])
    done = _pkmlab("identify", str(log), "--efforts", "sampled", "--out", "result", "--json", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    written = json.loads((tmp_path / "result" / "identification.json").read_text())
    # the rows whose filter window holds a rate's reversal left out, as the API leaves them out
    kept = pkmlab.filter_measurements(PAPER, t, q[:, :3], tau, pose=q[0, -3:], efforts="sampled")
    assert written == out and out["reversals"] == "drop" and out["samples"] == len(kept.t) < len(t[::15])
    truth = pkmlab.base_parameters(PAPER).of(pkmlab.inertial_parameters(PAPER))
    rows = out["base_parameters"]
    assert len(rows) == 13
    for row, value in zip(rows, truth, strict=True):  # within 5 σ of the truth
        assert abs(row["estimate"] - value) < 5 * row["sigma"] + 1e-9, row
    csv_lines = (tmp_path / "result" / "base_parameters.csv").read_text().splitlines()
    assert csv_lines[0] == "name,estimate,sigma,relative_sigma_percent" and len(csv_lines) == 14
    table = _pkmlab("identify", str(log), "--efforts", "sampled", cwd=tmp_path)
    assert table.returncode == 0 and "platform.Izz" in table.stdout and "sigma %" in table.stdout
    every = _pkmlab("identify", str(log), "--efforts", "sampled", "--reversals", "keep", "--json", cwd=tmp_path)
    assert every.returncode == 0 and json.loads(every.stdout)["samples"] == len(t[::15])


@pytest.mark.parametrize("change, message", [
    (lambda h, rows: (h.replace(",tau2", ""), [r[:-3] + r[-2:] for r in rows]), r"missing column tau2"),
    (lambda h, rows: (h, rows[:5] + [rows[5][:1] + ["nan"] + rows[5][2:]] + rows[6:]),
     r"row 6 \(line 7\): theta1 = 'nan' is not a finite number"),
    (lambda h, rows: (h, rows[:9] + [rows[8]] + rows[10:]), r"t at row 10 .* is not after the row before it"),
    (lambda h, rows: (h, [[r[0], str(float(r[1]) * 180 / np.pi), *r[2:]] for r in rows]),
     r"column theta1 reaches .* cannot be radians"),
    (lambda h, rows: (h, rows[:1]), r"too few samples \(1 row\)"),
    (lambda h, rows: (h, rows[:30]), r"too few samples: 30 rows, and the filter's window"),
    (lambda h, rows: (h, [[str(float(r[0]) * 1000), *r[1:]] for r in rows]),
     r"log.csv: the filter's window of 0.05 s spans 0.05 samples at the log's step of 1 s.*is t in seconds\?"),
])
def test_a_bad_log_is_refused_in_one_line_and_nothing_is_written(tmp_path, paper_log, change, message):
    t, q, tau = paper_log
    log = _write_log(tmp_path / "log.csv", PAPER, t[:400], q[:400, :3], tau[:400])
    header, *rows = log.read_text().splitlines()
    header, rows = change(header, [r.split(",") for r in rows])
    log.write_text(header + "\n" + "\n".join(",".join(r) for r in rows) + "\n")
    done = _pkmlab("identify", str(log), "--out", "result", cwd=tmp_path)
    assert done.returncode == 1 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pkmlab identify: error: "), done.stderr
    assert re.search(message, lines[0]), lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv"]


def test_a_friction_model_without_the_drives_is_refused(tmp_path, paper_log):
    t, q, tau = paper_log
    log = _write_log(tmp_path / "log.csv", PAPER, t[:400], q[:400, :3], tau[:400])
    done = _pkmlab("identify", str(log), "--coulomb-rate", "1e-3", "--out", "result", cwd=tmp_path)
    assert done.returncode == 1 and done.stderr.strip() == ("pkmlab identify: error: --coulomb-rate is the drives' "
                                                            "friction model: it needs --drives")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv"]


def test_a_log_that_leaves_the_machine_names_the_row(tmp_path, paper_log):
    t, q, tau = paper_log
    theta = q[:400, :3] + np.clip(np.arange(400) - 250, 0, None)[:, None] * [0.01, 0.0, 0.0]  # drifts out of reach
    log = _write_log(tmp_path / "log.csv", PAPER, t[:400], theta, tau[:400])
    done = _pkmlab("identify", str(log), cwd=tmp_path)
    assert done.returncode == 1
    assert len(done.stderr.splitlines()) == 1
    assert re.search(r"leaves the machine's reach: theta at row \d+ .* cannot be reached", done.stderr)


def test_identify_validates_on_a_held_out_log(tmp_path, paper_log):
    t, q, tau = paper_log
    log = _write_log(tmp_path / "log.csv", PAPER, t, q[:, :3], tau, pose=q[:, -3:])
    t2, q2, rates2, accelerations2 = fourier_motion(PAPER, seconds=3.0, seed=9)  # another motion
    held = pkmlab.inverse_dynamics(PAPER, q2, rates2, accelerations2)
    other = _write_log(tmp_path / "held.csv", PAPER, t2, q2[:, :3], held, pose=q2[:, -3:])
    done = _pkmlab("identify", str(log), "--efforts", "sampled", "--validate", str(other), "--out", "result", "--json",
                   cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    validation = json.loads(done.stdout)["validation"]
    # the noise-free held-out efforts predicted to a small share of their size (the estimate's noise only)
    assert all(e < 0.05 * r for e, r in zip(validation["rms_error"], validation["rms_effort"], strict=True))
    assert (tmp_path / "result" / "prediction.png").stat().st_size > 10_000


def test_the_identified_machine_and_drives_run_as_the_controllers_model_from_files(tmp_path):
    """A user's loop by files alone: a run of the plant with drives and an encoder (examples/identification/
    excitation.toml), identified with --drives --consistent; its controller.toml, pasted into a scenario of the
    real machine, makes the controller compute with identified.toml and the identified drives — the friction
    found to 5 % — and the circle tracked closer than with the described model alone."""
    import shutil
    import tomllib

    shutil.copy(Path(__file__).parents[1] / "examples" / "identification" / "excitation.toml", tmp_path)
    run = _pkmlab("simulate", "excitation.toml", "--out", "run", "--no-figures", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    done = _pkmlab("identify", "run/run.csv", "--drives", "--coulomb-rate", "1e-3", "--consistent", "--out", "id",
                   cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    controller = tomllib.loads((tmp_path / "id" / "controller.toml").read_text())["controller"]
    assert controller["mechanism"] == "identified.toml"
    assert controller["viscous"] == pytest.approx([0.01] * 3, rel=0.05)
    real = {"mechanism": {"preset": "paper"},
            "trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2},
            "plant": {"armature": 2e-4, "viscous": 0.01, "coulomb": 0.003, "coulomb_rate": 1e-3},
            "simulation": {"working_mode": "auto"}}
    identified = pkmlab.load_scenario(_toml(tmp_path / "id" / "real.toml", {**real, "controller": controller}))
    assert identified.model.description == pkmlab.load(tmp_path / "id" / "identified.toml").description
    assert identified.plant_model.description == PAPER.description
    assert identified.controller_drives.viscous == pytest.approx(tuple(controller["viscous"]))
    described = pkmlab.load_scenario(_toml(tmp_path / "id" / "described.toml", real))
    errors = [pkmlab.simulate(s).summary()["max_path_error_m"] for s in (identified, described)]
    assert errors[0] < 0.5 * errors[1], errors
    (tmp_path / "delta.toml").write_text(pkmlab.description.files.mechanism_to_toml(pkmlab.load("delta").description,
                                                                                   "a Delta"))
    bad = _pkmlab("simulate", _toml(tmp_path / "bad.toml", {**real, "controller": {"mechanism": "delta.toml"}}),
                  "--out", "bad", cwd=tmp_path)
    assert bad.returncode == 1 and len(bad.stderr.splitlines()) == 1, bad.stderr
    assert "[controller].mechanism 'delta.toml' is a 3-R*US, the machine a 3-R*RR" in bad.stderr, bad.stderr
    assert not (tmp_path / "bad").exists()



def _toml(path, data: dict):
    """``data`` written as a scenario file at ``path``."""
    from pkmlab.formats.scenario import scenario_to_toml

    path.write_text(scenario_to_toml(data))
    return path
