"""The fault corpus: one fault at a time, in every layout, from a sensor to the command line.

The two-run shaking-table recording of :func:`fault_injection.short_recording` (run 2 yields
sections 1-2) is recorded by the full network, by accelerometers only (``accel``) and by the
foundation, mid-height and top accelerometers (``sparse``).  Each case injects one fault and
asserts its class:

* **repaired** / **excluded**: the finding (code, sensor, action) is there, both events are
  ingested, the windows' accelerations stay within :data:`TOLERANCE` of the clean ones, and
  no other sensor is excluded;
* **failed**: the event that cannot be ingested says why, the other keeps its window;
* **error**: a project error whose message names the fault (never a traceback).

Most cases run at the ingest level (``ingest_recording`` or ``read_bag``, no training);
sample-block and file faults go through a bag of 1 s blocks; a few run end to end through
``pier-monitor identify --method field``.  A slow offset step or drift of an accelerometer
is found against the level's other accelerometers, and a wire's drift while the level is at
rest; both are excluded.  An accelerometer without partners at its level is left to the
self-check against the identified model: the event's result is unreliable, naming the level.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import re
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from fault_injection import (Timeline, at_sample, block_fault_bag, clock_jump, config_rate,
                             drop, duplicated, edit, frozen_from, garbled, idx, in_layout,
                             offset_jump, reordered, replace_sensor, scaled, set_fields,
                             short_recording, stray_string, timestamps_at, without)

from pier_monitor.bags import read_bag, write_bag
from pier_monitor.cli import EXIT_ERROR, EXIT_FAILED, EXIT_UNRELIABLE, main
from pier_monitor.core.errors import PierMonitorError
from pier_monitor.core.identify.damage import classify_ductility, failed_event_result
from pier_monitor.core.ingest import ingest_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording
from pier_monitor.core.model.units import G_STANDARD
from pier_monitor.pipeline import identify_bag

pytestmark = pytest.mark.timeout(600)

#: Largest relative RMS change of any level's acceleration against the clean window.
TOLERANCE = 0.03
LAYOUTS = ("full", "accel", "sparse")
#: Findings that never count as losing a sensor (levels without wires, in every layout).
_LEVEL_CODES = {"unmeasured_level"}


@pytest.fixture(scope="module")
def source() -> tuple[Recording, Timeline]:
    synthetic, timeline = short_recording(seed=0)
    return synthetic.recording, timeline


@pytest.fixture(scope="module")
def clean(source):
    """The clean windows of each layout, computed once per layout when first asked."""
    rec, _ = source
    cache: dict[str, list] = {}

    def get(layout: str):
        if layout not in cache:
            windows, report = ingest_recording(in_layout(rec, layout))
            assert [o.status for o in report.outcomes] == ["ingested", "ingested"]
            cache[layout] = windows
        return cache[layout]
    return get


def rel_rms_a(got, want) -> float:
    """Largest relative RMS difference of the measured levels' accelerations (the levels a
    layout does not measure are NaN, reconstructed by the identifier)."""
    keep = np.isfinite(want.a).all(axis=0)
    assert np.isfinite(got.a[:, keep]).all()
    d, w = got.a[:, keep] - want.a[:, keep], want.a[:, keep]
    return float(np.max(np.sqrt(np.mean(d ** 2, axis=0)) / np.sqrt(np.mean(w ** 2, axis=0))))


def _check_outcome(report, clean_windows, *, code, where, action, failed=(), match="",
                   others_kept=True, tolerance=TOLERANCE):
    """The shared assertions of a case that ingests (see the module doc)."""
    codes = (code,) if isinstance(code, str) else code
    found = [f for f in report.findings if f.code in codes and where in (f.where, f.sensor_id)]
    assert found, f"no {codes} finding for {where}: {report.findings}"
    assert all(f.action == action for f in found), found
    assert len(report.outcomes) == 2, "an event was lost"
    for run, (outcome, want) in enumerate(zip(report.outcomes, clean_windows), start=1):
        assert outcome.event_id == want.event_id
        if run in failed:
            assert outcome.window is None and re.search(match, outcome.failure), outcome.failure
            continue
        assert outcome.status == "ingested", outcome.failure
        assert rel_rms_a(outcome.window, want) < tolerance
    if others_kept:  # no other sensor excluded during an event
        sensor = where.split(".")[0]
        lost = {f"{f.where}: {f.code}" for f in report.findings if f.action == "excluded"
                and f.code not in _LEVEL_CODES and f.sensor_id != sensor
                and any(f.overlaps(o.start_ns, o.end_ns) for o in report.outcomes)}
        assert not lost, f"other sensors excluded: {lost}"


# -- sensor faults, in every layout ---------------------------------------------------------

def restart_index(sid: str, run: int, share: float):
    """The logger restarts: the sample index falls back to 0 mid-stream."""
    def make(rec, tl):
        r = rec.sensors[sid]
        i = idx(tl.at(run, share))
        index = np.array(r.sample_index)
        index[i:] -= index[i]
        return replace_sensor(rec, sid, sample_index=index)
    return make


def in_g(sid: str):
    """Recorded in g, declared m/s² (the z axis reads 1.0 at rest)."""
    return edit(sid, lambda d, o, tl: d.__setitem__(slice(None), d / G_STANDARD))


def acc_step(sid: str, run: int, share: float, step: float):
    """An offset step of one accelerometer channel from a point of a run, m/s²."""
    def change(d, o, tl):
        d[idx(tl.at(run, share)):, 0] += step
    return edit(sid, change)


def acc_drift(sid: str, run: int, rate: float):
    """A slow bias of one accelerometer channel growing from a run's start, m/s² per s."""
    def change(d, o, tl):
        i = idx(tl.windows[run - 1][0])
        d[i:, 0] += rate * np.arange(d.shape[0] - i) / 200.0
    return edit(sid, change)


def fast_clock(sid: str, factor: float):
    """The sensor's clock runs ``factor`` fast: its timestamps advance too slowly."""
    def make(rec, tl):
        r = rec.sensors[sid]
        t = r.time_ns[0] + np.rint((r.time_ns - r.time_ns[0]) / factor).astype(np.int64)
        return replace_sensor(rec, sid, time_ns=t)
    return make


def wire_drift(sid: str, mm_per_min: float):
    """A wire that drifts slowly from the recording's start, mm per minute."""
    def change(d, o, tl):
        d[:, 0] += mm_per_min * np.arange(d.shape[0]) / (60.0 * 200.0)
    return edit(sid, change)


@dataclass(frozen=True)
class SensorFault:
    """``make`` on the recording in a layout; the finding that must be there."""

    name: str
    make: Callable
    code: str | tuple[str, ...]
    where: str
    action: str
    failed: tuple[int, ...] = ()
    match: str = ""
    layouts: tuple[str, ...] = LAYOUTS


# the top level keeps six accelerometers and the foundation four in every layout
SENSOR_FAULTS = [
    SensorFault("acc_spike", at_sample("l4_acc_nw", 2, 0.5, 0, 5.0), "glitch", "l4_acc_nw.x",
                "repaired"),
    SensorFault("acc_1e30", at_sample("l4_acc_se", 1, 0.45, 0, 1e30, add=False),
                "out_of_range", "l4_acc_se.x", "repaired"),
    SensorFault("acc_nan_burst", edit("l4_acc_nw", lambda d, o, tl: d.__setitem__(
        slice(idx(tl.at(2, 0.6)), idx(tl.at(2, 0.6)) + 8), np.nan)), "gap_interpolated",
        "l4_acc_nw", "repaired"),
    SensorFault("acc_frozen_mid_run2", frozen_from("l4_acc_n", 2, 0.2), "frozen", "l4_acc_n.x",
                "excluded"),
    SensorFault("acc_dead", edit("l4_acc_w", lambda d, o, tl: d.__setitem__(slice(None), o)),
                "dead", "l4_acc_w.x", "excluded"),
    SensorFault("acc_gap_2s", drop("l4_acc_ne", 1, 0.5, 2.0), "gap_excluded", "l4_acc_ne",
                "excluded"),
    SensorFault("acc_in_g_declared_mps2", in_g("l4_acc_nw"), "implausible_units", "l4_acc_nw",
                "excluded"),
    SensorFault("foundation_acc_in_g", in_g("l0_acc_nw"), "implausible_units", "l0_acc_nw",
                "excluded"),
    SensorFault("index_restart", restart_index("l4_acc_se", 1, 0.5), "index_restart",
                "l4_acc_se", "repaired"),
    SensorFault("duplicated_samples", duplicated("l4_acc_ne"), "duplicate", "l4_acc_ne",
                "repaired"),
    SensorFault("samples_out_of_order", reordered("l4_acc_nw"), "out_of_order", "l4_acc_nw",
                "repaired"),
    SensorFault("clock_jump_3ms", clock_jump("l4_acc_sw"), "timestamp_jump", "l4_acc_sw",
                "repaired"),
    SensorFault("declared_100hz", lambda rec, tl: replace_sensor(rec, "l4_acc_sw",
                                                                 rate_hz=100.0),
                "rate_mismatch", "l4_acc_sw", "excluded"),
    SensorFault("timestamps_at_100hz", timestamps_at("l4_acc_n", 100.0), "rate_mismatch",
                "l4_acc_n", "excluded"),
    SensorFault("missing_accelerometer", without("l4_acc_ne"), "missing_sensor", "l4_acc_ne",
                "excluded"),
    SensorFault("missing_foundation_accelerometer", without("l0_acc_se"), "missing_sensor",
                "l0_acc_se", "excluded"),
    SensorFault("clock_0.5pct_fast", fast_clock("l4_acc_nw", 1.005), "inconsistent",
                "l4_acc_nw", "excluded"),
    SensorFault("acc_gain_x1.5", scaled("l4_acc_nw", 1.5), "inconsistent", "l4_acc_nw",
                "excluded"),
    SensorFault("acc_offset_step_0.5", acc_step("l4_acc_nw", 2, 0.5, 0.5), "offset_step",
                "l4_acc_nw.x", "excluded"),
    SensorFault("acc_drift", acc_drift("l4_acc_se", 2, 0.02), "drift", "l4_acc_se.x",
                "excluded"),
    # wires: the full network only
    SensorFault("wire_spike", at_sample("l3_wire_n", 2, 0.5, 0, 500.0), "glitch", "l3_wire_n",
                "repaired", layouts=("full",)),
    SensorFault("wire_offset_jump", offset_jump("l2_wire_n", 2, 0.4, 20.0), "offset_jump",
                "l2_wire_n", "repaired", layouts=("full",)),
    SensorFault("wire_index_restart", restart_index("l1_wire_w", 2, 0.3), "index_restart",
                "l1_wire_w", "repaired", layouts=("full",)),
    SensorFault("wire_drift_50mm_per_min", wire_drift("l3_wire_w", 50.0), "drift",
                "l3_wire_w.x", "excluded", layouts=("full",)),
    SensorFault("velocity_meter_frozen", frozen_from("l0_vel", 1, 0.5), "frozen", "l0_vel.x",
                "excluded", layouts=("full",)),
]

SENSOR_CASES = [pytest.param(f, layout, id=f"{f.name}-{layout}")
                for f in SENSOR_FAULTS for layout in f.layouts]


@pytest.mark.parametrize("fault, layout", SENSOR_CASES)
def test_sensor_fault(source, clean, fault, layout):
    rec, timeline = source
    bad = in_layout(fault.make(rec, timeline), layout)
    windows, report = ingest_recording(bad)
    _check_outcome(report, clean(layout), code=fault.code, where=fault.where,
                   action=fault.action, failed=fault.failed, match=fault.match)
    assert windows == [o.window for o in report.outcomes if o.window is not None]


def test_an_index_restart_keeps_every_sample_as_it_was(source, clean):
    rec, timeline = source
    windows, report = ingest_recording(restart_index("l4_acc_se", 1, 0.5)(rec, timeline))
    assert not any(f.code == "duplicate" for f in report.findings)
    for got, want in zip(windows, clean("full"), strict=True):
        np.testing.assert_array_equal(got.a, want.a)


def test_a_sensor_in_g_is_named_a_units_problem_with_the_unit_it_looks_recorded_in(source):
    rec, timeline = source
    _, report = ingest_recording(in_layout(in_g("l0_acc_nw")(rec, timeline), "sparse"))
    (f,) = [f for f in report.findings if f.sensor_id == "l0_acc_nw"]
    assert f.code == "implausible_units" and f.message.startswith("units: z reads 1.0")
    assert "looks recorded in 'g'" in f.message and "inconsistent" not in f.message


# -- sample-block faults: a bag of 1 s blocks, the sparse network -----------------------------

BLOCK_SID, BLOCK_NO = "l2_acc_n", 30  # block 30 of the mid-height sensor: inside run 1

BLOCK_FAULTS = {
    "stamp_0": (set_fields(stamp_sec=0), "header.stamp/first_sample_index"),
    "stamp_minus_2e31": (set_fields(stamp_sec=-2 ** 31), "header.stamp/first_sample_index"),
    "stamp_10_years_ahead": (set_fields(stamp_sec=2_000_000_000),
                             "header.stamp/first_sample_index"),
    "index_2e63": (set_fields(first_sample_index=2 ** 63), "first_sample_index"),
    "index_2e64_minus_1": (set_fields(first_sample_index=2 ** 64 - 1), "first_sample_index"),
    "index_jump_1e12": (set_fields(first_sample_index=10 ** 12),
                        "header.stamp/first_sample_index"),
    "kind_displacement": (set_fields(kind=1), "kind"),
    "kind_unknown": (set_fields(kind=7), "kind"),
    "unit_g": (set_fields(unit="g"), "unit"),
    "axes_x_only": (set_fields(axes=["x"]), "axes"),
    "sensor_id_other": (set_fields(sensor_id="l2_acc_s"), "sensor_id"),
    "value_count": (lambda m: setattr(m, "data", m.data[:-1]), "data"),
    "rate_nan": (set_fields(sample_rate_hz=float("nan")), "sample_rate_hz"),
    "rate_0": (set_fields(sample_rate_hz=0.0), "sample_rate_hz"),
    "rate_100": (set_fields(sample_rate_hz=100.0), "sample_rate_hz"),
    "undecodable": (garbled, "message"),
}


@pytest.fixture(scope="module")
def block_bags(source, tmp_path_factory):
    """The sparse recording, and its clean bag of 1 s blocks read back with its windows."""
    rec, _ = source
    sparse = in_layout(rec, "sparse")
    tmp = tmp_path_factory.mktemp("blocks")
    block_fault_bag(sparse, tmp / "clean.mcap", {})
    recording = read_bag(tmp / "clean.mcap")
    windows, _ = ingest_recording(recording)
    return sparse, recording, windows, tmp


def _block_span(number: int) -> slice:
    """The samples of block ``number`` (1-based) of a sensor: 1 s blocks at 200 Hz."""
    return slice((number - 1) * 200, number * 200)


def _assert_only_the_block_lost(got: Recording, want: Recording, sids: dict[str, list[int]]):
    """Every sensor as in the clean bag, less the samples of the dropped blocks."""
    assert list(got.sensors) == list(want.sensors), "a sensor was lost"
    for sid, w in want.sensors.items():
        g = got.sensors[sid]
        keep = np.ones(w.n_samples, dtype=bool)
        for number in sids.get(sid, []):
            keep[_block_span(number)] = False
        np.testing.assert_array_equal(g.time_ns, w.time_ns[keep])
        np.testing.assert_array_equal(g.data, w.data[keep])


@pytest.mark.parametrize("name", list(BLOCK_FAULTS))
def test_a_malformed_block_is_dropped_and_named(block_bags, tmp_path, name):
    sparse, clean_rec, clean_windows, _ = block_bags
    change, field = BLOCK_FAULTS[name]
    bag = tmp_path / f"{name}.mcap"
    block_fault_bag(sparse, bag, {(BLOCK_SID, BLOCK_NO): change})
    recording = read_bag(bag)
    _assert_only_the_block_lost(recording, clean_rec, {BLOCK_SID: [BLOCK_NO]})
    (f,) = recording.findings
    assert f.code == "bad_block" and f.where == BLOCK_SID and f.action == "excluded"
    assert f"acc_n: block {BLOCK_NO} (logged at 2024-" in f.message
    assert f"): {field}: " in f.message and "block dropped" in f.message
    _, report = ingest_recording(recording)
    _check_outcome(report, clean_windows, code="bad_block", where=BLOCK_SID,
                   action="excluded", others_kept=True)


def test_a_stray_string_on_a_sensor_topic_is_ignored_and_named(block_bags, tmp_path):
    sparse, clean_rec, clean_windows, _ = block_bags
    bag = tmp_path / "stray.mcap"
    block_fault_bag(sparse, bag, {(BLOCK_SID, BLOCK_NO): stray_string()})
    recording = read_bag(bag)
    _assert_only_the_block_lost(recording, clean_rec, {BLOCK_SID: [BLOCK_NO]})
    (f,) = recording.findings
    assert f.code == "wrong_message_type" and f.where == BLOCK_SID
    assert "messages of type 'std_msgs/msg/String' on /edefense_pier/sensors/level2/acc_n" \
        in f.message
    _, report = ingest_recording(recording)
    assert [o.status for o in report.outcomes] == ["ingested", "ingested"]


def test_many_bad_blocks_are_summed_up_and_the_rest_kept(block_bags, tmp_path):
    sparse, clean_rec, _, _ = block_bags
    bad = {("l0_acc_nw", k): set_fields(unit="gal") for k in range(5, 20)}
    bad[("l4_acc_ne", 60)] = set_fields(stamp_sec=0)
    bag = tmp_path / "many.mcap"
    block_fault_bag(sparse, bag, bad)
    recording = read_bag(bag)
    _assert_only_the_block_lost(recording, clean_rec,
                                {"l0_acc_nw": list(range(5, 20)), "l4_acc_ne": [60]})
    mine = [f for f in recording.findings if f.where == "l0_acc_nw"]
    assert len(mine) == 11 and "15 blocks of sensor l0_acc_nw dropped in all" in \
        mine[-1].message
    _, report = ingest_recording(recording)
    assert [o.status for o in report.outcomes] == ["ingested", "ingested"]


def test_a_sensor_whose_every_block_contradicts_the_map_is_named_missing(block_bags, tmp_path):
    sparse, clean_rec, _, _ = block_bags
    n = -(-clean_rec.sensors["l4_acc_w"].n_samples // 200)
    bag = tmp_path / "all_bad.mcap"
    block_fault_bag(sparse, bag, {("l4_acc_w", k): set_fields(kind=1) for k in range(1, n + 1)})
    recording = read_bag(bag)
    assert "l4_acc_w" not in recording.sensors and len(recording.sensors) == \
        len(clean_rec.sensors) - 1
    _, report = ingest_recording(recording)
    assert {f.code for f in report.findings if f.where == "l4_acc_w"} == {"bad_block",
                                                                         "missing_sensor"}
    assert [o.status for o in report.outcomes] == ["ingested", "ingested"]


def test_the_live_stream_drops_a_block_stamped_0_and_gives_the_batch_windows(block_bags):
    from pier_monitor.core.ingest.stream import StreamIngest

    _, clean_rec, clean_windows, _ = block_bags
    stream = StreamIngest(clean_rec.config, poll_s=8.0)
    blocks = []
    for sid, r in clean_rec.sensors.items():
        for k in range(0, r.n_samples, 200):
            blocks.append((int(r.time_ns[min(k + 199, r.n_samples - 1)]), sid, k))
    blocks.sort()
    windows = []
    for number, (_, sid, k) in enumerate(blocks):
        r = clean_rec.sensors[sid]
        t, d, i = r.time_ns[k:k + 200], r.data[k:k + 200], r.sample_index[k:k + 200]
        if sid == BLOCK_SID and k == 200 * (BLOCK_NO - 1):  # the logger had no clock yet
            windows += stream.push(sid, t - t[0], d, i)
        windows += stream.push(sid, t, d, i)
    windows += stream.flush()
    assert any(f.code == "stale_block" and f.where == BLOCK_SID for f in stream.report.findings)
    assert [w.event_id for w in windows] == [w.event_id for w in clean_windows]
    for got, want in zip(windows, clean_windows, strict=True):
        np.testing.assert_allclose(got.a, want.a, rtol=0, atol=1e-9)


# -- file faults ----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def file_bags(source, tmp_path_factory):
    """The sparse recording as a plain mcap and as a rosbag2 directory (1 s blocks)."""
    rec, _ = source
    sparse = in_layout(rec, "sparse")
    tmp = tmp_path_factory.mktemp("files")
    write_bag(sparse, tmp / "clean.mcap", block_s=1.0)
    write_bag(sparse, tmp / "clean_bag", fmt="rosbag2", block_s=1.0)
    windows, _ = ingest_recording(read_bag(tmp / "clean.mcap"))
    return {"mcap": tmp / "clean.mcap", "rosbag2": tmp / "clean_bag"}, windows


def _copy(file_bags, fmt, tmp_path) -> tuple[Path, Path]:
    src = file_bags[0][fmt]
    if fmt == "mcap":
        shutil.copy(src, tmp_path / "bag.mcap")
        return tmp_path / "bag.mcap", tmp_path / "bag.mcap"
    shutil.copytree(src, tmp_path / "bag")
    return tmp_path / "bag", next((tmp_path / "bag").glob("*.mcap"))


def _overwrite(storage: Path, share: float, data: bytes) -> int:
    at = int(storage.stat().st_size * share)
    with storage.open("r+b") as fh:
        fh.seek(at)
        fh.write(data)
    return at


@pytest.mark.parametrize("fmt, share", [("mcap", 0.3), ("mcap", 0.8), ("rosbag2", 0.3),
                                        ("rosbag2", 0.8)])
def test_noise_mid_file_loses_only_the_damaged_bytes(file_bags, tmp_path, fmt, share):
    bag, storage = _copy(file_bags, fmt, tmp_path)
    noise = np.random.default_rng(3).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    at = _overwrite(storage, share, noise)
    recording = read_bag(bag)
    damaged = [f for f in recording.findings if f.code == "bag_damaged"]
    spans = [tuple(int(x) for x in re.search(r"bytes (\d+)-(\d+) ", f.message).groups())
             for f in damaged]
    if fmt == "mcap":  # a compressed chunk: lost whole, named by its bytes
        assert damaged and all(f.action == "noted" for f in damaged)
        assert any(a <= at + 4096 and b >= at for a, b in spans)
    # uncompressed: the noise may lie in message data only, for the ingest to judge
    assert sum(b - a for a, b in spans) < 1_500_000  # a chunk at most, never the rest
    _assert_events_outside_the_damage_kept(recording, file_bags[1])


def _assert_events_outside_the_damage_kept(recording: Recording, clean_windows) -> None:
    """Every clean event is there, identical, unless a finding's time span touches it (then
    it may be missing, or ingested, or failed with the gap named)."""
    _, report = ingest_recording(recording)
    # where the bag's reader or the ingest found something (noise in an uncompressed
    # message's data is for the ingest to find)
    spans = [(f.start_ns, f.end_ns) for f in report.findings if f.code not in _LEVEL_CODES]
    got = {o.event_id: o for o in report.outcomes}
    for want in clean_windows:
        t0, t1 = want.start_time_ns, want.start_time_ns + int(want.duration_s * NS_PER_S)
        touched = any(a <= t1 + 15 * NS_PER_S and b >= t0 - 15 * NS_PER_S for a, b in spans)
        outcome = got.get(want.event_id)
        if not touched:
            assert outcome is not None and outcome.status == "ingested", outcome
            assert rel_rms_a(outcome.window, want) < 1e-9
        elif outcome is not None and outcome.window is None:
            assert "gap" in outcome.failure or "cut" in outcome.failure, outcome.failure


def test_a_damaged_magic_loses_nothing(file_bags, tmp_path):
    bag, storage = _copy(file_bags, "mcap", tmp_path)
    _overwrite(storage, 0.0, b"\x00" * 8)
    recording = read_bag(bag)
    assert [f.code for f in recording.findings] == ["bag_damaged"]
    assert recording.equals(read_bag(file_bags[0]["mcap"]))


@pytest.mark.parametrize("text", ["rosbag2_bagfile_information: [unclosed\n", "", "- 1\n"])
def test_a_broken_metadata_yaml_alone_is_named_as_that(file_bags, tmp_path, text):
    bag, _ = _copy(file_bags, "rosbag2", tmp_path)
    (bag / "metadata.yaml").write_text(text)
    recording = read_bag(bag)
    assert [f.code for f in recording.findings] == ["bag_metadata"]
    assert "damaged" not in recording.findings[0].message
    assert recording.equals(read_bag(file_bags[0]["mcap"]))


def test_a_missing_metadata_yaml_is_named_as_that(file_bags, tmp_path):
    bag, _ = _copy(file_bags, "rosbag2", tmp_path)
    (bag / "metadata.yaml").unlink()
    recording = read_bag(bag)
    assert [f.code for f in recording.findings] == ["bag_metadata"]
    assert "it is missing" in recording.findings[0].message


@pytest.mark.parametrize("fmt, keep", [("mcap", 0.5), ("mcap", 0.85), ("rosbag2", 0.6),
                                       ("mcap", 0.95)])
def test_a_truncated_bag_keeps_everything_before_the_cut(file_bags, tmp_path, fmt, keep):
    bag, storage = _copy(file_bags, fmt, tmp_path)
    with storage.open("r+b") as fh:
        fh.truncate(int(storage.stat().st_size * keep))
    recording = read_bag(bag)
    (cut,) = [f for f in recording.findings if f.code == "bag_truncated"]
    end = cut.end_ns
    # the events that ended well before the cut are there, identical; the one it cuts is
    # named as cut
    _, report = ingest_recording(recording)
    got = {o.event_id: o for o in report.outcomes}
    for want in file_bags[1]:
        t1 = want.start_time_ns + int(want.duration_s * NS_PER_S)
        if t1 + 15 * NS_PER_S < end:
            assert got[want.event_id].status == "ingested"
            assert rel_rms_a(got[want.event_id].window, want) < 1e-9
        elif want.event_id in got and got[want.event_id].window is None:
            assert got[want.event_id].status == "cut"


def test_a_file_of_noise_is_a_clear_bag_error(tmp_path):
    bag = tmp_path / "noise.mcap"
    bag.write_bytes(np.random.default_rng(1).integers(0, 256, 50_000, dtype=np.uint8).tobytes())
    with pytest.raises(PierMonitorError, match=r"noise\.mcap: cannot read bag"):
        read_bag(bag)


# -- configuration faults -------------------------------------------------------------------

def test_a_configured_rate_that_contradicts_every_sensor_is_named(source):
    rec, timeline = source
    for rate in (100.0, 400.0):
        with pytest.raises(PierMonitorError, match=rf"sample_rate_hz {rate:g} Hz contradicts "
                                                   "the data"):
            ingest_recording(config_rate(rate)(rec, timeline))


def _with_heights(rec: Recording, factor: float, at_s: float) -> Recording:
    c = rec.config
    g = dataclasses.replace(c.geometry, section_heights_m=np.asarray(
        c.geometry.section_heights_m) * factor)
    return dataclasses.replace(rec, config_updates=(
        (rec.start_ns + int(at_s * NS_PER_S), dataclasses.replace(c, geometry=g)),))


def test_a_configuration_update_with_other_heights_holds_for_the_later_event(source):
    rec, _ = source
    windows, report = ingest_recording(_with_heights(rec, 1.1, 45.0))
    assert [o.status for o in report.outcomes] == ["ingested", "ingested"]
    np.testing.assert_allclose(windows[0].geometry.section_heights_m,
                               rec.config.geometry.section_heights_m)
    np.testing.assert_allclose(windows[1].geometry.section_heights_m,
                               1.1 * np.asarray(rec.config.geometry.section_heights_m))


def test_a_configuration_update_that_changes_the_sensor_map_is_a_clear_error(source):
    rec, _ = source
    c = rec.config
    other = dataclasses.replace(c, sensors=c.sensors[:-1])
    with pytest.raises(PierMonitorError, match=r"changes the pier, its levels or its sensor "
                                               r"map"):
        dataclasses.replace(rec, config_updates=((rec.start_ns + 45 * NS_PER_S, other),))


def test_a_pier_id_that_does_not_match_the_bag_is_named(file_bags, tmp_path):
    config = read_bag(file_bags[0]["mcap"]).config
    other = dataclasses.replace(config, pier_id="pier_b")
    with pytest.raises(PierMonitorError, match=r"configuration is of pier 'pier_b' .* under "
                                               r"/edefense_pier/: the pier_id does not match"):
        identify_bag(file_bags[0]["mcap"], tmp_path / "out", config=other, figures=False)


def test_a_pier_file_of_another_pier_is_named_by_the_command(file_bags, tmp_path, capsys):
    import yaml

    raw = read_bag(file_bags[0]["mcap"]).config.as_dict()
    raw["pier_id"] = "pier_b"
    pier = tmp_path / "pier.yaml"
    pier.write_text(yaml.safe_dump(raw))
    rc = main(["identify", str(file_bags[0]["mcap"]), "--out", str(tmp_path / "out"),
               "--pier", str(pier), "--no-progress", "--no-figures", "--method", "field"])
    err = capsys.readouterr().err
    assert rc == EXIT_ERROR and "the pier_id does not match the bag's namespace" in err
    assert "Traceback" not in err and "no samples" not in err


# -- command-line misuse ------------------------------------------------------------------------

@pytest.mark.parametrize("argv, shown", [
    (["simulate", "--seed", "-1"], "argument --seed: expected a seed from 0 to 4294967295"),
    (["simulate", "--seed", "x"], "argument --seed: expected a whole number"),
    (["simulate", "--seed", str(2 ** 32)], "argument --seed: expected a seed from 0"),
    (["demo", "--seed", "-5"], "argument --seed: expected a seed from 0"),
    (["identify", "BAG", "--train-seed", "-1"], "argument --train-seed: expected a seed"),
    (["identify", "BAG", "--max-epochs", "0"], "argument --max-epochs"),
    (["identify", "BAG", "--method", "magic"], "argument --method"),
])
def test_command_line_misuse_is_a_clear_error(tmp_path, capsys, argv, shown):
    argv = [str(tmp_path / "x.mcap") if a == "BAG" else a for a in argv]
    if argv[0] == "simulate":
        argv += ["--out", str(tmp_path / "sim.mcap")]
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and shown in err and "Traceback" not in err


def test_identify_of_a_missing_bag_is_a_clear_error(tmp_path, capsys):
    rc = main(["identify", str(tmp_path / "nope.mcap"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert rc == EXIT_ERROR and "nope.mcap: no such bag" in err and "Traceback" not in err


def test_identify_bag_sub_dotdot_writes_beside_the_bags_real_name(file_bags, tmp_path, capsys,
                                                                 monkeypatch):
    bag = tmp_path / "site_a"
    shutil.copytree(file_bags[0]["rosbag2"], bag)
    (bag / "sub").mkdir()
    for f in bag.glob("*.mcap"):  # no configuration: the command stops after making its out
        f.write_bytes(b"")
    monkeypatch.chdir(tmp_path)
    rc = main(["identify", "site_a/sub/..", "--no-progress", "--no-figures"])
    assert rc == EXIT_ERROR
    assert (tmp_path / "results" / "site_a").is_dir()
    assert sorted(p.name for p in (tmp_path / "results").iterdir()) == ["site_a"]


# -- end to end, the field route -------------------------------------------------------------

FIELD = ["--method", "field", "--no-progress", "--no-figures"]


@pytest.fixture(scope="module")
def truth_states(tmp_path_factory):
    synthetic, _ = short_recording(seed=0)
    return [[classify_ductility(df).name.lower() for df in run.ductility_factors]
            for run in synthetic.truth.runs]


def test_end_to_end_other_heights_and_a_bad_earlier_result_are_not_baselines(
        source, truth_states, tmp_path, capsys, caplog):
    rec, _ = source
    bag = tmp_path / "heights.mcap"
    write_bag(_with_heights(rec, 1.0 + 1e-3, 45.0), bag, block_s=1.0)
    out = tmp_path / "out"
    # an earlier event of the pier whose result, reliable by its flags, holds a NaN k1
    earlier = out / "edefense_pier_20200101T000000Z"
    earlier.mkdir(parents=True)
    failed = failed_event_result(rec.config.geometry, pier_id=rec.config.pier_id,
                                 event_id=earlier.name, start_ns=1_577_836_800 * NS_PER_S,
                                 duration_s=10.0, message="")
    doc = json.loads(failed.save_json(earlier / "result.json").read_text())
    doc.update(success=True, overall_state="intact")
    for s in doc["sections"]:
        s.update(k1=1e9, k2=1e8, fy=1e6, c=1e6, state="intact")
    doc["sections"][0]["k1"] = float("nan")
    (earlier / "result.json").write_text(json.dumps(doc))
    with caplog.at_level(logging.WARNING):
        rc = main(["identify", str(bag), "--out", str(out), *FIELD])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    assert rc in (0, 3), captured.out
    results = {p.parent.name: json.loads(p.read_text()) for p in out.glob("*/result.json")}
    ids = sorted(k for k in results if k != earlier.name)
    assert len(ids) == 2  # both events identified
    for event_id, states in zip(ids, truth_states, strict=True):
        assert [s["state"] for s in results[event_id]["sections"]] == states
    warnings = caplog.text
    assert f"{earlier / 'result.json'}: not a baseline: its k1 [nan, " in warnings
    assert f"{out / ids[0] / 'result.json'}: not a baseline of event {ids[1]}" in warnings
    assert "the geometry changed" in warnings


def test_end_to_end_an_event_directory_planted_as_a_link_fails_that_event_only(
        source, truth_states, tmp_path, capsys):
    rec, _ = source
    bag = tmp_path / "bag.mcap"
    write_bag(rec, bag, block_s=1.0)
    windows, _ = ingest_recording(rec)
    out = tmp_path / "out"
    out.mkdir()
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (out / windows[0].event_id).symlink_to(elsewhere)
    rc = main(["identify", str(bag), "--out", str(out), *FIELD])
    captured = capsys.readouterr()
    assert rc == EXIT_FAILED and "Traceback" not in captured.err
    assert f"event {windows[0].event_id}: FAILED: identification failed" in captured.out
    assert "1 identified, 1 failed" in captured.out
    assert not any(elsewhere.iterdir())  # nothing written through the link
    result = json.loads((out / windows[1].event_id / "result.json").read_text())
    # the other event keeps its diagnosis: the true states, or "suspicious" with its reason
    # where the members are unsure (section 3, true DF 0.89: 2 of 32 members yield, and its
    # DF interval straddles 1.2), never another confident state
    for got, want, sec in zip([s["state"] for s in result["sections"]], truth_states[1],
                              result["sections"], strict=True):
        assert got == want or (got == "suspicious" and sec["reasons"])


def _lone_accelerometer_at_level_2(rec: Recording, timeline: Timeline) -> Recording:
    """The sparse network less three of the four accelerometers at level 2."""
    rec = in_layout(rec, "sparse")
    for sid in ("l2_acc_e", "l2_acc_s", "l2_acc_w"):
        rec = without(sid)(rec, timeline)
    return rec


@pytest.mark.parametrize("fault", [acc_step("l2_acc_n", 2, 0.5, 50.0),  # gal: 0.5 m/s²
                                   acc_drift("l2_acc_n", 2, 2.0)],      # gal/s: 0.02 m/s²/s
                         ids=["offset_step", "drift"])
def test_end_to_end_an_offset_change_without_partners_makes_the_event_unreliable(
        source, truth_states, tmp_path, capsys, fault):
    """Without partners at its level, the ingest cannot judge an accelerometer's offset: the
    self-check against the identified model finds it, and the event's result is unreliable
    with the level named; the event before the fault keeps the clean states (or is
    suspicious where the thinner network leaves the ensemble unsure)."""
    rec, timeline = source
    bag = tmp_path / "lone.mcap"
    write_bag(_lone_accelerometer_at_level_2(fault(rec, timeline), timeline), bag,
              block_s=1.0)
    out = tmp_path / "out"
    rc = main(["identify", str(bag), "--out", str(out), *FIELD])
    assert "Traceback" not in capsys.readouterr().err
    assert rc == EXIT_UNRELIABLE
    first, second = [json.loads(p.read_text()) for p in sorted(out.glob("*/result.json"))]
    # the event before the fault: the clean states, or "suspicious" where the lone
    # accelerometer leaves the ensemble unsure (never another confident state)
    for got, want in zip([s["state"] for s in first["sections"]], truth_states[0],
                         strict=True):
        assert got in (want, "suspicious")
    assert second["overall_state"] == "unreliable"
    assert {s["state"] for s in second["sections"]} == {"unreliable"}
    assert any("suspect sensor at level 2" in r for r in second["unreliable_reasons"])
