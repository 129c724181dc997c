"""Writing results safely: a file or a folder appears complete, or not at all, and nothing of a
user's is ever deleted.

:func:`atomic_file` writes one file through a temporary file beside it.

:func:`atomic_output_dir` hands out a temporary folder beside the target; the caller writes
everything into it, and only when the ``with`` block finishes without an error does it take the
target's place. Every result folder carries a manifest (:data:`MANIFEST`): the command that
wrote it, pkmlab's version and the SHA-256 of every file. An existing target is replaced only
when it is empty, or when it holds exactly the files its manifest lists, unchanged since pkmlab
wrote them, and was written by the same command — a folder holding anything else (a notebook,
notes, an edited report, the run's own input file) is refused with a one-line
:class:`~pkmlab.errors.PkmlabError`, never deleted.

The new folder takes the old one's place in one atomic step (Linux ``renameat2`` with
``RENAME_EXCHANGE``; elsewhere two renames, the old folder kept until the new one is in place),
so that a run killed at any moment — even ``kill -9`` — leaves either the old result or the new
one, never a mix. Temporary folders left behind by a killed run are removed by the next run
into the same target. Used by ``pkmlab reproduce`` and ``pkmlab simulate``.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import datetime
import functools
import hashlib
import json
import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from .errors import PkmlabError

#: The manifest of a result folder: which command wrote it, and the SHA-256 of every file.
MANIFEST = "pkmlab-manifest.json"


class OutputFolderError(PkmlabError):
    """An output folder that cannot be written, or that holds something pkmlab must not replace."""


class OutputFileError(PkmlabError):
    """A file that cannot be written where its caller asks: the path is a folder, or its folder does not
    exist (and the caller did not ask for one). The message names the path."""


class ResultReplacedWarning(UserWarning):
    """An earlier result of the same command is being replaced (the command line prints it as a note)."""


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, *, make_folder: bool = True, mark: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; when the block succeeds it becomes ``path``.

    The file gets ordinary permissions (``mkstemp`` creates it 0600); on an error the
    temporary file is removed, so no half-written file is ever left. ``make_folder``: make the folder of
    ``path`` if it is missing (a result folder's own subfolders); a path a user names in the API is written
    with ``make_folder=False``, so that a mistyped folder is refused rather than created. A path that is a
    folder and a missing folder are an :class:`OutputFileError` naming ``path``; the system's refusals
    (permissions, a full disk) stay the ``OSError`` they are, for the caller to word. ``mark``: remember the file
    as pkmlab's (:func:`mark_written`), for a file a user named (a figure, a page) that a later command may replace.
    """
    path = Path(path)
    if path.is_dir():
        raise OutputFileError(f"cannot write {path}: it is a folder; name a file")
    if not make_folder and not path.parent.is_dir():
        raise OutputFileError(f"cannot write {path}: there is no folder {path.parent}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
        if mark:
            mark_written(path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc) or type(exc).__name__


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _written_record(path: Path) -> Path:
    """Where pkmlab remembers the file it wrote at ``path``: a file named after the absolute path, in pkmlab's
    cache folder (beside the compiled kernels' versions, so that it outlives them)."""
    from ._compile_cache import cache_base

    key = hashlib.sha1(str(Path(os.path.abspath(path))).encode()).hexdigest()
    return cache_base() / "written" / key


def mark_written(path: str | os.PathLike) -> None:
    """Remember that pkmlab wrote ``path`` as it is now (the SHA-256 of its content), so that a later command may
    replace it (:func:`written_by_pkmlab`). Best effort: where the cache cannot be written, a later command asks
    for ``--force`` instead."""
    try:
        with atomic_file(_written_record(Path(path))) as tmp:
            tmp.write_text(sha256_of(Path(path)))
    except OSError:
        pass


def written_by_pkmlab(path: str | os.PathLike) -> bool:
    """Whether the file at ``path`` is one pkmlab wrote there, unchanged since (:func:`mark_written`); a symbolic
    link never is (it points at someone's file)."""
    p = Path(path)
    if p.is_symlink() or not p.is_file():
        return False
    try:
        return _written_record(p).read_text().strip() == sha256_of(p)
    except OSError:
        return False


def _entries(folder: Path) -> tuple[list[str], list[str]]:
    """Relative paths of the regular files of ``folder`` and of everything else in it: symbolic links,
    sockets, ... and subfolders that hold no file (a user's, even empty, is theirs). Symbolic links
    are never followed."""
    files, others = [], []

    def unreadable(exc: OSError) -> None:  # a subfolder that cannot be read is not known to be empty
        raise exc

    for root, dirs, names in os.walk(folder, onerror=unreadable, topdown=False):
        for name in names + dirs:
            full = Path(root, name)
            rel = full.relative_to(folder).as_posix()
            if full.is_file() and not full.is_symlink():
                files.append(rel)
            elif full.is_symlink() or not full.is_dir() or not any(f.startswith(rel + "/") for f in files):
                others.append(rel)
    return sorted(files), sorted(others)


def read_manifest(folder: str | os.PathLike) -> dict:
    """The manifest of a result folder, checked against the folder's content.

    Raises :class:`OutputFolderError` naming what does not match: no manifest, a file that is
    not listed (the user's), a listed file missing or changed since pkmlab wrote it.
    """
    folder = Path(folder)
    try:
        manifest = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        listed = dict(manifest["files"])
        if not (isinstance(manifest["command"], str) and isinstance(listed, dict)):
            raise TypeError
        pending = manifest.get("pending")  # a file being added (add_to_result): its temporary, its accepted states
        if pending is not None:
            name, temp, accept = pending["file"], pending["temp"], list(pending["accept"])
            if not (isinstance(name, str) and isinstance(temp, str) and Path(temp).name.startswith(".pending-")):
                raise TypeError
    except FileNotFoundError:
        raise OutputFolderError(f"{folder}: it has no {MANIFEST} (pkmlab did not write it)") from None
    except (OSError, ValueError, KeyError, TypeError):
        raise OutputFolderError(f"{folder}: its {MANIFEST} is not a pkmlab manifest") from None
    try:
        files, others = _entries(folder)
    except OSError as exc:
        raise OutputFolderError(f"{folder}: {exc.filename or 'a subfolder'} cannot be read ({_reason(exc)})") from None
    if pending is not None:
        listed.pop(name, None)
        files = [f for f in files if f not in (name, temp)]  # checked below, as what the addition allows
        if (folder / name).is_symlink() or (folder / temp).is_symlink():
            raise OutputFolderError(f"{folder}: its {name} is a symbolic link")
        state = sha256_of(folder / name) if (folder / name).is_file() else None
        if state not in accept:
            raise OutputFolderError(f"{folder}: its {name} was changed since pkmlab wrote it")
    ours = {name.rsplit("/", k)[0] for name in listed for k in range(1, name.count("/") + 1)}  # listed files' folders
    foreign = [f for f in files if f != MANIFEST and f not in listed] + [
        o for o in others if o not in ours or (folder / o).is_symlink()]
    if foreign:
        shown = ", ".join(foreign[:3]) + (f" and {len(foreign) - 3} more" if len(foreign) > 3 else "")
        raise OutputFolderError(f"{folder}: it holds files pkmlab did not write: {shown}")
    for name, digest in listed.items():
        path = folder / name
        if not path.is_file():
            raise OutputFolderError(f"{folder}: its {name}, listed in {MANIFEST}, is missing")
        if sha256_of(path) != digest:
            raise OutputFolderError(f"{folder}: its {name} was changed since pkmlab wrote it")
    return manifest


def _check_replaceable(out: Path, command: str) -> dict | None:
    """Refuse a target folder that is not empty and is not an unchanged result of ``command``;
    return the manifest of the result it holds (None if empty)."""
    if not any(out.iterdir()):
        return None
    try:
        manifest = read_manifest(out)
    except OutputFolderError as exc:
        reason = str(exc).removeprefix(f"{out}: ")
        raise OutputFolderError(f"cannot write results to {out}: {reason}; pkmlab replaces only a folder of its "
                                "own unchanged results: choose a new or empty folder") from None
    if manifest["command"] != command:
        raise OutputFolderError(f"cannot write results to {out}: it holds the results of `pkmlab "
                                f"{manifest['command']}`, not of `pkmlab {command}`: choose another folder")
    return manifest


def _describe(manifest: dict) -> str:
    prov = manifest.get("provenance")
    details = [f"pkmlab {manifest['command']}"]
    if isinstance(prov, dict):
        details += [f"{prov[k]}" + (" control" if k == "control" else "") for k in ("scenario", "control") if k in prov]
    return ", ".join(details) + f", written {manifest.get('created', '?')}"


def _check_inputs(out: Path, inputs: Iterable) -> None:
    """An input file inside the output folder would be deleted by the replacement: refuse it."""
    target = Path(os.path.realpath(out))
    for item in inputs:
        path = Path(os.path.realpath(item))
        if path == target or target in path.parents:
            raise OutputFolderError(f"cannot write results to {out}: it holds the input {item}, which the "
                                    "results would replace; choose another folder")


def _temp_prefix(out: Path) -> str:
    return f".{out.name}.pkmlab-tmp-"


def _clean_up_after_killed_runs(out: Path, note) -> None:
    """Deal with the temporary folders that earlier runs into ``out`` left when they were killed
    (their process is gone): a half-written result (no manifest) or a complete result that was not
    needed any more is removed; an earlier ``out`` moved aside by a run killed in the middle of its
    two-step swap is put back; anything else is kept beside ``out`` as ``out.previous-*``."""
    pattern = re.compile(re.escape(_temp_prefix(out)) + r"(\d+)-(old-)?")
    try:
        siblings = sorted(out.parent.iterdir())
    except OSError:
        return
    for folder in siblings:
        match = pattern.match(folder.name)
        if not match or folder.is_symlink() or not folder.is_dir() or _alive(int(match.group(1))):
            continue
        if match.group(2) and not out.exists() and not out.is_symlink():
            os.rename(folder, out)  # the earlier result, moved aside when the run was killed
            note(f"restored the earlier results in {out}, moved aside by a run that was killed")
        elif not (folder / MANIFEST).exists() and not match.group(2):
            shutil.rmtree(folder, ignore_errors=True)  # a result killed while being written
        else:
            _dispose_of_old(folder, out, note)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def _warn(message: str) -> None:
    import warnings

    warnings.warn(message, ResultReplacedWarning, stacklevel=4)


@contextlib.contextmanager
def atomic_output_dir(out: str | os.PathLike, command: str, inputs: Iterable = (),
                      provenance: dict | None = None, note=None) -> Iterator[Path]:
    """Yield a temporary folder that becomes ``out`` when the block succeeds.

    ``command`` names what writes the results (``"simulate"``, ``"reproduce"``); it goes into the
    manifest with ``provenance`` (any JSON-able details) and the SHA-256 of every file. An
    existing ``out`` must be empty or an unchanged result of the same command; ``inputs`` (files
    the run reads) must not lie inside it. Everything that makes the target unusable (it is a
    file, its parent is a file, a read-only folder, a folder of the user's files, ...) is reported
    as a one-line :class:`OutputFolderError` before anything is computed; a file the user adds
    while the run writes makes it refuse at the end. An ``OSError`` while writing inside the block
    is reported the same way; an error or Ctrl-C leaves the target as it was and removes the
    temporary folder (and any parent folders made for it). ``note(message)`` is told what else
    happens (an earlier result replaced, ...); by default it is a :class:`ResultReplacedWarning`.
    """
    note = note or _warn
    out = Path(out)
    if out.name in ("", ".", ".."):
        raise OutputFolderError(f"cannot write results to {out}: name a folder to create or replace")
    created: list[Path] = []
    try:
        if out.is_symlink():
            raise OutputFolderError(f"cannot write results to {out}: it is a symbolic link; name the folder itself")
        if out.exists() and not out.is_dir():
            raise OutputFolderError(f"cannot write results to {out}: it exists and is not a folder")
        _check_inputs(out, inputs)
        created = [p for p in (out.parent, *out.parent.parents) if not p.exists()]
        out.parent.mkdir(parents=True, exist_ok=True)
        _clean_up_after_killed_runs(out, note)
        earlier = _check_replaceable(out, command) if out.is_dir() else None
        tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f"{_temp_prefix(out)}{os.getpid()}-"))
    except OSError as exc:
        _remove_empty(created)
        raise OutputFolderError(f"cannot write results to {out}: {_reason(exc)}") from None
    swapped = False  # from then on, `tmp` may hold the earlier `out`: it is never removed unchecked
    try:
        try:
            yield tmp
            _write_manifest(tmp, command, provenance or {})
            umask = _umask()
            for path in tmp.rglob("*"):
                os.chmod(path, (0o777 if path.is_dir() else 0o666) & ~umask)
            os.chmod(tmp, 0o777 & ~umask)
            if out.exists():
                _check_replaceable(out, command)  # again: the run took a while
                old = _swap(tmp, out)
                swapped = True
                _dispose_of_old(old, out, note)
            else:
                os.rename(tmp, out)
                swapped = True
        except OSError as exc:
            raise OutputFolderError(f"cannot write results to {out}: {_reason(exc)}") from None
    finally:
        if not swapped:
            shutil.rmtree(tmp, ignore_errors=True)
            _remove_empty(created)
    if earlier is not None:
        note(f"replaced the earlier results in {out} ({_describe(earlier)})")


def _write_manifest(folder: Path, command: str, provenance: dict) -> None:
    from ._version import __version__

    files, others = _entries(folder)
    if others or MANIFEST in files:
        raise OutputFolderError(f"internal error: a result may hold only regular files, got {others or MANIFEST}")
    manifest = {
        "written_by": "pkmlab",
        "pkmlab_version": __version__,
        "command": command,
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "provenance": provenance,
        "files": {name: sha256_of(folder / name) for name in files},
    }
    (folder / MANIFEST).write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")


def add_to_result(folder: str | os.PathLike, name: str, write) -> Path:
    """Add the file ``name`` to the result folder ``folder`` (``pkmlab view`` adding ``REPORT.html``): the folder
    is checked against its manifest first (refused, naming what does not match, if anything does),
    ``write(tmp)`` writes the file atomically, and the manifest then lists it with its SHA-256 — so the folder
    stays one that its command may replace, at every instant: a kill between the steps leaves the manifest's
    ``pending`` entry, which names the temporary file and the file's accepted states (its old and its new
    content), and which the next addition resolves."""
    folder = Path(folder)
    manifest = read_manifest(folder)
    if "pending" in manifest:  # an addition a kill interrupted: the file is in its old or its new state, both valid
        interrupted = manifest.pop("pending")
        (folder / interrupted["temp"]).unlink(missing_ok=True)
        if (folder / interrupted["file"]).is_file():
            manifest["files"][interrupted["file"]] = sha256_of(folder / interrupted["file"])
        else:
            manifest["files"].pop(interrupted["file"], None)
    # every instant a kill may stop it at leaves a folder read_manifest accepts: the manifest first says which
    # temporary file may exist and which states the file may be in, then each step moves within them
    path = folder / name
    temp = path.parent / f".pending-{path.name}"
    old = manifest["files"].get(name)
    manifest["pending"] = {"file": name, "temp": temp.relative_to(folder).as_posix(),
                           "accept": [old if path.exists() else None]}
    _save_manifest(folder, manifest)
    try:
        write(temp)
        os.chmod(temp, 0o666 & ~_umask())
        new = sha256_of(temp)
        manifest["pending"]["accept"].append(new)
        _save_manifest(folder, manifest)
        os.replace(temp, path)
    except BaseException:  # an error or Ctrl-C: the file in whichever state it reached, listed as such
        temp.unlink(missing_ok=True)
        manifest.pop("pending")
        if path.is_file() and old != sha256_of(path):
            manifest["files"][name] = sha256_of(path)
        _save_manifest(folder, manifest)
        raise
    manifest.pop("pending")
    manifest["files"][name] = new
    _save_manifest(folder, manifest)
    return path


def _save_manifest(folder: Path, manifest: dict) -> None:
    with atomic_file(folder / MANIFEST) as tmp:
        tmp.write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")


# Linux renameat2(2) with RENAME_EXCHANGE swaps two paths atomically; None where unavailable.
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


@functools.cache
def _renameat2():
    with contextlib.suppress(OSError, AttributeError, TypeError):
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        fn = libc.renameat2
        fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
        fn.restype = ctypes.c_int
        return fn
    return None


def _exchange(a: Path, b: Path) -> bool:
    """Swap the paths ``a`` and ``b`` in one atomic step; False where the system cannot."""
    fn = _renameat2()
    if fn is None:
        return False
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (22, 38, 95):  # EINVAL, ENOSYS, EOPNOTSUPP: the file system or kernel cannot exchange
        return False
    raise OSError(err, os.strerror(err))


def _swap(new: Path, out: Path) -> Path:
    """Put the folder ``new`` in the place of the folder ``out``; return where the old one now is.

    One atomic exchange where the system has it; otherwise two renames, the old folder moved
    aside (a ``-old-`` temporary name that a later run puts back if this one is killed between
    the two) and put back if the second fails.
    """
    if _exchange(new, out):
        return new
    old = Path(tempfile.mkdtemp(dir=out.parent, prefix=f"{_temp_prefix(out)}{os.getpid()}-old-"))
    os.rename(out, old)  # onto the empty folder just made: POSIX replaces it
    try:
        os.rename(new, out)
    except BaseException:
        os.rename(old, out)
        raise
    return old


def _dispose_of_old(old: Path, out: Path, note) -> None:
    """Remove the earlier content of ``out``, now at ``old``, if it is empty or an unchanged pkmlab
    result; otherwise (a file added since it was checked, an unreadable one, an interruption) keep it
    beside ``out`` as ``out.previous-TIME`` and say so."""
    try:
        if any(old.iterdir()):
            read_manifest(old)
            shutil.rmtree(old)
        else:
            old.rmdir()
        return
    except BaseException as exc:
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        keep = Path(tempfile.mkdtemp(dir=out.parent, prefix=f"{out.name}.previous-{stamp}-"))
        os.rename(old, keep)
        note(f"{out} changed while the run was writing; its earlier content is kept in {keep}")
        if not isinstance(exc, OutputFolderError):
            raise


def _remove_empty(folders: list[Path]) -> None:
    """Remove the folders this module created (deepest first), if they are still empty."""
    for folder in folders:
        with contextlib.suppress(OSError):
            folder.rmdir()
