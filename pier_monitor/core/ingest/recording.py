"""A multi-sensor recording as it comes from the sensors or a bag: raw channels, not yet ingested.

One :class:`SensorRecord` per physical sensor holds its samples exactly as recorded: in the
sensor's own unit, with its own sign, gain, offset and orientation (the sensor map of the
:class:`~pier_monitor.core.model.config.PierConfig` describes how to undo them).  Times are
integer nanoseconds since the Unix epoch.  Arrays are time-first.

Nothing here checks that the samples are sane (finite, uniformly spaced, in order): a
recording carries bad data through unchanged so that the ingest can report it by sensor and
time instead of losing it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from pier_monitor.core.model.config import PierConfig
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.findings import NS_PER_S, Finding

__all__ = ["SensorRecord", "Recording", "sample_times_ns", "NS_PER_S", "ns_to_stamp",
           "stamp_to_ns"]

_INT32_MIN, _INT32_MAX = -2 ** 31, 2 ** 31 - 1


def ns_to_stamp(t_ns: int) -> tuple[int, int]:
    """ns since the Unix epoch → ``(sec, nanosec)`` of a ``builtin_interfaces/Time``.

    ``nanosec`` is in ``[0, 1e9)``, so times before the epoch have a negative ``sec``.

    Raises
    ------
    InputDataError
        If ``sec`` does not fit the message's int32.
    """
    sec, nanosec = divmod(int(t_ns), NS_PER_S)
    if not _INT32_MIN <= sec <= _INT32_MAX:
        raise InputDataError(f"time {int(t_ns)} ns does not fit a builtin_interfaces/Time "
                             "(int32 seconds)")
    return sec, nanosec


def stamp_to_ns(sec: int, nanosec: int) -> int:
    """``(sec, nanosec)`` of a ``builtin_interfaces/Time`` → ns since the Unix epoch."""
    return int(sec) * NS_PER_S + int(nanosec)


def sample_times_ns(start_ns: int, n_samples: int, rate_hz: float) -> np.ndarray:
    """Times of ``n_samples`` uniform samples from ``start_ns``, ns, int64, shape (n_samples,).

    Sample ``i`` is at ``start_ns + round(i * 1e9 / rate_hz)``; exact for rates whose period
    is a whole number of nanoseconds (100, 200, 500, 1000 Hz, ...).
    """
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise InputDataError(f"rate_hz: expected a positive sampling rate, got {rate_hz}")
    if n_samples < 0:
        raise InputDataError(f"n_samples: expected a non-negative count, got {n_samples}")
    offsets = np.rint(np.arange(n_samples, dtype=np.float64) * (NS_PER_S / float(rate_hz)))
    return np.int64(start_ns) + offsets.astype(np.int64)


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, copy=True)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class SensorRecord:
    """The recorded samples of one sensor.

    Attributes
    ----------
    sensor_id : str
        Id of the sensor in the pier configuration's sensor map.
    time_ns : ndarray of int64, shape (T,)
        Time of each sample, ns since the Unix epoch.
    data : ndarray of float64, shape (T, n_axes)
        Samples as recorded, in the sensor's unit; column ``j`` is the sensor's axis ``j``.
    rate_hz : float
        Nominal sampling rate, Hz.
    sample_index : ndarray of int64, shape (T,)
        Running index of each sample since the start of the recording; a jump means dropped
        samples, a repeat a duplicate.  Default ``0 .. T-1``.
    """

    sensor_id: str
    time_ns: np.ndarray
    data: np.ndarray
    rate_hz: float
    sample_index: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.time_ns)
        if t.ndim != 1 or not (t.size == 0 or np.issubdtype(t.dtype, np.integer)):
            raise InputDataError(f"sensor {self.sensor_id}: time_ns: expected a 1-D integer array "
                                 f"(ns), got shape {t.shape} dtype {t.dtype}")
        d = np.asarray(self.data, dtype=np.float64)
        if d.ndim != 2 or d.shape[0] != t.shape[0]:
            raise InputDataError(f"sensor {self.sensor_id}: data: expected shape "
                                 f"({t.shape[0]}, n_axes), got {d.shape}")
        if not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise InputDataError(
                f"sensor {self.sensor_id}: rate_hz: expected a positive rate, got {self.rate_hz}")
        if self.sample_index is None:
            idx = np.arange(t.shape[0], dtype=np.int64)
        else:
            idx = np.asarray(self.sample_index)
            if idx.shape != t.shape or not (idx.size == 0 or np.issubdtype(idx.dtype, np.integer)):
                raise InputDataError(f"sensor {self.sensor_id}: sample_index: expected "
                                     f"{t.shape[0]} integers, got shape {idx.shape} "
                                     f"dtype {idx.dtype}")
        object.__setattr__(self, "time_ns", _readonly(t.astype(np.int64, copy=False)))
        object.__setattr__(self, "data", _readonly(d))
        object.__setattr__(self, "sample_index", _readonly(idx.astype(np.int64, copy=False)))
        object.__setattr__(self, "rate_hz", float(self.rate_hz))

    @property
    def n_samples(self) -> int:
        """Number of samples ``T``."""
        return int(self.time_ns.shape[0])

    @property
    def n_axes(self) -> int:
        """Number of recorded channels (columns of :attr:`data`)."""
        return int(self.data.shape[1])

    def equals(self, other: "SensorRecord") -> bool:
        """Exact equality of ids, rates, times, indices and data (NaN equal to NaN)."""
        return (self.sensor_id == other.sensor_id and self.rate_hz == other.rate_hz
                and np.array_equal(self.time_ns, other.time_ns)
                and np.array_equal(self.sample_index, other.sample_index)
                and self.data.shape == other.data.shape
                and np.array_equal(self.data, other.data, equal_nan=True))


@dataclass(frozen=True, eq=False)
class Recording:
    """The raw recording of one pier: its configuration and every sensor's samples.

    Attributes
    ----------
    config : PierConfig
        Pier configuration, including the sensor map that describes each sensor's unit,
        axes, orientation, signs, gain and offsets.
    sensors : mapping of str to SensorRecord
        Samples by sensor id, in the order of the configuration's sensor map.  Sensors of
        the map with no samples are absent (see :attr:`missing_sensors`).
    source : str
        Where the recording came from (bag path, generator settings).
    unmapped_topics : tuple of str
        Topics of sample blocks found next to the recording whose sensor is not in the map.
    config_updates : tuple of (int, PierConfig)
        Later configurations with the time (ns) from which each holds, in time order, e.g.
        deck mass added between two shaking runs.  They must keep the sensor map and the
        number of levels; :meth:`config_at` picks the one in force.
    findings : tuple of Finding
        What the reader found about the source, e.g. a bag that ends early (where its data
        end); the ingest reports them with its own.
    """

    config: PierConfig
    sensors: Mapping[str, SensorRecord]
    source: str = ""
    unmapped_topics: tuple[str, ...] = field(default=())
    config_updates: tuple[tuple[int, PierConfig], ...] = field(default=())
    findings: tuple[Finding, ...] = field(default=())

    def __post_init__(self) -> None:
        known = {s.sensor_id: s for s in self.config.sensors}
        for key, rec in self.sensors.items():
            if key != rec.sensor_id:
                raise InputDataError(f"sensors[{key!r}] holds the samples of {rec.sensor_id!r}")
            spec = known.get(key)
            if spec is None:
                raise InputDataError(f"sensor {key!r} is not in the sensor map of pier "
                                     f"{self.config.pier_id!r}")
            if rec.n_axes != len(spec.axes):
                raise InputDataError(f"sensor {key}: data has {rec.n_axes} columns but the "
                                     f"configuration lists {len(spec.axes)} axes {list(spec.axes)}")
        ordered = {s.sensor_id: self.sensors[s.sensor_id] for s in self.config.sensors
                   if s.sensor_id in self.sensors}
        object.__setattr__(self, "sensors", ordered)
        object.__setattr__(self, "unmapped_topics", tuple(self.unmapped_topics))
        updates = tuple(sorted(((int(t), c) for t, c in self.config_updates), key=lambda u: u[0]))
        for t, c in updates:
            if c.sensors != self.config.sensors or c.n_levels != self.config.n_levels \
                    or c.pier_id != self.config.pier_id:
                raise InputDataError(
                    f"configuration update at {t} ns for pier {c.pier_id!r} changes the pier, "
                    "its levels or its sensor map; only geometry and design values may change")
        object.__setattr__(self, "config_updates", updates)
        object.__setattr__(self, "findings", tuple(self.findings))

    def config_at(self, t_ns: int) -> PierConfig:
        """The configuration in force at ``t_ns``: the latest update at or before it."""
        current = self.config
        for t, c in self.config_updates:
            if t <= t_ns:
                current = c
        return current

    @property
    def missing_sensors(self) -> tuple[str, ...]:
        """Ids of the sensors of the map that have no samples in this recording."""
        return tuple(s.sensor_id for s in self.config.sensors if s.sensor_id not in self.sensors)

    @property
    def start_ns(self) -> int:
        """Time of the earliest sample over all sensors, ns; :class:`InputDataError` if none."""
        starts = [int(r.time_ns.min()) for r in self.sensors.values() if r.n_samples]
        if not starts:
            raise InputDataError(f"recording of pier {self.config.pier_id!r} has no samples")
        return min(starts)

    @property
    def end_ns(self) -> int:
        """Time of the latest sample over all sensors, ns."""
        ends = [int(r.time_ns.max()) for r in self.sensors.values() if r.n_samples]
        if not ends:
            raise InputDataError(f"recording of pier {self.config.pier_id!r} has no samples")
        return max(ends)

    def sensor(self, sensor_id: str) -> SensorRecord:
        """The samples of one sensor; :class:`InputDataError` naming it if absent."""
        try:
            return self.sensors[sensor_id]
        except KeyError:
            raise InputDataError(
                f"no samples of sensor {sensor_id!r} in the recording of pier "
                f"{self.config.pier_id!r} ({self.source or 'unknown source'})") from None

    def equals(self, other: "Recording") -> bool:
        """Equal configuration and exactly equal samples of the same sensors."""
        return (self.config == other.config and list(self.sensors) == list(other.sensors)
                and all(self.sensors[k].equals(other.sensors[k]) for k in self.sensors)
                and len(self.config_updates) == len(other.config_updates)
                and all(ta == tb and ca == cb for (ta, ca), (tb, cb)
                        in zip(self.config_updates, other.config_updates)))
