"""The node runtime (``pier_monitor.nodes._runtime``) in this process, on the real rclpy.

The ordered shutdown of :func:`ros_runtime`, its stop flag (signals and
:meth:`RosRuntime.request_stop`) and :class:`QueueWorker`.  The nodes started as real
processes are in test/integration.
"""

from __future__ import annotations

import os
import signal
import threading

import pytest
import rclpy
from rclpy.exceptions import InvalidHandle
from rclpy.node import Node

from pier_monitor.nodes._runtime import QueueWorker, ros_runtime

pytestmark = [pytest.mark.ros, pytest.mark.timeout(60)]
WAIT_S = 30.0  # a guard against hanging only


class _Boom(Exception):
    pass


class _Recording(Node):
    """A real node that notes, while it is destroyed, what the runtime has shut down so far."""

    def __init__(self, name, runtime, events, fail=None, signal_on_destroy=None):
        super().__init__(name)
        self._runtime, self._events = runtime, events
        self._fail, self._signal = fail, signal_on_destroy

    def destroy_node(self):
        executor = self._runtime.executor
        self._events.append((self.get_name(), executor.get_nodes(), executor.context.ok()))
        if self._signal is not None:
            signal.raise_signal(self._signal)
        super().destroy_node()
        if self._fail is not None:
            raise self._fail


@pytest.fixture
def runtime_env(ros_env):
    """This test's own ROS graph; pytest's SIGINT / SIGTERM handlers put back afterwards
    (:func:`ros_runtime` leaves its own installed for the rest of the process)."""
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


def test_exit_shuts_down_the_executor_then_the_nodes_last_first_then_the_context(runtime_env):
    events = []
    with ros_runtime(["test"]) as rt:
        # The first node added (destroyed last) sends SIGINT during the cleanup.
        first = rt.add_node(_Recording("first", rt, events, signal_on_destroy=signal.SIGINT))
        second = rt.add_node(_Recording("second", rt, events))
        context = rt.executor.context
        assert set(rt.executor.get_nodes()) == {first, second}
        assert rclpy.ok(context=context) and not rt.stopped
    # Each node saw the executor already shut down (no nodes left on it), the context not yet.
    assert events == [("second", [], True), ("first", [], True)]
    assert not rclpy.ok(context=context)
    assert rt.stopped
    for node in (first, second):
        with pytest.raises(InvalidHandle):
            node.get_name()
    # The signal during the cleanup only set the flag; the handlers stay installed after it.
    assert rt.signal == signal.SIGINT
    signal.raise_signal(signal.SIGINT)  # no KeyboardInterrupt
    assert signal.getsignal(signal.SIGINT) is not signal.default_int_handler


def test_a_failing_step_does_not_skip_the_later_ones_and_its_error_comes_last(
        runtime_env, capfd):
    events = []
    with pytest.raises(_Boom, match="third") as raised:
        with ros_runtime(["test"]) as rt:
            nodes = [rt.add_node(_Recording("first", rt, events)),
                     rt.add_node(_Recording("second", rt, events, fail=_Boom("second"))),
                     rt.add_node(_Recording("third", rt, events, fail=_Boom("third")))]
            context = rt.executor.context
    # Every node was destroyed and the context shut down despite two failures; the first
    # failure (the last node added) is the one raised, both are reported on stderr.
    assert [name for name, _, _ in events] == ["third", "second", "first"]
    for node in nodes:
        with pytest.raises(InvalidHandle):
            node.get_name()
    assert not rclpy.ok(context=context)
    stderr = capfd.readouterr().err
    assert "shutdown: _Recording.destroy_node: _Boom: third" in stderr
    assert "shutdown: _Recording.destroy_node: _Boom: second" in stderr
    assert raised.value.__context__ is None


def test_a_cleanup_error_is_chained_to_the_error_of_the_block(runtime_env, capfd):
    events = []
    with pytest.raises(_Boom, match="cleanup") as raised:
        with ros_runtime(["test"]) as rt:
            rt.add_node(_Recording("only", rt, events, fail=_Boom("cleanup")))
            context = rt.executor.context
            raise ValueError("the block failed")
    assert isinstance(raised.value.__context__, ValueError)
    assert str(raised.value.__context__) == "the block failed"
    assert [name for name, _, _ in events] == ["only"]
    assert not rclpy.ok(context=context)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_sets_the_stop_flag_and_spin_returns_before_the_next_poll(runtime_env, signum):
    polls = []

    def until():
        polls.append(len(polls))
        if len(polls) == 3:
            signal.raise_signal(signum)  # its handler runs before raise_signal returns
        return False

    with ros_runtime(["test"]) as rt:
        rt.add_node(Node("spinner"))
        rt.spin(until)  # no KeyboardInterrupt
        assert len(polls) == 3
        assert rt.stopped and rt.signal == signum
        assert rt.executor.context.ok()  # only the flag: the context is shut down on exit
        assert rt.sleep(WAIT_S) is False  # returns at once once stopped


def test_a_signal_from_another_thread_stops_spin_within_one_poll(runtime_env):
    polls, sent = [], threading.Event()
    worker = QueueWorker("killer", lambda _: (os.kill(os.getpid(), signal.SIGINT), sent.set()),
                         on_error=lambda item, err: sent.set())

    def until():
        polls.append(len(polls))
        if len(polls) == 3:
            worker.put(None)
            assert sent.wait(WAIT_S)
        return False

    with ros_runtime(["test"]) as rt:
        rt.add_node(Node("spinner"))
        rt.spin(until)
        worker.stop(log=print)
        assert 3 <= len(polls) <= 4  # the handler runs in this thread, at the latest after
        assert rt.signal == signal.SIGINT  # the one wait of the executor that was under way


def test_request_stop_from_a_worker_ends_spin_and_until_ends_it_without_a_stop(runtime_env):
    with ros_runtime(["test"]) as rt:
        rt.add_node(Node("spinner"))
        rt.spin(until=lambda: True)
        assert not rt.stopped and rt.sleep(0.0) is True
        worker = QueueWorker("stopper", lambda _: rt.request_stop(), on_error=print)
        worker.put(None)
        rt.spin()  # no `until`: only the flag set on the worker thread ends it
        worker.stop(log=print)
        assert rt.stopped and rt.signal is None


def _worker_alive(name):
    return any(t.name == name for t in threading.enumerate())


def test_queue_worker_handles_in_order_and_goes_on_after_an_error():
    handled, errors = [], []

    def handle(item):
        if item % 7 == 3:
            raise _Boom(f"bad {item}")
        handled.append(item)

    worker = QueueWorker("order", handle, lambda item, err: errors.append((item, str(err))))
    for item in range(30):
        worker.put(item)
    worker.stop(log=print)
    assert handled == [i for i in range(30) if i % 7 != 3]
    assert errors == [(i, f"bad {i}") for i in (3, 10, 17, 24)]
    assert not _worker_alive("order")


def test_queue_worker_stop_handles_everything_queued_before_it_returns():
    started, gate, handled, lines = threading.Event(), threading.Event(), [], []

    def handle(item):
        started.set()
        assert gate.wait(WAIT_S)  # the first item holds the worker until stop() reports
        handled.append(item)

    def log(text):
        lines.append(text)
        gate.set()

    worker = QueueWorker("drain", handle, on_error=lambda item, err: handled.append(err))
    for item in range(5):
        worker.put(item)
    assert started.wait(WAIT_S)
    worker.stop(log=log, report_every_s=0.01)
    assert handled == [0, 1, 2, 3, 4]
    assert not _worker_alive("drain") and worker.backlog == 0
    # Item 0 was being handled when stop() first reported: items 1..4 were still queued.
    assert lines[0] == "drain: still handling, 4 items queued"
