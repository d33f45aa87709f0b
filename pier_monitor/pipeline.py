"""Offline identification of a bag: read → ingest → one event at a time (SPEC §8).

``identify_bag`` is what ``pier-monitor identify BAG`` runs.  Every event the ingest detects
gets an outcome of its own, and one event's failure never costs another its result:

* an event with a window goes through :func:`pier_monitor.events.identify_window`, the step
  the live identifier node runs as well, into ``<out>/<event_id>/`` with ``window.npz``
  (stored before training starts, so that a crash loses no event), ``damage_state.mcap``,
  the figures and ``result.json`` — identified, or *unreliable* when the result failed its
  self-check, or ``failed.json`` when the training failed;
* an event the ingest could give no window of (a level left without usable sensors, the data
  ending during it) gets ``<out>/<event_id>/failed.json`` with the ingest's reason, naming
  the level, sensors, time and cause.

Reading a bag into its events is :func:`read_bag_events`, the one step ``identify_bag`` and a
fleet's ingest task (:func:`pier_monitor.fleet.tasks.ingest_bag`) share: each detected event
comes back with its window or, without one, its failure record.

Events are identified in time order; the baseline of each is the earliest earlier reliable
result of the same pier in ``out`` (:class:`~pier_monitor.store.ResultsStore`): in an
empty directory, the first event of the bag.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pier_monitor.bags import read_bag
from pier_monitor.core.errors import BagError, PierMonitorError
from pier_monitor.core.identify.damage import (IdentificationResult, failed_event_result,
                                               failed_result)
from pier_monitor.core.ingest import IngestReport, IngestSettings, ingest_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording
from pier_monitor.core.ingest.settings import EventIngest
from pier_monitor.core.ingest.findings import Finding
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.config import PierConfig
from pier_monitor.events import EventOutcome, identify_window
from pier_monitor.core.identify.methods import IdentifySettings, Progress
from pier_monitor.store import ResultsStore

__all__ = ["BagEvent", "BagEvents", "BagOutcome", "identify_bag", "read_bag_events"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class BagEvent:
    """One detected event of a bag: its window, or why it has none.

    Attributes
    ----------
    ingest : EventIngest
        What the ingest made of the event (its window, findings, status).
    failure : IdentificationResult or None
        For an event the ingest gave no window of (failed, or cut by the end of the data):
        its failure record (``success`` false, every section ``unknown``, the ingest's
        reason in ``message``), to be written as its ``failed.json``; None with a window.
    """

    ingest: EventIngest
    failure: IdentificationResult | None = None

    @property
    def event_id(self) -> str:
        return self.ingest.event_id

    @property
    def window(self) -> MeasuredWindow | None:
        return self.ingest.window


@dataclass(frozen=True)
class BagEvents:
    """A bag read and ingested (:func:`read_bag_events`): every detected event, in time order.

    Attributes
    ----------
    bag : Path
    pier_id : str
        The pier of the bag's configuration.
    events : tuple of BagEvent
        One per detected event: its window or its failure record.
    ingest_report : IngestReport
        Every finding of the ingest, by sensor and time.
    bag_findings : tuple of Finding
        What reading the bag found (e.g. ``bag_truncated``: where its data end).
    """

    bag: Path
    pier_id: str
    events: tuple[BagEvent, ...]
    ingest_report: IngestReport
    bag_findings: tuple[Finding, ...] = ()

    @property
    def windows(self) -> tuple[MeasuredWindow, ...]:
        """The windows of the events that have one, in time order."""
        return tuple(ev.window for ev in self.events if ev.window is not None)


def read_bag_events(bag: str | Path, *, config: PierConfig | None = None,
                    ingest_settings: IngestSettings | None = None) -> BagEvents:
    """Read a bag, find its events, and give each event its window or its failure record.

    The one reading of a bag into events, for ``pier-monitor identify``
    (:func:`identify_bag`) and for a fleet's ingest task: an event with a window is to be
    identified, an event without one is recorded as failed (its ``failed.json``, built here
    by :func:`~pier_monitor.core.identify.damage.failed_event_result` with the ingest's
    reason, naming the level, sensors, time and cause).

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory or a plain ``.mcap`` file.
    config : PierConfig, optional
        Pier configuration to use instead of the one in the bag.
    ingest_settings : IngestSettings, optional

    Raises
    ------
    BagError
        The bag cannot be read, or holds no samples of the configuration's sensors (a pier
        id that does not match the bag's topics is named as such).
    IngestError
        Nothing of the bag can be ingested.
    """
    bag = Path(bag)
    recording = read_bag(bag, config=config)
    if not recording.sensors:
        raise _no_samples(bag, recording)
    _, report = ingest_recording(recording, ingest_settings)
    events = tuple(BagEvent(ingest, None if ingest.window is not None
                            else _ingest_failure(ingest, recording))
                   for ingest in report.outcomes)
    return BagEvents(bag=bag, pier_id=recording.config.pier_id, events=events,
                     ingest_report=report, bag_findings=recording.findings)


@dataclass(frozen=True)
class BagOutcome:
    """Everything ``identify_bag`` did with one bag.

    Attributes
    ----------
    bag : Path
    events : tuple of EventOutcome
        One per detected event, in time order (identified, unreliable, failed or cut).
    ingest_report : IngestReport
        Every finding of the ingest, by sensor and time.
    bag_findings : tuple of Finding
        What reading the bag found (e.g. ``bag_truncated``: where its data end).
    """

    bag: Path
    events: tuple[EventOutcome, ...]
    ingest_report: IngestReport
    bag_findings: tuple[Finding, ...] = ()

    def with_status(self, *statuses: str) -> list[EventOutcome]:
        """The events whose :attr:`EventOutcome.status` is one of ``statuses``."""
        return [ev for ev in self.events if ev.status in statuses]


def identify_bag(bag: str | Path, out_dir: str | Path, *, settings: IdentifySettings | None = None,
                 ingest_settings: IngestSettings | None = None,
                 config: PierConfig | None = None,
                 progress: Callable[[str, Progress], None] | None = None,
                 figures: bool = True) -> BagOutcome:
    """Identify every event of a bag and write one results directory per event.

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory or a plain ``.mcap`` file written by pier_monitor (or with the
        same topics and the configuration inside).
    out_dir : str or Path
        Results root (a :class:`~pier_monitor.store.ResultsStore`); created when
        missing.
    settings : IdentifySettings, optional
        Identification settings (default: the benchmarked ones).
    ingest_settings : IngestSettings, optional
    config : PierConfig, optional
        Pier configuration to use instead of the one in the bag (needed for a bag recorded
        without one).
    progress : callable, optional
        ``progress(event_id, Progress)`` after every epoch.
    figures : bool
        Also draw each event's report figures (a few seconds per event).

    Returns
    -------
    BagOutcome
        One outcome per event, failed ones included: a failed event (ingest or training)
        raises nothing, its ``failed.json`` says why.

    Raises
    ------
    BagError
        The bag cannot be read (names the file and what was wrong).
    IngestError
        Nothing of the bag can be ingested (e.g. every sensor contradicts the configured
        sample rate; the message says so).
    ReportError
        ``out_dir`` cannot be written (names it).
    """
    bag = Path(bag)
    store = ResultsStore(out_dir).create()
    read = read_bag_events(bag, config=config, ingest_settings=ingest_settings)
    settings = settings or IdentifySettings()
    events = []
    for event in read.events:
        if event.failure is not None:
            events.append(_failed_outcome(event.failure, store, None, event.ingest))
            continue
        callback = None
        if progress is not None:
            callback = (lambda p, eid=event.event_id: progress(eid, p))
        events.append(_identify(event.ingest, settings, store, callback, figures))
    return BagOutcome(bag=bag, events=tuple(events), ingest_report=read.ingest_report,
                      bag_findings=read.bag_findings)


def _identify(ingest: EventIngest, settings: IdentifySettings, store: ResultsStore,
              progress: Callable[[Progress], None] | None, figures: bool) -> EventOutcome:
    """One event with a window; a failure is recorded and returned, never raised."""
    window = ingest.window
    try:
        outcome = identify_window(window, settings, store, progress=progress, figures=figures)
    except PierMonitorError as err:  # bad window, result or results directory: this event's
        failed = failed_result(window, device=settings.device,
                               message=f"identification failed: {type(err).__name__}: {err}")
        return _failed_outcome(failed, store, window, ingest)
    return EventOutcome(window=outcome.window, result=outcome.result, out_dir=outcome.out_dir,
                        window_file=outcome.window_file, paths=outcome.paths, ingest=ingest)


def _failed_outcome(failed: IdentificationResult, store: ResultsStore,
                    window: MeasuredWindow | None, ingest: EventIngest) -> EventOutcome:
    """A failed event's outcome, with its ``failed.json`` when its directory can hold one
    (not when the directory itself is the fault, e.g. a link out of the results root)."""
    out_dir = store.root / failed.event_id
    window_file = None
    try:
        out_dir = store.record_failure(failed).parent
        window_file = store.window_file(failed.event_id) if window is not None else None
    except PierMonitorError as err:
        failed = dataclasses.replace(failed, message=f"{failed.message}; no failure record "
                                     f"written: {err}")
        log.error("event %s: %s", failed.event_id, failed.message)
    return EventOutcome(window=window, result=failed, out_dir=out_dir, window_file=window_file,
                        paths=None, ingest=ingest)


def _ingest_failure(ingest: EventIngest, recording: Recording) -> IdentificationResult:
    """The failure record of an event without a window, with the ingest's reason."""
    config = recording.config_at(ingest.start_ns)
    return failed_event_result(
        config.geometry, pier_id=config.pier_id, event_id=ingest.event_id,
        start_ns=ingest.start_ns, duration_s=(ingest.end_ns - ingest.start_ns) / NS_PER_S,
        window_start_s=(ingest.start_ns - recording.start_ns) / NS_PER_S,
        message=f"ingest: {ingest.failure}", findings=ingest.findings)


def _no_samples(bag: Path, recording: Recording) -> BagError:
    """Why a bag gave no samples of the configuration's sensors: a pier id that does not
    match the bag's topics is named as such."""
    config = recording.config
    ours = {s.topic.lstrip("/") for s in config.sensors}
    namespaces = sorted({t[: -len(st) - 1] for t in recording.unmapped_topics for st in ours
                         if t.endswith("/" + st)})
    if namespaces:
        return BagError(
            f"{bag}: the configuration is of pier {config.pier_id!r} (its sensors on "
            f"/{config.pier_id}/...) but the bag's sample blocks of the same sensors are "
            f"under {', '.join(n + '/' for n in namespaces)}: the pier_id does not match the "
            "bag's namespace; correct pier_id in the configuration (--pier)")
    return BagError(f"{bag}: the bag holds no samples of any sensor of the configuration's "
                    f"map ({len(config.sensors)} sensors listed)")
