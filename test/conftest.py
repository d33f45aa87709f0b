"""Fixtures shared by all tests: an isolated ROS 2 graph per test, child processes, messages.

rclpy is imported inside the fixtures only, so that collecting the unit tests (and any
import-boundary test) never loads it.
"""

from __future__ import annotations

import itertools
import math
import numbers
import os
import selectors
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
MSG_DIR = REPO_ROOT / "msg_defs" / "msg"

# ROS_DOMAIN_IDs 1..101 (0 is everyone's default). Each test takes the next one; the start
# depends on the process id so that test runs started together rarely share a domain.
_DOMAIN_IDS = itertools.cycle(
    [1 + (os.getpid() * 17 + i) % 101 for i in range(101)])


@pytest.fixture
def ros_domain_id() -> int:
    """A ROS_DOMAIN_ID of this test's own (1..101)."""
    return next(_DOMAIN_IDS)


@pytest.fixture
def ros_env(ros_domain_id: int, monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """Environment of an isolated ROS 2 graph, applied to this process and returned for children.

    UDP only (no shared-memory files left in /dev/shm by a killed process), discovery limited
    to this host, and this test's own domain id.
    """
    settings = {
        "ROS_DOMAIN_ID": str(ros_domain_id),
        "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
    }
    for key, value in settings.items():
        monkeypatch.setenv(key, value)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    return dict(os.environ)


@pytest.fixture
def rclpy_context(ros_env: dict[str, str]) -> Iterator[Any]:
    """An initialised rclpy ``Context`` of this test's own, shut down afterwards.

    Destroy nodes and shut down executors (joining their threads) before the test returns:
    ``rclpy.shutdown`` with a live executor thread aborts the process.
    """
    import rclpy
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context, domain_id=int(ros_env["ROS_DOMAIN_ID"]))
    try:
        yield context
    finally:
        rclpy.shutdown(context=context)


class RosProcess:
    """A child Python process of the venv interpreter, with a deadline-bound line reader."""

    def __init__(self, popen: subprocess.Popen[str]) -> None:
        self.popen = popen
        self._selector = selectors.DefaultSelector()
        self._selector.register(popen.stdout, selectors.EVENT_READ)
        self._fd = popen.stdout.fileno()
        self._pending = b""  # read from the pipe, not yet split into lines
        self.lines: list[str] = []

    def wait_for_line(self, expected: str, timeout_s: float) -> str:
        """Read stdout until a line starting with ``expected``; fail after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        while (line := self._next_line(deadline)) is not None:
            self.lines.append(line)
            if line.startswith(expected):
                return line
        pytest.fail(f"child process did not print {expected!r} within {timeout_s} s "
                    f"(exit code {self.popen.poll()}); its output:\n" + "\n".join(self.lines))

    def _next_line(self, deadline: float) -> str | None:
        """The next line of stdout, or None at EOF / the deadline.

        Reads the pipe's file descriptor directly: a buffered ``readline()`` may pull several
        lines out of the pipe at once, and ``select()`` would then wait for more output while
        the line looked for sits in the buffer.
        """
        while b"\n" not in self._pending:
            left = deadline - time.monotonic()
            if left <= 0 or not self._selector.select(timeout=left):
                return None
            chunk = os.read(self._fd, 65536)
            if not chunk:  # EOF: the child exited
                if not self._pending:
                    return None
                chunk = b"\n"
            self._pending += chunk
        line, _, self._pending = self._pending.partition(b"\n")
        return line.decode(errors="replace")

    def read_rest(self, timeout_s: float = 10.0) -> list[str]:
        """Read stdout to its end (the child has exited or is exiting); all lines so far."""
        deadline = time.monotonic() + timeout_s
        while (line := self._next_line(deadline)) is not None:
            self.lines.append(line)
        return self.lines

    def stop(self, timeout_s: float = 10.0) -> int:
        """Close stdin (the child's signal to finish), wait, kill if it does not exit."""
        if self.popen.stdin and not self.popen.stdin.closed:
            self.popen.stdin.close()
        try:
            return self.popen.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.popen.kill()
            self.popen.wait()
            raise
        finally:
            self._selector.close()
            self.popen.stdout.close()


@pytest.fixture
def spawn_python(ros_env: dict[str, str]) -> Iterator[Callable[..., RosProcess]]:
    """Start ``python -c CODE ARGS...`` with the venv interpreter in this test's ROS graph.

    stdout and stderr come back merged, line by line; stdin stays open until ``stop()``.
    Children still running at the end of the test are killed.
    """
    children: list[RosProcess] = []

    def spawn(code: str, *args: str) -> RosProcess:
        popen = subprocess.Popen(
            [sys.executable, "-c", code, *args], env=ros_env, cwd=REPO_ROOT, text=True,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
        child = RosProcess(popen)
        children.append(child)
        return child

    yield spawn
    for child in children:
        if child.popen.poll() is None:
            child.popen.kill()
            child.popen.wait()


@pytest.fixture(scope="session")
def msg_typestore() -> Any:
    """A rosbags typestore (ROS 2 Kilted) with the pier_monitor_msgs types from msg_defs/."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    typestore = get_typestore(Stores.ROS2_KILTED)
    types: dict[str, Any] = {}
    for path in sorted(MSG_DIR.glob("*.msg")):
        types.update(get_types_from_msg(path.read_text(), f"pier_monitor_msgs/msg/{path.stem}"))
    typestore.register(types)
    return typestore


def assert_fields_equal(expected: Any, actual: Any, path: str = "msg") -> None:
    """Assert that two messages hold equal field values, recursively; NaN equals NaN.

    ``expected`` is an rclpy message; ``actual`` is an rclpy message or a rosbags dataclass
    (sequences may be lists, ``array.array`` or NumPy arrays).
    """
    if hasattr(expected, "get_fields_and_field_types"):
        for name in expected.get_fields_and_field_types():
            assert_fields_equal(getattr(expected, name), getattr(actual, name), f"{path}.{name}")
    elif isinstance(expected, (str, bytes, numbers.Number)):
        if isinstance(expected, float) and math.isnan(expected):
            assert math.isnan(actual), f"{path}: expected NaN, got {actual!r}"
        else:
            assert expected == actual, f"{path}: expected {expected!r}, got {actual!r}"
    else:  # a sequence
        assert len(expected) == len(actual), (
            f"{path}: expected {len(expected)} elements, got {len(actual)}")
        for i, (want, got) in enumerate(zip(expected, actual)):
            assert_fields_equal(want, got, f"{path}[{i}]")


@pytest.fixture(scope="session")
def fields_equal() -> Callable[[Any, Any], None]:
    """``assert_fields_equal(expected, actual)``: compare messages field by field."""
    return assert_fields_equal
