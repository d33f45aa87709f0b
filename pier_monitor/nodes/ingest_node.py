"""Ingest node: sensor topics → streaming ingest → mainshock windows (SPEC §6, §7, §9).

Topics (relative: run the node in the pier's namespace, e.g. ``/edefense_pier``):

* in ``pier_configuration`` (``std_msgs/String`` YAML, reliable, transient local) unless the
  ``config_file`` parameter names one; a later message is a configuration update (e.g. more
  deck mass) that holds from the latest sample received before it;
* in one topic per sensor of the map: ``pier_monitor_msgs/SampleBlock`` (sensor-data QoS
  but reliable, deep queue), or ``sensor_msgs/Imu`` for the sensors in ``imu_sensor_ids``;
* out ``mainshock_window`` (``MainshockWindow``, reliable, transient local, depth 10): each
  window is written to ``window_dir/<event_id>.npz`` *before* it is published;
* out ``ingest_status`` and ``/diagnostics`` (``DiagnosticArray``): samples received, blocks
  dropped, channels alive, gaps, duplicates, exclusions.

Subscriptions are raw: callbacks only count and enqueue bytes; a worker thread decodes,
checks each message against the sensor map (a malformed or mis-typed message is logged with
its topic and dropped) and feeds :class:`~pier_monitor.core.ingest.StreamIngest`, whose
event processing takes ~0.5 s and never runs on the executor.
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from pier_monitor_msgs.msg import MainshockWindow, SampleBlock
from rcl_interfaces.msg import SetParametersResult
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Imu
from std_msgs.msg import String

from pier_monitor.core.model.config import PierConfig, config_from_yaml, load_config
from pier_monitor.core.ingest import StreamIngest
from pier_monitor.core.ingest.recording import NS_PER_S
from pier_monitor.core.ingest.window import MeasuredWindow, save_window

from ._params import declare
from .conversions import block_arrays, imu_arrays, window_to_msg

__all__ = ["IngestNode", "main", "SENSOR_QOS", "IMU_QOS", "LATCHED_QOS", "WINDOW_QOS"]

#: Sensor streams: reliable with a deep queue (a 0.1 s block per message and sensor), so that
#: a short stall of the executor loses nothing.
SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
#: Per-sample Imu streams: best effort, so that the usual sensor-data publishers of IMU
#: drivers (best effort) connect as well as reliable ones; a lost message shows as a gap.
IMU_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2000,
                     reliability=ReliabilityPolicy.BEST_EFFORT,
                     durability=DurabilityPolicy.VOLATILE)
#: Latched configuration / results: late subscribers get the latest.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Windows: the last ten stay available to an identifier that (re)starts late.
WINDOW_QOS = LATCHED_QOS

_STOP = object()
_EXCLUSION_CODES = ("gap_excluded", "dead", "saturated", "implausible_units", "rate_mismatch")


class IngestNode(Node):
    """Streaming ingest of one pier's sensors; see the module documentation."""

    def __init__(self, name: str = "ingest", **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self._config_file = declare(
            self, "config_file", "", "Pier configuration YAML; empty: take it from the "
            "pier_configuration topic", read_only=True)
        self._window_dir = Path(declare(
            self, "window_dir", "pier_monitor_data/windows", "Directory the raw mainshock "
            "windows are written to before they are published", read_only=True))
        self._buffer_s = declare(self, "buffer_s", 300.0, "Length of the per-sensor ring "
                                 "buffer", unit="s", lo=30.0, hi=3600.0, read_only=True)
        self._poll_s = declare(self, "poll_s", 1.0, "Foundation data between two runs of the "
                               "event trigger", unit="s", lo=0.1, hi=60.0, read_only=True)
        self._imu_ids = declare(self, "imu_sensor_ids", [], "Sensors of the map whose topic "
                                "carries sensor_msgs/Imu (one sample per message) instead of "
                                "SampleBlock", read_only=True, string_array=True)
        declare(self, "status_period_s", 1.0, "Period of the status on ingest_status and "
                "/diagnostics", unit="s", lo=0.1, hi=60.0)
        declare(self, "alive_timeout_s", 2.0, "A channel with no message for this long "
                "counts as not alive", unit="s", lo=0.1, hi=600.0)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._stream: StreamIngest | None = None
        self._specs: dict[str, Any] = {}
        self._subs: list[Any] = []
        self._last_seen: dict[str, float] = {}
        self._next_index: dict[str, int] = {}
        self._imu_t0: dict[str, int] = {}  # stamp of sample index 0 of each Imu sensor
        self.stats = {"messages_received": 0, "samples_received": 0, "messages_dropped": 0,
                      "gap_samples": 0, "duplicate_samples": 0, "windows_emitted": 0,
                      "queue_backlog": 0}
        self._last_error = ""
        self._drops_by_topic: dict[str, int] = {}
        self._last_window = ""
        self._pending: list[Any] = []  # blocks before the configuration is known
        self._max_time_ns = 0
        self._config_updates: list[tuple[int, PierConfig]] = []

        self._window_pub = self.create_publisher(MainshockWindow, "mainshock_window", WINDOW_QOS)
        self._status_pub = self.create_publisher(DiagnosticArray, "ingest_status", 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._status_timer = self.create_timer(
            self.get_parameter("status_period_s").value, self._publish_status)
        self._worker = threading.Thread(target=self._work, name="ingest_worker", daemon=True)
        self._worker.start()
        if self._config_file:
            self._set_config(load_config(self._config_file), "config_file")
        else:
            self._config_sub = self.create_subscription(
                String, "pier_configuration", self._on_config, LATCHED_QOS, raw=True)
        self.get_logger().info(
            f"ingest in {self.get_namespace()}: windows to {self._window_dir}, configuration "
            f"from {self._config_file or self.resolve_topic_name('pier_configuration')}")

    # -- parameters -------------------------------------------------------------------------
    def _on_set_parameters(self, params: list[Any]) -> SetParametersResult:
        for p in params:
            if p.name == "status_period_s" and hasattr(self, "_status_timer"):
                self._status_timer.timer_period_ns = int(p.value * 1e9)
        return SetParametersResult(successful=True)

    # -- callbacks: only enqueue ------------------------------------------------------------
    def _on_config(self, raw: bytes) -> None:
        topic = self.resolve_topic_name("pier_configuration")
        try:
            text = deserialize_message(raw, String).data
            config = config_from_yaml(text, source=topic)
        except Exception as err:  # malformed: log and keep running
            self.stats["messages_dropped"] += 1
            self._log_drop(topic, err)
            return
        if self._stream is None:
            self._set_config(config, topic)
        else:
            self._queue.put(("config", topic, config))

    def _set_config(self, config: PierConfig, source: str) -> None:
        self._specs = {s.sensor_id: s for s in config.sensors}
        imu = set(self._imu_ids)
        unknown = imu - set(self._specs)
        if unknown:
            self.get_logger().error(f"imu_sensor_ids: {sorted(unknown)} are not in the sensor "
                                    "map; ignored")
        self._stream = StreamIngest(config, buffer_s=self._buffer_s, poll_s=self._poll_s)
        self._queue.put(("started", source, config))
        for spec in config.sensors:
            msg_type = Imu if spec.sensor_id in imu else SampleBlock
            topic = spec.topic.lstrip("/")  # relative: the node's namespace is the pier's
            self._subs.append(self.create_subscription(
                msg_type, topic,
                lambda raw, sid=spec.sensor_id, t=msg_type: self._on_sample(sid, t, raw),
                IMU_QOS if msg_type is Imu else SENSOR_QOS, raw=True))
        self.get_logger().info(f"pier {config.pier_id}: {len(config.sensors)} sensors from "
                               f"{source}, {len(imu & set(self._specs))} of them Imu")

    def _on_sample(self, sensor_id: str, msg_type: type, raw: bytes) -> None:
        self._queue.put(("sample", sensor_id, msg_type, raw))

    # -- worker -----------------------------------------------------------------------------
    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            try:
                self._handle(item)
            except Exception as err:  # never let one bad item stop the ingest
                self._last_error = f"{type(err).__name__}: {err}"
                self.get_logger().error(f"ingest worker: {self._last_error}")

    def _handle(self, item: tuple[Any, ...]) -> None:
        kind = item[0]
        if kind == "config":
            _, topic, config = item
            self._stream.update_config(self._max_time_ns + 1, config)
            self._config_updates.append((self._max_time_ns + 1, config))
            self.get_logger().info(f"{topic}: configuration update from "
                                   f"{self._max_time_ns / 1e9:.3f} s")
            return
        if kind == "started":
            return
        _, sid, msg_type, raw = item
        spec = self._specs[sid]
        topic = self.resolve_topic_name(spec.topic.lstrip("/"))
        try:
            msg = deserialize_message(raw, msg_type)
            if msg_type is Imu:
                times, data = imu_arrays(msg, spec, topic)
                # an Imu carries no sample index: derive it from the stamp (the sensor's
                # clock), so that a lost message is a gap, not a shift of every later sample
                t0 = self._imu_t0.setdefault(sid, int(times[0]))
                index = np.rint((times - t0) * (self._stream.rate / NS_PER_S)).astype(np.int64)
            else:
                times, data, index = block_arrays(msg, spec, self._stream.rate, topic)
        except Exception as err:
            self.stats["messages_dropped"] += 1
            self._log_drop(topic, err)
            return
        self._account(sid, times, index)
        windows = self._stream.push(sid, times, data, index)
        self._emit(windows)

    def _account(self, sid: str, times: Any, index: Any) -> None:
        n = int(times.size)
        self._last_seen[sid] = time.monotonic()
        if n:
            self._max_time_ns = max(self._max_time_ns, int(times[-1]))
        if index is not None and n:
            expected = self._next_index.get(sid)
            first = int(index[0])
            if expected is not None and first > expected:
                self.stats["gap_samples"] += first - expected
            elif expected is not None and first < expected:
                self.stats["duplicate_samples"] += min(n, expected - first)
            self._next_index[sid] = max(expected or 0, int(index[-1]) + 1)
        self.stats["messages_received"] += 1
        self.stats["samples_received"] += n

    def _emit(self, windows: list[MeasuredWindow]) -> None:
        for window in windows:
            self._window_dir.mkdir(parents=True, exist_ok=True)
            path = save_window(window, self._window_dir / f"{window.event_id}.npz")
            config = self._stream.config
            for t_ns, c in self._config_updates:  # the configuration of the event
                if t_ns <= window.start_time_ns:
                    config = c
            self._window_pub.publish(window_to_msg(window, config))
            self.stats["windows_emitted"] += 1
            self._last_window = window.event_id
            self.get_logger().info(f"window {window.event_id} ({window.duration_s:.2f} s) "
                                   f"written to {path} and published")

    def _log_drop(self, topic: str, err: Exception) -> None:
        self._last_error = f"{topic}: {err}"
        n = self._drops_by_topic[topic] = self._drops_by_topic.get(topic, 0) + 1
        if n <= 10 or n % 100 == 0:  # a flood of bad messages does not flood the log
            self.get_logger().error(f"{topic}: dropped a message ({n} so far): "
                                    f"{type(err).__name__}: {err}")

    # -- status -----------------------------------------------------------------------------
    def status(self) -> DiagnosticStatus:
        """The node's status: counters, channels alive, exclusions."""
        now = time.monotonic()
        timeout = self.get_parameter("alive_timeout_s").value
        alive = sorted(s for s, t in self._last_seen.items() if now - t <= timeout)
        silent = sorted(set(self._specs) - set(alive))
        exclusions = []
        if self._stream is not None:
            exclusions = sorted({f"{w}: {c}" for c, w, _ in list(self._stream.report.events)
                                 if c in _EXCLUSION_CODES})
        st = DiagnosticStatus()
        st.name = f"pier_monitor/{self.get_namespace().strip('/') or 'pier'}/ingest"
        st.hardware_id = self.get_namespace()
        if self._stream is None:
            st.level, st.message = DiagnosticStatus.WARN, "waiting for the pier configuration"
        elif self.stats["messages_dropped"] or self.stats["gap_samples"] or exclusions:
            st.level, st.message = DiagnosticStatus.WARN, (
                f"{self.stats['messages_dropped']} messages dropped, "
                f"{self.stats['gap_samples']} samples missing, {len(exclusions)} exclusions")
        else:
            st.level, st.message = DiagnosticStatus.OK, f"{len(alive)} channels alive"
        values = dict(self.stats, queue_backlog=self._queue.qsize(),
                      channels=len(self._specs), channels_alive=len(alive))
        st.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        st.values += [KeyValue(key="silent_channels", value=",".join(silent)),
                      KeyValue(key="exclusions", value="; ".join(exclusions)),
                      KeyValue(key="last_window", value=self._last_window),
                      KeyValue(key="last_error", value=self._last_error)]
        return st

    def _publish_status(self) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [self.status()]
        self._status_pub.publish(arr)
        self._diag_pub.publish(arr)

    # -- shutdown ---------------------------------------------------------------------------
    def destroy_node(self) -> None:
        """Drain the queue, flush events that ended with the stream to disk, stop the worker."""
        self._queue.put(_STOP)
        self._worker.join(timeout=30.0)
        if self._stream is not None:
            try:
                for window in self._stream.flush():
                    self._window_dir.mkdir(parents=True, exist_ok=True)
                    save_window(window, self._window_dir / f"{window.event_id}.npz")
                    self.get_logger().info(f"window {window.event_id} at the end of the "
                                           "stream written to disk")
            except Exception as err:
                self.get_logger().error(f"flush at shutdown: {type(err).__name__}: {err}")
        super().destroy_node()


def run_node(node_class: type, args: list[str] | None = None) -> int:
    """Spin one node on a SingleThreadedExecutor until Ctrl-C / SIGTERM; clean shutdown."""
    import signal

    rclpy.init(args=args)
    node = None
    executor = SingleThreadedExecutor()
    signal.signal(signal.SIGTERM, lambda *_: rclpy.try_shutdown())
    try:
        node = node_class()
        executor.add_node(node)
        print(f"READY {node.get_fully_qualified_name()}", flush=True)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        # a second Ctrl-C (terminal and start_graph.py both signal) must not cut the cleanup
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(args: list[str] | None = None) -> int:
    """Entry point: ``python -m pier_monitor.nodes.ingest_node --ros-args ...``."""
    return run_node(IngestNode, args if args is not None else sys.argv)


if __name__ == "__main__":
    sys.exit(main())
