"""Benchmark rows: a 2,000-run study on Dask (``pkmlab sweep``'s engine) against the same runs in-process.

The study is the paper's fast case crossed over 10 gains kp (100 to 10^4, log) and 5 speeds (0.2 to 0.6
m/s), each on 40 plants drawn with masses and inertias within ±15 % (2,000 runs, 520 to 1,571 samples
each). Measured in the same run, medians of ``repeats``:

* the baseline: every run in this process, one :func:`pkmlab.study.runs.run_chunk` call (its batches over
  both cores) — what the study costs without Dask;
* the study on a local cluster of 1 worker and of 2 workers (one core each), through
  :func:`pkmlab.study.sweep` without a folder: wall time and runs per second; the cluster's start is its
  own row (paid once per study);
* the scheduler's overhead per chunk: the time of 200 empty tasks through the same cluster, per task,
  and the study's own estimate (workers × wall − compute time, per chunk).

The tables of the three ways are checked equal (the study is deterministic).
"""

from __future__ import annotations

import logging
import statistics
import time
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _study(quick: bool):
    from pkmlab.study import Study

    return Study.create(EXAMPLES / "fast.toml",
                        grid={"controller.kp": {"start": 100.0, "stop": 1e4, "num": 10, "scale": "log"},
                              "trajectory.speed": {"start": 0.2, "stop": 0.6, "num": 5}},
                        uncertainty={"mass": 0.15, "inertia": 0.15}, draws=4 if quick else 40, seed=1,
                        name="bench_fast_2000")


def _nothing(x):
    return x


def study_rows(h, quick: bool) -> tuple[list[dict], dict]:
    """Rows ``study_*``: the 2,000-run study in-process, on 1 and 2 Dask workers, and the overhead per chunk."""
    import distributed

    from pkmlab.study import sweep
    from pkmlab.study.runs import run_chunk

    repeats = 1 if quick else 3
    study = _study(quick)
    runs = list(range(study.size))
    rows: list[dict] = [h.section_row(f"a study of {study.size} runs (the fast case: 10 kp x 5 speeds x "
                                      f"{study.draws} plants), in-process and on Dask")]
    checks: dict = {"runs": study.size}
    run_chunk(study, runs[:8])  # compile or load the kernels in this process
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        reference = run_chunk(study, runs)
        times.append(time.perf_counter() - t0)
    base = statistics.median(times)
    rows.append(h.metric_row("study_inprocess", f"{study.size} runs in this process, no Dask (baseline)", base, "s"))
    rows.append(h.metric_row("study_inprocess_rate", "  runs per second", study.size / base, "runs/s"))
    checks["inprocess_wall_s"] = base
    checks["failed_runs"] = sum(r["status"] != "ok" for r in reference)
    for workers in (1, 2):
        t0 = time.perf_counter()
        with distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                      dashboard_address=":0", silence_logs=logging.ERROR) as cluster, \
                distributed.Client(cluster) as client:
            start = time.perf_counter() - t0
            client.run(lambda: run_chunk(study, runs[:8]))  # every worker loads the kernels once
            walls, overheads, frames = [], [], []
            for _ in range(repeats):
                t0 = time.perf_counter()
                frame = sweep(study, client=client, figures=False)
                walls.append(time.perf_counter() - t0)
                overheads.append(frame.attrs["summary"]["execution"]["task_overhead_s"])
                frames.append(frame)
            t0 = time.perf_counter()
            client.gather(client.map(_nothing, range(200), pure=False))
            empty = (time.perf_counter() - t0) / 200
        wall = statistics.median(walls)
        same = all(f["max_path_error_m"].tolist() == [r["max_path_error_m"] for r in reference] for f in frames)
        checks[f"workers_{workers}"] = {"cluster_start_s": start, "wall_s": wall, "runs_per_s": study.size / wall,
                                        "empty_task_s": empty, "study_overhead_per_chunk_s": statistics.median(
                                            overheads), "chunks": frames[0].attrs["summary"]["execution"]["chunks"],
                                        "same_table_as_inprocess": same}
        rows.append(h.metric_row(f"study_dask{workers}_start", f"local cluster of {workers} worker"
                                 f"{'s' if workers > 1 else ''}: start", start, "s"))
        rows.append(h.metric_row(f"study_dask{workers}", f"  {study.size} runs (same table: {same})", wall, "s"))
        rows.append(h.metric_row(f"study_dask{workers}_rate", f"  runs per second ({base / wall:.2f}x the "
                                 "in-process rate)", study.size / wall, "runs/s"))
        rows.append(h.metric_row(f"study_dask{workers}_task", "  scheduler's overhead per task (200 empty tasks)",
                                 empty * 1e3, "ms"))
        rows.append(h.metric_row(f"study_dask{workers}_chunk_overhead", "  study's overhead per chunk (workers x "
                                 "wall - compute)", statistics.median(overheads) * 1e3, "ms"))
    return rows, checks
