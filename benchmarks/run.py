"""Benchmarks of pkmlab's kinematics and dynamics on the paper's 3-RRR (``make bench``).

Prints a table and writes every figure, with the machine it ran on, to
``benchmarks/results.json``. Each figure is the median of several timed runs
(``time.perf_counter``, garbage collector off as in :mod:`timeit`) taken after a warm-up
call, so Numba compilation is excluded; the first call of each compiled entry point
(compilation, or loading from pkmlab's on-disk cache) is reported on its own rows.

Figures
-------
* forward kinematics, every assembly mode: batched (one call for the whole batch), the
  compiled batch driver alone, and one call per ``θ`` (python API in a loop);
* branch-following forward kinematics along the paper's circle: the python API once per
  sample, and the compiled core's :func:`pkmlab.codegen.core.branch_following.follow_branch_in_steps` (what the
  API calls) from a small ``@numba.njit`` loop (no Python overhead per call);
* inverse kinematics, all 8 working modes, batched;
* a baseline measured in the same run: ``scipy.optimize.fsolve`` on the loop-closure
  equations written in plain NumPy. The "vs baseline" column of these rows is the baseline's
  time per solve divided by the row's time per solve.

Dynamics (paper §3, eq. 35), in working mode (-, +, -):

* the actuator-space model ``(Mθ, Cθ θ̇)``: the compiled core's
  :func:`pkmlab.codegen.core.dynamics.actuator_space_model` (on the machine's description) from a small
  ``@numba.njit`` loop, :func:`paper_dynamics.actuator_space_model` batched and once per state;
* forward dynamics ``θ̈``: the same with its solve, from an njit loop
  over the states of the paper's circle, the same with branch following of the passive
  variables at every step (what :class:`pkmlab.paper.plant.ReducedPlant` evaluates), and
  :func:`paper_dynamics.forward_dynamics` once per state and batched;
* 1 s of free motion (zero torque) with :class:`pkmlab.paper.plant.ReducedPlant` and
  :class:`pkmlab.paper.plant.FullPlant`: wall time, right-hand-side evaluations, loop-closure
  residual, relative kinetic-energy drift and the largest difference between the two;
* a baseline measured in the same run: ``(Mθ, Cθ θ̇)`` in plain NumPy (body Jacobians, ``M``
  and ``Jqθ`` by ``np.linalg.solve``), once per state and vectorized over the batch, checked
  against pkmlab to 1e-10. Rows called once per state are compared with the per-state
  baseline, batched rows and compiled loops with the vectorized one.

Closed-loop simulation (the paper's nominal case in-process, the NumPy/SciPy ``solve_ivp``
path, MuJoCo on the same mechanism, a batch of 1,000 disturbed runs, the plant integrator's
error and order, the arithmetic limit, cost growth): :mod:`simulation_bench`, whose rows follow;
then every preset mechanism (forward kinematics, one dynamics evaluation, the default run):
:mod:`mechanism_bench`; the two plants' accuracy against speed: :mod:`mujoco_frontier`; a 2,000-run
study in-process and on Dask: :mod:`study_bench`; the command line's start-up: :mod:`startup_bench`.

Usage::

    .venv/bin/python benchmarks/run.py            # full run (a few minutes + any compilation of pkmlab)
    .venv/bin/python benchmarks/run.py --quick    # smoke test

The benchmark's own njit loops are not cached (a cached loop would keep stale copies of
pkmlab's kernels): compiling them takes about 15 s of every run on a 2-CPU machine.

The first-call rows depend on the state of the compile cache: with a warm cache they are
the time to load the kernels; after any change to pkmlab's sources (which invalidates the
cache) or with ``PKMLAB_CACHE_DIR=$(mktemp -d)`` they are the compilation time.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

import numba
import numpy as np
import scipy
from scipy.optimize import fsolve

import pkmlab
from pkmlab.model.mechanism_model import MechanismModel
from pkmlab.paper import dynamics as pk_dynamics
from pkmlab.paper import kinematics as kin
from pkmlab.paper import kinematics as pk_kinematics
from pkmlab.paper import rrr3
from pkmlab.paper.geometry import WORKING_MODES, Planar3RRR
from pkmlab.paper.kinematics import coordinates_from_3rrr, coordinates_to_3rrr
from pkmlab.paper.plant import FullPlant, ReducedPlant

HERE = Path(__file__).resolve().parent
DEFAULT_OUTPUT = HERE / "results.json"
SEED = 20240527

# Random reachable poses: centroid uniform in a disc, orientation uniform in an interval.
POSE_CENTRE = (0.25, 0.20)
POSE_RADIUS = 0.08
ALPHA_HALF_RANGE = 0.3

# The paper's circle (section 5): centre, radius, α = 0, 1571 samples, working mode (-, +, -).
CIRCLE_CENTRE = (0.25, 0.21)
CIRCLE_RADIUS = 0.05
CIRCLE_SAMPLES = 1571
CIRCLE_MODE = (-1, 1, -1)
SINGULARITY_GUARD = 1e-6  # kin.branch_following's default

BASELINE_XTOL = 1e-12  # relative step tolerance handed to fsolve (its default is 1.49e-8)

# Dynamics: states are the random poses above in the circle's working mode, with random rates and torques.
DYN_MODE = CIRCLE_MODE
THETA_DOT_STD = 1.0  # rad/s, standard deviation of each random θ̇_i
TAU_STD = 0.1  # N·m, standard deviation of each random τ_i
DYN_BASELINE_RTOL = 1e-10  # the NumPy baseline must agree with pkmlab to this, relative to max |entry|

# Free motion (zero torque) of the plants: start pose, actuated rates, duration, output samples.
FREE_MOTION_POSE = (0.25, 0.21, 0.0)
FREE_MOTION_THETA_DOT = (0.4, 0.3, -0.4)
FREE_MOTION_SECONDS = 1.0
FREE_MOTION_SAMPLES = 201

# Problem sizes and repeat counts: full run, and --quick.
SETTINGS = {
    "full": {
        "n_batch": 20_000,
        "n_single": 2_000,
        "repeats_batch": 7,
        "repeats_single": 5,
        "repeats_path_api": 7,
        "repeats_path_kernel": 31,
        "repeats_baseline": 5,
        "repeats_baseline_fd": 3,
        "n_dyn_batch": 10_000,
        "n_dyn_single": 2_000,
        "n_dyn_baseline_single": 500,
        "repeats_dyn_kernel": 15,
        "repeats_dyn_batch": 7,
        "repeats_dyn_single": 5,
        "repeats_dyn_baseline": 5,
        "repeats_plant": 5,
    },
    "quick": {
        "n_batch": 2_000,
        "n_single": 200,
        "repeats_batch": 3,
        "repeats_single": 3,
        "repeats_path_api": 3,
        "repeats_path_kernel": 5,
        "repeats_baseline": 3,
        "repeats_baseline_fd": 3,
        "n_dyn_batch": 1_000,
        "n_dyn_single": 200,
        "n_dyn_baseline_single": 100,
        "repeats_dyn_kernel": 5,
        "repeats_dyn_batch": 3,
        "repeats_dyn_single": 3,
        "repeats_dyn_baseline": 3,
        "repeats_plant": 3,
    },
}


# ------------------------------------------------------------------ timing
def time_runs(fn: Callable[[], object], repeats: int, warmup: int = 1) -> tuple[list[float], object]:
    """Wall-clock seconds of ``repeats`` calls of ``fn`` after ``warmup`` untimed calls, and the last result."""
    out = None
    for _ in range(warmup):
        out = fn()
    times = []
    gc_was_enabled = gc.isenabled()
    try:
        for _ in range(repeats):
            gc.collect()
            gc.disable()
            start = time.perf_counter()
            out = fn()
            times.append(time.perf_counter() - start)
            gc.enable()
    finally:
        if gc_was_enabled:
            gc.enable()
        else:
            gc.disable()
    return times, out


def time_once(fn: Callable[[], object]) -> tuple[float, object]:
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def rate_row(key: str, name: str, times: list[float], ops: int, op: str, compare: bool = True,
             baseline: str = "fsolve") -> dict:
    """A row whose figure is the time per operation (``ops`` operations per timed run).

    ``baseline`` names the entry of :data:`BASELINES` it is compared with (when ``compare``).
    """
    median = statistics.median(times)
    return {
        "key": key,
        "name": name,
        "kind": "per_op",
        "op": op,
        "ops_per_run": ops,
        "repeats": len(times),
        "times_s": times,
        "median_s": median,
        "min_s": min(times),
        "max_s": max(times),
        "median_us_per_op": median / ops * 1e6,
        "per_second": ops / median,
        "compare_to_baseline": compare,
        "baseline": baseline if compare else None,
    }


def first_call_row(key: str, name: str, seconds: float) -> dict:
    return {"key": key, "name": name, "kind": "first_call", "repeats": 1, "times_s": [seconds], "median_s": seconds}


def metric_row(key: str, name: str, value: float, unit: str) -> dict:
    """A row whose figure is a measured quantity, not a time (shown in the median column)."""
    return {"key": key, "name": name, "kind": "metric", "value": value, "unit": unit}


def section_row(name: str) -> dict:
    """A heading line in the printed table (not written to the JSON results)."""
    return {"kind": "section", "name": name}


# Reference row of each baseline: a row with ``baseline=b`` is compared with ``BASELINES[b]``.
BASELINES = {
    "numpy_solve_ivp_run": "numpy_solve_ivp_run",
    "fsolve": "baseline_fsolve",
    "numpy_dyn_single": "baseline_numpy_dyn_single",
    "numpy_dyn_batched": "baseline_numpy_dyn_batched",
}


# ------------------------------------------------------------------ machine
def machine_info() -> dict:
    info = {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor(),
        "cpu_model": None,
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "python_implementation": platform.python_implementation(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "pkmlab": pkmlab.__version__,
        "numba_cache_dir": str(numba.config.CACHE_DIR),
    }
    if hasattr(os, "sched_getaffinity"):
        info["cpus_available"] = len(os.sched_getaffinity(0))
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                info["cpu_model"] = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return info


def cache_files() -> set[str]:
    """Compiled-kernel files currently in pkmlab's Numba cache (to tell compilation from loading)."""
    root = Path(numba.config.CACHE_DIR)
    return {str(p.relative_to(root)) for p in root.rglob("*.nbc")} if root.is_dir() else set()


# ------------------------------------------------------------------ workloads
def reachable_samples(model: Planar3RRR, n: int, rng: np.random.Generator):
    """``n`` reachable poses, the θ of a random working mode for each, and the counts drawn and reachable."""
    poses, thetas = [], []
    have = drawn = 0
    while have < n:
        m = max(1024, int(1.5 * (n - have)))
        radius = POSE_RADIUS * np.sqrt(rng.random(m))
        angle = 2.0 * np.pi * rng.random(m)
        batch = np.column_stack([
            POSE_CENTRE[0] + radius * np.cos(angle),
            POSE_CENTRE[1] + radius * np.sin(angle),
            rng.uniform(-ALPHA_HALF_RANGE, ALPHA_HALF_RANGE, m),
        ])
        ik = kin.inverse_kinematics(model, batch, on_unreachable="nan")
        ok = ik.reachable.all(axis=1)
        mode = rng.integers(0, ik.theta.shape[1], m)
        theta = ik.theta[np.arange(m), mode]
        poses.append(batch[ok])
        thetas.append(theta[ok])
        have += int(ok.sum())
        drawn += m
    poses_all = np.concatenate(poses)[:n]
    thetas_all = np.ascontiguousarray(np.concatenate(thetas)[:n])
    return poses_all, thetas_all, drawn, have


def circle_path(model: Planar3RRR):
    s = np.linspace(0.0, 2.0 * np.pi, CIRCLE_SAMPLES)
    path = np.column_stack([
        CIRCLE_CENTRE[0] + CIRCLE_RADIUS * np.cos(s),
        CIRCLE_CENTRE[1] + CIRCLE_RADIUS * np.sin(s),
        np.zeros_like(s),
    ])
    ik = kin.inverse_kinematics(model, path, mode=CIRCLE_MODE)
    return path, np.ascontiguousarray(ik.q), np.ascontiguousarray(ik.theta)


def wrapped(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * x))


def dynamics_states(model: Planar3RRR, poses: np.ndarray, rng: np.random.Generator):
    """Configurations of ``poses`` in working mode :data:`DYN_MODE`, random ``θ̇`` and ``τ``, and ``|S|`` min."""
    ik = kin.inverse_kinematics(model, poses, mode=DYN_MODE)
    n = poses.shape[0]
    theta_dot = rng.normal(0.0, THETA_DOT_STD, (n, 3))
    tau = rng.normal(0.0, TAU_STD, (n, 3))
    return np.ascontiguousarray(ik.q), theta_dot, tau, float(np.abs(ik.S).min())


# The dynamics are evaluated by the compiled core on the machine's description (the simulation's own):
# its kernels, a workspace made once, configurations in its coordinates (θ, φ, x, y, α).
PAPER_KERNELS = MechanismModel.from_preset("paper").kernels


@numba.njit(cache=False, _nrt=False)
def _actuator_space_loop(ws, sc, qs, theta_dots, P, m_out, c_out, taus, accelerations):
    all_ok = True
    for k in range(qs.shape[0]):
        PAPER_KERNELS.trig(qs[k], sc)
        ok = PAPER_KERNELS.actuator_space_model(ws, qs[k], sc, theta_dots[k], P)
        for i in range(3):
            c_out[k, i] = ws.c_theta[i]
            for j in range(3):
                m_out[k, i, j] = ws.m_theta[i, j]
        if taus.shape[0] > 0:
            ok = ok and PAPER_KERNELS.solve_accelerations(ws, taus[k])
            for i in range(3):
                accelerations[k, i] = ws.theta_ddot[i]
        all_ok = all_ok and ok
    return all_ok


@numba.njit(cache=False, _nrt=False)
def _follow_path(ws, thetas, P, singularity_guard, q_path):
    status = 0
    for k in range(1, thetas.shape[0]):
        status |= PAPER_KERNELS.follow_branch_in_steps(ws, q_path[k - 1], thetas[k], P, singularity_guard, np.inf)
        for i in range(q_path.shape[1]):
            q_path[k, i] = ws.q[PAPER_KERNELS.BASE, i]
    return status


def follow_path_kernel(thetas, P, singularity_guard, q_path):
    """Branch following along ``thetas`` from ``q_path[0]`` (the core's coordinates): one compiled call per sample,
    each started afresh from the previous configuration, as the public API's kernel does."""
    return _follow_path(PAPER_KERNELS.make_workspaces(1)[0], thetas, P, singularity_guard, q_path)


def actuator_space_kernel_loop(qs, theta_dots, P, m_out, c_out):
    """``(Mθ, Cθ θ̇)`` at every state (``qs`` in the core's coordinates): one compiled call per state. True when
    all were regular."""
    none = np.empty((0, 3))
    return _actuator_space_loop(PAPER_KERNELS.make_workspaces(1)[0], np.zeros((qs.shape[1], 2)), qs, theta_dots, P,
                                m_out, c_out, none, none)


def forward_dynamics_kernel_loop(qs, theta_dots, taus, P, out):
    """``θ̈`` at every state: one compiled evaluation of the model and its solve per state."""
    n = qs.shape[0]
    return _actuator_space_loop(PAPER_KERNELS.make_workspaces(1)[0], np.zeros((qs.shape[1], 2)), qs, theta_dots, P,
                                np.empty((n, 3, 3)), np.empty((n, 3)), taus, out)


@numba.njit(cache=False, _nrt=False)
def _follow_and_forward_dynamics(ws, thetas, theta_dots, taus, P, singularity_guard, q_path, out):
    status = 0
    for k in range(1, thetas.shape[0]):
        status |= PAPER_KERNELS.plant_stage(ws, thetas[k], theta_dots[k], taus[k], P, singularity_guard,
                                            PAPER_KERNELS.TRIAL, False, PAPER_KERNELS.NO_DRIVES)
        PAPER_KERNELS.accept_trial(ws)
        for i in range(3):
            out[k, i] = ws.theta_ddot[i]
        for i in range(q_path.shape[1]):
            q_path[k, i] = ws.q[PAPER_KERNELS.BASE, i]
    return status


def follow_and_forward_dynamics_kernel_loop(thetas, theta_dots, taus, P, singularity_guard, q_path, out):
    """Per step: branch-follow from ``q_path[k - 1]`` to ``θ_k``, then ``θ̈`` there (a reduced-plant RHS, as the
    simulation's RK4 stages evaluate it). Returns the status."""
    workspaces = PAPER_KERNELS.make_workspaces(1)  # kept alive: ws points into it
    ws = workspaces[0]
    PAPER_KERNELS.set_base(ws, q_path[0], P)
    return _follow_and_forward_dynamics(ws, thetas, theta_dots, taus, P, singularity_guard, q_path, out)


# ------------------------------------------------------------------ baseline: NumPy + scipy.optimize.fsolve
# BASELINE: a SINGLE-SOLUTION Newton-type solve (MINPACK's hybrj, Powell's hybrid method, as
# wrapped by scipy.optimize.fsolve) of the four loop-closure equations η(θ, φ) = 0 for
# φ = (φ1, φ2, φ3, α), written in plain NumPy with the analytic Jacobian. Started from the known
# solution perturbed -- namely the solution at the previous sample of the path, exactly what
# branch following starts from -- it returns the ONE assembly mode nearest the guess. It is
# therefore the like-for-like reference for branch following; kin.forward_kinematics finds
# ALL assembly modes (up to six), so its ratio against this baseline is indicative only.
class NumpyLoopClosure:
    """η(θ, φ) = 0 of the 3-RRR (same equations and order as pkmlab.paper.rrr3.constraints)."""

    def __init__(self, model: Planar3RRR):
        self.base = np.array(model.base_points, dtype=float)
        self.l = np.array(model.active_lengths, dtype=float)
        self.r = np.array(model.passive_lengths, dtype=float)
        vertices = np.array(model.platform_vertices, dtype=float)  # P1 at the platform origin
        self.p2 = vertices[1] - vertices[0]
        self.p32 = vertices[2] - vertices[1]

    def elbows(self, theta: np.ndarray) -> np.ndarray:
        return self.base + self.l[:, None] * np.column_stack([np.cos(theta), np.sin(theta)])

    def residual(self, x: np.ndarray, elbows: np.ndarray) -> np.ndarray:
        phi, alpha = x[:3], x[3]
        tips = elbows + self.r[:, None] * np.column_stack([np.cos(phi), np.sin(phi)])  # vertex p_i via leg i
        c, s = np.cos(alpha), np.sin(alpha)
        rot = np.array([[c, -s], [s, c]])
        return np.concatenate([tips[0] + rot @ self.p2 - tips[1], tips[1] + rot @ self.p32 - tips[2]])

    def jacobian(self, x: np.ndarray, elbows: np.ndarray) -> np.ndarray:
        phi, alpha = x[:3], x[3]
        d = self.r[:, None] * np.column_stack([-np.sin(phi), np.cos(phi)])  # d/dφ_i of r_i u(φ_i)
        c, s = np.cos(alpha), np.sin(alpha)
        drot = np.array([[-s, -c], [c, -s]])
        jac = np.zeros((4, 4))
        jac[0:2, 0] = d[0]
        jac[0:2, 1] = -d[1]
        jac[2:4, 1] = d[1]
        jac[2:4, 2] = -d[2]
        jac[0:2, 3] = drot @ self.p2
        jac[2:4, 3] = drot @ self.p32
        return jac

    def solve(self, theta: np.ndarray, guess: np.ndarray, fprime: bool = True) -> tuple[np.ndarray, int]:
        elbows = self.elbows(theta)
        x, _info, ier, _msg = fsolve(
            self.residual,
            guess,
            args=(elbows,),
            fprime=self.jacobian if fprime else None,
            xtol=BASELINE_XTOL,
            full_output=True,
        )
        return x, ier


def baseline_path(closure: NumpyLoopClosure, q_start: np.ndarray, thetas: np.ndarray, fprime: bool) -> tuple:
    out = np.empty((thetas.shape[0], 4))
    out[0] = q_start[3:]
    failures = 0
    for k in range(1, thetas.shape[0]):
        out[k], ier = closure.solve(thetas[k], out[k - 1], fprime)
        failures += ier != 1
    return out, failures


# ------------------------------------------------------------------ baseline: actuator-space model in NumPy
# BASELINE: (Mθ, Cθ θ̇) of eq. (35) written directly in NumPy, from the model's attributes (not
# pkmlab's packed vector or kernels): the constraint Jacobian Jηq, Jqθ = [I; -Jηφ⁻¹ Jηθ] and the
# passive acceleration bias by np.linalg.solve, the bodies' mass-centre/rotation Jacobians and
# centripetal accelerations, M = Σ Jbᵀ Db Jb, C q̇ = Σ Jbᵀ Db (J̇b q̇), then
# Mθ = Jqθᵀ M Jqθ and Cθ θ̇ = Jqθᵀ (M J̇qθ θ̇ + C q̇). Vectorized over a leading batch axis, so the
# same code serves as the per-state baseline (one state per call) and the batched one.
class NumpyActuatorSpaceModel:
    """``(Mθ, Cθ θ̇)`` of the 3-RRR in plain NumPy, for ``q`` (n, 7) and ``θ̇`` (n, 3)."""

    def __init__(self, model: Planar3RRR):
        self.l = np.array(model.active_lengths, dtype=float)
        self.r = np.array(model.passive_lengths, dtype=float)
        vertices = np.array(model.platform_vertices, dtype=float)  # P1 at the platform origin
        self.p2 = vertices[1] - vertices[0]
        self.p32 = vertices[2] - vertices[1]
        # Mass centre of body b (active links 0-2, passive links 3-5, platform 6) = base point
        # + Σ R(q_j) v over its terms (b, j, v); body b rotates with coordinate b.
        terms = [(i, i, model.active_com[i]) for i in range(3)]
        for i in range(3):
            terms += [(3 + i, i, (self.l[i], 0.0)), (3 + i, 3 + i, model.passive_com[i])]
        terms += [(6, 0, (self.l[0], 0.0)), (6, 3, (self.r[0], 0.0)), (6, 6, model.platform_com)]
        self.terms = [(b, j, float(v[0]), float(v[1])) for b, j, v in terms]
        mass = np.concatenate([model.active_masses, model.passive_masses, [model.platform_mass]])
        inertia = np.concatenate([model.active_inertias, model.passive_inertias, [model.platform_inertia]])
        self.D = np.column_stack([mass, mass, inertia])  # (7, 3): (m, m, I) per body

    def constraint_jacobian(self, c: np.ndarray, s: np.ndarray) -> np.ndarray:
        """``Jηq`` (n, 4, 7) from ``cos q`` and ``sin q``."""
        jac = np.zeros((c.shape[0], 4, 7))
        for i in range(3):
            for coord, length in ((i, self.l[i]), (3 + i, self.r[i])):
                d = length * np.stack([-s[:, coord], c[:, coord]], axis=-1)  # d/dx of length u(x)
                if i == 0:
                    jac[:, 0:2, coord] = d
                elif i == 1:
                    jac[:, 0:2, coord] = -d
                    jac[:, 2:4, coord] = d
                else:
                    jac[:, 2:4, coord] = -d
        ca, sa = c[:, 6], s[:, 6]
        for rows, v in ((slice(0, 2), self.p2), (slice(2, 4), self.p32)):
            jac[:, rows, 6] = np.stack([-sa * v[0] - ca * v[1], ca * v[0] - sa * v[1]], axis=-1)
        return jac

    def __call__(self, q: np.ndarray, theta_dot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        q = np.asarray(q, dtype=float).reshape(-1, 7)
        theta_dot = np.asarray(theta_dot, dtype=float).reshape(-1, 3)
        n = q.shape[0]
        c, s = np.cos(q), np.sin(q)
        jac = self.constraint_jacobian(c, s)
        j_eta_phi = jac[:, :, 3:]
        j_q_theta = np.zeros((n, 7, 3))
        j_q_theta[:, :3] = np.eye(3)
        j_q_theta[:, 3:] = -np.linalg.solve(j_eta_phi, jac[:, :, :3])
        qd = (j_q_theta @ theta_dot[:, :, None])[:, :, 0]
        # J̇ηq q̇: column j of Jηq is a vector R(q_j + π/2) v, whose rate is R(q_j + π) v q̇_j
        turned = np.empty_like(jac)
        turned[:, 0::2], turned[:, 1::2] = -jac[:, 1::2], jac[:, 0::2]
        gamma = (turned @ (qd * qd)[:, :, None])[:, :, 0]
        bias_q = np.zeros((n, 7))  # J̇qθ θ̇ (eq. 32)
        bias_q[:, 3:] = -np.linalg.solve(j_eta_phi, gamma[:, :, None])[:, :, 0]
        J = np.zeros((n, 7, 3, 7))  # body Jacobians: mass-centre velocity (x, y) and angular velocity
        body_bias = np.zeros((n, 7, 3))  # J̇b q̇: centripetal accelerations
        for b, j, vx, vy in self.terms:
            rx, ry = c[:, j] * vx - s[:, j] * vy, s[:, j] * vx + c[:, j] * vy
            J[:, b, 0, j] -= ry
            J[:, b, 1, j] += rx
            w2 = qd[:, j] * qd[:, j]
            body_bias[:, b, 0] -= rx * w2
            body_bias[:, b, 1] -= ry * w2
        J[:, np.arange(7), 2, np.arange(7)] = 1.0
        DJ = self.D[None, :, :, None] * J
        M = np.einsum("nbri,nbrk->nik", J, DJ)
        h = np.einsum("nbri,nbr->ni", DJ, body_bias)  # C q̇
        j_q_theta_t = j_q_theta.transpose(0, 2, 1)
        m_theta = j_q_theta_t @ M @ j_q_theta
        c_theta = (j_q_theta_t @ (M @ bias_q[:, :, None] + h[:, :, None]))[:, :, 0]
        return m_theta, c_theta


def baseline_dynamics_per_state(baseline: NumpyActuatorSpaceModel, qs: np.ndarray, theta_dots: np.ndarray):
    m_out = np.empty((qs.shape[0], 3, 3))
    c_out = np.empty((qs.shape[0], 3))
    for k in range(qs.shape[0]):
        m_theta, c_theta = baseline(qs[k], theta_dots[k])
        m_out[k], c_out[k] = m_theta[0], c_theta[0]
    return m_out, c_out


def relative_kinetic_energy_drift(model: Planar3RRR, run) -> float:
    """``max_t |T(t) - T(0)| / T(0)`` of a plant run."""
    energy = pk_dynamics.kinetic_energy(model, run.q, run.q_dot)
    return float(np.abs(energy - energy[0]).max() / energy[0])


# ------------------------------------------------------------------ report
def micro() -> str:
    try:
        "µ".encode(sys.stdout.encoding or "ascii")
    except (UnicodeEncodeError, LookupError):
        return "u"
    return "µ"


def fmt_number(x: float) -> str:
    if x >= 1000:
        return f"{x:,.0f}"
    if x >= 100:
        return f"{x:.1f}"
    if x >= 10:
        return f"{x:.2f}"
    return f"{x:.3f}"


def fmt_metric(x: float | int) -> str:
    if isinstance(x, int | np.integer):
        return f"{x:,}"
    if x == 0.0:
        return "0"
    if 1e-3 <= abs(x) < 1e4:
        return fmt_number(x)
    return f"{x:.2e}"


def format_table(rows: list[dict]) -> str:
    mu = micro()
    header = ("benchmark", "median", "unit", "rate", "vs baseline")
    lines = []
    sections = []  # line indices of headings, printed across the table
    for row in rows:
        if row["kind"] == "section":
            sections.append(len(lines))
            lines.append((row["name"], "", "", "", ""))
            continue
        if row["kind"] == "metric":
            lines.append((row["name"], fmt_metric(row["value"]), row["unit"], "", ""))
            continue
        if row["kind"] == "first_call":
            lines.append((row["name"], fmt_number(row["median_s"] * 1e3), "ms (1 call)", "", ""))
            continue
        ratio = row.get("speedup_vs_baseline")
        if ratio is None:
            ratio_text = ""
        elif row.get("is_baseline_reference"):
            ratio_text = "reference"
        elif ratio >= 1.0:
            ratio_text = f"{ratio:.1f}x faster"
        else:
            ratio_text = f"{1.0 / ratio:.1f}x slower"
        lines.append((
            row["name"],
            fmt_number(row["median_us_per_op"]),
            f"{mu}s/{row['op']}",
            f"{row['per_second']:,.0f} {row['op']}s/s",
            ratio_text,
        ))
    body = [r for k, r in enumerate(lines) if k not in sections]
    widths = [max(len(str(r[i])) for r in [header, *body]) for i in range(len(header))]
    align = ["<", ">", "<", ">", ">"]

    def fmt(r):
        return "  ".join(f"{str(v):{a}{w}}" for v, a, w in zip(r, align, widths, strict=True)).rstrip()

    rule = "-" * len(fmt(header))
    out = [fmt(header), rule]
    for k, r in enumerate(lines):
        out.append(f"-- {r[0]} " + "-" * max(0, len(rule) - len(r[0]) - 4) if k in sections else fmt(r))
    return "\n".join([*out, rule])


def write_json_atomic(path: Path, payload: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(payload, fh, indent=2, allow_nan=False)
        fh.write("\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def progress(msg: str) -> None:
    print(f"[bench] {msg}", file=sys.stderr, flush=True)


# ------------------------------------------------------------------ main
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="smaller batches and fewer repeats (smoke test)")
    parser.add_argument("--output", type=Path, default=DEFAULT_OUTPUT, help="JSON file (default: %(default)s)")
    args = parser.parse_args(argv)
    mode = "quick" if args.quick else "full"
    cfg = SETTINGS[mode]
    t_start = time.perf_counter()
    rng = np.random.default_rng(SEED)
    model = Planar3RRR.paper()
    P = model.packed
    P_core = MechanismModel.from_3rrr(model).P  # the compiled core's parameters of the same machine
    rows: list[dict] = []
    checks: dict = {}

    # -- first calls: compilation or cache load, one row each, before anything else runs
    progress("first calls (compile or cache load) ...")
    files_before = cache_files()
    probe_pose = np.array([CIRCLE_CENTRE[0] + CIRCLE_RADIUS, CIRCLE_CENTRE[1], 0.0])
    dt, ik1 = time_once(lambda: kin.inverse_kinematics(model, probe_pose))
    rows.append(first_call_row("first_call_inverse_kinematics", "first call: inverse_kinematics", dt))
    q1, th1 = ik1.q[0], ik1.theta[0]
    dt, _ = time_once(lambda: kin.forward_kinematics(model, th1))
    rows.append(first_call_row("first_call_forward_kinematics", "first call: forward_kinematics", dt))
    dt, _ = time_once(lambda: kin.branch_following(model, q1, th1 + 1e-3))
    rows.append(first_call_row("first_call_branch_following", "first call: branch_following", dt))
    q_free = kin.inverse_kinematics(model, FREE_MOTION_POSE, mode=DYN_MODE).q
    theta_dot_free = np.array(FREE_MOTION_THETA_DOT)
    zero3 = np.zeros(3)
    dt, _ = time_once(lambda: pk_dynamics.actuator_space_model(model, q_free, theta_dot_free))
    rows.append(first_call_row("first_call_actuator_space_model", "first call: dynamics.actuator_space_model", dt))
    dt, _ = time_once(lambda: pk_dynamics.forward_dynamics(model, q_free, theta_dot_free, zero3))
    rows.append(first_call_row("first_call_forward_dynamics", "first call: dynamics.forward_dynamics", dt))
    dt, _ = time_once(lambda: pk_dynamics.kinetic_energy(model, q_free, np.zeros(7)))
    rows.append(first_call_row("first_call_kinetic_energy", "first call: dynamics.kinetic_energy", dt))
    dt, _ = time_once(lambda: ReducedPlant(model).simulate(q_free, theta_dot_free, zero3, 1e-3))
    rows.append(first_call_row("first_call_reduced_plant", "first call: ReducedPlant.simulate (1 ms)", dt))
    dt, _ = time_once(lambda: FullPlant(model).simulate(q_free, kin.coordinate_rates(model, q_free, theta_dot_free),
                                                       zero3, 1e-3))
    rows.append(first_call_row("first_call_full_plant", "first call: FullPlant.simulate (1 ms)", dt))
    files_after = cache_files()
    scratch = np.tile(q1, (2, 1))
    scratch = coordinates_from_3rrr(model, scratch)
    dt, _ = time_once(lambda: follow_path_kernel(np.tile(th1, (2, 1)), P_core, SINGULARITY_GUARD, scratch))
    rows.append(first_call_row("first_call_benchmark_njit_loop", "first call: benchmark's njit loop (compile)", dt))

    def compile_dynamics_loops():
        qs = coordinates_from_3rrr(model, np.tile(q_free, (2, 1)))
        tds, taus = np.tile(theta_dot_free, (2, 1)), np.zeros((2, 3))
        actuator_space_kernel_loop(qs, tds, P_core, np.empty((2, 3, 3)), np.empty((2, 3)))
        forward_dynamics_kernel_loop(qs, tds, taus, P_core, np.empty((2, 3)))
        follow_and_forward_dynamics_kernel_loop(qs[:, :3].copy(), tds, taus, P_core, SINGULARITY_GUARD, qs.copy(),
                                                np.empty((2, 3)))

    dt, _ = time_once(compile_dynamics_loops)
    rows.append(first_call_row("first_call_benchmark_dynamics_njit_loops",
                               "first call: benchmark's 3 dynamics njit loops (compile)", dt))
    new_files = sorted(files_after - files_before)
    cache_state = {
        "dir": str(numba.config.CACHE_DIR),
        "kernels_compiled_during_first_calls": len(new_files),
        "state": "cold (compiled and saved)" if new_files else "warm (loaded from cache)",
        "files_written_during_first_calls": new_files,
    }

    # -- workloads
    progress(f"generating {cfg['n_batch']} reachable poses ...")
    poses, thetas, drawn, n_reachable = reachable_samples(model, cfg["n_batch"], rng)
    n = thetas.shape[0]
    thetas_single = thetas[: cfg["n_single"]]
    path, q_ref, path_thetas = circle_path(model)
    n_steps = path_thetas.shape[0] - 1

    # (1) forward kinematics, every assembly mode
    progress("forward kinematics, batched ...")
    times, fk = time_runs(lambda: kin.forward_kinematics(model, thetas), cfg["repeats_batch"])
    rows.append(rate_row("fk_all_batched", f"FK all modes, batched API ({n} θ)", times, n, "solve"))

    def fk_driver():
        q = np.full((n, 6, 7), np.nan)
        s = np.full((n, 6), np.nan)
        count = np.zeros(n, dtype=np.int64)
        status = np.zeros(n, dtype=np.int64)
        pk_kinematics._forward_kinematics_batch(thetas, P, q, s, count, status)

    times, _ = time_runs(fk_driver, cfg["repeats_batch"])
    rows.append(rate_row("fk_all_batched_kernel", f"FK all modes, compiled batch driver only ({n} θ)", times, n,
                         "solve"))

    progress("forward kinematics, one call per θ ...")

    def fk_single():
        for theta in thetas_single:
            kin.forward_kinematics(model, theta)

    times, _ = time_runs(fk_single, cfg["repeats_single"])
    rows.append(rate_row("fk_all_single", f"FK all modes, API once per θ ({len(thetas_single)} θ)", times,
                         len(thetas_single), "solve"))
    d = fk.pose - poses[:, None, :]
    d[..., 2] = wrapped(d[..., 2])
    err = np.nanmin(np.linalg.norm(d, axis=-1), axis=-1)
    checks["fk_recovers_ik_pose_fraction"] = float(np.mean(err < 1e-9))
    checks["fk_mean_assembly_modes"] = float(fk.count.mean())
    checks["fk_assembly_mode_histogram"] = {str(k): int(v) for k, v in zip(*np.unique(fk.count, return_counts=True),
                                                                               strict=True)}

    # (2) branch following along the paper's circle
    progress("branch following ...")

    def bf_api():
        q = q_ref[0]
        for k in range(1, n_steps + 1):
            q = kin.branch_following(model, q, path_thetas[k])
        return q

    times, q_last = time_runs(bf_api, cfg["repeats_path_api"])
    rows.append(rate_row("bf_api_per_call", f"branch following, API once per sample ({n_steps} steps)", times,
                         n_steps, "call"))

    # Same steps, every one from the exact previous configuration, in a single batched API call.
    q_prev_batch = np.ascontiguousarray(q_ref[:-1])
    times, _ = time_runs(lambda: kin.branch_following(model, q_prev_batch, path_thetas[1:]), cfg["repeats_batch"])
    rows.append(rate_row("bf_api_batched", f"branch following, batched API ({n_steps} steps)", times, n_steps,
                         "call"))

    q_path = np.empty((q_ref.shape[0], PAPER_KERNELS.N_COORDINATES))
    q_path[0] = coordinates_from_3rrr(model, q_ref[0])
    times, status = time_runs(lambda: follow_path_kernel(path_thetas, P_core, SINGULARITY_GUARD, q_path),
                              cfg["repeats_path_kernel"])
    rows.append(rate_row("bf_kernel_per_call", f"branch following, compiled kernel in njit loop ({n_steps} steps)",
                         times, n_steps, "call"))
    checks["bf_kernel_status"] = int(status)
    checks["bf_kernel_max_dev_from_ik_rad"] = float(np.abs(wrapped(coordinates_to_3rrr(q_path)[:, 3:]
                                                                   - q_ref[:, 3:])).max())
    checks["bf_api_max_dev_from_ik_rad"] = float(np.abs(wrapped(q_last[3:] - q_ref[-1, 3:])).max())

    # (3) inverse kinematics, all 8 working modes
    progress("inverse kinematics ...")
    times, _ = time_runs(lambda: kin.inverse_kinematics(model, poses, on_unreachable="nan"), cfg["repeats_batch"])
    rows.append(rate_row("ik_all_modes_batched", f"IK all 8 modes, batched API ({n} poses)", times, n, "pose",
                         compare=False))

    def ik_driver():
        q = np.empty((n, WORKING_MODES.shape[0], 7))
        unreachable = np.zeros((n, WORKING_MODES.shape[0]), dtype=np.int64)
        pk_kinematics._inverse_kinematics_batch(poses, WORKING_MODES, P, q, unreachable)

    times, _ = time_runs(ik_driver, cfg["repeats_batch"])
    rows.append(rate_row("ik_all_modes_batched_kernel", f"IK all 8 modes, compiled batch driver only ({n} poses)",
                         times, n, "pose", compare=False))

    # (4) baseline
    progress("baseline (NumPy + scipy.optimize.fsolve) ...")
    closure = NumpyLoopClosure(model)
    for fprime, key, label in ((True, "baseline_fsolve", "analytic Jacobian"),
                               (False, "baseline_fsolve_fd", "finite-difference Jacobian")):
        repeats = cfg["repeats_baseline"] if fprime else cfg["repeats_baseline_fd"]
        times, (out, failures) = time_runs(lambda fprime=fprime: baseline_path(closure, q_ref[0], path_thetas, fprime),
                                           repeats)
        rows.append(rate_row(key, f"baseline: NumPy + fsolve, {label} ({n_steps} steps)", times, n_steps, "solve"))
        checks[f"{key}_failures"] = int(failures)
        checks[f"{key}_max_dev_from_ik_rad"] = float(np.abs(wrapped(out - q_ref[:, 3:])).max())
        checks[f"{key}_max_residual"] = float(max(np.abs(closure.residual(x, closure.elbows(t))).max()
                                                  for x, t in zip(out, path_thetas, strict=True)))

    # (5) dynamics: the actuator-space model, forward dynamics, free motion of the plants
    rows.append(section_row("dynamics (working mode (-, +, -); vs baseline: NumPy Mθ, Cθθ̇)"))
    dyn_q, dyn_theta_dot, dyn_tau, dyn_min_abs_S = dynamics_states(model, poses[: cfg["n_dyn_batch"]], rng)
    n_dyn = dyn_q.shape[0]
    n_dyn_single = min(cfg["n_dyn_single"], n_dyn)
    checks["dyn_states_min_abs_S"] = dyn_min_abs_S

    progress("actuator-space model ...")
    m_kernel = np.empty((n_dyn, 3, 3))
    c_kernel = np.empty((n_dyn, 3))
    dyn_q_core = np.ascontiguousarray(coordinates_from_3rrr(model, dyn_q))
    times, kernel_ok = time_runs(lambda: actuator_space_kernel_loop(dyn_q_core, dyn_theta_dot, P_core, m_kernel,
                                                                    c_kernel), cfg["repeats_dyn_kernel"])
    rows.append(rate_row("dyn_model_kernel", f"Mθ, Cθθ̇: compiled kernel in njit loop ({n_dyn} states)", times, n_dyn,
                         "eval", baseline="numpy_dyn_batched"))
    checks["dyn_model_kernel_ok"] = bool(kernel_ok)
    times, (m_api, c_api) = time_runs(lambda: pk_dynamics.actuator_space_model(model, dyn_q, dyn_theta_dot),
                                      cfg["repeats_dyn_batch"])
    rows.append(rate_row("dyn_model_api_batched", f"Mθ, Cθθ̇: batched API ({n_dyn} states)", times, n_dyn, "eval",
                         baseline="numpy_dyn_batched"))

    def model_api_single():
        for k in range(n_dyn_single):
            pk_dynamics.actuator_space_model(model, dyn_q[k], dyn_theta_dot[k])

    times, _ = time_runs(model_api_single, cfg["repeats_dyn_single"])
    rows.append(rate_row("dyn_model_api_single", f"Mθ, Cθθ̇: API once per state ({n_dyn_single} states)", times,
                         n_dyn_single, "eval", baseline="numpy_dyn_single"))
    checks["dyn_model_kernel_vs_api_max_abs_diff"] = float(max(np.abs(m_kernel - m_api).max(),
                                                               np.abs(c_kernel - c_api).max()))

    progress("baseline (NumPy Mθ, Cθθ̇) ...")
    numpy_model = NumpyActuatorSpaceModel(model)
    times, (m_base, c_base) = time_runs(lambda: numpy_model(dyn_q, dyn_theta_dot), cfg["repeats_dyn_baseline"])
    rows.append(rate_row("baseline_numpy_dyn_batched", f"baseline: NumPy Mθ, Cθθ̇, vectorized ({n_dyn} states)",
                         times, n_dyn, "eval", baseline="numpy_dyn_batched"))
    n_base_single = min(cfg["n_dyn_baseline_single"], n_dyn)
    times, (m_base1, c_base1) = time_runs(
        lambda: baseline_dynamics_per_state(numpy_model, dyn_q[:n_base_single], dyn_theta_dot[:n_base_single]),
        cfg["repeats_dyn_baseline"])
    rows.append(rate_row("baseline_numpy_dyn_single", f"baseline: NumPy Mθ, Cθθ̇, once per state ({n_base_single} "
                         "states)", times, n_base_single, "eval", baseline="numpy_dyn_single"))
    m_scale, c_scale = float(np.abs(m_api).max()), float(np.abs(c_api).max())
    diff_m = float(max(np.abs(m_base - m_api).max(), np.abs(m_base1 - m_api[:n_base_single]).max()))
    diff_c = float(max(np.abs(c_base - c_api).max(), np.abs(c_base1 - c_api[:n_base_single]).max()))
    checks["dyn_baseline_max_abs_diff_m_theta"] = diff_m
    checks["dyn_baseline_max_abs_diff_c_theta"] = diff_c
    checks["dyn_baseline_max_abs_m_theta"] = m_scale
    checks["dyn_baseline_max_abs_c_theta"] = c_scale
    checks["dyn_baseline_max_rel_diff"] = max(diff_m / m_scale, diff_c / c_scale)
    checks["dyn_baseline_agrees_to_rtol"] = checks["dyn_baseline_max_rel_diff"] <= DYN_BASELINE_RTOL

    progress("forward dynamics ...")
    circle_theta_dot = rng.normal(0.0, THETA_DOT_STD, (CIRCLE_SAMPLES, 3))
    circle_tau = rng.normal(0.0, TAU_STD, (CIRCLE_SAMPLES, 3))
    fd_kernel = np.empty((n_steps, 3))
    q_steps = np.ascontiguousarray(coordinates_from_3rrr(model, q_ref[1:]))
    times, fd_ok = time_runs(lambda: forward_dynamics_kernel_loop(q_steps, circle_theta_dot[1:], circle_tau[1:], P_core,
                                                                  fd_kernel), cfg["repeats_dyn_kernel"])
    rows.append(rate_row("fd_kernel", f"forward dynamics: compiled kernel in njit loop ({n_steps} circle states)",
                         times, n_steps, "call", compare=False))
    checks["fd_kernel_ok"] = bool(fd_ok)
    q_fd_path = np.empty((q_ref.shape[0], q_steps.shape[1]))
    q_fd_path[0] = coordinates_from_3rrr(model, q_ref[0])
    fd_bf = np.zeros((CIRCLE_SAMPLES, 3))
    times, fd_bf_status = time_runs(
        lambda: follow_and_forward_dynamics_kernel_loop(path_thetas, circle_theta_dot, circle_tau, P_core,
                                                        SINGULARITY_GUARD, q_fd_path, fd_bf),
        cfg["repeats_dyn_kernel"])
    rows.append(rate_row("fd_bf_kernel", f"forward dynamics + branch following, kernels in njit loop ({n_steps} "
                         "steps)", times, n_steps, "step", compare=False))
    checks["fd_bf_kernel_status"] = int(fd_bf_status)
    checks["fd_bf_max_dev_from_ik_rad"] = float(np.abs(wrapped(coordinates_to_3rrr(q_fd_path)[:, 3:]
                                                               - q_ref[:, 3:])).max())
    checks["fd_bf_vs_fd_at_ik_max_abs_diff"] = float(np.abs(fd_bf[1:] - fd_kernel).max())

    def fd_api_single():
        for k in range(1, n_steps + 1):
            pk_dynamics.forward_dynamics(model, q_ref[k], circle_theta_dot[k], circle_tau[k])

    times, _ = time_runs(fd_api_single, cfg["repeats_dyn_single"])
    rows.append(rate_row("fd_api_single", f"forward dynamics: API once per state ({n_steps} circle states)", times,
                         n_steps, "call", compare=False))
    times, fd_api = time_runs(lambda: pk_dynamics.forward_dynamics(model, dyn_q, dyn_theta_dot, dyn_tau),
                              cfg["repeats_dyn_batch"])
    rows.append(rate_row("fd_api_batched", f"forward dynamics: batched API ({n_dyn} states)", times, n_dyn, "call",
                         compare=False))
    # θ̈ must satisfy eq. (35): Mθ θ̈ + Cθ θ̇ = τ
    checks["fd_api_eq35_max_abs_residual"] = float(np.abs(np.einsum("nij,nj->ni", m_api, fd_api) + c_api
                                                          - dyn_tau).max())

    progress("free motion of the plants ...")
    t_eval = np.linspace(0.0, FREE_MOTION_SECONDS, FREE_MOTION_SAMPLES)
    q_dot_free = kin.coordinate_rates(model, q_free, theta_dot_free)
    reduced_plant, full_plant = ReducedPlant(model), FullPlant(model)
    plant_runs = {}
    for key, label, plant, rate in (("reduced", "ReducedPlant", reduced_plant, theta_dot_free),
                                    ("full", "FullPlant", full_plant, q_dot_free)):
        times, run = time_runs(lambda plant=plant, rate=rate: plant.simulate(q_free, rate, zero3, FREE_MOTION_SECONDS,
                                                                            t_eval=t_eval), cfg["repeats_plant"])
        plant_runs[key] = run
        label = f"free motion {FREE_MOTION_SECONDS:g} s, {label}"
        rows.append(rate_row(f"plant_{key}_wall", f"{label}: wall time", times, 1, "run", compare=False))
        rows[-1]["us_per_rhs_evaluation"] = rows[-1]["median_us_per_op"] / run.n_evaluations
        rows.append(metric_row(f"plant_{key}_rhs_evaluations", f"{label}: RHS evaluations", int(run.n_evaluations),
                               "evals"))
        rows.append(metric_row(f"plant_{key}_max_closure_violation", f"{label}: max closure violation",
                               float(run.closure_violation.max()), "m"))
        rows.append(metric_row(f"plant_{key}_energy_drift", f"{label}: relative kinetic-energy drift",
                               relative_kinetic_energy_drift(model, run), "max|T-T0|/T0"))
    rows.append(metric_row("plant_reduced_vs_full_max_theta_diff",
                           f"free motion {FREE_MOTION_SECONDS:g} s: max |θ_reduced - θ_full|",
                           float(np.abs(plant_runs["reduced"].theta - plant_runs["full"].theta).max()), "rad"))
    checks["plant_initial_kinetic_energy_J"] = float(pk_dynamics.kinetic_energy(model, q_free, q_dot_free))

    progress("closed-loop simulation: nominal case, NumPy/SciPy path, MuJoCo, batch, integrator, limits, growth")
    import simulation_bench

    sim_rows, sim_checks = simulation_bench.simulation_rows(sys.modules[__name__], args.quick)
    rows += sim_rows
    checks["simulation"] = sim_checks

    progress("every mechanism: forward kinematics, dynamics, default runs")
    import mechanism_bench

    paper_loop = next((r for r in rows if r.get("key") == "sim_nominal_loop"), None)
    per_sample = paper_loop["us_per_sample"] * 1e-6 if paper_loop else None
    mech_rows, mech_checks = mechanism_bench.mechanism_rows(sys.modules[__name__], args.quick, per_sample,
                                                            sim_checks.get("operation_counts"),
                                                            sim_checks.get("scalar_speed"))
    rows += mech_rows
    checks["mechanisms"] = mech_checks

    progress("two plants: pkmlab's and MuJoCo's, accuracy against speed")
    import mujoco_frontier

    frontier_rows, frontier_checks = mujoco_frontier.frontier_rows(sys.modules[__name__], args.quick)
    rows += frontier_rows
    checks["plants_frontier"] = frontier_checks
    mujoco_plant, checks["mujoco_plant"] = mujoco_frontier.plant_rows(sys.modules[__name__], args.quick)
    rows += mujoco_plant

    progress("a study of 2,000 runs: in-process and on Dask")
    import study_bench

    study_rows, study_checks = study_bench.study_rows(sys.modules[__name__], args.quick)
    rows += study_rows
    checks["study"] = study_checks

    progress("memory of a long run against its length")
    import memory_bench

    memory, checks["memory"] = memory_bench.memory_rows(sys.modules[__name__], args.quick)
    rows += memory

    progress("start-up of the command line")
    import startup_bench

    startup, checks["startup_ms"] = startup_bench.startup_rows(sys.modules[__name__], args.quick)
    rows += startup
    if not args.quick:
        progress("first start from an empty kernel cache")
        cold, checks["cold_start_s"] = startup_bench.cold_rows(sys.modules[__name__])
        rows += cold

    for row in rows:
        if row["kind"] == "per_op" and row["key"] == BASELINES.get(row["baseline"]):
            row["is_baseline_reference"] = True
    for row in rows:
        if row.get("compare_to_baseline"):
            reference = next(r for r in rows if r.get("key") == BASELINES[row["baseline"]])
            row["speedup_vs_baseline"] = reference["median_us_per_op"] / row["median_us_per_op"]

    total = time.perf_counter() - t_start
    table = format_table(rows)
    print(table)
    first = sum(r["median_s"] for r in rows if r["kind"] == "first_call")
    print(f"{mode} run, {total:.1f} s in all ({first:.1f} s of first calls); compile cache {cache_state['state']}; "
          f"{machine_info()['cpu_count']} CPUs; numba {numba.__version__}, numpy {np.__version__}")
    print("vs baseline, kinematics: the fsolve baseline's time per solve / this row's. The baseline is a "
          "single-solution Newton-type solve (fsolve) started next to the answer;\nforward_kinematics finds every "
          "assembly mode, so only the branch-following rows are like for like.")
    print("vs baseline, dynamics: the NumPy (Mθ, Cθθ̇) baseline's time per state / this row's; rows called once per "
          "state against the baseline called once per state,\nbatched rows and compiled loops against the baseline "
          f"vectorized over the batch. Baseline vs pkmlab: max relative difference "
          f"{checks['dyn_baseline_max_rel_diff']:.1e} (required <= {DYN_BASELINE_RTOL:.0e}).")
    noisy = [r["key"] for r in rows if r["kind"] == "per_op" and r["max_s"] > 1.5 * r["min_s"]]
    if noisy:
        print(f"noisy (slowest repeat > 1.5x fastest; is the machine busy?): {', '.join(noisy)}")
    for key, value in checks.items():
        if key.endswith("failures") and value:
            print(f"WARNING: {key} = {value}")
    if checks["bf_kernel_status"] != rrr3.OK:
        print(f"WARNING: branch following along the circle returned status {checks['bf_kernel_status']}")
    if checks["fd_bf_kernel_status"] != rrr3.OK:
        print(f"WARNING: branch following with forward dynamics returned status {checks['fd_bf_kernel_status']}")
    for key in ("dyn_model_kernel_ok", "fd_kernel_ok", "dyn_baseline_agrees_to_rtol"):
        if not checks[key]:
            print(f"WARNING: {key} is False")

    payload = {
        "schema": 1,
        "mode": mode,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "total_seconds": total,
        "machine": machine_info(),
        "compile_cache": cache_state,
        "settings": {
            **cfg,
            "seed": SEED,
            "pose_centre": POSE_CENTRE,
            "pose_radius": POSE_RADIUS,
            "alpha_half_range": ALPHA_HALF_RANGE,
            "poses_drawn": drawn,
            "reachable_fraction": n_reachable / drawn,
            "circle_centre": CIRCLE_CENTRE,
            "circle_radius": CIRCLE_RADIUS,
            "circle_samples": CIRCLE_SAMPLES,
            "circle_mode": CIRCLE_MODE,
            "singularity_guard": SINGULARITY_GUARD,
            "baseline_xtol": BASELINE_XTOL,
            "dyn_mode": DYN_MODE,
            "dyn_states": "the first n_dyn_batch random poses above, inverse kinematics in dyn_mode",
            "theta_dot_std": THETA_DOT_STD,
            "tau_std": TAU_STD,
            "dyn_baseline_rtol": DYN_BASELINE_RTOL,
            "free_motion_pose": FREE_MOTION_POSE,
            "free_motion_theta_dot": FREE_MOTION_THETA_DOT,
            "free_motion_seconds": FREE_MOTION_SECONDS,
            "free_motion_samples": FREE_MOTION_SAMPLES,
            "free_motion_plants": {
                "reduced": {"rtol": reduced_plant.rtol, "atol": reduced_plant.atol,
                            "singularity_guard": reduced_plant.singularity_guard},
                "full": {"rtol": full_plant.rtol, "atol": full_plant.atol,
                         "stabilization": full_plant.stabilization},
            },
            "timer": "time.perf_counter, median of repeats after one warm-up call, gc disabled while timing",
        },
        "baseline_note": (
            "scipy.optimize.fsolve (MINPACK hybrj) on the 4 loop-closure equations in plain NumPy: a SINGLE-solution "
            "Newton-type solve from the previous path sample, not an all-solution forward kinematics. "
            "speedup_vs_baseline = baseline us/solve / row us/op."
        ),
        "dynamics_baseline_note": (
            "(M_theta, C_theta theta_dot) of eq. (35) in plain NumPy (body Jacobians, M, J_q_theta by "
            "np.linalg.solve), vectorized over a batch axis: baseline_numpy_dyn_single calls it once per state and is "
            "the reference of rows with baseline 'numpy_dyn_single'; baseline_numpy_dyn_batched calls it once for all "
            "states and is the reference of rows with baseline 'numpy_dyn_batched'. speedup_vs_baseline = baseline "
            "us/eval / row us/eval. Agreement with pkmlab: checks.dyn_baseline_*."
        ),
        "checks": checks,
        "results": {row["key"]: row for row in rows if row["kind"] != "section"},
    }
    write_json_atomic(args.output, payload)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
