"""ROS 2 nodes: the package's only rclpy / ``*_msgs`` importer (SPEC §7).

* :mod:`~pier_monitor.nodes.ingest_node` — sensor topics → streaming ingest → mainshock
  windows (written to disk, then published) and its own status;
* :mod:`~pier_monitor.nodes.identifier_node` — windows → :func:`pier_monitor.events.
  identify_window` on a worker thread → progress, latched damage state, ``/diagnostics``;
* :mod:`~pier_monitor.nodes.conversions` — messages ↔ core types (one function each way);
* :mod:`~pier_monitor.nodes.qos` — the QoS of every topic;
* ``_runtime`` (the queue worker, ``run_node`` and ``ros_runtime``: rclpy without its signal
  handlers and an ordered shutdown, also used by the launch-free scripts) and ``_params``
  (parameter declaration), shared by the nodes.

The nodes hold ROS glue only (parameters, topics, conversions, diagnostics); what happens to
the data is the library's.

Nothing here is imported by ``pier_monitor.core``, ``pinn``, ``bags`` or ``report``.
"""

from __future__ import annotations

__all__: list[str] = []
