"""Settings, report and error type of the ingest (SI units; names carry them)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.recording import NS_PER_S

__all__ = ["IngestError", "IngestSettings", "IngestReport", "fmt_time"]


class IngestError(InputDataError):
    """The recording cannot give a window (e.g. a level without any usable sensor)."""


@dataclass(frozen=True)
class IngestSettings:
    """Settings of the ingest (SI units; names carry them).

    Attributes
    ----------
    output_rate_hz : float
        Rate of the emitted windows (the identifier's data rate).
    short_gap_s : float
        Gaps up to this long are interpolated; longer ones exclude the sensor from windows
        that overlap them.
    trigger_window_s : float
        Length of the causal moving RMS of the foundation acceleration.
    trigger_floor_mps2 : float
        Absolute floor of the trigger threshold, m/s².
    trigger_noise_factor : float
        The threshold is at least this many times the foundation accelerometers' noise.
    merge_gap_s : float
        Triggers closer than this belong to one event; an event ends once the RMS has stayed
        below the threshold for this long.
    min_event_s : float
        Shorter triggered spans are not events.
    arias_bounds : tuple of float
        Shares of the event's Arias intensity that bound the window before padding.
    pad_s : float
        Padding of the window on each side, s.
    context_s : float
        Data kept on each side of the window for bias removal and fusion, s.
    principal_direction_deg : float or None
        Overrides the configuration's direction; None = configuration, else estimate.
    highpass_hz : float
        Levels with accelerometers but no displacement sensor get velocities and
        displacements integrated from their acceleration, high-passed at this frequency
        (their content below it is not measured), Hz.
    gain_rel : float
        Relative 1-sigma uncertainty of the sensors' gains that the configuration does not
        state (field sensors: about 1 %); carried to the identifier in the noise model.
    """

    output_rate_hz: float = 100.0
    short_gap_s: float = 0.05
    trigger_window_s: float = 1.0
    trigger_floor_mps2: float = 0.05
    trigger_noise_factor: float = 10.0
    merge_gap_s: float = 5.0
    min_event_s: float = 3.0
    arias_bounds: tuple[float, float] = (0.01, 0.99)
    pad_s: float = 2.0
    context_s: float = 10.0
    principal_direction_deg: float | None = None
    highpass_hz: float = 0.05
    gain_rel: float = 0.01


@dataclass
class IngestReport:
    """What the ingest did: every exclusion, repair and check, by sensor and time.

    ``events`` holds ``(code, sensor_or_level, message)`` tuples; ``checks`` numbers such as
    the velocity-meter comparison.
    """

    events: list[tuple[str, str, str]] = field(default_factory=list)
    checks: dict[str, Any] = field(default_factory=dict)

    def add(self, code: str, where: str, message: str) -> None:
        """Record one finding."""
        self.events.append((code, where, message))

    def codes(self, where: str | None = None) -> list[str]:
        """Codes recorded (for one sensor/level, or all)."""
        return [c for c, w, _ in self.events if where is None or w == where]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"events": [{"code": c, "where": w, "message": m} for c, w, m in self.events],
                "checks": self.checks}


def fmt_time(t_ns: int) -> str:
    return f"t = {t_ns / NS_PER_S:.3f} s"
