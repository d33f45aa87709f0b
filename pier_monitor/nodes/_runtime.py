"""What every node of the package runs on: a queue worker off the executor, and ``run_node``.

Subscription callbacks only put items on a :class:`QueueWorker`; its thread does the work
(decoding, ingest, training), so that the executor never stalls and nothing received is
lost while a PINN trains.
"""

from __future__ import annotations

import faulthandler
import queue
import signal
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Generic, TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

__all__ = ["QueueWorker", "node_usage", "run_node"]

T = TypeVar("T")
_STOP = object()
#: Seconds a stop request (SIGINT, SIGTERM) waits at most for the spin loop to see it: the
#: executor waits at most this long in one go (the signal handler runs in the main thread,
#: between two waits).
STOP_POLL_S = 0.1


class QueueWorker(Generic[T]):
    """One thread that handles queued items in order; started at construction.

    Parameters
    ----------
    name : str
        Name of the thread.
    handle : callable
        ``handle(item)``, called on the worker thread for every item.
    on_error : callable
        ``on_error(item, exception)`` when ``handle`` raised; the worker goes on with the
        next item (one bad item never stops a node).
    """

    def __init__(self, name: str, handle: Callable[[T], None],
                 on_error: Callable[[T, Exception], None]) -> None:
        self._handle = handle
        self._on_error = on_error
        self._queue: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def put(self, item: T) -> None:
        """Queue an item (any thread; never blocks)."""
        self._queue.put(item)

    @property
    def backlog(self) -> int:
        """Items queued and not handled yet."""
        return self._queue.qsize()

    def stop(self, log: Callable[[str], None], report_every_s: float = 10.0) -> None:
        """Handle what is queued, then end the thread; return once it has ended.

        There is no deadline: the node's publishers, logger and rclpy itself must outlive
        every call the worker makes (a worker thread still running while the node is
        destroyed, or at interpreter exit, can crash the process).  A handler that must stop
        early checks a flag of its own (the identifier ends a training at its next epoch).

        Parameters
        ----------
        log : callable
            ``log(text)``, called every ``report_every_s`` seconds of waiting with the
            number of items still queued.
        report_every_s : float
            Seconds between two such lines.
        """
        self._queue.put(_STOP)
        self._thread.join(timeout=report_every_s)
        while self._thread.is_alive():
            log(f"{self._thread.name}: still handling, {self.backlog} items queued")
            self._thread.join(timeout=report_every_s)

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            try:
                self._handle(item)  # type: ignore[arg-type]
            except Exception as err:  # never let one bad item stop the node
                self._on_error(item, err)  # type: ignore[arg-type]


def node_usage(node_class: Callable[[], Node], program: str) -> str:
    """The ``--help`` text of a node: how to run it, then its module's documentation."""
    name = Path(program).name
    doc = (sys.modules[node_class.__module__].__doc__ or "").strip()
    return (f"usage: ros2 run pier_monitor {name} [--ros-args -r __ns:=/<pier_id> "
            f"--params-file nodes.yaml -p NAME:=VALUE ...]\n"
            f"   or: {name} --ros-args ... (the same executable)\n\n{doc}\n\n"
            "Parameters: config/nodes.yaml lists each with its default and range; "
            "`ros2 param describe` gives the same on a running node.")


def run_node(node_class: Callable[[], Node], args: list[str] | None = None) -> int:
    """Spin one node on a SingleThreadedExecutor until Ctrl-C / SIGTERM; orderly shutdown.

    Prints ``READY <fully qualified name>`` once the node is constructed (the launch-free
    scripts and the tests wait for it).  ``-h`` / ``--help`` before any ROS arguments prints
    the node's usage and returns 0 without starting it.

    SIGINT and SIGTERM only ask the spin loop to stop (it looks every :data:`STOP_POLL_S`
    seconds); then, in this thread and in this order, the executor is shut down, the node
    destroyed (its ``destroy_node`` stops its worker: the ingest handles what is queued, the
    identifier ends a training at its next epoch and keeps the window for the next start)
    and only then the rclpy context shut down.  A second signal during that cleanup changes
    nothing.  rclpy's own signal handlers are not installed: on SIGINT they shut the context
    down at once, from a thread of rclpy's, which also triggers the executor's SIGINT guard
    condition; the executor destroyed right after (the KeyboardInterrupt reaches this thread
    first) left that thread reading freed memory: the process could end with SIGSEGV after
    a clean run, and the worker could still be publishing on the shut-down context.

    :mod:`faulthandler` is enabled: a native crash prints the Python stack of every thread
    to stderr.
    """
    faulthandler.enable()
    user_args = list(args or [])[1:]
    if "--ros-args" in user_args:
        user_args = user_args[:user_args.index("--ros-args")]
    if {"-h", "--help"} & set(user_args):
        print(node_usage(node_class, (args or ["node"])[0]))
        return 0
    stop = threading.Event()

    def request_stop(signum: int, frame: object) -> None:
        stop.set()

    signal.signal(signal.SIGINT, request_stop)
    signal.signal(signal.SIGTERM, request_stop)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = None
    executor = SingleThreadedExecutor()
    try:
        node = node_class()
        executor.add_node(node)
        print(f"READY {node.get_fully_qualified_name()}", flush=True)
        while not stop.is_set() and executor.context.ok():
            executor.spin_once(timeout_sec=STOP_POLL_S)
    except ExternalShutdownException:  # the context was shut down by someone else
        pass
    finally:
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
