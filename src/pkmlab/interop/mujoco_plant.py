"""MuJoCo as the plant: pkmlab's sampled-data controller against MuJoCo's integration of the exported machine.

The controller is the one of :func:`pkmlab.simulation.run.simulate` — computed torque (or PD) on the
controller's own model, its passive coordinates followed by branch following from the measured actuators,
the effort held over each sample — compiled as :func:`pkmlab.codegen.core.entry_points.measured_control_effort`.
The plant is MuJoCo stepping :func:`pkmlab.interop.mujoco_export.mjcf` of the scenario's plant model (its time step
``timestep``, which must divide the sample time, and its integrator), started at rest at the plant's
configuration of :func:`~pkmlab.simulation.run.simulate`. Each sample measures MuJoCo's actuated joints
(pkmlab's actuator values, :func:`~pkmlab.interop.mujoco_export.q_from_qpos`), and records, besides what every run
records, MuJoCo's loop-closure violation: the largest distance between a leg's end and its platform
attachment point (m) — zero for pkmlab's own plant, whose loops are closed to round-off.

A scenario's drives and sensors apply as on pkmlab's plant: the controller sees the sensors' readings, the
command is saturated and its noise added by the same compiled code
(:func:`pkmlab.codegen.core.entry_points.measured_control_effort`); the drives' armature, viscous and Coulomb
friction are MuJoCo's joint ``armature``, ``damping`` and ``frictionloss``
(:func:`pkmlab.interop.mujoco_export.drive_attributes`) — MuJoCo's dry friction is stick–slip, so Coulomb friction
is taken only as stick–slip friction (``stick_slip = true``).

Needs ``mujoco`` (``pip install pkmlab[mujoco]``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import InvalidParameterError, PkmlabError, UnstableControlError
from ..model.mechanism_model import pose_of
from ..simulation.result import SimulationResult
from ..simulation.run import branch_failure_text, loop_motion, prepare_run, run_measures, run_result
from ..simulation.scenario import Scenario, pose_text
from . import mujoco_export as mx

INTEGRATORS = ("RK4", "implicitfast", "implicit", "Euler")


def simulate_mujoco(scenario: Scenario, *, timestep: float | None = None, integrator: str = "RK4",
                    closures: str = "stiff", stiff: bool | None = None) -> SimulationResult:
    """Run ``scenario`` with MuJoCo as the plant (module docstring); the result has the fields of
    :func:`~pkmlab.simulation.run.simulate`'s and ``closure_violation`` (m, per sample). ``timestep`` defaults to
    the sample time or 1 ms, whichever is smaller; ``closures`` is ``"stiff"`` (default: the stiffest loop
    closures MuJoCo accepts, which behave like the rigid machine) or ``"soft"`` (MuJoCo's own defaults, whose
    loops open by up to a few millimetres: :func:`pkmlab.interop.mujoco_export.mjcf`). ``stiff`` is deprecated
    (a DeprecationWarning): ``stiff=True`` is ``closures="stiff"``, ``stiff=False`` ``closures="soft"``."""
    mx.closure_settings(closures)  # a bad name is refused before anything runs
    if stiff is not None:
        import warnings

        wanted = "stiff" if stiff else "soft"
        if closures not in ("stiff", wanted):
            raise InvalidParameterError(f"stiff={stiff!r} contradicts closures={closures!r}: give closures only")
        warnings.warn(f"simulate_mujoco's stiff= is deprecated: give closures={wanted!r} (stiff closures are "
                      "now the default)", DeprecationWarning, stacklevel=2)
        closures = wanted
    try:
        import mujoco
    except ImportError:
        raise PkmlabError("MuJoCo is not installed: pip install 'pkmlab[mujoco]' (or pip install mujoco)") from None
    if not isinstance(scenario, Scenario):
        raise InvalidParameterError(f"scenario must be a Scenario, got {type(scenario).__name__}")
    ts = scenario.sample_time
    if ts <= 0:
        raise InvalidParameterError("the MuJoCo plant runs sampled-data control: give the scenario a sample_time "
                                    "above 0")
    if scenario.sensors is not None and scenario.model.description.actuation_redundancy:
        raise InvalidParameterError(f"{scenario.model.name} is redundantly actuated: the MuJoCo plant gives its "
                                    "controller the pose, and sensors of its actuators are modelled on pkmlab's plant "
                                    "(pkmlab.simulate); remove the sensors")
    step = min(ts, 1e-3) if timestep is None else timestep
    if not (isinstance(step, float | int) and math.isfinite(step) and step > 0):
        raise InvalidParameterError(f"the MuJoCo time step must be a positive number of seconds, got {step!r}")
    steps = round(ts / step)
    if steps < 1 or abs(steps * step - ts) > 1e-9 * ts:
        raise InvalidParameterError(f"the MuJoCo time step {step:g} s must divide the sample time {ts:g} s")
    if integrator not in INTEGRATORS:
        raise InvalidParameterError(f"the MuJoCo integrator must be one of {', '.join(INTEGRATORS)}, got "
                                    f"{integrator!r}")
    prep = prepare_run(scenario)
    ctrl, plant = scenario.model, scenario.plant_model
    q_plant0, q_ctrl = prep.q_plant0, prep.q_ctrl0.copy()
    model = mujoco.MjModel.from_xml_string(mx.mjcf(plant, q_plant0, timestep=step, integrator=integrator,
                                                   closures=closures, drives=scenario.drives))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    n, count, d = ctrl.n_actuators, prep.t.size, prep.desired
    q = np.zeros((count, q_plant0.size))
    theta_dot, tau, violation = np.zeros((count, n)), np.zeros((count, n)), np.zeros(count)
    q_out, effort, applied, r = np.empty_like(q_ctrl), np.zeros(n), np.zeros(n), prep.realism
    readings = count if r.sensing >= 0 else 0  # rows of the controller's readings (none: it reads the state)
    theta_m, theta_dot_m = np.zeros((readings, n)), np.zeros((readings, n))
    affine = mx.affine_map(plant)  # the coordinate maps as one matrix where they are linear
    # the controller's state: the actuators', or a redundantly actuated machine's pose and its rates
    independent, desired = list(ctrl.kernels.INDEPENDENT), loop_motion(ctrl, d)
    for k in range(count):
        if affine is None:
            q[k] = mx.q_from_qpos(plant, data.qpos)
            q_dot = mx.q_dot_from_qvel(plant, q[k], data.qvel)
        else:
            q[k] = affine[0] @ data.qpos + affine[1]
            q_dot = affine[0] @ data.qvel
        theta_dot[k] = q_dot[:n]
        violation[k] = float(np.abs(data.efc_pos).max()) if data.nefc else 0.0
        status = ctrl.kernels.measured_control_effort(k, ts, np.concatenate([q[k, independent], q_dot[independent]]),
                                                      q_ctrl, prep.kind, prep.kp, prep.kv, prep.distribution,
                                                      desired[0][k], desired[1][k], desired[2][k], ctrl.P,
                                                      prep.singularity_guard, r.drive, r.ctrl_drive, r.effort_noise,
                                                      r.resolution, r.theta_noise, r.sensing, r.delay, theta_m,
                                                      theta_dot_m, q_out, effort, applied)
        if status != ctrl.kernels.OK:
            pose = pose_text(pose_of(plant, q[k]))
            raise PkmlabError(f"run stopped at t = {prep.t[k]:.4f} s: the controller's model "
                              f"{branch_failure_text(status, prep.singularity_guard)} near pose {pose}")
        q_ctrl[:] = q_out
        tau[k] = effort
        if k == count - 1:
            break
        data.ctrl[:] = applied
        for _ in range(steps):
            mujoco.mj_step(model, data)
        if not math.isfinite(float(data.qpos.sum() + data.qvel.sum())) \
                or data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0:
            raise UnstableControlError(f"MuJoCo's integration failed between t = {prep.t[k]:.4f} and "
                                       f"{prep.t[k + 1]:.4f} s (non-finite state): try a smaller --mujoco-timestep "
                                       "or another integrator")
    pose = pose_of(plant, q).copy()
    result = run_result(scenario, prep, q, theta_dot, tau, pose, run_measures(plant, q),
                        theta_m if r.sensing >= 0 else None)
    return replace(result, closure_violation=violation)
