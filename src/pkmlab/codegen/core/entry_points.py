"""The compiled core, entry points for callers outside compiled code (an adaptive integrator, a path's kinematics,
branch following of a batch): plain arrays in and out.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    import numpy as np

    from pkmlab._compile_cache import NO_REFCOUNT_INLINE, NO_WRAPPERS, call_native, njit
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import (
        LINE_WIDTH,
        N_ACTUATORS,
        N_COORDINATES,
        N_INDEPENDENT,
        constraint_bias,
        constraint_jacobian,
        constraints,
        trig,
    )

    from .branch_following import accept_trial, follow_branch, follow_branch_in_steps, is_base, singularity_measure
    from .control import computed_torque, control_effort, distributed_pd
    from .loop import compensate_drives, drive_effort, measure, plant_stage
    from .workspace import BASE, IDEAL_SENSORS, NOT_CONVERGED, OK, PLANT_FAILED, REDUNDANT, make_workspaces

# ==== TEMPLATE
@njit(cache=True)
def singularity_measures(qs, P, out):
    """:func:`singularity_measure` of every configuration ``qs`` (K, N) into ``out`` (K,); NaN rows give NaN."""
    lines, sc = np.empty((N_ACTUATORS, LINE_WIDTH)), np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        out[k] = singularity_measure(qs[k], sc, P, lines)


@njit(cache=True)
def constraint_residuals(qs, P, out):
    """``η`` of every configuration ``qs`` (K, N) into ``out`` (K, m): a multistart's many starts at once."""
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        constraints(qs[k], sc, P, out[k])


@njit(cache=True)
def constraint_jacobians(qs, P, out):
    """``Jηq`` of every configuration ``qs`` (K, N) into ``out`` (K, m, N)."""
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        constraint_jacobian(qs[k], sc, P, out[k])


@njit(cache=True)
def constraint_biases(qs, q_dots, P, out):
    """``J̇ηq q̇`` of every configuration and rate (K, N) into ``out`` (K, m)."""
    sc = np.zeros((N_COORDINATES, 2))
    for k in range(qs.shape[0]):
        trig(qs[k], sc)
        constraint_bias(qs[k], sc, q_dots[k], P, out[k])


# ---- entry points for callers outside compiled code (an adaptive integrator, a path's kinematics): plain
# arrays in and out, the workspace made inside (making one costs well under a microsecond), then passed
# with the array that holds it to the function that does the work
@njit(cache=True)
def actuator_space_rhs(q_base, y, tau, P, singularity_guard, drive, q_out):
    """``(θ̇, θ̈)`` of the actuator-space plant at ``y = (θ, θ̇)`` under efforts ``tau``, for an adaptive integrator;
    the passive coordinates by branch following from ``q_base`` (a configuration on the manifold), the
    configuration reached into ``q_out``; ``drive`` the plant's drives (:func:`plant_stage`, no rows: ideal).
    Returns ``(ẏ, status)``."""
    return _actuator_space_rhs(make_workspaces(1), q_base, y, tau, P, singularity_guard, drive, q_out)


@njit(**NO_WRAPPERS)
def _actuator_space_rhs(workspaces, q_base, y, tau, P, singularity_guard, drive, q_out):
    n = N_INDEPENDENT
    ws = workspaces[0]
    out = np.zeros(2 * n)
    # an adaptive integrator's trial steps may be long: branch following in sub-steps where needed
    status = follow_branch_in_steps(ws, q_base, y[:n], P, singularity_guard, np.inf)
    if status == OK:
        # the base stage and no known passive motion, typed as the loop passes them (not literals): one compiled
        # plant_stage for both
        status = plant_stage(ws, y[:n], y[n:], tau, P, singularity_guard, n - n + BASE, n < 0, drive)
    for i in range(N_COORDINATES):
        q_out[i] = ws.q[BASE, i]
    if status == OK:
        for i in range(n):
            out[i] = y[n + i]
            out[n + i] = ws.theta_ddot[i]
    return out, status


@njit(**NO_WRAPPERS)
def _control_effort_from(workspaces, q_base, kind, kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d,
                         theta_ddot_d, P, singularity_guard, q_out, tau):
    """:func:`control_effort` with the controller's model at ``q_base`` before the measurement; its configuration
    at the measured ``theta`` into ``q_out``. Returns the status.

    A workspace whose base is ``q_base`` and factored (the last call's, handed on by a caller that keeps it) is
    followed from as :func:`control_effort` follows it — the base's factors, ``S`` and trigonometry reused — and in
    sub-steps only where that one step fails."""
    ws = workspaces[0]
    if kind == 1 and not REDUNDANT:  # PD: no model to move
        for i in range(N_COORDINATES):
            q_out[i] = q_base[i]
        return control_effort(kind, kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P,
                              singularity_guard, ws, tau)
    # computed torque: the model follows the measurement, in one step from a kept base, else in sub-steps
    status = NOT_CONVERGED
    if is_base(ws, q_base):
        status = follow_branch(ws, theta, P, singularity_guard)
        if status == OK:
            accept_trial(ws)
    if status != OK:
        status = follow_branch_in_steps(ws, q_base, theta, P, singularity_guard, np.inf)
    if status == OK and kind == 0:
        status = computed_torque(kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, theta_ddot_d, P, ws,
                                 tau)
    elif status == OK:
        status = distributed_pd(kp, kv, distribution, theta, theta_dot, theta_d, theta_dot_d, P, ws, tau)
    for i in range(N_COORDINATES):
        q_out[i] = ws.q[BASE, i]
    return status


@njit(cache=True)
def measured_control_effort(k, ts, x, q_base, kind, kp, kv, distribution, theta_d, theta_dot_d, theta_ddot_d, P,
                            singularity_guard, drive, ctrl_drive, effort_noise, resolution, theta_noise, sensing, delay,
                            out_theta_m, theta_dot_m, q_out, tau, applied):
    """Sample ``k`` of :func:`sampled_data_loop`'s controller for a plant integrated elsewhere (MuJoCo, an adaptive
    integrator), at the plant's state ``x = (θ, θ̇)``: the measurement (``sensing`` not :data:`IDEAL_SENSORS`:
    into ``out_theta_m[k]`` and ``theta_dot_m[k]``, the controller using sample ``k - delay``'s), the effort of
    :func:`_control_effort_from` into ``tau`` with the controller's model of the drives ``ctrl_drive``, and the
    effort the plant's drives ``drive`` apply (:func:`drive_effort`; no rows: the command) into ``applied``; the
    arguments as :func:`sampled_data_loop`'s. Returns the status. A redundantly actuated machine's ``x`` is its pose
    and the pose's rates, read as they are: its sensors (of its actuators) are modelled in the loop only, and
    refused where this is called (the MuJoCo plant; continuous time has no sensors)."""
    return _measured_control_effort(make_workspaces(1), k, ts, x, q_base, kind, kp, kv, distribution, theta_d,
                                    theta_dot_d, theta_ddot_d, P, singularity_guard, drive, ctrl_drive, effort_noise,
                                    resolution, theta_noise, sensing, delay, out_theta_m, theta_dot_m, q_out, tau,
                                    applied)


@njit(**NO_WRAPPERS)
def _measured_control_effort(workspaces, k, ts, x, q_base, kind, kp, kv, distribution, theta_d, theta_dot_d,
                             theta_ddot_d, P, singularity_guard, drive, ctrl_drive, effort_noise, resolution,
                             theta_noise, sensing, delay, out_theta_m, theta_dot_m, q_out, tau, applied):
    n = N_INDEPENDENT
    if sensing == IDEAL_SENSORS:
        theta, theta_dot = x[:n], x[n:]
    else:
        measure(x, k, ts, resolution, theta_noise, sensing, out_theta_m, theta_dot_m)
        j = max(k - delay, 0)
        theta, theta_dot = out_theta_m[j], theta_dot_m[j]
    status = _control_effort_from(workspaces, q_base, kind, kp, kv, distribution, theta, theta_dot, theta_d,
                                  theta_dot_d, theta_ddot_d, P, singularity_guard, q_out, tau)
    if status != OK:
        return status
    if kind == 0 and ctrl_drive.shape[0] > 0:
        compensate_drives(workspaces[0], tau, theta_dot, ctrl_drive)
    if drive.shape[0] > 0:
        drive_effort(drive, tau, effort_noise, k, applied)
    else:
        for i in range(N_ACTUATORS):
            applied[i] = tau[i]
    return OK


@njit(**NO_REFCOUNT_INLINE)
def warning_count(warnings, bad):
    """How many times MuJoCo has warned of the kinds ``bad`` (indices into its counters ``warnings``)."""
    count = 0
    for i in range(bad.shape[0]):
        count += warnings[bad[i]]
    return count


@njit(cache=True, nogil=True)
def native_plant_samples(k0, k1, ts, x_given, native, qpos, qvel, ctrl, warnings, bad, site_xpos, ten_length, state_map,
                         connects, tendons, tendon_targets, q_base, kind, kp, kv, distribution, theta_d, theta_dot_d,
                         theta_ddot_d, P, singularity_guard, drive, ctrl_drive, effort_noise, resolution, theta_noise,
                         sensing, delay, out_theta_m, theta_dot_m, qpos_out, qvel_out, tau_out, violation_out):
    """Samples ``k0`` to ``k1 - 1`` of the sampled-data controller against a plant stepped by native code (MuJoCo)
    that keeps its state in arrays shared with the caller: at each sample, the plant's state ``qpos``, ``qvel`` is
    recorded (into ``qpos_out[k]``, ``qvel_out[k]``) with its loop closures' violation (``violation_out[k]``: the
    largest component of ``site_xpos[a] - site_xpos[b]`` over the pairs ``connects``, and of
    ``ten_length[t] - target`` over ``tendons`` and ``tendon_targets``, in absolute value: MuJoCo's ``efc_pos`` of
    its equality constraints, of the last state it evaluated — an RK4 step's last stage); the controller of
    :func:`measured_control_effort` runs on ``x = (A qpos + b, V qvel)`` (``state_map = (A, b, V)``: the
    independent coordinates and their rates; ``x_given`` where ``A`` has no rows), its effort into ``tau_out[k]``
    and the drives' into ``ctrl``; then, but after the last sample, the plant steps ``native = (step, model,
    data, steps)`` — ``steps`` calls of the C function ``step(model, data)`` at the address ``step``
    (:func:`pkmlab._compile_cache.call_native`) — and fails if its state is not finite or any of the counts
    ``warnings[bad]`` has grown (MuJoCo resets a bad state and warns). The GIL is released throughout. Returns
    ``(status, k)``: :data:`OK` and ``k1``, the controller's status and its sample, or :data:`PLANT_FAILED` and
    the sample the plant stepped from."""
    n = N_INDEPENDENT
    workspaces = make_workspaces(1)
    x = np.empty(2 * n)
    q_out, tau, applied = np.empty(N_COORDINATES), np.empty(N_ACTUATORS), np.empty(N_ACTUATORS)
    a, b, v = state_map
    step, model, data, steps = native
    warned = warning_count(warnings, bad)
    last = qpos_out.shape[0] - 1
    for k in range(k0, k1):
        for j in range(qpos.shape[0]):
            qpos_out[k, j] = qpos[j]
        for j in range(qvel.shape[0]):
            qvel_out[k, j] = qvel[j]
        gap = 0.0
        for c in range(connects.shape[0]):
            for r in range(3):
                gap = max(gap, abs(site_xpos[connects[c, 0], r] - site_xpos[connects[c, 1], r]))
        for c in range(tendons.shape[0]):
            gap = max(gap, abs(ten_length[tendons[c]] - tendon_targets[c]))
        violation_out[k] = gap
        if a.shape[0] == 0:
            for i in range(2 * n):
                x[i] = x_given[i]
        else:
            for i in range(n):
                position, rate = b[i], 0.0
                for j in range(qpos.shape[0]):
                    position += a[i, j] * qpos[j]
                for j in range(qvel.shape[0]):
                    rate += v[i, j] * qvel[j]
                x[i], x[n + i] = position, rate
        status = _measured_control_effort(workspaces, k, ts, x, q_base, kind, kp, kv, distribution, theta_d[k],
                                          theta_dot_d[k], theta_ddot_d[k], P, singularity_guard, drive, ctrl_drive,
                                          effort_noise, resolution, theta_noise, sensing, delay, out_theta_m,
                                          theta_dot_m, q_out, tau, applied)
        if status != OK:
            return status, k
        for i in range(N_COORDINATES):
            q_base[i] = q_out[i]
        for i in range(N_ACTUATORS):
            tau_out[k, i] = tau[i]
        if k == last:
            break
        for i in range(N_ACTUATORS):
            ctrl[i] = applied[i]
        for _ in range(steps):
            call_native(step, model, data)
        finite = warning_count(warnings, bad) == warned
        for j in range(qpos.shape[0]):
            finite = finite and np.isfinite(qpos[j])
        for j in range(qvel.shape[0]):
            finite = finite and np.isfinite(qvel[j])
        if not finite:
            return PLANT_FAILED, k
    return OK, k1


@njit(cache=True)
def branch_following_batch(q_previous, thetas, P, singularity_guard, max_step, q_out, status):
    """:func:`follow_branch_in_steps` from each ``q_previous[k]`` (K, N) to ``thetas[k]`` (K, n), into ``q_out``
    (K, N) and ``status`` (K,)."""
    _branch_following_batch(make_workspaces(1), q_previous, thetas, P, singularity_guard, max_step, q_out, status)


@njit(**NO_WRAPPERS)
def _branch_following_batch(workspaces, q_previous, thetas, P, singularity_guard, max_step, q_out, status):
    ws = workspaces[0]
    for k in range(thetas.shape[0]):
        status[k] = follow_branch_in_steps(ws, q_previous[k], thetas[k], P, singularity_guard, max_step)
        for i in range(N_COORDINATES):
            q_out[k, i] = ws.q[BASE, i]


@njit(cache=True)
def follow_path(q_start, thetas, P, singularity_guard, q_out):
    """Branch following from ``q_start`` through the actuator values ``thetas`` (K, n) in turn
    (:func:`follow_branch_in_steps`), into ``q_out`` (K, N); returns ``(status, k)``, ``k`` the first point
    not reached (else -1)."""
    return _follow_path(make_workspaces(1), q_start, thetas, P, singularity_guard, q_out)


@njit(**NO_WRAPPERS)
def _follow_path(workspaces, q_start, thetas, P, singularity_guard, q_out):
    ws = workspaces[0]
    previous = q_start.copy()
    for k in range(thetas.shape[0]):
        status = follow_branch_in_steps(ws, previous, thetas[k], P, singularity_guard, np.inf)
        if status != OK:
            return status, k
        for i in range(N_COORDINATES):
            q_out[k, i] = previous[i] = ws.q[BASE, i]
    return OK, -1
