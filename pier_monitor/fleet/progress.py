"""Progress of a fleet run: a bar over events on a terminal, a line per event in a log."""

from __future__ import annotations

import sys
from typing import TextIO

from tqdm import tqdm

__all__ = ["FleetProgress"]


class FleetProgress:
    """Counts of a fleet run, drawn as they change.

    On a terminal a tqdm bar over the events known so far (bags are ingested as the run
    goes, so the total grows) with the counts done, failed and remaining; off a terminal one
    line per finished event.  Use it as a context manager, or call :meth:`close`.

    Parameters
    ----------
    stream : file, optional
        Where to write (default: standard error).
    tty : bool, optional
        Draw a bar (True) or write lines (False); default: whether ``stream`` is a terminal.
    """

    def __init__(self, stream: TextIO | None = None, *, tty: bool | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(self.stream.isatty()) if tty is None else tty
        self.total = 0
        self.done = 0
        self.failed = 0
        self.skipped = 0
        self._bar = tqdm(total=0, desc="fleet", unit="event", file=self.stream,
                         dynamic_ncols=True) if self.tty else None

    @property
    def remaining(self) -> int:
        """Events known and not finished yet."""
        return self.total - self.done - self.failed - self.skipped

    def add(self, events: int, skipped: int = 0) -> None:
        """``events`` more events are known, ``skipped`` of them done in an earlier run."""
        self.total += events
        self.skipped += skipped
        self._draw(skipped)

    def finished(self, event_id: str, state: str, success: bool, message: str = "") -> None:
        """An event ended (identified, or failed with ``message``)."""
        if success:
            self.done += 1
        else:
            self.failed += 1
        if self._bar is None:
            what = state if success else f"FAILED: {message}"
            self._write(f"[{self.done + self.failed + self.skipped}/{self.total}] {event_id}: "
                        f"{what} (done {self.done}, failed {self.failed}, remaining "
                        f"{self.remaining})")
        self._draw(1)

    def note(self, line: str) -> None:
        """A line of its own (e.g. a bag that cannot be read)."""
        if self._bar is not None:
            self._bar.write(line, file=self.stream)
        else:
            self._write(line)

    def _draw(self, advance: int) -> None:
        if self._bar is None:
            return
        self._bar.total = self.total
        self._bar.set_postfix(done=self.done, failed=self.failed, skipped=self.skipped,
                              remaining=self.remaining, refresh=False)
        self._bar.update(advance)

    def _write(self, line: str) -> None:
        self.stream.write(line + "\n")
        self.stream.flush()

    def close(self) -> None:
        """End the bar."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> FleetProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
