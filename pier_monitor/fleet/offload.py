"""One window's identification offloaded to a Ray cluster, for a caller that waits for it.

The live identifier node with ``ray_address`` set trains each window here rather than in
its own process: :func:`identify_offloaded` stores the window (on disk before it leaves this
machine), runs the fleet's identification task (:func:`~pier_monitor.fleet.tasks.
identify_event`, the task of ``pier-monitor fleet``) on a :class:`~pier_monitor.fleet.
backends.RayBackend`, and waits for it, asking ``stopped`` between polls.  A task that
fails (it raised, or its worker died past the retries) is recorded in the store as the
event's failure, as any failed identification.
"""

from __future__ import annotations

from collections.abc import Callable

from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.identify.methods import IdentifySettings
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.events import TrainingStopped
from pier_monitor.store import ResultsStore

from .backends import RayBackend
from .tasks import EventTask, identify_event

__all__ = ["POLL_S", "identify_offloaded"]

#: How often the wait for a task asks whether to stop, s.
POLL_S = 0.5


def identify_offloaded(backend: RayBackend, window: MeasuredWindow, settings: IdentifySettings,
                       store: ResultsStore, *, figures: bool,
                       stopped: Callable[[], bool] = lambda: False) -> IdentificationResult:
    """Identify ``window`` as one task on ``backend`` and return its result.

    Parameters
    ----------
    backend : RayBackend
        Where the task runs (one task at a time: its only running task is this one).
    window : MeasuredWindow
        The event's window; stored in ``store`` before the task is submitted.
    settings : IdentifySettings
        The identification settings of the task.
    store : ResultsStore
        The results root, which the task's worker writes into (a path it must reach).
    figures : bool
        Whether the task writes the result's figures.
    stopped : callable
        Asked every :data:`POLL_S` while the task runs; when it says true, the wait ends.

    Raises
    ------
    TrainingStopped
        When ``stopped`` said true before the task ended (the window stays stored).
    """
    store.start_event(window)  # on disk before it leaves this machine
    backend.submit(window.event_id, identify_event, EventTask(
        window=window, settings=settings, results_root=store.root.resolve(), figures=figures))
    finished = []
    while not finished:
        if stopped():
            raise TrainingStopped()
        finished = backend.wait(timeout_s=POLL_S)
    if finished[0].value is not None:
        return finished[0].value.result
    return store.fail_window(window, device=settings.device,
                             message=f"Ray task failed: {finished[0].error}")
