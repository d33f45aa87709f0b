"""Helpers shared by the tests that run real ROS 2 processes (the fixtures are in conftest.py).

Child processes with a line reader, field-by-field message comparison, and the pieces of a
live pier graph: parameters files, a test-side listener, starting and stopping nodes.
rclpy and the message packages are imported inside the helpers, so that importing this
module (conftest.py does, also for the unit tests) never loads them.
"""

from __future__ import annotations

import atexit
import math
import numbers
import os
import selectors
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest
import yaml

REPO_ROOT = Path(__file__).resolve().parents[1]
MSG_DIR = REPO_ROOT / "msg_defs" / "msg"

NS = "/edefense_pier"
TINY = {"device": "cpu", "seed": 0, "max_epochs": 6, "min_epochs": 1, "method": "pinn"}
RUN_SCRIPT = ("import runpy, sys; script = sys.argv.pop(1); sys.argv[0] = script; "
              "runpy.run_path(script, run_name='__main__')")
RUN_MODULE = ("import runpy, sys; module = sys.argv.pop(1); "
              "runpy.run_module(module, run_name='__main__', alter_sys=True)")


#: Children started by :func:`start_child` in this process (killed at exit at the latest).
_CHILDREN: list[subprocess.Popen[str]] = []
#: Run before the child's command: die with the test process however it ends (a failed or
#: killed test run never leaves nodes behind), then exec the command.  PR_SET_PDEATHSIG (1)
#: survives the exec; the parent check closes the race with a parent that died first.
_DIE_WITH_PARENT = ("import ctypes, os, signal, sys; "
                    "ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL); "
                    "os.getppid() == int(sys.argv[1]) or os._exit(70); "
                    "os.execvp(sys.argv[2], sys.argv[2:])")


def start_child(cmd: Sequence[str], env: dict[str, str], cwd: Path | str) -> RosProcess:
    """Start ``cmd`` with merged stdout/stderr and stdin open, in a process group of its own.

    The child is killed when this process dies (also by SIGKILL or a timeout's
    ``os._exit``), and :func:`kill_children` kills its whole group (a graph script's nodes
    included).  Call it from the main thread: the death signal follows the thread that
    started the child.
    """
    popen = subprocess.Popen([sys.executable, "-c", _DIE_WITH_PARENT, str(os.getpid()), *cmd],
                             env=env, cwd=cwd, text=True, stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             start_new_session=True)
    _CHILDREN.append(popen)
    return RosProcess(popen)


def kill_children(children: Sequence[RosProcess] | None = None) -> None:
    """SIGKILL the process groups of children still running (default: all of them)."""
    popens = _CHILDREN if children is None else [c.popen for c in children]
    for popen in list(popens):
        if popen.poll() is None:
            try:
                os.killpg(popen.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            popen.wait()
        if popen in _CHILDREN:
            _CHILDREN.remove(popen)


atexit.register(kill_children)


class RosProcess:
    """A child Python process of the venv interpreter, with a deadline-bound line reader."""

    def __init__(self, popen: subprocess.Popen[str]) -> None:
        self.popen = popen
        self._selector = selectors.DefaultSelector()
        self._selector.register(popen.stdout, selectors.EVENT_READ)
        self._fd = popen.stdout.fileno()
        self._pending = b""  # read from the pipe, not yet split into lines
        self.lines: list[str] = []

    def wait_for_line(self, expected: str, timeout_s: float, *, anywhere: bool = False) -> str:
        """Read stdout until a line starting with ``expected`` (holding it, with
        ``anywhere``); fail after ``timeout_s``.  Lines read before stay in :attr:`lines`
        and are searched too (with ``anywhere``)."""
        if anywhere:
            for line in self.lines:
                if expected in line:
                    return line
        deadline = time.monotonic() + timeout_s
        while (line := self._next_line(deadline)) is not None:
            self.lines.append(line)
            if line.startswith(expected) or (anywhere and expected in line):
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
            kill_children([self])
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


def check_markers(markers: Any, result: Any) -> None:
    """Cylinders and labels of a decoded MarkerArray against a result's sections.

    Colours: intact green, suspicious amber, damaged red, unknown and unreliable grey;
    labels ``S<n> <state> DF <DF> k1 <change> %`` (no diagnosis: ``S<n> <state>: no
    diagnosis``).
    """
    rgba = {"intact": (0.173, 0.627, 0.173), "suspicious": (1.0, 0.749, 0.0),
            "damaged": (0.839, 0.153, 0.157), "unknown": (0.62, 0.62, 0.62),
            "unreliable": (0.62, 0.62, 0.62)}
    assert markers.markers[0].action == 3  # DELETEALL first
    by_ns = {}
    for m in markers.markers[1:]:
        assert m.header.frame_id == result.pier_id
        by_ns.setdefault(m.ns, []).append(m)
    cylinders, labels = by_ns["sections"], by_ns["labels"]
    assert len(cylinders) == len(labels) == len(result.sections)
    for cyl, label, sec in zip(cylinders, labels, result.sections):
        assert cyl.type == 3 and label.type == 9 and cyl.id == label.id == sec.index
        want = rgba[sec.state]
        assert (cyl.color.r, cyl.color.g, cyl.color.b) == pytest.approx(want, abs=2e-3)
        assert (label.color.r, label.color.g, label.color.b) == pytest.approx(want, abs=2e-3)
        assert cyl.pose.position.z == pytest.approx(0.5 * (sec.z_bottom_m + sec.z_top_m))
        assert cyl.scale.z == pytest.approx(0.96 * (sec.z_top_m - sec.z_bottom_m))
        assert label.text.startswith(f"S{sec.index + 1} {sec.state}")
        if sec.state in ("unknown", "unreliable"):
            assert label.text.startswith(f"S{sec.index + 1} {sec.state}: no diagnosis")
        else:
            df = f"{sec.ductility_factor:.2f}" if sec.yielded else f"<={sec.ductility_factor:.2f}"
            assert f"DF {df}" in label.text
            k1 = "k1 n/a" if sec.k1_change_pct is None else f"k1 {sec.k1_change_pct:+.1f} %"
            assert k1 in label.text  # a first event has no change
    (title,) = by_ns["pier"]
    assert title.text.startswith(f"{result.pier_id} {result.overall_state.upper()}")


def wait_until(predicate: Any, timeout_s: float, what: str) -> None:
    """Poll ``predicate()`` every 0.1 s until true; fail the test after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.1)


def params_file(path: Path, data: Path, **identifier: Any) -> Path:
    """A ros__parameters file for both nodes (tiny training unless overridden).

    Both nodes use ``data/windows`` as their window directory unless ``window_dir`` is given
    for the identifier.
    """
    ident = {"window_dir": str(data / "windows"), "results_dir": str(data / "results"),
             "progress_every": 1, "write_figures": False, **TINY, **identifier}
    path.write_text(yaml.safe_dump({
        "/**/ingest": {"ros__parameters": {"window_dir": str(data / "windows"),
                                           "status_period_s": 0.5}},
        "/**/identifier": {"ros__parameters": ident}}))
    return path


class Listener:
    """Test-side subscriptions, spun on a background SingleThreadedExecutor."""

    def __init__(self, context: Any, typestore: Any) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from pier_monitor_msgs.msg import IdentificationProgress, PierDamageState
        from rclpy.executors import SingleThreadedExecutor
        from visualization_msgs.msg import MarkerArray

        from pier_monitor.nodes.qos import DAMAGE_STATE_QOS

        self.node = rclpy.create_node("test_listener", context=context)
        self.states: list[Any] = []
        self.status: list[Any] = []
        self.diagnostics: list[Any] = []
        self.progress: list[Any] = []
        self.markers: list[Any] = []

        def on_state(raw: bytes) -> None:  # knows only the .msg text: rosbags decodes
            self.states.append(typestore.deserialize_cdr(
                raw, "pier_monitor_msgs/msg/PierDamageState"))

        self.node.create_subscription(PierDamageState, f"{NS}/damage_state", on_state,
                                      DAMAGE_STATE_QOS, raw=True)
        self.node.create_subscription(  # decoded from the CDR bytes, as a viewer would
            MarkerArray, f"{NS}/damage_markers",
            lambda raw: self.markers.append(typestore.deserialize_cdr(
                raw, "visualization_msgs/msg/MarkerArray")), DAMAGE_STATE_QOS, raw=True)
        self.node.create_subscription(DiagnosticArray, f"{NS}/ingest_status",
                                      self.status.append, 10)
        self.node.create_subscription(DiagnosticArray, "/diagnostics",
                                      self.diagnostics.append, 50)
        self.node.create_subscription(
            IdentificationProgress, f"{NS}/identification_progress", self.progress.append, 100)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def wait(self, predicate: Any, timeout_s: float, what: str) -> None:
        wait_until(predicate, timeout_s, what)

    def ingest_values(self) -> dict[str, str]:
        for arr in reversed(self.status):
            for st in arr.status:
                if st.name.endswith("/ingest"):
                    return {kv.key: kv.value for kv in st.values}
        return {}

    def close(self) -> None:
        self.executor.shutdown()
        self.thread.join(timeout=5)
        self.node.destroy_node()


def start_node(spawn_python: Any, module: str, params: Path, *extra: str) -> Any:
    """Start ``pier_monitor.nodes.<module>`` in the pier namespace; wait for its READY."""
    child = spawn_python(RUN_MODULE, f"pier_monitor.nodes.{module}", "--ros-args", "-r",
                         f"__ns:={NS}", "--params-file", str(params), *extra)
    child.wait_for_line("READY", 30)
    return child


def interrupt(child: Any, timeout_s: float = 20.0) -> int:
    """Ctrl-C a child; its exit code."""
    child.popen.send_signal(signal.SIGINT)
    return child.popen.wait(timeout=timeout_s)
