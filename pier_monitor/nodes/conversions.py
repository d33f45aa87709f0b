"""Conversions between ROS messages and pier_monitor core types.

Every function that reads a message checks it against what the pier configuration expects
and raises :class:`MessageError` with the topic and field that are wrong, so that a node can
log it and drop the message.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from pier_monitor_msgs.msg import (IdentificationProgress, MainshockWindow, PierDamageState,
                                   SampleBlock, SectionState)
from sensor_msgs.msg import Imu

from pier_monitor.bags.types import sample_block_arrays
from pier_monitor.core.model.config import PierConfig, SensorSpec, config_from_yaml
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.recording import NS_PER_S
from pier_monitor.core.ingest.window import Coverage, MeasuredWindow, NoiseModel

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
    "failed_state_fields",
    "progress_msg",
    "section_diagnostics",
    "DIAGNOSTIC_LEVELS",
]


class MessageError(InputDataError):
    """A message that does not match what its topic must carry (names topic and field)."""


#: DiagnosticStatus level of each SectionState.STATE_* code.
DIAGNOSTIC_LEVELS = {
    SectionState.STATE_INTACT: DiagnosticStatus.OK,
    SectionState.STATE_SUSPICIOUS: DiagnosticStatus.WARN,
    SectionState.STATE_DAMAGED: DiagnosticStatus.ERROR,
    SectionState.STATE_UNKNOWN: DiagnosticStatus.STALE,
}
_STATE_NAMES = {0: "intact", 1: "suspicious", 2: "damaged", 3: "unknown"}


def time_to_ns(stamp: Any) -> int:
    """``builtin_interfaces/Time`` → ns since the epoch."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def ns_to_time(t_ns: int) -> Time:
    """ns since the epoch → ``builtin_interfaces/Time``."""
    sec, nanosec = divmod(int(t_ns), NS_PER_S)
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


def window_to_msg(window: MeasuredWindow, config: PierConfig) -> MainshockWindow:
    """The MainshockWindow message of a window (its configuration as YAML)."""
    msg = MainshockWindow()
    msg.header.stamp = ns_to_time(window.start_time_ns)
    msg.header.frame_id = window.pier_id
    msg.pier_id = window.pier_id
    msg.event_id = window.event_id
    msg.sample_rate_hz = 1.0 / window.dt
    msg.n_levels = window.n_levels
    msg.n_samples = int(window.t.size)
    msg.level_heights_m = np.cumsum(window.geometry.section_heights_m).tolist()
    msg.masses_kg = window.geometry.masses_kg.tolist()
    msg.ground_acceleration = window.ag.tolist()
    msg.acceleration = window.a.ravel().tolist()
    msg.velocity = window.v.ravel().tolist()
    msg.displacement = window.x.ravel().tolist()
    for name, key in (("acceleration_sigma", "a"), ("velocity_sigma", "v"),
                      ("displacement_sigma", "x")):
        setattr(msg, name, getattr(window.noise, key).tolist())
    msg.pier_config_yaml = config.to_yaml()
    msg.report = json.dumps({"report": window.report, "noise": window.noise.as_dict(),
                             "coverage": window.coverage.as_dict(),
                             "t0_s": float(window.t[0])})
    return msg


def window_from_msg(msg: MainshockWindow, topic: str = "mainshock_window") -> MeasuredWindow:
    """A MeasuredWindow from its message (geometry and design from the embedded YAML).

    Raises
    ------
    MessageError
        Naming the topic and field when sizes or the configuration are inconsistent.
    """
    where = f"{topic}: MainshockWindow {msg.event_id!r}"
    try:
        config = config_from_yaml(msg.pier_config_yaml, source=where)
        extra = json.loads(msg.report) if msg.report else {}
        n, m = int(msg.n_levels), int(msg.n_samples)
        rate = float(msg.sample_rate_hz)
        if not (rate > 0 and math.isfinite(rate)):
            raise MessageError(f"{where}: sample_rate_hz {rate}")
        shape = (m, n)
        arrays = {}
        for key, name in (("a", "acceleration"), ("v", "velocity"), ("x", "displacement")):
            arr = np.asarray(getattr(msg, name), dtype=float)
            if arr.size != m * n:
                raise MessageError(f"{where}: {name} has {arr.size} values, expected "
                                   f"n_samples x n_levels = {m * n}")
            arrays[key] = arr.reshape(shape)
        noise = NoiseModel.from_dict(extra["noise"]) if "noise" in extra else None
        coverage = Coverage.from_dict(extra["coverage"]) if "coverage" in extra else None
        t = float(extra.get("t0_s", 0.0)) + np.arange(m) / rate
        return MeasuredWindow(
            pier_id=msg.pier_id, event_id=msg.event_id, geometry=config.geometry,
            design=config.design, t=t, ag=np.asarray(msg.ground_acceleration, dtype=float),
            a=arrays["a"], v=arrays["v"], x=arrays["x"], noise=noise, coverage=coverage,
            start_time_ns=time_to_ns(msg.header.stamp), report=extra.get("report", {}))
    except MessageError:
        raise
    except Exception as err:  # config/shape errors of the core name the field
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
    raise TypeError(f"no message class known for {type(msg).__name__}.{name}")


def damage_state_msg(fields: dict[str, Any]) -> PierDamageState:
    """A PierDamageState from :func:`pier_monitor.report.results.damage_state_fields`."""
    return fill_message(PierDamageState(), fields)


def failed_state_fields(window: MeasuredWindow, message: str, device: str, stamp_ns: int
                        ) -> dict[str, Any]:
    """Damage-state fields of a failed identification: every section STATE_UNKNOWN."""
    nan = float("nan")
    z = np.concatenate(([0.0], np.cumsum(window.geometry.section_heights_m)))
    sections = [{"index": i, "z_bottom_m": float(z[i]), "z_top_m": float(z[i + 1]),
                 "k1": nan, "k2": nan, "fy": nan, "c": nan, "yield_angle_rad": nan,
                 "max_angle_rad": nan, "ductility_factor": nan, "k1_change_pct": nan,
                 "k2_identifiable": False, "fy_identifiable": False,
                 "state": int(SectionState.STATE_UNKNOWN)} for i in range(window.n_levels)]
    sec, nanosec = divmod(int(stamp_ns), NS_PER_S)
    ws, wn = divmod(int(window.start_time_ns), NS_PER_S)
    return {"header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": window.pier_id},
            "pier_id": window.pier_id, "event_id": window.event_id,
            "window_start": {"sec": ws, "nanosec": wn},
            "window_duration_s": float(window.duration_s), "sections": sections,
            "overall_state": int(SectionState.STATE_UNKNOWN), "epochs": 0, "final_loss": nan,
            "wall_time_s": 0.0, "device": device, "message": message, "success": False}


def progress_msg(event_id: str, progress: Any, stamp_ns: int) -> IdentificationProgress:
    """IdentificationProgress of a :class:`pier_monitor.pinn.Progress`."""
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


def _fmt(value: float) -> str:
    return "nan" if value is None or not math.isfinite(value) else f"{value:.6g}"


def section_diagnostics(fields: dict[str, Any], stamp_ns: int) -> DiagnosticArray:
    """``/diagnostics``: one status per section (OK/WARN/ERROR = intact/suspicious/damaged,
    STALE when there is no diagnosis), values k1, its change from baseline and DF."""
    arr = DiagnosticArray()
    arr.header.stamp = ns_to_time(stamp_ns)
    pier = fields["pier_id"]
    for s in fields["sections"]:
        st = DiagnosticStatus()
        st.level = DIAGNOSTIC_LEVELS[s["state"]]
        st.name = f"pier_monitor/{pier}/section_{s['index'] + 1}"
        st.hardware_id = pier
        state = _STATE_NAMES[s["state"]]
        if fields["success"]:
            st.message = (f"{state}: DF {_fmt(s['ductility_factor'])}, k1 change "
                          f"{_fmt(s['k1_change_pct'])} % (event {fields['event_id']})")
        else:
            st.message = f"no diagnosis: {fields['message']}"[:500]
        st.values = [KeyValue(key=k, value=v) for k, v in (
            ("event_id", fields["event_id"]),
            ("state", state),
            ("z_bottom_m", _fmt(s["z_bottom_m"])), ("z_top_m", _fmt(s["z_top_m"])),
            ("k1", _fmt(s["k1"])), ("k1_change_pct", _fmt(s["k1_change_pct"])),
            ("ductility_factor", _fmt(s["ductility_factor"])),
            ("k2", _fmt(s["k2"]) if s["k2_identifiable"] else "not identifiable"),
            ("fy", _fmt(s["fy"]) if s["fy_identifiable"] else "not identifiable"),
            ("c", _fmt(s["c"])))]
        arr.status.append(st)
    return arr
