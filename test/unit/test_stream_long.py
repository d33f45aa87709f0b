"""Live = offline for long shaking: a stream of small blocks gives ingest_recording's windows,
sample for sample, and a recording that ends during the shaking gives the same partial
window (or the same cut) both ways."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.core.ingest import StreamIngest, ingest_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord, sample_times_ns
from pier_monitor.core.model.config import PierConfig, load_config
from pier_monitor.core.model.ground_motion import (GroundMotion, el_centro_1940,
                                                   synthetic_near_fault)
from pier_monitor.core.model.solver import simulate
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.measurement import record_sensor
from pier_monitor.core.synthetic.shaking_table import (DEFAULT_START_NS, RunSpec, Scenario,
                                                       generate_recording)


def recording_from_motion(config: PierConfig, gm: GroundMotion, *, lead_s: float = 20.0,
                          tail_s: float = 20.0, seed: int = 0) -> tuple[Recording, int]:
    """The pier (its design values) under ``gm`` in its principal direction, recorded by every
    sensor of its map; returns the recording and the time of the peak ground acceleration
    (ns since the Unix epoch)."""
    rate = config.sample_rate_hz
    dt = 1.0 / rate
    t_src = np.arange(gm.acc.size) * gm.dt
    rec = np.interp(np.arange(int(t_src[-1] * rate) + 1) * dt, t_src, gm.acc)
    n_lead, n_tail = int(lead_s * rate), int(tail_s * rate)
    ag = np.concatenate([np.zeros(n_lead), rec, np.zeros(n_tail)])
    resp = simulate(config.geometry, config.design, ag, dt, dt=0.001, output_dt=dt)
    ag_vel = np.concatenate([[0.0], np.cumsum(0.5 * (ag[1:] + ag[:-1]) * dt)])
    phi = np.radians(config.principal_direction_deg)
    e_p = np.array([np.cos(phi), np.sin(phi), 0.0])
    rng = np.random.default_rng(seed)
    sensors = {}
    for spec in config.sensors:
        lv = spec.level
        if spec.kind == "acceleration":
            p = ag + (resp.a[:, lv - 1] if lv else 0.0)
        elif spec.kind == "velocity":
            p = ag_vel + (resp.v[:, lv - 1] if lv else 0.0)
        else:
            p = resp.x[:, lv - 1]
        data = record_sensor(spec, p[:, None] * e_p, rng)
        sensors[spec.sensor_id] = SensorRecord(
            spec.sensor_id, sample_times_ns(DEFAULT_START_NS, ag.size, rate), data, rate)
    peak_ns = DEFAULT_START_NS + int(round(int(np.argmax(np.abs(ag))) * NS_PER_S / rate))
    return Recording(config, sensors, source=gm.name), peak_ns


@pytest.fixture(scope="module")
def config():
    return load_config(find_config_file("edefense_like.yaml"))


@pytest.fixture(scope="module")
def records(config):
    """Long-shaking recordings by name: a shaking-table test with a 30 s strong motion, El
    Centro 1940 NS, and a long-duration pulse-free record (40 s of strong motion)."""
    table = generate_recording(config, Scenario(
        runs=(RunSpec("long", pga_mps2=3.5, duration_s=60.0, strong_duration_s=30.0,
                      motion_seed=1994),), lead_s=20.0, tail_s=20.0), seed=0).recording
    el_centro, _ = recording_from_motion(config, el_centro_1940(), lead_s=15.0)
    long, _ = long_duration(config)
    return {"table_30s": table, "el_centro": el_centro, "long_duration": long}


def long_duration(config: PierConfig) -> tuple[Recording, int]:
    """A pulse-free record with 40 s of stationary strong motion, and its peak time."""
    gm = synthetic_near_fault(duration_s=80.0, strong_start_s=15.0, strong_duration_s=40.0,
                              pulse_share=0.0, dominant_hz=1.0, seed=1, pga_mps2=4.0)
    return recording_from_motion(config, gm, lead_s=15.0)


@pytest.fixture(scope="module")
def offline(records):
    return {name: ingest_recording(rec) for name, rec in records.items()}


def stream_blocks(rec: Recording, block_s: float, **kwargs) -> tuple[list, StreamIngest]:
    """Feed ``rec`` to a :class:`StreamIngest` in blocks of ``block_s`` (every sensor in turn,
    as topics arrive); the windows it returns while fed, then at the end of the stream."""
    stream = StreamIngest(rec.config, **kwargs)
    for t_ns, cfg in rec.config_updates:
        stream.update_config(cfg, t_ns)
    start, end = rec.start_ns, rec.end_ns
    step = int(round(block_s * NS_PER_S))
    live = []
    for b0 in range(start, end + step, step):
        for sid, s in rec.sensors.items():
            sel = slice(np.searchsorted(s.time_ns, b0), np.searchsorted(s.time_ns, b0 + step))
            if sel.stop > sel.start:
                live += stream.push(sid, s.time_ns[sel], s.data[sel], s.sample_index[sel])
    return live, stream


def assert_same_windows(got, want) -> None:
    assert [w.event_id for w in got] == [w.event_id for w in want]
    for a, b in zip(got, want):
        assert a.start_time_ns == b.start_time_ns
        for key in ("t", "ag", "a", "v", "x"):
            assert np.array_equal(getattr(a, key), getattr(b, key), equal_nan=True), key
        assert a == b  # every field: noise model, coverage, report with its findings


def check_stream_equals_offline(rec, offline_result, block_s, **kwargs) -> StreamIngest:
    want, report = offline_result
    assert [o.status for o in report.outcomes] == ["ingested"]
    live, stream = stream_blocks(rec, block_s, **kwargs)
    # handed on while the data still arrive (the record's tail is longer than the event's
    # quiet and context): never cut, never held until the end
    assert [o.status for o in stream.report.outcomes] == ["ingested"]
    assert stream.flush() == []
    assert_same_windows(live, want)
    assert "event_cut" not in stream.report.codes()
    return stream


@pytest.mark.parametrize("name, block_s", [("table_30s", 0.05), ("el_centro", 0.1),
                                           ("long_duration", 0.5), ("table_30s", 2.0)])
def test_stream_of_small_blocks_equals_offline_for_long_shaking(records, offline, name,
                                                                 block_s):
    check_stream_equals_offline(records[name], offline[name], block_s)


@pytest.mark.slow
@pytest.mark.parametrize("block_s", [0.05, 0.1, 0.25, 0.5, 1.0, 2.0])
@pytest.mark.parametrize("name", ["table_30s", "el_centro", "long_duration"])
def test_stream_equals_offline_for_every_record_and_block_size(records, offline, name,
                                                               block_s):
    check_stream_equals_offline(records[name], offline[name], block_s)


def test_a_slow_poll_and_a_short_buffer_still_give_the_offline_windows(config):
    """poll_s of 8 s, and a buffer that has dropped the first event's data by the time the
    second ends (the windows' ``t`` still count from the stream's first sample)."""
    rec = generate_recording(config, seed=0).recording  # two runs, a deck-mass update
    want, report = ingest_recording(rec)
    live, stream = stream_blocks(rec, 0.5, poll_s=8.0, buffer_s=60.0)
    assert [o.status for o in stream.report.outcomes] == ["ingested", "ingested"]
    assert stream.flush() == []
    assert_same_windows(live, want)
    buffered = stream._buf["l0_acc_ne"].arrays()[0]
    assert buffered[0] > want[1].start_time_ns - 60 * NS_PER_S > rec.start_ns


def test_shaking_longer_than_the_buffer_is_finalised_on_what_it_holds(records):
    rec = records["long_duration"]
    live, stream = stream_blocks(rec, 1.0, buffer_s=40.0)
    first = stream.report.outcomes[0]
    assert first.status in ("partial", "cut")
    assert "buffer_full" in stream.report.codes(first.event_id)
    assert "buffer_full" in [f.code for f in first.findings]
    if first.window is not None:
        assert live[0] is first.window
        assert "buffer_full" in [f.code for f in first.window.findings]


def truncated(rec: Recording, end_ns: int) -> Recording:
    """``rec`` with every sample at or after ``end_ns`` lost (a station that lost power)."""
    sensors = {}
    for sid, s in rec.sensors.items():
        keep = s.time_ns < end_ns
        sensors[sid] = SensorRecord(sid, s.time_ns[keep], s.data[keep], s.rate_hz,
                                    s.sample_index[keep])
    return Recording(rec.config, sensors, source="truncated")


@pytest.fixture(scope="module")
def kobe_type(config):
    """A Kobe-type near-fault record (8 s of strong motion with its pulse, then a decay)."""
    gm = synthetic_near_fault(duration_s=50.0, strong_start_s=10.0, pga_mps2=4.0)
    return recording_from_motion(config, gm, lead_s=10.0)


def test_data_ending_10_s_after_the_peak_give_the_same_partial_window_both_ways(kobe_type):
    rec, peak_ns = kobe_type
    rec = truncated(rec, peak_ns + 10 * NS_PER_S)
    windows, report = ingest_recording(rec)
    (outcome,) = report.outcomes
    assert outcome.status == "partial" and outcome.window is windows[0]
    assert outcome.partial.startswith("the data end at")
    assert "10.0 s before the end of the data" in outcome.partial
    assert windows[0].report["partial"] == {"reason": outcome.partial}
    assert outcome.as_dict()["partial"] == {"reason": outcome.partial}
    assert "event_partial" in report.codes(outcome.event_id)
    # the window holds the peak and the 99 % of the recorded shaking's Arias intensity
    # (padded by 2 s): it ends 7.7 s after the peak, 2.3 s before the data
    w = windows[0]
    assert w.start_time_ns < peak_ns - 5 * NS_PER_S
    assert w.start_time_ns + w.duration_s * NS_PER_S > peak_ns + 7 * NS_PER_S
    live, stream = stream_blocks(rec, 0.1)
    assert live == []  # nothing is decided while the data may go on
    final = stream.flush()
    assert [o.status for o in stream.report.outcomes] == ["partial"]
    assert stream.report.outcomes[0].partial == outcome.partial
    assert_same_windows(final, windows)


@pytest.mark.parametrize("after_peak_s", [-1.0, 2.0])
def test_data_ending_before_or_just_after_the_peak_cut_the_event_both_ways(kobe_type,
                                                                           after_peak_s):
    rec, peak_ns = kobe_type
    short = truncated(rec, peak_ns + int(after_peak_s * NS_PER_S))
    windows, report = ingest_recording(short)
    assert windows == [] and [o.status for o in report.outcomes] == ["cut"]
    assert "is cut" in report.outcomes[0].failure
    assert "less than the 5 s a partial window needs" in report.outcomes[0].failure
    live, stream = stream_blocks(short, 0.25)
    assert live + stream.flush() == []
    assert [o.failure for o in stream.report.outcomes] == [report.outcomes[0].failure]


def test_data_ending_in_a_plateau_of_strong_shaking_cut_the_event(config):
    """The largest sample so far lies long before the end, but the shaking has not decayed:
    the peak may be still to come (here it is, 5 s later)."""
    rec, peak_ns = long_duration(config)
    windows, report = ingest_recording(truncated(rec, peak_ns - 5 * NS_PER_S))
    assert windows == [] and [o.status for o in report.outcomes] == ["cut"]
    assert "more than the 50% that shows the strong motion over" in report.outcomes[0].failure
