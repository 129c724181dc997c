"""Where Numba keeps pkmlab's compiled kernels, and the compiler every kernel is decorated with.

Numba's on-disk cache (``cache=True``) revalidates a function against its own source file
only: a kernel that calls a changed kernel in *another* module would be loaded stale. The
cache directory is therefore keyed by a hash of all of pkmlab's sources, so that any change
(an upgrade, a local edit) starts from a fresh cache, and the source tree stays clean.

Kernels are decorated with this module's :func:`njit` (Numba's, whose cached functions compile under a lock
that processes share, so that two processes reaching a function at once compile it once). A process started with
``PKMLAB_INTERPRETED=1`` runs the same kernels interpreted instead: Numba is not imported and
nothing is loaded from the cache. Importing Numba and loading the compiled kernels of a
command costs about 0.4 s; one pose's kinematics interpreted costs a few milliseconds, so the
command line's one-shot commands (``pkmlab ik`` ...) run that way (:func:`pkmlab.cli.entry`).
Anything that loops over many samples must run compiled.

Must run before any module that defines compiled kernels is imported.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import shutil
import tempfile
import threading
import time
import types
from pathlib import Path

try:
    import fcntl
except ImportError:  # Windows: no compile lock
    fcntl = None

#: True in a process whose kernels run interpreted (``PKMLAB_INTERPRETED=1`` when pkmlab was imported).
INTERPRETED = os.environ.get("PKMLAB_INTERPRETED") == "1"


def cache_base() -> Path:
    """pkmlab's cache folder: ``$PKMLAB_CACHE_DIR`` (or ``$NUMBA_CACHE_DIR``), else ``~/.cache/pkmlab``."""
    base = os.environ.get("PKMLAB_CACHE_DIR") or os.environ.get("NUMBA_CACHE_DIR")
    if not base:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        base = os.path.join(xdg, "pkmlab")
    return Path(base)


def digest_sources(digest, root: Path, files) -> str:
    """``digest`` (a :mod:`hashlib` object) of ``files``' names relative to ``root`` and contents, in the order
    given: what tells one version of pkmlab's sources from another."""
    for path in files:
        digest.update(path.relative_to(root).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


def cache_folder() -> Path:
    """The folder of this version's compiled kernels (and of the kernels generated for new structures),
    made if missing; one of its own for kernels compiled at another optimisation level than LLVM's usual 3
    (``NUMBA_OPT``: the test suite's 1), so that such code never serves a run at the usual level."""
    package = Path(__file__).resolve().parent
    opt = os.environ.get("NUMBA_OPT", "").strip()
    level = "" if opt in ("", "3") else f"-opt{opt}"
    cache = cache_base() / f"numba-{digest_sources(hashlib.sha1(), package, sorted(package.rglob('*.py')))[:16]}{level}"
    new = not cache.exists()
    if not _writable(cache):  # a read-only home or cache folder: the temporary folder's
        cache = Path(tempfile.gettempdir()) / "pkmlab-cache" / cache.name
        new = not cache.exists()
        cache.mkdir(parents=True, exist_ok=True)
    try:
        (cache / LAST_USED).touch()
    except OSError:
        pass
    if new:
        prune(cache.parent, keep=cache)
    return cache


def _writable(folder: Path) -> bool:
    """Whether ``folder`` is (made if missing and) a folder this process can write files into."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError:
        return False
    return True


#: A process marks the cache folder it uses by this file's time.
LAST_USED = "last-used"
#: The cache folder of another version of pkmlab's sources unused this long is removed when a new one is made.
STALE_AFTER_DAYS = 7


def prune(base: Path, keep: Path) -> list[Path]:
    """Remove from ``base`` the cache folders (``numba-*``) other than ``keep`` that no process has used for
    :data:`STALE_AFTER_DAYS`: each holds the compiled kernels of one version of the sources, a few hundred
    megabytes that nothing reads once pkmlab is upgraded or edited. A folder still in use, by another
    installation or a long session, is kept by its last use. Returns the folders removed."""
    limit = time.time() - STALE_AFTER_DAYS * 86400
    removed = []
    for folder in sorted(base.glob("numba-*")):
        marker = folder / LAST_USED
        try:
            used = (marker if marker.exists() else folder).stat().st_mtime
        except OSError:
            continue
        if folder != keep and folder.is_dir() and used < limit:
            shutil.rmtree(folder, ignore_errors=True)
            removed.append(folder)
    return removed


def configure() -> Path:
    """Numba's cache set to :func:`cache_folder` (Numba imported: :func:`_import_numba`)."""
    _import_numba()
    import numba

    cache = cache_folder()
    numba.config.CACHE_DIR = str(cache)
    return cache


#: Numba's switch of its error messages' terminal highlighting, read once, as it imports its errors module.
_PLAIN_ERRORS = "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"


def _import_numba() -> None:
    """Import Numba where pkmlab is the first to, its error messages without terminal highlighting unless the
    environment says otherwise. Typing a kernel tries overloads that fail, and Numba formats the message of
    each failure — highlighted through colorama, which wraps the output streams every time (some 30,000 times in a
    machine's first compile): measured, single processes from an empty cache, alternating, the Delta's first run's
    CPU time 19.7-22.2 s with it, 18.6-21.2 s without (a second less in three pairs of four). The switch is taken
    out of the environment again, so that this process's environment, and that of what it starts, is as it was, and
    Numba's settings read again from it before pkmlab sets its own (:func:`configure`)."""
    import sys

    if "numba" in sys.modules or _PLAIN_ERRORS in os.environ:  # (imported by the caller, :func:`configure`)
        return
    os.environ[_PLAIN_ERRORS] = "1"
    try:
        import numba.core.errors  # noqa: F401
    finally:
        del os.environ[_PLAIN_ERRORS]
        # Numba reads its settings from the environment again at each compile where the environment changed since:
        # read now, or the first compile would set back what this process sets after (the cache folder among them)
        from numba.core import config

        config.reload_config()


def _interpreted_njit(*args, **_options):
    """``njit`` of an interpreted process: the function itself (``@njit`` and ``@njit(...)`` alike)."""
    if len(args) == 1 and callable(args[0]):
        return args[0]
    return lambda function: function


#: The functions this process is compiling, whose locks it holds (a recursive function asks again); guarded by
#: Numba's compiler lock, which every compilation in the process holds.
_HELD: set[str] = set()
#: Longest wait for another process's compilation (s): past it (a process stopped while compiling), compile here.
LOCK_WAIT = 300.0


def _acquire(handle) -> bool:
    """Lock ``handle`` (flock), waiting at most :data:`LOCK_WAIT`; False where the file system has no locks or the
    wait was too long."""
    deadline = time.monotonic() + LOCK_WAIT
    while True:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return True
        except BlockingIOError:
            if time.monotonic() > deadline:
                return False
            time.sleep(0.02)
        except OSError:  # a file system without locks (some network mounts)
            return False


@contextlib.contextmanager
def cache_lock(name: str):
    """Hold the lock file of the cached item ``name`` (a function compiling, a generic instance solved) while it is
    made: a second process that reaches the same item waits, then loads the first's from the cache instead of
    making it too (test workers, a batch's processes, two commands started at once). No lock where the cache
    folder is read-only, the file system or the system has no ``flock``, or another process has held it for
    :data:`LOCK_WAIT`: each process then makes it, as it would without."""
    if fcntl is None or name in _HELD:
        yield
        return
    locks = CACHE_DIR / "locks"
    try:
        locks.mkdir(exist_ok=True)
        handle = open(locks / (hashlib.sha1(name.encode()).hexdigest()[:20] + ".lock"), "a")
    except OSError:
        yield
        return
    with handle:
        if not _acquire(handle):
            yield
            return
        _HELD.add(name)
        try:
            yield
        finally:
            _HELD.discard(name)
            fcntl.flock(handle, fcntl.LOCK_UN)


def _locked(dispatcher):
    """``dispatcher`` (a cached Numba function) whose compilations hold its lock (:func:`cache_lock`). Numba
    calls ``compile`` for a signature at each call site it types, and looks in its cache first; the lock makes
    that look happen after another process's compilation is saved. The lock is taken inside Numba's own
    compiler lock (held by every compilation of the process, and by a nested one already), so threads of one
    process take the two in one order; callers lock before callees, along a call graph without cycles, so two
    processes cannot wait for each other. A signature already compiled here takes no lock."""
    from numba.core.compiler_lock import global_compiler_lock
    from numba.core.sigutils import normalize_signature

    compile_signature = dispatcher.compile
    name = f"{dispatcher.py_func.__module__}.{dispatcher.py_func.__qualname__}"

    def compile(sig):
        with global_compiler_lock:
            if tuple(normalize_signature(sig)[0]) in dispatcher.overloads:
                return compile_signature(sig)
            with cache_lock(name):
                return compile_signature(sig)

    dispatcher.compile = compile
    _tolerant(dispatcher._cache)
    return dispatcher


def _tolerant(cache) -> None:
    """Numba's cache of one function (``cache``), made to survive its files: an entry that cannot be read (a file
    cut short by a full disk or a process killed while writing it, or overwritten) is a miss — its index emptied,
    the function compiled and saved again over it — and an entry that cannot be written (a folder made read-only,
    a full disk) is not kept, said once on stderr: the process goes on either way, with what it compiled."""
    load, save = cache.load_overload, cache.save_overload

    def load_overload(sig, target_context):
        try:
            return load(sig, target_context)
        except Exception:  # noqa: BLE001  (unpickling or rebuilding an unreadable entry raises anything)
            try:
                cache.flush()  # an empty index, which the compile about to follow saves its entry into
            except OSError as exc:
                _say_unsaved(exc)
            return None

    def save_overload(sig, data):
        try:
            save(sig, data)
        except OSError as exc:
            _say_unsaved(exc)

    cache.load_overload, cache.save_overload = load_overload, save_overload


#: Whether this process has said that it cannot write the kernel cache.
_UNSAVED: list[str] = []


def _say_unsaved(exc: OSError) -> None:
    """Say once, in one line on stderr, that compiled kernels cannot be kept in the cache folder, and what to do."""
    if not _UNSAVED:
        import sys

        _UNSAVED.append(str(exc))
        print(f"pkmlab: cannot write the kernel cache in {CACHE_DIR} ({exc.strerror or exc}): this process compiles "
              "what it needs each time it starts; set PKMLAB_CACHE_DIR to a folder you can write to", file=sys.stderr)


def compiled_njit(*args, **options):
    """Numba's ``njit`` (``@njit``, ``@njit(...)``), whose cached functions compile under a lock shared by
    processes (:func:`_locked`): every kernel's compiler (:data:`njit`), and the one of modules compiled even in
    an interpreted process."""
    import numba

    def finish(dispatcher):
        if options.get("no_cpython_wrapper"):
            dispatcher.__class__ = _compiled_only_class(type(dispatcher))
        return _locked(dispatcher) if options.get("cache") else dispatcher

    if args and callable(args[0]):
        _keep_cache_folder(numba)
        return finish(numba.njit(*args, **options))
    decorate = numba.njit(*args, **options)

    def apply(function):
        _keep_cache_folder(numba)
        return finish(decorate(function))

    return apply


def _keep_cache_folder(numba) -> None:
    """Numba's cache folder set back to pkmlab's (:data:`CACHE_DIR`) where Numba has set it back to its default, before
    a function is decorated (which fixes where its compiled code is kept): Numba reads its settings from the
    environment again at a compile where a ``NUMBA_`` variable has changed since — a program's own setting of one
    after pkmlab was imported — and a kernel decorated after that would be kept beside the sources, where an edit of
    another module is not seen."""
    if numba.config.CACHE_DIR != str(CACHE_DIR):
        numba.config.CACHE_DIR = str(CACHE_DIR)


@functools.cache
def _compiled_only_class(base: type) -> type:
    """The class of a Numba function compiled without its Python wrapper (:data:`NO_WRAPPERS`): ``base``, whose call
    from Python refuses in one line — Numba's own would call the missing wrapper and end the process (Numba's issue
    2541). Compiled callers call the function directly, as before."""

    def __call__(self, *args, **kwargs):
        raise TypeError(f"{self.py_func.__module__}.{self.py_func.__qualname__} is called from compiled code only "
                        "(pkmlab._compile_cache.NO_WRAPPERS): compile it with NO_REFCOUNT_PYTHON or cache=True to call "
                        "it from Python")

    return type(f"CompiledOnly{base.__name__}", (base,), {"__call__": __call__, "__module__": __name__})


def _interpreted_call_native(address, first, second):
    """:func:`call_native` of an interpreted process, through :mod:`ctypes`."""
    import ctypes

    function = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)(int(address))
    function(int(first), int(second))


def _compiled_call_native():
    """:func:`call_native` for compiled code: a Numba intrinsic calling the function at an address (an integer
    argument, so that the code calling it is cached as any other: no address is compiled in)."""
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    @intrinsic
    def call_native(typingctx, address, first, second):
        def codegen(context, builder, signature, args):
            pointer = ir.IntType(8).as_pointer()
            function = builder.inttoptr(args[0], ir.FunctionType(ir.VoidType(), [pointer, pointer]).as_pointer())
            builder.call(function, [builder.inttoptr(args[1], pointer), builder.inttoptr(args[2], pointer)])
            return context.get_dummy_value()

        return types.void(address, first, second), codegen

    return call_native


if INTERPRETED:
    CACHE_DIR = cache_folder()  # (kernels generated for a new structure are kept there too)
    njit, prange = _interpreted_njit, range
    call_native = _interpreted_call_native
else:
    CACHE_DIR = configure()
    from numba import prange  # noqa: F401  (re-exported: every kernel module's compiler)

    njit = compiled_njit
    #: ``call_native(address, first, second)``: call the C function ``void f(void *, void *)`` at ``address`` (all
    #: three integers) — a native plant's step (MuJoCo's ``mj_step(model, data)``) from compiled code.
    call_native = _compiled_call_native()


def has_compiled(module_name: str, function: str = "") -> bool:
    """Whether a kernel of the module ``module_name`` (its ``function``, given one) is in this version's cache
    (Numba names a kernel's index file after the last part of its module's name and its own)."""
    stem = module_name.rsplit(".", 1)[-1]
    return any(CACHE_DIR.rglob(f"{stem}.{function}-*.nbi" if function else f"{stem}.*.nbi"))


def _is_kernel(value) -> bool:
    """Whether ``value`` is a compiled kernel (a Numba function): its Python function and its compiled versions."""
    return hasattr(value, "py_func") and hasattr(value, "overloads")


#: The interpreted copies made so far (:func:`interpreted`): of each kernel's Python function, and of each module's
#: names (by the identity of the module's namespace, kept alive beside its copy). Made under :data:`_COPYING`: a
#: copy is handed out only once the names its module's kernels see are all interpreted.
_COPIES: dict = {}
_NAMESPACES: dict[int, tuple[dict, dict]] = {}
_COPYING = threading.RLock()


def interpreted(kernel):
    """The compiled kernel ``kernel`` run by Python: its Python function, every compiled kernel that it calls (by a
    name of its module, or as an attribute of a module of pkmlab's or of a structure's generated kernels) replaced by
    its interpreted copy, and so on down its calls. The same operations in the same order as compiled, so the same
    numbers bit for bit where Python and the compiled code compute each operation alike: ``+ - * /``, comparisons,
    ``max``, ``abs``, ``sqrt`` and the C library's ``sin``, ``cos``, ``atan2``... — not ``x**k`` (Numba multiplies
    it out, Python's ``pow`` rounds once: write the products) nor ``math.hypot`` (Python's own, Numba's is the C
    library's): a test holds each kernel run this way (:class:`InterpretedFirst`) to its compiled numbers. Where the
    compiled code raises (a float divided by zero), NumPy's numbers may give infinities with a warning instead. For
    kernels of plain arrays and numbers (a workspace's fields, read by attribute, are not). A copy sees its module's
    names as they were when the module was first copied."""
    if not _is_kernel(kernel):
        return kernel
    function = kernel.py_func
    with _COPYING:
        copy = _COPIES.get(function)
        if copy is None:
            namespace = _interpreted_namespace(function.__globals__)
            copy = _COPIES.get(function)  # (made while its module's names were: a kernel of the same module)
        if copy is None:
            cells = function.__closure__ and tuple(types.CellType(_interpreted_value(cell.cell_contents))
                                                   for cell in function.__closure__)
            copy = types.FunctionType(function.__code__, namespace, function.__name__, function.__defaults__, cells)
            copy.__kwdefaults__, copy.__qualname__ = function.__kwdefaults__, function.__qualname__
            copy.__doc__ = function.__doc__
            _COPIES[function] = copy
    return copy


class _InterpretedModule:
    """A module as an interpreted kernel sees it: its compiled kernels interpreted (:func:`interpreted`)."""

    def __init__(self, module):
        self._module = module

    def __getattr__(self, name):
        return _interpreted_value(getattr(self._module, name))


#: The modules whose kernels an interpreted kernel calls interpreted too: pkmlab's, and the kernels generated for a
#: structure new to the installation (``pkmlab_kernels_<structure>``, :mod:`pkmlab.model.mechanism_model`).
_OWN_MODULES = (__name__.split(".")[0] + ".", __name__.split(".")[0] + "_kernels_")


def _interpreted_value(value):
    if _is_kernel(value):
        return interpreted(value)
    if isinstance(value, types.ModuleType) and (value.__name__ + ".").startswith(_OWN_MODULES):
        return _InterpretedModule(value)
    return value


def _interpreted_namespace(namespace: dict) -> dict:
    """A copy of a module's names (``namespace``) whose kernels and modules are interpreted
    (:func:`_interpreted_value`); one per module, registered before its kernels are copied (which share it: two
    kernels that call each other end there)."""
    entry = _NAMESPACES.get(id(namespace))
    if entry is None:
        copy = dict(namespace)
        _NAMESPACES[id(namespace)] = (namespace, copy)
        for key, value in list(copy.items()):
            copy[key] = _interpreted_value(value)
        return copy
    return entry[1]


#: Calls of a kernel run interpreted first (:class:`InterpretedFirst`) in a process before it is compiled.
INTERPRETED_CALLS = 1


class InterpretedFirst:
    """A compiled kernel called from Python (``kernel``) that runs interpreted (:func:`interpreted`) for its first
    ``calls`` calls in a process, unless its compiled code for the call's argument types is at hand (compiled in
    this process already, by a compiled caller say, or in the cache); then compiled, and kept in the cache.

    For a kernel that a command may call once, whose compile costs seconds and whose interpreted call milliseconds:
    a planar machine's assembly modes at a run's start (``three_circles``: 5-6 s of compiling on the first run of
    the paper's disturbed case, against 10 ms interpreted). A process that calls it more (a batch of disturbed runs)
    compiles it at its second call, as it would have at its first, and every later process loads it. The numbers are
    the same either way: only for a kernel that :func:`interpreted` runs bit for bit as compiled, which a test
    checks."""

    def __init__(self, kernel, calls: int = INTERPRETED_CALLS):
        self.kernel = kernel
        self.calls = calls
        self._cached: dict[tuple, bool] = {}

    def compiled_at_hand(self, *args) -> bool:
        """Whether a call with ``args`` runs compiled: its compiled code in this process or in the cache, or the
        interpreted calls spent."""
        if INTERPRETED or not _is_kernel(self.kernel) or self.calls <= 0:
            return True
        signature = tuple(self.kernel.typeof_pyval(a) for a in args)
        if signature in self.kernel.overloads:
            return True
        if signature not in self._cached:  # looked up once: a process that saves it has compiled it
            self._cached[signature] = _in_cache(self.kernel, signature)
        return self._cached[signature]

    def __call__(self, *args):
        if self.compiled_at_hand(*args):
            return self.kernel(*args)
        self.calls -= 1
        return interpreted(self.kernel)(*args)


def _in_cache(kernel, signature: tuple) -> bool:
    """Whether Numba's cache holds ``kernel`` compiled for the argument types ``signature``, for this Numba and
    processor (its index's key for them): what its next call would load rather than compile. False where it cannot
    tell (no cache, an index it cannot read)."""
    cache = getattr(kernel, "_cache", None)
    try:
        key = cache._index_key(signature, kernel.targetctx.codegen())
        return cache._cache_file._load_index().get(key) is not None
    except Exception:  # noqa: BLE001  (Numba's private cache: any failure means "cannot tell")
        return False


#: Numba options of a compiled function called from compiled code only: without the two wrappers Numba otherwise
#: compiles and caches with each function, one that converts Python's arguments and one that makes it a C callback
#: (measured interleaved with and without: a machine's first simulation compiles in 4-15 % less time). Called from
#: Python, it raises a TypeError naming it (:func:`_compiled_only_class`).
NO_WRAPPERS = {"cache": True, "no_cpython_wrapper": True, "no_cfunc_wrapper": True}

#: Numba options of the allocation-free kernels of the hot path (they only read and write
#: arrays they are given, typically a workspace's). Numba's reference counting, on by
#: default, makes every call that passes arrays pay an atomic increment and decrement per
#: array — for a workspace of ~20 arrays that is most of the cost of a small kernel
#: (measured: a 3×3 solve called with a workspace, 280 ns with it, 43 ns without). Kernels
#: compiled with these options must not allocate or return arrays. Called from compiled code only
#: (:data:`NO_WRAPPERS`).
NO_REFCOUNT = {**NO_WRAPPERS, "_nrt": False}

#: The same for the few of them also called from Python: the simulation's steps, which tests and benchmarks take
#: one at a time, and the singularity measure of one configuration.
NO_REFCOUNT_PYTHON = {"cache": True, "_nrt": False}

#: The same, inlined into the caller by Numba: for the small kernels that take a whole
#: workspace, whose ~20 arrays would otherwise be passed by value at every call.
NO_REFCOUNT_INLINE = {**NO_REFCOUNT, "inline": "always"}
