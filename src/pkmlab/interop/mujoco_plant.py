"""MuJoCo as the plant: pkmlab's sampled-data controller against MuJoCo's integration of the exported machine.

The controller is the one of :func:`pkmlab.simulation.run.simulate` — computed torque (or PD) on the
controller's own model, its passive coordinates followed by branch following from the measured actuators,
the effort held over each sample. The whole run is one compiled loop
(:func:`pkmlab.codegen.core.entry_points.native_plant_samples`): it calls MuJoCo's ``mj_step`` itself (in the
library MuJoCo's Python bindings load) on the model and data the bindings made, reading and writing their state
in place, so that a sample costs MuJoCo's steps and the controller's arithmetic, not Python's. (Called at its
address, MuJoCo reports an error of its own — out of memory — by ending the process, not by an exception: the
exported models, without contacts, have a fixed number of constraints.)
The plant is MuJoCo stepping :func:`pkmlab.interop.mujoco_export.mjcf` of the scenario's plant model (its time step
``timestep``, which must divide the sample time, and its integrator), started at rest at the plant's
configuration of :func:`~pkmlab.simulation.run.simulate`. Each sample measures MuJoCo's actuated joints
(pkmlab's actuator values, :func:`~pkmlab.interop.mujoco_export.independent_map`; a redundantly actuated six-DOF
platform's pose is read from MuJoCo's quaternion in Python at each sample), and records, besides what every run
records, MuJoCo's loop-closure violation as its equality constraints measure it (``efc_pos``, of the last state
MuJoCo evaluated in the step before the sample: an RK4 step's last stage): the largest coordinate, in absolute
value, of a leg end's offset from its platform attachment point, or of a held joint's tendon from its length (m) —
zero for pkmlab's own plant, whose loops are closed to round-off.

A scenario's drives and sensors apply as on pkmlab's plant: the controller sees the sensors' readings, the
command is saturated and its noise added by the same compiled code; the drives' armature, viscous and Coulomb
friction are MuJoCo's joint ``armature``, ``damping`` and ``frictionloss``
(:func:`pkmlab.interop.mujoco_export.drive_attributes`) — MuJoCo's dry friction is stick–slip, so Coulomb friction
is taken only as stick–slip friction (``stick_slip = true``).

Needs ``mujoco`` (``pip install pkmlab[mujoco]``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InvalidParameterError, PkmlabError, UnstableControlError
from ..model.mechanism_model import pose_of
from ..simulation.result import SimulationResult
from ..simulation.run import branch_failure_text, loop_motion, prepare_run, run_measures, run_result
from ..simulation.scenario import Scenario, pose_text
from . import mujoco_export as mx

INTEGRATORS = ("RK4", "implicitfast", "implicit", "Euler")
#: Samples of one call of the compiled loop (which holds the process until it returns).
SAMPLES_PER_CALL = 1000


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
    q_ctrl = prep.q_ctrl0.copy()
    # (the model and data of the last run of this machine from this start, reset, where there is one)
    with mx.mujoco_log_held(mujoco), mx.pooled_mujoco(plant, prep.q_plant0, timestep=step, integrator=integrator,
                                                      closures=closures, drives=scenario.drives) as (model, data):
        n, count, r = ctrl.n_actuators, prep.t.size, prep.realism
        qpos, qvel = np.zeros((count, model.nq)), np.zeros((count, model.nv))
        tau, violation = np.zeros((count, n)), np.zeros(count)
        readings = count if r.sensing >= 0 else 0  # rows of the controller's readings (none: it reads the state)
        theta_m, theta_dot_m = np.zeros((readings, n)), np.zeros((readings, n))
        native = (_step_address(mujoco), model._address, data._address, steps)
        # the warnings of a state MuJoCo found bad and reset
        bad = np.array([int(getattr(mujoco.mjtWarning, f"mjWARN_BAD{what}")) for what in ("QPOS", "QVEL", "QACC")])
        desired = tuple(np.ascontiguousarray(a) for a in loop_motion(ctrl, prep.desired))
        closures_measured = _closure_rows(mujoco, model)

        def samples(k0, k1, x, state_map):  # the compiled loop over samples k0 to k1 - 1 (its docstring)
            return ctrl.kernels.native_plant_samples(
                k0, k1, ts, x, native, data.qpos, data.qvel, data.ctrl, data.warning.number, bad, data.site_xpos,
                data.ten_length, state_map, *closures_measured, q_ctrl, prep.kind, prep.kp, prep.kv,
                prep.distribution, *desired, ctrl.P, prep.singularity_guard, r.drive, r.ctrl_drive, r.effort_noise,
                r.resolution, r.theta_noise, r.sensing, r.delay, theta_m, theta_dot_m, qpos, qvel, tau, violation)

        state_map = mx.independent_map(plant, model.nq, model.nv)
        # the compiled loop reads and writes MuJoCo's arrays by these sizes
        if (data.ctrl.size, data.qpos.size, data.qvel.size) != (n, model.nq, model.nv) or (
                state_map is not None and (state_map[0].shape[1], state_map[2].shape[1]) != (model.nq, model.nv)):
            raise PkmlabError(f"the exported MuJoCo model of {plant.name} does not have the sizes of pkmlab's map of "
                              "its coordinates: please report this")
        if state_map is not None:
            for k0 in range(0, count, SAMPLES_PER_CALL):  # (Ctrl-C is seen between calls)
                status, k = samples(k0, min(count, k0 + SAMPLES_PER_CALL), np.zeros(0), state_map)
                if status != ctrl.kernels.OK:
                    break
        else:  # a redundantly actuated six-DOF platform's pose, from its quaternion here at each sample
            independent, read = list(ctrl.kernels.INDEPENDENT), (np.zeros((0, model.nq)), np.zeros(0),
                                                                  np.zeros((0, model.nv)))
            for k in range(count):
                q_k = mx.q_from_qpos(plant, data.qpos)
                x = np.concatenate([q_k[independent], mx.q_dot_from_qvel(plant, q_k, data.qvel)[independent]])
                status, _ = samples(k, k + 1, x, read)
                if status != ctrl.kernels.OK:
                    break
        if status != ctrl.kernels.PLANT_FAILED:  # (a state found bad is the run's error below)
            mx.say_mujoco_warnings(mujoco, data, said_otherwise=bad)
    if status == ctrl.kernels.PLANT_FAILED:
        raise UnstableControlError(f"MuJoCo's integration failed between t = {prep.t[k]:.4f} and "
                                   f"{prep.t[k + 1]:.4f} s (a state not finite, or one MuJoCo found bad and reset): "
                                   "try a smaller --mujoco-timestep or another integrator")
    if status != ctrl.kernels.OK:
        raise PkmlabError(f"run stopped at t = {prep.t[k]:.4f} s: the controller's model "
                          f"{branch_failure_text(status, prep.singularity_guard)} near pose "
                          f"{pose_text(pose_of(plant, mx.q_from_qpos(plant, qpos[k])))}")
    q = mx.q_from_qpos(plant, qpos)
    pose = pose_of(plant, q).copy()
    result = run_result(scenario, prep, q, mx.actuator_rates(plant, qvel), tau, pose, run_measures(plant, q),
                        theta_m if r.sensing >= 0 else None)
    return replace(result, closure_violation=violation)


@functools.cache
def _step_address(mujoco) -> int:
    """The address of MuJoCo's ``mj_step`` in the library its Python bindings load (beside them), for the compiled
    loop to step the plant without returning to Python."""
    import ctypes
    import os

    folder = Path(mujoco.__file__).parent
    for pattern in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll"):
        for path in sorted(folder.glob(pattern)):
            try:  # only the copy the bindings have loaded (POSIX: RTLD_NOLOAD opens nothing new)
                library = ctypes.CDLL(str(path), mode=getattr(os, "RTLD_NOLOAD", 0) | ctypes.RTLD_LOCAL)
            except OSError:
                continue
            library.mj_versionString.restype = ctypes.c_char_p
            if library.mj_versionString().decode() == mujoco.mj_versionString():
                return ctypes.cast(library.mj_step, ctypes.c_void_p).value
    raise PkmlabError(f"the MuJoCo plant steps MuJoCo's library from compiled code, and the one MuJoCo's Python "
                      f"bindings loaded is not beside them in {folder} (a MuJoCo built another way): install MuJoCo "
                      "from its wheel (pip install mujoco)")


def _closure_rows(mujoco, model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The loop closures of an exported model as the compiled loop measures them — MuJoCo's constraint violations
    ``efc_pos`` of its equalities: each ``connect``'s two sites (pairs of site indices, (n, 2)), each
    ``tendon`` equality's tendon and the length it holds it at (its length at ``qpos0`` plus ``polycoef[0]``)."""
    connects, tendons, targets = [], [], []
    for e in range(model.neq):
        if model.eq_type[e] == mujoco.mjtEq.mjEQ_CONNECT and model.eq_objtype[e] == mujoco.mjtObj.mjOBJ_SITE:
            connects.append((model.eq_obj1id[e], model.eq_obj2id[e]))
        elif model.eq_type[e] == mujoco.mjtEq.mjEQ_TENDON and model.eq_obj2id[e] < 0:
            tendons.append(model.eq_obj1id[e])
            targets.append(model.tendon_length0[model.eq_obj1id[e]] + model.eq_data[e, 0])
        else:
            raise PkmlabError(f"the exported model's equality {e} is neither a connect between two sites nor a "
                              "tendon held at a length: pkmlab's MuJoCo plant does not measure it")
    return (np.array(connects, dtype=np.int64).reshape(-1, 2), np.array(tendons, dtype=np.int64),
            np.array(targets, dtype=float))
