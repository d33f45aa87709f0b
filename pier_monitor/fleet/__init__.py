"""Every pier of a network: many bags identified on a local process pool or a Ray cluster.

``pier-monitor fleet BAG_OR_DIR... --out DIR`` runs :func:`run_fleet`: one ingest task per
bag, one identification task per event (:func:`pier_monitor.events.identify_window`), results
keyed by event id in one results store, a rerun skipping what is done, and the ranked summary
of the network (read by :mod:`pier_monitor.fleet.summary`, rendered by
:mod:`pier_monitor.report.fleet`).  Ray is loaded only for a Ray run.
"""

from __future__ import annotations

from .backends import Backend, FleetBackendError, Finished, LocalPool, RayBackend, Resources
from .discover import find_bags
from .offload import identify_offloaded
from .progress import FleetProgress
from .runner import FLEET_DIR, FleetOptions, FleetRun, run_fleet
from .summary import pier_rows, summarize_store
from .tasks import EventDone, EventTask, KillOnce, identify_event

__all__ = ["Backend", "EventDone", "EventTask", "FLEET_DIR", "FleetBackendError", "FleetOptions",
           "FleetProgress", "FleetRun", "Finished", "KillOnce", "LocalPool", "RayBackend",
           "Resources", "find_bags", "identify_event", "identify_offloaded", "pier_rows",
           "run_fleet", "summarize_store"]
