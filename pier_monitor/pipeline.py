"""Offline identification of a bag: read → ingest → one event at a time (SPEC §8).

``identify_bag`` is what ``pier-monitor identify BAG`` runs: every detected event of the bag
goes through :func:`pier_monitor.events.identify_window`, the step the live identifier node
runs as well, into one results directory ``<out>/<event_id>/`` with ``window.npz`` (stored
before training starts, so that a crash loses no event), ``damage_state.mcap``, the figures
and ``result.json``.  Events are identified in time order; the baseline of each is the
earliest earlier result of the same pier in ``out`` (:class:`~pier_monitor.report.store.
ResultsStore`): in an empty directory, the first event of the bag.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pier_monitor.bags import read_bag
from pier_monitor.core.errors import BagError, IdentificationError
from pier_monitor.core.ingest import IngestReport, IngestSettings, ingest_recording
from pier_monitor.core.model.config import PierConfig
from pier_monitor.events import EventOutcome, identify_window
from pier_monitor.pinn import PinnSettings, Progress
from pier_monitor.report.store import ResultsStore

__all__ = ["BagOutcome", "identify_bag"]


@dataclass(frozen=True)
class BagOutcome:
    """Everything ``identify_bag`` did with one bag."""

    bag: Path
    events: tuple[EventOutcome, ...]
    ingest_report: IngestReport


def identify_bag(bag: str | Path, out_dir: str | Path, *, settings: PinnSettings | None = None,
                 ingest_settings: IngestSettings | None = None,
                 config: PierConfig | None = None,
                 progress: Callable[[str, Progress], None] | None = None) -> BagOutcome:
    """Identify every event of a bag and write one results directory per event.

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory or a plain ``.mcap`` file written by pier_monitor (or with the
        same topics and the configuration inside).
    out_dir : str or Path
        Results root (a :class:`~pier_monitor.report.store.ResultsStore`); created when
        missing.
    settings : PinnSettings, optional
        Identification settings (default: the benchmarked ones).
    ingest_settings : IngestSettings, optional
    config : PierConfig, optional
        Pier configuration to use instead of the one in the bag (needed for a bag recorded
        without one).
    progress : callable, optional
        ``progress(event_id, Progress)`` after every epoch.

    Raises
    ------
    BagError
        The bag cannot be read (names the file and what was wrong).
    ReportError
        ``out_dir`` cannot be written (names it).
    IdentificationError
        A training failed (its ``failed.json`` and the window stay on disk; the events
        before it are written).
    """
    bag = Path(bag)
    store = ResultsStore(out_dir).create()
    recording = read_bag(bag, config=config)
    if not recording.sensors:
        raise BagError(f"{bag}: the bag holds no samples of any sensor of the configuration's "
                       f"map ({len(recording.config.sensors)} sensors listed)")
    windows, report = ingest_recording(recording, ingest_settings)
    settings = settings or PinnSettings()
    events = []
    for window in windows:
        callback = None
        if progress is not None:
            callback = (lambda p, eid=window.event_id: progress(eid, p))
        outcome = identify_window(window, settings, store, progress=callback)
        if not outcome.result.success:
            raise IdentificationError(f"{window.event_id}: {outcome.result.message} (window and "
                                      f"failure record in {outcome.out_dir})")
        events.append(outcome)
    return BagOutcome(bag=bag, events=tuple(events), ingest_report=report)
