"""pier_monitor_msgs built from msg_defs/: real rclpy serialisation, rosbags decoding, DDS.

These run against the message package that scripts/setup_env.sh builds into the venv.
"""

from __future__ import annotations

import math
import time

import pytest

pytestmark = [pytest.mark.ros, pytest.mark.timeout(60)]


def sample_block():
    from pier_monitor_msgs.msg import SampleBlock

    msg = SampleBlock()
    msg.header.stamp.sec = 1_700_000_000
    msg.header.stamp.nanosec = 5_000_000
    msg.header.frame_id = "A3-NE"
    msg.sensor_id = "A3-NE"
    msg.kind = SampleBlock.KIND_ACCELERATION
    msg.unit = "gal"
    msg.sample_rate_hz = 200.0
    msg.first_sample_index = 2**40 + 7  # beyond 32 bits: long recordings
    msg.axes = ["x", "y", "z"]
    msg.data = [0.25 * i - 3.0 for i in range(3 * 40)]
    return msg


def damage_state():
    from pier_monitor_msgs.msg import PierDamageState, SectionState

    msg = PierDamageState()
    msg.header.stamp.sec = 1_700_000_100
    msg.header.frame_id = "pier_p1"
    msg.pier_id = "P1"
    msg.event_id = "run-3"
    msg.window_start.sec = 1_700_000_010
    msg.window_start.nanosec = 250_000_000
    msg.window_duration_s = 20.48
    for index, (df, state) in enumerate([(0.8, SectionState.STATE_INTACT),
                                         (1.3, SectionState.STATE_SUSPICIOUS),
                                         (2.1, SectionState.STATE_DAMAGED)]):
        section = SectionState()
        section.index = index
        section.z_bottom_m = 1.5 * index
        section.z_top_m = 1.5 * (index + 1)
        section.k1 = 1.0e9 * (1.0 - 0.1 * index)
        section.k2 = section.k1 / 10.0
        section.fy = 5.0e6
        section.c = 2.5e6
        section.yield_angle_rad = section.fy / section.k1
        section.ductility_factor = df
        section.max_angle_rad = df * section.yield_angle_rad
        section.k1_change_pct = math.nan if index == 0 else -12.5 * index  # no baseline: NaN
        section.k2_identifiable = section.fy_identifiable = df >= 1.0
        section.state = state
        msg.sections.append(section)
    msg.overall_state = SectionState.STATE_DAMAGED
    msg.epochs = 3000
    msg.final_loss = 1.25e-4
    msg.wall_time_s = 95.5
    msg.device = "cpu"
    msg.message = "3 sections: intact, suspicious, damaged (DF 2.10 at 3.0–4.5 m)"
    msg.success = True
    return msg


def mainshock_window():
    from pier_monitor_msgs.msg import MainshockWindow

    n_samples, n_levels = 50, 3
    msg = MainshockWindow()
    msg.header.stamp.sec = 1_700_000_010
    msg.pier_id = "P1"
    msg.event_id = "run-3"
    msg.sample_rate_hz = 100.0
    msg.n_levels = n_levels
    msg.n_samples = n_samples
    msg.time_s = [12.5 + 0.01 * i for i in range(n_samples)]
    msg.section_heights_m = [1.5, 1.5, 4.35]
    msg.masses_kg = [9600.0, 9600.0, 1033800.0]
    msg.design_k1 = [1.0e9, 0.9e9, 1.0e9]
    msg.design_k2 = [1.0e8, 0.9e8, 1.0e8]
    msg.design_fy = [5.0e6, 4.5e6, 5.0e6]
    msg.design_c = [2.0e7, 2.2e7, 2.0e7]
    msg.ground_acceleration = [math.sin(0.1 * i) for i in range(n_samples)]
    msg.acceleration = [0.01 * i for i in range(n_samples * n_levels)]
    msg.velocity = [-0.001 * i for i in range(n_samples * n_levels)]
    msg.displacement = [1e-5 * i if i % 3 else math.nan for i in range(n_samples * n_levels)]
    msg.ground_acceleration_sigma = 1e-3
    msg.acceleration_sigma = [0.02, 0.03, 0.05]
    msg.velocity_sigma = [0.002, 0.003, 0.004]
    msg.displacement_sigma = [1e-4, 2e-4, 3e-4]
    msg.displacement_increment_sigma = [1e-6, 2e-6, math.nan]
    msg.velocity_increment_sigma = [1e-5, 2e-5, 3e-5]
    msg.moment_sigma = [math.nan] * n_levels
    msg.gain_sigma_rel = 0.01
    msg.acceleration_measured = [True, True, True]
    msg.displacement_measured = [False, True, True]
    msg.highpass_hz = 0.1
    msg.pier_config_yaml = "pier_id: P1\nlevels: [1.5, 3.0, 7.35]\n"
    msg.report = '{"principal_direction_deg": 12.5, "dropped_samples": 0}'
    return msg


def identification_progress():
    from pier_monitor_msgs.msg import IdentificationProgress

    msg = IdentificationProgress()
    msg.event_id = "run-3"
    msg.epoch = 120
    msg.max_epochs = 3000
    msg.loss = 0.031
    msg.loss_terms = [0.02, 0.01, 0.001]
    msg.loss_term_names = ["data_displacement", "data_acceleration", "physics"]
    msg.k1 = [1.0e9, 0.9e9]
    msg.k2 = [1.0e8, 0.9e8]
    msg.fy = [5.0e6, 4.5e6]
    msg.c = [2.5e6, 2.5e6]
    msg.elapsed_s = 3.75
    return msg


MESSAGES = {
    "SampleBlock": sample_block,
    "PierDamageState": damage_state,
    "MainshockWindow": mainshock_window,
    "IdentificationProgress": identification_progress,
}


def test_message_classes_import_and_sample_block_roundtrips_through_rclpy(fields_equal):
    import rclpy  # noqa: F401 - the real middleware, not a stand-in
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from pier_monitor_msgs.msg import SampleBlock, SectionState
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import Imu

    assert (SampleBlock.KIND_ACCELERATION, SampleBlock.KIND_DISPLACEMENT,
            SampleBlock.KIND_VELOCITY) == (0, 1, 2)
    from pier_monitor.core.identify.states import DamageState

    assert {s.name: int(s) for s in DamageState} == {
        name: getattr(SectionState, f"STATE_{name}") for name in
        ("INTACT", "SUSPICIOUS", "DAMAGED", "UNKNOWN", "UNRELIABLE")} == {
        "INTACT": 0, "SUSPICIOUS": 1, "DAMAGED": 2, "UNKNOWN": 3, "UNRELIABLE": 4}
    assert DiagnosticStatus.WARN == b"\x01" and Imu().linear_acceleration.x == 0.0
    assert DiagnosticArray().status == []

    msg = sample_block()
    data = serialize_message(msg)
    decoded = deserialize_message(data, SampleBlock)
    assert decoded == msg
    fields_equal(msg, decoded)
    assert len(decoded.data) == len(decoded.axes) * 40


@pytest.mark.parametrize("name", sorted(MESSAGES))
def test_rclpy_bytes_decode_with_rosbags_typestore_and_back(name, msg_typestore, fields_equal):
    from rclpy.serialization import deserialize_message, serialize_message

    msg = MESSAGES[name]()
    msgtype = f"pier_monitor_msgs/msg/{name}"

    decoded = msg_typestore.deserialize_cdr(serialize_message(msg), msgtype)
    assert decoded.__msgtype__ == msgtype
    fields_equal(msg, decoded)

    # And the other way: bytes written by rosbags (e.g. from a bag) decode in rclpy, which
    # takes bytes only (rosbags returns a memoryview).
    back = deserialize_message(bytes(msg_typestore.serialize_cdr(decoded, msgtype)), type(msg))
    fields_equal(msg, back)


def test_bytes_on_the_wire_decode_with_rosbags_and_bag_bytes_replay_into_the_graph(
        rclpy_context, msg_typestore, fields_equal):
    """What a recorder stores (raw subscription) and what a replay publishes (bag bytes).

    A MainshockWindow with an empty sigma sequence on purpose: rclpy.serialization's
    serialize_message() returns the rmw's size *estimate* for such messages, with trailing
    junk bytes that rosbags rejects ("CDR message size mismatch"); the bytes DDS delivers are
    exact. Recorders must store the raw bytes received, never re-serialise with rclpy.
    """
    import rclpy
    from pier_monitor_msgs.msg import MainshockWindow
    from rclpy.executors import SingleThreadedExecutor

    sent = mainshock_window()
    sent.velocity_sigma = []  # unknown: allowed by the message definition
    msgtype = "pier_monitor_msgs/msg/MainshockWindow"

    node = rclpy.create_node("wire_bytes", context=rclpy_context)
    executor = SingleThreadedExecutor(context=rclpy_context)
    raw, typed = [], []
    try:
        node.create_subscription(MainshockWindow, "window", raw.append, 10, raw=True)
        node.create_subscription(MainshockWindow, "replayed", typed.append, 10)
        window_pub = node.create_publisher(MainshockWindow, "window", 10)
        replay_pub = node.create_publisher(MainshockWindow, "replayed", 10)
        executor.add_node(node)

        deadline = time.monotonic() + 10.0
        while not raw and time.monotonic() < deadline:  # volatile QoS: publish until matched
            window_pub.publish(sent)
            executor.spin_once(timeout_sec=0.1)
        assert raw, "no raw MainshockWindow received within 10 s"
        assert isinstance(raw[0], bytes)
        decoded = msg_typestore.deserialize_cdr(raw[0], msgtype)
        fields_equal(sent, decoded)

        bag_bytes = bytes(msg_typestore.serialize_cdr(decoded, msgtype))
        deadline = time.monotonic() + 10.0
        while not typed and time.monotonic() < deadline:
            replay_pub.publish(bag_bytes)  # a publisher takes serialised bytes as they are
            executor.spin_once(timeout_sec=0.1)
        assert typed, "the replayed bytes were not received within 10 s"
        fields_equal(sent, typed[0])
    finally:
        executor.shutdown()
        node.destroy_node()


PUBLISHER = r"""
import select, sys
import rclpy
from rclpy.context import Context
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from pier_monitor_msgs.msg import PierDamageState

msg = deserialize_message(bytes.fromhex(sys.argv[1]), PierDamageState)
context = Context()
rclpy.init(context=context)
node = rclpy.create_node("latched_damage_state_publisher", context=context)
qos = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                 reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
publisher = node.create_publisher(PierDamageState, "damage_state", qos)
publisher.publish(msg)
print("published", flush=True)
# DDS serves the latched sample to late joiners from its own threads: no spinning needed.
# Stay until the parent closes stdin (or 30 s at most).
select.select([sys.stdin], [], [], 30.0)
node.destroy_node()
rclpy.shutdown(context=context)
print("done", flush=True)
"""


def test_late_subscriber_in_other_process_receives_latched_damage_state(
        rclpy_context, spawn_python, fields_equal):
    import rclpy
    from pier_monitor_msgs.msg import PierDamageState
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.serialization import serialize_message

    sent = damage_state()
    publisher = spawn_python(PUBLISHER, serialize_message(sent).hex())
    publisher.wait_for_line("published", timeout_s=20.0)

    # Only now subscribe: a late joiner gets the sample only through TRANSIENT_LOCAL.
    node = rclpy.create_node("late_damage_state_subscriber", context=rclpy_context)
    executor = SingleThreadedExecutor(context=rclpy_context)
    received = []
    try:
        qos = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(PierDamageState, "damage_state", received.append, qos)
        executor.add_node(node)
        deadline = time.monotonic() + 15.0
        while not received and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.shutdown()
        node.destroy_node()

    assert publisher.stop() == 0, "\n".join(publisher.lines)
    assert received, "the late subscriber received no PierDamageState within 15 s"
    assert len(received) == 1
    fields_equal(sent, received[0])
