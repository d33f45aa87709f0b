"""Where a fleet's tasks run: a local process pool, or a Ray cluster.

Both backends take tasks as ``(key, function, argument, resources)``, run ``function(argument)``
on a worker and hand back :class:`Finished` records as tasks end.  A worker process that dies
mid-task (killed, out of memory) is replaced and its task retried, up to ``max_retries``
times; a task that raises is not retried (the fleet's tasks record bad data and failed
trainings themselves and return).

* :class:`LocalPool` — ``concurrent.futures.ProcessPoolExecutor`` with the ``spawn`` start
  method (torch and ``fork`` do not mix), ``workers`` tasks at a time.  A dead worker breaks
  the whole pool: the pool is rebuilt and every task that was running is retried (which one
  died cannot be told).
* :class:`RayBackend` — Ray tasks (``ray.remote`` with ``max_retries``); each asks for
  ``num_cpus`` and, for training on CUDA, a fraction of a GPU, so that a GPU node runs several
  events at once.  Ray retries a task whose worker died by itself.  With no address a local
  Ray instance is started (and stopped by :meth:`RayBackend.close`).
"""

from __future__ import annotations

import multiprocessing
import os
from collections import deque
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any, Protocol

from pier_monitor.core.errors import PierMonitorError

__all__ = ["Backend", "FleetBackendError", "Finished", "LocalPool", "RayBackend", "Resources",
           "machine_cpus"]


class FleetBackendError(PierMonitorError):
    """A backend cannot be started (e.g. no Ray cluster at the address given)."""


@dataclass(frozen=True)
class Resources:
    """What one task asks for: CPUs, and a share of a GPU (0 = none)."""

    num_cpus: float = 1.0
    num_gpus: float = 0.0


@dataclass(frozen=True)
class Finished:
    """A task that ended: its value, or why it failed (``error`` non-empty)."""

    key: str
    value: Any = None
    error: str = ""
    attempts: int = 1


@dataclass
class _Task:
    key: str
    fn: Callable[[Any], Any]
    arg: Any
    resources: Resources
    attempts: int = field(default=1)


class Backend(Protocol):
    """The interface of the fleet's backends."""

    name: str
    workers: int
    retried: int

    def submit(self, key: str, fn: Callable[[Any], Any], arg: Any,
               resources: Resources = Resources()) -> None:
        """Queue ``fn(arg)`` under ``key``."""

    def wait(self) -> list[Finished]:
        """Block until at least one task ends; the tasks that ended."""

    def busy(self) -> int:
        """Tasks queued or running."""

    def close(self) -> None:
        """Stop the workers (and a local Ray instance this backend started)."""


def machine_cpus() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _describe(err: BaseException) -> str:
    return f"{type(err).__name__}: {err}"


class LocalPool:
    """A process pool on this machine (see the module documentation).

    Parameters
    ----------
    workers : int, optional
        Processes; default :func:`machine_cpus`.
    max_retries : int
        Retries of a task whose worker process died.
    """

    name = "local"

    def __init__(self, workers: int | None = None, *, max_retries: int = 2) -> None:
        self.workers = int(workers) if workers is not None else machine_cpus()
        if self.workers < 1:
            raise FleetBackendError(f"workers: expected a positive number, got {workers}")
        self.max_retries = max_retries
        self.retried = 0
        self._context = multiprocessing.get_context("spawn")
        self._pool = self._new_pool()
        self._queue: deque[_Task] = deque()
        self._running: dict[Future[Any], _Task] = {}

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.workers, mp_context=self._context)

    def submit(self, key: str, fn: Callable[[Any], Any], arg: Any,
               resources: Resources = Resources()) -> None:
        self._queue.append(_Task(key, fn, arg, resources))
        self._dispatch()

    def _dispatch(self) -> None:
        # at most one task per worker in the executor: when a worker dies, the tasks the
        # broken pool fails are those that were running, never ones still waiting
        while self._queue and len(self._running) < self.workers:
            task = self._queue.popleft()
            self._running[self._pool.submit(task.fn, task.arg)] = task

    def busy(self) -> int:
        return len(self._queue) + len(self._running)

    def wait(self) -> list[Finished]:
        if not self._running:
            return []
        done, _ = wait(list(self._running), return_when=FIRST_COMPLETED)
        out: list[Finished] = []
        broken: list[_Task] = []
        for fut in done:
            self._collect(fut, out, broken)
        if broken:
            # every task still running in the broken pool fails the same way: collect them all
            for fut in list(self._running):
                wait([fut])
                self._collect(fut, out, broken)
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = self._new_pool()
            for task in broken:
                if task.attempts > self.max_retries:
                    out.append(Finished(task.key, error=f"worker process died {task.attempts} "
                                        "times running this task", attempts=task.attempts))
                else:
                    task.attempts += 1
                    self.retried += 1
                    self._queue.appendleft(task)
        self._dispatch()
        return out

    def _collect(self, fut: Future[Any], out: list[Finished], broken: list[_Task]) -> None:
        task = self._running.pop(fut)
        try:
            out.append(Finished(task.key, fut.result(), attempts=task.attempts))
        except BrokenProcessPool:
            broken.append(task)
        except Exception as err:  # the task raised: reported, not retried
            out.append(Finished(task.key, error=_describe(err), attempts=task.attempts))

    def close(self) -> None:
        self._queue.clear()
        self._pool.shutdown(wait=True, cancel_futures=True)
        self._running.clear()


class RayBackend:
    """Ray tasks on a cluster, or on a local Ray instance (see the module documentation).

    Parameters
    ----------
    address : str, optional
        ``"auto"`` (the cluster this machine belongs to, as ``ray start`` left it) or an
        address as Ray understands it (``host:port`` of the head, ``ray://host:10001``); None
        starts a local Ray instance.
    num_cpus : int, optional
        CPUs of a local instance (default: this machine's).
    max_retries : int
        Retries of a task whose worker process died.

    Raises
    ------
    FleetBackendError
        When Ray cannot start or connect (the message says to which address).
    """

    name = "ray"

    def __init__(self, address: str | None = None, *, num_cpus: int | None = None,
                 max_retries: int = 2) -> None:
        import ray  # optional heavy dependency: loaded only for a Ray run

        self._ray = ray
        self.max_retries = max_retries
        self.retried = 0  # Ray retries by itself and does not say how often
        self._owns = not ray.is_initialized()
        quiet = dict(configure_logging=False, log_to_driver=False)
        try:
            if self._owns and address is None:
                ray.init(num_cpus=num_cpus or machine_cpus(), include_dashboard=False, **quiet)
            elif self._owns:
                ray.init(address=address, **quiet)
        except (ConnectionError, RuntimeError, ValueError) as err:
            where = "a local Ray instance" if address is None else f"Ray at {address!r}"
            raise FleetBackendError(f"cannot start or reach {where}: {_describe(err)}") from err
        self.address = ray.get_runtime_context().gcs_address
        resources = ray.cluster_resources()
        self.cpus = float(resources.get("CPU", 0.0))
        self.gpus = float(resources.get("GPU", 0.0))
        self.workers = max(1, int(self.cpus))
        self._remote: dict[Callable[[Any], Any], Any] = {}
        self._running: dict[Any, _Task] = {}

    def submit(self, key: str, fn: Callable[[Any], Any], arg: Any,
               resources: Resources = Resources()) -> None:
        if fn not in self._remote:
            self._remote[fn] = self._ray.remote(fn)
        ref = self._remote[fn].options(num_cpus=resources.num_cpus, num_gpus=resources.num_gpus,
                                       max_retries=self.max_retries,
                                       retry_exceptions=False).remote(arg)
        self._running[ref] = _Task(key, fn, arg, resources)

    def busy(self) -> int:
        return len(self._running)

    def wait(self, timeout_s: float | None = None) -> list[Finished]:
        """Block until a task ends (or ``timeout_s`` passes: then maybe none)."""
        if not self._running:
            return []
        ready, _ = self._ray.wait(list(self._running), num_returns=1, timeout=timeout_s)
        out = []
        for ref in ready:
            task = self._running.pop(ref)
            try:
                out.append(Finished(task.key, self._ray.get(ref)))
            except self._ray.exceptions.RayTaskError as err:  # the task raised
                out.append(Finished(task.key, error=_describe(err.cause)))
            except self._ray.exceptions.RayError as err:  # its worker died past the retries
                out.append(Finished(task.key, error=_describe(err).splitlines()[0],
                                    attempts=self.max_retries + 1))
        return out

    def close(self) -> None:
        for ref in list(self._running):
            self._ray.cancel(ref, force=True)
        self._running.clear()
        if self._owns:
            self._ray.shutdown()
