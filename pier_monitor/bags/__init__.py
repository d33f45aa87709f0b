"""Bags: rosbag2 directories and plain mcap files <-> pier_monitor recordings.

Reads and writes with ``rosbags`` and ``mcap``; never imports rclpy.  See
:mod:`~pier_monitor.bags.writer` for the layout of a bag.
"""

from __future__ import annotations

from pier_monitor.core.lazy import lazy_names


#: Where each public name lives: loaded on first use (PEP 562), so that importing one
#: submodule does not load the others' heavy dependencies.
_LAZY = {
    "BagError": "errors",
    "BagSummary": "writer",
    "KIND_CODES": "types",
    "SAMPLE_BLOCK": "types",
    "STRING": "types",
    "SyntheticBagInfo": "synthetic_bag",
    "bag_format": "writer",
    "config_topic": "writer",
    "default_edefense_config": "synthetic_bag",
    "find_msg_dir": "types",
    "get_typestore": "types",
    "iter_messages": "writer",
    "read_bag": "reader",
    "read_bag_config": "reader",
    "sensor_topic": "writer",
    "truth_paths": "synthetic_bag",
    "write_bag": "writer",
    "write_mcap_messages": "writer",
    "write_synthetic_bag": "synthetic_bag",
    "write_synthetic_edefense_bag": "synthetic_bag",
}


__all__ = [
    "BagError",
    "BagSummary",
    "KIND_CODES",
    "SAMPLE_BLOCK",
    "STRING",
    "SyntheticBagInfo",
    "bag_format",
    "config_topic",
    "default_edefense_config",
    "find_msg_dir",
    "get_typestore",
    "iter_messages",
    "read_bag",
    "read_bag_config",
    "sensor_topic",
    "truth_paths",
    "write_bag",
    "write_mcap_messages",
    "write_synthetic_bag",
    "write_synthetic_edefense_bag",
]

__getattr__, __dir__ = lazy_names(__name__, _LAZY, __all__)
