"""The loop closed on the paper's machine: a real plant unlike its description — masses and lengths 15 % off
(the paper's "disturbed" case), drive friction and armature, a 20-bit encoder — calibrated from measured poses,
excited and identified, and the paper's circle run again with the calibrated, identified model as the
controller's.

Run: python examples/identification/paper_loop.py   (about 15 s once compiled)
"""

import numpy as np

import pkmlab
from pkmlab.algorithms.calibration import calibrate, geometric_parameters
from pkmlab.algorithms.consistency import identified_model, physically_consistent
from pkmlab.control.excitation import excitation_trajectory
from pkmlab.model import mechanism_model as mm
from pkmlab.simulation.realism import Drives, Sensors
from pkmlab.simulation.scenario import scaled_model

rng = np.random.default_rng(2026)
model = pkmlab.load("paper")                                  # what we believe
true = scaled_model(model, mass=1.15, length=1.15)            # what the machine is
drives = Drives(armature=2e-4, viscous=0.01, coulomb=0.003, coulomb_rate=1e-3)
# a 20-bit encoder, the only sensor: the rates are its readings' second-order backward difference — the first
# difference lags half a sample, which alone costs about 60 um on this circle (rates="difference"); a drive with a
# tachometer would give rates="exact"
encoder = Sensors(resolution=2 * np.pi / 2**20, rates="backward2")
nominal = pkmlab.paper_scenario("nominal")
mode = pkmlab.simulate(nominal).working_mode  # the task's working mode: every pose below is measured in it
nominal = nominal.replace(working_mode=mode)


def path_error(controller_model, controller_drives=None, sensors=encoder):
    run = pkmlab.simulate(nominal.replace(model=controller_model, plant=true, drives=drives, sensors=sensors,
                                          controller_drives=controller_drives))
    return run.summary()["max_path_error_m"]


reference = pkmlab.simulate(nominal).summary()["max_path_error_m"]
print(f"nominal case (ideal plant = model):      {reference:.3e} m")
print(f"real plant, the described model:          {path_error(model):.3e} m")

# 1. calibration: 60 poses measured with 1 um and 10 urad of noise, the readings of the true machine
poses, readings = [], []
while len(poses) < 60:
    pose = np.array([0.25, 0.21, 0.0]) + rng.uniform(-1, 1, 3) * [0.07, 0.07, 0.3]  # the task's region and more
    try:
        q = mm.inverse_kinematics(true, pose, mode)
    except pkmlab.PkmlabError:
        continue
    # a pose the described machine cannot even assemble at these readings cannot start a calibration from it
    if abs(mm.singularity_measure(true, q)) > 0.05 and int(pkmlab.forward_kinematics(model, q[:3]).count) > 0:
        poses.append(pose + rng.standard_normal(3) * [1e-6, 1e-6, 1e-5])
        readings.append(q[:3])
# the encoders are homed (their zeros known): the geometry alone is calibrated
geometry_only = [n for n in geometric_parameters(model) if not n.startswith("offset")]
calibration = calibrate(model, np.array(readings), np.array(poses), measure="pose", names=geometry_only)
print(f"calibration: RMS residual {calibration.rms_before:.2e} -> {calibration.rms_after:.2e} "
      f"({len(calibration.fixed)} parameters the poses do not determine, kept)")
geometry = calibration.model

# 2. excitation, run on the real machine, logged as it would be (encoder readings, commanded efforts)
excitation = excitation_trajectory(geometry, harmonics=5, iterations=30, period=10.0, seed=1)
run = pkmlab.simulate(pkmlab.Scenario(geometry, excitation.trajectory, plant=true, working_mode=excitation.mode,
                                      drives=drives, sensors=encoder))
data = pkmlab.filter_measurements(geometry, run.t, run.theta_measured, run.tau, pose=run.pose[0],
                                  mode=excitation.mode)
# identified with the friction model the controller will compensate with (a sign fitted to a smooth friction,
# or the reverse, is wrong exactly where the excitation starts and ends: at rest)
identification = pkmlab.identify(geometry, *data.states, data.tau, drives=True, coulomb_rate=drives.coulomb_rate)
estimate = physically_consistent(geometry, identification)
identified = identified_model(geometry, estimate)
compensation = Drives.from_estimate(estimate, 3, coulomb_rate=drives.coulomb_rate)
print(f"identification: condition number {identification.condition_number:.3g}; viscous friction "
      f"{', '.join(f'{v:.4f}' for v in compensation.viscous)} (true 0.0100)")

# 3. the circle again, the controller computing with the calibrated, identified model and drives
closed = path_error(identified, compensation)
print(f"real plant, calibrated and identified:    {closed:.3e} m")
tachometer = path_error(identified, compensation, Sensors(resolution=encoder.resolution, rates="exact"))
print(f"  with a tachometer for the rates:        {tachometer:.3e} m ({tachometer / reference:.2f}x)")
print(f"ratio to the nominal case: {closed / reference:.2f}")
