"""Bags: synthetic E-Defense-style rosbag2 directories and mcap files, written and read back."""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from pier_monitor.bags import (SAMPLE_BLOCK, BagError, config_topic, find_msg_dir,
                               get_typestore, read_bag, read_bag_config, sensor_topic,
                               truth_paths, write_bag, write_synthetic_edefense_bag)
from pier_monitor.core.model.config import config_from_yaml, load_config
from pier_monitor.core.ingest.recording import Recording, SensorRecord
from pier_monitor.cli import main
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.field import (field_case_recording, field_recording,
                                               field_scenario)
from pier_monitor.core.synthetic.layouts import GNSS_SENSOR_ID, layout_config
from pier_monitor.core.synthetic.shaking_table import generate_recording, load_truth


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """The default synthetic test written once in each format, and the recording it holds."""
    root = tmp_path_factory.mktemp("bags")
    rosbag2 = write_synthetic_edefense_bag(root / "edefense", fmt="rosbag2", seed=0)
    mcap = write_synthetic_edefense_bag(root / "edefense_plain", fmt="mcap", seed=0)
    expected = generate_recording(load_config(rosbag2.config_path), seed=0).recording
    return {"rosbag2": rosbag2, "mcap": mcap, "expected": expected}


def assert_recordings_equal(got: Recording, want: Recording) -> None:
    assert got.config == want.config
    assert list(got.sensors) == list(want.sensors)
    for sid, rec in want.sensors.items():
        other = got.sensor(sid)
        assert np.array_equal(other.time_ns, rec.time_ns), sid
        assert np.array_equal(other.sample_index, rec.sample_index), sid
        assert np.array_equal(other.data, rec.data, equal_nan=True), sid
        assert other.rate_hz == rec.rate_hz
    assert got.equals(want)


# --- round trips ------------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["rosbag2", "mcap"])
def test_written_bag_reads_back_to_the_recording(written, fmt):
    info = written[fmt]
    if fmt == "rosbag2":
        assert info.bag.path.is_dir() and (info.bag.path / "metadata.yaml").is_file()
        assert len(list(info.bag.path.glob("*.mcap"))) == 1
    else:
        assert info.bag.path.suffix == ".mcap" and info.bag.path.is_file()
    got = read_bag(info.bag.path)
    assert_recordings_equal(got, written["expected"])
    assert got.missing_sensors == () and got.unmapped_topics == ()
    assert read_bag_config(info.bag.path) == written["expected"].config
    n_sensors = len(written["expected"].config.sensors)
    # the configuration, its update before run 2 (deck mass added), 30002 samples per sensor
    # in 20-sample blocks
    assert len(got.config_updates) == 1
    assert got.config_updates[0][1].geometry.masses_kg[-1] > got.config.geometry.masses_kg[-1]
    assert info.bag.n_messages == 2 + n_sensors * 1501
    assert info.bag.topics[0] == "/edefense_pier/pier_configuration"


def test_truth_files_lie_beside_the_bag(written):
    for fmt in ("rosbag2", "mcap"):
        info = written[fmt]
        npz, js = truth_paths(info.bag.path)
        assert (info.truth_npz, info.truth_json) == (npz, js)
        assert npz.parent == info.bag.path.parent
        meta = json.loads(js.read_text())
        assert meta["principal_direction_deg"] == 196.0 and meta["seed"] == 0
        assert [r["name"] for r in meta["runs"]] == ["run1", "run2"]
        for key in ("params", "geometry", "ductility_factors", "window_start_ns", "periods_s"):
            assert key in meta["runs"][0]
        assert meta["noise"]["l0_acc_ne"]["unit"] == "gal"
        truth = load_truth(npz, js)
        assert np.array_equal(truth.runs[1].ductility_factors,
                              info.truth.runs[1].ductility_factors)
        assert np.array_equal(truth.runs[0].response.x, info.truth.runs[0].response.x)
    summary = written["rosbag2"].summary()
    assert summary["runs"][1]["ductility_factors"][0] > summary["runs"][0]["ductility_factors"][0]


def test_uneven_timestamps_gaps_and_duplicates_survive_a_round_trip(written, tmp_path):
    """Blocks are uniform by definition; the writer splits them so that nothing is lost."""
    base = written["expected"]
    rec = base.sensor("l1_acc_n")
    keep = np.r_[0:100, 110:150, 140:160, 160:230]  # 10 samples dropped, 10 duplicated
    times = rec.time_ns[keep].copy()
    times[200:] += 1_234_567  # a clock jump
    data = rec.data[keep].copy()
    data[5, 1] = np.nan  # a bad sample is carried, not judged
    odd = SensorRecord("l1_acc_n", times, data, rec.rate_hz, sample_index=rec.sample_index[keep])
    wire = base.sensor("l2_wire_w")
    short = SensorRecord("l2_wire_w", wire.time_ns[:7], wire.data[:7], wire.rate_hz)
    recording = Recording(base.config, {"l1_acc_n": odd, "l2_wire_w": short})
    for name in ("odd.mcap", "odd_bag"):
        summary = write_bag(recording, tmp_path / name, block_s=0.1)
        got = read_bag(summary.path)
        assert_recordings_equal(got, recording)
        assert "l1_acc_w" in got.missing_sensors


# --- field networks: a slower GNSS receiver, imperfect sensors, the command line ---------------


def test_a_slower_gnss_receiver_round_trips_through_both_formats(tmp_path):
    config = load_config(find_config_file("table1_field.yaml"))
    scenario = field_scenario("table1", "just_yield", lead_s=4.0, tail_s=4.0)
    recording = field_recording(config, "sparse", scenario, gnss=True, seed=1).recording
    gnss = recording.sensor(GNSS_SENSOR_ID)
    assert gnss.rate_hz == 10.0 and recording.sensor("l0_acc_n").rate_hz == 200.0
    for name in ("gnss.mcap", "gnss_bag"):
        summary = write_bag(recording, tmp_path / name)
        got = read_bag(summary.path)
        assert_recordings_equal(got, recording)
        assert got.config.sensor(GNSS_SENSOR_ID).rate_hz == 10.0
        assert got.sensor(GNSS_SENSOR_ID).n_samples == gnss.n_samples == 481  # 48 s at 10 Hz


def test_simulate_writes_a_field_bag_with_imperfect_sensors(tmp_path, capsys):
    pier = find_config_file("table1_field.yaml")
    out = tmp_path / "field.mcap"
    assert main(["simulate", "--out", str(out), "--layout", "sparse", "--gnss", "--pier",
                 str(pier), "--scenario", "just_yield", "--seed", "3"]) == 0
    printed = capsys.readouterr().out
    assert "sensors: 7, layout sparse + GNSS top (field network)" in printed
    assert "imperfect sensors: yes, anti-aliasing: yes" in printed
    got = read_bag(out)
    # the bag carries the nominal field configuration; the library gives the same recording
    assert got.config == layout_config(load_config(pier), "sparse", gnss=True)
    expected = field_case_recording("table1", "sparse", gnss=True, shaking="just_yield", seed=3)
    assert_recordings_equal(got, expected.recording)
    npz, js = truth_paths(out)
    meta = json.loads(js.read_text())
    assert set(meta["sensor_errors"]) == {s.sensor_id for s in got.config.sensors}
    assert meta["imperfections"]["misalignment_sd_deg"] == 0.5 and "anti_alias" in meta
    truth = load_truth(npz, js)
    assert truth.sensor_errors == expected.truth.sensor_errors
    assert 1.2 <= max(meta["runs"][0]["ductility_factors"]) <= 1.5


def test_simulate_without_a_layout_writes_the_shaking_table_bag(written, tmp_path, capsys):
    out = tmp_path / "edefense"
    assert main(["simulate", "--out", str(out)]) == 0
    assert "layout of the configuration (shaking table); imperfect sensors: no" in (
        capsys.readouterr().out)
    assert_recordings_equal(read_bag(out), written["expected"])
    assert "sensor_errors" not in json.loads(truth_paths(out)[1].read_text())


def test_simulate_rejects_field_options_that_do_not_apply(tmp_path, capsys):
    assert main(["simulate", "--out", str(tmp_path / "b"), "--gnss"]) == 2
    assert "--gnss adds a GNSS receiver to a field layout" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "r.npz"), "--layout", "accel"]) == 2
    assert "apply to bags" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "c"), "--layout", "accel", "--pier",
                 str(find_config_file("table1.yaml")), "--scenario", "edefense"]) == 2
    assert "k1_factors: expected 6" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "d"), "--layout", "accel", "--layout",
                 "sparse"]) == 2
    assert "one --layout for a bag, got ['accel', 'sparse']" in capsys.readouterr().err
    assert main(["simulate", "--out", str(tmp_path / "e"), "--fleet", "2", "--gnss"]) == 2
    assert "apply to one bag" in capsys.readouterr().err
    assert not any((tmp_path / name).exists() for name in "bcde")


# --- standard tools read the plain mcap ------------------------------------------------------


def test_mcap_tools_decode_the_plain_mcap(written):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    info = written["mcap"]
    expected = written["expected"]
    config = expected.config
    spec = config.sensor("l4_acc_nw")
    record = expected.sensor(spec.sensor_id)
    with info.bag.path.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary.statistics.message_count == info.bag.n_messages
        assert {s.name for s in summary.schemas.values()} == {"std_msgs/msg/String",
                                                              SAMPLE_BLOCK}
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        configs = [m for _, _, _, m in
                   reader.iter_decoded_messages(topics=[config_topic(config.pier_id)])]
        assert len(configs) == 2  # the configuration and its update before run 2
        assert config_from_yaml(configs[0].data) == config
        assert config_from_yaml(configs[1].data) == expected.config_updates[0][1]
        blocks = [(msg, m.log_time) for _, _, m, msg in
                  reader.iter_decoded_messages(topics=[sensor_topic(config.pier_id, spec)])]
    assert len(blocks) == 1501
    for i, (msg, log_time) in enumerate(blocks[:50] + blocks[-3:]):
        first = int(msg.first_sample_index)
        n = len(msg.data) // 3
        assert msg.sensor_id == spec.sensor_id == msg.header.frame_id
        assert (msg.kind, msg.unit, list(msg.axes)) == (0, "m/s^2", ["x", "y", "z"])
        assert msg.sample_rate_hz == 200.0
        stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
        assert stamp == record.time_ns[first]
        assert log_time == record.time_ns[first + n - 1]
        assert np.array_equal(np.reshape(msg.data, (n, 3)), record.data[first:first + n])
    assert [int(m.first_sample_index) for m, _ in blocks[:3]] == [0, 20, 40]


def test_mcap_tools_decode_the_rosbag2_storage_file(written):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (storage,) = written["rosbag2"].bag.path.glob("*.mcap")
    with storage.open("rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        _, _, _, msg = next(iter(reader.iter_decoded_messages(
            topics=["/edefense_pier/sensors/level0/acc_ne"])))
        assert msg.unit == "gal" and msg.first_sample_index == 0 and len(msg.data) == 60


@pytest.mark.ros
def test_rclpy_deserializes_the_bag_messages(written):
    """A live graph gets these bytes on replay: rclpy must decode them to equal messages."""
    serialization = pytest.importorskip("rclpy.serialization")
    pier_msgs = pytest.importorskip("pier_monitor_msgs.msg")
    std_msgs = pytest.importorskip("std_msgs.msg")
    from rosbags.rosbag2 import Reader

    expected = written["expected"]
    record = expected.sensor("l3_acc_e")
    with Reader(written["mcap"].bag.path) as reader:
        conns = [c for c in reader.connections
                 if c.topic in ("/edefense_pier/pier_configuration",
                                "/edefense_pier/sensors/level3/acc_e")]
        messages = list(reader.messages(connections=conns))
    config_raw = next(raw for c, _, raw in messages if c.msgtype == "std_msgs/msg/String")
    text = serialization.deserialize_message(config_raw, std_msgs.String).data
    assert config_from_yaml(text) == expected.config
    blocks = [serialization.deserialize_message(raw, pier_msgs.SampleBlock)
              for c, _, raw in messages if c.msgtype == SAMPLE_BLOCK]
    assert len(blocks) == 1501
    data = np.concatenate([np.reshape(np.asarray(b.data), (-1, 3)) for b in blocks])
    assert np.array_equal(data, record.data)
    assert [b.first_sample_index for b in blocks[:2]] == [0, 20]


# --- errors ----------------------------------------------------------------------------------


def test_missing_bag_is_a_bag_error(tmp_path):
    with pytest.raises(BagError, match="nope.mcap: no such bag"):
        read_bag(tmp_path / "nope.mcap")
    (tmp_path / "empty_dir").mkdir()
    with pytest.raises(BagError, match="empty_dir: not a rosbag2 directory"):
        read_bag(tmp_path / "empty_dir")


def _damaged_copy(written, tmp_path, fmt: str, keep: float = 0.5,
                  flip_at: float | None = None) -> Path:
    """A copy of the written bag whose mcap keeps ``keep`` of its bytes (a logger that lost
    power), or has bytes overwritten at ``flip_at`` of its length (a bad disk sector)."""
    src = written[fmt].bag.path
    if fmt == "mcap":
        bag = storage = tmp_path / "cut.mcap"
        shutil.copy(src, bag)
    else:
        bag = tmp_path / "cut_bag"
        shutil.copytree(src, bag)
        (storage,) = bag.glob("*.mcap")
    size = storage.stat().st_size
    with storage.open("r+b") as fh:
        if flip_at is None:
            fh.truncate(int(size * keep))
        else:
            fh.seek(int(size * flip_at))
            fh.write(b"\xff" * 4096)
    return bag


@pytest.fixture(scope="module")
def full_windows(written):
    """The windows of the complete bag (both formats hold the same recording)."""
    from pier_monitor.core.ingest import ingest_recording

    return ingest_recording(read_bag(written["mcap"].bag.path))[0]


@pytest.mark.parametrize("fmt", ["mcap", "rosbag2"])
def test_truncated_bag_is_read_up_to_the_damage_and_run1_is_unchanged(written, full_windows,
                                                                       tmp_path, fmt):
    from pier_monitor.core.ingest import ingest_recording

    bag = _damaged_copy(written, tmp_path, fmt)
    recording = read_bag(bag)
    (finding,) = recording.findings
    assert finding.code == "bag_truncated" and finding.where == str(bag)
    end_s = (finding.end_ns - written["expected"].start_ns) / 1e9
    assert 50.0 < end_s < 90.0  # cut between run 1 (ends ~47 s) and run 2 (starts ~97 s)
    assert "messages read up to the damage; its data end at 2024-03-12T01:0" in finding.message
    n_read = int(finding.message.split(": ")[-1].split(" messages")[0])
    assert 10_000 < n_read < written[fmt].summary()["messages"]
    windows, report = ingest_recording(recording)
    assert [o.status for o in report.outcomes] == ["ingested"]
    assert windows[0] == full_windows[0]  # every field, the findings included


def test_bag_cut_inside_run2_reports_run2_as_cut(written, full_windows, tmp_path):
    from pier_monitor.core.ingest import ingest_recording

    bag = _damaged_copy(written, tmp_path, "mcap", keep=0.72)
    windows, report = ingest_recording(read_bag(bag))
    assert [o.status for o in report.outcomes] == ["ingested", "cut"]
    assert windows == [full_windows[0]]
    cut = report.outcomes[1]
    assert cut.window is None and "is cut: the data end at 2024-03-12T01:01:" in cut.failure
    assert "bag_truncated" in [f.code for f in cut.findings]


@pytest.mark.parametrize("fmt", ["mcap", "rosbag2"])
def test_bag_with_a_corrupt_middle_keeps_every_readable_chunk_after_it(written, full_windows,
                                                                        tmp_path, fmt):
    from pier_monitor.core.ingest import ingest_recording

    bag = _damaged_copy(written, tmp_path, fmt, flip_at=0.3)
    recording = read_bag(bag)
    (finding,) = recording.findings
    assert finding.code == "bag_damaged" and finding.where == str(bag)
    storage = bag if fmt == "mcap" else next(bag.glob("*.mcap"))
    at = int(storage.stat().st_size * 0.3)
    start, end = (int(b) for b in re.search(r"bytes (\d+)-(\d+) \(", finding.message).groups())
    # the noise ends inside the range (a whole compressed chunk, or the records of an
    # uncompressed one from the first whose framing it breaks)
    assert start <= at + 4096 <= end and end - start < 2_000_000
    assert "the records before and after them were read; data lost " in finding.message
    # the data after the damage are all there: run 2 ingested exactly as from the whole bag
    assert recording.end_ns == written["expected"].end_ns
    windows, report = ingest_recording(recording)
    assert windows[-1] == dataclasses.replace(full_windows[-1], report=windows[-1].report)
    assert len(report.outcomes) == 2


def test_bag_with_a_damaged_magic_is_read_whole(written, tmp_path):
    bag = _damaged_copy(written, tmp_path, "mcap", keep=1.0)
    with bag.open("r+b") as fh:
        fh.write(b"\x00" * 8)
    recording = read_bag(bag)
    (finding,) = recording.findings
    assert finding.code == "bag_damaged" and "the file magic (bytes 0-8) is damaged" in \
        finding.message
    assert_recordings_equal(recording, written["expected"])


def test_a_broken_metadata_yaml_alone_is_named_and_the_storage_read(written, tmp_path):
    bag = _damaged_copy(written, tmp_path, "rosbag2", keep=1.0)
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [unclosed\n")
    recording = read_bag(bag)
    (finding,) = recording.findings
    assert finding.code == "bag_metadata" and finding.where == str(bag / "metadata.yaml")
    assert "it cannot be read" in finding.message and "were read directly" in finding.message
    assert "damaged" not in finding.message
    assert_recordings_equal(recording, written["expected"])


def test_rosbag2_directory_without_metadata_is_recovered(written, tmp_path):
    bag = _damaged_copy(written, tmp_path, "rosbag2")
    (bag / "metadata.yaml").unlink()
    recording = read_bag(bag)
    assert recording.findings[0].code == "bag_truncated"
    assert read_bag_config(bag) == written["expected"].config


def test_bag_damaged_before_any_message_is_a_bag_error(written, tmp_path):
    bag = _damaged_copy(written, tmp_path, "mcap", keep=0.0005)
    with pytest.raises(BagError, match=r"cut\.mcap: cannot read bag, it may be truncated or "
                                       r"corrupt: .*no complete message before the damage"):
        read_bag(bag)


def test_corrupt_bytes_are_a_bag_error(written, tmp_path):
    bag = tmp_path / "garbage.mcap"
    bag.write_bytes(b"\x89MCAP0\r\n" + bytes(range(256)) * 64)
    with pytest.raises(BagError, match="garbage.mcap"):
        read_bag(bag)


def _write_raw_rosbag2(path: Path, topics: list[tuple[str, str, list[tuple[int, object]]]]) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    typestore = get_typestore()
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        for topic, msgtype, messages in topics:
            conn = writer.add_connection(topic, msgtype, typestore=typestore)
            for t_ns, msg in messages:
                writer.write(conn, t_ns, typestore.serialize_cdr(msg, msgtype))


def _block(spec, unit=None):
    types = get_typestore().types
    return types[SAMPLE_BLOCK](
        header=types["std_msgs/msg/Header"](
            stamp=types["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id=spec.sensor_id),
        sensor_id=spec.sensor_id, kind=0, unit=unit or spec.unit, sample_rate_hz=200.0,
        first_sample_index=0, axes=list(spec.axes), data=np.zeros(3 * len(spec.axes)))


def test_bag_without_configuration_is_a_bag_error(written, tmp_path):
    config = written["expected"].config
    spec = config.sensor("l0_acc_nw")
    bag = tmp_path / "no_config"
    _write_raw_rosbag2(bag, [(sensor_topic(config.pier_id, spec), SAMPLE_BLOCK,
                              [(1_000_000_000, _block(spec))])])
    with pytest.raises(BagError, match="no_config: no pier configuration in the bag"):
        read_bag(bag)


@pytest.mark.parametrize("pier_id, shown", [("../../x", r"'\.\./\.\./x' holds '\./'"),
                                            ("/abs/y", r"'/abs/y' holds '/'"),
                                            ("", r"expected a non-empty string")])
def test_bag_whose_configuration_has_an_unsafe_pier_id_is_refused(written, tmp_path, pier_id,
                                                                  shown):
    import yaml

    from pier_monitor.core.errors import ConfigError

    types = get_typestore().types
    raw = written["expected"].config.as_dict()
    raw["pier_id"] = pier_id
    bag = tmp_path / "evil"
    _write_raw_rosbag2(bag, [("/evil/pier_configuration", "std_msgs/msg/String",
                              [(1, types["std_msgs/msg/String"](data=yaml.safe_dump(raw)))])])
    with pytest.raises(ConfigError, match=rf"evil:/evil/pier_configuration: pier_id: {shown}"):
        read_bag(bag)


def test_unknown_message_type_on_a_sensor_topic_is_ignored_with_a_finding(written, tmp_path):
    types = get_typestore().types
    config = written["expected"].config
    spec = config.sensor("l0_acc_nw")
    other = config.sensor("l0_acc_ne")
    bag = tmp_path / "wrong_type"
    _write_raw_rosbag2(bag, [
        (config_topic(config.pier_id), "std_msgs/msg/String",
         [(1, types["std_msgs/msg/String"](data=config.to_yaml()))]),
        (sensor_topic(config.pier_id, spec), "std_msgs/msg/Float64",
         [(2, types["std_msgs/msg/Float64"](data=1.0))]),
        (sensor_topic(config.pier_id, other), SAMPLE_BLOCK, [(3, _block(other))]),
    ])
    recording = read_bag(bag)
    assert list(recording.sensors) == ["l0_acc_ne"]
    (finding,) = recording.findings
    assert finding.code == "wrong_message_type" and finding.where == "l0_acc_nw"
    assert ("messages of type 'std_msgs/msg/Float64' on /edefense_pier/sensors/level0/acc_nw"
            in finding.message)


def test_block_contradicting_the_sensor_map_is_dropped_with_a_finding(written, tmp_path):
    types = get_typestore().types
    config = written["expected"].config
    spec = config.sensor("l0_acc_nw")  # m/s^2 in the map
    bag = tmp_path / "wrong_unit"
    _write_raw_rosbag2(bag, [
        (config_topic(config.pier_id), "std_msgs/msg/String",
         [(1, types["std_msgs/msg/String"](data=config.to_yaml()))]),
        (sensor_topic(config.pier_id, spec), SAMPLE_BLOCK, [(2, _block(spec, unit="gal"))]),
    ])
    recording = read_bag(bag)
    assert recording.sensors == {}
    (finding,) = recording.findings
    assert finding.code == "bad_block" and finding.where == "l0_acc_nw"
    assert finding.action == "excluded" and finding.start_ns == 2
    assert re.search(r"acc_nw: block 1 \(logged at .*\): unit: block unit 'gal' but the "
                     r"configuration says 'm/s\^2'; block dropped \(3 samples\)",
                     finding.message)


def test_writer_refuses_to_overwrite(written, tmp_path):
    target = tmp_path / "exists.mcap"
    target.write_bytes(b"")
    with pytest.raises(BagError, match="exists.mcap: exists already"):
        write_bag(written["expected"], target)
    with pytest.raises(BagError, match="edefense: exists already"):
        write_synthetic_edefense_bag(written["rosbag2"].bag.path)


def test_message_definitions_are_found():
    msg_dir = find_msg_dir()
    assert (msg_dir / "SampleBlock.msg").is_file()
    assert SAMPLE_BLOCK in get_typestore().types


def test_installed_message_definitions_come_first_then_the_repository(tmp_path, monkeypatch):
    import sys

    from pier_monitor.core import resources

    installed = tmp_path / "prefix" / "share" / "pier_monitor_msgs" / "msg"
    installed.mkdir(parents=True)
    (installed / "SampleBlock.msg").write_text("float64[] data\n")
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "prefix"))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    assert find_msg_dir() == installed
    monkeypatch.setattr(sys, "prefix", str(tmp_path / "elsewhere"))
    assert find_msg_dir() == resources.REPO_ROOT / "msg_defs" / "msg"
    monkeypatch.setattr(resources, "REPO_ROOT", tmp_path / "no_repo")
    with pytest.raises(BagError, match=r"cannot find the pier_monitor_msgs message definitions.*"
                                       r"no_repo/msg_defs/msg"):
        find_msg_dir()


def test_bags_package_imports_no_rclpy():
    import subprocess
    import sys

    code = ("import sys, pier_monitor.bags; "
            "bad = [m for m in ('rclpy', 'torch') if m in sys.modules]; sys.exit(1 if bad else 0)")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
