"""A machine's compiled loop compiled ahead, in a second process, while this one prepares its first run.

From an empty kernel cache, a machine's first sampled-data run spends most of its time compiling: its run's
preparation (the desired motion's kinematics, the checks along the path) and then the loop over its samples
(:func:`~pkmlab.codegen.core.loop.sampled_data_chunk` and everything under it, most of it). The two are
independent, so :func:`compile_loop_ahead` starts a second Python process that compiles the loop — by calling
it on a run of no samples, with arguments of the types :func:`~pkmlab.simulation.run.simulate` gives it — while
this process prepares the run on the other core. The kernel cache's compile locks
(:func:`pkmlab._compile_cache.cache_lock`) do the rest: a function the two reach at once is compiled by one and
loaded by the other, and the run's call of the loop waits for the second process's compile, then loads it. While the
second process runs, a run prepared here compiles the loop's last part, the plant's stage, itself
(:func:`compile_plant_stage_meanwhile`).

Only where it pays: a sampled-data scenario whose structure's loop is neither compiled in this process nor in the
cache, compiled kernels (not ``PKMLAB_INTERPRETED=1``), a second core, a system with the cache's locks, and not
switched off by ``PKMLAB_COMPILE_AHEAD=0`` (the test suite's workers, which share the cores already). The second
process ends with this one however this one ends: it is ended at a normal exit or Ctrl-C, and ends itself when
the pipe this process holds open to it closes (the process killed).
"""

from __future__ import annotations

import atexit
import os
import pickle
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np

from .. import _compile_cache
from ..model.mechanism_model import MechanismModel

#: Environment variable: ``0`` switches compiling ahead off.
SWITCH = "PKMLAB_COMPILE_AHEAD"

#: The second processes started, by the name of the kernel module whose loop each compiles.
_STARTED: dict[str, subprocess.Popen] = {}


def loop_is_compiled(kernels_name: str) -> bool:
    """Whether the loop of the structure whose kernel module is ``kernels_name`` is compiled in this process or
    saved in the kernel cache."""
    kernels = sys.modules.get(kernels_name)
    return (kernels is not None and bool(kernels.sampled_data_chunk.signatures)) or _compile_cache.has_compiled(
        kernels_name, "sampled_data_chunk")


def available_cores() -> int:
    """The cores this process may run on (its affinity, where the system says it)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # (macOS, Windows)
        return os.cpu_count() or 1


def compile_loop_ahead(scenario) -> subprocess.Popen | None:
    """Start compiling the sampled-data loop of ``scenario``'s controller model in a second process
    (:func:`compile_loop_ahead_of`; the module's text); None for a continuous-time run."""
    if scenario.sample_time == 0:
        return None
    return compile_loop_ahead_of(scenario.model.description)


def compile_loop_ahead_of(description) -> subprocess.Popen | None:
    """Start compiling the sampled-data loop of ``description``'s structure in a second process (the module's
    text): from :func:`compile_loop_ahead`, or earlier, from a scenario file read before its machine's model is
    bound (:func:`~pkmlab.formats.scenario.load_scenario`: the model's assembly check compiles too).

    Parameters
    ----------
    description : Mechanism or SpatialMechanism
        The machine, checked or about to be: the second process binds it without checking it again — and
        derives its structure where it is new to this installation, while this process checks it (this one
        then waits for that derivation instead of making its own).

    Returns
    -------
    subprocess.Popen or None
        The second process; None where none is started: the loop compiled or cached already, a process started
        already for the structure, switched off (``PKMLAB_COMPILE_AHEAD=0``), an interpreted process, one core, no
        file locks, or no process to be had.
    """
    from ..model.mechanism_model import kernels_name

    for process in _STARTED.values():
        process.poll()  # (a finished one is reaped)
    if (_compile_cache.INTERPRETED or _compile_cache.fcntl is None or os.environ.get(SWITCH) == "0"
            or available_cores() < 2):
        return None
    name = kernels_name(description)
    if name in _STARTED or loop_is_compiled(name):
        return None
    try:
        sent = pickle.dumps(description)
    except (pickle.PicklingError, TypeError, AttributeError):  # (a description holding what cannot be sent)
        return None
    # -P: no current folder on the second process's path, which would import a pkmlab found there; this pkmlab's
    # folder is put first only where that process would not find it (this one's path changed at run time)
    root = str(Path(__file__).resolve().parents[2])
    start = ("import sys\nif sys.argv[1] not in sys.path:\n    sys.path.insert(0, sys.argv[1])\n"
             "from pkmlab.simulation.ahead import main\nmain()")
    try:
        process = subprocess.Popen([sys.executable, "-P", "-c", start, root], stdin=subprocess.PIPE,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                   env={**os.environ, SWITCH: "0"})
    except OSError:  # no process to be had: this one compiles the loop as it would
        return None
    try:  # the description; the pipe then stays open, and its end tells the second process that this one ended
        process.stdin.write(sent)
        process.stdin.flush()
    except OSError:  # (it ended at once)
        process.kill()
        process.wait()
        return None
    _STARTED[name] = process
    if len(_STARTED) == 1:
        atexit.register(_end_started)
    return process


def end_compiling_ahead(process: subprocess.Popen | None) -> None:
    """End a second process :func:`compile_loop_ahead_of` started for a machine then refused (its assembly check):
    its work would be of no use, and a structure new to the installation would be derived for nothing."""
    if process is None:
        return
    if process.poll() is None:
        process.kill()
        process.wait()
    for name in [name for name, started in _STARTED.items() if started is process]:
        del _STARTED[name]


def _end_started() -> None:
    """End the second processes still compiling as this process exits (their work is of no use to it now)."""
    for process in _STARTED.values():
        if process.poll() is None:
            process.kill()
            process.wait()


def compile_loop(model: MechanismModel) -> None:
    """Compile the sampled-data loop of ``model``'s structure: :func:`~pkmlab.codegen.core.loop.sampled_data_chunk`
    called on a run of no samples from its second sample on (which computes nothing), each argument of the type
    :func:`~pkmlab.simulation.run.simulate` passes (a test holds the two to one compiled signature)."""
    k_ = model.kernels
    n, n_x, n_q = model.n_actuators, k_.N_INDEPENDENT, k_.N_COORDINATES
    q, none = np.zeros(n_q), np.zeros((0, n))
    rows = np.zeros((0, n_x))  # the desired motion: no samples
    k_.sampled_data_chunk(k_.make_workspaces(2), np.zeros(2 * n_x), np.zeros((0, n)), 1, 1, 1e-3, 1, rows, rows,
                          rows, q, q, model.P, model.P, 0, 1.0, 1.0, np.zeros((0, n)), 0.0, k_.NO_DRIVES,
                          k_.NO_DRIVES, none, np.zeros(n), none, -1, 0, np.zeros((0, n_q)), np.zeros((0, n_x)),
                          np.zeros((0, n)), np.zeros(0), none)


def compile_plant_stage_meanwhile(model: MechanismModel, P: np.ndarray, drive: np.ndarray) -> None:
    """While a second process compiles the loop of ``model``'s structure (:func:`compile_loop_ahead`), compile
    here the part of it that process reaches last: the plant's stage (:func:`~pkmlab.codegen.core.loop.plant_stage`
    and what it calls) for the parameters ``P`` and drives ``drive`` the loop is given (:func:`plant_stage_signature`).
    Compiled only, nothing evaluated.

    The second process compiles the loop depth first: the controller's model
    (:func:`~pkmlab.codegen.core.dynamics.actuator_space_model`) first, the plant's stage last. This process, its
    run prepared, takes the plant's stage meanwhile, and the cache's compile locks make whichever of the two
    reaches a function second wait for the other and load it. Nothing is done where no second process is running
    for this structure (none was started, or it ended), or where the plant's stage is in the cache already."""
    process = _STARTED.get(model.kernels.__name__)
    if (process is not None and process.poll() is None
            and not _compile_cache.has_compiled(model.kernels.__name__, "plant_stage")):
        model.kernels.plant_stage.compile(plant_stage_signature(model, P, drive))


def plant_stage_signature(model: MechanismModel, P: np.ndarray, drive: np.ndarray) -> tuple:
    """The argument types the loop of ``model``'s structure passes its plant's stage
    (:func:`~pkmlab.codegen.core.loop.plant_stage`, from ``rk4_sample``) with parameters ``P`` and drives ``drive``:
    those of stand-ins, of which only the types count — the workspace's record, ``θ`` and ``θ̇`` as slices of one
    state, ``τ``, ``P``, the guard, the slot, whether the model there is known, ``drive``. A test holds them to the
    types the loop's call has, typed afresh."""
    from numba import typeof

    k_ = model.kernels
    n = k_.N_INDEPENDENT
    y = np.zeros(2 * n)
    stand_ins = (k_.make_workspaces(1)[0], y[:n], y[n:], np.zeros(n), P, 0.0, k_.BASE, False, drive)
    return tuple(typeof(a) for a in stand_ins)


def main() -> None:
    """The second process: the structure's description from stdin, its loop compiled, and an end to it as soon as
    stdin closes (the process that started it has ended). The description is bound without the assembly check:
    the first process checks it, and ends this one where it refuses it (:func:`end_compiling_ahead`)."""
    from ..model.mechanism_model import bind

    description = pickle.load(sys.stdin.buffer)

    def watch() -> None:  # (the descriptor, not sys.stdin, whose lock a thread reading it holds at exit)
        while os.read(sys.stdin.fileno(), 1 << 12):
            pass
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()
    compile_loop(bind(description))
