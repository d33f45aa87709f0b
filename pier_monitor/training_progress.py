"""Training progress on the command line: a bar on a terminal, a line now and then in a log.

A tqdm bar redraws several times a second; written to a file (CI, a service, ``nohup``) every
redraw is a line of its own.  :class:`TrainingProgress` draws the bar only when its stream
is a terminal; otherwise it writes one plain line when an event starts, one every
``interval_s`` while it trains, and one when it ends.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

from tqdm import tqdm

from pier_monitor.core.identify.methods import Progress

__all__ = ["TrainingProgress"]


class TrainingProgress:
    """``progress(event_id, Progress)`` callback of :func:`pier_monitor.pipeline.identify_bag`.

    Parameters
    ----------
    stream : file, optional
        Where to write (default: standard error).
    interval_s : float
        Off a terminal, the time between two progress lines, s.
    tty : bool, optional
        Draw a bar (True) or write lines (False); default: whether ``stream`` is a terminal.
    clock : callable
        Monotonic clock in seconds (replaceable in tests).

    Use it as a context manager, or call :meth:`close` at the end: it ends the last bar
    or writes the last line.
    """

    def __init__(self, stream: TextIO | None = None, *, interval_s: float = 10.0,
                 tty: bool | None = None, clock: Callable[[], float] = time.monotonic) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(self.stream.isatty()) if tty is None else tty
        self.interval_s = interval_s
        self._clock = clock
        self._event = ""
        self._last: Progress | None = None
        self._printed_at = 0.0
        self._bar: tqdm | None = None

    def __call__(self, event_id: str, p: Progress) -> None:
        if event_id != self._event:
            self._end_event()
            self._event = event_id
            self._start_event(p)
        self._last = p
        if self._bar is not None:
            self._bar.update(p.epoch - self._bar.n)
            if p.epoch % 25 == 0:
                self._bar.set_postfix(loss=f"{p.loss:.3g}", k1_1=f"{p.k1[0]:.4g}")
        elif self._clock() - self._printed_at >= self.interval_s:
            self._line(p)

    def close(self) -> None:
        """End the current event's bar or write its last line."""
        self._end_event()
        self._event = ""

    def __enter__(self) -> TrainingProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _start_event(self, p: Progress) -> None:
        if self.tty:
            self._bar = tqdm(total=p.max_epochs, desc=f"training {self._event}", unit="epoch",
                             file=self.stream, leave=False)
        else:
            self._write(f"training {self._event}: up to {p.max_epochs} epochs")
            self._printed_at = self._clock()

    def _end_event(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self._event and self._last is not None:
            self._line(self._last, done=True)
        self._last = None

    def _line(self, p: Progress, done: bool = False) -> None:
        state = "done after" if done else "epoch"
        self._write(f"training {self._event}: {state} {p.epoch}/{p.max_epochs}, loss "
                    f"{p.loss:.3g}, k1 of section 1 {p.k1[0]:.4g} N*m/rad, "
                    f"{p.elapsed_s:.0f} s")
        self._printed_at = self._clock()

    def _write(self, line: str) -> None:
        self.stream.write(line + "\n")
        self.stream.flush()
