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
  dropped, channels alive, gaps, duplicates, exclusions, the number of ingest findings; WARN
  naming the sensors with an exclusion; WARN when every channel has been silent for
  ``alive_timeout_s`` and STALE after ``stale_timeout_s``
  (:func:`~pier_monitor.report.diagnostics.ingest_silence`).  An event the ingest can give no window of (a level
  left without usable sensors, or the stream ending while the ground still shakes) adds a
  status of its own, ``pier_monitor/<pier>/ingest/<event_id>``, at ERROR with the reason
  (level, sensors, time, cause), and is logged as an error.

Subscriptions are raw: callbacks only enqueue bytes; a worker thread decodes, checks each
message against the sensor map (a malformed or mis-typed message is logged with its topic
and dropped) and feeds :class:`~pier_monitor.core.ingest.StreamIngest`, which accounts for
every sample (gaps, duplicates), keeps the configuration history and runs the event
processing (~0.5 s per event), never on the executor.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from pier_monitor_msgs.msg import MainshockWindow, SampleBlock
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Imu
from std_msgs.msg import String

from pier_monitor.core.ids import EVENT_ID_MAX_LEN, check_id, safe_child
from pier_monitor.core.ingest import StreamIngest
from pier_monitor.core.ingest.settings import EventIngest
from pier_monitor.core.ingest.findings import fmt_time
from pier_monitor.core.ingest.window import MeasuredWindow, save_window
from pier_monitor.core.model.config import PierConfig, SensorSpec, config_from_yaml, load_config

from pier_monitor.report.diagnostics import ingest_silence

from ._params import declare
from ._runtime import QueueWorker, run_node
from .conversions import block_arrays, imu_arrays, window_to_msg
from .qos import IMU_QOS, LATCHED_QOS, SENSOR_QOS, WINDOW_QOS

__all__ = ["IngestNode", "main"]

#: Work items: a sensor message ``("sample", sensor_id, type, raw bytes)`` or a configuration
#: update ``("config", topic, config)``.
_Item = tuple[str, str, type, bytes] | tuple[str, str, PierConfig]


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
                "counts as not alive; with every channel silent the status is WARN",
                unit="s", lo=0.1, hi=600.0)
        declare(self, "stale_timeout_s", 30.0, "With every channel silent for this long the "
                "status is STALE", unit="s", lo=0.1, hi=3600.0)
        self.add_on_set_parameters_callback(self._on_set_parameters)

        self._stream: StreamIngest | None = None
        self._specs: dict[str, SensorSpec] = {}
        self._subs: list[Any] = []
        self._last_seen: dict[str, float] = {}  # monotonic time of each sensor's last message
        self._dropped = 0
        self._drops_by_topic: dict[str, int] = {}
        self._last_error = ""
        self._last_window = ""
        self._failed: list[EventIngest] = []  # events without a window, in time order
        self._outcomes_seen = 0

        self._window_pub = self.create_publisher(MainshockWindow, "mainshock_window", WINDOW_QOS)
        self._status_pub = self.create_publisher(DiagnosticArray, "ingest_status", 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._status_timer = self.create_timer(
            self.get_parameter("status_period_s").value, self._publish_status)
        self._worker: QueueWorker[_Item] = QueueWorker("ingest_worker", self._handle,
                                                       self._on_worker_error)
        if self._config_file:
            self._start(load_config(self._config_file), "config_file")
        else:
            self._config_sub = self.create_subscription(
                String, "pier_configuration", self._on_config, LATCHED_QOS, raw=True)
        self.get_logger().info(
            f"ingest in {self.get_namespace()}: windows to {self._window_dir}, configuration "
            f"from {self._config_file or self.resolve_topic_name('pier_configuration')}")

    # -- parameters -------------------------------------------------------------------------
    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        for p in params:
            if p.name == "status_period_s" and hasattr(self, "_status_timer"):
                self._status_timer.timer_period_ns = int(p.value * 1e9)
        return SetParametersResult(successful=True)

    # -- callbacks: only enqueue (the first configuration also subscribes) ------------------
    def _on_config(self, raw: bytes) -> None:
        topic = self.resolve_topic_name("pier_configuration")
        try:
            config = config_from_yaml(deserialize_message(raw, String).data, source=topic)
        except Exception as err:  # malformed: log and keep running
            self._drop(topic, err)
            return
        if self._stream is None:
            self._start(config, topic)
        else:
            self._worker.put(("config", topic, config))

    def _on_sample(self, sensor_id: str, msg_type: type, raw: bytes) -> None:
        self._worker.put(("sample", sensor_id, msg_type, raw))

    def _start(self, config: PierConfig, source: str) -> None:
        """The first configuration: start the stream and subscribe to every sensor."""
        self._specs = {s.sensor_id: s for s in config.sensors}
        imu = set(self._imu_ids)
        unknown = imu - set(self._specs)
        if unknown:
            self.get_logger().error(f"imu_sensor_ids: {sorted(unknown)} are not in the sensor "
                                    "map; ignored")
        self._stream = StreamIngest(config, buffer_s=self._buffer_s, poll_s=self._poll_s)
        for spec in config.sensors:
            msg_type = Imu if spec.sensor_id in imu else SampleBlock
            topic = spec.topic.lstrip("/")  # relative: the node's namespace is the pier's
            self._subs.append(self.create_subscription(
                msg_type, topic,
                lambda raw, sid=spec.sensor_id, t=msg_type: self._on_sample(sid, t, raw),
                IMU_QOS if msg_type is Imu else SENSOR_QOS, raw=True))
        self.get_logger().info(f"pier {config.pier_id}: {len(config.sensors)} sensors from "
                               f"{source}, {len(imu & set(self._specs))} of them Imu")

    # -- worker -----------------------------------------------------------------------------
    def _handle(self, item: _Item) -> None:
        if item[0] == "config":
            _, topic, config = item
            t_ns = self._stream.update_config(config)
            self.get_logger().info(f"{topic}: configuration update from {t_ns / 1e9:.3f} s")
            return
        _, sid, msg_type, raw = item
        spec = self._specs[sid]
        topic = self.resolve_topic_name(spec.topic.lstrip("/"))
        try:
            msg = deserialize_message(raw, msg_type)
            if msg_type is Imu:  # no sample index: the stream derives it from the stamps
                (times, data), index = imu_arrays(msg, spec, topic), None
            else:
                times, data, index = block_arrays(
                    msg, spec, self._stream.config.sensor_rate_hz(spec), topic)
        except Exception as err:
            self._drop(topic, err)
            # a finding too, as the bag reader gives: the stream's report names the block
            t_ns = self._stream.latest_time_ns or 0
            if self._drops_by_topic[topic] <= 10:  # a flood is counted, not listed
                self._stream.report.add("bad_block", sid, f"{topic}: {type(err).__name__}: {err}; "
                                        "block dropped", t_ns, t_ns, "excluded")
            return
        self._last_seen[sid] = time.monotonic()
        for window in self._stream.push(sid, times, data, index):
            self._emit(window)
        self._note_failed_events()

    def _note_failed_events(self) -> None:
        """Log the events handed on without a window (and the partial ones) since the last
        call, and keep those without a window for the status."""
        outcomes = self._stream.report.outcomes
        for outcome in outcomes[self._outcomes_seen:]:
            if outcome.window is None:
                self._failed.append(outcome)
                self.get_logger().error(f"event {outcome.event_id}: {outcome.status}, no "
                                        f"window: {outcome.failure}")
            elif outcome.partial is not None:
                self.get_logger().warning(f"event {outcome.event_id}: partial window: "
                                          f"{outcome.partial}")
        self._outcomes_seen = len(outcomes)

    def _window_file(self, window: MeasuredWindow) -> Path:
        """``window_dir/<event_id>.npz``, created; never outside ``window_dir``."""
        self._window_dir.mkdir(parents=True, exist_ok=True)
        event_id = check_id("event_id", window.event_id, max_len=EVENT_ID_MAX_LEN)
        return safe_child(self._window_dir, f"{event_id}.npz")

    def _emit(self, window: MeasuredWindow) -> None:
        path = save_window(window, self._window_file(window))
        config = self._stream.config_at(window.start_time_ns)
        self._window_pub.publish(window_to_msg(window, config))
        self._last_window = window.event_id
        self.get_logger().info(f"window {window.event_id} ({window.duration_s:.2f} s) "
                               f"written to {path} and published")

    def _drop(self, topic: str, err: Exception) -> None:
        self._dropped += 1
        self._last_error = f"{topic}: {err}"
        n = self._drops_by_topic[topic] = self._drops_by_topic.get(topic, 0) + 1
        if n <= 10 or n % 100 == 0:  # a flood of bad messages does not flood the log
            self.get_logger().error(f"{topic}: dropped a message ({n} so far): "
                                    f"{type(err).__name__}: {err}")

    def _on_worker_error(self, item: _Item, err: Exception) -> None:
        self._last_error = f"{type(err).__name__}: {err}"
        self.get_logger().error(f"ingest worker: {self._last_error}")

    # -- status -----------------------------------------------------------------------------
    def status(self) -> DiagnosticStatus:
        """The node's status: counters, channels alive, findings, exclusions, failed events."""
        now = time.monotonic()
        timeout = self.get_parameter("alive_timeout_s").value
        alive = sorted(s for s, t in self._last_seen.items() if now - t <= timeout)
        silent = sorted(set(self._specs) - set(alive))
        stream = self._stream
        counts = stream.counts if stream is not None else None
        exclusions = stream.exclusions() if stream is not None else []
        findings = list(stream.report.findings) if stream is not None else []
        excluded = sorted({f.sensor_id for f in findings if f.action == "excluded"})
        failed = list(self._failed)
        st = DiagnosticStatus()
        st.name = self._status_name()
        st.hardware_id = self.get_namespace()
        gaps = counts.gap_samples if counts else 0
        silence = ingest_silence(len(self._specs), [now - t for t in self._last_seen.values()],
                                 timeout, self.get_parameter("stale_timeout_s").value)
        if stream is None:
            st.level, st.message = DiagnosticStatus.WARN, "waiting for the pier configuration"
        elif silence is not None or self._dropped or gaps or exclusions or failed:
            parts = [] if silence is None else [silence[1]]
            if self._dropped or gaps or exclusions:
                parts.append(f"{self._dropped} messages dropped, {gaps} samples missing, "
                             f"{len(exclusions)} exclusions")
            if excluded:
                parts.append(f"excluded: {', '.join(excluded)}")
            if failed:
                parts.append(f"{len(failed)} events without a window: "
                             f"{', '.join(o.event_id for o in failed)}")
            # rclpy's byte field takes one-byte bytes (the constants are)
            level = DiagnosticStatus.WARN if silence is None else bytes([silence[0]])
            st.level, st.message = level, "; ".join(parts)[:500]
        else:
            st.level, st.message = DiagnosticStatus.OK, f"{len(alive)} channels alive"
        values = {
            "messages_received": counts.blocks if counts else 0,
            "samples_received": counts.samples if counts else 0,
            "messages_dropped": self._dropped,
            "gap_samples": gaps,
            "duplicate_samples": counts.duplicate_samples if counts else 0,
            "windows_emitted": counts.windows if counts else 0,
            "queue_backlog": self._worker.backlog,
            "channels": len(self._specs),
            "channels_alive": len(alive),
            "silent_channels": ",".join(silent),
            "exclusions": "; ".join(exclusions),
            "findings": len(findings),
            "excluded_sensors": ",".join(excluded),
            "events_failed": len(failed),
            "failed_events": ",".join(o.event_id for o in failed),
            "last_window": self._last_window,
            "last_error": self._last_error,
        }
        st.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        return st

    def _status_name(self) -> str:
        return f"pier_monitor/{self.get_namespace().strip('/') or 'pier'}/ingest"

    def event_statuses(self) -> list[DiagnosticStatus]:
        """One ERROR status per event without a window, with its reason."""
        out = []
        for outcome in list(self._failed):
            st = DiagnosticStatus()
            st.name = f"{self._status_name()}/{outcome.event_id}"
            st.hardware_id = self.get_namespace()
            st.level = DiagnosticStatus.ERROR
            st.message = f"{outcome.status}, no window: {outcome.failure}"[:500]
            values = {"event_id": outcome.event_id, "status": outcome.status,
                      "start": fmt_time(outcome.start_ns), "end": fmt_time(outcome.end_ns),
                      "findings": len(outcome.findings), "reason": outcome.failure}
            st.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
            out.append(st)
        return out

    def _publish_status(self) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [self.status(), *self.event_statuses()]
        self._status_pub.publish(arr)
        self._diag_pub.publish(arr)

    # -- shutdown ---------------------------------------------------------------------------
    def destroy_node(self) -> None:
        """Drain the queue, write events that ended with the stream to disk, stop."""
        self._worker.stop(self.get_logger().info)
        if self._stream is not None:
            try:
                for window in self._stream.flush():
                    save_window(window, self._window_file(window))
                    self.get_logger().info(f"window {window.event_id} at the end of the "
                                           "stream written to disk")
                self._note_failed_events()
            except Exception as err:
                self.get_logger().error(f"flush at shutdown: {type(err).__name__}: {err}")
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point (``ros2 run pier_monitor ingest``, ``python -m ...ingest_node``)."""
    return run_node(IngestNode, args if args is not None else sys.argv)


if __name__ == "__main__":
    sys.exit(main())
