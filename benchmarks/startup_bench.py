"""Start-up of the command line: whole processes, warm caches, against bare imports measured in the same run.

* ``pkmlab ik 0.2 0.21 0`` against ``python -c "import numpy"``: a one-shot command runs its kernels
  interpreted (:mod:`pkmlab._compile_cache`), so it pays for NumPy and pkmlab's own modules only;
* ``pkmlab reproduce --no-figures`` against ``python -c "import numpy, scipy.integrate, numba"``: the paper's
  three cases, compiled kernels loaded from the cache, every file written.

Each figure is the median of several processes started one after the other, after one unmeasured start
(the operating system's file cache warm, pkmlab's kernels compiled).

And the first start, each process with an empty kernel cache of its own (:func:`cold_rows`): the paper's
reproduction, a preset's first run (the Delta's pick-and-place) and a new structure's first run (the
catalogue's 6-RUS: its derivation, then its compilation) — what a user waits for on a fresh install.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PYTHON = sys.executable
PKMLAB = str(Path(sys.executable).with_name("pkmlab"))
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _process_seconds(command: list[str], repeats: int, fresh_dir: bool = False) -> float:
    """Median wall time of ``command`` as a new process (``{out}`` in it replaced by a new folder each time)."""
    times = []
    for i in range(repeats + 1):
        with tempfile.TemporaryDirectory() as tmp:
            argv = [a.replace("{out}", str(Path(tmp) / "out")) for a in command] if fresh_dir else command
            start = time.perf_counter()
            subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            if i > 0:  # the first start warms the caches
                times.append(time.perf_counter() - start)
    return statistics.median(times)


def startup_rows(h, quick: bool) -> tuple[list[dict], dict]:
    repeats = 3 if quick else 7
    figures = {
        "import_numpy": _process_seconds([PYTHON, "-c", "import numpy"], repeats),
        "ik": _process_seconds([PKMLAB, "ik", "0.2", "0.21", "0"], repeats),
        "import_numpy_scipy_numba": _process_seconds([PYTHON, "-c", "import numpy, scipy.integrate, numba"], repeats),
        "reproduce": _process_seconds([PKMLAB, "reproduce", "--no-figures", "--out", "{out}"], repeats,
                                      fresh_dir=True),
    }
    rows = [h.section_row("start-up of the command line (whole processes, warm caches)"),
            h.metric_row("startup_import_numpy", "python -c 'import numpy' (baseline)", figures["import_numpy"] * 1e3,
                         "ms"),
            h.metric_row("startup_ik", "pkmlab ik 0.2 0.21 0", figures["ik"] * 1e3, "ms"),
            h.metric_row("startup_ik_ratio", "ratio: pkmlab ik / import numpy",
                         figures["ik"] / figures["import_numpy"], "x"),
            h.metric_row("startup_import_numpy_scipy_numba", "python -c 'import numpy, scipy.integrate, numba' "
                         "(baseline)", figures["import_numpy_scipy_numba"] * 1e3, "ms"),
            h.metric_row("startup_reproduce", "pkmlab reproduce --no-figures", figures["reproduce"] * 1e3, "ms"),
            h.metric_row("startup_reproduce_ratio", "ratio: pkmlab reproduce --no-figures / import numpy, "
                         "scipy.integrate, numba", figures["reproduce"] / figures["import_numpy_scipy_numba"], "x")]
    return rows, {k: v * 1e3 for k, v in figures.items()}


def _cold_seconds(command: list[str]) -> float:
    """Wall time of ``command`` as a new process whose kernel cache is a new, empty folder (``{out}`` in it
    replaced by a new folder): everything it runs is compiled, a new structure derived too."""
    with tempfile.TemporaryDirectory() as tmp:
        argv = [a.replace("{out}", str(Path(tmp) / "out")) for a in command]
        env = {**os.environ, "PKMLAB_CACHE_DIR": str(Path(tmp) / "cache")}
        env.pop("NUMBA_CACHE_DIR", None)
        start = time.perf_counter()
        done = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
        seconds = time.perf_counter() - start
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(command)} failed from an empty kernel cache: {done.stderr.strip()}")
        return seconds


def cold_rows(h) -> tuple[list[dict], dict]:
    """The first start of three commands, each from an empty kernel cache (module docstring); one run each."""
    run = "import pkmlab; pkmlab.simulate(pkmlab.load_scenario({!r}))"
    figures = {
        "reproduce": _cold_seconds([PKMLAB, "reproduce", "--no-figures", "--out", "{out}"]),
        "simulate_delta": _cold_seconds([PYTHON, "-c", run.format(str(EXAMPLES / "delta_pick_and_place.toml"))]),
        "simulate_new_structure": _cold_seconds([PYTHON, "-c", run.format(str(EXAMPLES / "mechanisms" /
                                                                             "6rus_motion.toml"))]),
    }
    rows = [h.section_row("first start from an empty kernel cache (whole processes, one each)"),
            h.metric_row("cold_reproduce", "pkmlab reproduce --no-figures, empty cache", figures["reproduce"], "s"),
            h.metric_row("cold_simulate_delta", "a preset's first run: the Delta's pick-and-place, empty cache",
                         figures["simulate_delta"], "s"),
            h.metric_row("cold_simulate_new_structure", "a new structure's first run (derived, compiled): the "
                         "6-RUS's default scenario, empty cache", figures["simulate_new_structure"], "s")]
    return rows, figures
