#!/usr/bin/env python3
"""Record topics of the live graph to a plain mcap file (no ros2 bag).

``record_topics.py OUT.mcap TOPIC [TOPIC ...] [--duration S] [--ros-args ...]``

Each topic is subscribed raw (reliable; transient local for the latched damage state and
configuration) once it appears in the graph with its type; the bytes received are stored as
they came (never re-serialised), with the ``ros2msg`` schema of the type, so that the file
reads back with the mcap tools, ``mcap-ros2-support`` and :func:`pier_monitor.bags.read_bag`.
Stops after ``--duration`` or on Ctrl-C / SIGTERM (exit status 0 either way): the messages
already delivered are still written, the file is closed properly, and it prints
``RECORDED <n> messages``.  rclpy runs without its own signal handlers
(:func:`pier_monitor.nodes._runtime.ros_runtime`).
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from pathlib import Path
from typing import Any

import rclpy
from rclpy.node import Node

from pier_monitor import __version__
from pier_monitor.bags.types import message_definition
from pier_monitor.nodes._runtime import RosRuntime, ros_runtime
from pier_monitor.nodes.qos import LATCHED_QOS, SENSOR_QOS

_LATCHED_SUFFIXES = ("/damage_state", "/pier_configuration", "/mainshock_window")


def main(argv: list[str] | None = None) -> int:
    from mcap.writer import CompressionType, Writer

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("topics", nargs="+")
    parser.add_argument("--duration", type=float, default=0.0, help="s; 0: until Ctrl-C")
    args, ros_args = parser.parse_known_args(argv)
    with ros_runtime([sys.argv[0], *ros_args]) as runtime:
        node = runtime.add_node(rclpy.create_node("record_topics"))
        topics = [node.resolve_topic_name(t) for t in args.topics]
        with args.out.open("xb") as stream:
            writer = Writer(stream, compression=CompressionType.ZSTD)
            writer.start(profile="ros2", library=f"pier_monitor {__version__}")
            try:
                n = record(runtime, node, writer, topics, args.duration)
            finally:  # every callback has run: none can write after this
                writer.finish()
    print(f"RECORDED {n} messages", flush=True)
    return 0


def record(runtime: RosRuntime, node: Node, writer: Any, topics: list[str],
           duration: float) -> int:
    """Subscribe to ``topics`` as they appear and write what arrives, until ``duration``
    seconds have passed (0: no limit) or a stop is requested; the number of messages."""
    channels: dict[str, int] = {}
    counts = {"n": 0}
    subs = []

    def subscribe_new() -> None:
        known = dict(node.get_topic_names_and_types())
        for topic in topics:
            if topic in channels or topic not in known:
                continue
            type_name = known[topic][0]
            pkg, _, name = type_name.split("/")
            cls = getattr(importlib.import_module(f"{pkg}.msg"), name)
            msgdef, _ = message_definition(type_name)
            schema = writer.register_schema(type_name, "ros2msg", msgdef.encode())
            channel = writer.register_channel(topic, "cdr", schema)
            channels[topic] = channel

            def on_raw(raw: bytes, channel: int = channel) -> None:
                now = time.time_ns()
                writer.add_message(channel, log_time=now, data=raw, publish_time=now)
                counts["n"] += 1

            qos = LATCHED_QOS if topic.endswith(_LATCHED_SUFFIXES) else SENSOR_QOS
            subs.append(node.create_subscription(cls, topic, on_raw, qos, raw=True))
            print(f"RECORDING {topic} [{type_name}]", flush=True)

    deadline = time.monotonic() + duration if duration > 0 else math.inf
    last_scan = -math.inf

    def done() -> bool:  # called between two callbacks: also looks for new topics
        nonlocal last_scan
        if time.monotonic() - last_scan > 0.5 and len(channels) < len(topics):
            subscribe_new()
            last_scan = time.monotonic()
        return time.monotonic() >= deadline

    runtime.spin(until=done)
    runtime.drain()  # what arrived before the stop is recorded too
    return counts["n"]


if __name__ == "__main__":
    sys.exit(main())
