"""Start-up of the command line: whole processes, warm caches, against bare imports measured in the same run.

* ``pkmlab ik 0.2 0.21 0`` against ``python -c "import numpy"``: a one-shot command runs its kernels
  interpreted (:mod:`pkmlab._compile_cache`), so it pays for NumPy and pkmlab's own modules only;
* ``pkmlab reproduce --no-figures`` against ``python -c "import numpy, scipy.integrate, numba"``: the paper's
  three cases, compiled kernels loaded from the cache, every file written.

Each figure is the median of several processes started one after the other, after one unmeasured start
(the operating system's file cache warm, pkmlab's kernels compiled).
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PYTHON = sys.executable
PKMLAB = str(Path(sys.executable).with_name("pkmlab"))


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
