"""Ingest: from raw sensor streams to mainshock windows (SPEC §6, §9).

Steps, the same for a whole recording and for a stream:

1. **Clean each sensor** (:func:`clean_sensor`): name a sample rate that contradicts the
   configuration, order by sample index, drop duplicates, re-time samples whose timestamp
   jumped, mark NaN/Inf and physically impossible samples (beyond ``full_scale`` /
   ``range``) missing, detect dead, saturated (clipped) and frozen channels, convert to SI in
   the pier frame (undoing gain, offset, sign, unit), and find glitches and offset jumps of
   displacement and velocity sensors in their own increments.
2. **Check each sensor against its level** (:mod:`~pier_monitor.core.ingest.consistency`):
   accelerometers in a wrong unit; accelerometer channels that disagree with the others of
   their level (excluded over those seconds) or have glitches (marked missing); then short
   runs of missing samples are interpolated and long ones exclude the channel there.  Every
   finding (:class:`Finding`) names the sensor and the time, and says what was done.
3. **Average per level** by least squares over every usable horizontal channel of a kind at
   the level (each channel sees the level's motion projected on its own axis).
4. **Principal direction**: given by the configuration, else the principal axis of the
   foundation acceleration during the event.
5. **Detect events** on the foundation acceleration in the principal direction with a causal
   trigger (moving RMS over ``trigger_window_s`` above a threshold set from the
   accelerometers' configured noise and an absolute floor), merge triggers closer than
   ``merge_gap_s``, then take ``[1 %, 99 %]`` of the event's Arias intensity, padded.  An
   event still shaking where the data end (or begin) is cut and gets no window, unless the
   data end after its strong motion: its recorded part is then a *partial* window.
6. **Relative motion and fusion** over the window plus context: relative accelerations
   (level minus foundation), wire displacements relative to their pre-event level (a wire
   that disagrees with its level's acceleration is excluded for the event), velocities
   and displacements by the Kalman/RTS fusion (:mod:`pier_monitor.core.ingest.fusion`) at the sensor
   rate, checked against the velocity meters where there are any.
7. **Resample** to ``output_rate_hz`` with a zero-phase anti-aliasing filter and emit a
   :class:`~pier_monitor.core.ingest.window.MeasuredWindow`.

Each event has an outcome (:class:`EventIngest`): its window or the reason it has none; one
event's failure never loses another.  Whole and stream give the same window because every
step looks only at data near the samples it judges (local statistics per UTC second, the
event's context), the trigger is causal with a fixed threshold, and the stream hands an event
on only once the offline rule sees it ended (or at the end of the stream).
"""

from pier_monitor.core.ingest.clean import CleanSensor, clean_sensor
from pier_monitor.core.ingest.triggers import EventSpan, detect_events
from pier_monitor.core.ingest.levels import estimate_principal_direction, level_motion
from pier_monitor.core.ingest.prepare import clean_recording
from pier_monitor.core.ingest.settings import (EventIngest, IngestError, IngestReport,
                                               IngestSettings, LevelUnusableError)
from pier_monitor.core.ingest.findings import Finding
from pier_monitor.core.ingest.stream import StreamIngest
from pier_monitor.core.ingest.batch import ingest_recording

__all__ = [
    "IngestError",
    "LevelUnusableError",
    "Finding",
    "EventIngest",
    "EventSpan",
    "clean_recording",
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
