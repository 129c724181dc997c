"""Writing a folder of results all at once: it appears complete, or not at all.

:func:`atomic_output_dir` hands out a temporary folder beside the target; the caller writes
everything into it, and only when the ``with`` block finishes without an error is it moved
into place (replacing a previous folder of the same name). An error, or Ctrl-C, removes the
temporary folder — and any parent folders it had to create — so no half-written results are
ever left behind. A folder that holds something other than earlier results is never
replaced. Used by ``pkmlab reproduce`` and ``pkmlab simulate``.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from .errors import PkmlabError


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; when the block succeeds it becomes ``path``.

    The file gets ordinary permissions (``mkstemp`` creates it 0600); on an error the
    temporary file is removed, so no half-written file is ever left.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc) or type(exc).__name__


@contextlib.contextmanager
def atomic_output_dir(out: str | os.PathLike, marker: str = "summary.json") -> Iterator[Path]:
    """Yield a temporary folder that becomes ``out`` when the block succeeds.

    An existing ``out`` is replaced as a whole, so it must be empty or hold earlier results
    (a ``marker`` file): a folder of other files is refused rather than deleted. A target that
    cannot be written (it is a file, its parent is a file, a read-only folder, ...) is reported
    as a one-line :class:`PkmlabError` before anything is computed. An ``OSError`` while
    writing inside the block is reported the same way.
    """
    out = Path(out)
    if out.name in ("", ".", ".."):
        raise PkmlabError(f"cannot write results to {out}: name a folder to create or replace")
    created: list[Path] = []
    try:
        if out.exists() and not out.is_dir():
            raise PkmlabError(f"cannot write results to {out}: it exists and is not a folder")
        if out.is_dir() and not (out / marker).is_file() and any(out.iterdir()):
            raise PkmlabError(f"cannot write results to {out}: it is a folder of other files (it has no "
                              f"{marker}) and would be replaced; choose a new or empty folder")
        created = [p for p in (out.parent, *out.parent.parents) if not p.exists()]
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}-tmp-"))
    except OSError as exc:
        _remove_empty(created)
        raise PkmlabError(f"cannot write results to {out}: {_reason(exc)}") from None
    moved = False
    try:
        try:
            yield tmp
            for path in tmp.rglob("*"):
                os.chmod(path, 0o755 if path.is_dir() else 0o644)
            os.chmod(tmp, 0o755)
            if out.exists():
                _swap(tmp, out)
            else:
                os.replace(tmp, out)
            moved = True
        except OSError as exc:
            raise PkmlabError(f"cannot write results to {out}: {_reason(exc)}") from None
    finally:
        if not moved:
            shutil.rmtree(tmp, ignore_errors=True)
            _remove_empty(created)


def _swap(new: Path, out: Path) -> None:
    """Replace the folder ``out`` by ``new``, putting the old one back if that fails."""
    old = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}-old-"))
    try:
        os.replace(out, old / out.name)
        try:
            os.replace(new, out)
        except BaseException:
            os.replace(old / out.name, out)
            raise
    finally:
        shutil.rmtree(old, ignore_errors=True)


def _remove_empty(folders: list[Path]) -> None:
    """Remove the folders this module created (deepest first), if they are still empty."""
    for folder in folders:
        with contextlib.suppress(OSError):
            folder.rmdir()
