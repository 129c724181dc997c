"""Peak memory of a long run against its length (rows of ``make bench``).

Each measurement is a fresh process (its peak resident set, ``ru_maxrss``, is the process's own): the paper's
circle slowed down so that the run has ``N`` samples at 1 ms, simulated, then written as CSV. Two lengths give
the cost per sample beyond the process's fixed base (the interpreter, NumPy, the loaded kernels): the slope
``(peak(N₂) − peak(N₁)) / (N₂ − N₁)``, of the run alone and of the run and its CSV. What it measures is what
``MAX_SAMPLES`` (:mod:`pkmlab.simulation.scenario`) is sized by.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

#: A run of about ``N`` samples: the circle of length 0.2π m at ``speed = 0.2π / (N · 1 ms)``.
PROGRAM = """
import json, resource, sys, math
import pkmlab
from pkmlab.control.trajectory import paper_trajectory
from pkmlab.formats.scenario import paper_scenario
samples, csv = int(sys.argv[1]), sys.argv[2]
scenario = paper_scenario("nominal")
speed = scenario.trajectory.duration * 0.2 / (samples * 1e-3)
scenario = scenario.replace(trajectory=paper_trajectory(speed))
result = pkmlab.simulate(scenario)
run = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
result.to_csv(csv)
total = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"samples": int(result.t.size), "run_bytes": run, "csv_bytes": total}))
"""


def _peak(samples: int) -> dict:
    with tempfile.TemporaryDirectory() as folder:
        out = subprocess.run([sys.executable, "-c", PROGRAM, str(samples), str(Path(folder) / "run.csv")],
                             capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def memory_rows(h, quick: bool) -> tuple[list[dict], dict]:
    # both runs several pieces long (SIMULATION_PIECE samples): the pieces' own buffers are part of the fixed base
    small, large = (_peak(n) for n in ((150_000, 600_000) if quick else (300_000, 2_000_000)))
    samples = large["samples"] - small["samples"]
    run = (large["run_bytes"] - small["run_bytes"]) / samples
    csv = (large["csv_bytes"] - small["csv_bytes"]) / samples
    rows = [h.section_row("memory of a long run (the paper's circle slowed down, a fresh process per length)"),
            h.metric_row("memory_run_per_sample", "peak memory per sample of a run beyond its base "
                         f"({small['samples']:,} and {large['samples']:,} samples)", run, "B"),
            h.metric_row("memory_run_and_csv_per_sample", "the same with the run written as CSV", csv, "B"),
            h.metric_row("memory_base", f"peak memory of the {small['samples']:,}-sample run's process",
                         small["run_bytes"] / 2**20, "MiB")]
    return rows, {"run_bytes_per_sample": run, "csv_bytes_per_sample": csv, "small": small, "large": large}
