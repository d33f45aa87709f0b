"""What the ingest found in the data (:class:`Finding`) and how times are written in it.

The record type every ingest module and the measured window share; it imports nothing of
the ingest, so none of them import each other through it.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

from pier_monitor.core.errors import InputDataError

__all__ = ["ACTIONS", "NS_PER_S", "Finding", "fmt_time", "fmt_span"]

#: Nanoseconds per second (times at the I/O boundaries are integer ns since the Unix epoch).
NS_PER_S = 1_000_000_000

#: What a finding did to the data: ``repaired`` (samples restored, the sensor still used),
#: ``excluded`` (the sensor or channel not used over the finding's span), ``noted``
#: (nothing changed, e.g. a direction estimated) or ``failed`` (an event gave no window).
ACTIONS = ("repaired", "excluded", "noted", "failed")


@dataclass(frozen=True)
class Finding:
    """One thing the ingest found in the data, and what it did about it.

    Attributes
    ----------
    code : str
        What was found, e.g. ``glitch``, ``gap_excluded``, ``frozen``, ``inconsistent``,
        ``rate_mismatch``, ``event_cut`` (see the package README for the list).
    where : str
        Sensor id, ``<sensor id>.<axis>`` for one channel, ``level <n>``, an event id, a
        topic or the bag.
    message : str
        What was found and done, naming the sensor and the time (UTC).
    start_ns, end_ns : int
        Span of data the finding concerns, ns since the Unix epoch (``end_ns`` inclusive).
    action : str
        One of :data:`ACTIONS`.
    """

    code: str
    where: str
    message: str
    start_ns: int
    end_ns: int
    action: str = "noted"

    def __post_init__(self) -> None:
        if self.action not in ACTIONS:
            raise InputDataError(f"finding {self.code}: action must be one of {ACTIONS}, got "
                                 f"{self.action!r}")
        if self.end_ns < self.start_ns:
            raise InputDataError(f"finding {self.code} at {self.where}: end {self.end_ns} ns "
                                 f"before start {self.start_ns} ns")

    @property
    def sensor_id(self) -> str:
        """The sensor part of :attr:`where` (``where`` without ``.<axis>``)."""
        return self.where.split(".", 1)[0]

    def overlaps(self, start_ns: int, end_ns: int) -> bool:
        """Whether the finding's span meets ``[start_ns, end_ns]``."""
        return self.start_ns <= end_ns and self.end_ns >= start_ns

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form; :meth:`from_dict` reads it back."""
        return {"code": self.code, "where": self.where, "action": self.action,
                "message": self.message, "start_ns": self.start_ns, "end_ns": self.end_ns}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Finding":
        """Inverse of :meth:`as_dict`."""
        return cls(code=d["code"], where=d["where"], message=d["message"],
                   start_ns=int(d["start_ns"]), end_ns=int(d["end_ns"]),
                   action=d.get("action", "noted"))

    def __str__(self) -> str:
        return f"{self.where}: {self.code}: {self.message}"


def fmt_time(t_ns: int) -> str:
    """UTC time of ``t_ns`` (ns since the Unix epoch) to the millisecond."""
    t_ns = int(t_ns)
    try:
        stamp = datetime.fromtimestamp(t_ns // NS_PER_S, tz=timezone.utc)
    except (OverflowError, ValueError, OSError):  # beyond the calendar: the number itself
        return f"{t_ns} ns"
    return f"{stamp.strftime('%Y-%m-%dT%H:%M:%S')}.{(t_ns % NS_PER_S) // 1_000_000:03d}Z"


def fmt_span(start_ns: int, end_ns: int) -> str:
    """``<UTC start> for <duration> s``."""
    return f"{fmt_time(start_ns)} for {(int(end_ns) - int(start_ns)) / NS_PER_S:.2f} s"
