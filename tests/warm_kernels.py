"""Compile the kernels of the spatial machines (the Delta, the Stewart platform, the 3-PRS, the 3-UPU, the 3-RRS; for
their forward kinematics the 3-RPS, the 6-RUS and the 6-PUS) into the kernel cache, by calling every compiled entry
point the test suite calls on them.

Their first compiles are the largest cost of a test run on a fresh checkout (about a minute for the Stewart
platform's actuator-space model alone). ``conftest.py`` starts this script in a second process when a test
session begins and runs the tests that use these machines last, so that the compiles happen on the core the
tests leave idle and the tests load them from the cache. It checks nothing: a failure here only means that
the tests compile what they need themselves (as without it). Run alone: ``python tests/warm_kernels.py``.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np

import pkmlab
from pkmlab.algorithms import assembly, calibration, general_fk

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: A regular pose of each machine (as in the tests) and the scenario file of a short tracking run.
MACHINES = {
    "delta": ([0.05, -0.03, -0.75], "delta_pick_and_place.toml"),
    "stewart": ([0.0, 0.0, 0.85, 0.05, -0.03, 0.1], "stewart_motion.toml"),
    str(EXAMPLES / "mechanisms" / "3prs.toml"): ([0.45, 0.05, -0.03], "mechanisms/3prs_motion.toml"),
    str(EXAMPLES / "mechanisms" / "3upu.toml"): ([0.02, -0.01, 0.62], "mechanisms/3upu_motion.toml"),
    str(EXAMPLES / "mechanisms" / "3rrs.toml"): ([0.34, 0.05, -0.03], "mechanisms/3rrs_motion.toml"),
}
#: Machines whose tests call only their forward kinematics, the loop closures' kernels (test_catalogue_fk) and the
#: actuator-space model (test_mujoco_export).
FORWARD_ONLY = {str(EXAMPLES / "mechanisms" / name): pose for name, pose in
                (("3rps.toml", [0.5, 0.05, -0.03]), ("6rus.toml", [0.0, 0.0, -0.30, 0.05, -0.03, 0.1]),
                 ("6pus.toml", [0.0, 0.0, -0.30, 0.05, -0.03, 0.1]))}
#: Machines whose tests call only the kinematics, the actuator-space model and one sampled-data run.
LIGHT = {str(EXAMPLES / "mechanisms" / name) for name in ("3prs.toml", "3upu.toml", "3rrs.toml")}


def warm_light(name: str) -> None:
    pose, scenario_file = MACHINES[name]
    model = pkmlab.load(name)
    ik = pkmlab.inverse_kinematics(model, pose)
    q = ik.q.reshape(-1, len(model.coordinates))[0]
    pkmlab.singularity_measure(model, q)
    pkmlab.actuator_space_model(model, q, np.linspace(0.1, 0.2, model.n_actuators))
    pkmlab.simulate(pkmlab.load_scenario(EXAMPLES / scenario_file))
    general_fk.generic_solutions(model.description)  # its monodromy, kept in the cache folder


def warm_forward(name: str) -> None:
    model = pkmlab.load(name)
    q = pkmlab.inverse_kinematics(model, FORWARD_ONLY[name], pkmlab.working_modes(model)[0]).q
    n = model.n_actuators
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assembly.assembly_modes(model, q[:n])  # its kernels, its monodromy (kept in the cache folder), the tracker
    k = model.kernels
    k.constraint_jacobians(q[None, :], model.P, np.empty((1, k.N_CONSTRAINTS, len(q))))
    pkmlab.actuator_space_model(model, q, np.linspace(0.1, 0.2, n))  # MuJoCo's hard-constraint check


def warm(name: str) -> None:
    if name in FORWARD_ONLY:
        warm_forward(name)
        return
    if name in LIGHT:
        warm_light(name)
        return
    pose, scenario_file = MACHINES[name]
    model = pkmlab.load(name)
    ik = pkmlab.inverse_kinematics(model, pose)
    q = ik.q.reshape(-1, len(model.coordinates))[0]
    n = model.n_actuators
    theta_dot = np.linspace(0.1, 0.2, n)
    pkmlab.singularity_measure(model, q)
    pkmlab.constraint_residual(model, q)
    pkmlab.constraint_jacobian(model, q)
    pkmlab.velocity_jacobian(model, q)
    pkmlab.coordinate_jacobian(model, q)
    q_dot = pkmlab.coordinate_rates(model, q, theta_dot)
    pkmlab.acceleration_bias(model, q, theta_dot)
    pkmlab.actuator_space_model(model, q, theta_dot)
    pkmlab.full_space_model(model, q, q_dot)
    pkmlab.constrained_dynamics(model, q, q_dot, np.zeros(n))
    pkmlab.inverse_dynamics(model, q, theta_dot, np.zeros(n))
    pkmlab.forward_dynamics(model, q, theta_dot, np.zeros(n))
    pkmlab.branch_following(model, q, q[:n] + 1e-3)
    pkmlab.follow_path(model, q, np.linspace(q[:n], q[:n] + 1e-3, 3))  # and calibration's batch of it
    pkmlab.inverse_kinematics(model, pose, pkmlab.working_modes(model)[0], on_unreachable="nan")
    calibration.predicted_measurements(model, q[None, :n], np.asarray(pose, dtype=float)[None, :],
                                       measure="pose")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assembly.assembly_modes(model, q[:n])
    pkmlab.ActuatorSpacePlant(model).simulate(q, theta_dot, np.zeros(n), 1e-3)
    pkmlab.FullSpacePlant(model).simulate(q, q_dot, np.zeros(n), 1e-3)
    scenario = pkmlab.load_scenario(EXAMPLES / scenario_file)
    pkmlab.simulate(scenario)
    pkmlab.simulate_batch([scenario, scenario])
    pkmlab.simulate(scenario.replace(sample_time=0.0))


def main(names: list[str]) -> int:
    for name in names or [*MACHINES, *FORWARD_ONLY]:
        warm(name)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
