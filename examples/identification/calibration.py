"""Kinematic calibration as it is done on a real machine: the measurement poses planned on the described machine
(D-optimal among candidates spread over the workspace), the machine as built driven to them and measured by an
instrument with 10 um of noise, its geometry calibrated, and the result checked on 50 held-out poses.

The Delta's geometry is off by up to 1 mm and its joint axes and encoders' zeros by up to 0.5 deg, and a laser
tracker measures its platform's point; the Stewart platform's 42 joint positions are off by up to 1 mm, its joint
axes by up to 0.5 deg and its 6 legs' zeros by up to 1 mm, and its whole pose is measured (10 um, 10 urad).

Run: python examples/identification/calibration.py   (about 10 s once compiled)
"""

import numpy as np

import pkmlab
from pkmlab.algorithms.calibration import calibrate, perturbed_geometry, reachable_poses, select_poses

NOISE = 1e-5  # the instrument's standard deviation per measured coordinate (m, rad)


def as_driven(machine, offsets, readings, near, mode):
    """Where ``machine`` really is when its actuators read ``readings``: its configuration followed (forward
    kinematics by branch following) from the pose ``near`` it was sent to, to its true actuator values."""
    poses = []
    for theta, target in zip(readings, near, strict=True):
        start = pkmlab.inverse_kinematics(machine, target, mode).q
        path = np.linspace(start[: machine.n_actuators], theta + offsets, 5)
        poses.append(pkmlab.follow_path(machine, start, path)[-1, -machine.description.dof:])
    return np.array(poses)


def calibrated_on(name, measure, poses, seed):
    rng = np.random.default_rng(seed)
    model = pkmlab.load(name)  # the machine as described
    built, offsets = perturbed_geometry(model, rng, size=1e-3)  # and as built
    # plan: candidate poses of the described machine, the readings that would reach them, the best of them
    mode = pkmlab.working_modes(model)[0]
    candidates, q = reachable_poses(model, 600, rng, mode=mode)
    # a pose that would take the machine as built past an actuator's stroke is not visited (in this simulation
    # of the machine, the test is its inverse kinematics; on the machine, its limit switches)
    visited = [k for k, pose in enumerate(candidates)
               if np.all(np.isfinite(pkmlab.inverse_kinematics(built, pose, mode, on_unreachable="nan").q))]
    candidates, q = candidates[visited], q[visited]
    readings = q[:, : model.n_actuators]
    chosen = select_poses(model, readings, candidates, poses, measure=measure)
    # measure: the machine driven to those readings, its platform measured with noise
    columns = [i for i, n in enumerate(model.pose_names) if measure == "pose" or n in ("x", "y", "z")]
    true = as_driven(built, offsets, readings[chosen], candidates[chosen], mode)
    measured = true[:, columns] + NOISE * rng.standard_normal((poses, len(columns)))
    result = calibrate(model, readings[chosen], measured, measure=measure)
    # held out: 50 other poses of the built machine, predicted by the calibrated one from the readings alone
    others = np.setdiff1d(np.arange(len(candidates)), chosen)[:50]
    held_true = as_driven(built, offsets, readings[others], candidates[others], mode)
    predicted = as_driven(result.model, result.offsets, readings[others], held_true, mode)
    point = [i for i, n in enumerate(model.pose_names) if n in ("x", "y", "z")]
    error = np.linalg.norm(predicted[:, point] - held_true[:, point], axis=1)
    before = np.linalg.norm(candidates[others][:, point] - held_true[:, point], axis=1)
    print(f"{name}: {len(result.names)} parameters, {len(result.fixed)} not determined by the poses (kept); "
          f"O1 {result.observability:.3g}")
    print(f"  {poses} measured poses: RMS residual {result.rms_before:.2e} -> {result.rms_after:.2e} "
          f"(noise {NOISE:.0e})")
    print(f"  50 held-out poses: worst position error {before.max():.2e} m described, {error.max():.2e} m "
          "calibrated")
    orientation = [i for i in range(len(model.pose_names)) if i not in point]
    if orientation:
        angle = np.abs(predicted[:, orientation] - held_true[:, orientation]).max()
        print(f"  and worst orientation error {angle:.2e} rad")
    print(f"{name} held-out error / noise: {error.max() / NOISE:.2f}")
    return result


calibrated_on("delta", "position", 40, seed=0)
calibrated_on("stewart", "pose", 50, seed=1)
