"""Helpers shared by the test modules: the repository's paths, child processes with a
deadline-bound line reader, field-by-field message comparison.

Test modules import this module by its own name (the test folder is on ``sys.path``), never
``conftest``, whose name several folders share.
"""

from __future__ import annotations

import math
import numbers
import os
import selectors
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

__all__ = ["REPO_ROOT", "MSG_DIR", "RosProcess", "assert_fields_equal"]

REPO_ROOT = Path(__file__).resolve().parents[1]
MSG_DIR = REPO_ROOT / "msg_defs" / "msg"


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
