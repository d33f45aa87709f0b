"""Incremental ingest of sample blocks as they arrive (the live node's path)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.triggers import EventSpan, detect_events, trigger_threshold
from pier_monitor.core.ingest.levels import level_motion_partial
from pier_monitor.core.ingest.prepare import clean_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
from pier_monitor.core.ingest.settings import IngestReport, IngestSettings
from pier_monitor.core.ingest.findings import fmt_time
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.ingest.batch import SpanFilter, ingest_recording, span_times
from pier_monitor.core.model.config import PierConfig

__all__ = ["StreamIngest", "StreamCounts"]

#: Data a sensor must hold beyond an event's context before the event is ingested, s: the
#: cleaning judges samples by the statistics of their whole UTC second.
_EDGE_S = 1.0


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


class _Buffer:
    """The samples of one sensor kept by a stream: the newest ``cap`` or a few more.

    New blocks are appended to a list and joined into one array only when the samples are
    read (:meth:`arrays`) or the buffer overflows, so a block costs O(its size).
    """

    def __init__(self, cap: int) -> None:
        self.cap = cap
        self._blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.size = 0
        self.oldest_ns: int | None = None

    def append(self, time_ns: np.ndarray, data: np.ndarray, index: np.ndarray) -> None:
        self._blocks.append((time_ns, data, index))
        self.size += time_ns.size
        if time_ns.size:
            low = int(time_ns.min())
            self.oldest_ns = low if self.oldest_ns is None else min(self.oldest_ns, low)
        if self.size > self.cap + max(self.cap // 8, 1):
            t, d, i = self.arrays()
            self._blocks = [(t[-self.cap:], d[-self.cap:], i[-self.cap:])]
            self.size = self.cap

    def drop_before(self, limit_ns: int) -> None:
        """Drop the samples stamped before ``limit_ns`` (e.g. a block that came before the
        stream's clock did, seen late as far behind it)."""
        if self.oldest_ns is None or self.oldest_ns >= limit_ns:
            return
        t, d, i = self.arrays()
        keep = t >= limit_ns
        self._blocks = [(t[keep], d[keep], i[keep])]
        self.size = int(keep.sum())
        self.oldest_ns = int(t[keep].min()) if self.size else None

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(time_ns (T,), data (T, n_axes), sample_index (T,))`` in arrival order."""
        if len(self._blocks) > 1:
            self._blocks = [tuple(np.concatenate(parts) for parts in zip(*self._blocks))]
        return self._blocks[0]


class StreamIngest:
    """Incremental ingest: feed sample blocks as they arrive, get windows once events end.

    A bounded buffer per sensor keeps at least ``buffer_s`` seconds.  Every ``poll_s`` of
    new foundation data the causal trigger runs on the buffered foundation accelerometers
    (from a little before the earliest event not yet handed on).  An event is handed on
    once it has ended as :func:`ingest_recording` sees an ended event, and its data are in:

    * the trigger has been off for ``merge_gap_s`` (the offline rule: any later shaking is
      another event), so an event is never declared cut while the foundation still
      delivers data;
    * every sensor that sends has data up to ``context_s`` (and 1 s) beyond the event's
      window, or lags the foundation by more than ``max_lag_s`` of data (it is then left to
      the ingest's checks: a sensor that fell silent does not hold the events back).

    The buffered samples are then ingested exactly as :func:`ingest_recording` would ingest
    the whole recording (the windows' ``t`` counts from the stream's first sample), and
    the window is returned by :meth:`push`.  Only data times count, never the wall clock.

    At the end of the stream (:meth:`flush`, which the node calls at shutdown) every pending
    event is finalised as :func:`ingest_recording` would finalise it at the end of a
    recording: ingested, *partial* (the data end after its strong motion) or cut.  An event
    that shakes for longer than the buffer can hold is finalised in the same way on the
    buffered data before its beginning is lost, with a ``buffer_full`` finding that says so
    (the rest of that shaking is left out).

    Nothing received is dropped: samples stay in the buffer until they are older than
    ``buffer_s``, and :attr:`counts` accounts for every one of them (gaps and duplicates by
    sample index).  :attr:`report` gathers every finding once, and in ``report.outcomes``
    the outcome of every event handed on: with its window (``partial`` or not), or failed
    (the reason names the level, sensors, time and cause) or cut by the stream's edge.

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
        self._buf: dict[str, _Buffer] = {}
        self._next_index: dict[str, int] = {}
        self._first_ns: dict[str, int] = {}  # time of sample index 0 of sensors without indices
        self._mapped = {sp.sensor_id for sp in config.sensors}
        self._foundation = {sp.sensor_id for sp in config.sensors
                            if sp.level == 0 and sp.kind == "acceleration"}
        self._poll_ns = int(poll_s * NS_PER_S)
        self._max_lag_ns = int(max_lag_s * NS_PER_S)
        self._latest_by_sensor: dict[str, int] = {}
        self._last_poll_ns: int | None = None
        self._done_until_ns = -1  # events starting at or before this are handed on
        self._scan_from_ns: int | None = None  # the trigger needs no data before this
        self._origin_ns: int | None = None
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
        if sensor_id not in self._buf:
            rate = self.config.sensor_rate_hz(self.config.sensor(sensor_id))
            self._buf[sensor_id] = _Buffer(int(self.buffer_s * rate) + 1)
        self._buf[sensor_id].append(time_ns, data, sample_index)
        # and one already buffered before the stream's clock came (the same, seen late)
        if self._latest_ns is not None:
            self._buf[sensor_id].drop_before(self._latest_ns - buffer_ns)
        if sensor_id not in self._foundation or not time_ns.size:
            return []
        now = int(time_ns.max())
        if self._last_poll_ns is not None and now - self._last_poll_ns < self._poll_ns:
            return []
        self._last_poll_ns = now
        return self._emit(self._poll())

    def flush(self) -> list[MeasuredWindow]:
        """End of the stream: every pending event is finalised as at the end of a recording
        (ingested, partial or cut); returns the windows."""
        if not any(self._buf[sid].size for sid in self._foundation & set(self._buf)):
            return []  # no ground motion at all: nothing to finalise
        return self._emit(self._ingest(lambda span, start_ns, end_ns:
                                       start_ns > self._done_until_ns))

    def _account(self, sensor_id: str, time_ns: np.ndarray, index: np.ndarray) -> None:
        c = self.counts
        gaps, dups, n = c.gap_samples, c.duplicate_samples, int(time_ns.size)
        if n:
            last = int(time_ns.max())
            first_t = int(time_ns.min())
            self._origin_ns = first_t if self._origin_ns is None else min(self._origin_ns,
                                                                          first_t)
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

    def _recording(self, only: set[str] | None = None, from_ns: int | None = None,
                   until_ns: int | None = None) -> Recording:
        """The buffered samples (of ``only``, from ``from_ns`` on, up to ``until_ns``) as a
        recording."""
        sensors = {}
        for sid, buf in self._buf.items():
            if not buf.size or (only is not None and sid not in only):
                continue
            t, d, i = buf.arrays()
            if from_ns is not None or until_ns is not None:
                keep = np.ones(t.shape, dtype=bool)
                if from_ns is not None:
                    keep &= t >= from_ns
                if until_ns is not None:
                    keep &= t <= until_ns
                t, d, i = t[keep], d[keep], i[keep]
                if not t.size:
                    continue
            sensors[sid] = SensorRecord(sid, t, d,
                                        self.config.sensor_rate_hz(self.config.sensor(sid)), i)
        return Recording(self.config, sensors, source="stream",
                         config_updates=self._history.config_updates)

    def _ended(self, span: EventSpan, end_ns: int, found_end_ns: int) -> bool:
        """The event has ended as the offline rule sees it (the trigger off for
        ``merge_gap_s``: ``span.cut_end`` false) and every sensor that sends has data
        ``context_s`` (and :data:`_EDGE_S`) beyond its window, or lags by more than
        ``max_lag_s``."""
        if span.cut_end:
            return False
        need = end_ns + int((self.settings.context_s + _EDGE_S) * NS_PER_S)
        return found_end_ns >= need and all(
            latest >= need or found_end_ns - latest > self._max_lag_ns
            for latest in self._latest_by_sensor.values())

    def _poll(self) -> list[MeasuredWindow]:
        """Run the trigger on the buffered foundation data; ingest the events that ended,
        and those about to outgrow the buffer."""
        s = self.settings
        found = self._recording(self._foundation, self._scan_from_ns)
        if not found.sensors:
            return []
        scratch = IngestReport()
        cleaned, t0, n, rate = clean_recording(found, s, scratch)
        ag_xy = level_motion_partial(cleaned, "acceleration", 0, slice(0, n))
        if ag_xy is None:
            return []
        spans = [span_times(sp, t0, rate)
                 for sp in detect_events(ag_xy, rate, trigger_threshold(self.config, s), s)]
        pending = [(sp, a, b) for sp, a, b in spans if a > self._done_until_ns]
        found_end = found.end_ns
        margin_ns = int((s.trigger_window_s + s.merge_gap_s + s.pad_s + 2.0) * NS_PER_S)
        # the trigger of the next poll needs data from before every pending event (and any
        # shaking of the last merge_gap_s that may still grow into one), never much more
        scan_from = min([a for _, a, _ in pending] + [found_end]) - margin_ns
        scan_from -= scan_from % NS_PER_S  # whole UTC seconds, as the cleaning judges them
        if self._scan_from_ns is None or scan_from > self._scan_from_ns:
            self._scan_from_ns = scan_from
        if any(self._ended(sp, b, found_end) for sp, _, b in pending):
            return self._ingest(lambda span, start_ns, end_ns: start_ns > self._done_until_ns
                                and self._ended(span, end_ns, found_end))
        # an event whose beginning (and its context) would leave the buffer before the next
        # poll is finalised now, on what the buffer holds, as if the data ended here
        lost_ns = found_end + 2 * self._poll_ns - int(self.buffer_s * NS_PER_S)
        context_ns = int(s.context_s * NS_PER_S)
        overflowing = [a for _, a, _ in pending if a - context_ns < lost_ns]
        if not overflowing:
            return []
        until = max(overflowing) + NS_PER_S
        first = len(self.report.outcomes)
        # as if the data ended where every sensor that sends has them
        data_end = min(latest for latest in self._latest_by_sensor.values()
                       if found_end - latest <= self._max_lag_ns)
        self._ingest(lambda span, start_ns, end_ns: self._done_until_ns < start_ns <= until,
                     data_end)
        out = []
        for k in range(first, len(self.report.outcomes)):
            outcome = self.report.outcomes[k]
            note = self.report.add(
                "buffer_full", outcome.event_id, f"the ground has been shaking since "
                f"{fmt_time(outcome.start_ns)}, longer than the {self.buffer_s:g} s buffer "
                f"holds: the event is finalised on the buffered data as if they ended at "
                f"{fmt_time(data_end)} ({outcome.status}); the rest of this shaking is left "
                "out", outcome.start_ns, max(outcome.start_ns, data_end))
            window = outcome.window
            if window is not None:
                window = dataclasses.replace(window, report={
                    **window.report, "findings": [*window.report["findings"], note.as_dict()]})
                out.append(window)
            self.report.outcomes[k] = dataclasses.replace(
                outcome, window=window, findings=(*outcome.findings, note))
        # the rest of this shaking is not this event again
        self._done_until_ns = max(self._done_until_ns, found_end)
        return out

    def _ingest(self, select: SpanFilter, until_ns: int | None = None) -> list[MeasuredWindow]:
        """Ingest the buffer (up to ``until_ns``), hand on the outcomes of the events
        ``select`` picks."""
        _, report = ingest_recording(self._recording(until_ns=until_ns), self.settings,
                                     origin_ns=self._origin_ns, select=select)
        # each ingest reports on the whole buffer: keep every finding once
        seen = set(self.report.findings)
        self.report.findings.extend(f for f in report.findings if f not in seen)
        self.report.checks.update(report.checks)
        out = []
        for outcome in report.outcomes:
            self.report.outcomes.append(outcome)
            self._done_until_ns = max(self._done_until_ns, outcome.start_ns)
            if outcome.window is not None:
                out.append(outcome.window)
        return out
