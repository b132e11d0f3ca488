"""The one progress display of every long command: stage lines and a bar on stderr.

Layer 0 (support).  :class:`Progress` is what ``check``, ``excite``, ``identify``, ``track``,
``montecarlo`` and the identification demo draw: ``progress(done, total)`` redraws one line,
``[####------] 3/10 runs  1.2 s, 2.5 runs/s, 2.8 s left``, at most every
:data:`REDRAW_SECONDS` (the first and the last call always draw), and ``progress.stage(text)``
writes one line ``[   1.2 s] text`` with the time since the start.  Shown only when the stream
is a terminal, unless forced (``enabled=True``, ``--progress``); never on a pipe by default,
so logs and captured output stay clean.  Plain text: no dependency (tqdm or rich would add one
for no more than this line).
"""

from __future__ import annotations

import sys
import time

__all__ = ["Progress", "REDRAW_SECONDS"]

#: shortest time between two redraws of a bar, s (a fast loop would otherwise spend its time writing)
REDRAW_SECONDS = 0.1


def _duration(s: float) -> str:
    """``s`` seconds as ``12.3 s``, ``4 min 05 s`` or ``2 h 03 min``."""
    if s < 60:
        return f"{s:.1f} s"
    if s < 3600:
        return f"{int(s // 60)} min {int(s % 60):02d} s"
    return f"{int(s // 3600)} h {int(s % 3600 // 60):02d} min"


class Progress:
    """A progress display on ``stream`` (stderr): ``progress(done, total)`` draws a one-line bar with
    the rate and the time left; ``progress.stage(text)`` writes a line with the elapsed time.

    ``label``: the bar's name; ``enabled``: True draws, False is silent, None (the default) draws
    when ``stream`` is a terminal; ``unit``: what is counted; ``width``: the bar's characters.
    """

    def __init__(self, label: str = "", enabled: bool | None = None, width: int = 30, unit: str = "states",
                 stream=None, clock=time.perf_counter):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.label, self.enabled, self.width, self.unit, self.clock = label, bool(enabled), width, unit, clock
        self.t0 = clock()
        self._drawn = None           # (done, total, time) of the last redraw
        self._length = 0             # characters of the last line drawn

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        now = self.clock()
        last = self._drawn
        if last is not None and (done, total) == last[:2]:
            return
        final = total and done >= total
        if last is not None and not final and now - last[2] < REDRAW_SECONDS:
            return                   # throttled: the next call (or the last one) draws
        self._drawn = (done, total, now)
        frac = min(1.0, done / total) if total else 1.0
        fill = int(self.width * frac)
        el = now - self.t0
        line = f"\r{self.label:<16} [{'#' * fill}{'-' * (self.width - fill)}] {done}/{total} {self.unit}  {el:5.1f} s"
        if done > 0 and el > 0:
            rate = done / el
            line += f", {rate:.3g} {self.unit}/s"
            if not final:
                line += f", {_duration((total - done) / rate)} left"
        pad = max(0, self._length - len(line))      # clear what a longer line left behind
        self._length = len(line)
        self.stream.write(line + " " * pad + ("\n" if final else ""))
        self.stream.flush()

    def stage(self, text: str) -> None:
        """One line ``[elapsed] text`` (a stage of the work begins)."""
        if self.enabled:
            self.stream.write(f"[{self.clock() - self.t0:6.1f} s] {text}\n")
            self.stream.flush()
