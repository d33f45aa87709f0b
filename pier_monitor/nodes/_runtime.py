"""What every node of the package runs on: a queue worker off the executor, and ``run_node``.

Subscription callbacks only put items on a :class:`QueueWorker`; its thread does the work
(decoding, ingest, training), so that the executor never stalls and nothing received is
lost while a PINN trains.  :func:`ros_runtime` (rclpy without its signal handlers, a stop
flag set by SIGINT / SIGTERM, an ordered shutdown) is what ``run_node`` and the launch-free
scripts spin in.
"""

from __future__ import annotations

import faulthandler
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Generic, TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor, TimeoutException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

__all__ = ["QueueWorker", "RosRuntime", "node_usage", "ros_runtime", "run_node"]

T = TypeVar("T")
N = TypeVar("N", bound=Node)
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
            # The stop marker is in the queue until the thread takes it, as its last item.
            left = max(self.backlog - 1, 0)
            log(f"{self._thread.name}: still handling, {left} items queued")
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


class RosRuntime:
    """What :func:`ros_runtime` yields: the stop flag, one executor and the nodes on it.

    Everything here is called from the thread that entered :func:`ros_runtime` (the main
    thread: the signal handlers run there).
    """

    def __init__(self) -> None:
        self._stop = threading.Event()
        #: The signal that asked to stop (``signal.SIGINT`` / ``signal.SIGTERM``), or None.
        self.signal: int | None = None
        #: Created by :func:`ros_runtime` once rclpy is initialised.
        self.executor: SingleThreadedExecutor
        self._nodes: list[Node] = []

    def request_stop(self, signum: int | None = None) -> None:
        """Ask every loop of this runtime to stop (what SIGINT and SIGTERM do)."""
        if self.signal is None:
            self.signal = signum
        self._stop.set()

    @property
    def stopped(self) -> bool:
        """A stop was requested, or the rclpy context is no longer valid."""
        return self._stop.is_set() or not self.executor.context.ok()

    def add_node(self, node: N) -> N:
        """Put ``node`` on the executor; it is destroyed at the end, after the executor."""
        self._nodes.append(node)
        self.executor.add_node(node)
        return node

    def spin(self, until: Callable[[], bool] = lambda: False) -> None:
        """Run callbacks until a stop is requested or ``until()`` is true (checked between
        two callbacks, and at least every :data:`STOP_POLL_S` seconds).  A context shut down
        by someone else while it waits ends it as a stop does."""
        try:
            while not self.stopped and not until():
                self.executor.spin_once(timeout_sec=STOP_POLL_S)
        except ExternalShutdownException:
            self._stop.set()

    def drain(self, max_s: float = 2.0) -> int:
        """Run, without waiting, the callbacks whose data have already arrived; return how
        many ran.

        Called after :meth:`spin` (also after a stop request): messages the middleware
        delivered before the stop but not yet handed over are handled, not dropped.  Ends
        when one pass over the entities finds nothing ready, or after ``max_s`` seconds (a
        publisher that never pauses).
        """
        deadline = time.monotonic() + max_s
        ran = 0
        while self.executor.context.ok() and time.monotonic() < deadline:
            before = ran
            while True:  # one wait without timeout, then the callbacks it found ready
                try:
                    handler, _, _ = self.executor.wait_for_ready_callbacks(timeout_sec=0.0)
                except TimeoutException:
                    break
                handler()
                if handler.exception() is not None:
                    raise handler.exception()
                ran += 1
            if ran == before:
                break
        return ran

    def sleep(self, seconds: float) -> bool:
        """Sleep ``seconds`` unless a stop is requested meanwhile (looked at every
        :data:`STOP_POLL_S` seconds); True when the whole time was slept."""
        deadline = time.monotonic() + seconds
        while not self.stopped:
            left = deadline - time.monotonic()
            if left <= 0:
                return True
            time.sleep(min(left, STOP_POLL_S))
        return False


@contextmanager
def ros_runtime(args: list[str] | None = None) -> Iterator[RosRuntime]:
    """rclpy for a process's main thread: own SIGINT / SIGTERM handling, ordered shutdown.

    Enables :mod:`faulthandler` (a native crash prints the Python stack of every thread to
    stderr), makes SIGINT and SIGTERM only set the runtime's stop flag (the loops of
    :class:`RosRuntime` look at it every :data:`STOP_POLL_S` seconds; no KeyboardInterrupt is
    raised) and initialises rclpy with ``args`` but without its own signal handlers.  On
    leaving the block, in this thread and in this order: the executor is shut down, the
    nodes added with :meth:`RosRuntime.add_node` are destroyed (last added first), and only
    then the rclpy context is shut down; a step that raises is reported on stderr, the steps
    after it still run, and its error is raised at the end (chained to the block's own, if
    any).  A signal during that cleanup changes nothing; the
    handlers stay installed until the process exits, so that work done after the block
    (closing a file) is not interrupted either.

    rclpy's own handlers are not used: on SIGINT they shut the context down at once, from a
    thread of rclpy's, which also triggers the executor's SIGINT guard condition; the
    executor destroyed right after (the KeyboardInterrupt reaches the main thread first)
    left that thread reading freed memory: the process could end with SIGSEGV after a clean
    run, and a node's worker could still be publishing on the shut-down context.
    """
    faulthandler.enable()
    runtime = RosRuntime()

    def request_stop(signum: int, frame: object) -> None:
        runtime.request_stop(signum)

    signal.signal(signal.SIGINT, request_stop)
    signal.signal(signal.SIGTERM, request_stop)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    executor = None
    try:
        executor = runtime.executor = SingleThreadedExecutor()
        yield runtime
    finally:
        steps = ([executor.shutdown] if executor is not None else []) + [
            node.destroy_node for node in reversed(runtime._nodes)] + [rclpy.try_shutdown]
        errors = []
        for step in steps:  # one step that fails must not skip the others
            try:
                step()
            except Exception as err:
                errors.append(err)
                print(f"shutdown: {getattr(step, '__qualname__', step)}: "
                      f"{type(err).__name__}: {err}", file=sys.stderr, flush=True)
        if errors:
            raise errors[0]


def run_node(node_class: Callable[[], Node], args: list[str] | None = None) -> int:
    """Spin one node on a SingleThreadedExecutor until Ctrl-C / SIGTERM; orderly shutdown.

    Prints ``READY <fully qualified name>`` once the node is constructed (the launch-free
    scripts and the tests wait for it).  ``-h`` / ``--help`` before any ROS arguments prints
    the node's usage and returns 0 without starting it.

    Runs in :func:`ros_runtime`: SIGINT and SIGTERM only ask the spin loop to stop (it looks
    every :data:`STOP_POLL_S` seconds); then, in this thread and in this order, the executor
    is shut down, the node destroyed (its ``destroy_node`` stops its worker: the ingest
    handles what is queued, the identifier ends a training at its next epoch and keeps the
    window for the next start) and only then the rclpy context shut down.  A second signal
    during that cleanup changes nothing.  rclpy's own signal handlers are not installed (see
    :func:`ros_runtime` for the crash they caused).  :mod:`faulthandler` is enabled.
    """
    user_args = list(args or [])[1:]
    if "--ros-args" in user_args:
        user_args = user_args[:user_args.index("--ros-args")]
    if {"-h", "--help"} & set(user_args):
        print(node_usage(node_class, (args or ["node"])[0]))
        return 0
    with ros_runtime(args) as runtime:
        node = runtime.add_node(node_class())
        print(f"READY {node.get_fully_qualified_name()}", flush=True)
        runtime.spin()
    return 0
