"""Incremental ingest of sample blocks as they arrive (the live node's path)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.events import detect_events, trigger_threshold
from pier_monitor.core.ingest.levels import level_motion_partial
from pier_monitor.core.ingest.prepare import clean_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
from pier_monitor.core.ingest.settings import IngestReport, IngestSettings, fmt_time
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.ingest.windows import ingest_recording
from pier_monitor.core.model.config import PierConfig

__all__ = ["StreamIngest", "StreamCounts"]


@dataclass(frozen=True)
class StreamCounts:
    """What a :class:`StreamIngest` received so far.

    Attributes
    ----------
    blocks : int
        Blocks pushed (of mapped sensors).
    samples : int
        Samples pushed (of mapped sensors).
    gap_samples : int
        Samples missing between consecutive blocks of a sensor (by sample index).
    duplicate_samples : int
        Samples of a block that repeat indices already received.
    windows : int
        Windows returned so far.
    """

    blocks: int = 0
    samples: int = 0
    gap_samples: int = 0
    duplicate_samples: int = 0
    windows: int = 0


class StreamIngest:
    """Incremental ingest: feed sample blocks as they arrive, get windows once events end.

    A bounded ring buffer per sensor keeps ``buffer_s`` seconds.  Every ``poll_s`` of new
    foundation data the causal trigger runs on the buffered foundation accelerometers; once
    an event has ended (``merge_gap_s`` + ``context_s`` of data after its window), the
    buffered samples are ingested exactly as :func:`ingest_recording` would and the window is
    returned by :meth:`push`.  Sensors arrive on topics of their own and one may lag the
    foundation (a slow link, a replay faster than real time): an event waits until every
    sensor that sends has data up to the end of its window's context, or has lagged the
    foundation by more than ``max_lag_s`` of data (it is then left to the ingest's checks:
    a sensor that fell silent does not hold the events back).  Only data times count, never
    the wall clock.  Nothing received is dropped: samples stay in the buffer until
    they are older than ``buffer_s``, and :attr:`counts` accounts for every one of them
    (gaps and duplicates by sample index).

    :attr:`report` gathers every finding once, and in ``report.outcomes`` the outcome of
    every event handed on: with its window, or failed (the reason names the level, sensors,
    time and cause) or cut by the end of the stream.

    The configuration history lives here too: :meth:`update_config` adds an update (e.g.
    deck mass added before a run) and :meth:`config_at` answers which configuration held at
    a time, as :meth:`Recording.config_at` does for a whole recording.
    """

    def __init__(self, config: PierConfig, settings: IngestSettings | None = None,
                 buffer_s: float = 300.0, poll_s: float = 1.0, max_lag_s: float = 30.0) -> None:
        self.config = config
        self.settings = settings or IngestSettings()
        self.buffer_s = buffer_s
        self.rate = config.sample_rate_hz
        self._cap = int(buffer_s * self.rate) + 1
        self._buf: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
        self._next_index: dict[str, int] = {}
        self._first_ns: dict[str, int] = {}  # time of sample index 0 of sensors without indices
        self._mapped = {sp.sensor_id for sp in config.sensors}
        self._foundation = {sp.sensor_id for sp in config.sensors
                            if sp.level == 0 and sp.kind == "acceleration"}
        self._poll_ns = int(poll_s * NS_PER_S)
        self._max_lag_ns = int(max_lag_s * NS_PER_S)
        self._latest_by_sensor: dict[str, int] = {}
        self._last_poll_ns: int | None = None
        self._done_until_ns = -1
        self._history = Recording(config, {}, source="stream")
        self._latest_ns: int | None = None
        self.counts = StreamCounts()
        self.report = IngestReport()

    @property
    def received(self) -> int:
        """Samples received so far (of mapped sensors)."""
        return self.counts.samples

    @property
    def latest_time_ns(self) -> int | None:
        """Time of the latest sample received, ns (None before the first)."""
        return self._latest_ns

    def update_config(self, config: PierConfig, time_ns: int | None = None) -> int:
        """A new configuration holds from ``time_ns``; returns that time.

        ``time_ns`` defaults to just after the latest sample received (an update that
        arrives during the stream holds for what comes next).  Only geometry and design
        values may change; the sensor map stays.

        Raises
        ------
        InputDataError
            If the update changes the pier, its levels or its sensor map.
        """
        if time_ns is None:
            time_ns = (self._latest_ns + 1) if self._latest_ns is not None else 0
        updates = (*self._history.config_updates, (int(time_ns), config))
        self._history = Recording(self.config, {}, source="stream", config_updates=updates)
        return int(time_ns)

    def config_at(self, time_ns: int) -> PierConfig:
        """The configuration in force at ``time_ns`` (the latest update at or before it)."""
        return self._history.config_at(time_ns)

    def exclusions(self) -> list[str]:
        """``"<sensor>: <code>"`` for every exclusion reported so far (findings whose action
        is ``excluded``: a sensor, a channel or a stretch of one left out), sorted."""
        return sorted({f"{f.where}: {f.code}" for f in list(self.report.findings)
                       if f.action == "excluded"})

    def push(self, sensor_id: str, time_ns: np.ndarray, data: np.ndarray,
             sample_index: np.ndarray | None = None) -> list[MeasuredWindow]:
        """Add a block of one sensor (times in ns, data (T, n_axes) as recorded).

        ``sample_index`` (T,) is the running index of each sample.  Without it (a
        ``sensor_msgs/Imu`` carries none) the index follows from the time stamps on the
        sensor's own clock, ``round((t - t_first) * rate)``, so that a lost message is a gap
        and not a shift of every later sample.

        Returns the windows of events that have just ended (usually none).
        """
        time_ns = np.asarray(time_ns, dtype=np.int64).reshape(-1)
        if sensor_id not in self._mapped:
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
            first = self._first_ns.setdefault(sensor_id, int(time_ns[0]) if time_ns.size else 0)
            rate = self.config.sensor_rate_hz(self.config.sensor(sensor_id))
            sample_index = np.rint((time_ns - first) * (rate / NS_PER_S)).astype(np.int64)
        sample_index = np.asarray(sample_index, dtype=np.int64).reshape(-1)
        # a block stamped far behind the stream (a logger without a clock yet) would stretch
        # the buffer's time grid over years: dropped, and named
        buffer_ns = int(self.buffer_s * NS_PER_S)
        if time_ns.size and self._latest_ns is not None \
                and int(time_ns.max()) < self._latest_ns - buffer_ns:
            t = int(time_ns[0])
            stale = sum(f.code == "stale_block" and f.where == sensor_id
                        for f in self.report.findings)
            if stale < 10:
                self.report.add("stale_block", sensor_id, f"a block of {time_ns.size} samples "
                                f"stamped {fmt_time(t)} is more than "
                                f"buffer_s {self.buffer_s:g} s behind the stream's newest sample "
                                f"{fmt_time(self._latest_ns)}; dropped", self._latest_ns,
                                self._latest_ns, "excluded")
            return []
        self._account(sensor_id, time_ns, sample_index)
        blocks = self._buf.setdefault(sensor_id, [])
        blocks.append((time_ns, data, sample_index))
        # and one already buffered before the stream's clock came (the same, seen late)
        blocks[:] = [b for b in blocks if not b[0].size
                     or int(b[0].max()) >= self._latest_ns - buffer_ns]
        self._trim(sensor_id)
        if sensor_id not in self._foundation or not time_ns.size:
            return []
        now = int(time_ns.max())
        if self._last_poll_ns is not None and now - self._last_poll_ns < self._poll_ns:
            return []
        self._last_poll_ns = now
        return self._emit(self._poll())

    def flush(self) -> list[MeasuredWindow]:
        """End of the stream: windows of events whose data ended with the stream."""
        return self._emit(self._poll(final=True))

    def _account(self, sensor_id: str, time_ns: np.ndarray, index: np.ndarray) -> None:
        c = self.counts
        gaps, dups, n = c.gap_samples, c.duplicate_samples, int(time_ns.size)
        if n:
            last = int(time_ns.max())
            self._latest_ns = last if self._latest_ns is None else max(self._latest_ns, last)
            self._latest_by_sensor[sensor_id] = max(self._latest_by_sensor.get(sensor_id, last),
                                                    last)
            expected = self._next_index.get(sensor_id)
            first = int(index[0])
            if expected is not None and first > expected:
                gaps += first - expected
            elif expected is not None and first < expected:
                dups += min(n, expected - first)
            self._next_index[sensor_id] = max(expected or 0, int(index.max()) + 1)
        self.counts = StreamCounts(blocks=c.blocks + 1, samples=c.samples + n, gap_samples=gaps,
                                   duplicate_samples=dups, windows=c.windows)

    def _emit(self, windows: list[MeasuredWindow]) -> list[MeasuredWindow]:
        if windows:
            c = self.counts
            self.counts = StreamCounts(c.blocks, c.samples, c.gap_samples, c.duplicate_samples,
                                       c.windows + len(windows))
        return windows

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
                                        np.concatenate([b[1] for b in blocks]),
                                        self.config.sensor_rate_hz(self.config.sensor(sid)),
                                        np.concatenate([b[2] for b in blocks]))
        return Recording(self.config, sensors, source="stream",
                         config_updates=self._history.config_updates)

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
        context_ns = int(s.context_s * NS_PER_S)

        def complete(event_end_ns: int) -> bool:
            """The foundation has been quiet long enough after the event, and every sensor
            has caught up with its context or lags by more than max_lag_s."""
            if final:
                return True
            return end_ns - event_end_ns >= quiet_ns and all(
                latest >= event_end_ns + context_ns or end_ns - latest > self._max_lag_ns
                for latest in self._latest_by_sensor.values())

        ready = [sp for sp in spans
                 if t0 + int(sp.start * NS_PER_S / rate) > self._done_until_ns
                 and complete(t0 + int(sp.end * NS_PER_S / rate))]
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
            if not complete(outcome.end_ns):
                continue
            self.report.outcomes.append(outcome)
            self._done_until_ns = outcome.start_ns
            if outcome.window is not None:
                out.append(outcome.window)
        return out
