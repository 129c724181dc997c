"""Benchmarks of pkmlab's kinematics on the paper's 3-RRR (``make bench``).

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
  sample, and the compiled kernel :func:`pkmlab.mechanisms.rrr3.branch_following` called
  from a small ``@numba.njit`` loop (no Python overhead per call);
* inverse kinematics, all 8 working modes, batched;
* a baseline measured in the same run: ``scipy.optimize.fsolve`` on the loop-closure
  equations written in plain NumPy. The "vs fsolve" column is the baseline's time per solve
  divided by the row's time per solve.

Usage::

    .venv/bin/python benchmarks/run.py            # full run (about 20 s + any compilation)
    .venv/bin/python benchmarks/run.py --quick    # smoke test

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
from pkmlab import WORKING_MODES
from pkmlab import kinematics as pk_kinematics
from pkmlab.mechanisms import rrr3

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
MIN_ABS_S = 1e-6  # pkmlab.branch_following's default

BASELINE_XTOL = 1e-12  # relative step tolerance handed to fsolve (its default is 1.49e-8)

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


def rate_row(key: str, name: str, times: list[float], ops: int, op: str, compare: bool = True) -> dict:
    """A row whose figure is the time per operation (``ops`` operations per timed run)."""
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
    }


def first_call_row(key: str, name: str, seconds: float) -> dict:
    return {"key": key, "name": name, "kind": "first_call", "repeats": 1, "times_s": [seconds], "median_s": seconds}


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
def reachable_samples(model: pkmlab.Planar3RRR, n: int, rng: np.random.Generator):
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
        ik = pkmlab.inverse_kinematics(model, batch, on_unreachable="nan")
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


def circle_path(model: pkmlab.Planar3RRR):
    s = np.linspace(0.0, 2.0 * np.pi, CIRCLE_SAMPLES)
    path = np.column_stack([
        CIRCLE_CENTRE[0] + CIRCLE_RADIUS * np.cos(s),
        CIRCLE_CENTRE[1] + CIRCLE_RADIUS * np.sin(s),
        np.zeros_like(s),
    ])
    ik = pkmlab.inverse_kinematics(model, path, mode=CIRCLE_MODE)
    return path, np.ascontiguousarray(ik.q), np.ascontiguousarray(ik.theta)


@numba.njit(cache=False)
def follow_path_kernel(thetas, P, min_abs_s, q_path):
    """Branch following along ``thetas`` from ``q_path[0]``: one compiled kernel call per sample."""
    status = 0
    for k in range(1, thetas.shape[0]):
        status |= rrr3.branch_following(q_path[k - 1], thetas[k], P, q_path[k], min_abs_s)
    return status


def wrapped(x: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * x))


# ------------------------------------------------------------------ baseline: NumPy + scipy.optimize.fsolve
# BASELINE: a SINGLE-SOLUTION Newton-type solve (MINPACK's hybrj, Powell's hybrid method, as
# wrapped by scipy.optimize.fsolve) of the four loop-closure equations η(θ, φ) = 0 for
# φ = (φ1, φ2, φ3, α), written in plain NumPy with the analytic Jacobian. Started from the known
# solution perturbed -- namely the solution at the previous sample of the path, exactly what
# branch following starts from -- it returns the ONE assembly mode nearest the guess. It is
# therefore the like-for-like reference for branch following; pkmlab.forward_kinematics finds
# ALL assembly modes (up to six), so its ratio against this baseline is indicative only.
class NumpyLoopClosure:
    """η(θ, φ) = 0 of the 3-RRR (same equations and order as pkmlab.mechanisms.rrr3.constraints)."""

    def __init__(self, model: pkmlab.Planar3RRR):
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


def format_table(rows: list[dict]) -> str:
    mu = micro()
    header = ("benchmark", "median", "unit", "rate", "vs fsolve")
    lines = []
    for row in rows:
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
    widths = [max(len(str(r[i])) for r in [header, *lines]) for i in range(len(header))]
    align = ["<", ">", "<", ">", ">"]

    def fmt(r):
        return "  ".join(f"{str(v):{a}{w}}" for v, a, w in zip(r, align, widths, strict=True)).rstrip()

    rule = "-" * len(fmt(header))
    return "\n".join([fmt(header), rule, *(fmt(r) for r in lines), rule])


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
    model = pkmlab.Planar3RRR.paper()
    P = model.packed
    rows: list[dict] = []
    checks: dict = {}

    # -- first calls: compilation or cache load, one row each, before anything else runs
    progress("first calls (compile or cache load) ...")
    files_before = cache_files()
    probe_pose = np.array([CIRCLE_CENTRE[0] + CIRCLE_RADIUS, CIRCLE_CENTRE[1], 0.0])
    dt, ik1 = time_once(lambda: pkmlab.inverse_kinematics(model, probe_pose))
    rows.append(first_call_row("first_call_inverse_kinematics", "first call: inverse_kinematics", dt))
    q1, th1 = ik1.q[0], ik1.theta[0]
    dt, _ = time_once(lambda: pkmlab.forward_kinematics(model, th1))
    rows.append(first_call_row("first_call_forward_kinematics", "first call: forward_kinematics", dt))
    dt, _ = time_once(lambda: pkmlab.branch_following(model, q1, th1 + 1e-3))
    rows.append(first_call_row("first_call_branch_following", "first call: branch_following", dt))
    files_after = cache_files()
    scratch = np.tile(q1, (2, 1))
    dt, _ = time_once(lambda: follow_path_kernel(np.tile(th1, (2, 1)), P, MIN_ABS_S, scratch))
    rows.append(first_call_row("first_call_benchmark_njit_loop", "first call: benchmark's njit loop (compile)", dt))
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
    times, fk = time_runs(lambda: pkmlab.forward_kinematics(model, thetas), cfg["repeats_batch"])
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
            pkmlab.forward_kinematics(model, theta)

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
            q = pkmlab.branch_following(model, q, path_thetas[k])
        return q

    times, q_last = time_runs(bf_api, cfg["repeats_path_api"])
    rows.append(rate_row("bf_api_per_call", f"branch following, API once per sample ({n_steps} steps)", times,
                         n_steps, "call"))

    # Same steps, every one from the exact previous configuration, in a single batched API call.
    q_prev_batch = np.ascontiguousarray(q_ref[:-1])
    times, _ = time_runs(lambda: pkmlab.branch_following(model, q_prev_batch, path_thetas[1:]), cfg["repeats_batch"])
    rows.append(rate_row("bf_api_batched", f"branch following, batched API ({n_steps} steps)", times, n_steps,
                         "call"))

    q_path = np.empty_like(q_ref)
    q_path[0] = q_ref[0]
    times, status = time_runs(lambda: follow_path_kernel(path_thetas, P, MIN_ABS_S, q_path),
                              cfg["repeats_path_kernel"])
    rows.append(rate_row("bf_kernel_per_call", f"branch following, compiled kernel in njit loop ({n_steps} steps)",
                         times, n_steps, "call"))
    checks["bf_kernel_status"] = int(status)
    checks["bf_kernel_max_dev_from_ik_rad"] = float(np.abs(wrapped(q_path[:, 3:] - q_ref[:, 3:])).max())
    checks["bf_api_max_dev_from_ik_rad"] = float(np.abs(wrapped(q_last[3:] - q_ref[-1, 3:])).max())

    # (3) inverse kinematics, all 8 working modes
    progress("inverse kinematics ...")
    times, _ = time_runs(lambda: pkmlab.inverse_kinematics(model, poses, on_unreachable="nan"), cfg["repeats_batch"])
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

    reference_row = next(r for r in rows if r["key"] == "baseline_fsolve")
    reference_row["is_baseline_reference"] = True
    reference = reference_row["median_us_per_op"]
    for row in rows:
        if row.get("compare_to_baseline"):
            row["speedup_vs_baseline"] = reference / row["median_us_per_op"]

    total = time.perf_counter() - t_start
    table = format_table(rows)
    print(table)
    first = sum(r["median_s"] for r in rows if r["kind"] == "first_call")
    print(f"{mode} run, {total:.1f} s in all ({first:.1f} s of first calls); compile cache {cache_state['state']}; "
          f"{machine_info()['cpu_count']} CPUs; numba {numba.__version__}, numpy {np.__version__}")
    print("vs fsolve: the baseline's time per solve / this row's. The baseline is a single-solution Newton-type "
          "solve (fsolve) started next to the answer;\nforward_kinematics finds every assembly mode, so only the "
          "branch-following rows are like for like.")
    noisy = [r["key"] for r in rows if r["kind"] == "per_op" and r["max_s"] > 1.5 * r["min_s"]]
    if noisy:
        print(f"noisy (slowest repeat > 1.5x fastest; is the machine busy?): {', '.join(noisy)}")
    for key, value in checks.items():
        if key.endswith("failures") and value:
            print(f"WARNING: {key} = {value}")
    if checks["bf_kernel_status"] != rrr3.OK:
        print(f"WARNING: branch following along the circle returned status {checks['bf_kernel_status']}")

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
            "min_abs_S": MIN_ABS_S,
            "baseline_xtol": BASELINE_XTOL,
            "timer": "time.perf_counter, median of repeats after one warm-up call, gc disabled while timing",
        },
        "baseline_note": (
            "scipy.optimize.fsolve (MINPACK hybrj) on the 4 loop-closure equations in plain NumPy: a SINGLE-solution "
            "Newton-type solve from the previous path sample, not an all-solution forward kinematics. "
            "speedup_vs_baseline = baseline us/solve / row us/op."
        ),
        "checks": checks,
        "results": {row["key"]: row for row in rows},
    }
    write_json_atomic(args.output, payload)
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
