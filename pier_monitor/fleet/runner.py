"""Identify every event of many bags on a backend: ingest once per bag, one task per event.

:func:`run_fleet` is what ``pier-monitor fleet`` runs:

1. The bags are found (:func:`~pier_monitor.fleet.discover.find_bags`).  A bag whose record
   in ``<out>/.fleet/`` says that every one of its events is done, and whose files have not
   changed since, is skipped without reading it (unless ``force``).
2. Each other bag is ingested by a task of its own; its windows come back to the driver,
   which stores each window in its event directory (:meth:`ResultsStore.start_event`: an
   earlier outcome of the event is removed, a crash later loses nothing) and records the
   bag's events.  An event that already has a result is skipped (unless ``force``).  An
   event the ingest gave no window of (failed, or cut by the end of the data) is recorded
   as failed there and then (its ``failed.json`` with the ingest's reason, as
   ``pier-monitor identify`` writes it: :func:`~pier_monitor.pipeline.read_bag_events`).
3. Each event is identified by a task of its own (:func:`~pier_monitor.fleet.tasks.
   identify_event`, i.e. :func:`~pier_monitor.events.identify_window`).  Results are keyed
   by event id and written atomically by the store.  The baseline of an event is the
   store's (:meth:`~pier_monitor.store.ResultsStore.baseline_for`: the earliest
   earlier reliable result of its pier), as for ``pier-monitor identify``: an event is
   handed out once every bag of its pier is ingested and its pier's earlier events have
   settled it (the first that may be a baseline is done, or all of them are done).  The first
   events of all piers run at once; the later ones follow — the same results as identifying
   each pier's bags one after another.
4. A failed event is recorded with its reason (``failed.json``) and the fleet goes on; a
   worker process that dies mid-task is replaced and the task retried
   (:mod:`~pier_monitor.fleet.backends`).  The summary of the whole results root is read
   (:func:`~pier_monitor.fleet.summary.summarize_store`) and written at the end
   (:func:`~pier_monitor.report.fleet.write_fleet_summary`).
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from pier_monitor.bags import read_bag_config
from pier_monitor.core.errors import PierMonitorError, ReportError
from pier_monitor.core.fileio import atomic_path, to_strict_json
from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.ingest import IngestSettings
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.identify.methods import IdentifySettings
from pier_monitor.report.fleet import FleetPaths, FleetSummary, write_fleet_summary
from pier_monitor.store import ResultsStore

from .backends import Backend, Finished, Resources, machine_cpus
from .discover import bag_fingerprint, bag_key, find_bags
from .progress import FleetProgress
from .summary import summarize_store
from .tasks import BagWindows, EventDone, EventTask, IngestTask, KillOnce, identify_event, ingest_bag

__all__ = ["FLEET_DIR", "FleetOptions", "FleetRun", "run_fleet"]

#: Directory of the bags' records inside the results root.
FLEET_DIR = ".fleet"


@dataclass(frozen=True)
class FleetOptions:
    """How a fleet is identified.

    Attributes
    ----------
    settings : IdentifySettings
        Training settings of every event (those of ``pier-monitor identify``).
    ingest_settings : IngestSettings, optional
    figures : bool
        Draw each event's report figures.
    force : bool
        Identify every event again, also those with a result.
    cpus_per_task : int
        CPUs (and training threads) of an event's task on Ray.
    gpus_per_task : float
        Share of a GPU of an event's task when training on CUDA (Ray): 0.25 puts four
        events on a GPU at once.
    fault : KillOnce, optional
        Tests only: a worker fault to inject.
    """

    settings: IdentifySettings = field(default_factory=IdentifySettings)
    ingest_settings: IngestSettings | None = None
    figures: bool = True
    force: bool = False
    cpus_per_task: int = 1
    gpus_per_task: float = 0.25
    fault: KillOnce | None = None


@dataclass(frozen=True)
class FleetRun:
    """What :func:`run_fleet` did.

    Attributes
    ----------
    bags : tuple of Path
        The bags found.
    results : dict of str to IdentificationResult
        The outcome of every event identified in this run, by event id.
    identified, failed, skipped : int
        Events identified successfully, failed (recorded with their reason), and skipped
        (done in an earlier run).
    retried : int
        Tasks retried after their worker died (the local pool counts them; Ray retries by
        itself and reports 0).
    failed_bags : tuple of (Path, str)
        Bags that could not be ingested, with the reason.
    backend : str
        ``local`` or ``ray``.
    workers : int
        Tasks the backend runs at once (local) or CPUs of the cluster (Ray).
    wall_s : float
        Wall time of the run, s.
    first_result_s : float or None
        From the start of the run to the first event identified, s.
    summary : FleetSummary
        The ranked state of every pier of the results root.
    paths : FleetPaths
        ``fleet.json``, ``fleet.png``, ``fleet_state.mcap``.
    """

    bags: tuple[Path, ...]
    results: dict[str, IdentificationResult]
    identified: int
    failed: int
    skipped: int
    retried: int
    failed_bags: tuple[tuple[Path, str], ...]
    backend: str
    workers: int
    wall_s: float
    first_result_s: float | None
    summary: FleetSummary
    paths: FleetPaths

    def as_dict(self) -> dict[str, Any]:
        """The run's counts and times, for ``fleet.json``."""
        return {"bags": len(self.bags), "identified": self.identified, "failed": self.failed,
                "skipped": self.skipped, "retried": self.retried,
                "failed_bags": [{"bag": str(b), "error": e} for b, e in self.failed_bags],
                "backend": self.backend, "workers": self.workers,
                "wall_s": round(self.wall_s, 3),
                "first_result_s": None if self.first_result_s is None
                else round(self.first_result_s, 3)}


class _Schedule:
    """The driver's view of the events of the run: what is pending, running, settled."""

    def __init__(self, store: ResultsStore) -> None:
        self.store = store
        self.windows: dict[str, MeasuredWindow] = {}
        self.status: dict[str, str] = {}  # pending, running, ok, failed
        self.open_bags: Counter[str] = Counter()  # pier -> bags not ingested yet
        self._prior: dict[str, list[tuple[int, bool]]] = {}

    def add(self, window: MeasuredWindow) -> None:
        self.windows[window.event_id] = window
        self.status[window.event_id] = "pending"

    def settle(self, event_id: str, result: IdentificationResult) -> None:
        """An event is done: ``baseline`` when later events may compare with it
        (:meth:`ResultsStore.is_baseline`), else ``done``."""
        self.status[event_id] = "baseline" if self.store.is_baseline(result) else "done"

    def _earlier(self, window: MeasuredWindow) -> list[tuple[int, str]]:
        pier = window.pier_id
        if pier not in self._prior:  # outcomes of earlier runs, read once
            self._prior[pier] = [(r.window_start_ns, self.store.is_baseline(r)) for r in
                                 (*self.store.results(pier), *self.store.failures(pier))
                                 if r.event_id not in self.status]
        out = [(start, "baseline" if ok else "done") for start, ok in self._prior[pier]]
        out += [(w.start_time_ns, self.status[eid]) for eid, w in self.windows.items()
                if w.pier_id == pier and eid != window.event_id]
        return sorted(e for e in out if e[0] < window.start_time_ns)

    def _settled(self, window: MeasuredWindow) -> bool:
        """Whether the baseline of ``window`` is known: an earlier event that may be a
        baseline, or none left pending (the store's rule, :meth:`ResultsStore.baseline_for`)."""
        for _, earlier in self._earlier(window):
            if earlier == "baseline":
                return True
            if earlier != "done":
                return False
        return True

    def ready(self) -> list[MeasuredWindow]:
        """Pending events whose baseline is settled (see the module documentation)."""
        out = [w for eid, w in self.windows.items() if self.status[eid] == "pending"
               and self.open_bags[w.pier_id] == 0 and self._settled(w)]
        return sorted(out, key=lambda w: (w.start_time_ns, w.event_id))


def _record_path(out: Path, bag: Path) -> Path:
    return out / FLEET_DIR / f"{bag_key(bag)}.json"


def _read_record(out: Path, bag: Path) -> dict[str, Any] | None:
    try:
        return json.loads(_record_path(out, bag).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _write_record(out: Path, bag: Path, fingerprint: str, got: BagWindows) -> None:
    path = _record_path(out, bag)
    doc = {"bag": str(bag.resolve()), "fingerprint": fingerprint, "pier_id": got.pier_id,
           "events": [ev.event_id for ev in got.events]}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            tmp.write_text(to_strict_json(doc, indent=1) + "\n", encoding="utf-8")
    except OSError as err:
        raise ReportError(f"{path}: cannot write the bag's record: {err.strerror or err}") from err


def _pier_of(bag: Path) -> str:
    """The pier of a bag from its configuration; "" when it cannot be read (ingest says why)."""
    try:
        return read_bag_config(bag).pier_id
    except PierMonitorError:
        return ""


def run_fleet(paths: Sequence[str | Path], out: str | Path, backend: Backend,
              options: FleetOptions | None = None,
              progress: FleetProgress | None = None) -> FleetRun:
    """Identify every event of the bags under ``paths`` into the results root ``out``.

    Parameters
    ----------
    paths : sequence of str or Path
        Bags (rosbag2 directories, ``.mcap`` files) and directories searched for bags.
    out : str or Path
        Results root (a :class:`~pier_monitor.store.ResultsStore`); never searched for
        bags.
    backend : Backend
        Where the tasks run (:class:`~pier_monitor.fleet.backends.LocalPool`,
        :class:`~pier_monitor.fleet.backends.RayBackend`); not closed here.
    options : FleetOptions, optional
    progress : FleetProgress, optional
        Counts drawn as the run goes.

    Returns
    -------
    FleetRun

    Raises
    ------
    BagError
        When a path does not exist or no bag is found.
    ReportError
        When the results root cannot be written (names it).
    """
    started = time.perf_counter()
    options = options or FleetOptions()
    out = Path(out)
    bags = tuple(find_bags(paths, exclude=[out]))
    store = ResultsStore(out).create()
    schedule = _Schedule(store)
    on_cuda = options.settings.device == "cuda" or (
        options.settings.device == "auto" and getattr(backend, "gpus", 0.0) > 0)
    resources = Resources(num_cpus=options.cpus_per_task,
                          num_gpus=options.gpus_per_task if on_cuda else 0.0)
    threads = options.cpus_per_task if backend.name == "ray" else \
        max(1, machine_cpus() // backend.workers)
    fingerprints: dict[str, tuple[Path, str, str]] = {}
    skipped = 0
    for i, bag in enumerate(bags):
        fingerprint = bag_fingerprint(bag)
        record = _read_record(out, bag)
        if (not options.force and record is not None and record.get("fingerprint") == fingerprint
                and all(store.is_done(e) for e in record.get("events", []))):
            skipped += len(record["events"])
            continue
        pier = _pier_of(bag)
        schedule.open_bags[pier] += 1
        fingerprints[f"ingest:{i}"] = (bag, fingerprint, pier)
        backend.submit(f"ingest:{i}", ingest_bag, IngestTask(bag, options.ingest_settings))
    if progress is not None and skipped:
        progress.add(skipped, skipped=skipped)

    results: dict[str, IdentificationResult] = {}
    failed_bags: list[tuple[Path, str]] = []
    first_result_s: float | None = None
    identified = failed = 0

    def ingested(fin: Finished) -> None:
        nonlocal skipped, failed
        bag, fingerprint, pier = fingerprints[fin.key]
        schedule.open_bags[pier] -= 1
        got: BagWindows | None = fin.value
        error = fin.error or (got.error if got is not None else "no result")
        if error:
            failed_bags.append((bag, error))
            if progress is not None:
                progress.note(f"{bag}: not ingested: {error}")
            return
        new, no_window = 0, []
        for event in got.events:
            if not options.force and store.is_done(event.event_id):
                skipped += 1
                continue
            if event.failure is not None:  # no window: its failure record, now
                store.record_failure(event.failure)
                results[event.event_id] = event.failure
                no_window.append(event.failure)
                continue
            store.start_event(event.window)
            schedule.add(event.window)
            new += 1
        _write_record(out, bag, fingerprint, got)
        failed += len(no_window)
        if progress is not None:
            progress.add(len(got.events), skipped=len(got.events) - new - len(no_window))
            for result in no_window:
                progress.finished(result.event_id, result.overall_state, False, result.message)

    def identified_event(fin: Finished) -> None:
        nonlocal identified, failed, first_result_s
        event_id = fin.key.removeprefix("event:")
        window = schedule.windows[event_id]
        done: EventDone | None = fin.value
        if done is not None:
            result = done.result
        else:  # the task raised or its worker kept dying: a failure record, the fleet goes on
            result = store.fail_window(
                window, device=options.settings.device,
                message=f"identification task failed after {fin.attempts} attempt(s): "
                        f"{fin.error}")
        results[event_id] = result
        schedule.settle(event_id, result)
        if result.success:
            identified += 1
            if first_result_s is None:
                first_result_s = time.perf_counter() - started
        else:
            failed += 1
        if progress is not None:
            progress.finished(event_id, result.overall_state, result.success, result.message)

    while True:
        for window in schedule.ready():
            schedule.status[window.event_id] = "running"
            backend.submit(f"event:{window.event_id}", identify_event, EventTask(
                window=window, settings=options.settings, results_root=out,
                figures=options.figures, threads=threads, fault=options.fault), resources)
        if not backend.busy():
            break
        for fin in backend.wait():
            (ingested if fin.key.startswith("ingest:") else identified_event)(fin)

    summary = summarize_store(store)
    run = FleetRun(bags=bags, results=results, identified=identified, failed=failed,
                   skipped=skipped, retried=backend.retried, failed_bags=tuple(failed_bags),
                   backend=backend.name, workers=backend.workers,
                   wall_s=time.perf_counter() - started, first_result_s=first_result_s,
                   summary=summary, paths=FleetPaths(out, out, None))
    return replace(run, paths=write_fleet_summary(summary, out, run=run.as_dict()))
