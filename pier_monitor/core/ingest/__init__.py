"""Ingest: from raw sensor streams to mainshock windows (SPEC §6, §9).

Steps, the same for a whole recording and for a stream:

1. **Clean each sensor** (:func:`clean_sensor`): order by sample index, drop duplicates,
   re-time samples whose timestamp jumped, mark NaN/Inf samples missing, interpolate short
   gaps, exclude the sensor around long gaps, detect dead (flat) and saturated (clipped)
   channels, and convert to SI in the pier frame (undoing gain, offset, sign, unit).  Every
   action is recorded in the :class:`IngestReport` with the sensor and time.
2. **Average per level** by least squares over every usable horizontal channel of a kind at
   the level (each channel sees the level's motion projected on its own axis).
3. **Principal direction**: given by the configuration, else the principal axis of the
   foundation acceleration during the event.
4. **Detect events** on the foundation acceleration in the principal direction with a causal
   trigger (moving RMS over ``trigger_window_s`` above a threshold set from the
   accelerometers' configured noise and an absolute floor), merge triggers closer than
   ``merge_gap_s``, then take ``[1 %, 99 %]`` of the event's Arias intensity, padded.
5. **Relative motion and fusion** over the window plus context: relative accelerations
   (level minus foundation), wire displacements relative to their pre-event level, velocities
   and displacements by the Kalman/RTS fusion (:mod:`pier_monitor.core.ingest.fusion`) at the sensor
   rate, checked against the velocity meters where there are any.
6. **Resample** to ``output_rate_hz`` with a zero-phase anti-aliasing filter and emit a
   :class:`~pier_monitor.core.ingest.window.MeasuredWindow`.

Whole and stream give the same window because every step after cleaning only looks at the
data within ``context_s`` of the event, and the trigger is causal with a fixed threshold.
"""

from pier_monitor.core.ingest.clean import CleanSensor, clean_sensor
from pier_monitor.core.ingest.events import detect_events
from pier_monitor.core.ingest.levels import estimate_principal_direction, level_motion
from pier_monitor.core.ingest.settings import IngestError, IngestReport, IngestSettings
from pier_monitor.core.ingest.stream import StreamIngest
from pier_monitor.core.ingest.windows import ingest_recording

__all__ = [
    "IngestError",
    "IngestSettings",
    "IngestReport",
    "CleanSensor",
    "clean_sensor",
    "level_motion",
    "estimate_principal_direction",
    "detect_events",
    "ingest_recording",
    "StreamIngest",
]
