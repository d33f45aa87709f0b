"""Ingest: raw sensor streams to mainshock windows, against the synthetic ground truth."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import signal

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest import StreamIngest, ingest_recording
from pier_monitor.core.ingest.recording import Recording, SensorRecord
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.model.config import load_config
from pier_monitor.core.synthetic.shaking_table import generate_recording


@pytest.fixture(scope="module")
def synthetic():
    config = load_config(find_config_file("edefense_like.yaml"))
    return generate_recording(config, seed=0)


@pytest.fixture(scope="module")
def ingested(synthetic):
    return ingest_recording(synthetic.recording)


def with_sensor(rec: Recording, sid: str, **changes) -> Recording:
    old = rec.sensors[sid]
    fields = {"sensor_id": sid, "time_ns": old.time_ns, "data": old.data, "rate_hz": old.rate_hz,
              "sample_index": old.sample_index}
    fields.update(changes)
    sensors = dict(rec.sensors)
    sensors[sid] = SensorRecord(**fields)
    return Recording(rec.config, sensors, source="modified")


def truth_on_window(window, run, key):
    """True response at the window's samples, through the same anti-aliasing (200 → 100 Hz)."""
    arr = getattr(run.response, key)
    dec = signal.decimate(arr, 2, ftype="fir", axis=0, zero_phase=True)
    k0 = int(round((window.start_time_ns - run.start_ns) / 1e9 * 100))
    return dec[k0:k0 + window.t.size]


def test_windows_match_the_ground_truth(synthetic, ingested):
    windows, report = ingested
    runs = synthetic.truth.runs
    assert len(windows) == len(runs) == 2
    for w, run in zip(windows, runs):
        assert w.geometry == run.geometry  # run 2: deck mass from the configuration update
        a_true = truth_on_window(w, run, "a")
        rel = lambda e, t: np.sqrt(np.mean(e ** 2, axis=0)) / np.sqrt(np.mean(t ** 2, axis=0))
        assert np.all(rel(w.a - a_true, a_true) < 0.01)
        v_true = truth_on_window(w, run, "v")
        v_err = w.v - v_true
        assert np.all(rel(v_err, v_true) < 0.01)
        assert np.all(np.sqrt(np.mean(v_err ** 2, axis=0)) < 0.5e-3)
        # the wires read the drift left by earlier runs; the ingest zeroes each event's start
        x_true = truth_on_window(w, run, "x")
        x_true = x_true - (x_true[:1] - w.x[:1])
        wire_noise = 1e-4
        assert np.all(np.sqrt(np.mean((w.x - x_true) ** 2, axis=0)) < wire_noise)
        ag_true = truth_on_window(w, run, "ag")
        assert rel(w.ag - ag_true, ag_true) < 0.01
        # at least 95 % of the run's Arias intensity is inside the window
        ag = run.response.ag
        t = np.arange(ag.size) / 200.0
        ws = (w.start_time_ns - run.start_ns) / 1e9
        inside = (t >= ws) & (t < ws + w.duration_s)
        assert np.sum(ag[inside] ** 2) / np.sum(ag ** 2) >= 0.95
        assert w.noise.v.shape == (4,) and np.all(w.noise.v > 0)
    # the velocity meter at the top agrees with the fused velocity
    for checks in report.checks["velocity_meter"].values():
        assert checks["level4"]["rms_difference_mps"] < 0.01 * checks["level4"]["rms_velocity_mps"]


def test_principal_direction_is_estimated_within_one_degree(synthetic):
    config = dataclasses.replace(synthetic.recording.config, principal_direction_deg=None)
    rec = Recording(config, synthetic.recording.sensors)
    windows, report = ingest_recording(rec)
    assert len(windows) == 2
    for w in windows:
        est = w.report["principal_direction_deg"]
        diff = (est - synthetic.truth.principal_direction_deg + 90.0) % 180.0 - 90.0
        assert abs(diff) < 1.0
    assert "principal_direction" in report.codes(windows[0].event_id)


def test_stream_of_blocks_gives_the_same_windows(synthetic, ingested):
    rec = synthetic.recording
    stream = StreamIngest(rec.config)
    for t_ns, config in rec.config_updates:  # on ROS: the latched configuration topic
        stream.update_config(config, t_ns)
    got = []
    n = next(iter(rec.sensors.values())).n_samples
    for b0 in range(0, n, 40):
        for sid, r in rec.sensors.items():
            got += stream.push(sid, r.time_ns[b0:b0 + 40], r.data[b0:b0 + 40],
                               r.sample_index[b0:b0 + 40])
    got += stream.flush()
    assert stream.received == sum(r.n_samples * 1 for r in rec.sensors.values())
    assert stream.counts.gap_samples == stream.counts.duplicate_samples == 0
    assert stream.counts.windows == len(got) == 2
    whole, _ = ingested
    assert [w.event_id for w in got] == [w.event_id for w in whole]
    for a, b in zip(whole, got):
        assert a.start_time_ns == b.start_time_ns
        assert a.geometry == b.geometry and a.design == b.design
        for key in ("ag", "a", "v", "x"):
            np.testing.assert_array_equal(getattr(a, key), getattr(b, key))
        assert a == b  # every field: noise model, coverage, report with its findings
    assert [o.status for o in stream.report.outcomes] == ["ingested", "ingested"]


def _stream(rec, bad):
    stream = StreamIngest(rec.config)
    for t_ns, config in rec.config_updates:
        stream.update_config(config, t_ns)
    got = []
    for b0 in range(0, next(iter(bad.sensors.values())).n_samples + 400, 400):
        for sid, s in bad.sensors.items():
            sel = slice(np.searchsorted(s.time_ns, rec.start_ns + b0 * 5_000_000),
                        np.searchsorted(s.time_ns, rec.start_ns + (b0 + 400) * 5_000_000))
            got += stream.push(sid, s.time_ns[sel], s.data[sel], s.sample_index[sel])
    return got + stream.flush(), stream


def _gap_in_run2(synthetic, rec, sensor_ids):
    """``rec`` with 2 s of ``sensor_ids`` missing in run 2."""
    start = synthetic.truth.runs[1].window_start_ns
    for sid in sensor_ids:
        r = rec.sensors[sid]
        keep = (r.time_ns < start + 5 * 10**9) | (r.time_ns >= start + 7 * 10**9)
        rec = with_sensor(rec, sid, time_ns=r.time_ns[keep], data=r.data[keep],
                          sample_index=r.sample_index[keep])
    return rec


def test_stream_hands_on_a_failed_event_and_keeps_the_others(synthetic, ingested):
    rec = synthetic.recording
    foundation = [s.sensor_id for s in rec.config.sensors_at(0, "acceleration")]
    got, stream = _stream(rec, _gap_in_run2(synthetic, rec, foundation))
    outcomes = stream.report.outcomes
    assert [o.status for o in outcomes] == ["ingested", "failed"]
    assert got == [outcomes[0].window]
    np.testing.assert_array_equal(got[0].x, ingested[0][0].x)
    assert outcomes[1].failure.startswith("level 0: no usable acceleration sensor")
    assert "gap_excluded" in [f.code for f in stream.report.findings]


def test_stream_carries_on_with_a_level_whose_wires_failed(synthetic, ingested):
    rec = synthetic.recording
    got, stream = _stream(rec, _gap_in_run2(synthetic, rec, ["l2_wire_n"]))
    outcomes = stream.report.outcomes
    assert [o.status for o in outcomes] == ["ingested", "ingested"]
    assert got[0] == ingested[0][0]
    # run 2: level 2 keeps one wire, which cannot give both directions: unmeasured there
    assert got[1].coverage.displacement.tolist() == [True, False, True, True]
    np.testing.assert_array_equal(got[1].a, ingested[0][1].a)
    assert "unmeasured_level" in [f.code for f in stream.report.findings]


def test_stream_waits_for_a_lagging_sensor_but_not_for_a_silent_one(synthetic, ingested):
    rec = synthetic.recording
    lag = 2000  # samples: l2_wire_n arrives 10 s behind the others (a slow link)
    n = next(iter(rec.sensors.values())).n_samples

    def feed(stream, stop_at=None):
        got = []
        for b0 in range(0, n + lag, 100):
            for sid, r in rec.sensors.items():
                lo = max(b0 - lag, 0) if sid == "l2_wire_n" else b0
                hi = b0 + 100 - (lag if sid == "l2_wire_n" else 0)
                if sid == "l2_wire_n" and stop_at is not None:
                    hi = min(hi, stop_at)
                if hi > lo:
                    got += stream.push(sid, r.time_ns[lo:hi], r.data[lo:hi],
                                       r.sample_index[lo:hi])
        handed_on = len(stream.report.outcomes)
        return got + stream.flush(), handed_on

    stream = StreamIngest(rec.config)
    for t_ns, config in rec.config_updates:
        stream.update_config(config, t_ns)
    whole, _ = ingested
    assert feed(stream) == (whole, 2)  # every field: the lagging wire was waited for
    # the wire falls silent in run 2: the event goes on without waiting for ever; its level
    # keeps one wire, which cannot give both directions: displacement unmeasured there
    silent = StreamIngest(rec.config, max_lag_s=20.0)
    for t_ns, config in rec.config_updates:
        silent.update_config(config, t_ns)
    stop = int(np.searchsorted(rec.sensors["l2_wire_n"].time_ns,
                               synthetic.truth.runs[1].window_start_ns + 5 * 10**9))
    got, handed_on = feed(silent, stop_at=stop)
    assert got[0] == whole[0] and handed_on == 2  # before the end of the stream
    assert [o.status for o in silent.report.outcomes] == ["ingested", "ingested"]
    assert got[1].coverage.displacement.tolist() == [True, False, True, True]
    assert "unmeasured_level" in [f.code for f in silent.report.findings]


def test_stream_accounts_for_gaps_duplicates_and_samples_without_index(synthetic):
    rec = synthetic.recording
    stream = StreamIngest(rec.config)
    level2 = next(sp for sp in rec.config.sensors if sp.level == 2 and sp.kind == "acceleration")
    r = rec.sensors[level2.sensor_id]
    sid, t, x, idx = level2.sensor_id, r.time_ns, r.data, r.sample_index
    for sl in (slice(0, 10), slice(15, 20), slice(18, 23)):  # 5 samples lost, 2 repeated
        assert stream.push(sid, t[sl], x[sl], idx[sl]) == []
    # no sample index (sensor_msgs/Imu): from the stamps, so a lost sample is a gap of one
    imu = next(sp for sp in rec.config.sensors if sp.level == 3 and sp.kind == "acceleration")
    ri = rec.sensors[imu.sensor_id]
    for i in (0, 1, 2, 4, 5):
        stream.push(imu.sensor_id, ri.time_ns[i:i + 1], ri.data[i:i + 1])
    stream.push("not_in_the_map", t[:3], x[:3], idx[:3])
    c = stream.counts
    assert (c.blocks, c.samples, c.gap_samples, c.duplicate_samples) == (8, 25, 6, 2)
    assert "unmapped_sensor" in stream.report.codes("not_in_the_map")
    assert stream.latest_time_ns == int(t[22])


def test_stream_keeps_the_configuration_history(synthetic):
    rec = synthetic.recording
    (t_update, updated), *_ = rec.config_updates
    stream = StreamIngest(rec.config)
    sp = rec.config.sensors[-1]
    r = rec.sensors[sp.sensor_id]
    stream.push(sp.sensor_id, r.time_ns[:5], r.data[:5], r.sample_index[:5])
    at = stream.update_config(updated)  # arrives live: holds from just after the latest sample
    assert at == int(r.time_ns[4]) + 1
    assert stream.config_at(int(r.time_ns[4])) is rec.config
    assert stream.config_at(at) is updated
    assert stream.config_at(at + 10 ** 12) is updated
    bad = dataclasses.replace(updated, pier_id="another_pier")
    with pytest.raises(InputDataError, match="changes the pier"):
        stream.update_config(bad)


def test_no_event_is_a_normal_result(synthetic):
    rec = synthetic.recording
    quiet_end = rec.start_ns + int(15e9)  # the first 15 s hold only ambient motion
    sensors = {}
    for sid, r in rec.sensors.items():
        keep = r.time_ns < quiet_end
        sensors[sid] = SensorRecord(sid, r.time_ns[keep], r.data[keep], r.rate_hz,
                                    r.sample_index[keep])
    windows, report = ingest_recording(Recording(rec.config, sensors))
    assert windows == []
    assert "no_event" in report.codes()


def test_nan_samples_and_short_gaps_are_interpolated_and_reported(synthetic, ingested):
    rec = synthetic.recording
    sid = "l2_acc_n"
    data = np.array(rec.sensors[sid].data)
    data[6000:6004, 0] = np.nan  # 20 ms
    data[6100, 1] = np.inf
    windows, report = ingest_recording(with_sensor(rec, sid, data=data))
    assert "non_finite" in report.codes(sid)
    assert report.codes(sid).count("gap_interpolated") == 2
    assert len(windows) == 2
    # one of eight channels bridged over 20 ms: the level average moves by a few mm/s² there
    np.testing.assert_allclose(windows[0].a, ingested[0][0].a, atol=1e-2)


def test_long_gap_excludes_the_sensor_and_says_when(synthetic):
    rec = synthetic.recording
    sid = "l2_acc_n"
    r = rec.sensors[sid]
    keep = np.ones(r.n_samples, dtype=bool)
    keep[6000:6400] = False  # 2 s dropout inside run 1
    windows, report = ingest_recording(with_sensor(rec, sid, time_ns=r.time_ns[keep],
                                                   data=r.data[keep],
                                                   sample_index=r.sample_index[keep]))
    msgs = [f.message for f in report.findings if f.code == "gap_excluded" and f.where == sid]
    assert msgs and "400 missing samples (2.00 s)" in msgs[0]
    assert windows[0].report["channels"]["acceleration.2"] == 6  # 8 channels less its 2
    assert windows[1].report["channels"]["acceleration.2"] == 8  # run 2 is after the gap
    assert len(windows) == 2


def test_duplicates_out_of_order_and_timestamp_jumps_are_repaired(synthetic, ingested):
    rec = synthetic.recording
    sid = "l1_acc_n"
    r = rec.sensors[sid]
    order = np.arange(r.n_samples)
    order[7000], order[7001] = 7001, 7000  # swapped
    order = np.concatenate([order[:8000], [7999, 7999], order[8000:]])  # duplicated
    t = np.array(r.time_ns[order])
    t[9000:9010] += 3_000_000  # the clock jumped by 3 ms for ten samples
    modified = with_sensor(rec, sid, time_ns=t, data=r.data[order],
                           sample_index=r.sample_index[order])
    windows, report = ingest_recording(modified)
    codes = report.codes(sid)
    assert {"out_of_order", "duplicate", "timestamp_jump"} <= set(codes)
    for a, b in zip(windows, ingested[0]):
        np.testing.assert_array_equal(a.a, b.a)


def test_dead_and_saturated_channels_are_excluded(synthetic):
    rec = synthetic.recording
    dead = np.array(rec.sensors["l3_acc_n"].data)
    dead[:, 0] = 12.5
    sat = np.array(rec.sensors["l3_acc_s"].data)
    cap = 0.3 * np.abs(sat[:, 1]).max()
    sat[:, 1] = np.clip(sat[:, 1], -cap, cap)
    modified = with_sensor(with_sensor(rec, "l3_acc_n", data=dead), "l3_acc_s", data=sat)
    windows, report = ingest_recording(modified)
    assert "dead" in report.codes("l3_acc_n.x")
    assert "saturated" in report.codes("l3_acc_s.y")
    assert len(windows) == 2


def test_accelerometer_in_the_wrong_unit_is_caught(synthetic):
    rec = synthetic.recording
    spec = rec.config.sensor("l1_acc_s")
    assert spec.unit in ("gal", "m/s^2")
    wrong = "m/s^2" if spec.unit == "gal" else "g"
    sensors = tuple(dataclasses.replace(s, unit=wrong) if s.sensor_id == "l1_acc_s" else s
                    for s in rec.config.sensors)
    config = dataclasses.replace(rec.config, sensors=sensors)
    windows, report = ingest_recording(Recording(config, rec.sensors))
    assert "implausible_units" in report.codes("l1_acc_s")
    assert len(windows) == 2


def test_missing_and_unmapped_sensors_are_reported(synthetic):
    rec = synthetic.recording
    sensors = {k: v for k, v in rec.sensors.items() if k != "l4_acc_ne"}
    windows, report = ingest_recording(Recording(rec.config, sensors,
                                                 unmapped_topics=("/edefense_pier/sensors/x",)))
    assert "missing_sensor" in report.codes("l4_acc_ne")
    assert "unmapped_topic" in report.codes("/edefense_pier/sensors/x")
    assert len(windows) == 2


def test_level_without_displacement_sensor_is_reported_unmeasured(synthetic):
    rec = synthetic.recording
    sensors = {k: v for k, v in rec.sensors.items()
               if not (rec.config.sensor(k).level == 2 and rec.config.sensor(k).kind == "displacement")}
    windows, report = ingest_recording(Recording(rec.config, sensors))
    assert len(windows) == 2
    assert "unmeasured_level" in report.codes("level 2")
    for w in windows:
        assert w.coverage.acceleration.all()
        assert w.coverage.displacement.tolist() == [True, False, True, True]
        assert w.coverage.highpass_hz > 0 and np.isnan(w.noise.x[1])
        assert np.isfinite(w.x).all()  # level 2: integrated from its acceleration


def test_nothing_measured_above_the_foundation_fails_the_events_naming_it(synthetic):
    rec = synthetic.recording
    sensors = {k: v for k, v in rec.sensors.items() if rec.config.sensor(k).level == 0}
    windows, report = ingest_recording(Recording(rec.config, sensors))
    assert windows == []
    assert [o.status for o in report.outcomes] == ["failed", "failed"]
    for o in report.outcomes:
        assert "no usable acceleration or displacement sensor at any level above the " \
               "foundation" in o.failure


def test_rate_contradicting_the_configuration_is_reported(synthetic):
    rec = synthetic.recording
    modified = with_sensor(rec, "l1_acc_n", rate_hz=100.0)
    windows, report = ingest_recording(modified)
    assert "rate_mismatch" in report.codes("l1_acc_n")
    assert len(windows) == 2


def test_field_layouts_give_windows_with_their_coverage_and_gnss_at_its_own_rate():
    """Accelerometers only (plus a 10 Hz GNSS at the top): every level's acceleration, the top's
    displacement from the GNSS fused with its acceleration; the stream gives the same window."""
    from pier_monitor.core.synthetic.field import field_case_recording

    rec = field_case_recording("edefense", "accel", True, "strong", 0).recording
    windows, report = ingest_recording(rec)
    assert [o.status for o in report.outcomes] == ["ingested"]
    (w,) = windows
    assert w.coverage.acceleration.all()
    assert w.coverage.displacement.tolist() == [False, False, False, True]
    assert 0 < w.noise.x[3] < 0.005  # fused: better than the GNSS's 5 mm alone
    assert "rate_mismatch" not in report.codes()
    stream = StreamIngest(rec.config)
    got = []
    for b0 in range(0, max(s.n_samples for s in rec.sensors.values()) + 400, 400):
        for sid, s in rec.sensors.items():
            sel = slice(np.searchsorted(s.time_ns, rec.start_ns + b0 * 5_000_000),
                        np.searchsorted(s.time_ns, rec.start_ns + (b0 + 400) * 5_000_000))
            got += stream.push(sid, s.time_ns[sel], s.data[sel], s.sample_index[sel])
    got += stream.flush()
    assert got == windows
