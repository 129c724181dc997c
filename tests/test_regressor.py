"""The dynamics regressor and the base parameters (pkmlab.algorithms.regressor), checked against the model's
own inverse dynamics (a second formulation: Newton–Euler about the mass centres, not linear in the parameters)
and against what rigid-body theory says cannot be identified."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import pkmlab

CATALOGUE = Path(__file__).parents[1] / "examples" / "mechanisms"
MACHINES = ["paper", "five_bar", "3rpr", "3prr", "delta", "stewart", CATALOGUE / "3prs.toml",
            CATALOGUE / "3upu.toml"]


def _id(machine) -> str:
    return Path(str(machine)).stem


@pytest.fixture(scope="module", params=MACHINES, ids=_id)
def machine(request):
    model = pkmlab.load(request.param)
    return model, pkmlab.random_states(model, 16, seed=5)


def test_the_regressor_times_the_parameters_is_the_inverse_dynamics(machine):
    model, (q, theta_dot, theta_ddot) = machine
    Y = pkmlab.dynamics_regressor(model, q, theta_dot, theta_ddot)
    pi = pkmlab.inertial_parameters(model)
    assert Y.shape == (len(q), model.n_actuators, len(pkmlab.inertial_parameter_names(model)))
    assert pi.shape == Y.shape[-1:]
    tau = pkmlab.inverse_dynamics(model, q, theta_dot, theta_ddot)
    assert np.abs(Y @ pi - tau).max() <= 1e-12 * np.abs(tau).max()


def test_the_random_states_are_on_the_loop_closures_and_reproducible(machine):
    model, (q, theta_dot, theta_ddot) = machine
    size = pkmlab.algorithms.kinematics.length_scale(model)
    assert np.abs(pkmlab.constraint_residual(model, q)).max() < 1e-10 * size
    assert np.abs(pkmlab.singularity_measure(model, q)).min() > 0
    again = pkmlab.random_states(model, 16, seed=5)
    assert all(np.array_equal(a, b) for a, b in zip(again, (q, theta_dot, theta_ddot), strict=True))
    assert not np.array_equal(pkmlab.random_states(model, 16, seed=6)[0], q)


def test_the_base_parameters_give_the_same_efforts_on_other_states(machine):
    """Found on one set of states, the regrouping holds on any other: it is the machine's, not the data's."""
    model, (q, theta_dot, theta_ddot) = machine
    base = pkmlab.base_parameters(model, seed=1)
    Y = pkmlab.dynamics_regressor(model, q, theta_dot, theta_ddot)
    pi = pkmlab.inertial_parameters(model)
    assert np.abs(base.regressor(Y) @ base.of(pi) - Y @ pi).max() <= 1e-10 * np.abs(Y @ pi).max()
    again = pkmlab.base_parameters(model, seed=2)
    assert again.names == base.names and np.allclose(again.combination, base.combination, atol=1e-9)
    # every standard parameter is kept, regrouped or unidentifiable
    used = set(base.independent) | set(np.flatnonzero(np.abs(base.combination).sum(axis=0)))
    assert used | {base.parameters.index(n) for n in base.unidentifiable} == set(range(len(base.parameters)))


def test_noise_free_efforts_give_the_base_parameters_back_exactly(machine):
    model, _ = machine
    base = pkmlab.base_parameters(model)
    q, theta_dot, theta_ddot = pkmlab.random_states(model, 40, seed=11)
    tau = pkmlab.inverse_dynamics(model, q, theta_dot, theta_ddot)
    Yb = base.regressor(pkmlab.dynamics_regressor(model, q, theta_dot, theta_ddot))
    estimate = np.linalg.lstsq(Yb.reshape(-1, base.rank), tau.ravel(), rcond=None)[0]
    truth = base.of(pkmlab.inertial_parameters(model))
    assert np.abs(estimate - truth).max() <= 1e-8 * np.abs(truth).max()


def _with_body(description, leg: int, k: int, **changes):
    legs = list(description.legs)
    bodies = list(legs[leg].bodies)
    bodies[k] = replace(bodies[k], **changes)
    legs[leg] = replace(legs[leg], bodies=tuple(bodies))
    return replace(description, legs=tuple(legs))


def _efforts_and_base(description, states, base):
    model = pkmlab.load(description)
    return pkmlab.inverse_dynamics(model, *states), base.of(pkmlab.inertial_parameters(model))


def test_a_link_turning_about_a_fixed_joint_in_a_level_plane_shows_only_its_inertia_about_the_joint():
    """The paper's machine lies in a level plane: its proximal links' masses and mass centres move no effort
    as long as each link's inertia about its base joint is kept (Steiner) — unidentifiable, as reported."""
    model = pkmlab.load("paper")
    base = pkmlab.base_parameters(model)
    assert {"body1_1.m", "body1_1.mx", "body1_1.my"} <= set(base.unidentifiable)
    assert "body1_1.Izz" not in base.unidentifiable
    states = pkmlab.random_states(model, 12, seed=4)
    link = model.description.legs[0].bodies[0]
    about_joint = link.inertia + link.mass * float(np.dot(link.com, link.com))
    mass, com = 2.0 * link.mass, (0.05, 0.02)
    inertia = about_joint - mass * float(np.dot(com, com))
    moved = _with_body(model.description, 0, 0, mass=mass, com=com, inertia=inertia)
    tau, pi_b = _efforts_and_base(model.description, states, base)
    tau_moved, pi_b_moved = _efforts_and_base(moved, states, base)
    assert np.abs(tau_moved - tau).max() <= 1e-12 * np.abs(tau).max()
    assert np.allclose(pi_b_moved, pi_b, rtol=0, atol=1e-12)
    # a change the efforts do see (the distal link's inertia) moves the base parameters
    heavier = _with_body(model.description, 0, 1, inertia=2.0 * model.description.legs[0].bodies[1].inertia)
    tau_heavier, pi_b_heavier = _efforts_and_base(heavier, states, base)
    assert np.abs(tau_heavier - tau).max() > 1e-6 * np.abs(tau).max()
    assert not np.allclose(pi_b_heavier, pi_b, rtol=0, atol=1e-9)


def test_mass_moved_along_a_hinge_axis_is_unidentifiable():
    """The Delta's upper arm turns about a fixed hinge (leg 1: along y): moving its mass centre along that axis
    changes neither the efforts (gravity's moment about the axis, the inertia about it) nor the base
    parameters."""
    model = pkmlab.load("delta")
    assert np.allclose(model.description.legs[0].joints[0].axes[0], (0.0, 1.0, 0.0))
    base = pkmlab.base_parameters(model)
    assert "body1_1.my" in base.unidentifiable
    states = pkmlab.random_states(model, 12, seed=4)
    arm = model.description.legs[0].bodies[0]
    moved = _with_body(model.description, 0, 0, com=(arm.com[0], 0.03, arm.com[2]))
    tau, pi_b = _efforts_and_base(model.description, states, base)
    tau_moved, pi_b_moved = _efforts_and_base(moved, states, base)
    assert np.abs(tau_moved - tau).max() <= 1e-12 * np.abs(tau).max()
    assert np.allclose(pi_b_moved, pi_b, rtol=0, atol=1e-12)
    assert not np.allclose(pkmlab.inertial_parameters(pkmlab.load(moved)), pkmlab.inertial_parameters(model))


def test_a_distal_mass_is_regrouped_onto_the_link_it_rides_on():
    """The five-bar's distal link's mass sits at its elbow, at the proximal link's length l from the base joint:
    it adds m l² to the proximal link's inertia about that joint (the classic regrouping)."""
    model = pkmlab.load("five_bar")
    base = pkmlab.base_parameters(model)
    tip = np.hypot(*model.description.legs[0].bodies[0].tip)
    row = base.combination[base.parameters.index("body1_1.Izz") == base.independent][0]
    assert row[base.parameters.index("body1_2.m")] == pytest.approx(tip**2, rel=1e-9)
    assert base.names[list(base.independent).index(base.parameters.index("body1_1.Izz"))].startswith("body1_1.Izz + ")


def test_the_stewart_legs_pistons_ride_on_the_platform():
    """A piston's frame is at its spherical joint, a point of the platform: its mass is a point mass of the
    platform there, so the platform's mass absorbs all six."""
    base = pkmlab.base_parameters(pkmlab.load("stewart"))
    name = base.names[list(base.independent).index(base.parameters.index("platform.m"))]
    assert name == "platform.m + " + " + ".join(f"body{i}_2.m" for i in range(1, 7))


def test_states_that_are_not_a_triple_are_refused_by_name():
    model = pkmlab.load("five_bar")
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^states must be \(q, theta_dot, theta_ddot\)"):
        pkmlab.base_parameters(model, states=np.zeros(3))
    q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    off = q.copy()
    off[0] += 0.3
    with pytest.raises(pkmlab.PkmlabError, match=r"^states: .*off the loop closure"):
        pkmlab.base_parameters(model, states=(off[None], np.ones((1, 2)), np.ones((1, 2))))
