"""Whole-recording ingest: cleaned sensors to mainshock windows, event by event.

Each detected event gets its own outcome (:class:`~pier_monitor.core.ingest.settings.
EventIngest`): a window, or a failure that names the level, the sensors, the time and the
cause.  A fault in one event's data never costs another event its window.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
from scipy import signal

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.clean import CleanSensor
from pier_monitor.core.ingest.consistency import check_displacement
from pier_monitor.core.ingest.triggers import (EventSpan, detect_events, make_event_id,
                                             trigger_threshold)
from pier_monitor.core.ingest.fusion import fuse_acceleration_displacement
from pier_monitor.core.ingest.levels import (estimate_principal_direction, level_motion,
                                             level_motion_partial, level_noise_si)
from pier_monitor.core.ingest.prepare import clean_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording
from pier_monitor.core.ingest.settings import EventIngest, IngestError, IngestReport, IngestSettings, LevelUnusableError
from pier_monitor.core.ingest.findings import fmt_span, fmt_time
from pier_monitor.core.ingest.window import Coverage, MeasuredWindow, NoiseModel
from pier_monitor.core.numerics import cumulative_trapezoid

__all__ = ["ingest_recording", "span_times", "SpanFilter"]

#: ``select(span, start_ns, end_ns)``: whether to ingest a detected event now (``start_ns``,
#: ``end_ns``: its window's first and last sample, ns since the Unix epoch).
SpanFilter = Callable[[EventSpan, int, int], bool]


def _decimate(x: np.ndarray, factor: int) -> np.ndarray:
    if factor == 1:
        return x
    return signal.decimate(x, factor, ftype="fir", axis=0, zero_phase=True)


def _window_from_span(recording: Recording, cleaned: list[CleanSensor], t0: int, rate: float,
                      w0: int, w1: int, direction: float, settings: IngestSettings,
                      report: IngestReport, event_id: str, origin_ns: int) -> MeasuredWindow:
    # geometry and design in force for this event (e.g. deck mass added before a run)
    config = recording.config_at(t0 + int(round(w0 * NS_PER_S / rate)))
    n_lv = config.n_levels
    ctx = int(round(settings.context_s * rate))
    n_all = cleaned[0].values.shape[0] if cleaned else 0
    c0, c1 = max(0, w0 - ctx), min(n_all, w1 + ctx)
    sl = slice(c0, c1)
    phi = math.radians(direction)
    e_p = np.array([math.cos(phi), math.sin(phi)])
    counts: dict[str, int] = {}
    ag_xy = level_motion(cleaned, "acceleration", 0, sl, True, counts)
    ag = ag_xy @ e_p
    # accelerometer bias: the quiet lead-in before the window
    lead = slice(0, max(1, w0 - c0 - int(round(settings.pad_s * rate))))
    ag = ag - ag[lead].mean()
    a_rel = np.full((c1 - c0, n_lv), np.nan)
    x_rel = np.full((c1 - c0, n_lv), np.nan)
    for lv in range(1, n_lv + 1):
        a_xy = level_motion(cleaned, "acceleration", lv, sl, False, counts)
        wires = cleaned
        if a_xy is not None:
            a_abs = a_xy @ e_p
            a_rel[:, lv - 1] = a_abs - a_abs[lead].mean() - ag
            wires = _without_disagreeing_wires(cleaned, lv, sl, a_xy - ag_xy, ag_xy, rate,
                                               settings, report)
        wire = level_motion(wires, "displacement", lv, sl, False, counts)
        if wire is not None:
            wire = wire @ e_p
            x_rel[:, lv - 1] = wire - np.nanmean(wire[lead])
    has_a = np.isfinite(a_rel).all(axis=0)
    has_x = np.isfinite(x_rel).any(axis=0)
    if not (has_a | has_x).any():
        raise IngestError(f"{event_id}: no usable acceleration or displacement sensor at any "
                          f"level above the foundation (levels 1-{n_lv}); nothing to identify")
    t_lo = t0 + int(round(c0 * NS_PER_S / rate))
    t_hi = t0 + int(round((c1 - 1) * NS_PER_S / rate))
    for lv in np.flatnonzero(~(has_a & has_x)) + 1:
        what = ("no usable sensor" if not (has_a[lv - 1] or has_x[lv - 1]) else
                "no usable displacement sensor" if has_a[lv - 1] else
                "no usable accelerometer")
        report.add("unmeasured_level", f"level {lv}", f"{event_id}: {what} during "
                   f"{fmt_span(t_lo, t_hi)}; its motion is reconstructed by the identifier",
                   t_lo, t_hi, "noted")
    sig_a = np.array([math.hypot(level_noise_si(config, "acceleration", lv),
                                 level_noise_si(config, "acceleration", 0))
                      for lv in range(1, n_lv + 1)])
    sig_x = np.array([level_noise_si(config, "displacement", lv) for lv in range(1, n_lv + 1)])
    sig_a = np.where(np.isfinite(sig_a) & (sig_a > 0), sig_a, 1e-3)
    sig_x = np.where(np.isfinite(sig_x) & (sig_x > 0), sig_x, 1e-4)
    factor = int(round(rate / settings.output_rate_hz))
    if factor < 1 or abs(factor * settings.output_rate_hz - rate) > 1e-6 * rate:
        raise IngestError(f"output_rate_hz {settings.output_rate_hz:g} must divide the sensor rate "
                          f"{rate:g} Hz")
    both = has_a & has_x
    fused = None
    v_rel = np.full_like(a_rel, np.nan)
    x_out = np.full_like(a_rel, np.nan)
    nan = np.full(n_lv, np.nan)
    x_sigma, v_sigma, dx_sigma, dv_sigma = nan.copy(), nan.copy(), nan.copy(), nan.copy()
    inner = slice(w0 - c0, w1 - c0)
    if both.any():
        fused = fuse_acceleration_displacement(a_rel[:, both], x_rel[:, both], rate,
                                               sig_a[both], sig_x[both])
        v_rel[:, both], x_out[:, both] = fused.v, fused.x
        x_sigma[both] = fused.x_sigma[inner].mean(axis=0)
        v_sigma[both] = fused.v_sigma[inner].mean(axis=0)
        # increments over one output step (factor sensor steps)
        dx_sigma[both] = np.sqrt(factor * np.mean(fused.dx_sigma[inner] ** 2, axis=0))
        dv_sigma[both] = np.sqrt(factor * np.mean(fused.dv_sigma[inner] ** 2, axis=0))
    only_a = has_a & ~has_x
    if only_a.any():  # integrals of the acceleration, above highpass_hz only
        v_rel[:, only_a], x_out[:, only_a] = _integrate_highpass(a_rel[:, only_a], rate,
                                                                 settings.highpass_hz)
    only_x = has_x & ~has_a
    if only_x.any():
        x_out[:, only_x] = x_rel[:, only_x]
        v_rel[:, only_x] = np.gradient(x_rel[:, only_x], 1.0 / rate, axis=0)
        x_sigma[only_x] = sig_x[only_x]
    # velocity meters: relative velocity of a level = level meter − foundation meter
    v0_xy = level_motion(cleaned, "velocity", 0, sl, False, counts)
    checks = {}
    if v0_xy is not None:
        for lv in range(1, n_lv + 1):
            v_xy = level_motion(cleaned, "velocity", lv, sl, False, counts)
            if v_xy is None or not both[lv - 1]:
                continue
            meter = (v_xy - v0_xy) @ e_p
            d = meter[inner] - meter[inner].mean() - (v_rel[inner, lv - 1]
                                                      - v_rel[inner, lv - 1].mean())
            checks[f"level{lv}"] = {
                "rms_difference_mps": float(np.sqrt(np.mean(d ** 2))),
                "rms_velocity_mps": float(np.sqrt(np.mean(v_rel[inner, lv - 1] ** 2)))}
    report.checks.setdefault("velocity_meter", {})[event_id] = checks
    # decimated sample k is sensor sample c0 + k·factor; keep those inside [w0, w1)
    k0 = -(-(w0 - c0) // factor)
    k1 = -(-(w1 - c0) // factor)
    dec = {name: _decimate(arr, factor)[k0:k1]
           for name, arr in (("a", a_rel), ("ag", ag), ("x", x_out), ("v", v_rel))}
    m = min(arr.shape[0] for arr in dec.values())
    start_ns = t0 + int(round((c0 + k0 * factor) * NS_PER_S / rate))
    t = (start_ns - origin_ns) / NS_PER_S + np.arange(m) / settings.output_rate_hz
    return MeasuredWindow(
        pier_id=config.pier_id, event_id=event_id, geometry=config.geometry,
        design=config.design, t=t, ag=dec["ag"][:m], a=dec["a"][:m], v=dec["v"][:m],
        x=dec["x"][:m], moments=None,
        noise=NoiseModel(ag=float(level_noise_si(config, "acceleration", 0)),
                         a=np.where(has_a, sig_a, np.nan), v=v_sigma, x=x_sigma, dx=dx_sigma,
                         dv=dv_sigma, f=nan, gain_rel=settings.gain_rel),
        coverage=Coverage(has_a, has_x, settings.highpass_hz if only_a.any() else 0.0),
        start_time_ns=start_ns,
        report={"principal_direction_deg": direction,
                "fusion_q": [] if fused is None else fused.q.tolist(),
                "velocity_meter_check": checks, "channels": counts})


def _integrate_highpass(acc: np.ndarray, rate: float, highpass_hz: float
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and displacement (T, C) integrated from acceleration (T, C), each integral
    high-passed (zero-phase, 2nd order) at ``highpass_hz``: only the band that integration
    gets right."""
    sos = signal.butter(2, highpass_hz, btype="highpass", fs=rate, output="sos")
    v = signal.sosfiltfilt(sos, cumulative_trapezoid(acc, 1.0 / rate), axis=0)
    x = signal.sosfiltfilt(sos, cumulative_trapezoid(v, 1.0 / rate), axis=0)
    return v, x


def _without_disagreeing_wires(cleaned: list[CleanSensor], level: int, sl: slice,
                               a_rel_xy: np.ndarray, ag_xy: np.ndarray, rate: float,
                               settings: IngestSettings, report: IngestReport
                               ) -> list[CleanSensor]:
    """``cleaned`` with the displacement channels of a level that disagree with its
    acceleration over ``sl`` made unusable there (copies; the originals stay as they are)."""
    flagged = check_displacement(cleaned, level, sl, a_rel_xy, ag_xy, rate, settings)
    if not flagged:
        return cleaned
    out = list(cleaned)
    for ch, share in flagged:
        cs = ch.sensor
        usable = cs.usable.copy()
        usable[sl, ch.column] = False
        out[out.index(cs)] = dataclasses.replace(cs, usable=usable)
        t0, t1 = cs.time_ns(sl.start), cs.time_ns(sl.stop - 1)
        report.add("inconsistent", ch.name, f"disagrees with the acceleration of level {level} "
                   f"integrated twice {fmt_span(t0, t1)}: it departs by {share:.0%} of the "
                   "motion in 0.2-10 Hz (more than its noise and gain allow); excluded for "
                   "this event", t0, t1, "excluded")
    return out


def _explain(err: Exception, recording: Recording, report: IngestReport, start_ns: int,
             end_ns: int) -> str:
    """Why an event failed: the error, and for a level without usable sensors what became of
    each of its sensors over the event (their findings)."""
    if not isinstance(err, LevelUnusableError):
        return f"{err} ({fmt_span(start_ns, end_ns)})"
    parts = []
    for spec in recording.config.sensors_at(err.level, err.kind):
        if spec.sensor_id not in recording.sensors:
            parts.append(f"{spec.sensor_id}: no samples at all")
            continue
        excluded = [f for f in report.about(spec.sensor_id)
                    if f.action == "excluded" and f.overlaps(start_ns, end_ns)]
        if excluded:
            parts.append("; ".join(f"{f.where}: {f.code} ({f.message})" for f in excluded[:2]))
    detail = ": " + "; ".join(parts) if parts else ""
    return f"{err} during {fmt_span(start_ns, end_ns)}{detail}"


def _strong_motion_recorded(ag_xy: np.ndarray, rate: float, span: EventSpan,
                            settings: IngestSettings) -> tuple[int, int, float]:
    """For an event the data end in: ``(i_peak, i_last, decay)``, the sample of the largest
    horizontal foundation acceleration from the window's start on, the last sample with
    data, and the foundation's RMS over the last ``partial_after_peak_s`` of data relative
    to its RMS over as long centred on the peak (NaN when the data after the peak are
    shorter than that)."""
    seg = ag_xy[span.start:]
    valid = np.flatnonzero(np.isfinite(seg).all(axis=1))
    if valid.size == 0:
        return span.start, span.start, math.nan
    seg = seg - seg[valid].mean(axis=0)
    mag = np.hypot(seg[:, 0], seg[:, 1]) if seg.shape[1] > 1 else np.abs(seg[:, 0])
    k_peak = int(valid[np.argmax(mag[valid])])
    k_last = int(valid[-1])
    n_after = int(round(settings.partial_after_peak_s * rate))
    if k_last - k_peak < n_after:
        return span.start + k_peak, span.start + k_last, math.nan

    def rms(lo: int, hi: int) -> float:
        part = mag[max(lo, 0):hi]
        return float(np.sqrt(np.nanmean(part ** 2)))

    decay = rms(k_last + 1 - n_after, k_last + 1) / rms(k_peak - n_after // 2,
                                                        k_peak + n_after - n_after // 2)
    return span.start + k_peak, span.start + k_last, decay


def _ingest_event(recording: Recording, cleaned: list[CleanSensor], t0: int, rate: float,
                  span: EventSpan, ag_xy: np.ndarray, settings: IngestSettings,
                  report: IngestReport, origin_ns: int) -> EventIngest:
    """One event's outcome: its window, or why there is none."""
    config = recording.config
    n_all = ag_xy.shape[0]

    def to_ns(i: int) -> int:
        return t0 + int(round(i * NS_PER_S / rate))

    start_ns, end_ns = t0 + int(span.start * NS_PER_S / rate), to_ns(span.end - 1)
    event_id = make_event_id(config.pier_id, start_ns)
    ctx = int(round(settings.context_s * rate))
    c0_ns, c1_ns = to_ns(max(0, span.start - ctx)), to_ns(min(n_all, span.end + ctx) - 1)
    partial = None
    if span.cut_end and not span.cut_start:
        i_peak, i_last, decay = _strong_motion_recorded(ag_xy, rate, span, settings)
        after_s = (i_last - i_peak) / rate
        peak = (f"the largest foundation acceleration ({fmt_time(to_ns(i_peak))}) lies "
                f"{after_s:.1f} s before the end of the data")
        if not after_s >= settings.partial_after_peak_s:
            peak += f", less than the {settings.partial_after_peak_s:g} s a partial window needs"
        else:
            peak += (f" and the shaking of the last {settings.partial_after_peak_s:g} s has "
                     f"{decay:.0%} of its RMS about that peak")
            if decay <= settings.partial_decay:
                partial = (f"the data end at {fmt_time(to_ns(i_last))} while the ground is "
                           f"still shaking; {peak} (at most {settings.partial_decay:.0%} "
                           "needed): the window holds the strong motion, the rest of the "
                           "shaking is missing")
            else:
                peak += (f", more than the {settings.partial_decay:.0%} that shows the strong "
                         "motion over")
    if (span.cut_start or span.cut_end) and partial is None:
        edge = (f"end at {fmt_time(to_ns(n_all - 1))}" if span.cut_end
                else f"begin at {fmt_time(t0)}")
        why = "" if span.cut_start else f"; {peak}"
        reason = (f"event {event_id} is cut: the data {edge} while the ground is still "
                  f"shaking ({fmt_span(start_ns, end_ns)} of it recorded); no window{why}")
        report.add("event_cut", event_id, reason, start_ns, end_ns, "failed")
        return EventIngest(event_id, start_ns, end_ns, None, reason, "cut",
                           tuple(report.within(c0_ns, c1_ns)))
    direction = settings.principal_direction_deg
    if direction is None:
        direction = config.principal_direction_deg
    try:
        if direction is None:
            seg = ag_xy[span.start:span.end]
            seg = seg[np.isfinite(seg).all(axis=1)]
            if seg.shape[0] < 2:
                raise IngestError(f"level 0: no foundation acceleration to estimate the "
                                  f"principal direction of event {event_id}")
            direction = estimate_principal_direction(seg - seg.mean(axis=0))
            report.add("principal_direction", event_id, f"estimated from the foundation "
                       f"acceleration: {direction:.2f} deg", start_ns, end_ns)
        window = _window_from_span(recording, cleaned, t0, rate, span.start, span.end,
                                   direction, settings, report, event_id, origin_ns)
    except (IngestError, InputDataError) as err:
        reason = _explain(err, recording, report, c0_ns, c1_ns)
        if partial is not None:
            reason = f"{reason}; partial event: {partial}"
        report.add("event_failed", event_id, reason, start_ns, end_ns, "failed")
        return EventIngest(event_id, start_ns, end_ns, None, reason, "failed",
                           tuple(report.within(c0_ns, c1_ns)), partial)
    extra: dict = {}
    if partial is not None:
        report.add("event_partial", event_id, partial, start_ns, end_ns, "noted")
        extra["partial"] = {"reason": partial}
    findings = tuple(report.within(c0_ns, c1_ns))
    window = dataclasses.replace(window, report={**window.report, **extra,
                                                 "findings": [f.as_dict() for f in findings]})
    return EventIngest(event_id, start_ns, end_ns, window, None,
                       "ingested" if partial is None else "partial", findings, partial)


def ingest_recording(recording: Recording, settings: IngestSettings | None = None, *,
                     origin_ns: int | None = None, select: SpanFilter | None = None
                     ) -> tuple[list[MeasuredWindow], IngestReport]:
    """All mainshock windows of a recording, and the report of what was done.

    "No event" is a normal result: an empty list.  Every detected event has an outcome in
    ``report.outcomes``, in time order: its window (also in the returned list), or why it
    has none (a level without usable sensors, data cut by the end of the recording, ...);
    one event's failure never loses another's window.  Each window's ``report["findings"]``
    lists the findings about its data.

    An event the data end in while the ground still shakes is *partial* when the recorded
    part holds the strong motion: the largest foundation acceleration and at least
    ``settings.partial_after_peak_s`` after it.  Its window covers what was recorded; the
    window's ``report["partial"]`` is ``{"reason": ...}`` and its outcome has status
    ``partial`` with the same reason.  Otherwise the event is ``cut`` and has no window.

    Parameters
    ----------
    recording : Recording
    settings : IngestSettings, optional
    origin_ns : int, optional
        Time of ``t = 0`` of the windows' ``t``, ns since the Unix epoch; default the
        recording's first sample.  A stream passes the time of its first sample, so that its
        windows do not depend on how much of the stream its buffer still holds.
    select : callable, optional
        ``select(span, start_ns, end_ns)``: ingest only the detected events for which it is
        true (a stream: those that have ended); the others get no outcome.  Default: all.

    Raises
    ------
    IngestError
        Only when nothing can be ingested at all: every sensor contradicts the configured
        rate, or the foundation has no usable accelerometer at any time.
    """
    settings = settings or IngestSettings()
    report = IngestReport()
    cleaned, t0, n, rate = clean_recording(recording, settings, report)
    config = recording.config
    ag_xy = level_motion_partial(cleaned, "acceleration", 0, slice(0, n))
    if ag_xy is None or not np.isfinite(ag_xy).any():
        t_end = t0 + int(round((n - 1) * NS_PER_S / rate))
        raise IngestError(_explain(LevelUnusableError(
            "level 0 (foundation): no usable acceleration sensor at any time; the ground "
            "motion is needed", 0, "acceleration"), recording, report, t0, t_end))
    threshold = trigger_threshold(config, settings)
    # trigger on both horizontal components: the direction may still be unknown
    spans = detect_events(ag_xy, rate, threshold, settings)
    report.checks["trigger_threshold_mps2"] = threshold
    origin = t0 if origin_ns is None else int(origin_ns)
    for span in spans:
        if select is not None and not select(*span_times(span, t0, rate)):
            continue
        report.outcomes.append(_ingest_event(recording, cleaned, t0, rate, span, ag_xy,
                                             settings, report, origin))
    if not spans:
        report.add("no_event", config.pier_id, f"no mainshock: the foundation RMS never exceeded "
                   f"{threshold:.3g} m/s²", t0, t0 + int(round((n - 1) * NS_PER_S / rate)))
    return [o.window for o in report.outcomes if o.window is not None], report


def span_times(span: EventSpan, t0_ns: int, rate_hz: float) -> tuple[EventSpan, int, int]:
    """``(span, start_ns, end_ns)``: a detected event with its window's first and last
    sample in ns since the Unix epoch (``t0_ns``: time of sample 0), as the ingest names
    them."""
    return (span, t0_ns + int(span.start * NS_PER_S / rate_hz),
            t0_ns + int(round((span.end - 1) * NS_PER_S / rate_hz)))
