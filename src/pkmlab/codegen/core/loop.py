"""The compiled core, the sampled-data loop: the plant's Runge-Kutta stages over each sample with the effort held, the
controller at each sample, one run or a batch over all cores.

A template, as every part of :mod:`pkmlab.codegen.core`: the text below the marker is appended to each
structure's generated module, where the names imported here for reading are that module's own."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # defined in the generated module before this text
    import math

    import numpy as np

    from pkmlab._compile_cache import NO_REFCOUNT, NO_REFCOUNT_INLINE, NO_REFCOUNT_PYTHON, njit, prange
    from pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid import (
        ANGLES,
        ELIMINATED,
        N_ACTUATORS,
        N_COORDINATES,
        N_INDEPENDENT,
    )

    from .branch_following import (
        accept_trial,
        actuated_jacobian,
        factor_passive,
        follow_branch,
        keep_base_factors,
        set_base,
    )
    from .control import computed_torque, control_effort
    from .dynamics import actuator_space_model, solve_accelerations
    from .workspace import (
        ARMATURE,
        BACKWARD_RATES,
        BASE,
        CONTROLLER,
        COULOMB,
        COULOMB_RATE,
        DIFFERENCED_RATES,
        EFFORT_LIMIT,
        IDEAL_SENSORS,
        MAX_NEWTON,
        NEWTON_STEP,
        NOT_CONVERGED,
        OK,
        REDUCED,
        REDUNDANT,
        SINGULAR,
        STICK_SLIP,
        TRIAL,
        VISCOUS,
        actuator_component,
        generalised_force,
        independent_column,
        ldlt_solve,
        make_workspaces,
        wrapped,
    )

# ==== TEMPLATE
@njit(**NO_REFCOUNT_PYTHON)
def plant_stage(ws, theta, theta_dot, tau, P, singularity_guard, slot, known, drive):
    """``θ̈`` of the actuator-space plant at ``(θ, θ̇)`` into ``ws.theta_ddot``; returns the status.

    ``slot = BASE``: ``θ`` is the base's own; otherwise the passive coordinates are first found by
    branch following from the base. ``known``: the workspace already holds the model there
    (:func:`actuator_space_model` at the base and ``θ̇``, see :func:`copy_model`). ``drive``: the drives'
    rows (:data:`ARMATURE` …), none for ideal drives (:func:`drive_accelerations`).
    """
    if slot != BASE:
        status = follow_branch(ws, theta, P, singularity_guard)
        if status != OK:
            return status
    if not known and not actuator_space_model(ws, ws.q[slot], ws.sc[slot], theta_dot, P):
        return SINGULAR
    if slot == BASE:
        keep_base_factors(ws)
    if drive.shape[0] > 0:
        return drive_accelerations(ws, theta_dot, tau, drive)
    if not solve_accelerations(ws, tau):
        return SINGULAR
    return OK


@njit(**NO_REFCOUNT_INLINE)
def drive_friction(drive, i, rate):
    """Actuator ``i``'s friction ``fv θ̇ + fc φ(θ̇)`` at the rate ``rate``: ``φ = tanh(θ̇ / v_c)``, or ``sign(θ̇)``
    when ``v_c = 0`` (the drive rows' :data:`VISCOUS`, :data:`COULOMB`, :data:`COULOMB_RATE`); for stick–slip
    friction (:data:`STICK_SLIP`) ``sign(θ̇)`` outside Karnopp's window ``|θ̇| < v_c`` and 0 inside it, where the
    friction is whatever holds the actuator (:func:`stick_slip_accelerations`)."""
    band = drive[i, COULOMB_RATE]
    if drive[i, STICK_SLIP] > 0.0:
        phi = 0.0 if abs(rate) < band else (1.0 if rate > 0.0 else -1.0)
    elif band > 0.0:
        phi = math.tanh(rate / band)
    else:
        phi = 1.0 if rate > 0.0 else (-1.0 if rate < 0.0 else 0.0)
    return drive[i, VISCOUS] * rate + drive[i, COULOMB] * phi


@njit(**NO_REFCOUNT)
def drive_accelerations(ws, theta_dot, tau, drive):
    """``θ̈`` of a plant with drives into ``ws.theta_ddot``, from the model at ``θ̇`` in the workspace:

        ``(Mθ + Ia) θ̈ = τ - fv θ̇ - fc φ(θ̇) - cθ - gθ``,   ``φ = tanh(θ̇ / v_c)`` (``sign(θ̇)`` when ``v_c = 0``)

    with each actuator's reflected armature ``Ia``, viscous ``fv`` and Coulomb ``fc`` friction (``τ`` the
    effort the drive applies). ``Mθ`` is overwritten. Returns the status. A redundantly actuated machine's drives
    act at its actuators, whose rates are ``θ̇_a = W ẋ`` and accelerations ``W ẍ + b`` (:func:`redundant_drives`)."""
    if REDUNDANT:
        return redundant_drives(ws, theta_dot, tau, drive)
    sticking = False
    for i in range(N_INDEPENDENT):
        ws.m_theta[i, i] += drive[i, ARMATURE]
        ws.theta_ddot[i] = (generalised_force(ws, tau, i) - drive_friction(drive, i, theta_dot[i]) - ws.c_theta[i]
                            - ws.g_theta[i])
        ws.stuck[i] = 1 if drive[i, STICK_SLIP] > 0.0 and abs(theta_dot[i]) < drive[i, COULOMB_RATE] else 0
        sticking = sticking or ws.stuck[i] == 1
    if sticking:
        return stick_slip_accelerations(ws, drive)
    if not ldlt_solve(ws.m_theta, ws.ldl, ws.theta_ddot):
        return SINGULAR
    return OK


@njit(**NO_REFCOUNT)
def redundant_drives(ws, pose_dot, tau, drive):
    """:func:`drive_accelerations` of a redundantly actuated machine, in its pose: each actuator's drive takes
    ``Ia θ̈_a + f(θ̇_a)`` of its effort, ``θ̇_a = W ẋ`` and ``θ̈_a = W ẍ + b`` (``b``, the actuators' accelerations
    at ``ẍ = 0``, in ``ws.bias_q``), so that

        ``(Mx + Wᵀ Ia W) ẍ = Wᵀ (τ - f(W ẋ) - Ia b) - cx - gx``.

    Friction is smooth or exact-sign (stick–slip friction, a constraint on ``ẍ`` where an actuator holds, is not
    modelled for it)."""
    n = N_INDEPENDENT
    passed = ws.internal[0]  # the effort each drive passes on: τ - f(θ̇_a) - Ia b_a
    for a in range(N_ACTUATORS):
        friction = drive_friction(drive, a, actuator_component(ws, a, pose_dot))
        passed[a] = tau[a] - friction - drive[a, ARMATURE] * ws.bias_q[a]
    for i in range(n):
        ws.theta_ddot[i] = generalised_force(ws, passed, i) - ws.c_theta[i] - ws.g_theta[i]
        for j in range(n):
            acc = 0.0
            for a in range(N_ACTUATORS):
                acc += ws.j_q_theta[a, i] * drive[a, ARMATURE] * ws.j_q_theta[a, j]
            ws.m_theta[i, j] += acc
    if not ldlt_solve(ws.m_theta, ws.ldl, ws.theta_ddot):
        return SINGULAR
    return OK


@njit(**NO_REFCOUNT)
def stick_slip_accelerations(ws, drive):
    """``θ̈`` with the actuators of ``ws.stuck`` (inside Karnopp's window) held at ``θ̈ = 0`` by their friction
    while it can hold them: ``ws.m_theta`` is ``Mθ + Ia`` and ``ws.theta_ddot`` the efforts less every other
    friction (:func:`drive_accelerations`). The held actuators' rows are solved away; the friction that holds
    each, ``F_i = rhs_i - Σ_j (Mθ + Ia)_ij θ̈_j``, is checked against ``fc_i``, and the actuator that exceeds it
    most slips, its friction ``fc_i sign(F_i)``; again until every held one holds (at most once per actuator)."""
    for i in range(N_INDEPENDENT):
        ws.free_rhs[i] = ws.theta_ddot[i]
        for j in range(N_INDEPENDENT):
            ws.m_drives[i, j] = ws.m_theta[i, j]
    for _ in range(N_INDEPENDENT + 1):
        for i in range(N_INDEPENDENT):
            for j in range(N_INDEPENDENT):
                held = ws.stuck[i] == 1 or ws.stuck[j] == 1
                ws.m_theta[i, j] = (1.0 if i == j else 0.0) if held else ws.m_drives[i, j]
            ws.theta_ddot[i] = 0.0 if ws.stuck[i] == 1 else ws.free_rhs[i]
        if not ldlt_solve(ws.m_theta, ws.ldl, ws.theta_ddot):
            return SINGULAR
        worst, excess, force = -1, 1.0, 0.0
        for i in range(N_INDEPENDENT):
            if ws.stuck[i] == 1:
                f = ws.free_rhs[i]
                for j in range(N_INDEPENDENT):
                    f -= ws.m_drives[i, j] * ws.theta_ddot[j]
                limit = drive[i, COULOMB]
                ratio = abs(f) / limit if limit > 0.0 else (math.inf if f != 0.0 else 0.0)
                if ratio > excess:
                    worst, excess, force = i, ratio, f
        if worst < 0:
            return OK
        ws.stuck[worst] = 0
        ws.free_rhs[worst] -= drive[worst, COULOMB] * (1.0 if force > 0.0 else -1.0)
    return OK


@njit(**NO_REFCOUNT)
def copy_base(source, destination):
    """The base configuration of the workspace ``source`` (configuration, trig table, ``S``) made
    ``destination``'s: for two workspaces of the same machine."""
    for i in range(N_COORDINATES):
        destination.q[BASE, i] = source.q[BASE, i]
        destination.sc[BASE, i, 0] = source.sc[BASE, i, 0]
        destination.sc[BASE, i, 1] = source.sc[BASE, i, 1]
    destination.s[BASE] = source.s[BASE]
    destination.base_factored[0] = 0


@njit(**NO_REFCOUNT)
def copy_model(source, destination):
    """The model evaluated at the base (``Mθ``, ``cθ``, ``gθ``, ``Jqθ`` and the factors of ``Jηφ``) copied from
    the workspace ``source`` to ``destination``: for two workspaces of the same machine at the same base
    configuration and rates."""
    for i in range(N_COORDINATES):
        for j in range(N_INDEPENDENT):
            destination.j_q_theta[i, j] = source.j_q_theta[i, j]
    for i in range(N_INDEPENDENT):
        destination.c_theta[i] = source.c_theta[i]
        destination.g_theta[i] = source.g_theta[i]
        for j in range(N_INDEPENDENT):
            destination.m_theta[i, j] = source.m_theta[i, j]
    for i in range(REDUCED):
        destination.piv[i] = source.piv[i]
        for d in range(ELIMINATED):
            destination.top[d, i] = source.top[d, i]
        for j in range(REDUCED):
            destination.lu[i, j] = source.lu[i, j]


@njit(**NO_REFCOUNT_PYTHON)
def rk4_sample(ws, x, tau, P, dt, n_sub, singularity_guard, work, known, drive):
    """Advance the actuator-space plant over one sample with constant ``τ``: classical RK4 in ``n_sub`` steps.

    ``x`` (2n,) = ``(θ, θ̇)`` is updated in place and the base configuration moved along; stages
    find their passive coordinates by branch following from the start of the step. ``work`` is a
    (5, 2n) scratch array. ``known``: the workspace already holds the model at the sample's start
    (its first stage). ``drive``: as for :func:`plant_stage`. Returns the status.
    """
    n = N_INDEPENDENT
    h = dt / n_sub
    k = work[:4]
    y = work[4]
    for step in range(n_sub):
        for stage in range(4):
            c = 0.0 if stage == 0 else (h if stage == 3 else 0.5 * h)
            for i in range(2 * n):
                y[i] = x[i] + c * k[stage - 1, i] if stage > 0 else x[i]
            status = plant_stage(ws, y[:n], y[n:], tau, P, singularity_guard, BASE if stage == 0 else TRIAL,
                                 known and step == 0 and stage == 0, drive)
            if status != OK:
                return status
            for i in range(n):
                k[stage, i] = y[n + i]
                k[stage, n + i] = ws.theta_ddot[i]
        for i in range(2 * n):
            x[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
        status = follow_branch(ws, x[:n], P, singularity_guard)
        if status != OK:
            return status
        accept_trial(ws)
    return OK


@njit(cache=True)
def sampled_data_loop(ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant, P_ctrl,
                      kind, kp, kv, distribution, singularity_guard, drive, ctrl_drive, effort_noise, resolution,
                      theta_noise, sensing, delay, out_q, out_theta_dot, out_tau, out_s, out_theta_m):
    """The whole sampled-data run (conventions §5: the effort computed at ``t_k`` is held until ``t_k+1``);
    returns ``(status, k)``, ``k`` the sample of a failure (else -1). A status of the controller's
    own model is offset by ``CONTROLLER``. Records the plant's configuration, rates, the commanded efforts and
    ``S``, and what the controller measured.

    The plant's drives (``drive``, rows of :data:`ARMATURE` …, none for ideal drives) saturate the held effort
    at their limit, add ``effort_noise[k]`` to it (no rows: none) and oppose friction. With ``sensing`` not
    :data:`IDEAL_SENSORS` the controller sees only measurements, recorded in ``out_theta_m``: the plant's
    ``θ`` plus ``theta_noise[k]`` (no rows: none), rounded to each actuator's ``resolution`` (0: none), taken
    ``delay`` samples earlier; its rates the plant's own (:data:`EXACT_RATES`), the measured values differenced
    (:data:`DIFFERENCED_RATES`) or their second-order backward difference (:data:`BACKWARD_RATES`).
    ``ctrl_drive`` (rows as ``drive``'s, none: no compensation) is the controller's model of the drives: computed
    torque adds ``Ia v + fv θ̇ + fc φ(θ̇)`` at the rates it uses.

    A redundantly actuated machine's run is in its controlled pose: ``θ`` (the desired motion, the recorded rates,
    the plant's state) are its independent coordinates (:data:`INDEPENDENT`), the efforts its actuators', distributed
    by :func:`distribute` with ``distribution``; its sensors read its actuators, whose readings the controller turns
    into a pose (:func:`pose_from_actuators`); its drives act at its actuators (:func:`redundant_drives`)."""
    count, n = theta_d.shape[0], N_INDEPENDENT
    theta_dot_m = np.zeros((count if sensing != IDEAL_SENSORS else 0, N_ACTUATORS))
    start = count - count  # 0, typed as sampled_data_chunk's k0 (not a literal): one compiled loop for both
    return sampled_data_chunk(make_workspaces(2), np.zeros(2 * n), theta_dot_m, start, count, ts, n_sub,
                              theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant, P_ctrl, kind, kp, kv,
                              distribution, singularity_guard, drive, ctrl_drive, effort_noise, resolution, theta_noise,
                              sensing, delay, out_q, out_theta_dot, out_tau, out_s, out_theta_m)


@njit(**NO_REFCOUNT)
def measure(x, k, ts, resolution, theta_noise, sensing, out_theta_m, theta_dot_m):
    """The controller's measurement at sample ``k`` of the plant's state ``x = (θ, θ̇)`` into
    ``out_theta_m[k]`` and ``theta_dot_m[k]`` (:func:`sampled_data_loop`)."""
    n = N_INDEPENDENT
    for i in range(n):
        read_sensor(x[i], x[n + i], k, i, ts, resolution, theta_noise, sensing, out_theta_m, theta_dot_m)


@njit(**NO_REFCOUNT_INLINE)
def read_sensor(value, rate, k, i, ts, resolution, theta_noise, sensing, out_theta_m, theta_dot_m):
    """Actuator ``i``'s reading at sample ``k`` of its ``value`` and ``rate`` into ``out_theta_m[k, i]`` and
    ``theta_dot_m[k, i]``: noise added, rounded to its resolution, the rate its own or the readings differenced
    (``rate`` is read only where :func:`exact_rate_read` says so)."""
    value = value + (theta_noise[k, i] if theta_noise.shape[0] > 0 else 0.0)
    step = resolution[i]
    out_theta_m[k, i] = step * math.floor(value / step + 0.5) if step > 0.0 else value
    if sensing == DIFFERENCED_RATES or (sensing == BACKWARD_RATES and k == 1):
        theta_dot_m[k, i] = (out_theta_m[k, i] - out_theta_m[k - 1, i]) / ts if k > 0 else rate
    elif sensing == BACKWARD_RATES:
        theta_dot_m[k, i] = ((3.0 * out_theta_m[k, i] - 4.0 * out_theta_m[k - 1, i] + out_theta_m[k - 2, i])
                             / (2.0 * ts) if k > 1 else rate)
    else:
        theta_dot_m[k, i] = rate


@njit(**NO_REFCOUNT_INLINE)
def exact_rate_read(k, sensing):
    """Whether :func:`read_sensor` reads the plant's own rate at sample ``k``: exact rates, or the first sample of
    differenced ones."""
    return k == 0 or (sensing != DIFFERENCED_RATES and sensing != BACKWARD_RATES)


@njit(**NO_REFCOUNT)
def measure_actuators(ws, x, k, ts, P, resolution, theta_noise, sensing, out_theta_m, theta_dot_m):
    """:func:`measure` of a redundantly actuated plant, whose state ``x`` is its pose and the pose's rates and
    whose workspace ``ws`` is at the sample's configuration: its actuators' readings (``q``'s first
    ``N_ACTUATORS`` coordinates), their rates ``W ẋ`` where read. Returns ok (False: ``Jηφ`` singular)."""
    n = N_INDEPENDENT
    exact = exact_rate_read(k, sensing)
    if exact:
        if not factor_passive(ws, ws.q[BASE], ws.sc[BASE], P):
            return False
        actuated_jacobian(ws, ws.j_q_theta)
    for a in range(N_ACTUATORS):
        rate = actuator_component(ws, a, x[n:]) if exact else 0.0
        read_sensor(ws.q[BASE, a], rate, k, a, ts, resolution, theta_noise, sensing, out_theta_m, theta_dot_m)
    return True


@njit(**NO_REFCOUNT)
def pose_from_actuators(ws, theta_m, theta_dot_m, P, singularity_guard, pose, pose_dot):
    """Forward kinematics of a redundantly actuated machine from its actuators' readings ``theta_m`` (more than
    its degrees of freedom, and inconsistent once rounded or noisy): the pose of least squared actuator residual
    into ``pose``, by Gauss–Newton from the pose of the workspace's base (the last one accepted), each iterate's
    configuration by branch following; the pose's rates of least squared residual to ``theta_dot_m``,
    ``ẋ = (WᵀW)⁻¹ Wᵀ θ̇_m``, into ``pose_dot``. Returns the status (the base is kept)."""
    n = N_INDEPENDENT
    for j in range(n):
        pose[j] = ws.q[BASE, independent_column(j)]
    status = NOT_CONVERGED
    for _ in range(MAX_NEWTON):
        status = follow_branch(ws, pose, P, singularity_guard)
        if status != OK:
            return status
        if not factor_passive(ws, ws.q[TRIAL], ws.sc[TRIAL], P):
            return SINGULAR
        actuated_jacobian(ws, ws.j_q_theta)
        for a in range(N_ACTUATORS):  # the residual θ_m - θ(x), an angle's the shorter way round
            ws.internal[0, a] = wrapped(theta_m[a] - ws.q[TRIAL, a], ANGLES[a])
        if not least_squares_step(ws, ws.internal[0]):
            return SINGULAR
        step = 0.0
        for j in range(n):
            pose[j] += ws.force[j]
            step = max(step, abs(ws.force[j]))
        if step < NEWTON_STEP:
            status = OK
            break
        status = NOT_CONVERGED
    if status != OK:
        return status
    least_squares_step(ws, theta_dot_m)
    for j in range(n):
        pose_dot[j] = ws.force[j]
    return OK


@njit(**NO_REFCOUNT)
def least_squares_step(ws, values):
    """``(WᵀW)⁻¹ Wᵀ values`` into ``ws.force``, ``W`` the actuators' rows of ``ws.j_q_theta``; returns ok."""
    n = N_INDEPENDENT
    for i in range(n):
        acc = 0.0
        for a in range(N_ACTUATORS):
            acc += ws.j_q_theta[a, i] * values[a]
        ws.force[i] = acc
        for j in range(i, n):
            acc = 0.0
            for a in range(N_ACTUATORS):
                acc += ws.j_q_theta[a, i] * ws.j_q_theta[a, j]
            ws.normal[i, j] = acc
            ws.normal[j, i] = acc
    return ldlt_solve(ws.normal, ws.normal_ldl, ws.force)


@njit(cache=True)
def sampled_data_chunk(workspaces, x, theta_dot_m, k0, count, ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0,
                       q_ctrl0, P_plant, P_ctrl, kind, kp, kv, distribution, singularity_guard, drive, ctrl_drive,
                       effort_noise, resolution, theta_noise, sensing, delay, out_q, out_theta_dot, out_tau, out_s,
                       out_theta_m):
    """Samples ``k0 … k0 + len(theta_d) - 1`` of a sampled-data run of ``count`` samples: :func:`sampled_data_loop`
    in pieces, so that a long run needs its desired motion one piece at a time. The piece's desired motion
    (``theta_d`` …) has a row per sample of the piece; the recorded series (``out_q`` …, ``effort_noise``,
    ``theta_noise``) a row per sample of the run. ``workspaces`` (:func:`make_workspaces` of 2), ``x`` (2n,
    zeros) and ``theta_dot_m`` (the controller's measured rates, which its delayed and differenced measurements
    read back: shaped as ``out_theta_m``, zeros) are the run's state, made once by the caller and handed
    from one piece to the next: the pieces compute exactly what the whole run computes. Returns ``(status, k)``
    as :func:`sampled_data_loop`, ``k`` the run's sample."""
    n = N_INDEPENDENT
    plant, ctrl = workspaces[0], workspaces[1]
    if k0 == 0:  # the run starts: the plant at rest at q_plant0, the controller's model at q_ctrl0
        set_base(plant, q_plant0, P_plant)
        set_base(ctrl, q_ctrl0, P_ctrl)
        for i in range(n):
            x[i] = q_plant0[independent_column(i)]
            x[n + i] = 0.0
    work = np.empty((5, 2 * n))
    estimate = np.empty(2 * n)  # a redundantly actuated machine's pose and rates from its actuators' readings
    tau = np.zeros(N_ACTUATORS)
    applied = np.zeros(N_ACTUATORS)
    ideal = sensing == IDEAL_SENSORS
    # a computed-torque controller whose model is the plant (the nominal cases), which measures the plant's own
    # state: from the second sample on, its model's configuration at the measured θ is the plant's own (same
    # machine, same branch: the plant's branch following has just reached it and checked its S), and the model
    # it evaluates there is the plant's at the sample's start, the RK4 step's first stage: both taken over
    # instead of computed twice
    same = kind == 0 and ideal and drive.shape[0] == 0
    for i in range(P_plant.size):
        same = same and P_plant[i] == P_ctrl[i]
    for c in range(theta_d.shape[0]):
        k = k0 + c  # the run's sample; c, the piece's
        # element by element: an array assigned to a slice compiles its error message (seconds, in every process)
        for i in range(N_COORDINATES):
            out_q[k, i] = plant.q[BASE, i]
        out_s[k] = plant.s[BASE]
        for i in range(n):
            out_theta_dot[k, i] = x[n + i]
        shared = same and k > 0
        j = max(k - delay, 0)
        if shared:
            copy_base(plant, ctrl)
            status = computed_torque(kp, kv, distribution, x[:n], x[n:], theta_d[c], theta_dot_d[c], theta_ddot_d[c],
                                     P_ctrl, ctrl, tau)
        elif ideal:
            status = control_effort(kind, kp, kv, distribution, x[:n], x[n:], theta_d[c], theta_dot_d[c],
                                    theta_ddot_d[c], P_ctrl, singularity_guard, ctrl, tau)
        elif REDUNDANT:  # the actuators' readings over-determine the pose: the controller's least-squares estimate
            if not measure_actuators(plant, x, k, ts, P_plant, resolution, theta_noise, sensing, out_theta_m,
                                     theta_dot_m):
                return SINGULAR, k
            status = pose_from_actuators(ctrl, out_theta_m[j], theta_dot_m[j], P_ctrl, singularity_guard,
                                         estimate[:n], estimate[n:])
            if status == OK:
                status = control_effort(kind, kp, kv, distribution, estimate[:n], estimate[n:], theta_d[c],
                                        theta_dot_d[c], theta_ddot_d[c], P_ctrl, singularity_guard, ctrl, tau)
        else:
            measure(x, k, ts, resolution, theta_noise, sensing, out_theta_m, theta_dot_m)
            status = control_effort(kind, kp, kv, distribution, out_theta_m[j], theta_dot_m[j], theta_d[c],
                                    theta_dot_d[c], theta_ddot_d[c], P_ctrl, singularity_guard, ctrl, tau)
        if status != OK:
            return CONTROLLER + status, k
        if kind == 0 and ctrl_drive.shape[0] > 0:  # at the rates the controller used
            compensate_drives(ctrl, tau, x[n:] if ideal else (estimate[n:] if REDUNDANT else theta_dot_m[j]),
                              ctrl_drive)
        for i in range(N_ACTUATORS):
            out_tau[k, i] = tau[i]
        if k == count - 1:
            break
        if shared:
            copy_model(ctrl, plant)
        held = tau
        if drive.shape[0] > 0:
            drive_effort(drive, tau, effort_noise, k, applied)
            held = applied
        status = rk4_sample(plant, x, held, P_plant, ts, n_sub, singularity_guard, work, shared, drive)
        if status != OK:
            return status, k
    return OK, -1


@njit(**NO_REFCOUNT)
def drive_effort(drive, tau, effort_noise, k, applied):
    """The effort the plant's drives apply at sample ``k`` for the command ``tau``, into ``applied``: the command
    within each drive's :data:`EFFORT_LIMIT`, plus ``effort_noise[k]`` (no rows: none)."""
    for i in range(N_ACTUATORS):
        limit = drive[i, EFFORT_LIMIT]
        applied[i] = min(max(tau[i], -limit), limit) + (effort_noise[k, i] if effort_noise.shape[0] > 0 else 0.0)


@njit(**NO_REFCOUNT)
def compensate_drives(ws, tau, theta_dot, drive):
    """Add the controller's model of the drives to computed torque's efforts ``tau``: ``Ia v + fv θ̇ + fc φ(θ̇)``,
    ``v`` the commanded acceleration (kept in ``ws.theta_ddot``), the friction as the plant's
    (:func:`drive_friction`). A redundantly actuated machine's at its actuators: ``θ̇`` its pose's rates, the
    actuators' ``W θ̇``, their commanded accelerations ``W v + b`` (:func:`redundant_drives`). Added after the
    distribution: the efforts then exceed its least peak or its limits by what the drives take (the drives
    saturate at their limits)."""
    if REDUNDANT:
        for a in range(N_ACTUATORS):
            acceleration = ws.bias_q[a] + actuator_component(ws, a, ws.theta_ddot)
            tau[a] += drive[a, ARMATURE] * acceleration + drive_friction(drive, a, actuator_component(ws, a, theta_dot))
        return
    for i in range(N_INDEPENDENT):
        tau[i] += drive[i, ARMATURE] * ws.theta_ddot[i] + drive_friction(drive, i, theta_dot[i])


@njit(cache=True, parallel=True)
def sampled_data_batch(ts, n_sub, theta_d, theta_dot_d, theta_ddot_d, q_plant0, q_ctrl0, P_plant, P_ctrl, kind,
                       kp, kv, distribution, singularity_guard, drive, ctrl_drive, effort_noise, resolution,
                       theta_noise, sensing, delay, out_q, out_theta_dot, out_tau, out_s, out_theta_m, out_status,
                       out_k):
    """:func:`sampled_data_loop` for a batch of runs (leading axis) over the CPU cores; each run executes
    exactly the code of a single run."""
    for r in prange(theta_d.shape[0]):
        status, k = sampled_data_loop(ts[r], n_sub[r], theta_d[r], theta_dot_d[r], theta_ddot_d[r], q_plant0[r],
                                      q_ctrl0[r], P_plant[r], P_ctrl[r], kind[r], kp[r], kv[r], distribution[r],
                                      singularity_guard[r],
                                      drive[r], ctrl_drive[r], effort_noise[r], resolution[r], theta_noise[r],
                                      sensing[r], delay[r],
                                      out_q[r], out_theta_dot[r], out_tau[r], out_s[r], out_theta_m[r])
        out_status[r] = status
        out_k[r] = k
