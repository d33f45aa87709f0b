"""Offline identification of a bag: read → ingest → PINN → results (SPEC §8).

``identify_bag`` is what ``pier-monitor identify BAG`` runs: every detected event of the
bag becomes one results directory ``<out>/<event_id>/`` with ``window.npz`` (the raw window,
written before training starts, so that a crash loses no event), ``result.json``,
``damage_state.mcap`` and the figures.  Events are identified in time order; from the second
on, ``k1`` changes are relative to the first event of the same pier.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from pier_monitor.core.model.config import PierConfig
from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.errors import BagError, ReportError
from pier_monitor.core.ingest import IngestReport, IngestSettings, ingest_recording
from pier_monitor.core.ingest.window import MeasuredWindow, save_window

__all__ = ["EventOutcome", "BagOutcome", "identify_bag"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class EventOutcome:
    """One identified event."""

    window: MeasuredWindow
    result: IdentificationResult
    out_dir: Path
    window_file: Path


@dataclass(frozen=True)
class BagOutcome:
    """Everything ``identify_bag`` did with one bag."""

    bag: Path
    events: tuple[EventOutcome, ...]
    ingest_report: IngestReport


def identify_bag(bag: str | Path, out_dir: str | Path, *, settings: object | None = None,
                 ingest_settings: IngestSettings | None = None,
                 config: PierConfig | None = None,
                 progress: Callable[[str, object], None] | None = None) -> BagOutcome:
    """Identify every event of a bag and write one results directory per event.

    Parameters
    ----------
    bag : str or Path
        A rosbag2 directory or a plain ``.mcap`` file written by pier_monitor (or with the
        same topics and the configuration inside).
    out_dir : str or Path
        Results root; created when missing.
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
        Training failed (the window file stays on disk).
    """
    from .bags import read_bag
    from .pinn import PinnSettings, identify
    from .report.results import write_results

    bag = Path(bag)
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ReportError(f"{out}: cannot create the results directory: {err.strerror}") from err
    recording = read_bag(bag, config=config)
    if not recording.sensors:
        raise BagError(f"{bag}: the bag holds no samples of any sensor of the configuration's "
                       f"map ({len(recording.config.sensors)} sensors listed)")
    windows, report = ingest_recording(recording, ingest_settings)
    settings = settings or PinnSettings()
    events = []
    first: IdentificationResult | None = None
    for window in windows:
        event_dir = out / window.event_id
        try:
            event_dir.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise ReportError(f"{event_dir}: cannot create the results directory: "
                              f"{err.strerror}") from err
        window_file = save_window(window, event_dir / "window.npz")
        callback = None
        if progress is not None:
            callback = (lambda p, eid=window.event_id: progress(eid, p))
        baseline = first.params.k1 if first is not None else None
        run = identify(window, settings, callback=callback, baseline_k1=baseline)
        paths = write_results(run, window, event_dir, baseline=first)
        result = IdentificationResult.load_json(paths.result_json)
        if first is None:
            first = result
        events.append(EventOutcome(window=window, result=result, out_dir=event_dir,
                                   window_file=window_file))
    return BagOutcome(bag=bag, events=tuple(events), ingest_report=report)
