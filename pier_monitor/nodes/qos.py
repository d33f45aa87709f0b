"""QoS profiles of the pier_monitor topics (shared by the nodes and the launch-free scripts)."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ["SENSOR_QOS", "IMU_QOS", "LATCHED_QOS", "WINDOW_QOS", "DAMAGE_STATE_QOS",
           "TF_STATIC_QOS"]

#: Sensor streams: reliable with a deep queue (a 0.1 s block per message and sensor), so that
#: a short stall of the executor loses nothing.
SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                        reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.VOLATILE)
#: Per-sample Imu streams: best effort, so that the usual sensor-data publishers of IMU
#: drivers (best effort) connect as well as reliable ones; a lost message shows as a gap.
IMU_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2000,
                     reliability=ReliabilityPolicy.BEST_EFFORT,
                     durability=DurabilityPolicy.VOLATILE)
#: Latched configuration / results: late subscribers get the latest.
LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: Windows: the last ten stay available to an identifier that (re)starts late.
WINDOW_QOS = LATCHED_QOS
#: Damage state, latched with depth 1: a late subscriber gets the latest diagnosis.
DAMAGE_STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                              reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: /tf_static as tf2_ros.StaticTransformBroadcaster offers it: latched, depth 1.
TF_STATIC_QOS = DAMAGE_STATE_QOS
