#!/usr/bin/env python3
"""Replay a bag into the live ROS graph, raw CDR bytes with their original header stamps.

``replay_bag.py BAG [--rate R] [--start-s S] [--end-s S] [--wait-subscribers N]
[--wait-timeout S]``

Messages go out on the bag's own (absolute) topics, paced by their log times at ``--rate``
times real time (``0``: as fast as the middleware takes them).  ``--start-s`` and
``--end-s`` play only the messages logged in ``[start, end)`` seconds after the bag's first
message (a bag replayed in parts: no message twice, none left out).  The pier configuration
topic is offered latched: the configuration in force at the start.  Before playing, the script waits until every sensor topic has
``--wait-subscribers`` subscriptions (the ingest node subscribes once it has the
configuration).  At the end it waits for reliable delivery and prints one line::

    SENT messages=<n> samples=<n> blocks=<n> seconds=<wall>

Ctrl-C / SIGTERM stop it between two messages (or waits), without that line; the exit
status is then 128 + the signal number (130 for Ctrl-C).  rclpy runs without its own signal
handlers (:func:`pier_monitor.nodes._runtime.ros_runtime`).
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import time
from pathlib import Path

import rclpy
from rclpy.duration import Duration

from pier_monitor.bags import SAMPLE_BLOCK, get_typestore
from pier_monitor.nodes._runtime import STOP_POLL_S, ros_runtime
from pier_monitor.nodes.qos import LATCHED_QOS, SENSOR_QOS


def message_class(type_name: str) -> type:
    """``pkg/msg/Type`` → the rclpy message class."""
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bag", type=Path)
    parser.add_argument("--rate", type=float, default=1.0,
                        help="times real time; 0 = as fast as possible")
    parser.add_argument("--start-s", type=float, default=0.0,
                        help="play from this many seconds after the first message")
    parser.add_argument("--end-s", type=float, default=float("inf"),
                        help="play up to (not including) this many seconds after it")
    parser.add_argument("--wait-subscribers", type=int, default=1)
    parser.add_argument("--wait-timeout", type=float, default=30.0, help="s")
    args, ros_args = parser.parse_known_args(argv)
    from rosbags.rosbag2 import Reader

    typestore = get_typestore()
    with ros_runtime([sys.argv[0], *ros_args]) as runtime:
        node = runtime.add_node(rclpy.create_node("replay_bag"))

        def interrupted() -> int:  # the exit status after a stop request
            return 128 + (runtime.signal or signal.SIGINT)

        with Reader(args.bag) as reader:
            pubs = {}
            for conn in reader.connections:
                latched = conn.topic.endswith("/pier_configuration")
                pubs[conn.topic] = node.create_publisher(
                    message_class(conn.msgtype), conn.topic, LATCHED_QOS if latched else SENSOR_QOS)
            msgs = list(reader.messages())
            first_ns = msgs[0][1]
            start_ns = first_ns + int(args.start_s * 1e9)
            end_ns = first_ns + args.end_s * 1e9
            configs = [m for m in msgs if m[0].topic.endswith("/pier_configuration")]
            # the configuration in force at the start first, then wait for the subscriptions
            config_first = ([m for m in configs if m[1] <= start_ns] or configs)[-1:]
            msgs = [m for m in msgs
                    if start_ns <= m[1] < end_ns or any(m is c for c in config_first)]
            for conn, _, raw in config_first:
                pubs[conn.topic].publish(bytes(raw))
            sensor_topics = [c.topic for c in reader.connections
                             if not c.topic.endswith("/pier_configuration")]
            deadline = time.monotonic() + args.wait_timeout
            while any(pubs[t].get_subscription_count() < args.wait_subscribers
                      for t in sensor_topics):
                if time.monotonic() > deadline:
                    missing = [t for t in sensor_topics
                               if pubs[t].get_subscription_count() < args.wait_subscribers]
                    print(f"replay_bag: no subscriber on {len(missing)} topics after "
                          f"{args.wait_timeout} s, e.g. {missing[:3]}", file=sys.stderr)
                    return 2
                if not runtime.sleep(0.05):
                    return interrupted()
            if not runtime.sleep(0.5):  # let the new readers finish matching every writer
                return interrupted()
            print(f"PLAYING {len(msgs)} messages", flush=True)
            n_msgs = n_samples = n_blocks = 0
            t0_log = max(msgs[0][1], start_ns)
            t0_wall = time.monotonic()
            # the data time of the start and the wall clock it is sent at, for latency figures
            print(f"CLOCK log_ns={t0_log} unix_s={time.time():.6f}", flush=True)
            for conn, log_ns, raw in msgs:
                if config_first and (conn, log_ns) == (config_first[0][0], config_first[0][1]):
                    n_msgs += 1
                    continue
                if args.rate > 0:
                    delay = t0_wall + (log_ns - t0_log) / 1e9 / args.rate - time.monotonic()
                    if delay > 0:
                        runtime.sleep(delay)
                if runtime.stopped:
                    return interrupted()
                pubs[conn.topic].publish(bytes(raw))
                n_msgs += 1
                if conn.msgtype == SAMPLE_BLOCK:
                    block = typestore.deserialize_cdr(raw, SAMPLE_BLOCK)
                    n_samples += len(block.data) // max(1, len(block.axes))
                    n_blocks += 1
            wall = time.monotonic() - t0_wall
            for topic, pub in pubs.items():  # up to 10 s each, a stop looked at in between
                deadline = time.monotonic() + 10.0
                while not pub.wait_for_all_acked(Duration(seconds=STOP_POLL_S)):
                    if runtime.stopped:
                        return interrupted()
                    if time.monotonic() >= deadline:
                        print(f"replay_bag: {topic}: not every subscriber acknowledged the "
                              "messages within 10 s", file=sys.stderr, flush=True)
                        break
                if runtime.stopped:
                    return interrupted()
        print(f"SENT messages={n_msgs} samples={n_samples} blocks={n_blocks} "
              f"seconds={wall:.3f}", flush=True)
        return 0


if __name__ == "__main__":
    sys.exit(main())
