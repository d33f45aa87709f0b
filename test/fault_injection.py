"""Faults injected into copies of a synthetic shaking-table recording, for the tests.

Each injector returns ``make(recording, timeline) -> recording``: a copy of the recording
with one fault (a glitch, a gap, a frozen or dead channel, a wrong gain, unit or rate, a
clock jump, data cut short, ...).  :func:`short_recording` is the recording they are made
for: two runs of increasing damage (the second yields sections 1-2), 88 s at 200 Hz.  The
ingest corpus (``unit/test_ingest_faults.py``) and the end-to-end corpus
(``integration/test_bad_input_end_to_end.py``) share them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
from pier_monitor.core.model.config import load_config
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.shaking_table import (SyntheticRecording, edefense_scenario,
                                                        generate_recording)

RATE = 200.0


@dataclass(frozen=True)
class Timeline:
    """Seconds from the recording's start of points in the runs' reference windows."""

    windows: tuple[tuple[float, float], ...]

    def at(self, run: int, share: float) -> float:
        """The point ``share`` (0-1) into the reference window of ``run`` (1-based)."""
        w0, w1 = self.windows[run - 1]
        return w0 + share * (w1 - w0)


def idx(t_s: float) -> int:
    return int(round(t_s * RATE))


def replace_sensor(rec: Recording, sid: str, **fields) -> Recording:
    old = rec.sensors[sid]
    new = {"time_ns": old.time_ns, "data": old.data, "rate_hz": old.rate_hz,
           "sample_index": old.sample_index, **fields}
    sensors = dict(rec.sensors)
    sensors[sid] = SensorRecord(sid, **new)
    return dataclasses.replace(rec, sensors=sensors)


def edit(sid: str, change: Callable[[np.ndarray, np.ndarray, Timeline], None], *more: str):
    """A fault: ``change(data, offsets, timeline)`` edits a copy of the samples of ``sid``
    (and of the ``more`` sensors)."""
    def make(rec: Recording, tl: Timeline) -> Recording:
        for s in (sid, *more):
            data = np.array(rec.sensors[s].data)
            change(data, np.asarray(rec.config.sensor(s).offsets), tl)
            rec = replace_sensor(rec, s, data=data)
        return rec
    return make


def at_sample(sid: str, run: int, share: float, axis: int, value: float, n: int = 1,
              add: bool = True):
    """Set (or add) ``value`` on ``n`` samples of one axis from a point of a run."""
    def change(data, _off, tl):
        i = idx(tl.at(run, share))
        if add:
            data[i:i + n, axis] += value
        else:
            data[i:i + n, axis] = value
    return edit(sid, change)


def drop(sid: str, run: int, share: float, seconds: float):
    def make(rec, tl):
        r = rec.sensors[sid]
        i = idx(tl.at(run, share))
        keep = np.ones(r.n_samples, dtype=bool)
        keep[i:i + idx(seconds)] = False
        return replace_sensor(rec, sid, time_ns=r.time_ns[keep], data=r.data[keep],
                              sample_index=r.sample_index[keep])
    return make


def frozen_from(sid: str, run: int, share: float, seconds: float | None = None):
    def change(data, _off, tl):
        i = idx(tl.at(run, share))
        j = data.shape[0] if seconds is None else i + idx(seconds)
        data[i:j] = data[i]
    return edit(sid, change)


def respec(sid: str, inner=None, **changes):
    """Change a sensor's entry of the map (in every configuration of the recording)."""
    def make(rec, tl):
        rec = inner(rec, tl) if inner is not None else rec
        fix = lambda c: dataclasses.replace(c, sensors=tuple(
            dataclasses.replace(s, **changes) if s.sensor_id == sid else s for s in c.sensors))
        return dataclasses.replace(rec, config=fix(rec.config), config_updates=tuple(
            (t, fix(c)) for t, c in rec.config_updates))
    return make


def config_rate(rate_hz: float):
    def make(rec, tl):
        fix = lambda c: dataclasses.replace(c, sample_rate_hz=rate_hz)
        return dataclasses.replace(rec, config=fix(rec.config), config_updates=tuple(
            (t, fix(c)) for t, c in rec.config_updates))
    return make


def without(sid: str):
    def make(rec, tl):
        return dataclasses.replace(rec, sensors={k: v for k, v in rec.sensors.items()
                                                 if k != sid})
    return make


def keep_span(start: Callable[[Timeline], float], end: Callable[[Timeline], float]):
    """Only the samples between two times (a recording that starts late or ends early)."""
    def make(rec, tl):
        t0 = rec.start_ns + int(start(tl) * NS_PER_S)
        t1 = rec.start_ns + int(end(tl) * NS_PER_S)
        sensors = {}
        for sid, r in rec.sensors.items():
            k = (r.time_ns >= t0) & (r.time_ns < t1)
            sensors[sid] = SensorRecord(sid, r.time_ns[k], r.data[k], r.rate_hz,
                                        r.sample_index[k])
        return dataclasses.replace(rec, sensors=sensors)
    return make


def scaled(sid: str, factor: float, axis: int | None = None):
    """A wrong gain (factor) or a reversed sign (-1) about the sensor's offsets."""
    def change(data, off, tl):
        cols = slice(None) if axis is None else axis
        data[:, cols] = (data[:, cols] - off[cols]) * factor + off[cols]
    return edit(sid, change)


def disconnected(sid: str):
    def change(data, off, tl):
        data[:] = off + 0.1 * np.random.default_rng(5).standard_normal(data.shape)
    return edit(sid, change)


def clipped_above_run1(sid: str):
    """Clipped at 1.05 x the largest excursion of run 1: only run 2 reaches the rails."""
    def change(data, off, tl):
        x = data - off
        run1 = slice(idx(tl.windows[0][0]), idx(tl.windows[0][1]))
        lim = 1.05 * np.abs(x[run1]).max()
        data[:] = np.clip(x, -lim, lim) + off
    return edit(sid, change)


def reordered(sid: str):
    def make(rec, tl):
        r = rec.sensors[sid]
        i = idx(tl.at(1, 0.5))
        order = np.arange(r.n_samples)
        order[i], order[i + 1] = i + 1, i
        return replace_sensor(rec, sid, time_ns=r.time_ns[order], data=r.data[order],
                              sample_index=r.sample_index[order])
    return make


def duplicated(sid: str):
    def make(rec, tl):
        r = rec.sensors[sid]
        i = idx(tl.at(2, 0.5))
        order = np.concatenate([np.arange(i), [i - 1, i - 1], np.arange(i, r.n_samples)])
        return replace_sensor(rec, sid, time_ns=r.time_ns[order], data=r.data[order],
                              sample_index=r.sample_index[order])
    return make


def clock_jump(sid: str):
    def make(rec, tl):
        t = np.array(rec.sensors[sid].time_ns)
        i = idx(tl.at(1, 0.6))
        t[i:i + 10] += 3_000_000  # the timestamps jumped by 3 ms for ten samples
        return replace_sensor(rec, sid, time_ns=t)
    return make


def timestamps_at(sid: str, rate_hz: float):
    def make(rec, tl):
        r = rec.sensors[sid]
        t = r.time_ns[0] + np.rint(np.arange(r.n_samples) * NS_PER_S / rate_hz).astype(np.int64)
        return replace_sensor(rec, sid, time_ns=t)
    return make


def unmapped(rec, tl):
    return dataclasses.replace(rec, unmapped_topics=("/edefense_pier/sensors/level9/acc",))


def offset_jump(sid: str, run: int, share: float, jump: float):
    def change(data, _off, tl):
        data[idx(tl.at(run, share)):, 0] += jump
    return edit(sid, change)


def short_recording(seed: int = 0) -> tuple[SyntheticRecording, Timeline]:
    """The two-run recording (runs at about 20-32 s and 58-70 s) and its timeline."""
    config = load_config(find_config_file("edefense_like.yaml"))
    scenario = edefense_scenario(record_s=20.0, lead_s=12.0, gap_s=18.0, tail_s=18.0)
    synthetic = generate_recording(config, scenario, seed=seed)
    rec = synthetic.recording
    timeline = Timeline(tuple(((r.window_start_ns - rec.start_ns) / NS_PER_S,
                               (r.window_end_ns - rec.start_ns) / NS_PER_S)
                              for r in synthetic.truth.runs))
    return synthetic, timeline


# -- block and bag faults ----------------------------------------------------------------------

def in_layout(rec: Recording, layout: str) -> Recording:
    """The recording as a field layout (``full``, ``accel``, ``sparse``) would record it: the
    layout's configuration and only its sensors."""
    from pier_monitor.core.synthetic.layouts import layout_config

    config = layout_config(rec.config, layout)
    keep = {s.sensor_id for s in config.sensors}
    return dataclasses.replace(
        rec, config=config, sensors={k: v for k, v in rec.sensors.items() if k in keep},
        config_updates=tuple((t, layout_config(c, layout)) for t, c in rec.config_updates))


def block_fault_bag(rec: Recording, path, faults: dict, block_s: float = 1.0) -> None:
    """Write ``rec`` to a plain mcap with some sample blocks changed.

    ``faults`` maps ``(sensor id, block number)`` (1-based, in time order) to
    ``change(msg) -> (type name, cdr bytes) | None``: ``msg`` is the decoded SampleBlock, to
    edit in place (None: serialize it as edited), or a replacement of another type or of
    undecodable bytes.
    """
    from pier_monitor.bags.types import SAMPLE_BLOCK, STRING, get_typestore
    from pier_monitor.bags.writer import iter_messages, write_mcap_messages

    typestore = get_typestore()
    by_topic = {}
    for spec in rec.config.sensors:
        by_topic[f"/{rec.config.pier_id}/{spec.topic.lstrip('/')}"] = spec.sensor_id
    conns: list[tuple[str, str, bool]] = []
    where: dict[tuple[str, str], int] = {}
    msgs = []
    counts: dict[str, int] = {}
    for log_ns, topic, cdr in iter_messages(rec, block_s):
        mtype = SAMPLE_BLOCK if topic in by_topic else STRING
        if mtype == SAMPLE_BLOCK:
            sid = by_topic[topic]
            counts[sid] = counts.get(sid, 0) + 1
            change = faults.get((sid, counts[sid]))
            if change is not None:
                msg = typestore.deserialize_cdr(cdr, SAMPLE_BLOCK)
                out = change(msg)
                if out is None:
                    cdr = bytes(typestore.serialize_cdr(msg, SAMPLE_BLOCK))
                else:
                    mtype, cdr = out
        key = (topic, mtype)
        if key not in where:
            where[key] = len(conns)
            conns.append((topic, mtype, mtype == STRING and topic not in by_topic))
        msgs.append((log_ns, where[key], cdr))
    write_mcap_messages(path, conns, msgs)


def stray_string(text: str = "hello"):
    """A ``std_msgs/String`` in place of a block (a stray publisher on the sensor topic)."""
    from pier_monitor.bags.types import STRING, get_typestore

    def change(msg):
        typestore = get_typestore()
        return STRING, bytes(typestore.serialize_cdr(typestore.types[STRING](data=text), STRING))
    return change


def garbled(msg):
    """A block whose bytes are cut in the middle (undecodable)."""
    from pier_monitor.bags.types import SAMPLE_BLOCK, get_typestore

    cdr = bytes(get_typestore().serialize_cdr(msg, SAMPLE_BLOCK))
    return SAMPLE_BLOCK, cdr[:len(cdr) // 3]


def set_fields(**fields):
    """A block with some fields replaced (``stamp_sec`` for ``header.stamp.sec``)."""
    def change(msg):
        for name, value in fields.items():
            if name == "stamp_sec":
                msg.header.stamp.sec = value
            elif name == "stamp_ns":
                msg.header.stamp.sec, msg.header.stamp.nanosec = 0, value
            else:
                setattr(msg, name, value)
    return change
