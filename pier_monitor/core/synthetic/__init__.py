"""Data with known truth: simulated shaking-table and field-network recordings, reference cases.

* :mod:`~pier_monitor.core.synthetic.shaking_table` — seeded multi-run recordings of a pier's
  sensor map and their ground truth;
* :mod:`~pier_monitor.core.synthetic.measurement` — the sensors' measurement model: rates,
  imperfections unknown to the configuration, anti-aliasing;
* :mod:`~pier_monitor.core.synthetic.layouts` — field sensor layouts derived from a full map;
* :mod:`~pier_monitor.core.synthetic.field` — the field benchmark's piers, shakings and cases;
* :mod:`~pier_monitor.core.synthetic.rc` — the RC test-bed: modified-Takeda springs (cracking,
  stiffness degradation, pinching, strength loss) with Rayleigh damping, and their truth;
* :mod:`~pier_monitor.core.synthetic.reference` — the paper's reference cases.
"""
