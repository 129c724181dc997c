"""A machine's compiled loop compiled ahead, in a second process, while this one prepares its first run.

From an empty kernel cache, a machine's first sampled-data run spends most of its time compiling: its run's
preparation (the desired motion's kinematics, the checks along the path) and then the loop over its samples
(:func:`~pkmlab.codegen.core.loop.sampled_data_chunk` and everything under it, about half). The two are
independent, so :func:`compile_loop_ahead` starts a second Python process that compiles the loop — by calling
it on a run of no samples, with arguments of the types :func:`~pkmlab.simulation.run.simulate` gives it — while
this process prepares the run on the other core. The kernel cache's compile locks
(:func:`pkmlab._compile_cache.cache_lock`) do the rest: a function the two reach at once is compiled by one and
loaded by the other, and the run's call of the loop waits for the second process's compile, then loads it.

Only where it pays: the loop of this machine structure neither compiled in this process nor in the cache,
compiled kernels (not ``PKMLAB_INTERPRETED=1``), a second core, a system with the cache's locks, and not switched off by
``PKMLAB_COMPILE_AHEAD=0`` (the test suite's workers, which share the cores already). The second process is
ended if it still runs when this one exits.
"""

from __future__ import annotations

import atexit
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np

from .. import _compile_cache
from ..model.mechanism_model import MechanismModel

#: Environment variable: ``0`` switches compiling ahead off.
SWITCH = "PKMLAB_COMPILE_AHEAD"

#: The second processes started, by the name of the kernel module whose loop each compiles.
_STARTED: dict[str, subprocess.Popen] = {}


def loop_is_compiled(model: MechanismModel) -> bool:
    """Whether the loop of ``model``'s structure is compiled in this process or saved in the kernel cache (Numba
    names a function's index file after its module's last name and its own)."""
    kernels = model.kernels
    if kernels.sampled_data_chunk.signatures:
        return True
    stem = kernels.__name__.rsplit(".", 1)[-1]
    return any(_compile_cache.CACHE_DIR.rglob(f"{stem}.sampled_data_chunk-*.nbi"))


def available_cores() -> int:
    """The cores this process may run on (its affinity, where the system says it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # (macOS, Windows)
        return os.cpu_count() or 1


def compile_loop_ahead(model: MechanismModel) -> subprocess.Popen | None:
    """Start compiling the sampled-data loop of ``model``'s structure in a second process (module docstring);
    returns that process, or None where it is not started (compiled already, started already, switched off)."""
    if (_compile_cache.INTERPRETED or _compile_cache.fcntl is None or os.environ.get(SWITCH) == "0"
            or available_cores() < 2 or model.kernels.__name__ in _STARTED or loop_is_compiled(model)):
        return None
    try:
        description = pickle.dumps(model.description)
    except (pickle.PicklingError, TypeError, AttributeError):  # (a description holding what cannot be sent)
        return None
    package_root = str(Path(__file__).resolve().parents[2])  # this pkmlab, whatever the second process's path
    env = {**os.environ, SWITCH: "0",
           "PYTHONPATH": os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH")) if p)}
    try:
        process = subprocess.Popen([sys.executable, "-m", __name__], stdin=subprocess.PIPE,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
        with process.stdin:
            process.stdin.write(description)
    except OSError:  # no process to be had, or it ended at once: this process compiles the loop as it would
        return None
    _STARTED[model.kernels.__name__] = process
    if len(_STARTED) == 1:
        atexit.register(_end_started)
    return process


def _end_started() -> None:
    """End the second processes still compiling as this process exits (their work is of no use to it now)."""
    for process in _STARTED.values():
        if process.poll() is None:
            process.kill()
            process.wait()


def compile_loop(model: MechanismModel) -> None:
    """Compile the sampled-data loop of ``model``'s structure: :func:`~pkmlab.codegen.core.loop.sampled_data_chunk`
    called on a run of no samples, each argument of the type :func:`~pkmlab.simulation.run.simulate` passes (a
    test holds the two to one compiled signature)."""
    k_ = model.kernels
    n, n_x, n_q = model.n_actuators, k_.N_INDEPENDENT, k_.N_COORDINATES
    q, P, none = np.zeros(n_q), np.asarray(model.P, dtype=float), np.zeros((0, n))
    rows = np.zeros((0, n_x))  # the desired motion: no samples
    k_.sampled_data_chunk(k_.make_workspaces(2), np.zeros(2 * n_x), np.zeros((0, n)), 0, 0, 1e-3, 1, rows, rows,
                          rows, q, q, P, P, 0, 1.0, 1.0, np.zeros((0, n)), 0.0, k_.NO_DRIVES, k_.NO_DRIVES, none,
                          np.zeros(n), none, -1, 0, np.zeros((0, n_q)), np.zeros((0, n_x)), np.zeros((0, n)),
                          np.zeros(0), none)


def _main() -> None:
    from ..model.mechanism_model import load

    compile_loop(load(pickle.load(sys.stdin.buffer)))


if __name__ == "__main__":
    _main()
