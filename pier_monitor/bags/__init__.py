"""Bags: rosbag2 directories and plain mcap files <-> pier_monitor recordings.

Reads and writes with ``rosbags`` and ``mcap``; never imports rclpy.  See
:mod:`~pier_monitor.bags.writer` for the layout of a bag.
"""

from __future__ import annotations

from .errors import BagError
from .reader import read_bag, read_bag_config
from .synthetic_bag import (SyntheticBagInfo, default_edefense_config, truth_paths,
                            write_synthetic_bag, write_synthetic_edefense_bag)
from .types import KIND_CODES, SAMPLE_BLOCK, STRING, find_msg_dir, get_typestore
from .writer import (BagSummary, bag_format, config_topic, iter_messages, sensor_topic,
                     write_bag, write_mcap_messages)

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
