"""The live graph: ingest and identifier nodes as real rclpy processes (SPEC §7, §9).

A short two-run synthetic bag (0.5 s blocks) is replayed at 8x real time into the nodes on a
private ROS_DOMAIN_ID; the training is tiny (6 epochs) and the offline pipeline runs with the
same settings for comparison.
"""

from __future__ import annotations

import math
import shutil
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fault_injection import edit, idx, short_recording
from ros_helpers import (NS, REPO_ROOT, RUN_SCRIPT, TINY, Listener, check_markers, interrupt,
                         params_file, start_node, wait_until)

pytestmark = [pytest.mark.ros, pytest.mark.timeout(170)]


@pytest.fixture(scope="module")
def short_bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, int]:
    """An 88 s two-run bag and the number of samples it holds."""
    from pier_monitor.bags import read_bag, write_bag
    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.core.synthetic.shaking_table import edefense_scenario, generate_recording

    config = load_config(find_config_file("edefense_like.yaml"))
    scenario = edefense_scenario(record_s=20.0, lead_s=12.0, gap_s=18.0, tail_s=18.0)
    synthetic = generate_recording(config, scenario, seed=1)
    path = tmp_path_factory.mktemp("live") / "short.mcap"
    write_bag(synthetic.recording, path, block_s=0.5)
    n_samples = sum(r.n_samples for r in read_bag(path).sensors.values())
    return path, n_samples


@pytest.fixture(scope="module")
def offline(short_bag: tuple[Path, int], tmp_path_factory: pytest.TempPathFactory) -> Any:
    """identify_bag on the same bag with the same settings as the live identifier."""
    from pier_monitor.core.identify.methods import IdentifySettings
    from pier_monitor.pipeline import identify_bag

    return identify_bag(short_bag[0], tmp_path_factory.mktemp("offline"),
                        settings=IdentifySettings.from_flat(**TINY))


@pytest.fixture
def listener(rclpy_context: Any, msg_typestore: Any) -> Any:
    lis = Listener(rclpy_context, msg_typestore)
    yield lis
    lis.close()


def expected_level(state: str) -> bytes:
    """The ``DiagnosticStatus`` level of a section state (the DF class, or above it where
    the intervals or the self-check raise it)."""
    from diagnostic_msgs.msg import DiagnosticStatus

    return {"intact": DiagnosticStatus.OK, "suspicious": DiagnosticStatus.WARN,
            "damaged": DiagnosticStatus.ERROR, "unreliable": DiagnosticStatus.WARN}[state]


def test_replayed_bag_is_fully_ingested_and_diagnosed_like_offline(
        short_bag, offline, listener, spawn_python, tmp_path):
    from pier_monitor.bags import read_bag
    from pier_monitor.core.ingest.window import load_window
    from pier_monitor.report.results import damage_state_fields

    bag, n_samples = short_bag
    # the identifier's window directory is not the ingest's: it gets the windows only as
    # messages, so the damage states below are of windows that travelled as messages
    inbox = tmp_path / "identifier_inbox"
    params = params_file(tmp_path / "params.yaml", tmp_path, window_dir=str(inbox))
    graph = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/start_graph.py"),
                         "--namespace", NS, "--params-file", str(params))
    graph.wait_for_line("READY", 30)
    graph.wait_for_line("READY", 30)
    # the bag in two parts: up to the quiet stretch after run 1 that ends its event, then
    # the rest once run 1 is in training; the live graph must not need the end of the data
    first, second = (ev.window for ev in offline.events)
    first_log_ns = read_bag(bag).start_ns - 1_000_000  # the configuration, 1 ms earlier
    split_s = (first.start_time_ns - first_log_ns) / 1e9 + first.duration_s + 17.0
    assert split_s < (second.start_time_ns - first_log_ns) / 1e9 - 5.0
    replay = REPO_ROOT / "launch_free_scripts/replay_bag.py"
    sent_samples = 0
    for part in (("--end-s", f"{split_s}"), ("--start-s", f"{split_s}")):
        player = spawn_python(RUN_SCRIPT, str(replay), str(bag), "--rate", "8", *part)
        sent = player.wait_for_line("SENT", 90)
        sent_samples += int(sent.split("samples=")[1].split()[0])
        assert player.stop() == 0
        if part[0] == "--end-s":
            listener.wait(lambda: any(m.event_id == first.event_id for m in listener.progress),
                          90, f"training of {first.event_id} before the rest of the bag")
    assert sent_samples == n_samples

    listener.wait(lambda: len(listener.states) >= 2, 90, "two damage states")
    listener.wait(lambda: listener.ingest_values().get("samples_received") == str(n_samples),
                  15, f"ingest status counting {n_samples} samples")
    status = listener.ingest_values()
    assert status["messages_dropped"] == "0" and status["gap_samples"] == "0"
    assert status["windows_emitted"] == "2"

    assert [s.event_id for s in listener.states] == [e.window.event_id for e in offline.events]
    assert not inbox.exists() and len(list((tmp_path / "windows").glob("*.npz"))) == 2
    for ev in offline.events:  # the identifier stored the window it got from the message
        stored = load_window(tmp_path / "results" / ev.window.event_id / "window.npz")
        assert stored == ev.window  # every field: the live ingest gives the offline window
    for live, ev in zip(listener.states, offline.events):
        want = damage_state_fields(ev.result)
        assert live.success and live.overall_state == want["overall_state"]
        assert live.epochs == want["epochs"]
        assert live.final_loss == pytest.approx(want["final_loss"], rel=1e-6)
        for got, exp in zip(live.sections, want["sections"], strict=True):
            assert got.state == exp["state"]
            for key in ("k1", "k2", "fy", "c", "ductility_factor", "k1_change_pct"):
                if math.isnan(exp[key]):
                    assert math.isnan(getattr(got, key))
                else:
                    assert getattr(got, key) == pytest.approx(exp[key], rel=1e-6), key

    # the pier as markers, one MarkerArray per damage state: colours and labels of its states
    listener.wait(lambda: len(listener.markers) >= 2, 10, "two marker arrays")
    for markers, ev in zip(listener.markers, offline.events, strict=True):
        check_markers(markers, ev.result)

    # /diagnostics: one status per section of the last event, level from its DF class
    last = offline.events[-1].result
    listener.wait(lambda: any(any(s.name.endswith("section_1") and
                                  {kv.key: kv.value for kv in s.values}.get("event_id")
                                  == last.event_id for s in a.status)
                              for a in listener.diagnostics), 10, "section diagnostics")
    arr = next(a for a in reversed(listener.diagnostics)
               if any(s.name.endswith("section_1") for s in a.status))
    sections = [s for s in arr.status if "/section_" in s.name]
    assert len(sections) == len(last.sections)
    for st, sec in zip(sections, last.sections):
        values = {kv.key: kv.value for kv in st.values}
        assert st.level == expected_level(sec.state), st.name
        # a spring that did not yield: its DF reads "≤ 1", an upper bound
        bound = "≤ " if not sec.yielded else ""
        assert values["ductility_factor"].startswith(bound)
        assert float(values["ductility_factor"].removeprefix("≤ ")) == pytest.approx(
            sec.ductility_factor, rel=1e-5)
        assert values["ductility_factor_upper_bound"] == str(not sec.yielded).lower()
        # the second event changes from the first; the design values are apart
        assert float(values["k1_change_pct"]) == pytest.approx(sec.k1_change_pct, rel=1e-5)
        assert float(values["k1_vs_design_pct"]) == pytest.approx(sec.k1_vs_design_pct,
                                                                  rel=1e-5)
    assert interrupt(graph) == 0  # Ctrl-C stops both nodes cleanly


def test_identifier_killed_mid_training_resumes_from_the_window_on_disk(
        offline, listener, spawn_python, tmp_path):
    from pier_monitor.report.results import damage_state_fields

    event = offline.events[0]
    windows = tmp_path / "windows"
    windows.mkdir()
    shutil.copy(event.window_file, windows / f"{event.window.event_id}.npz")
    long_run = params_file(tmp_path / "long.yaml", tmp_path, max_epochs=5000, min_epochs=5000)
    ident = start_node(spawn_python, "identifier_node", long_run)
    listener.wait(lambda: len(listener.progress) >= 2, 60, "training progress")
    ident.popen.kill()  # SIGKILL mid-training
    ident.popen.wait(timeout=10)
    result_dir = tmp_path / "results" / event.window.event_id
    assert not (result_dir / "result.json").exists()

    tiny = params_file(tmp_path / "tiny.yaml", tmp_path)
    ident = start_node(spawn_python, "identifier_node", tiny)
    listener.wait(lambda: len(listener.states) >= 1, 60, "the damage state after restart")
    state = listener.states[-1]
    assert state.event_id == event.window.event_id and state.success
    assert (result_dir / "result.json").is_file() and (result_dir / "damage_state.mcap").is_file()
    want = damage_state_fields(event.result)
    np.testing.assert_allclose([s.ductility_factor for s in state.sections],
                               [s["ductility_factor"] for s in want["sections"]], rtol=1e-6)
    assert interrupt(ident) == 0


def test_identifier_interrupted_mid_training_keeps_the_window_and_its_context_to_the_end(
        offline, listener, spawn_python, tmp_path):
    # Ctrl-C mid-training: the training ends at its next epoch, the window stays pending for
    # the next start, and the rclpy context is shut down only after the worker stopped (the
    # worker's last log line reaches /rosout; were the context shut down by the signal, as
    # rclpy's own handler does, the log would say "publisher's context is invalid")
    from pier_monitor.store import ResultsStore

    event_id = offline.events[0].window.event_id
    windows = tmp_path / "windows"
    windows.mkdir()
    shutil.copy(offline.events[0].window_file, windows / f"{event_id}.npz")
    long_run = params_file(tmp_path / "long.yaml", tmp_path, max_epochs=5000, min_epochs=5000)
    ident = start_node(spawn_python, "identifier_node", long_run)
    listener.wait(lambda: len(listener.progress) >= 2, 60, "training progress")
    assert interrupt(ident) == 0
    log = "\n".join(ident.read_rest())
    assert f"{event_id}: training stopped at shutdown; the window stays stored" in log, log
    assert "context is invalid" not in log and "Traceback" not in log, log
    store = ResultsStore(tmp_path / "results")
    assert not store.is_done(event_id)
    assert [w.event_id for w in store.pending(windows).windows] == [event_id]


def test_bad_parameters_bad_messages_and_failed_training_keep_the_nodes_running(
        offline, listener, rclpy_context, spawn_python, tmp_path):
    from pier_monitor_msgs.msg import SampleBlock
    from rclpy.parameter import Parameter
    from rclpy.parameter_client import AsyncParameterClient
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Imu

    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.nodes.qos import SENSOR_QOS

    config_path = find_config_file("edefense_like.yaml")
    config = load_config(config_path)
    event = offline.events[0]
    (tmp_path / "windows").mkdir()
    shutil.copy(event.window_file, tmp_path / "windows" / f"{event.window.event_id}.npz")
    # device cuda on a machine without a GPU: the training fails, an error state results
    params = params_file(tmp_path / "p.yaml", tmp_path, device="cuda")
    ingest = start_node(spawn_python, "ingest_node", params, "-p",
                        f"config_file:={config_path}")
    ident = start_node(spawn_python, "identifier_node", params)

    listener.wait(lambda: len(listener.states) >= 1, 30, "the failed damage state")
    failed = listener.states[-1]
    assert not failed.success and failed.overall_state == 3 and "cuda" in failed.message
    assert all(s.state == 3 for s in failed.sections)

    node = listener.node

    def set_param(target: str, name: str, value: Any) -> Any:
        client = AsyncParameterClient(node, f"{NS}/{target}")
        assert client.wait_for_services(timeout_sec=10)
        future = client.set_parameters([Parameter(name, value=value)])
        deadline = time.monotonic() + 10
        while not future.done() and time.monotonic() < deadline:
            time.sleep(0.05)
        return future.result().results[0]

    bad = [("ingest", "status_period_s", -1.0, "status_period_s|range|bound"),
           ("ingest", "window_dir", "/elsewhere", "read-only|read only"),
           ("identifier", "device", "gpu", "device"),
           ("identifier", "min_epochs", 100000, "min_epochs"),
           ("identifier", "max_epochs", 0, "max_epochs|range|bound")]
    for target, name, value, reason in bad:
        res = set_param(target, name, value)
        assert not res.successful and res.reason, (name, value)
        assert __import__("re").search(reason, res.reason), res.reason
    assert set_param("identifier", "device", "cpu").successful

    spec = config.sensors[0]
    topic = f"{NS}/{spec.topic.lstrip('/')}"
    pub = node.create_publisher(SampleBlock, topic, SENSOR_QOS)
    listener.wait(lambda: pub.get_subscription_count() > 0, 10, "the ingest subscription")

    def block(**changes: Any) -> Any:
        msg = SampleBlock(sensor_id=spec.sensor_id, kind=0, unit=spec.unit,
                          sample_rate_hz=config.sample_rate_hz, first_sample_index=0,
                          axes=list(spec.axes), data=[0.0] * (10 * len(spec.axes)))
        msg.header.stamp.sec = 1_700_000_000
        for k, v in changes.items():
            setattr(msg, k, v)
        return msg

    pub.publish(b"\x00\x01\x00\x00 not a SampleBlock")  # malformed CDR
    pub.publish(block(unit="furlong"))                  # contradicts the sensor map
    pub.publish(serialize_message(Imu()))               # bytes of another type
    pub.publish(block(first_sample_index=2 ** 63))     # an index beyond int64
    pub.publish(block())                                # a good block still counts
    no_clock = block(first_sample_index=10)
    no_clock.header.stamp.sec = 0                       # a logger without a clock yet
    pub.publish(no_clock)
    listener.wait(lambda: listener.ingest_values().get("messages_dropped") == "4"
                  and listener.ingest_values().get("samples_received") == "10", 15,
                  "four dropped messages and one good block in the ingest status")
    assert ingest.popen.poll() is None and ident.popen.poll() is None
    assert interrupt(ingest) == 0 and interrupt(ident) == 0
    log = "\n".join(ingest.read_rest())
    assert f"{topic}: dropped a message" in log and "furlong" in log
    node.destroy_publisher(pub)


def imu_params(path: Path, data: Path, imu_ids: list[str]) -> Path:
    """ros__parameters of an ingest node whose ``imu_ids`` sensors publish sensor_msgs/Imu."""
    import yaml

    path.write_text(yaml.safe_dump({"/**/ingest": {"ros__parameters": {
        "window_dir": str(data / "windows"), "status_period_s": 0.3,
        "imu_sensor_ids": imu_ids}}}))
    return path


@pytest.mark.timeout(60)
def test_imu_samples_are_counted_one_per_message_and_bad_imu_messages_dropped(
        listener, spawn_python, tmp_path):
    from pier_monitor_msgs.msg import SampleBlock
    from rclpy.duration import Duration
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Imu
    from std_msgs.msg import String

    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.nodes.qos import LATCHED_QOS, SENSOR_QOS

    config = load_config(find_config_file("edefense_like.yaml"))
    specs = {s.sensor_id: s for s in config.sensors}
    good, gal = specs["l0_acc_nw"], specs["l0_acc_ne"]  # m/s^2 (Imu-able) and gal (not)
    assert good.unit == "m/s^2" and gal.unit == "gal" and gal.kind == "acceleration"
    params = imu_params(tmp_path / "imu.yaml", tmp_path, [good.sensor_id, gal.sensor_id])
    ingest = start_node(spawn_python, "ingest_node", params)

    node = listener.node
    config_pub = node.create_publisher(String, f"{NS}/pier_configuration", LATCHED_QOS)
    config_pub.publish(String(data=config.to_yaml()))
    pubs = {s.sensor_id: node.create_publisher(Imu, f"{NS}/{s.topic.lstrip('/')}", SENSOR_QOS)
            for s in (good, gal)}
    listener.wait(lambda: all(p.get_subscription_count() > 0 for p in pubs.values()), 15,
                  "the ingest's Imu subscriptions (made once it has the configuration)")
    time.sleep(0.3)  # let the new reader match the writer completely

    period_ns = round(1e9 / config.sample_rate_hz)
    t0_ns = 1_700_000_000 * 10**9

    def imu(i: int, sid: str, acc: tuple[float, float, float]) -> Any:
        msg = Imu()  # one sample, recorded values in the sensor's own axes, m/s^2
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t0_ns + i * period_ns, 10**9)
        msg.header.frame_id = sid
        msg.orientation_covariance[0] = -1.0  # no orientation estimate
        msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = acc
        return msg

    at_rest = tuple(float(o) for o in good.offsets)  # gravity on z, as the map records it
    sent = 0
    for i in range(40):
        if i == 20:
            continue  # one sample lost: a gap of one sample, not a shift of the rest
        pubs[good.sensor_id].publish(imu(i, good.sensor_id, at_rest))
        sent += 1
        time.sleep(0.002)
    pubs[good.sensor_id].publish(imu(40, good.sensor_id, (math.nan, 0.0, 9.8)))  # kept:
    sent += 1  # the ingest marks NaN/Inf samples missing, as in a SampleBlock
    no_acc = imu(41, good.sensor_id, at_rest)
    no_acc.linear_acceleration_covariance[0] = -1.0  # "no linear acceleration estimate"
    pubs[good.sensor_id].publish(no_acc)
    pubs[good.sensor_id].publish(serialize_message(SampleBlock()))  # bytes of another type
    for i in range(2):  # a gal accelerometer cannot carry sensor_msgs/Imu (m/s^2 by definition)
        pubs[gal.sensor_id].publish(imu(i, gal.sensor_id, (0.0, 0.0, 980.0)))
    for pub in pubs.values():
        assert pub.wait_for_all_acked(Duration(seconds=10))

    def counted() -> bool:
        v = listener.ingest_values()
        return v.get("samples_received") == str(sent) and v.get("messages_dropped") == "4"

    listener.wait(counted, 15, f"ingest status counting {sent} Imu samples and 4 drops")
    time.sleep(0.5)  # nothing more arrives later
    status = listener.ingest_values()
    assert status["samples_received"] == status["messages_received"] == str(sent) == "40"
    assert status["messages_dropped"] == "4"
    assert status["gap_samples"] == "1" and status["duplicate_samples"] == "0"
    assert status["windows_emitted"] == "0" and status["queue_backlog"] == "0"
    assert status["last_error"].startswith((f"{NS}/{gal.topic}", f"{NS}/{good.topic}"))
    assert ingest.popen.poll() is None
    assert interrupt(ingest) == 0
    log = "\n".join(ingest.read_rest())
    assert "2 of them Imu" in log
    assert "linear_acceleration_covariance[0] == -1" in log
    assert f"sensor_msgs/Imu carries x, y, z in m/s^2 but sensor {gal.sensor_id}" in log
    assert "ingest worker:" not in log  # no exception in the worker
    for pub in (config_pub, *pubs.values()):
        node.destroy_publisher(pub)


def damage_state(event_id: str) -> Any:
    """A small PierDamageState (two sections, one NaN) for the echo/record scripts."""
    from pier_monitor_msgs.msg import PierDamageState, SectionState

    msg = PierDamageState(pier_id="edefense_pier", event_id=event_id, overall_state=1,
                          epochs=12, final_loss=math.nan, wall_time_s=3.5, device="cpu",
                          message="ok", success=True)
    msg.header.stamp.sec = 1_700_000_123
    msg.header.frame_id = "edefense_pier"
    msg.sections = [SectionState(index=i, k1=1.5e8 * (i + 1), ductility_factor=1.1 + i,
                                 state=i, k2_identifiable=bool(i)) for i in range(2)]
    return msg


@pytest.mark.timeout(60)
def test_echo_damage_state_prints_the_latched_state_and_exits_after_count(
        listener, spawn_python):
    import json

    from pier_monitor_msgs.msg import PierDamageState

    from pier_monitor.nodes.qos import DAMAGE_STATE_QOS

    script = str(REPO_ROOT / "launch_free_scripts/echo_damage_state.py")
    pub = listener.node.create_publisher(PierDamageState, f"{NS}/damage_state",
                                         DAMAGE_STATE_QOS)
    pub.publish(damage_state("run_old"))
    pub.publish(damage_state("run_07"))  # depth 1: a late subscriber gets only this one
    echo = spawn_python(RUN_SCRIPT, script, "--count", "1", "--timeout", "20",
                        "--ros-args", "-r", f"__ns:={NS}")
    line = echo.wait_for_line("DAMAGE_STATE", 20)
    # exit status 0: it stopped after one message (at the --timeout it would exit with 1)
    assert echo.popen.wait(timeout=30) == 0
    got = json.loads(line.split(" ", 1)[1])
    assert got["event_id"] == "run_07" and got["pier_id"] == "edefense_pier"
    assert got["header"]["stamp"]["sec"] == 1_700_000_123
    assert got["final_loss"] is None and got["epochs"] == 12 and got["success"] is True
    assert [s["k1"] for s in got["sections"]] == [1.5e8, 3.0e8]
    assert [s["state"] for s in got["sections"]] == [0, 1]
    assert [s["k2_identifiable"] for s in got["sections"]] == [False, True]
    assert sum(ln.startswith("DAMAGE_STATE") for ln in echo.lines) == 1
    echo.stop()

    # nothing on the topic: --timeout ends it with exit code 1
    empty = spawn_python(RUN_SCRIPT, script, "--count", "1", "--timeout", "1",
                         "--topic", "no_such_state", "--ros-args", "-r", f"__ns:={NS}")
    assert empty.popen.wait(timeout=20) == 1
    empty.stop()
    listener.node.destroy_publisher(pub)


def sample_block(cls: Any, sensor_id: str, k: int, n: int, xyz: list[float]) -> Any:
    """Block ``k`` of ``n`` three-axis samples at 200 Hz of one accelerometer (``cls`` the
    SampleBlock message class), all equal to ``xyz`` (m/s²), stamped at ``k n / 200`` s."""
    msg = cls(sensor_id=sensor_id, kind=0, unit="m/s^2", sample_rate_hz=200.0,
              first_sample_index=n * k, axes=["x", "y", "z"], data=list(xyz) * n)
    t_ns = 1_700_000_000 * 10 ** 9 + k * n * 5_000_000
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 10 ** 9)
    msg.header.frame_id = sensor_id
    return msg


@pytest.mark.timeout(60)
def test_record_topics_writes_an_mcap_that_decodes_with_mcap_ros2(
        listener, spawn_python, tmp_path, fields_equal):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from pier_monitor_msgs.msg import PierDamageState, SampleBlock
    from rclpy.duration import Duration

    from pier_monitor.nodes.qos import DAMAGE_STATE_QOS
    from pier_monitor.nodes.qos import SENSOR_QOS

    node = listener.node
    state_pub = node.create_publisher(PierDamageState, f"{NS}/damage_state", DAMAGE_STATE_QOS)
    state = damage_state("run_03")
    state_pub.publish(state)  # before the recorder starts: latched, still recorded
    block_topic = f"{NS}/sensors/level0/acc_nw"
    block_pub = node.create_publisher(SampleBlock, block_topic, SENSOR_QOS)
    out = tmp_path / "rec.mcap"
    rec = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/record_topics.py"),
                       str(out), "damage_state", "sensors/level0/acc_nw", "--duration", "6",
                       "--ros-args", "-r", f"__ns:={NS}")
    seen = {rec.wait_for_line("RECORDING", 15), rec.wait_for_line("RECORDING", 5)}
    assert {s.split()[1] for s in seen} == {f"{NS}/damage_state", block_topic}
    listener.wait(lambda: block_pub.get_subscription_count() > 0, 10, "the recorder")
    time.sleep(0.3)
    blocks = []
    for k in range(25):
        msg = sample_block(SampleBlock, "l0_acc_nw", k, 20, [float(k), 0.5, 9.81])
        block_pub.publish(msg)
        blocks.append(msg)
        time.sleep(0.01)
    assert block_pub.wait_for_all_acked(Duration(seconds=10))
    done = rec.wait_for_line("RECORDED", 20)
    assert rec.popen.wait(timeout=10) == 0
    assert done == "RECORDED 26 messages"
    rec.stop()

    decoded: dict[str, list[Any]] = {}
    with out.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, ros_msg in reader.iter_decoded_messages():
            assert channel.message_encoding == "cdr" and schema.encoding == "ros2msg"
            decoded.setdefault(channel.topic, []).append((schema.name, ros_msg))
    assert {t: len(v) for t, v in decoded.items()} == {f"{NS}/damage_state": 1,
                                                       block_topic: 25}
    (name, got), = decoded[f"{NS}/damage_state"]
    assert name == "pier_monitor_msgs/msg/PierDamageState"
    fields_equal(state, got)
    assert [n for n, _ in decoded[block_topic]] == ["pier_monitor_msgs/msg/SampleBlock"] * 25
    for want, (_, got) in zip(blocks, decoded[block_topic]):
        fields_equal(want, got)
    node.destroy_publisher(state_pub)
    node.destroy_publisher(block_pub)


@pytest.mark.timeout(60)
def test_record_topics_stopped_by_sigint_closes_a_bag_with_every_message_received(
        listener, spawn_python, tmp_path, fields_equal):
    """Ctrl-C (no --duration): exit status 0, and the mcap holds each message delivered
    before the signal, in order."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    from pier_monitor_msgs.msg import SampleBlock
    from rclpy.duration import Duration

    from pier_monitor.nodes.qos import SENSOR_QOS

    node = listener.node
    topic = f"{NS}/sensors/level1/acc_se"
    pub = node.create_publisher(SampleBlock, topic, SENSOR_QOS)
    out = tmp_path / "interrupted.mcap"
    rec = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/record_topics.py"),
                       str(out), "sensors/level1/acc_se", "--ros-args", "-r", f"__ns:={NS}")
    assert rec.wait_for_line("RECORDING", 15).split()[1] == topic
    listener.wait(lambda: pub.get_subscription_count() > 0, 10, "the recorder")
    time.sleep(0.3)
    sent = []
    for k in range(40):
        msg = sample_block(SampleBlock, "l1_acc_se", k, 50, [0.01 * k, -0.5, 9.81])
        pub.publish(msg)
        sent.append(msg)
    # every message is in the recorder's reader before the signal (reliable: acknowledged)
    assert pub.wait_for_all_acked(Duration(seconds=10))
    assert interrupt(rec, timeout_s=20) == 0
    lines = rec.read_rest()
    assert "RECORDED 40 messages" in lines
    assert not any("Traceback" in ln or "Fatal Python error" in ln for ln in lines), lines
    rec.stop()

    with out.open("rb") as f:  # finished: summary and footer written, everything decodes
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        assert summary is not None and summary.statistics.message_count == 40
        got = [(channel.topic, ros_msg)
               for _, channel, _, ros_msg in reader.iter_decoded_messages()]
    assert [t for t, _ in got] == [topic] * 40
    for want, (_, msg) in zip(sent, got, strict=True):
        fields_equal(want, msg)
    node.destroy_publisher(pub)


def test_field_network_bag_live_equals_offline(listener, spawn_python, tmp_path):
    """Accelerometers at every level and a 10 Hz GNSS receiver at the top, no wire: the live
    graph reconstructs the springs exactly as ``identify`` does for the same bag."""
    from pier_monitor.bags.synthetic_bag import write_synthetic_bag
    from pier_monitor.core.identify.methods import IdentifySettings
    from pier_monitor.pipeline import identify_bag
    from pier_monitor.report.results import damage_state_fields

    info = write_synthetic_bag(tmp_path / "field.mcap", fmt="mcap", seed=2, layout="accel",
                               gnss=True, scenario="just_yield", block_s=0.5)
    offline = identify_bag(info.bag.path, tmp_path / "offline",
                           settings=IdentifySettings.from_flat(**{**TINY, "method": "auto"}))
    coverage, = (ev.window.coverage for ev in offline.events)
    assert coverage.acceleration.all() and coverage.displacement.tolist() == [False] * 3 + [True]
    params = params_file(tmp_path / "params.yaml", tmp_path, method="auto")
    graph = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/start_graph.py"),
                         "--namespace", NS, "--params-file", str(params))
    graph.wait_for_line("READY", 30)
    graph.wait_for_line("READY", 30)
    player = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/replay_bag.py"),
                          str(info.bag.path), "--rate", "8")
    player.wait_for_line("SENT", 120)
    assert player.stop() == 0
    listener.wait(lambda: len(listener.states) >= 1, 90, "the damage state")
    live, = listener.states
    want = damage_state_fields(offline.events[0].result)
    assert live.success and live.overall_state == want["overall_state"]
    for got, exp in zip(live.sections, want["sections"], strict=True):
        assert got.state == exp["state"]
        for key in ("k1", "c", "ductility_factor"):
            assert getattr(got, key) == pytest.approx(exp[key], rel=1e-6), key
    assert interrupt(graph) == 0


@pytest.mark.timeout(120)
def test_window_messages_with_unsafe_ids_are_refused_and_the_next_window_is_identified(
        offline, listener, spawn_python, tmp_path):
    from pier_monitor_msgs.msg import MainshockWindow
    from rclpy.duration import Duration

    from pier_monitor.nodes.conversions import window_to_msg
    from pier_monitor.nodes.qos import WINDOW_QOS

    root = tmp_path / "a" / "b"
    ident = start_node(spawn_python, "identifier_node",
                       params_file(tmp_path / "p.yaml", root))
    pub = listener.node.create_publisher(MainshockWindow, f"{NS}/mainshock_window", WINDOW_QOS)
    listener.wait(lambda: pub.get_subscription_count() > 0, 15, "the identifier's subscription")
    good = offline.events[0].window
    bad = [("pier_id", "../../x", "bad_pier_1", r"'../../x' holds './'"),
           ("pier_id", "/abs/y", "bad_pier_2", r"'/abs/y' holds '/'"),
           ("event_id", "../../x", "../../x", r"'../../x' holds './'"),
           ("event_id", "a/b", "a/b", r"'a/b' holds '/'"),
           ("event_id", "", "", "empty; expected 1 to 96 characters")]
    for field, value, event_id, _ in bad:
        msg = window_to_msg(good)
        msg.event_id = event_id
        setattr(msg, field, value)
        pub.publish(msg)
    pub.publish(window_to_msg(good))  # a good window after them is still identified
    assert pub.wait_for_all_acked(Duration(seconds=10))
    listener.wait(lambda: len(listener.states) >= 1, 60, "the good window's damage state")
    assert [s.event_id for s in listener.states] == [good.event_id]
    for field, _, _, shown in bad:
        line = ident.wait_for_line(f"{field}: {shown}", 10, anywhere=True)
        assert "dropped: MessageError" in line, line
    assert ident.popen.poll() is None
    assert interrupt(ident) == 0
    written = {p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file()}
    assert written and all(p.parts[:3] == ("a", "b", "results") or p.name == "p.yaml"
                           for p in written), written
    listener.node.destroy_publisher(pub)


@pytest.mark.timeout(120)
def test_ingest_node_reports_findings_excluded_sensors_and_a_failed_event(
        listener, spawn_python, tmp_path):
    from pier_monitor.bags import write_bag

    synthetic, timeline = short_recording(seed=1)
    bag = tmp_path / "gap.mcap"  # a 2 s gap in every foundation accelerometer during run 2

    def gap(data: np.ndarray, _offsets: np.ndarray, tl: Any) -> None:
        i = idx(tl.at(2, 0.5))
        data[i:i + 400] = np.nan
    fault = edit("l0_acc_ne", gap, "l0_acc_nw", "l0_acc_sw", "l0_acc_se")
    write_bag(fault(synthetic.recording, timeline), bag, block_s=0.5)
    ingest = start_node(spawn_python, "ingest_node", params_file(tmp_path / "p.yaml", tmp_path))
    player = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/replay_bag.py"),
                          str(bag), "--rate", "8")
    player.wait_for_line("SENT", 90)
    assert player.stop() == 0

    def failed_status() -> Any:
        for arr in reversed(listener.diagnostics):
            for st in arr.status:
                if st.name.startswith(f"pier_monitor{NS}/ingest/"):
                    return st
        return None

    listener.wait(lambda: failed_status() is not None
                  and listener.ingest_values().get("windows_emitted") == "1", 60,
                  "the failed event on /diagnostics and run 1's window")
    st = failed_status()
    values = {kv.key: kv.value for kv in st.values}
    assert st.level == b"\x02" and values["status"] == "failed"  # ERROR
    assert "level 0" in st.message and "l0_acc_ne: gap_excluded" in st.message
    status = listener.ingest_values()
    assert status["events_failed"] == "1" and status["failed_events"] == values["event_id"]
    assert "l0_acc_ne" in status["excluded_sensors"].split(",")
    assert int(status["findings"]) >= 1
    main = next(s for a in reversed(listener.status) for s in a.status
                if s.name.endswith("/ingest"))
    assert main.level == b"\x01" and "excluded: " in main.message and "l0_acc_ne" in main.message
    assert len(list((tmp_path / "windows").glob("*.npz"))) == 1  # run 1 is not lost
    assert interrupt(ingest) == 0
    assert f"event {values['event_id']}: failed, no window: level 0" in "\n".join(
        ingest.read_rest())


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except FileNotFoundError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _children_of(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (FileNotFoundError, ProcessLookupError):
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


@pytest.mark.timeout(90)
def test_no_node_outlives_a_killed_launcher_or_test_process(spawn_python, tmp_path):
    # the graph launcher killed: its nodes get SIGTERM and shut down
    graph = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/start_graph.py"),
                         "--namespace", NS, "--params-file",
                         str(params_file(tmp_path / "p.yaml", tmp_path)))
    graph.wait_for_line("READY", 30)
    graph.wait_for_line("READY", 30)
    nodes = _children_of(graph.popen.pid)
    assert len(nodes) == 2 and all(_alive(p) for p in nodes)
    graph.popen.kill()
    graph.popen.wait(timeout=10)
    wait_until(lambda: not any(_alive(p) for p in nodes), 45, "the nodes to exit")
    # a test process that dies (here: SIGKILL) takes the children of start_child with it
    code = ("import os, sys, time; sys.path.insert(0, 'test'); "
            "from ros_helpers import start_child; "
            "c = start_child(['sleep', '600'], dict(os.environ), '.'); "
            "print('CHILD', c.popen.pid, flush=True); time.sleep(600)")
    parent = spawn_python(code)
    child = int(parent.wait_for_line("CHILD", 20).split()[1])
    assert _alive(child)
    parent.popen.kill()
    parent.popen.wait(timeout=10)
    wait_until(lambda: not _alive(child), 10, "the child of the killed process to die")
