"""Settings, findings, report and error types of the ingest (SI units; names carry them)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.findings import Finding

if TYPE_CHECKING:  # pragma: no cover
    from pier_monitor.core.ingest.window import MeasuredWindow

__all__ = ["IngestError", "LevelUnusableError", "IngestSettings", "EventIngest",
           "IngestReport"]

class IngestError(InputDataError):
    """The recording cannot give a window (e.g. a level without any usable sensor)."""


class LevelUnusableError(IngestError):
    """A level has no usable channel of a kind (or only one direction) over a span.

    Attributes
    ----------
    level : int
        The level (0 = foundation).
    kind : str
        ``acceleration``, ``displacement`` or ``velocity``.
    """

    def __init__(self, message: str, level: int, kind: str) -> None:
        super().__init__(message)
        self.level = level
        self.kind = kind


@dataclass(frozen=True)
class IngestSettings:
    """Settings of the ingest (SI units; names carry them).

    Attributes
    ----------
    output_rate_hz : float
        Rate of the emitted windows (the identifier's data rate).
    short_gap_s : float
        Gaps (and glitches, out-of-range stretches) up to this long are interpolated;
        longer ones exclude the channel from windows that overlap them.
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
    glitch_threshold : float
        A sample is a glitch when it departs from what its neighbours predict by more than
        this many robust standard deviations (local, per second of data, never below the
        configured noise): the other accelerometers of its level for an accelerometer, its
        own neighbouring samples' increments for a displacement or velocity sensor.
    glitch_rel : float
        An accelerometer sample must also depart from the prediction by this share of the
        prediction: gain and alignment differences between sensors are not glitches.
    glitch_max_s : float
        A jump and a jump back within this time bound one glitch; a lone jump of a
        displacement or velocity sensor is an offset jump and is removed.
    frozen_s : float
        A channel that repeats exactly the same value for this long is frozen there.
    disagree_rel : float
        A sensor whose residual against the other sensors of its level exceeds this share of
        the signal (and several times its noise) is excluded there: accelerometers against
        the other accelerometers, per second; displacement sensors against the level's
        acceleration integrated twice, per event.
    partial_after_peak_s : float
        When the data end while the ground still shakes (a truncated bag, a station that lost
        power), the recorded part of the event becomes a *partial* window if it holds the
        strong motion: its largest horizontal foundation acceleration lies at least this
        long before the end of the data, s, and the shaking has decayed since (see
        ``partial_decay``); otherwise the event is cut and has no window.
    partial_decay : float
        ... the foundation's RMS over the last ``partial_after_peak_s`` of data is at most
        this share of its RMS over as long centred on that peak.  On a long plateau of
        strong shaking the largest sample so far says nothing about the peak to come: the
        RMS has not decayed, and the event stays cut.
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
    glitch_threshold: float = 10.0
    glitch_rel: float = 0.2
    glitch_max_s: float = 1.0
    frozen_s: float = 0.25
    disagree_rel: float = 0.2
    partial_after_peak_s: float = 5.0
    partial_decay: float = 0.5


@dataclass(frozen=True, eq=False)
class EventIngest:
    """What the ingest made of one detected event.

    Attributes
    ----------
    event_id : str
    start_ns, end_ns : int
        The event's window span at the sensor rate, ns since the Unix epoch.
    window : MeasuredWindow or None
        The window, or None when the event failed.
    failure : str or None
        Why there is no window, naming the level, sensors, times and causes.
    status : str
        ``ingested``; ``partial`` (the data end during the event, but after its strong
        motion: a window of the recorded part, see ``partial``); ``cut`` (the data begin or
        end during the event, no window) or ``failed``.
    findings : tuple of Finding
        The findings about the data of this event (its window and context).
    partial : str or None
        Why the event is partial (where the data end, where the peak lies); None for a
        complete event.  The window's ``report["partial"]`` holds the same reason.
    """

    event_id: str
    start_ns: int
    end_ns: int
    window: MeasuredWindow | None
    failure: str | None = None
    status: str = "ingested"
    findings: tuple[Finding, ...] = ()
    partial: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (without the window's arrays); ``partial`` is
        ``{"reason": ...}`` or None."""
        return {"event_id": self.event_id, "status": self.status, "start_ns": self.start_ns,
                "end_ns": self.end_ns, "failure": self.failure,
                "partial": None if self.partial is None else {"reason": self.partial},
                "findings": [f.as_dict() for f in self.findings]}


@dataclass
class IngestReport:
    """What the ingest did: every exclusion, repair and check, by sensor and time.

    ``findings`` holds :class:`Finding` objects in the order found; ``outcomes`` one
    :class:`EventIngest` per detected event; ``checks`` numbers such as the velocity-meter
    comparison.
    """

    findings: list[Finding] = field(default_factory=list)
    outcomes: list[EventIngest] = field(default_factory=list)
    checks: dict[str, Any] = field(default_factory=dict)

    def add(self, code: str, where: str, message: str, start_ns: int, end_ns: int,
            action: str = "noted") -> Finding:
        """Record one finding and return it."""
        finding = Finding(code, where, message, int(start_ns), int(end_ns), action)
        self.findings.append(finding)
        return finding

    def codes(self, where: str | None = None) -> list[str]:
        """Codes recorded for a sensor (its channels included), a channel, or all."""
        return [f.code for f in self.findings
                if where is None or f.where == where or f.sensor_id == where]

    def about(self, where: str) -> list[Finding]:
        """Findings of a sensor (its channels included) or a channel."""
        return [f for f in self.findings if f.where == where or f.sensor_id == where]

    def within(self, start_ns: int, end_ns: int) -> list[Finding]:
        """Findings whose span meets ``[start_ns, end_ns]``."""
        return [f for f in self.findings if f.overlaps(start_ns, end_ns)]

    @property
    def failed(self) -> list[EventIngest]:
        """Events without a window."""
        return [o for o in self.outcomes if o.window is None]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"findings": [f.as_dict() for f in self.findings],
                "outcomes": [o.as_dict() for o in self.outcomes], "checks": self.checks}
