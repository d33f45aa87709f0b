"""The ROS-free, torch-free core of pier_monitor: numpy and scipy, yaml for the pier
configuration, numba to compile the solver's and springs' loops where it is installed (the
same code runs as plain Python without it).

The sub-packages follow the flow of data and import only downward:

* :mod:`~pier_monitor.core.model` — pier configuration, link model, Newmark solver, spring
  families, ground motions, units;
* :mod:`~pier_monitor.core.ingest` — recordings of raw sensor streams, cleaning, per-level
  fusion, mainshock detection, the measured window;
* :mod:`~pier_monitor.core.identify` — the front door (the methods behind one
  ``identify``), the equation-error fit, the spring families, the field reconstruction, the
  damage indices and states, ensembles and self-checks;
* :mod:`~pier_monitor.core.synthetic` — simulated shaking-table and field-network
  recordings, the RC test-bed and reference cases with known truth.

``errors`` (the exception hierarchy) and ``resources`` (data files) serve them all.
"""
