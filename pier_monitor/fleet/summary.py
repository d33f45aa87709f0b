"""The rows of the fleet summary, read from a results store.

:func:`summarize_store` reads every pier of a :class:`~pier_monitor.store.ResultsStore`
(its results and failure records); :func:`pier_rows` gives one
:class:`~pier_monitor.report.fleet.PierRow` per pier: its latest event (a result, or a
failure record), how many events it has, and — when the latest event succeeded — its
previous reliable event and the change of each section's ``k1`` against it (none when the
pier's sections changed).  They are ranked into the
:class:`~pier_monitor.report.fleet.FleetSummary` that the report renders.
"""

from __future__ import annotations

from collections.abc import Sequence

from pier_monitor.core.identify.damage import IdentificationResult, k1_change_pct
from pier_monitor.report.fleet import FleetSummary, PierRow
from pier_monitor.store import ResultsStore

__all__ = ["pier_rows", "summarize_store"]


def pier_rows(results: Sequence[IdentificationResult],
              failures: Sequence[IdentificationResult]) -> list[PierRow]:
    """One row per pier of a store's ``results`` and ``failures`` (its failure records),
    piers in name order (module documentation)."""
    piers = sorted({r.pier_id for r in (*results, *failures)})
    rows = []
    for pier in piers:
        events = sorted([r for r in (*results, *failures) if r.pier_id == pier],
                        key=lambda r: (r.window_start_ns, r.event_id))
        latest = events[-1]
        earlier = [r for r in events[:-1] if r.reliable]
        previous = earlier[-1] if earlier and latest.success else None
        change = None
        if previous is not None and len(previous.sections) == len(latest.sections):
            change = k1_change_pct(latest.params.k1, previous.params.k1)
        elif previous is not None:
            previous = None  # another geometry: no section-by-section change
        rows.append(PierRow(result=latest, events=len(events), previous=previous,
                            k1_change_pct=change))
    return rows


def summarize_store(store: ResultsStore) -> FleetSummary:
    """The ranked piers of a results store and its failed events."""
    results, failures = store.results(), store.failures()
    return FleetSummary.ranked(pier_rows(results, failures), failures)
