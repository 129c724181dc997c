"""Executing a study: chunks of runs on a Dask cluster (or in this process), written as they finish.

The runs still to do are cut into chunks; each chunk is one task, :func:`~pkmlab.study.runs.run_chunk`
on a worker. This process gathers the chunks as they finish and writes each one atomically
(``chunks/runs-FIRST-LAST.parquet``, through a temporary file), so an interrupted study — Ctrl-C, a
killed worker, a lost scheduler, a killed client — loses at most the chunks in flight, and
``resume=True`` runs only the runs no chunk file holds. A worker killed while running a chunk costs
only time: the scheduler runs the chunk again elsewhere. The table is the chunks' rows in run
order, so it is the same, bit for bit, whatever the workers, the chunk size or the interruptions.

Where the work runs:

* by default a local cluster of worker processes, started and stopped here (one per core,
  ``workers`` to choose; each runs one chunk at a time on one core), nothing to set up;
* ``scheduler="tcp://HOST:PORT"``: an existing Dask cluster (its workers need pkmlab installed;
  they do not need the user's files: a study carries its scenario);
* ``client=``: a ``distributed.Client`` already open (a notebook's);
* ``workers=0``: in this process, chunk after chunk (small studies, debugging).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import time
from pathlib import Path

from ..errors import PkmlabError
from ..outputs import atomic_file
from ..simulation.ahead import SWITCH, available_cores
from .definition import Study
from .runs import columns, run_chunk

#: The study folder's record of the study it holds.
STUDY_FILE = "study.json"
#: The folder of chunk files inside a study folder.
CHUNKS = "chunks"
#: How long to try to reach a scheduler before saying it cannot be reached (s).
CONNECT_TIMEOUT = 5.0
#: Runs per chunk at most by default: a chunk of 3-RRR runs takes about a second on one core.
MAX_CHUNK = 64


class StudyError(PkmlabError):
    """A study that cannot start or go on: a folder in the way, an unreachable cluster, a lost one."""


class StudyInterrupted(KeyboardInterrupt):
    """Ctrl-C during a study; its message says what was kept and how to finish."""


def require_module(module: str):
    try:
        return __import__(module)
    except ImportError:
        raise StudyError(f"studies need {module}: pip install 'pkmlab[study]'") from None


# ------------------------------------------------------------------ the table's types
def schema(study: Study):
    """The Arrow schema of a study's table: integers for run numbers and counts, floats for metrics and
    factors, strings for the status, reason, working mode and message; an axis's cells take its values'
    type (numbers, strings, booleans; lists are stored as JSON text)."""
    pa = require_module("pyarrow")
    kinds = {}
    for key, values in study.axes:
        if all(isinstance(v, bool) for v in values):
            kinds[key] = pa.bool_()
        elif all(isinstance(v, int) and not isinstance(v, bool) for v in values):
            kinds[key] = pa.int64()
        elif all(isinstance(v, float) for v in values):
            kinds[key] = pa.float64()
        else:
            kinds[key] = pa.string()
    fields = []
    for name in columns(study):
        if name in kinds:
            kind = kinds[name]
        elif name in ("run", "point", "draw", "samples"):
            kind = pa.int64()
        elif name in ("status", "reason", "working_mode", "message"):
            kind = pa.string()
        else:
            kind = pa.float64()
        fields.append(pa.field(name, kind))
    return pa.schema(fields)


# ------------------------------------------------------------------ the study folder
class StudyFolder:
    """A study's folder: ``study.json``, ``chunks/``, and, once complete, ``runs.parquet``, ``summary.json``,
    ``figures/`` (and ``runs.csv`` on request)."""

    def __init__(self, path, study: Study):
        self.path = Path(path)
        self.study = study

    @property
    def chunks(self) -> Path:
        return self.path / CHUNKS

    @contextlib.contextmanager
    def exclusive(self):
        """Hold the study's folder for this process (an exclusive lock on its ``study.json``): a second process
        resuming the same study is refused, naming the one that holds it, rather than write overlapping
        chunks. The lock goes with the process, however it ends (where there is no ``fcntl``, nothing is held)."""
        try:
            import fcntl
        except ImportError:
            yield
            return
        record = self.path / STUDY_FILE
        fd = os.open(record, os.O_RDONLY)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise StudyError(f"--out {self.path}: another process{_lock_holder(record)} is running this study "
                                 "now: wait for it to end (or stop it), then --resume") from None
            yield
        finally:
            os.close(fd)

    def open(self, resume: bool, note=None) -> None:
        """Make the folder ready: new or empty, or holding this study (``resume``). Refuses a folder that holds
        anything else, another study, or this one unfinished without ``resume``."""
        out, study = self.path, self.study
        if out.exists() and not out.is_dir():
            raise StudyError(f"--out {out}: a file is in the way (a study's output is a folder)")
        record = out / STUDY_FILE
        if out.is_dir() and any(out.iterdir()):
            if not record.is_file():
                raise StudyError(f"--out {out} holds other files and no study: choose a new or empty folder")
            try:
                held = json.loads(record.read_text())
                digest = held["digest"]
            except (OSError, ValueError, KeyError, TypeError):
                raise StudyError(f"{record}: not a study record pkmlab wrote (unreadable); choose another folder"
                                 ) from None
            if digest != study.digest:
                raise StudyError(f"--out {out} holds another study ({held.get('name', '?')}, hash {digest[:12]}; "
                                 f"this one is {study.digest[:12]}): choose another folder")
            if not resume:
                complete = (out / "runs.parquet").is_file()
                raise StudyError(f"--out {out} already holds this study{' complete' if complete else ', unfinished'}"
                                 ": add --resume to " + ("write its table again" if complete else "finish it")
                                 + ", or choose another folder")
            if note is not None:
                note(f"resuming: {len(self.done_runs())} of {study.size} runs already in {out}")
            return
        text = json.dumps({"name": study.name, "digest": study.digest, "runs": study.size,
                           "columns": list(columns(study)), "definition": study.definition()}, indent=1)
        try:
            self.chunks.mkdir(parents=True, exist_ok=True)
            with atomic_file(record) as tmp:
                tmp.write_text(text)
        except OSError as exc:
            raise StudyError(f"cannot write the study's folder {out}: {exc.strerror or exc}") from None

    def remove_if_unused(self) -> None:
        """Remove what :meth:`open` made when no chunk was written since (a study that could not start)."""
        with contextlib.suppress(OSError):
            if not self.chunk_files():
                (self.path / STUDY_FILE).unlink(missing_ok=True)
                for folder in (self.chunks, self.path):
                    folder.rmdir()  # only if empty: nothing of anyone's is removed

    def chunk_files(self) -> list[Path]:
        return sorted(self.chunks.glob("runs-*.parquet"))

    def done_runs(self) -> set[int]:
        """The runs some chunk file holds."""
        pq = require_module("pyarrow.parquet").parquet
        done: set[int] = set()
        for path in self.chunk_files():
            try:
                runs = pq.read_table(path, columns=["run"]).column("run").to_pylist()
            except Exception as exc:  # noqa: BLE001 - any unreadable file is named, whatever Arrow says
                raise StudyError(f"{path}: unreadable chunk file ({exc}); remove it and --resume") from None
            done.update(runs)
        return done

    def write_chunk(self, table) -> Path:
        """Write one chunk's rows atomically."""
        pq = require_module("pyarrow.parquet").parquet
        runs = table.column("run").to_pylist()
        path = self.chunks / f"runs-{min(runs):09d}-{max(runs):09d}.parquet"
        try:
            with atomic_file(path) as tmp:
                pq.write_table(table, tmp)
        except OSError as exc:  # a full disk, a folder removed: said as such, never as a lost cluster
            raise StudyError(f"cannot write {path}: {exc.strerror or exc}; what is written is kept: --resume runs "
                             "the rest") from None
        return path

    def table(self, types):
        """Every chunk's rows in run order; refuses a folder whose chunks miss or repeat a run."""
        pa = require_module("pyarrow")
        pq = require_module("pyarrow.parquet").parquet
        parts = [pq.read_table(path).select(types.names).cast(types) for path in self.chunk_files()]
        table = pa.concat_tables(parts) if parts else types.empty_table()
        return _in_run_order(table, self.study, str(self.path))


def _in_run_order(table, study: Study, where: str):
    table = table.sort_by("run")
    runs = table.column("run").to_pylist()
    if runs != list(range(study.size)):
        missing = study.size - len(set(runs))
        raise StudyError(f"{where}: the chunks hold {len(runs)} rows for {study.size} runs ({missing} missing, "
                         f"{len(runs) - len(set(runs))} repeated)")
    return table


# ------------------------------------------------------------------ where the chunks run
@contextlib.contextmanager
def dask_client(workers: int | None, scheduler: str | None, client):
    """A Dask client: the one given, one of the cluster at ``scheduler``, or one of a local cluster
    started here and stopped on leaving (``workers`` processes of one thread each)."""
    if client is not None:
        yield client
        return
    distributed = require_module("distributed")
    if scheduler is not None:
        try:
            with contextlib.redirect_stderr(open(os.devnull, "w")):  # noqa: SIM115 - Dask's own retry chatter
                connected = distributed.Client(scheduler, timeout=CONNECT_TIMEOUT, set_as_default=False)
        except Exception as exc:  # noqa: BLE001 - OSError, TimeoutError, ValueError (a malformed address), ...
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise StudyError(f"cannot reach the Dask scheduler at {scheduler} within {CONNECT_TIMEOUT:g} s: "
                             f"{reason}") from None
        try:
            yield connected
        finally:
            connected.close()
        return
    import logging
    import signal

    n = workers or available_cores()
    # Ctrl-C reaches every process of the terminal's group: the workers, started with SIGINT ignored (a
    # disposition a new process inherits), leave it to this process, which stops them and keeps what is written
    try:
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    except ValueError:  # not the main thread: nothing to protect
        previous = None
    try:
        # dashboard_address=":0": a free port (None still takes 8787, and warns when another cluster holds it).
        # silence_logs=CRITICAL: every failure that matters reaches this process as an exception (a task's
        # error, a killed worker, a lost scheduler); what Dask logs at ERROR are its processes losing each
        # other while the cluster stops (a worker's heartbeat to a scheduler already closed, after Ctrl-C)
        # the workers share the cores already: none compiles a first run's loop in a second process of its own
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=":0", silence_logs=logging.CRITICAL,
                                           env={SWITCH: "0"})
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    try:
        local = distributed.Client(cluster, set_as_default=False)
        try:
            yield local
        finally:
            local.close()
    finally:
        cluster.close()


def _chunks(todo: list[int], size: int) -> list[list[int]]:
    return [todo[i:i + size] for i in range(0, len(todo), size)]


def default_chunk_size(runs: int, workers: int) -> int:
    """Enough chunks to keep every worker busy to the end (8 per worker), at most :data:`MAX_CHUNK` runs."""
    return max(1, min(MAX_CHUNK, math.ceil(runs / (8 * max(workers, 1)))))


def execute(study: Study, todo: list[int], *, folder: StudyFolder | None = None, workers: int | None = None,
            scheduler: str | None = None, client=None, chunk_size: int | None = None, progress=None,
            on_chunk=None) -> tuple[list, dict]:
    """Run ``todo`` (run numbers) of ``study`` in chunks; each chunk's Arrow table is written to ``folder`` as
    it finishes (or kept in memory without a folder). Returns the tables kept in memory and what was measured:
    ``{"workers", "chunk_size", "chunks", "wall_time_s", "runs_per_s", "task_overhead_s"}``."""
    pa = require_module("pyarrow")
    types = schema(study)
    kept: list = []
    start = time.perf_counter()
    busy = 0.0  # the chunks' own compute time, summed: the rest of a worker's time is the scheduler's
    done = 0

    def finished(rows: list[dict], seconds: float) -> None:
        nonlocal done, busy
        table = pa.Table.from_pylist(rows, schema=types)
        if folder is not None:
            folder.write_chunk(table)
        else:
            kept.append(table)
        done += len(rows)
        busy += seconds
        if progress is not None:
            progress.update(len(rows))
        if on_chunk is not None:
            on_chunk(done, len(todo))

    inline = workers == 0 and scheduler is None and client is None
    if inline:
        size = chunk_size or default_chunk_size(len(todo), 1)
        for chunk in _chunks(todo, size):
            t0 = time.perf_counter()
            rows = run_chunk(study, chunk)
            finished(rows, time.perf_counter() - t0)
        count = 1
    else:
        with dask_client(workers, scheduler, client) as dask:
            count = max(1, len(dask.scheduler_info(n_workers=-1)["workers"])) if client is not None or scheduler \
                else (workers or available_cores())
            size = chunk_size or default_chunk_size(len(todo), count)
            # one compiled thread per task: a worker is one core (Dask runs one task per worker thread), and
            # more threads per task would contend with the other workers and the scheduler for the cores
            _run_on_dask(dask, study, _chunks(todo, size), 1, finished)
    wall = time.perf_counter() - start
    chunks = math.ceil(len(todo) / size) if todo else 0
    stats = {"workers": count, "chunk_size": size, "chunks": chunks, "wall_time_s": wall,
             "runs_per_s": len(todo) / wall if wall > 0 else math.nan,
             "task_overhead_s": max(0.0, (wall * count - busy) / chunks) if chunks else 0.0}
    return kept, stats


def _timed_chunk(study: Study, chunk: list[int], threads: int) -> tuple[list[dict], float, list[tuple]]:
    """A chunk's rows and compute time, run on a worker, with the warnings it raised: a worker's own warnings
    would go to its stderr, raw, past what the caller makes of them (:func:`_warn_again`)."""
    import warnings

    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        rows = run_chunk(study, chunk, threads)
    said = {(w.category, str(w.message), w.filename, w.lineno) for w in caught}
    return rows, time.perf_counter() - t0, sorted(said, key=str)


def _warn_again(caught: list[tuple]) -> None:
    """Raise in this process the warnings a worker recorded, where they arose (the command line says each in
    one note line, as for a run of its own)."""
    import warnings

    for category, message, filename, lineno in caught:
        warnings.warn_explicit(message, category, filename, lineno)


@contextlib.contextmanager
def _ctrl_c_as_flag():
    """Ctrl-C sets the event yielded instead of raising at once: raised inside Dask's client calls, a
    KeyboardInterrupt leaves its event loop logging errors; the caller raises it between two of them."""
    import signal
    import threading

    stop = threading.Event()
    try:
        previous = signal.signal(signal.SIGINT, lambda _signum, _frame: stop.set())
    except ValueError:  # not the main thread: Ctrl-C is not delivered here anyway
        previous = None
    try:
        yield stop
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


#: How often the gathering loop looks for finished chunks and for Ctrl-C (s).
POLL = 0.05


def _run_on_dask(dask, study: Study, chunks: list[list[int]], threads: int, finished) -> None:
    distributed = require_module("distributed")
    tag = study.digest[:12]
    futures = [dask.submit(_timed_chunk, study, chunk, threads, key=f"pkmlab-{tag}-{chunk[0]}-{chunk[-1]}",
                           pure=False) for chunk in chunks]
    first = {f.key: chunk for f, chunk in zip(futures, chunks, strict=True)}
    try:
        with _ctrl_c_as_flag() as stop:
            pending = distributed.as_completed(futures, loop=dask.loop)
            while not pending.is_empty():
                if stop.is_set():
                    raise KeyboardInterrupt
                batch = pending.next_batch(block=False)
                if not batch:
                    time.sleep(POLL)
                    continue
                for future in batch:
                    try:
                        rows, seconds, caught = future.result()
                    except distributed.KilledWorker:
                        chunk = first[future.key]
                        raise StudyError(f"the chunk of runs {chunk[0]}..{chunk[-1]} killed the workers that ran it "
                                         "(out of memory?); what is written is kept: --resume runs the rest") from None
                    _warn_again(caught)
                    finished(rows, seconds)
    except (OSError, TimeoutError, distributed.comm.CommClosedError) as exc:
        raise StudyError(f"lost the Dask cluster ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
                         "what is written is kept: --resume runs the rest") from None
    except BaseException:
        with contextlib.suppress(Exception):
            dask.cancel(futures)
        raise


def _lock_holder(path: Path) -> str:
    """`` (pid N)`` of the process holding a lock on ``path``, from Linux's ``/proc/locks``; empty elsewhere."""
    try:
        inode = os.stat(path).st_ino
        for line in Path("/proc/locks").read_text().splitlines():
            fields = line.split()
            if len(fields) >= 6 and fields[1] == "FLOCK" and fields[5].rsplit(":", 1)[-1] == str(inode):
                return f" (pid {fields[4]})"
    except (OSError, ValueError):
        pass
    return ""


# ------------------------------------------------------------------ the whole study
def run_study(study: Study, out=None, *, workers: int | None = None, scheduler: str | None = None, client=None,
              chunk_size: int | None = None, resume: bool = False, progress: bool = False, on_chunk=None,
              note=None):
    """Run every run of ``study`` not yet in ``out`` and return ``(table, stats)``: the whole table (Arrow, in
    run order) and :func:`execute`'s measurements. Without ``out`` nothing is written."""

    if chunk_size is not None and (isinstance(chunk_size, bool) or not isinstance(chunk_size, int)
                                   or chunk_size < 1):
        raise StudyError(f"chunk_size must be a positive integer, got {chunk_size!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0):
        raise StudyError(f"workers must be a non-negative integer, got {workers!r}")
    folder = None
    with contextlib.ExitStack() as held:
        if out is not None:
            folder = StudyFolder(out, study)
            folder.open(resume, note)
            held.enter_context(folder.exclusive())  # one process at a time writes a study's chunks
            todo = sorted(set(range(study.size)) - folder.done_runs())
        else:
            todo = list(range(study.size))
        return _run(study, folder, todo, workers, scheduler, client, chunk_size, progress, on_chunk)


def _run(study, folder, todo, workers, scheduler, client, chunk_size, progress, on_chunk):
    """:func:`run_study`'s runs ``todo`` and the table, its folder opened (and held) or None."""
    from ..progress import Progress

    bar = Progress(len(todo), study.name, enabled=progress, unit="runs")
    try:
        kept, stats = execute(study, todo, folder=folder, workers=workers, scheduler=scheduler, client=client,
                              chunk_size=chunk_size, progress=bar, on_chunk=on_chunk)
    except KeyboardInterrupt:
        bar.close()
        if folder is None:
            raise
        folder.remove_if_unused()
        kept_runs = len(folder.done_runs()) if folder.path.exists() else 0
        raise StudyInterrupted(f"{kept_runs} of {study.size} runs are kept in {folder.path}; resume to finish"
                               ) from None
    except PkmlabError:  # a cluster that cannot be reached: a folder made for nothing is not left behind
        if folder is not None:
            folder.remove_if_unused()
        raise
    finally:
        bar.close()
    if folder is not None:
        table = folder.table(schema(study))
    else:
        pa = require_module("pyarrow")
        table = _in_run_order(pa.concat_tables(kept) if kept else schema(study).empty_table(), study, "the study")
    stats["runs_run"] = len(todo)
    return table, stats
