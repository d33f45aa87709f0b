"""The ROS-free, torch-free core of pier_monitor (numpy/scipy only).

The sub-packages follow the flow of data and import only downward:

* :mod:`~pier_monitor.core.model` — pier configuration, link model, Newmark solver, ground
  motions, units;
* :mod:`~pier_monitor.core.ingest` — recordings of raw sensor streams, cleaning, per-level
  fusion, mainshock detection, the measured window;
* :mod:`~pier_monitor.core.identify` — the equation-error fit and the damage indices;
* :mod:`~pier_monitor.core.synthetic` — simulated shaking-table and field-network
  recordings and reference cases with known truth.

``errors`` (the exception hierarchy) and ``resources`` (data files) serve them all.
"""
