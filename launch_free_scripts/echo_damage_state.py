#!/usr/bin/env python3
"""Print a pier's damage state as JSON lines, decoded from the .msg text only (no ros2 topic).

``echo_damage_state.py [--count N] [--timeout S] [--ros-args -r __ns:=/edefense_pier]``

The subscription is raw (reliable, transient local: the latest diagnosis arrives even when
it was published before this script started); each message is decoded with ``rosbags``
from the message definitions of ``msg_defs/`` and printed as ``DAMAGE_STATE {json}``.
Ctrl-C / SIGTERM end it in order (rclpy without its own signal handlers:
:func:`pier_monitor.nodes._runtime.ros_runtime`); the exit status is 1 when ``--count``
messages were asked for and fewer came, 0 otherwise.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import rclpy
from pier_monitor_msgs.msg import PierDamageState

from pier_monitor.bags import get_typestore
from pier_monitor.nodes._runtime import ros_runtime
from pier_monitor.nodes.qos import DAMAGE_STATE_QOS

TYPE = "pier_monitor_msgs/msg/PierDamageState"


def as_plain(obj: Any) -> Any:
    """A rosbags message as JSON-ready values (NaN → None)."""
    if hasattr(obj, "__dataclass_fields__"):
        return {k: as_plain(getattr(obj, k)) for k in obj.__dataclass_fields__
                if k != "__msgtype__"}
    if isinstance(obj, float):
        return None if math.isnan(obj) else obj
    if isinstance(obj, (list, tuple)) or hasattr(obj, "tolist"):
        return [as_plain(v) for v in (obj.tolist() if hasattr(obj, "tolist") else obj)]
    return obj


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--topic", default="damage_state")
    parser.add_argument("--count", type=int, default=0, help="exit after N messages (0: never)")
    parser.add_argument("--timeout", type=float, default=0.0, help="s; 0: none")
    args, ros_args = parser.parse_known_args(argv)
    typestore = get_typestore()
    received = 0

    def on_raw(raw: bytes) -> None:
        nonlocal received
        msg = typestore.deserialize_cdr(raw, TYPE)
        print("DAMAGE_STATE " + json.dumps(as_plain(msg)), flush=True)
        received += 1

    with ros_runtime([sys.argv[0], *ros_args]) as runtime:
        node = runtime.add_node(rclpy.create_node("echo_damage_state"))
        node.create_subscription(PierDamageState, args.topic, on_raw, DAMAGE_STATE_QOS,
                                 raw=True)
        deadline = time.monotonic() + args.timeout if args.timeout > 0 else math.inf
        runtime.spin(until=lambda: (0 < args.count <= received)
                     or time.monotonic() >= deadline)
    return 0 if args.count <= 0 or received >= args.count else 1


if __name__ == "__main__":
    sys.exit(main())
