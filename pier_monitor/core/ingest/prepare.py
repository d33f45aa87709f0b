"""A whole recording onto one grid: every sensor cleaned, then checked against the others.

:func:`clean_recording` is the first step of the ingest, the same for a whole recording and
for a stream's buffer: :func:`~pier_monitor.core.ingest.clean.clean_sensor` for each sensor,
:func:`~pier_monitor.core.ingest.consistency.check_units` and
:func:`~pier_monitor.core.ingest.consistency.check_accelerometers` across the sensors of each
level, :func:`~pier_monitor.core.ingest.consistency.check_wires_at_rest` for the displacement
sensors, then :func:`~pier_monitor.core.ingest.clean.bridge_gaps`.
"""

from __future__ import annotations

import numpy as np

from pier_monitor.core.ingest.clean import (CleanSensor, block_starts, bridge_gaps, clean_sensor,
                                            data_rate_hz, rate_problem)
from pier_monitor.core.ingest.consistency import (check_accelerometers, check_units,
                                                  check_wires_at_rest)
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
from pier_monitor.core.ingest.settings import IngestError, IngestReport, IngestSettings
from pier_monitor.core.ingest.findings import fmt_time

__all__ = ["clean_recording", "recording_grid"]


def recording_grid(recording: Recording) -> tuple[int, int, float]:
    """``(t0_ns, n, rate_hz)``: the uniform grid spanning every sensor's samples."""
    rate = recording.config.sample_rate_hz
    t0 = recording.start_ns
    n = int(round((recording.end_ns - t0) * rate / NS_PER_S)) + 1
    return t0, n, rate


def _check_rates(recording: Recording) -> None:
    """An :class:`IngestError` when every sensor contradicts the configured rate."""
    rate = recording.config.sample_rate_hz
    with_samples = [r for r in recording.sensors.values() if r.n_samples]
    config = recording.config
    problems = {r.sensor_id: rate_problem(r, config.sensor_rate_hz(config.sensor(r.sensor_id)))
                for r in with_samples}
    if with_samples and all(problems.values()):
        own = sorted({round(data_rate_hz(r) or r.rate_hz, 3) for r in with_samples})
        declared = sorted({r.rate_hz for r in with_samples})
        raise IngestError(
            f"the configuration's sample_rate_hz {rate:g} Hz contradicts the data: all "
            f"{len(with_samples)} sensors are recorded at {', '.join(f'{d:g}' for d in declared)}"
            f" Hz by their blocks, {', '.join(f'{o:g}' for o in own)} Hz by their timestamps "
            f"(e.g. {with_samples[0].sensor_id}); correct sample_rate_hz of pier "
            f"{recording.config.pier_id!r}")


def clean_recording(recording: Recording, settings: IngestSettings, report: IngestReport
                    ) -> tuple[list[CleanSensor], int, int, float]:
    """Clean every sensor of a recording onto one grid; see the module doc.

    Returns ``(cleaned, t0_ns, n, rate_hz)``.

    Raises
    ------
    IngestError
        When every sensor contradicts the configured sample rate (naming both rates).
    """
    config = recording.config
    t0, n, rate = recording_grid(recording)
    t_end = t0 + int(round((n - 1) * NS_PER_S / rate))
    report.findings.extend(recording.findings)
    for topic in recording.unmapped_topics:
        report.add("unmapped_topic", topic, "sample blocks of a sensor that is not in the sensor "
                   "map; ignored", t0, t_end)
    for sid in recording.missing_sensors:
        report.add("missing_sensor", sid, "in the sensor map but no samples were received",
                   t0, t_end, "excluded")
    _check_rates(recording)
    cleaned = []
    for sid, rec in recording.sensors.items():
        spec = config.sensor(sid)
        own = config.sensor_rate_hz(spec)
        if own == rate:
            cs = clean_sensor(spec, rec, t0, n, rate, settings, report)
        else:  # a slower sensor (GNSS): cleaned at its own rate, then put on the grid
            every = int(round(rate / own))
            cs = clean_sensor(spec, rec, t0, (n - 1) // every + 1, own, settings, report)
            bridge_gaps(cs, settings, report)
            cs = _on_grid(cs, every, n, rate)
        _report_silence(cs, rec, t_end, report)
        cleaned.append(cs)
    check_units(cleaned, report)
    starts = block_starts(t0, n, rate)
    check_accelerometers(cleaned, starts, settings, report)
    check_wires_at_rest(cleaned, starts, settings, report)
    for cs in cleaned:
        bridge_gaps(cs, settings, report)
    return cleaned, t0, n, rate


def _on_grid(cs: CleanSensor, every: int, n: int, rate_hz: float) -> CleanSensor:
    """A sensor cleaned at its own (slower) rate on the recording's grid: its samples at
    every ``every``-th grid sample, NaN between them (not sampled, not missing: no flag),
    usable where its own samples are."""
    n_axes = cs.values.shape[1]
    values = np.full((n, n_axes), np.nan)
    values[::every] = cs.values[:values[::every].shape[0]]
    usable = np.repeat(cs.usable, every, axis=0)[:n]
    flags = np.zeros((n, n_axes), dtype=np.int8)
    return CleanSensor(cs.spec, cs.t0_ns, rate_hz, values, usable, flags)


def _report_silence(cs: CleanSensor, rec: SensorRecord, t_end: int,
                    report: IngestReport) -> None:
    """Findings for a sensor that starts late or stops early against the others (> 1 s)."""
    if not rec.n_samples or not cs.usable.any():
        return
    first, last = int(rec.time_ns.min()), int(rec.time_ns.max())
    if first - cs.t0_ns > NS_PER_S:
        report.add("no_data", cs.spec.sensor_id, f"no samples before {fmt_time(first)} (the "
                   f"recording starts {(first - cs.t0_ns) / NS_PER_S:.2f} s earlier)",
                   cs.t0_ns, first, "excluded")
    if t_end - last > NS_PER_S:
        report.add("no_data", cs.spec.sensor_id, f"no samples after {fmt_time(last)} (the "
                   f"recording goes on {(t_end - last) / NS_PER_S:.2f} s longer)",
                   last, t_end, "excluded")
