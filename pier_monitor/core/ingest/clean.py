"""Per-sensor cleaning: raw samples to SI values on the recording's uniform grid, every
action reported with the sensor and the time."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
from pier_monitor.core.ingest.settings import IngestReport, IngestSettings, fmt_time
from pier_monitor.core.model.config import SensorSpec

__all__ = ["CleanSensor", "clean_sensor", "clean_recording", "recording_grid"]


@dataclass(frozen=True)
class CleanSensor:
    """One sensor on the uniform grid of its recording, in SI, pier frame.

    Attributes
    ----------
    spec : SensorSpec
    t0_ns : int
        Time of grid sample 0, ns.
    rate_hz : float
    values : ndarray, shape (T, n_axes)
        Measured component along each axis, SI (gain, offset, sign and unit undone); NaN
        where the sensor has no usable sample.
    usable : ndarray of bool, shape (T, n_axes)
        False at long gaps and on excluded channels.
    """

    spec: SensorSpec
    t0_ns: int
    rate_hz: float
    values: np.ndarray
    usable: np.ndarray


def clean_sensor(spec: SensorSpec, rec: SensorRecord, t0_ns: int, n: int, rate_hz: float,
                 settings: IngestSettings, report: IngestReport) -> CleanSensor:
    """Put one sensor on the grid ``t0_ns + i / rate_hz``, ``i < n``; see the module doc."""
    sid = spec.sensor_id
    period_ns = NS_PER_S / rate_hz
    if abs(rec.rate_hz - rate_hz) > 1e-6 * rate_hz:
        report.add("rate_mismatch", sid, f"recorded at {rec.rate_hz:g} Hz but the configuration "
                   f"says {rate_hz:g} Hz; sensor excluded")
        return CleanSensor(spec, t0_ns, rate_hz, np.full((n, len(spec.axes)), np.nan),
                           np.zeros((n, len(spec.axes)), dtype=bool))
    t = rec.time_ns
    idx = rec.sample_index
    data = rec.data
    order = np.lexsort((t, idx))
    if np.any(np.diff(order) < 0):
        report.add("out_of_order", sid, f"{int(np.sum(np.diff(order) < 0))} samples arrived out "
                   "of order; reordered by sample index")
    t, idx, data = t[order], idx[order], data[order]
    dup = np.concatenate(([False], np.diff(idx) == 0))
    if np.any(dup):
        first = int(np.flatnonzero(dup)[0])
        same = np.array_equal(data[dup], data[np.flatnonzero(dup) - 1], equal_nan=True)
        report.add("duplicate", sid, f"{int(dup.sum())} duplicated samples (first at "
                   f"{fmt_time(int(t[first]))}){'' if same else ' with different values'}; "
                   "the first copy kept")
        t, idx, data = t[~dup], idx[~dup], data[~dup]
    # timestamps: the running index is the sensor's own clock; a timestamp that disagrees
    # with it by more than half a period has jumped
    if t.size:
        ref = int(np.median(t - np.rint(idx * period_ns).astype(np.int64)))
        expected = ref + np.rint(idx * period_ns).astype(np.int64)
        jumped = np.abs(t - expected) > 0.5 * period_ns
        if np.any(jumped):
            i = int(np.flatnonzero(jumped)[0])
            report.add("timestamp_jump", sid, f"{int(jumped.sum())} timestamps off their sample "
                       f"index (first at index {int(idx[i])}, {fmt_time(int(t[i]))}, off by "
                       f"{(t[i] - expected[i]) / 1e6:.1f} ms); re-timed from the index")
        t = expected
    grid = np.rint((t - t0_ns) / period_ns).astype(np.int64)
    inside = (grid >= 0) & (grid < n)
    values = np.full((n, data.shape[1]), np.nan)
    values[grid[inside]] = data[inside]
    bad = ~np.isfinite(values) & np.isin(np.arange(n), grid[inside])[:, None]
    if np.any(bad):
        i = int(np.argwhere(bad)[0, 0])
        report.add("non_finite", sid, f"{int(bad.any(axis=1).sum())} samples with NaN/Inf "
                   f"(first at {fmt_time(t0_ns + int(i * period_ns))}); treated as missing")
    # SI, pier-frame components
    signs = np.asarray(spec.signs)
    offsets = np.asarray(spec.offsets)
    values = (values - offsets) * spec.si_factor / (spec.gain * signs)
    usable = np.ones_like(values, dtype=bool)
    # gaps (inside the span the sensor recorded)
    have = np.isfinite(values).all(axis=1)
    first, last = (np.flatnonzero(have)[[0, -1]] if have.any() else (0, -1))
    max_short = int(math.floor(settings.short_gap_s * rate_hz + 1e-9))
    if have.any():
        missing = ~have
        missing[:first] = False
        missing[last + 1:] = False
        starts = np.flatnonzero(missing & ~np.concatenate(([False], missing[:-1])))
        for s0 in starts:
            s1 = s0
            while s1 + 1 < n and missing[s1 + 1]:
                s1 += 1
            length = s1 - s0 + 1
            where = f"{fmt_time(t0_ns + int(s0 * period_ns))} to {fmt_time(t0_ns + int(s1 * period_ns))}"
            if length <= max_short:
                for j in range(values.shape[1]):
                    values[s0:s1 + 1, j] = np.interp(np.arange(s0, s1 + 1), [s0 - 1, s1 + 1],
                                                     [values[s0 - 1, j], values[s1 + 1, j]])
                report.add("gap_interpolated", sid, f"{length} missing samples {where} "
                           "interpolated")
            else:
                usable[s0:s1 + 1] = False
                report.add("gap_excluded", sid, f"{length} missing samples ({length / rate_hz:.2f}"
                           f" s) {where}: sensor excluded from windows overlapping the gap")
    usable &= np.isfinite(values)
    # dead and saturated channels (judged on the recorded span)
    for j, axis in enumerate(spec.axes):
        col = values[usable[:, j], j]
        if col.size < 10:
            continue
        step = np.abs(np.diff(col))
        if np.ptp(col) == 0 or np.mean(step == 0) > 0.95:
            usable[:, j] = False
            report.add("dead", f"{sid}.{axis}", f"channel {axis} is flat "
                       f"({np.mean(step == 0):.0%} of the steps are zero); excluded")
            continue
        hi, lo = col.max(), col.min()
        at_rail = np.isclose(col, hi, rtol=0, atol=1e-12 * max(abs(hi), 1.0)) | \
            np.isclose(col, lo, rtol=0, atol=1e-12 * max(abs(lo), 1.0))
        if np.mean(at_rail) > 0.005 and np.sum(at_rail) >= 5:
            usable[:, j] = False
            report.add("saturated", f"{sid}.{axis}", f"channel {axis} is clipped at "
                       f"{lo:.4g}/{hi:.4g} SI on {int(at_rail.sum())} samples; excluded")
    return CleanSensor(spec, t0_ns, rate_hz, values, usable)


def recording_grid(recording: Recording) -> tuple[int, int, float]:
    rate = recording.config.sample_rate_hz
    t0 = recording.start_ns
    n = int(round((recording.end_ns - t0) * rate / NS_PER_S)) + 1
    return t0, n, rate


def clean_recording(recording: Recording, settings: IngestSettings,
               report: IngestReport) -> tuple[list[CleanSensor], int, int, float]:
    config = recording.config
    t0, n, rate = recording_grid(recording)
    for topic in recording.unmapped_topics:
        report.add("unmapped_topic", topic, "sample blocks of a sensor that is not in the sensor "
                   "map; ignored")
    for sid in recording.missing_sensors:
        report.add("missing_sensor", sid, "in the sensor map but no samples were received")
    cleaned = [clean_sensor(config.sensor(sid), rec, t0, n, rate, settings, report)
               for sid, rec in recording.sensors.items()]
    _check_units(cleaned, report)
    return cleaned, t0, n, rate


def _check_units(cleaned: list[CleanSensor], report: IngestReport) -> None:
    """Exclude accelerometers whose level of motion is off by a unit factor from the others
    at the same level (e.g. recorded in g but declared m/s²)."""
    by_level: dict[int, list[tuple[CleanSensor, float]]] = {}
    for cs in cleaned:
        if cs.spec.kind != "acceleration":
            continue
        h = [j for j, a in enumerate(cs.spec.axes) if a != "z"]
        sel = cs.usable[:, h].all(axis=1)
        if len(h) == 0 or sel.sum() < 10:
            continue
        vals = cs.values[sel][:, h]
        rms = float(np.sqrt(np.mean((vals - vals.mean(axis=0)) ** 2)))
        by_level.setdefault(cs.spec.level, []).append((cs, rms))
    for level, items in by_level.items():
        if len(items) < 3:
            continue
        med = float(np.median([r for _, r in items]))
        for cs, r in items:
            ratio = r / med if med > 0 else 1.0
            if ratio > 5.0 or ratio < 0.2:
                cs.usable[:, :] = False
                report.add("implausible_units", cs.spec.sensor_id,
                           f"horizontal RMS {r:.4g} m/s² is {ratio:.3g}x the median of the other "
                           f"accelerometers at level {level} ({med:.4g} m/s²); declared unit "
                           f"{cs.spec.unit!r} looks wrong; sensor excluded")
