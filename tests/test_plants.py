"""The two plants for every machine (pkmlab.simulation.plants): ActuatorSpacePlant (eq. 35 in (θ, θ̇), branch following)
and FullSpacePlant (all coordinates with the loop-closure multipliers, eq. 26, Baumgarte-stabilised).

Independent checks only: the two formulations against each other on every preset, conservation of energy
(kinetic from the full-space mass matrix, potential from the bodies' mass centres and masses), the power
balance under effort by finite differences, the loop closure, the paper's own 7-coordinate plants
(``pkmlab.paper.plant``) as the oracle for the paper's machine, and one-line refusals that name the argument.
"""

from __future__ import annotations

import doctest

import numpy as np
import pytest

import pkmlab
from pkmlab.errors import BranchFollowingError, InvalidParameterError, PkmlabError
from pkmlab.model import mechanism_model as mm
from pkmlab.simulation import plants

#: A regular pose of each preset and, where it has several, the working mode to start in (None: the first
#: reachable mode with |S| > 0.05).
START = {
    "paper": ([0.20, 0.21, 0.0], (1, -1, 1)),
    "five_bar": ([0.0, 0.35], (1, -1)),
    "3rpr": ([0.25, 0.2, 0.3], None),
    "3prr": ([0.26, 0.2, 0.1], None),
    "delta": ([0.05, -0.03, -0.75], None),
    "stewart": ([0.0, 0.0, 0.85, 0.05, -0.03, 0.1], None),
}


@pytest.fixture(scope="module")
def models():
    return {name: pkmlab.load(name) for name in START}


def _start(model, name):
    """A configuration from inverse kinematics at the preset's pose, in a mode with |S| > 0.05."""
    pose, mode = START[name]
    ik = pkmlab.inverse_kinematics(model, pose, mode, on_unreachable="nan")
    qs = ik.q.reshape(-1, len(model.coordinates))
    s = np.atleast_1d(ik.S)
    regular = np.flatnonzero(np.isfinite(s) & (np.abs(np.nan_to_num(s)) > 0.05))
    assert regular.size, f"{name}: no regular working mode at {pose}"
    return qs[regular[0]].copy()


#: The paper's machine reaches a gain-type singularity after its actuators move by a few hundredths of a
#: radian from its start: its runs are slower.
SLOW = {"paper": 0.25}


def _scale(model):
    """1 for a revolute actuator (rad), 0.1 for a prismatic one (m): rates and efforts of similar effect."""
    return np.where(np.array(model.kernels.ANGLES[:model.n_actuators]), 1.0, 0.1)


def _kinetic(model, run):
    fs = pkmlab.full_space_model(model, run.q, run.q_dot)
    return 0.5 * np.einsum("ki,kij,kj->k", run.q_dot, fs.M, run.q_dot), fs.g


def _potential(model, qs):
    """``V = -Σ m_b gravity · r_b`` from the bodies' mass centres (the kernels' ``body_poses``) and the
    description's masses: independent of the ``g`` vector the plants integrate with."""
    d, k = model.description, model.kernels
    bodies = [b for leg in d.legs for b in leg.bodies] + [d.platform]
    masses = np.array([b.mass for b in bodies])
    gravity = np.array(d.gravity)
    out = np.empty((k.N_BODIES, 3))
    values = []
    for q in qs:
        k.body_poses(q, mm.trig_table(model, q), model.P, out)
        values.append(-float(masses @ (out[:, :len(gravity)] @ gravity)))
    return np.array(values)


# ------------------------------------------------------------------ 1. the two plants agree, every preset
@pytest.mark.parametrize("name", list(START))
def test_the_two_plants_agree_on_every_preset(models, name):
    """Both plants integrate the same machine from the same state under the same effort (gravity
    compensation at the start, plus a smooth sinusoid and a little damping, through the callable so that both
    feed it ``(t, θ, θ̇)``) for 0.2 s.

    Tolerance: each DOP853 run keeps its local error below ``rtol |y| + atol`` = 1e-11 |y| + 1e-12 per step,
    with states of order 1 (rad, m, rad/s); over the few tens of steps of the run the global error of each is at
    most ~1e-9 — so θ(t) and every coordinate of the two runs agree to 1e-9 (they do to ~1e-11), while the
    actuators move by more than 1e-2 (rad, or 1e-3 m) over the run. Baumgarte's drift (~1e-13 m) is far below.
    """
    model = models[name]
    na, scale = model.n_actuators, _scale(model)
    q0 = _start(model, name)
    theta_dot0 = SLOW.get(name, 1.0) * scale * np.resize([0.5, -0.3, 0.2], na)
    g0 = pkmlab.actuator_space_model(model, q0, np.zeros(na)).g
    phases = np.arange(na)

    def tau(t, theta, theta_dot):
        return g0 + 0.05 * scale * np.sin(15.0 * t + phases) - 0.1 * theta_dot

    t_eval = np.linspace(0.0, 0.2, 21)
    reduced = pkmlab.ActuatorSpacePlant(model).simulate(q0, theta_dot0, tau, 0.2, t_eval)
    full = pkmlab.FullSpacePlant(model).simulate(q0, pkmlab.coordinate_rates(model, q0, theta_dot0), tau, 0.2,
                                                 t_eval)
    assert reduced.q.shape == full.q.shape == (21, len(model.coordinates))
    np.testing.assert_array_equal(reduced.t, t_eval)
    assert np.abs(reduced.theta - reduced.theta[0]).max() > 1e-2 * scale.min()  # the machine moves
    np.testing.assert_allclose(full.theta, reduced.theta, rtol=0, atol=1e-9)
    np.testing.assert_allclose(full.theta_dot, reduced.theta_dot, rtol=0, atol=1e-8)
    np.testing.assert_allclose(full.q, reduced.q, rtol=0, atol=1e-9)  # the passive coordinates and the pose
    np.testing.assert_allclose(reduced.q[0], q0, rtol=0, atol=1e-14)
    # 4. the loop stays closed: by construction in the actuator space, within Baumgarte's drift in the full one
    assert reduced.closure_violation.max() < 1e-12
    assert full.closure_violation.max() < 1e-10
    assert reduced.n_evaluations > 0 and full.n_evaluations > 0


# ------------------------------------------------------------------ 2. energy
@pytest.mark.parametrize("name", ["five_bar", "paper", "delta"])
def test_energy_is_conserved_without_effort(models, name):
    """With zero effort the total energy ``½ q̇ᵀ M q̇ + V`` is constant along each plant's run (V = 0 without
    gravity; for the Delta from the bodies' heights): to 1e-8 of the kinetic energy reached (the
    integrators' 1e-11 tolerances allow ~1e-9)."""
    model = models[name]
    na = model.n_actuators
    q0 = _start(model, name)
    theta_dot0 = SLOW.get(name, 1.0) * _scale(model) * np.resize([0.8, -0.5, 0.3], na)
    t_eval = np.linspace(0.0, 0.15, 16)
    runs = (pkmlab.ActuatorSpacePlant(model).simulate(q0, theta_dot0, np.zeros(na), 0.15, t_eval),
            pkmlab.FullSpacePlant(model).simulate(q0, pkmlab.coordinate_rates(model, q0, theta_dot0),
                                                  np.zeros(na), 0.15, t_eval))
    for run in runs:
        kinetic, _ = _kinetic(model, run)
        energy = kinetic + _potential(model, run.q)
        if name != "delta":
            np.testing.assert_allclose(_potential(model, run.q), 0.0, atol=0)
        assert np.abs(energy - energy[0]).max() < 1e-8 * kinetic.max()
    if name == "delta":  # gravity does work: the kinetic energy itself changes
        assert np.ptp(kinetic) > 1e-2 * kinetic.max()


# ------------------------------------------------------------------ 3. power balance
def test_power_balance_under_effort(models):
    """``d(KE)/dt = τ·θ̇ - q̇·g`` along the Delta's run under a time-varying effort (gravity included), by
    five-point central differences of the recorded kinetic energy: with h = 1 ms the truncation, ~h⁴/30
    |KE⁽⁵⁾| with the effort's 20 rad/s, is ~1e-9 W, and the integrators' 1e-11 tolerance over h adds ~1e-8 W
    of noise, against powers of ~0.5 W: agreement to 1e-6 of the largest power."""
    model = models["delta"]
    q0 = _start(model, "delta")
    g0 = pkmlab.actuator_space_model(model, q0, np.zeros(3)).g

    def tau(t, theta, theta_dot):
        return g0 * (1.0 + 0.3 * np.sin(20.0 * t)) + np.array([0.5, -0.4, 0.3])

    h = 1e-3
    t_eval = np.arange(0.0, 0.1 + h / 2, h)
    for plant, rate0 in ((pkmlab.ActuatorSpacePlant(model), np.array([0.5, -0.3, 0.2])),
                         (pkmlab.FullSpacePlant(model), pkmlab.coordinate_rates(model, q0, [0.5, -0.3, 0.2]))):
        run = plant.simulate(q0, rate0, tau, 0.1, t_eval)
        kinetic, g = _kinetic(model, run)
        efforts = np.array([tau(t, th, thd) for t, th, thd in zip(run.t, run.theta, run.theta_dot, strict=True)])
        power = np.einsum("ki,ki->k", efforts, run.theta_dot) - np.einsum("ki,ki->k", run.q_dot, g)
        derivative = (kinetic[:-4] - 8 * kinetic[1:-3] + 8 * kinetic[3:-1] - kinetic[4:]) / (12 * h)
        assert np.abs(power).max() > 0.1  # the effort does real work (against KE ~ 0.4 J)
        np.testing.assert_allclose(derivative, power[2:-2], rtol=0, atol=1e-6 * np.abs(power).max())


# ------------------------------------------------------------------ 4. the loop closure over a longer run
def test_the_loop_stays_closed_over_a_longer_run(models):
    """Over 1 s of free motion of the five-bar the actuator plant stays on the loop closure at round-off and
    the full plant within Baumgarte's bound; without stabilisation (ω = 0) the full plant's drift grows
    well above it."""
    model = models["five_bar"]
    q0 = _start(model, "five_bar")
    q_dot0 = pkmlab.coordinate_rates(model, q0, [0.3, -0.2])
    t_eval = np.linspace(0.0, 1.0, 11)
    reduced = pkmlab.ActuatorSpacePlant(model).simulate(q0, [0.3, -0.2], np.zeros(2), 1.0, t_eval)
    full = pkmlab.FullSpacePlant(model).simulate(q0, q_dot0, np.zeros(2), 1.0, t_eval)
    free = pkmlab.FullSpacePlant(model, stabilization=0.0).simulate(q0, q_dot0, np.zeros(2), 1.0, t_eval)
    assert reduced.closure_violation.max() < 1e-12
    assert full.closure_violation.max() < 1e-10
    assert free.closure_violation.max() > 10 * full.closure_violation.max()
    np.testing.assert_allclose(full.theta, reduced.theta, rtol=0, atol=1e-8)


# ------------------------------------------------------------------ 5. the paper's own plants as the oracle
def test_the_paper_machine_against_the_paper_plants(models):
    """The paper's machine: both new plants against the old 7-coordinate ones (``pkmlab.paper.plant``), whose
    coordinates are (θ, φ, α) = new ``q[[0, 1, 2, 3, 4, 5, 8]]``; the old FullPlant integrates the paper's own
    multiplier model (``pkmlab.paper.rrr3``), a formulation that shares no code with the new plants.
    Same tolerances as the cross-check of the presets (1e-9 on θ)."""
    from pkmlab.paper.geometry import Planar3RRR
    from pkmlab.paper.plant import FullPlant, ReducedPlant

    model = models["paper"]
    q0 = _start(model, "paper")
    old_coordinates = [0, 1, 2, 3, 4, 5, 8]
    theta_dot0 = np.array([0.2, -0.12, 0.1])

    def tau(t, theta, theta_dot):
        return np.array([0.05, -0.03, 0.02]) * np.cos(10.0 * t) - 0.05 * theta_dot

    t_eval = np.linspace(0.0, 0.2, 11)
    new = pkmlab.ActuatorSpacePlant(model).simulate(q0, theta_dot0, tau, 0.2, t_eval)
    new_full = pkmlab.FullSpacePlant(model).simulate(q0, pkmlab.coordinate_rates(model, q0, theta_dot0), tau,
                                                     0.2, t_eval)
    paper = Planar3RRR.paper()
    old = ReducedPlant(paper).simulate(q0[old_coordinates], theta_dot0, tau, 0.2, t_eval)
    old_full = FullPlant(paper).simulate(q0[old_coordinates], new.q_dot[0, old_coordinates], tau, 0.2, t_eval)
    assert np.abs(new.theta - new.theta[0]).max() > 0.02
    for run in (new, new_full):
        np.testing.assert_allclose(run.theta, old.theta, rtol=0, atol=1e-9)
        np.testing.assert_allclose(run.theta, old_full.theta, rtol=0, atol=1e-9)
        np.testing.assert_allclose(run.q[:, old_coordinates], old_full.q, rtol=0, atol=1e-9)
        np.testing.assert_allclose(run.q_dot[:, old_coordinates], old_full.q_dot, rtol=0, atol=1e-8)


# ------------------------------------------------------------------ 6. refusals
def _one_line(excinfo, *words):
    message = str(excinfo.value)
    assert "\n" not in message
    for word in words:
        assert word in message, message


@pytest.fixture(scope="module")
def five_bar(models):
    model = models["five_bar"]
    return model, _start(model, "five_bar")


@pytest.mark.parametrize("kind", ["actuator", "full"])
def test_refusals_name_the_argument(five_bar, kind):
    model, q0 = five_bar
    if kind == "actuator":
        plant, rate0 = pkmlab.ActuatorSpacePlant(model), np.zeros(2)
    else:
        plant, rate0 = pkmlab.FullSpacePlant(model), np.zeros(6)
    off = q0.copy()
    off[2] += 1e-3
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(off, rate0, [0.0, 0.0], 0.1)
    _one_line(e, "q0", "loop closure")
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0[:-1], rate0, [0.0, 0.0], 0.1)
    _one_line(e, "q0")
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, rate0, [0.0, 0.0, 0.0], 0.1)
    _one_line(e, "tau", "2 numbers")
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, rate0, [0.0, np.nan], 0.1)
    _one_line(e, "tau", "finite")
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, rate0, lambda t, theta, theta_dot: np.zeros(3), 0.1)
    _one_line(e, "tau(t, theta, theta_dot)", "2 numbers", "t = 0")
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, rate0, lambda t, theta, theta_dot: [np.inf, 0.0], 0.1)
    _one_line(e, "tau(t, theta, theta_dot)", "finite")
    for t_final in (np.inf, np.nan, -1.0, 0.0, "1"):
        with pytest.raises(InvalidParameterError) as e:
            plant.simulate(q0, rate0, [0.0, 0.0], t_final)
        _one_line(e, "t_final")
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, rate0, [0.0, 0.0], 0.1, t_eval=[0.0, 0.2])
    _one_line(e, "t_eval")
    rate_name = "theta_dot0" if kind == "actuator" else "q_dot0"
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, np.zeros(7), [0.0, 0.0], 0.1)
    _one_line(e, rate_name)
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, np.full(len(rate0), np.nan), [0.0, 0.0], 0.1)
    _one_line(e, rate_name)
    with pytest.raises(InvalidParameterError) as e:
        type(plant)("five_bar")
    _one_line(e, "model")


def test_the_full_plant_refuses_rates_off_the_tangent_space(five_bar):
    model, q0 = five_bar
    q_dot0 = pkmlab.coordinate_rates(model, q0, [0.5, -0.2])
    plant = pkmlab.FullSpacePlant(model)
    assert plant.simulate(q0, q_dot0, [0.0, 0.0], 0.01).q.shape[1] == 6
    bad = q_dot0.copy()
    bad[3] += 0.1
    with pytest.raises(InvalidParameterError) as e:
        plant.simulate(q0, bad, [0.0, 0.0], 0.01)
    _one_line(e, "q_dot0", "tangent")


def test_a_run_into_a_singularity_names_the_time(models):
    """The paper's machine coasting at θ̇ = (0.6, -0.4, 0.3) rad/s reaches a gain-type singularity at about
    0.155 s: the full plant passes through it (S changes sign; the actuators are coordinates of their own
    there), the actuator-space plant, whose model does not exist there, stops with one line naming the time."""
    model = models["paper"]
    q0 = _start(model, "paper")
    theta_dot0 = [0.6, -0.4, 0.3]
    t_eval = np.linspace(0.0, 0.2, 41)
    full = pkmlab.FullSpacePlant(model).simulate(q0, pkmlab.coordinate_rates(model, q0, theta_dot0),
                                                 np.zeros(3), 0.2, t_eval)
    s = pkmlab.singularity_measure(model, full.q)
    crossing = t_eval[np.flatnonzero(np.sign(s) != np.sign(s[0]))[0]]
    assert 0.1 < crossing < 0.2
    with pytest.raises(BranchFollowingError) as e:
        pkmlab.ActuatorSpacePlant(model).simulate(q0, theta_dot0, np.zeros(3), 0.2)
    _one_line(e, "t = ")
    stopped = float(str(e.value).split("t = ")[1].split()[0])
    assert crossing - 0.02 < stopped < crossing + 1e-9
    assert isinstance(e.value, PkmlabError)


def test_top_level_names_and_docstring_examples():
    assert pkmlab.ActuatorSpacePlant is plants.ActuatorSpacePlant
    assert pkmlab.FullSpacePlant is plants.FullSpacePlant
    assert pkmlab.PlantRun is plants.PlantRun
    result = doctest.testmod(plants, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
