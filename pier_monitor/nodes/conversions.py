"""Conversions between ROS messages and pier_monitor core types.

Every function that reads a message checks it against what the pier configuration expects
and raises :class:`MessageError` with the topic and field that are wrong, so that a node can
log it and drop the message.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import TransformStamped
from pier_monitor_msgs.msg import (IdentificationProgress, MainshockWindow, PierDamageState,
                                   SampleBlock, SectionState)
from sensor_msgs.msg import Imu
from visualization_msgs.msg import Marker, MarkerArray

from pier_monitor.bags.types import sample_block_arrays
from pier_monitor.core.errors import InputDataError, PierMonitorError
from pier_monitor.core.ids import EVENT_ID_MAX_LEN, check_id
from pier_monitor.core.ingest.recording import ns_to_stamp, stamp_to_ns
from pier_monitor.core.ingest.window import Coverage, MeasuredWindow, NoiseModel
from pier_monitor.core.model.config import (PierConfig, PierGeometry, SensorSpec,
                                            SpringParameters)
from pier_monitor.report.diagnostics import diagnostics_fields
from pier_monitor.report.markers import (DEFAULT_PARENT_FRAME, damage_markers_fields,
                                         pier_transform_fields)

try:  # a ROS 2 installation has it; the PyPI wheels of the project's environment do not
    from tf2_msgs.msg import TFMessage
except ImportError:
    TFMessage = None

if TYPE_CHECKING:  # the type only: the ingest node does not load the PINN (torch)
    from pier_monitor.core.identify.methods import Progress

__all__ = [
    "MessageError",
    "block_arrays",
    "imu_arrays",
    "time_to_ns",
    "ns_to_time",
    "window_to_msg",
    "window_from_msg",
    "fill_message",
    "damage_state_msg",
    "progress_msg",
    "damage_diagnostics",
    "damage_markers_msg",
    "pier_transforms_msg",
]


class MessageError(InputDataError):
    """A message that does not match what its topic must carry (names topic and field)."""


#: MainshockWindow noise fields and the NoiseModel attribute each carries.
_NOISE_FIELDS = (("acceleration_sigma", "a"), ("velocity_sigma", "v"),
                 ("displacement_sigma", "x"), ("displacement_increment_sigma", "dx"),
                 ("velocity_increment_sigma", "dv"), ("moment_sigma", "f"))


def time_to_ns(stamp: Time) -> int:
    """``builtin_interfaces/Time`` → ns since the epoch."""
    return stamp_to_ns(stamp.sec, stamp.nanosec)


def ns_to_time(t_ns: int) -> Time:
    """ns since the epoch → ``builtin_interfaces/Time``.

    Raises
    ------
    MessageError
        If the time does not fit the message (int32 seconds).
    """
    try:
        sec, nanosec = ns_to_stamp(t_ns)
    except InputDataError as err:
        raise MessageError(str(err)) from err
    return Time(sec=sec, nanosec=nanosec)


def block_arrays(msg: SampleBlock, spec: SensorSpec, rate_hz: float, topic: str
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(time_ns (T,), data (T, n_axes), sample_index (T,))`` of a SampleBlock.

    Raises
    ------
    MessageError
        When the block contradicts the sensor map (sensor id, kind, unit, axes, rate) or its
        data are not whole samples.
    """
    try:
        times, index, data, _ = sample_block_arrays(msg, spec, f"{topic}: SampleBlock", rate_hz)
    except InputDataError as err:
        raise MessageError(str(err)) from err
    return times, data, index


def imu_arrays(msg: Imu, spec: SensorSpec, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """``(time_ns (1,), data (1, 3))`` of one ``sensor_msgs/Imu`` sample (m/s², x y z).

    Raises
    ------
    MessageError
        If the sensor is not a 3-axis m/s² accelerometer in the map, or the message says
        it has no linear acceleration (covariance element 0 is -1). NaN/Inf values pass:
        the ingest treats them as missing samples, as in a SampleBlock.
    """
    if spec.kind != "acceleration" or list(spec.axes) != ["x", "y", "z"] \
            or spec.unit not in ("m/s^2", "m/s2"):
        raise MessageError(f"{topic}: sensor_msgs/Imu carries x, y, z in m/s^2 but sensor "
                           f"{spec.sensor_id} is {spec.kind} {list(spec.axes)} in {spec.unit!r}")
    if float(msg.linear_acceleration_covariance[0]) == -1.0:
        # sensor_msgs/Imu: element 0 of a covariance set to -1 means "no estimate"
        raise MessageError(f"{topic}: sensor_msgs/Imu without linear acceleration "
                           "(linear_acceleration_covariance[0] == -1)")
    a = msg.linear_acceleration
    return (np.array([time_to_ns(msg.header.stamp)], dtype=np.int64),
            np.array([[a.x, a.y, a.z]], dtype=np.float64))


def _levels(values: Any, n: int, where: str, name: str, empty: float | None = None
            ) -> np.ndarray:
    """A per-level field as (N,) floats; an empty sequence is ``empty`` at every level."""
    arr = np.asarray(values, dtype=float)
    if arr.size == 0 and empty is not None:
        return np.full(n, empty)
    if arr.shape != (n,):
        raise MessageError(f"{where}: {name} has {arr.size} values, expected n_levels = {n}")
    return arr


def _series(values: Any, m: int, n: int, where: str, name: str) -> np.ndarray:
    """A T x N row-major field as a (T, N) array."""
    arr = np.asarray(values, dtype=float)
    if arr.size != m * n:
        raise MessageError(f"{where}: {name} has {arr.size} values, expected "
                           f"n_samples x n_levels = {m * n}")
    return arr.reshape(m, n)


def window_to_msg(window: MeasuredWindow, config: PierConfig | None = None) -> MainshockWindow:
    """The MainshockWindow message of a window: every field of it, nothing lost.

    Parameters
    ----------
    window : MeasuredWindow
        The window.
    config : PierConfig, optional
        The configuration in force for the event, sent along as YAML for reference.

    Raises
    ------
    MessageError
        If the window's start does not fit a ``builtin_interfaces/Time``.
    """
    msg = MainshockWindow()
    msg.header.stamp = ns_to_time(window.start_time_ns)
    msg.header.frame_id = window.pier_id
    msg.pier_id = window.pier_id
    msg.event_id = window.event_id
    msg.sample_rate_hz = 1.0 / window.dt
    msg.n_levels = window.n_levels
    msg.n_samples = int(window.t.size)
    msg.time_s = window.t.tolist()
    msg.section_heights_m = window.geometry.section_heights_m.tolist()
    msg.masses_kg = window.geometry.masses_kg.tolist()
    for name in ("k1", "k2", "fy", "c"):
        setattr(msg, f"design_{name}", getattr(window.design, name).tolist())
    msg.ground_acceleration = window.ag.tolist()
    msg.acceleration = window.a.ravel().tolist()
    msg.velocity = window.v.ravel().tolist()
    msg.displacement = window.x.ravel().tolist()
    msg.moments = [] if window.moments is None else window.moments.ravel().tolist()
    noise = window.noise
    msg.ground_acceleration_sigma = noise.ag
    for field, key in _NOISE_FIELDS:
        setattr(msg, field, getattr(noise, key).tolist())
    msg.gain_sigma_rel = noise.gain_rel
    msg.acceleration_measured = [bool(v) for v in window.coverage.acceleration]
    msg.displacement_measured = [bool(v) for v in window.coverage.displacement]
    msg.highpass_hz = window.coverage.highpass_hz
    msg.pier_config_yaml = "" if config is None else config.to_yaml()
    msg.report = json.dumps(window.report)
    return msg


def window_from_msg(msg: MainshockWindow, topic: str = "mainshock_window") -> MeasuredWindow:
    """The MeasuredWindow of a message (the inverse of :func:`window_to_msg`).

    Raises
    ------
    MessageError
        Naming the topic, the event and the field when sizes or values are inconsistent, or
        when ``pier_id`` or ``event_id`` is not a safe id (they become directory names:
        :func:`~pier_monitor.core.ids.check_id`).
    """
    where = f"{topic}: MainshockWindow {msg.event_id!r}"
    n, m = int(msg.n_levels), int(msg.n_samples)
    try:
        check_id("pier_id", msg.pier_id)
        check_id("event_id", msg.event_id, max_len=EVENT_ID_MAX_LEN)
        report = json.loads(msg.report) if msg.report else {}
        if not isinstance(report, dict):
            raise MessageError(f"{where}: report is not a JSON object")
        t = np.asarray(msg.time_s, dtype=float)
        if t.size != m:
            raise MessageError(f"{where}: time_s has {t.size} values, expected n_samples = {m}")
        level = lambda name, empty=None: _levels(getattr(msg, name), n, where, name, empty)
        series = lambda name: _series(getattr(msg, name), m, n, where, name)
        noise = NoiseModel(ag=float(msg.ground_acceleration_sigma),
                           gain_rel=float(msg.gain_sigma_rel),
                           **{key: level(field, math.nan) for field, key in _NOISE_FIELDS})
        coverage = None
        if len(msg.acceleration_measured) or len(msg.displacement_measured):
            coverage = Coverage(
                np.asarray(level("acceleration_measured"), dtype=bool),
                np.asarray(level("displacement_measured"), dtype=bool), float(msg.highpass_hz))
        return MeasuredWindow(
            pier_id=msg.pier_id, event_id=msg.event_id,
            geometry=PierGeometry(level("section_heights_m"), level("masses_kg")),
            design=SpringParameters(*(level(f"design_{k}") for k in ("k1", "k2", "fy", "c"))),
            t=t, ag=np.asarray(msg.ground_acceleration, dtype=float), a=series("acceleration"),
            v=series("velocity"), x=series("displacement"),
            moments=series("moments") if len(msg.moments) else None, noise=noise,
            coverage=coverage, start_time_ns=time_to_ns(msg.header.stamp), report=report)
    except MessageError:
        raise
    except (PierMonitorError, ValueError) as err:  # the core's checks name the field
        raise MessageError(f"{where}: {err}") from err


def fill_message(msg: Any, fields: dict[str, Any]) -> Any:
    """Set the fields of an rclpy message from a dict (nested dicts / lists of dicts)."""
    types = msg.get_fields_and_field_types()
    for name, value in fields.items():
        if name not in types:
            raise KeyError(f"{type(msg).__name__} has no field {name!r}")
        if isinstance(value, dict):
            fill_message(getattr(msg, name), value)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            cls = _sequence_class(msg, name)
            setattr(msg, name, [fill_message(cls(), v) for v in value])
        else:
            setattr(msg, name, value)
    return msg


def _sequence_class(msg: Any, name: str) -> type:
    if isinstance(msg, PierDamageState) and name == "sections":
        return SectionState
    if isinstance(msg, DiagnosticArray) and name == "status":
        return DiagnosticStatus
    if isinstance(msg, DiagnosticStatus) and name == "values":
        return KeyValue
    if isinstance(msg, MarkerArray) and name == "markers":
        return Marker
    raise TypeError(f"no message class known for {type(msg).__name__}.{name}")


def damage_state_msg(fields: dict[str, Any]) -> PierDamageState:
    """A PierDamageState from :func:`pier_monitor.report.results.damage_state_fields`."""
    return fill_message(PierDamageState(), fields)


def progress_msg(event_id: str, progress: Progress, stamp_ns: int) -> IdentificationProgress:
    """IdentificationProgress of a :class:`pier_monitor.core.identify.methods.Progress`."""
    msg = IdentificationProgress()
    msg.header.stamp = ns_to_time(stamp_ns)
    msg.event_id = event_id
    msg.epoch = int(progress.epoch)
    msg.max_epochs = int(progress.max_epochs)
    msg.loss = float(progress.loss)
    msg.loss_term_names = [str(k) for k in progress.terms]
    msg.loss_terms = [float(v) for v in progress.terms.values()]
    for name in ("k1", "k2", "fy", "c"):
        setattr(msg, name, np.asarray(getattr(progress, name), dtype=float).ravel().tolist())
    msg.elapsed_s = float(progress.elapsed_s)
    return msg


def damage_diagnostics(fields: dict[str, Any], stamp_ns: int, *,
                       k1_vs_design_pct: Sequence[float | None] = (),
                       poorly_identified: Sequence[Sequence[str]] | None = None
                       ) -> DiagnosticArray:
    """``/diagnostics`` of a damage state (:func:`pier_monitor.report.diagnostics.
    diagnostics_fields`): one status per section, then the identifier's.

    Parameters
    ----------
    fields : dict
        :func:`pier_monitor.report.results.damage_state_fields` of the result.
    stamp_ns : int
        ``header.stamp``, ns since the Unix epoch.
    k1_vs_design_pct : sequence of float or None
        Per section, the difference of ``k1`` from the design values, %
        (:func:`pier_monitor.report.results.k1_vs_design`).
    poorly_identified : sequence of sequence of str, optional
        Per section, the quantities whose interval is too wide (``SectionResult.
        poorly_identified``); None: not shown.
    """
    diag = diagnostics_fields(fields, stamp_ns, k1_vs_design_pct=k1_vs_design_pct,
                              poorly_identified=poorly_identified)
    for st in diag["status"]:
        st["level"] = bytes([st["level"]])  # rclpy's byte fields take one-byte bytes
    return fill_message(DiagnosticArray(), diag)


def damage_markers_msg(fields: dict[str, Any]) -> MarkerArray:
    """The pier's MarkerArray (:func:`pier_monitor.report.markers.damage_markers_fields`)."""
    return fill_message(MarkerArray(), damage_markers_fields(fields))


def pier_transforms_msg(pier_ids: list[str], stamp_ns: int, *,
                        parent_frame: str = DEFAULT_PARENT_FRAME) -> Any:
    """The ``tf2_msgs/TFMessage`` of the transforms ``parent_frame`` → each pier
    (:func:`pier_monitor.report.markers.pier_transform_fields`).

    Raises
    ------
    RuntimeError
        If ``tf2_msgs`` is not installed.
    ValueError
        If ``parent_frame`` is empty or one of the piers.
    """
    if TFMessage is None:
        raise RuntimeError("tf2_msgs is not installed")
    sec, nanosec = ns_to_stamp(stamp_ns)
    fields = pier_transform_fields(list(pier_ids), {"sec": sec, "nanosec": nanosec},
                                   parent_frame=parent_frame)
    msg = TFMessage()
    msg.transforms = [fill_message(TransformStamped(), t) for t in fields["transforms"]]
    return msg
