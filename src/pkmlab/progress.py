"""A tiny progress bar for long command-line jobs, drawn on stderr.

``Progress(total, label, enabled)`` redraws ``\\r[########............]  42% label`` as
:meth:`Progress.update` is called, and ends the line on :meth:`Progress.close` (or at the end
of a ``with`` block). With ``unit`` it also shows the count, the rate and the time left
(``1200/2000 runs  96.4 runs/s  ETA 0:08``). On a stream that is no terminal (a CI log, a pipe, a file) it
draws no bar — logs never receive carriage returns — but a job that lasts says how far it is in a whole line
every :data:`STATUS_EVERY` seconds (``pkmlab: sweep: 42% (840/2000 runs, ETA 0:12)``), and that it is done
if it said anything before; a short job stays silent. ``enabled=False`` (``--quiet``) silences both.

>>> import io
>>> with Progress(3, "frames", stream=io.StringIO()) as bar:  # not a terminal, and quick: silent
...     bar.update(3)
>>> bar.count
3
"""

from __future__ import annotations

import sys
import time

#: Seconds between two status lines of a job on a stream that is no terminal.
STATUS_EVERY = 10.0


def _clock(seconds: float) -> str:
    return f"{int(seconds) // 60}:{int(seconds) % 60:02d}"


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # no isatty, or a closed stream
        return False


class Progress:
    """Progress of ``total`` steps of a job named ``label``.

    Parameters
    ----------
    total : int
        Number of steps; the bar is full after ``total`` calls of ``update()``.
    label : str
        Shown after the percentage.
    enabled : bool
        ``False`` silences the bar (``--quiet``).
    stream : file-like, optional
        Where to draw (default ``sys.stderr``); nothing is drawn unless ``stream.isatty()``.
    width : int
        Number of cells of the bar.
    unit : str, optional
        The steps' name: the bar then shows the count, the rate (steps per second since it was created)
        and the estimated time left, redrawn at least every second.
    """

    def __init__(self, total: int, label: str = "", enabled: bool = True, stream=None, width: int = 30,
                 unit: str | None = None, status_every: float = STATUS_EVERY):
        self.total = max(int(total), 0)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.width = int(width)
        self.count = 0
        terminal = _is_terminal(self.stream)
        self.active = bool(enabled) and self.total > 0 and terminal
        self.status = bool(enabled) and self.total > 0 and not terminal  # whole status lines instead of a bar
        self.status_every = float(status_every)
        self._said = None  # the percentage of the last status line
        self.unit = unit
        self._shown = -1
        self._closed = False
        self._start = self._drawn = time.monotonic()
        self._draw()

    def _status(self, now: float) -> None:
        percent = min(100, int(100 * self.count / self.total))
        if percent == self._said or now - self._drawn < self.status_every:
            return
        self._said, self._drawn = percent, now
        counted = f" ({self.count}/{self.total} {self.unit}{self._eta(now)})" if self.unit else ""
        self.stream.write(f"pkmlab: {self.label}: {percent}%{counted}\n")
        self.stream.flush()

    def _eta(self, now: float) -> str:
        _rate, left = self._speed(now)
        return "" if left is None else f", ETA {_clock(left)}"

    def _draw(self) -> None:
        if self.status and not self._closed:
            self._status(time.monotonic())
        if not self.active or self._closed:
            return
        percent = min(100, int(100 * self.count / self.total))
        now = time.monotonic()
        if percent == self._shown and (self.unit is None or now - self._drawn < 1.0):
            return
        self._shown, self._drawn = percent, now
        filled = min(self.width, self.width * self.count // self.total)
        self.stream.write(f"\r[{'#' * filled}{'.' * (self.width - filled)}] {percent:3d}% {self.label}"
                          + self._rate(now))
        self.stream.flush()

    def _rate(self, now: float) -> str:
        if self.unit is None:
            return ""
        rate, left = self._speed(now)
        eta = "--:--" if left is None else _clock(left)
        return f"  {self.count}/{self.total} {self.unit}  {rate:.1f} {self.unit}/s  ETA {eta}   "

    def _speed(self, now: float) -> tuple[float, float | None]:
        """Steps per second so far, and the seconds left at that rate (None before the first step)."""
        elapsed = now - self._start
        rate = self.count / elapsed if elapsed > 0 else 0.0
        return rate, ((self.total - self.count) / rate if rate > 0 else None)

    def update(self, n: int = 1) -> None:
        """Advance by ``n`` steps and redraw if the percentage changed."""
        self.count += int(n)
        self._draw()

    def close(self) -> None:
        """End the bar's line (once), so later messages start on a line of their own."""
        if self.active and not self._closed:
            self.stream.write("\n")
            self.stream.flush()
        if self.status and not self._closed and self._said is not None and self._said < 100:
            ended = "done" if self.count >= self.total else f"stopped at {min(100, 100 * self.count // self.total)}%"
            self.stream.write(f"pkmlab: {self.label}: {ended} ({self.count}/{self.total}"
                              f"{' ' + self.unit if self.unit else ''})\n")
            self.stream.flush()
        self._closed = True

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def notice(message: str, stream=None) -> None:
    """Say ``message`` as one line on stderr (or ``stream``), terminal or not — a log, a pipe and a notebook's cell
    see it too: what takes time while it happens and happens once (a machine structure's first derivation, a
    first solve that pkmlab keeps)."""
    print(f"pkmlab: {message}", file=sys.stderr if stream is None else stream, flush=True)
