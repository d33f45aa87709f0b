"""Incremental ingest of sample blocks as they arrive (the live node's path)."""

from __future__ import annotations

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.events import detect_events, trigger_threshold
from pier_monitor.core.ingest.levels import level_motion_partial
from pier_monitor.core.ingest.prepare import clean_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
from pier_monitor.core.ingest.settings import IngestReport, IngestSettings
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.ingest.windows import ingest_recording
from pier_monitor.core.model.config import PierConfig

__all__ = ["StreamIngest"]


class StreamIngest:
    """Incremental ingest: feed sample blocks as they arrive, get windows once events end.

    A bounded ring buffer per sensor keeps ``buffer_s`` seconds.  Every ``poll_s`` of new
    foundation data the causal trigger runs on the buffered foundation accelerometers; once
    an event has ended (``merge_gap_s`` + ``context_s`` of data after its window), the
    buffered samples are ingested exactly as :func:`ingest_recording` would and the window is
    returned by :meth:`push`.  Nothing received is dropped: samples stay in the buffer until
    they are older than ``buffer_s``, and :attr:`received` counts them.

    :attr:`report` gathers every finding once, and in ``report.outcomes`` the outcome of
    every event handed on: with its window, or failed (the reason names the level, sensors,
    time and cause) or cut by the end of the stream.
    """

    def __init__(self, config: PierConfig, settings: IngestSettings | None = None,
                 buffer_s: float = 300.0, poll_s: float = 1.0) -> None:
        self.config = config
        self.settings = settings or IngestSettings()
        self.buffer_s = buffer_s
        self.rate = config.sample_rate_hz
        self._cap = int(buffer_s * self.rate) + 1
        self._buf: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
        self._count: dict[str, int] = {}
        self._foundation = {sp.sensor_id for sp in config.sensors
                            if sp.level == 0 and sp.kind == "acceleration"}
        self._poll_ns = int(poll_s * NS_PER_S)
        self._last_poll_ns: int | None = None
        self._done_until_ns = -1
        self._updates: list[tuple[int, PierConfig]] = []
        self.report = IngestReport()
        self.received = 0

    def update_config(self, time_ns: int, config: PierConfig) -> None:
        """A new configuration holds from ``time_ns`` (e.g. deck mass added before a run).

        Only geometry and design values may change; the sensor map stays.
        """
        self._updates.append((int(time_ns), config))
        Recording(self.config, {}, config_updates=tuple(self._updates))  # validates

    def push(self, sensor_id: str, time_ns: np.ndarray, data: np.ndarray,
             sample_index: np.ndarray | None = None) -> list[MeasuredWindow]:
        """Add a block of one sensor (times in ns, data (T, n_axes) as recorded).

        Returns the windows of events that have just ended (usually none).
        """
        time_ns = np.asarray(time_ns, dtype=np.int64).reshape(-1)
        if sensor_id not in {sp.sensor_id for sp in self.config.sensors}:
            if not any(f.code == "unmapped_sensor" and f.where == sensor_id
                       for f in self.report.findings):
                t = int(time_ns[0]) if time_ns.size else 0
                self.report.add("unmapped_sensor", sensor_id, "sample blocks of a sensor that "
                                "is not in the sensor map; ignored", t, t)
            return []
        n_axes = len(self.config.sensor(sensor_id).axes)
        data = np.asarray(data, dtype=float)
        if data.size != time_ns.size * n_axes:
            raise InputDataError(f"sensor {sensor_id}: block of {time_ns.size} times but "
                                 f"{data.size} values; expected {time_ns.size} x {n_axes}")
        data = data.reshape(time_ns.size, n_axes)
        if sample_index is None:
            start = self._count.get(sensor_id, 0)
            sample_index = np.arange(start, start + time_ns.size, dtype=np.int64)
        sample_index = np.asarray(sample_index, dtype=np.int64).reshape(-1)
        if time_ns.size:
            self._count[sensor_id] = max(self._count.get(sensor_id, 0),
                                         int(sample_index.max()) + 1)
        self._buf.setdefault(sensor_id, []).append((time_ns, data, sample_index))
        self.received += time_ns.size
        self._trim(sensor_id)
        if sensor_id not in self._foundation or not time_ns.size:
            return []
        now = int(time_ns.max())
        if self._last_poll_ns is not None and now - self._last_poll_ns < self._poll_ns:
            return []
        self._last_poll_ns = now
        return self._poll()

    def flush(self) -> list[MeasuredWindow]:
        """End of the stream: windows of events whose data ended with the stream."""
        return self._poll(final=True)

    def _trim(self, sensor_id: str) -> None:
        blocks = self._buf[sensor_id]
        total = sum(b[0].size for b in blocks)
        while blocks and total - blocks[0][0].size >= self._cap:
            total -= blocks.pop(0)[0].size

    def _recording(self, only: set[str] | None = None) -> Recording:
        sensors = {}
        for sid, blocks in self._buf.items():
            if not blocks or (only is not None and sid not in only):
                continue
            sensors[sid] = SensorRecord(sid, np.concatenate([b[0] for b in blocks]),
                                        np.concatenate([b[1] for b in blocks]), self.rate,
                                        np.concatenate([b[2] for b in blocks]))
        return Recording(self.config, sensors, source="stream",
                         config_updates=tuple(self._updates))

    def _poll(self, final: bool = False) -> list[MeasuredWindow]:
        s = self.settings
        found = self._recording(self._foundation)
        if not found.sensors:
            return []
        quiet_ns = int((s.merge_gap_s + s.context_s) * NS_PER_S)
        scratch = IngestReport()
        cleaned, t0, n, rate = clean_recording(found, s, scratch)
        ag_xy = level_motion_partial(cleaned, "acceleration", 0, slice(0, n))
        if ag_xy is None:
            return []
        spans = detect_events(ag_xy, rate, trigger_threshold(self.config, s), s)
        end_ns = found.end_ns
        ready = [sp for sp in spans
                 if t0 + int(sp.start * NS_PER_S / rate) > self._done_until_ns
                 and (final or end_ns - (t0 + int(sp.end * NS_PER_S / rate)) >= quiet_ns)]
        if not ready:
            return []
        _, report = ingest_recording(self._recording(), s)
        # each ingest reports on the whole buffer: keep every finding once
        seen = set(self.report.findings)
        self.report.findings.extend(f for f in report.findings if f not in seen)
        self.report.checks.update(report.checks)
        out = []
        for outcome in report.outcomes:
            if outcome.start_ns <= self._done_until_ns:
                continue
            if not final and end_ns - outcome.end_ns < quiet_ns:
                continue
            self.report.outcomes.append(outcome)
            self._done_until_ns = outcome.start_ns
            if outcome.window is not None:
                out.append(outcome.window)
        return out
