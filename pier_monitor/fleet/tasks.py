"""The two tasks of a fleet, as they run on a worker: ingest a bag, identify one event.

Both are plain module-level functions of picklable arguments, so that a process pool and a
Ray cluster run the same code.  Neither raises for bad data: a bag that cannot be read comes
back as a :class:`BagWindows` with its ``error``, an event the ingest gave no window of comes
back with its failure record (:func:`~pier_monitor.pipeline.read_bag_events`, as for
``pier-monitor identify``; the driver writes it as the event's ``failed.json``), a training
that fails is recorded by :func:`~pier_monitor.events.identify_window` as the event's
``failed.json``.

:class:`KillOnce` is a fault for tests only: a fleet run is handed one explicitly (the
command line never does), and it kills the process of the first attempt at one event.
"""

from __future__ import annotations

import dataclasses
import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path

from pier_monitor.core.errors import PierMonitorError
from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.ingest import IngestSettings
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.events import identify_window
from pier_monitor.core.identify.methods import IdentifySettings, Progress
from pier_monitor.pipeline import BagEvent, read_bag_events
from pier_monitor.store import ResultsStore

__all__ = ["BagWindows", "EventDone", "EventTask", "IngestTask", "KillOnce", "identify_event",
           "ingest_bag"]


@dataclass(frozen=True)
class BagWindows:
    """What ingesting one bag gave: its pier, its events in time order (each with its window
    or its failure record, :class:`~pier_monitor.pipeline.BagEvent`), or why it failed."""

    bag: Path
    pier_id: str
    events: tuple[BagEvent, ...]
    error: str = ""

    @property
    def windows(self) -> tuple[MeasuredWindow, ...]:
        """The windows of the events that have one, in time order."""
        return tuple(ev.window for ev in self.events if ev.window is not None)


@dataclass(frozen=True)
class IngestTask:
    """One bag to ingest, with the ingest settings."""

    bag: Path
    settings: IngestSettings | None = None


def ingest_bag(task: IngestTask) -> BagWindows:
    """Read a bag into its events (:func:`~pier_monitor.pipeline.read_bag_events`, as
    ``pier-monitor identify`` does): each with its window or its failure record.

    A bag that cannot be read or ingested comes back with ``error`` naming what is wrong.
    """
    try:
        read = read_bag_events(task.bag, ingest_settings=task.settings)
    except PierMonitorError as err:
        return BagWindows(task.bag, "", (), str(err))
    return BagWindows(task.bag, read.pier_id, read.events)


@dataclass(frozen=True)
class KillOnce:
    """Test fault: the first attempt at ``event_id`` exits its process mid-training.

    At epoch ``epoch`` of that event, when ``marker`` does not exist yet, the worker creates
    it and ends its process with ``os._exit(1)`` (no clean-up, as a kill would).  The marker
    makes it happen once across processes and machines that share the path.
    """

    event_id: str
    marker: Path
    epoch: int = 2

    def __call__(self, event_id: str, progress: Progress) -> None:
        if event_id != self.event_id or progress.epoch < self.epoch:
            return
        try:
            with self.marker.open("x"):
                pass
        except FileExistsError:
            return
        os._exit(1)


@dataclass(frozen=True)
class EventTask:
    """One event's identification, as shipped to a worker.

    Attributes
    ----------
    window : MeasuredWindow
        The event window.
    settings : IdentifySettings
        Training settings (the same for every event of a fleet).
    results_root : Path
        The results store's root (a path every worker sees).
    figures : bool
        Also draw the report figures.
    threads : int
        CPU threads of the training in the worker.
    fault : KillOnce, optional
        Tests only.
    """

    window: MeasuredWindow
    settings: IdentifySettings
    results_root: Path
    figures: bool = True
    threads: int = 1
    fault: KillOnce | None = None


@dataclass(frozen=True)
class EventDone:
    """What an event's task gave back.

    Attributes
    ----------
    result : IdentificationResult
        The saved result, or the failure record (``success`` false).
    worker : str
        ``host:pid`` of the process that ran it.
    wall_s : float
        Wall time of the task, s.
    reused : bool
        The event was done already when the task started (a retry of a task whose first
        attempt wrote its result): nothing was trained again.
    """

    result: IdentificationResult
    worker: str
    wall_s: float
    reused: bool = False


def identify_event(task: EventTask) -> EventDone:
    """Identify one event into the store (:func:`~pier_monitor.events.identify_window`).

    An event that is done already (its ``result.json`` or ``failed.json`` exists: a retried
    task whose first attempt finished) is not trained again; its stored outcome is returned.
    """
    started = time.perf_counter()
    worker = f"{platform.node()}:{os.getpid()}"
    store = ResultsStore(task.results_root)
    event_id = task.window.event_id
    done = store.outcome(event_id)
    if done is not None:
        return EventDone(done, worker, time.perf_counter() - started, reused=True)
    progress = None
    if task.fault is not None:
        fault = task.fault
        progress = (lambda p: fault(event_id, p))  # noqa: E731 - binds the event
    settings = dataclasses.replace(task.settings, threads=task.threads)
    outcome = identify_window(task.window, settings, store, progress=progress,
                              figures=task.figures)
    return EventDone(outcome.result, worker, time.perf_counter() - started)
