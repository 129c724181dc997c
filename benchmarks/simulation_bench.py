"""Closed-loop simulation benchmarks (``make bench`` runs them after the kernel rows of ``run.py``).

Rows
----
* the simulation loop's kernels along the paper's circle: branch following, and branch
  following + forward dynamics (one right-hand side of the plant), from a workspace;
* the paper's nominal case in-process, ``pkmlab.simulate(paper_scenario("nominal"))`` after
  warm-up, and its compiled sampled-data loop alone;
* the same case through a pure NumPy/SciPy path: the computed-torque controller and the plant
  written in NumPy (``run.NumpyActuatorSpaceModel``; passive variables by ``fsolve`` from the
  previous sample, ``run.NumpyLoopClosure``), the plant integrated over each 1 ms sample by
  ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) with the torque held;
* MuJoCo stepping the same mechanism (MJCF of ``mujoco_model.py``: 7 hinges, two ``connect``
  loops, RK4 at 1 ms) for the same 1,571 steps with pkmlab's torques replayed, in the same run;
* a batch of 1,000 disturbed runs with plant parameters drawn within ±15 %
  (:func:`pkmlab.simulate_batch`), on all cores and on one, and the largest difference between
  batch runs and the same runs done alone;
* the plant integrator: error of RK4 with 1, 2, 4 steps per sample against DOP853 at rtol
  1e-13 and its observed order;
* the arithmetic limit: the operations of one sample counted from the code that runs
  (:mod:`operation_count`) priced at this machine's measured scalar throughput;
* how the cost grows with the simulated duration, the batch size and the sample time.
"""

from __future__ import annotations

import math
import os
import statistics
import time

import numba
import numpy as np
import operation_count
from scipy.integrate import solve_ivp

import pkmlab
from pkmlab.control.trajectory import paper_trajectory
from pkmlab.model.mechanism_model import MechanismModel
from pkmlab.paper import dynamics as paper_dynamics
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.paper.kinematics import coordinates_from_3rrr, coordinates_to_3rrr
from pkmlab.paper.plant import ReducedPlant
from pkmlab.simulation.run import prepare_run

BATCH_SPREAD = 0.15
BATCH_SEED = 7

@numba.njit(cache=False)
def _independent_multiply_adds(n, x):
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = x
    for _ in range(n):
        s0 = s0 * 0.999999 + 1e-9
        s1 = s1 * 0.999998 + 1e-9
        s2 = s2 * 0.999997 + 1e-9
        s3 = s3 * 0.999996 + 1e-9
        s4 = s4 * 0.999995 + 1e-9
        s5 = s5 * 0.999994 + 1e-9
        s6 = s6 * 0.999993 + 1e-9
        s7 = s7 * 0.999992 + 1e-9
    return s0 + s1 + s2 + s3 + s4 + s5 + s6 + s7


@numba.njit(cache=False)
def _dependent_multiply_adds(n, x):
    s = x
    for _ in range(n):
        s = s * 0.999999 + 1e-9
    return s


@numba.njit(cache=False)
def _sincos_calls(n, x):
    s = 0.0
    for k in range(n):
        a = x + 1e-7 * k
        s += math.cos(a) + math.sin(a)
    return s


def scalar_throughput(time_runs) -> dict:
    """Measured scalar speed: independent and dependent multiply-adds, sin + cos pairs."""
    n = 20_000_000
    for f in (_independent_multiply_adds, _dependent_multiply_adds, _sincos_calls):
        f(10, 1.0)
    t_ind, _ = time_runs(lambda: _independent_multiply_adds(n, 1.0), 5)
    t_dep, _ = time_runs(lambda: _dependent_multiply_adds(n, 1.0), 5)
    t_sc, _ = time_runs(lambda: _sincos_calls(n // 4, 0.3), 5)
    return {
        "independent_gflops": 16 * n / statistics.median(t_ind) / 1e9,
        "dependent_gflops": 2 * n / statistics.median(t_dep) / 1e9,
        "ns_per_sin_or_cos": statistics.median(t_sc) / (n // 4) / 2 * 1e9,
    }


# ------------------------------------------------------------------ NumPy/SciPy path
class NumpySampledData:
    """The nominal case in NumPy/SciPy: computed torque, plant by solve_ivp over each sample.

    The passive variables of both the controller and the plant come from ``fsolve`` started at
    the previous solution (single-solution branch following); ``(Mθ, Cθθ̇)`` from the NumPy
    baseline model; the plant's θ̈ = Mθ⁻¹(τ - Cθθ̇) by ``np.linalg.solve``.
    """

    def __init__(self, closure, numpy_model):
        self.closure, self.model = closure, numpy_model

    def _passive(self, theta, q_guess):
        x, _ier = self.closure.solve(theta, q_guess[3:])
        return np.concatenate([theta, x])

    def run(self, desired, q0, ts, n, kp, kv):
        theta, theta_dot = q0[:3].copy(), np.zeros(3)
        q_ctrl = q_plant = q0.copy()
        out = np.empty((n, 3))
        for k in range(n):
            out[k] = theta
            q_ctrl = self._passive(theta, q_ctrl)
            m_theta, c_theta = self.model(q_ctrl, theta_dot)
            e, e_dot = theta - desired.theta[k], theta_dot - desired.theta_dot[k]
            tau = m_theta[0] @ (desired.theta_ddot[k] - kp * e - kv * e_dot) + c_theta[0]
            if k == n - 1:
                break
            guess = [q_plant]

            def rhs(_t, y, tau=tau, guess=guess):
                q = self._passive(y[:3], guess[0])
                guess[0] = q
                m, c = self.model(q, y[3:])
                return np.concatenate([y[3:], np.linalg.solve(m[0], tau - c[0])])

            sol = solve_ivp(rhs, (0.0, ts), np.concatenate([theta, theta_dot]), method="DOP853", rtol=1e-10,
                            atol=1e-12)
            theta, theta_dot = sol.y[:3, -1].copy(), sol.y[3:, -1].copy()
            q_plant = self._passive(theta, guess[0])
        return out


#: The kernels the simulation runs the paper's machine on: its description's, with the compiled core.
KERNELS = MechanismModel.from_preset("paper").kernels


def paper_oracle(model: MechanismModel) -> Planar3RRR:
    """The paper's own formulation (:class:`~pkmlab.paper.geometry.Planar3RRR`, 7 coordinates ``(θ, φ, α)``) of a
    scenario's machine, for the NumPy baselines and the 3-RRR plant that serve as references: the paper's machine,
    checked to be the scenario's (its description's parameters the same to rounding)."""
    paper = Planar3RRR.paper()
    if model.kernels is not KERNELS or not np.allclose(MechanismModel.from_3rrr(paper).P, model.P, rtol=1e-12,
                                                       atol=1e-15):
        raise ValueError(f"the scenario's machine ({model.description.notation}) is not the paper's 3-RRR")
    return paper


def kernel_rows(h, repeats: int) -> tuple[list[dict], dict]:
    """The simulation loop's own kernels along the paper's circle (1,571 samples, one call per sample)."""
    model = Planar3RRR.paper()
    _path, q_path, thetas = h.circle_path(model)
    rng = np.random.default_rng(3)
    theta_dots = rng.normal(0.0, 1.0, thetas.shape)
    taus = rng.normal(0.0, 0.1, thetas.shape)
    q_out = np.empty((q_path.shape[0], KERNELS.N_COORDINATES))
    acc = np.zeros_like(thetas)
    P = MechanismModel.from_3rrr(model).P
    q_start = coordinates_from_3rrr(model, q_path[0])
    n = thetas.shape[0] - 1
    rows, checks = [], {}
    # the compiled core's follow_path: one workspace along the path, as the simulation loop follows it
    times, (status, _k) = h.time_runs(lambda: KERNELS.follow_path(q_start, thetas[1:], P, 1e-6, q_out[1:]), repeats)
    rows.append(h.rate_row("bf_workspace_kernel", f"branch following, simulation kernel (workspace), {n} circle "
                           "steps", times, n, "step", baseline="fsolve"))
    checks["bf_workspace_status"] = int(status)
    checks["bf_workspace_max_diff_vs_ik"] = float(np.abs(h.wrapped(coordinates_to_3rrr(q_out[1:])[:, 3:]
                                                                   - q_path[1:, 3:])).max())
    q_fd = np.empty_like(q_out)
    q_fd[0] = q_start
    times, status = h.time_runs(lambda: h.follow_and_forward_dynamics_kernel_loop(thetas, theta_dots, taus, P, 1e-6,
                                                                                q_fd, acc), repeats)
    rows.append(h.rate_row("fd_bf_workspace_kernel", f"forward dynamics + branch following, simulation kernels, {n} "
                           "circle steps", times, n, "step", baseline="numpy_dyn_batched"))
    reference = paper_dynamics.forward_dynamics(model, q_path[1:], theta_dots[1:], taus[1:])
    checks["fd_bf_workspace_status"] = int(status)
    checks["fd_bf_workspace_max_rel_diff"] = float(np.abs(acc[1:] - reference).max() / np.abs(reference).max())
    return rows, checks


def compile_cache_behaviour() -> dict:
    """Wall time of a new process importing pkmlab and simulating the nominal case: with an empty
    compile cache (everything compiled), then again with the cache that run left (loaded)."""
    import subprocess
    import sys
    import tempfile

    code = "import pkmlab; pkmlab.simulate(pkmlab.paper_scenario('nominal'))"
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "PKMLAB_CACHE_DIR": cache}
        for label in ("empty", "warm"):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], env=env, check=True)
            out[label] = time.perf_counter() - start
    return out


# ------------------------------------------------------------------ the section
def simulation_rows(h, quick: bool) -> tuple[list[dict], dict]:
    """Rows and checks of the simulation section; ``h`` is the ``run`` module (its helpers)."""
    repeats = 3 if quick else 21
    rows, checks = kernel_rows(h, 5 if quick else 31)
    rows.append(h.section_row("closed-loop simulation (vs baseline: NumPy/SciPy solve_ivp path)"))
    nominal = pkmlab.paper_scenario("nominal")
    seconds, result = h.time_once(lambda: pkmlab.simulate(nominal))
    rows.append(h.first_call_row("first_call_simulate", "first call in this process: simulate(nominal)", seconds))
    seconds, _ = h.time_once(lambda: pkmlab.simulate_batch([nominal, nominal]))
    rows.append(h.first_call_row("first_call_simulate_batch", "first call in this process: simulate_batch", seconds))
    if not quick:
        for label, seconds in compile_cache_behaviour().items():
            rows.append(h.first_call_row(f"new_process_{label}", f"new process, import + simulate(nominal), {label} "
                                         "compile cache", seconds))
    n = result.t.size
    times, _ = h.time_runs(lambda: pkmlab.simulate(nominal), repeats)
    rows.append(h.rate_row("sim_nominal_inprocess", f"nominal case, simulate() in-process ({n} samples)", times, 1,
                           "run", baseline="numpy_solve_ivp_run"))
    checks["nominal_simulate_ms"] = rows[-1]["median_s"] * 1e3

    prep = prepare_run(nominal)  # what simulate() hands its compiled loop: the desired motion, the start
    mode, d = prep.mode, prep.desired
    machine = nominal.model  # the simulation's machine: its description's kernels, configurations (θ, φ, x, y, α)
    P, kernels = machine.P, machine.kernels
    kv = nominal.controller.velocity_gain
    oracle = paper_oracle(machine)  # the same machine in the paper's own formulation, for the NumPy path

    def desired(scenario):  # the desired motion simulate() computes for ``scenario`` (in nominal's working mode)
        return prepare_run(scenario.replace(working_mode=mode)).desired

    def outputs(count):  # the loop's records: configurations, rates, efforts, S
        return np.zeros((count, kernels.N_COORDINATES)), np.zeros((count, 3)), np.zeros((count, 3)), np.zeros(count)

    buffers = outputs(n)
    # ideal drives, no compensation, ideal sensors
    ideal = (kernels.NO_DRIVES, kernels.NO_DRIVES, np.zeros((0, 3)), np.zeros(3), np.zeros((0, 3)), -1, 0)
    # the distribution's rows (weights, preload, limits, least-peak flag): one solution for as many actuators
    minimum_norm = np.vstack([np.ones(3), np.zeros(3), np.full(3, np.inf), np.zeros(3)])

    def loop(n_sub=1, ts=1e-3, dd=d):
        return kernels.sampled_data_loop(ts, n_sub, dd.theta, dd.theta_dot, dd.theta_ddot, result.q[0], dd.q[0], P,
                                         P, 0, 1000.0, kv, minimum_norm, 0.01, *ideal,
                                         *(b[: dd.theta.shape[0]] for b in buffers),
                                         np.zeros((0, 3)))

    times, _ = h.time_runs(loop, repeats)
    rows.append(h.rate_row("sim_nominal_loop", f"nominal case, compiled sampled-data loop only ({n} samples)", times,
                           1, "run", baseline="numpy_solve_ivp_run"))
    rows[-1]["us_per_sample"] = rows[-1]["median_s"] / (n - 1) * 1e6
    checks["nominal_loop_ms"] = rows[-1]["median_s"] * 1e3

    # NumPy/SciPy path (slow: a prefix of the run in --quick mode, scaled to the whole run)
    n_np = 100 if quick else n
    numpy_path = NumpySampledData(h.NumpyLoopClosure(oracle), h.NumpyActuatorSpaceModel(oracle))
    seconds, theta_np = h.time_once(lambda: numpy_path.run(d, coordinates_to_3rrr(result.q[0]), 1e-3, n_np, 1000.0,
                                                           kv))
    rows.append(h.rate_row("numpy_solve_ivp_run", f"baseline: NumPy + fsolve + solve_ivp path ({n_np} samples"
                           f"{', scaled to ' + str(n) if n_np < n else ''})", [seconds * (n - 1) / (n_np - 1)], 1,
                           "run", compare=False))
    checks["numpy_path_max_theta_diff_rad"] = float(np.abs(theta_np - result.theta[:n_np]).max())

    # MuJoCo on the same mechanism and steps
    try:
        import mujoco_model
    except ImportError as exc:  # MuJoCo is optional
        checks["mujoco"] = f"not measured: {exc}"
    else:
        fig = mujoco_model.time_nominal_case(repeats, result=result)
        key = "rollout" if "rollout_ms" in fig else "python_loop"
        rows.append(h.rate_row("mujoco_nominal", f"MuJoCo {fig['mujoco_version']} same mechanism, {fig['steps']} RK4 "
                               f"steps of 1 ms ({key.replace('_', ' ')})", [fig[f"{key}_ms"] / 1e3], 1, "run",
                               baseline="numpy_solve_ivp_run"))
        rows[-1]["min_s"] = fig[f"{key}_min_ms"] / 1e3
        checks["mujoco"] = fig
        by_key = {r.get("key"): r for r in rows}
        mujoco_s = fig[f"{key}_ms"] / 1e3
        checks["ratio_pkmlab_simulate_to_mujoco"] = by_key["sim_nominal_inprocess"]["median_s"] / mujoco_s
        checks["ratio_pkmlab_loop_to_mujoco"] = by_key["sim_nominal_loop"]["median_s"] / mujoco_s
        rows.append(h.metric_row("ratio_simulate_to_mujoco", "ratio: simulate() nominal / MuJoCo same steps",
                                 checks["ratio_pkmlab_simulate_to_mujoco"], "x"))

    # batch of disturbed runs, ±15 % plant parameters
    n_batch = 100 if quick else 1000
    rng = np.random.default_rng(BATCH_SEED)
    disturbed = pkmlab.paper_scenario("disturbed")
    scenarios = [disturbed.replace(plant=pkmlab.perturbed_model(disturbed.model, rng, BATCH_SPREAD), name=f"draw {i}")
                 for i in range(n_batch)]
    pkmlab.simulate_batch(scenarios[:2])
    threads = numba.get_num_threads()
    seconds, batch = h.time_once(lambda: pkmlab.simulate_batch(scenarios, on_error="return"))
    rows.append(h.rate_row("batch_disturbed", f"batch: {n_batch} disturbed runs ±15 %, {threads} threads", [seconds],
                           n_batch, "run", compare=False))
    if isinstance(checks.get("mujoco"), dict):
        mujoco_s = next(r["median_s"] for r in rows if r.get("key") == "mujoco_nominal")
        rows.append(h.metric_row("ratio_batch_to_mujoco", f"ratio: the batch / {n_batch} MuJoCo steppings as above",
                                 seconds / (n_batch * mujoco_s), "x"))
    numba.set_num_threads(1)
    try:
        seconds1, _ = h.time_once(lambda: pkmlab.simulate_batch(scenarios[: n_batch // 4], on_error="none"))
    finally:
        numba.set_num_threads(threads)
    rows.append(h.rate_row("batch_disturbed_1_thread", f"batch: {n_batch // 4} of those runs on 1 thread",
                           [seconds1], n_batch // 4, "run", compare=False))
    failed = [r for r in batch if not isinstance(r, pkmlab.SimulationResult)]
    diffs = []
    for i in range(0, n_batch, max(1, n_batch // 10)):
        if isinstance(batch[i], pkmlab.SimulationResult):
            alone = pkmlab.simulate(scenarios[i])
            diffs.append(max(float(np.abs(getattr(batch[i], k) - getattr(alone, k)).max()) for k in ("q", "tau")))
    checks["batch_failed_runs"] = len(failed)
    checks["batch_failures_by_kind"] = {
        "plant cannot be assembled at the start angles": sum("cannot be assembled" in str(e) for e in failed),
        "plant met a gain-type singularity during the run": sum("gain-type singularity" in str(e) for e in failed),
    }
    checks["batch_vs_alone_max_diff"] = max(diffs)
    rows.append(h.metric_row("batch_vs_alone_max_diff", f"batch: max |batch - alone| over {len(diffs)} runs",
                             max(diffs), "rad, N·m"))

    # integrator: error and order per sample against DOP853 at rtol 1e-13, fast case's fastest state
    fast = pkmlab.simulate(pkmlab.paper_scenario("fast"))
    k = int(np.argmax(np.abs(fast.theta_dot).max(axis=1)))
    fast_machine = fast.scenario.model  # the simulation's machine; the reference: the paper's own 3-RRR plant
    ref = ReducedPlant(paper_oracle(fast_machine), rtol=1e-13, atol=1e-15).simulate(
        coordinates_to_3rrr(fast.q[k]), fast.theta_dot[k], fast.tau[k], 1e-3, t_eval=[0.0, 1e-3])
    ref_x = np.concatenate([ref.q[-1, :3], ref.theta_dot[-1]])
    errors = {}
    for n_sub in (1, 2, 4):
        workspaces = kernels.make_workspaces(1)  # kept alive: ws points into it
        ws = workspaces[0]
        kernels.set_base(ws, np.ascontiguousarray(fast.q[k]), fast_machine.P)
        x = np.concatenate([fast.q[k, :3], fast.theta_dot[k]])
        kernels.rk4_sample(ws, x, fast.tau[k], fast_machine.P, 1e-3, n_sub, 1e-3, np.empty((5, 6)), False,
                           kernels.NO_DRIVES)
        errors[n_sub] = float(np.abs(x - ref_x).max())
        rows.append(h.metric_row(f"rk4_error_{n_sub}_steps", f"plant RK4, {n_sub} step(s) per 1 ms sample: error "
                                 "vs DOP853 1e-13 (fast case, fastest state)", errors[n_sub], "rad, rad/s"))
    checks["rk4_observed_order_1_to_2"] = math.log2(errors[1] / errors[2]) if errors[2] > 0 else float("nan")
    whole = {s: pkmlab.simulate(nominal.replace(substeps=s)) for s in (1, 8)}
    checks["nominal_substeps_1_vs_8_max_theta_diff"] = float(np.abs(whole[1].theta - whole[8].theta).max())
    rows.append(h.metric_row("nominal_substeps_1_vs_8", "nominal case: max |θ(1 step/sample) - θ(8 steps)|",
                             checks["nominal_substeps_1_vs_8_max_theta_diff"], "rad"))

    # arithmetic limit: the operations of one sample counted from the code that runs (operation_count)
    speed = scalar_throughput(h.time_runs)
    counts = operation_count.counts_in_subprocess()  # every preset's (the mechanisms' rows use them)
    checks["operation_counts"], checks["scalar_speed"] = counts, speed
    count = counts["paper"]
    limit_sample = operation_count.limit_per_sample(count, speed)
    limit_ms = limit_sample * (n - 1) * 1e3
    checks["operation_count"] = {"per_sample_operations": count["operations_per_sample"],
                                 "per_sample_libm_calls": count["libm_calls_per_sample"],
                                 "bytes_streamed_per_sample": count["bytes_streamed_per_sample"],
                                 "working_set_bytes": count["working_set_bytes"],
                                 "limit_per_sample_us": limit_sample * 1e6, "limit_nominal_ms": limit_ms}
    rows.append(h.metric_row("arith_limit_nominal", "arithmetic limit, nominal case: "
                             f"{count['operations_per_sample']:.0f} operations + "
                             f"{count['libm_calls_per_sample']:.0f} libm calls per sample at "
                             f"{speed['independent_gflops']:.1f} Gflop/s, {speed['ns_per_sin_or_cos']:.0f} ns per call",
                             limit_ms, "ms"))
    loop_ms = checks.get("nominal_loop_ms")
    if loop_ms:
        rows.append(h.metric_row("ratio_loop_to_arith_limit", "ratio: compiled loop / arithmetic limit",
                                 loop_ms / limit_ms, "x"))
    rows.append(h.metric_row("ratio_simulate_to_arith_limit", "ratio: simulate() nominal / arithmetic limit",
                             checks["nominal_simulate_ms"] / limit_ms, "x"))

    # cost growth
    scale = {}
    length = 2 * math.pi * 0.05
    for duration in (0.5, 1.0, 2.0, 4.0, 8.0):
        speed_v = length / duration  # the paper's trajectory lasts L / v
        sc = nominal.replace(trajectory=paper_trajectory(speed_v))
        dd = desired(sc)  # samples 0 … ceil(T / 1 ms)
        buffers = outputs(dd.t.size)
        tm, _ = h.time_runs(lambda dd=dd: loop(dd=dd), 3)
        scale[f"duration_{sc.trajectory.duration:.2f}s"] = statistics.median(tm)
    for ts in (0.25e-3, 0.5e-3, 1e-3, 2e-3, 4e-3):
        dd = desired(nominal.replace(sample_time=ts))  # samples 0 … ceil(T / Ts)
        buffers = outputs(dd.t.size)
        tm, _ = h.time_runs(lambda dd=dd, ts=ts: loop(ts=ts, dd=dd), 3)
        scale[f"Ts_{ts * 1e3:g}ms"] = statistics.median(tm)
    for size in (1, 10, 100) + (() if quick else (1000,)):
        if size == n_batch:
            scale[f"batch_{size}"] = rows[[r.get("key") for r in rows].index("batch_disturbed")]["median_s"]
            continue
        tm, _ = h.time_runs(lambda size=size: pkmlab.simulate_batch(scenarios[:size], on_error="none"), 1)
        scale[f"batch_{size}"] = statistics.median(tm)
    checks["cost_growth_s"] = scale
    for key, value in scale.items():
        rows.append(h.metric_row(f"growth_{key}", f"cost growth: {key.replace('_', ' ')}", value * 1e3, "ms"))
    checks["threads"] = threads
    checks["cpu_count"] = os.cpu_count()
    return rows, checks

