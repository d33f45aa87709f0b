"""Whole-recording ingest: cleaned sensors to mainshock windows."""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from pier_monitor.core.ingest.clean import CleanSensor, clean_recording
from pier_monitor.core.ingest.events import detect_events, make_event_id, trigger_threshold
from pier_monitor.core.ingest.fusion import fuse_acceleration_displacement
from pier_monitor.core.ingest.levels import estimate_principal_direction, level_motion, level_noise_si
from pier_monitor.core.ingest.recording import NS_PER_S, Recording
from pier_monitor.core.ingest.settings import IngestError, IngestReport, IngestSettings
from pier_monitor.core.ingest.window import Coverage, MeasuredWindow, NoiseModel
from pier_monitor.core.numerics import cumulative_trapezoid

__all__ = ["ingest_recording"]


def _decimate(x: np.ndarray, factor: int) -> np.ndarray:
    if factor == 1:
        return x
    return signal.decimate(x, factor, ftype="fir", axis=0, zero_phase=True)


def _window_from_span(recording: Recording, cleaned: list[CleanSensor], t0: int, rate: float,
                      w0: int, w1: int, direction: float, settings: IngestSettings,
                      report: IngestReport, event_id: str) -> MeasuredWindow:
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
        if a_xy is not None:
            a_abs = a_xy @ e_p
            a_rel[:, lv - 1] = a_abs - a_abs[lead].mean() - ag
        wire = level_motion(cleaned, "displacement", lv, sl, False, counts)
        if wire is not None:
            wire = wire @ e_p
            x_rel[:, lv - 1] = wire - np.nanmean(wire[lead])
    has_a = np.isfinite(a_rel).all(axis=0)
    has_x = np.isfinite(x_rel).any(axis=0)
    if not (has_a | has_x).any():
        raise IngestError(f"{event_id}: no usable acceleration or displacement sensor at any "
                          f"level above the foundation (levels 1-{n_lv}); nothing to identify")
    for lv in np.flatnonzero(~(has_a & has_x)) + 1:
        what = ("no usable sensor" if not (has_a[lv - 1] or has_x[lv - 1]) else
                "no usable displacement sensor" if has_a[lv - 1] else
                "no usable accelerometer")
        report.add("unmeasured_level", f"level {lv}", f"{event_id}: {what}; its motion is "
                   "reconstructed by the identifier")
    sig_a = np.array([math.hypot(level_noise_si(config, "acceleration", lv),
                                 level_noise_si(config, "acceleration", 0))
                      for lv in range(1, n_lv + 1)])
    sig_x = np.array([level_noise_si(config, "displacement", lv) for lv in range(1, n_lv + 1)])
    sig_a = np.where(np.isfinite(sig_a) & (sig_a > 0), sig_a, 1e-3)
    sig_x = np.where(np.isfinite(sig_x) & (sig_x > 0), sig_x, 1e-4)
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
        factor_ = max(1, int(round(rate / settings.output_rate_hz)))
        # increments over one output step (factor sensor steps)
        dx_sigma[both] = np.sqrt(factor_ * np.mean(fused.dx_sigma[inner] ** 2, axis=0))
        dv_sigma[both] = np.sqrt(factor_ * np.mean(fused.dv_sigma[inner] ** 2, axis=0))
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
            if v_xy is None:
                continue
            if not both[lv - 1]:
                continue
            meter = (v_xy - v0_xy) @ e_p
            d = meter[inner] - meter[inner].mean() - (v_rel[inner, lv - 1]
                                                      - v_rel[inner, lv - 1].mean())
            checks[f"level{lv}"] = {
                "rms_difference_mps": float(np.sqrt(np.mean(d ** 2))),
                "rms_velocity_mps": float(np.sqrt(np.mean(v_rel[inner, lv - 1] ** 2)))}
    report.checks.setdefault("velocity_meter", {})[event_id] = checks
    factor = int(round(rate / settings.output_rate_hz))
    if factor < 1 or abs(factor * settings.output_rate_hz - rate) > 1e-6 * rate:
        raise IngestError(f"output_rate_hz {settings.output_rate_hz:g} must divide the sensor rate "
                          f"{rate:g} Hz")
    # decimated sample k is sensor sample c0 + k·factor; keep those inside [w0, w1)
    k0 = -(-(w0 - c0) // factor)
    k1 = -(-(w1 - c0) // factor)
    dec = {name: _decimate(arr, factor)[k0:k1]
           for name, arr in (("a", a_rel), ("ag", ag), ("x", x_out), ("v", v_rel))}
    m = min(arr.shape[0] for arr in dec.values())
    start_ns = t0 + int(round((c0 + k0 * factor) * NS_PER_S / rate))
    t = (start_ns - t0) / NS_PER_S + np.arange(m) / settings.output_rate_hz
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


def ingest_recording(recording: Recording, settings: IngestSettings | None = None
                     ) -> tuple[list[MeasuredWindow], IngestReport]:
    """All mainshock windows of a recording, and the report of what was done.

    "No event" is a normal result: an empty list.
    """
    settings = settings or IngestSettings()
    report = IngestReport()
    cleaned, t0, n, rate = clean_recording(recording, settings, report)
    config = recording.config
    ag_xy = level_motion(cleaned, "acceleration", 0, slice(0, n), False)
    if ag_xy is None:
        raise IngestError("level 0 (foundation): no usable acceleration sensor; the ground "
                          "motion is needed")
    direction = settings.principal_direction_deg
    if direction is None:
        direction = config.principal_direction_deg
    threshold = trigger_threshold(config, settings)
    # trigger on both horizontal components: the direction may still be unknown
    spans = detect_events(np.nan_to_num(ag_xy), rate, threshold, settings)
    report.checks["trigger_threshold_mps2"] = threshold
    windows = []
    for k, (w0, w1) in enumerate(spans):
        d = direction
        if d is None:
            d = estimate_principal_direction(ag_xy[w0:w1] - ag_xy[w0:w1].mean(axis=0))
            report.add("principal_direction", f"event{k + 1}",
                       f"estimated from the foundation acceleration: {d:.2f} deg")
        event_id = make_event_id(config.pier_id, t0 + int(w0 * NS_PER_S / rate))
        windows.append(_window_from_span(recording, cleaned, t0, rate, w0, w1, d, settings,
                                         report, event_id))
    if not spans:
        report.add("no_event", config.pier_id, f"no mainshock: the foundation RMS never exceeded "
                   f"{threshold:.3g} m/s²")
    return windows, report
