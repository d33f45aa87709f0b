"""Shared fixtures of the unit tests (no rclpy, no torch)."""

from __future__ import annotations

import pytest

from pier_monitor.core.model.ground_motion import synthetic_near_fault
from pier_monitor.core.synthetic.reference import table1_model
from pier_monitor.core.model.solver import simulate


@pytest.fixture(scope="session")
def table1():
    return table1_model()


@pytest.fixture(scope="session")
def table1_response(table1):
    """Table 1 pier under the default synthetic near-fault record at PGA 8 m/s², 100 Hz out."""
    geometry, params = table1
    gm = synthetic_near_fault(pga_mps2=8.0)
    return gm, simulate(geometry, params, gm.acc, gm.dt)
