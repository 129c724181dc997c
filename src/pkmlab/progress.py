"""A tiny progress bar for long command-line jobs, drawn on stderr.

``Progress(total, label, enabled)`` redraws ``\\r[########............]  42% label`` as
:meth:`Progress.update` is called, and ends the line on :meth:`Progress.close` (or at the end
of a ``with`` block). With ``unit`` it also shows the count, the rate and the time left
(``1200/2000 runs  96.4 runs/s  ETA 0:08``). It stays silent when ``enabled`` is false (``--quiet``) or when the
stream is not a terminal, so logs and pipes never receive carriage returns.

>>> import io
>>> with Progress(3, "frames", stream=io.StringIO()) as bar:  # not a terminal: silent
...     bar.update(3)
>>> bar.count
3
"""

from __future__ import annotations

import sys
import time


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
                 unit: str | None = None):
        self.total = max(int(total), 0)
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.width = int(width)
        self.count = 0
        self.active = bool(enabled) and self.total > 0 and _is_terminal(self.stream)
        self.unit = unit
        self._shown = -1
        self._closed = False
        self._start = self._drawn = time.monotonic()
        self._draw()

    def _draw(self) -> None:
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
        elapsed = now - self._start
        rate = self.count / elapsed if elapsed > 0 else 0.0
        left = (self.total - self.count) / rate if rate > 0 else None
        eta = "--:--" if left is None else f"{int(left) // 60}:{int(left) % 60:02d}"
        return f"  {self.count}/{self.total} {self.unit}  {rate:.1f} {self.unit}/s  ETA {eta}   "

    def update(self, n: int = 1) -> None:
        """Advance by ``n`` steps and redraw if the percentage changed."""
        self.count += int(n)
        self._draw()

    def close(self) -> None:
        """End the bar's line (once), so later messages start on a line of their own."""
        if self.active and not self._closed:
            self.stream.write("\n")
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
