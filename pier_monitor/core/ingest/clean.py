"""Per-sensor cleaning: raw samples to SI values on the recording's uniform grid, every
action reported with the sensor and the time.

Order of the steps (each judged on the sensor's own data; the checks against the other
sensors of a level are in :mod:`~pier_monitor.core.ingest.consistency`):

1. rate: the configured rate against the rate the blocks declare and the rate of the
   timestamps; a sensor that contradicts the configuration is excluded, named as such;
2. order by sample index, drop duplicates, re-time samples whose timestamp jumped;
3. onto the grid: NaN/Inf samples and samples beyond the sensor's ``full_scale`` or
   ``range`` (physically impossible) become missing;
4. flat channels: dead (flat throughout), saturated (clipped at its extremes: excluded
   around the clipping) and frozen (the same value repeated for ``frozen_s``: excluded
   from there);
5. SI in the pier frame (gain, offset, sign, unit undone);
6. displacement and velocity sensors: glitches (a jump and a jump back within
   ``glitch_max_s``) become missing; a lone jump is an offset jump and is removed.

After the checks against other sensors, :func:`bridge_gaps` interpolates short runs of
missing samples and excludes the channel over long ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from pier_monitor.core.ingest.recording import NS_PER_S, SensorRecord
from pier_monitor.core.ingest.settings import IngestReport, IngestSettings
from pier_monitor.core.ingest.findings import fmt_span, fmt_time
from pier_monitor.core.model.config import SensorSpec

__all__ = ["CleanSensor", "clean_sensor", "bridge_gaps", "block_starts", "block_median", "nan_median",
           "data_rate_hz", "rate_problem", "runs_of", "fmt_recorded", "MISSING", "OUT_OF_RANGE", "GLITCH"]

#: Why a sample of a :class:`CleanSensor` is NaN (``flags``); 0 = a good sample.
MISSING, OUT_OF_RANGE, GLITCH = 1, 2, 3
_CAUSE_CODES = {MISSING: "gap", OUT_OF_RANGE: "out_of_range", GLITCH: "glitch"}
_MAX_FINDINGS = 10  # per sensor and code; later ones are summed up in one


def fmt_recorded(spec: SensorSpec, axis: int, delta_si: float) -> str:
    """A change along one channel (SI, pier frame) as the sensor recorded it: ``+500 mm``."""
    recorded = delta_si * spec.gain * spec.signs[axis] / spec.si_factor
    return f"{recorded:+.4g} {spec.unit}"


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
        False at long gaps, on excluded stretches and on excluded channels.
    flags : ndarray of int8, shape (T, n_axes)
        Why a sample inside the sensor's recorded span is NaN: :data:`MISSING`,
        :data:`OUT_OF_RANGE` or :data:`GLITCH` (0 otherwise); :func:`bridge_gaps` acts on them.
    details : dict
        ``(axis index, first sample) -> text`` describing a glitch, for its finding.
    """

    spec: SensorSpec
    t0_ns: int
    rate_hz: float
    values: np.ndarray
    usable: np.ndarray
    flags: np.ndarray
    details: dict[tuple[int, int], str] = field(default_factory=dict)

    def time_ns(self, i: int) -> int:
        """Time of grid sample ``i``, ns."""
        return self.t0_ns + int(round(int(i) * NS_PER_S / self.rate_hz))

    def channel(self, j: int) -> str:
        """``<sensor id>.<axis>`` of column ``j``."""
        return f"{self.spec.sensor_id}.{self.spec.axes[j]}"


def data_rate_hz(rec: SensorRecord) -> float | None:
    """Rate of a sensor's samples by their own timestamps, Hz (median period between
    consecutive sample indices); None when fewer than two samples tell."""
    if rec.n_samples < 2:
        return None
    order = np.argsort(rec.sample_index, kind="stable")
    d_idx = np.diff(rec.sample_index[order])
    d_t = np.diff(rec.time_ns[order])
    ok = (d_idx > 0) & (d_t > 0)
    if not ok.any():
        return None
    return float(NS_PER_S / np.median(d_t[ok] / d_idx[ok]))


def rate_problem(rec: SensorRecord, rate_hz: float) -> str | None:
    """Why a sensor's rate contradicts the configured one (its blocks' or its timestamps'),
    or None."""
    if abs(rec.rate_hz - rate_hz) > 1e-6 * rate_hz:
        return (f"recorded at {rec.rate_hz:g} Hz (its sample blocks) but the configuration "
                f"says sample_rate_hz {rate_hz:g} Hz")
    own = data_rate_hz(rec)
    if own is not None and abs(own - rate_hz) > 0.01 * rate_hz:
        return (f"its timestamps advance at {own:.4g} Hz but its blocks and the configuration "
                f"say {rate_hz:g} Hz")
    return None


def block_starts(t0_ns: int, n: int, rate_hz: float) -> np.ndarray:
    """First grid sample of each whole UTC second touched by ``n`` samples from ``t0_ns``.

    Local statistics are taken per such block, so that a stream and a whole recording cut
    their data the same way.
    """
    times = t0_ns + np.rint(np.arange(n) * (NS_PER_S / rate_hz)).astype(np.int64)
    sec = times // NS_PER_S
    return np.concatenate(([0], np.flatnonzero(np.diff(sec)) + 1)).astype(np.int64)


def nan_median(a: np.ndarray, axis: int) -> np.ndarray:
    """Median along ``axis`` ignoring NaN (NaN where a slice has no data); a sort, faster
    than :func:`numpy.nanmedian` on many short slices."""
    a = np.sort(a, axis=axis)  # NaN last
    count = np.expand_dims(np.isfinite(a).sum(axis=axis), axis)
    lo = np.take_along_axis(a, np.maximum(count - 1, 0) // 2, axis=axis)
    hi = np.take_along_axis(a, count // 2 - (count == 0), axis=axis)
    return np.squeeze(np.where(count > 0, 0.5 * (lo + hi), np.nan), axis=axis)


def block_median(x: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """NaN-ignoring median of ``x`` (T,) or (T, C) over each block; shape (n_blocks,) or
    (n_blocks, C), NaN for a block without data."""
    x = np.asarray(x, dtype=float)
    flat = x.reshape(x.shape[0], -1)
    lengths = np.diff(np.append(starts, x.shape[0]))
    longest = int(lengths.max())
    # blocks side by side, NaN-padded
    rows = np.minimum(starts[:, None] + np.arange(longest)[None, :], x.shape[0] - 1)
    inside = np.arange(longest)[None, :] < lengths[:, None]
    stacked = np.where(inside[:, :, None], flat[rows], np.nan)
    return nan_median(stacked, axis=1).reshape((starts.size,) + x.shape[1:])


def runs_of(mask: np.ndarray) -> list[tuple[int, int]]:
    """``[(first, last), ...]`` of the runs of True in a 1-D mask (inclusive)."""
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist()))


def clean_sensor(spec: SensorSpec, rec: SensorRecord, t0_ns: int, n: int, rate_hz: float,
                 settings: IngestSettings, report: IngestReport) -> CleanSensor:
    """Put one sensor on the grid ``t0_ns + i / rate_hz``, ``i < n``; see the module doc.

    Short runs of missing samples are left NaN (flagged) for :func:`bridge_gaps`.
    """
    sid = spec.sensor_id
    n_axes = len(spec.axes)
    period_ns = NS_PER_S / rate_hz
    span = ((int(rec.time_ns.min()), int(rec.time_ns.max())) if rec.n_samples
            else (t0_ns, t0_ns))
    empty = CleanSensor(spec, t0_ns, rate_hz, np.full((n, n_axes), np.nan),
                        np.zeros((n, n_axes), dtype=bool), np.zeros((n, n_axes), dtype=np.int8))
    problem = rate_problem(rec, rate_hz)
    if problem is not None:
        report.add("rate_mismatch", sid, f"{problem}; sensor excluded", *span, "excluded")
        return empty
    t, idx, data = _ordered(sid, rec, period_ns, report)
    grid = np.rint((t - t0_ns) / period_ns).astype(np.int64)
    inside = (grid >= 0) & (grid < n)
    if not inside.any():
        return empty
    raw = np.full((n, n_axes), np.nan)
    raw[grid[inside]] = data[inside]
    first, last = int(grid[inside].min()), int(grid[inside].max())
    flags = np.zeros((n, n_axes), dtype=np.int8)
    recorded = np.zeros(n, dtype=bool)
    recorded[first:last + 1] = True
    flags[recorded[:, None] & np.isnan(raw)] = MISSING
    nonfinite = np.isinf(raw) | (np.isnan(raw) & np.isin(np.arange(n), grid[inside])[:, None])
    if np.any(nonfinite):
        i = int(np.argwhere(nonfinite)[0, 0])
        report.add("non_finite", sid, f"{int(nonfinite.any(axis=1).sum())} samples with NaN/Inf "
                   f"(first at {fmt_time(t0_ns + int(i * period_ns))}); treated as missing",
                   t0_ns + int(i * period_ns), t0_ns + int(last * period_ns), "noted")
        raw[nonfinite] = np.nan
        flags[nonfinite] = MISSING
    _impossible(spec, raw, flags)
    usable = np.ones((n, n_axes), dtype=bool)
    usable[~recorded] = False
    cs = CleanSensor(spec, t0_ns, rate_hz, raw, usable, flags)
    _flat_channels(cs, first, last, settings, report)
    # SI, pier-frame components
    signs = np.asarray(spec.signs)
    offsets = np.asarray(spec.offsets)
    values = (raw - offsets) * spec.si_factor / (spec.gain * signs)
    cs = CleanSensor(spec, t0_ns, rate_hz, values, usable, flags)
    if spec.kind in ("displacement", "velocity"):
        starts = block_starts(t0_ns, n, rate_hz)
        for j in range(n_axes):
            _increment_glitches(cs, j, starts, settings, report)
    return cs


def _restarted(sid: str, rec: SensorRecord, period_ns: float, report: IngestReport
               ) -> np.ndarray:
    """The sample index with its restarts undone (a logger rebooted mid-stream: its index
    falls back, e.g. to 0, while its clock goes on).

    In time order, an index that falls back by more than a second of samples while the
    timestamps advance is a restart: the samples from it on get the index the timestamps
    give them, continuing the earlier count, so that they are not taken for duplicates."""
    idx = rec.sample_index
    if rec.n_samples < 2:
        return idx
    order = np.argsort(rec.time_ns, kind="stable")
    t, ix = rec.time_ns[order], idx[order].copy()
    limit = max(1.0, NS_PER_S / period_ns)
    d_t = np.diff(t)
    back = np.flatnonzero((np.diff(ix) < -limit) & (d_t > 0))
    if back.size == 0:
        return idx
    for k in back:
        shift = int(ix[k]) + int(round(d_t[k] / period_ns)) - int(ix[k + 1])
        report.add("index_restart", sid, f"sample index restarts at {int(ix[k + 1])} (from "
                   f"{int(ix[k])}) at {fmt_time(int(t[k + 1]))}: a restart of the logger, not "
                   "duplicates; the samples after it indexed by their timestamps",
                   int(t[k + 1]), int(t[-1]), "repaired")
        ix[k + 1:] += shift
    out = np.empty_like(idx)
    out[order] = ix
    return out


def _ordered(sid: str, rec: SensorRecord, period_ns: float,
             report: IngestReport) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Samples ordered by index, duplicates dropped, timestamps re-timed from the index."""
    t, idx, data = rec.time_ns, _restarted(sid, rec, period_ns, report), rec.data
    order = np.lexsort((t, idx))
    if np.any(np.diff(order) < 0):
        k = int(np.flatnonzero(np.diff(order) < 0)[0])
        report.add("out_of_order", sid, f"{int(np.sum(np.diff(order) < 0))} samples arrived out "
                   f"of order (first at {fmt_time(int(t[order[k]]))}); reordered by sample "
                   "index", int(t.min()), int(t.max()), "repaired")
    t, idx, data = t[order], idx[order], data[order]
    dup = np.concatenate(([False], np.diff(idx) == 0))
    if np.any(dup):
        pos = np.flatnonzero(dup)
        same = np.array_equal(data[dup], data[pos - 1], equal_nan=True)
        report.add("duplicate", sid, f"{int(dup.sum())} duplicated samples (first at "
                   f"{fmt_time(int(t[pos[0]]))}){'' if same else ' with different values'}; "
                   "the first copy kept", int(t[pos[0]]), int(t[pos[-1]]), "repaired")
        t, idx, data = t[~dup], idx[~dup], data[~dup]
    # timestamps: the running index is the sensor's own clock; a timestamp that disagrees
    # with it by more than half a period has jumped
    if t.size:
        ref = int(np.median(t - np.rint(idx * period_ns).astype(np.int64)))
        expected = ref + np.rint(idx * period_ns).astype(np.int64)
        jumped = np.abs(t - expected) > 0.5 * period_ns
        if np.any(jumped):
            pos = np.flatnonzero(jumped)
            i = int(pos[0])
            report.add("timestamp_jump", sid, f"{int(jumped.sum())} timestamps off their sample "
                       f"index (first at index {int(idx[i])}, {fmt_time(int(expected[i]))}, off "
                       f"by {(t[i] - expected[i]) / 1e6:.1f} ms); re-timed from the index",
                       int(expected[i]), int(expected[pos[-1]]), "repaired")
        t = expected
    return t, idx, data


def _impossible(spec: SensorSpec, raw: np.ndarray, flags: np.ndarray) -> None:
    """In place: samples beyond the sensor's full scale / range become missing."""
    bounds = spec.recorded_bounds()
    if bounds is None:
        return
    with np.errstate(invalid="ignore"):
        beyond = (raw < bounds[0]) | (raw > bounds[1])
    raw[beyond] = np.nan
    flags[beyond] = OUT_OF_RANGE


def _flat_channels(cs: CleanSensor, first: int, last: int, settings: IngestSettings,
                   report: IngestReport) -> None:
    """Dead, saturated and frozen stretches of each channel (on the raw values)."""
    spec, raw, usable = cs.spec, cs.values, cs.usable
    rate = cs.rate_hz
    frozen_n = max(5, int(round(settings.frozen_s * rate)))
    pad = int(round(0.5 * rate))
    unit = spec.unit
    for j, axis in enumerate(spec.axes):
        where = cs.channel(j)
        col = raw[first:last + 1, j]
        ok = np.isfinite(col)
        if ok.sum() < 10:
            continue
        vals = col[ok]
        step = np.diff(vals)
        if np.ptp(vals) == 0 or np.mean(step == 0) > 0.95:
            usable[:, j] = False
            report.add("dead", where, f"channel {axis} is flat ({np.mean(step == 0):.0%} of the "
                       f"steps are zero, value {vals[0]:.6g} {unit}); excluded",
                       cs.time_ns(first), cs.time_ns(last), "excluded")
            continue
        hi, lo = vals.max(), vals.min()
        with np.errstate(invalid="ignore"):
            at_rail = ok & (np.isclose(col, hi, rtol=0, atol=1e-12 * max(abs(hi), 1.0))
                            | np.isclose(col, lo, rtol=0, atol=1e-12 * max(abs(lo), 1.0)))
        clipped = np.mean(at_rail[ok]) > 0.005 and at_rail.sum() >= 5
        if clipped:
            pos = first + np.flatnonzero(at_rail)
            breaks = np.flatnonzero(np.diff(pos) > settings.merge_gap_s * rate)
            for c0, c1 in zip(np.concatenate(([pos[0]], pos[breaks + 1])),
                              np.concatenate((pos[breaks], [pos[-1]]))):
                a, b = max(first, c0 - pad), min(last, c1 + pad)
                usable[a:b + 1, j] = False
                count = int(np.sum((pos >= c0) & (pos <= c1)))
                report.add("saturated", where, f"channel {axis} is clipped at {lo:.6g}/{hi:.6g} "
                           f"{unit} on {count} samples {fmt_span(cs.time_ns(c0), cs.time_ns(c1))}"
                           "; excluded there", cs.time_ns(a), cs.time_ns(b), "excluded")
        same = np.concatenate(([False], col[1:] == col[:-1]))  # NaN never equals
        if clipped:
            same &= ~at_rail
        for r0, r1 in runs_of(same):
            s0, s1 = first + r0 - 1, first + r1  # the run's first sample is the one repeated
            if s1 - s0 + 1 < frozen_n:
                continue
            usable[s0:s1 + 1, j] = False
            until = "to the end of its data" if s1 >= last else f"to {fmt_time(cs.time_ns(s1))}"
            report.add("frozen", where, f"channel {axis} repeats exactly {raw[s0, j]:.6g} "
                       f"{unit} from {fmt_time(cs.time_ns(s0))} {until} "
                       f"({(s1 - s0 + 1) / rate:.2f} s); excluded there",
                       cs.time_ns(s0), cs.time_ns(s1), "excluded")


def _increment_glitches(cs: CleanSensor, j: int, starts: np.ndarray, settings: IngestSettings,
                        report: IngestReport) -> None:
    """Glitches and offset jumps of a smooth channel (displacement, velocity), in place.

    The increment from sample k to k+1 is compared with the median of its neighbours'
    increments; the local robust spread (per second, never below √2 × the configured noise)
    scales the test.  A jump and the jump back within ``glitch_max_s`` bound a glitch: its
    samples become missing.  A lone jump is an offset jump: later samples are shifted back.
    """
    x = cs.values[:, j]
    spec = cs.spec
    d = np.diff(x)
    if d.size < 8:
        return
    half = 3
    med = nan_median(sliding_window_view(np.pad(d, half, mode="edge"), 2 * half + 1), axis=1)
    r = d - med
    scale = 1.4826 * block_median(np.abs(r), starts)
    scale = np.where(np.isfinite(scale), scale, 0.0)
    scale = np.maximum.reduce([scale, np.r_[scale[1:], 0.0], np.r_[0.0, scale[:-1]]])
    per_sample = scale[np.searchsorted(starts, np.arange(d.size), side="right") - 1]
    noise = math.sqrt(2.0) * spec.noise_rms * spec.si_factor / abs(spec.gain)
    floor = max(noise, 1e-12 * max(float(np.nanmax(np.abs(x))) if np.isfinite(x).any()
                                   else 0.0, 1e-12))
    thr = settings.glitch_threshold * np.maximum(per_sample, floor)
    with np.errstate(invalid="ignore"):
        out = np.flatnonzero(np.abs(r) > thr)
    if out.size == 0:
        return
    max_burst = max(1, int(round(settings.glitch_max_s * cs.rate_hz)))
    k = 0
    while k < out.size:
        k1 = int(out[k])
        later = out[(out > k1) & (out <= k1 + max_burst)]
        total = r[k1]
        end = None
        for k2 in later:
            total += r[k2]
            if abs(total) <= max(thr[k2], 0.05 * abs(r[k1])):
                end = int(k2)
        nan_after = np.flatnonzero(np.isnan(x[k1 + 1:k1 + 1 + max_burst]))
        if end is None and nan_after.size:  # the jump back is lost in a gap
            end = k1 + int(nan_after[0])
        if end is not None:
            s0, s1 = k1 + 1, end
            if s1 >= s0:
                peak = r[k1]
                x[s0:s1 + 1] = np.nan
                cs.flags[s0:s1 + 1, j] = GLITCH
                cs.details[(j, s0)] = (f"jumps by {fmt_recorded(spec, j, peak)} and back "
                                       f"{(s1 - s0 + 1) / cs.rate_hz:.3f} s later")
            k = int(np.searchsorted(out, end, side="right"))
            continue
        x[k1 + 1:] -= r[k1]
        t_jump = cs.time_ns(k1 + 1)
        report.add("offset_jump", cs.channel(j), f"jumps by {fmt_recorded(spec, j, r[k1])} at "
                   f"{fmt_time(t_jump)} and does not jump back within "
                   f"{settings.glitch_max_s:g} s: offset after the jump corrected",
                   t_jump, t_jump, "repaired")
        k += 1


def bridge_gaps(cs: CleanSensor, settings: IngestSettings, report: IngestReport) -> None:
    """In place: interpolate short runs of missing samples, exclude the channel over long
    ones; one finding per run (by sensor when all its channels share it)."""
    n = cs.values.shape[0]
    max_short = int(math.floor(settings.short_gap_s * cs.rate_hz + 1e-9))
    runs: dict[tuple[int, int, int], list[int]] = {}
    for j in range(cs.values.shape[1]):
        bad = (cs.flags[:, j] > 0) & cs.usable[:, j] & np.isnan(cs.values[:, j])
        for s0, s1 in runs_of(bad):
            flags = cs.flags[s0:s1 + 1, j]
            cause = MISSING if np.any(flags == MISSING) else int(flags.max())
            runs.setdefault((s0, s1, cause), []).append(j)
    counts: dict[tuple[str, str], int] = {}
    for (s0, s1, cause), axes in sorted(runs.items()):
        length = s1 - s0 + 1
        ends = [s0 - 1, s1 + 1]
        short = (length <= max_short and s0 > 0 and s1 < n - 1
                 and all(np.isfinite(cs.values[ends, j]).all() for j in axes))
        for j in axes:
            if short:
                cs.values[s0:s1 + 1, j] = np.interp(np.arange(s0, s1 + 1), ends,
                                                    cs.values[ends, j])
            else:
                cs.usable[s0:s1 + 1, j] = False
        t0, t1 = cs.time_ns(s0), cs.time_ns(s1)
        code = _CAUSE_CODES[cause]
        if cause == MISSING:
            code += "_interpolated" if short else "_excluded"
            text = (f"{length} missing samples ({length / cs.rate_hz:.2f} s) from "
                    f"{fmt_time(t0)} to {fmt_time(t1)}")
        elif cause == OUT_OF_RANGE:
            lo, hi = cs.spec.recorded_bounds()
            text = (f"{length} samples beyond the possible {lo:g} to {hi:g} {cs.spec.unit} "
                    f"{fmt_span(t0, t1)}")
        else:
            detail = cs.details.get((axes[0], s0), "departs from its neighbours")
            text = f"{length} samples {fmt_span(t0, t1)}: {detail}"
        action, done = ("repaired", "interpolated") if short else ("excluded", "excluded there")
        wheres = ([cs.spec.sensor_id] if len(axes) == len(cs.spec.axes)
                  else [cs.channel(j) for j in axes])
        for where in wheres:
            key = (where, code)
            counts[key] = counts.get(key, 0) + 1
            if counts[key] <= _MAX_FINDINGS:
                report.add(code, where, f"{text}; {done}", t0, t1, action)
            elif counts[key] == _MAX_FINDINGS + 1:
                report.add(code, where, f"more {code} findings from {fmt_time(t0)} on (only "
                           f"the first {_MAX_FINDINGS} are listed)", t0, cs.time_ns(n - 1),
                           action)
