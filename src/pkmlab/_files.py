"""Reading a user's text and TOML files: every failure is one line (:class:`~pkmlab.errors.FileFormatError`)
naming the file, whatever the file holds."""

from __future__ import annotations

import tomllib
from pathlib import Path

from .errors import FileFormatError


def path_text(path: Path) -> str:
    """``path`` as typed, or quoted with escapes if it holds a line break: a message stays one line."""
    text = str(path)
    return text if text.isprintable() else repr(text)


def read_text(path: Path) -> str:
    """The UTF-8 text of a file; every failure is a one-line :class:`FileFormatError`.

    A UTF-8 byte-order mark (which some editors write) is skipped; a file in another encoding is
    refused for that reason, with the line of the first byte that is not UTF-8.
    """
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise FileFormatError(f"cannot read {path_text(path)}: no such file") from None
    except IsADirectoryError:
        raise FileFormatError(f"cannot read {path_text(path)}: it is a directory") from None
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        reason = exc.strerror if isinstance(exc, OSError) else exc
        raise FileFormatError(f"cannot read {path_text(path)}: {reason}") from None
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise FileFormatError(f"cannot read {path_text(path)}: it is UTF-16 text; save it as UTF-8")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise FileFormatError(f"cannot read {path_text(path)}: not UTF-8 text (byte 0x{data[exc.start]:02x} at "
                              f"line {line}); save it as UTF-8") from None


def read_toml(path: str | Path) -> dict:
    """Parse a TOML file, turning every failure into a one-line :class:`FileFormatError`."""
    return parse_toml(read_text(Path(path)), path)


def parse_toml(text: str, source: str | Path) -> dict:
    """Parse TOML ``text`` read from ``source`` (named in the one-line :class:`FileFormatError`)."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise FileFormatError(f"{path_text(Path(source))}: malformed TOML: {exc}") from None
    except RecursionError:
        raise FileFormatError(f"{path_text(Path(source))}: malformed TOML: arrays or tables nested too deeply"
                              ) from None
