"""ROS 2 nodes: the package's only rclpy / ``*_msgs`` importer (SPEC §7).

* :mod:`~pier_monitor.nodes.ingest_node` — sensor topics → streaming ingest → mainshock
  windows (written to disk, then published) and its own status;
* :mod:`~pier_monitor.nodes.identifier_node` — windows → PINN on a worker thread →
  progress, latched damage state, ``/diagnostics`` and results on disk (mcap);
* :mod:`~pier_monitor.nodes.conversions` — messages ↔ core types.

Nothing here is imported by ``pier_monitor.core``, ``pinn``, ``bags`` or ``report``.
"""

from __future__ import annotations

__all__: list[str] = []
