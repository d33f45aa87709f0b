"""Kalman/RTS fusion of accelerations and wire displacements."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.fusion import fuse_acceleration_displacement


def motion(rate_hz: float = 200.0, duration_s: float = 30.0):
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    comps = [(0.02, 0.5, 0.3), (0.01, 1.3, 1.0), (0.003, 4.0, 2.0)]  # amplitude m, Hz, phase
    w = lambda f: 2 * np.pi * f
    x = sum(a * np.sin(w(f) * t + p) for a, f, p in comps)
    v = sum(a * w(f) * np.cos(w(f) * t + p) for a, f, p in comps)
    acc = sum(-a * w(f) ** 2 * np.sin(w(f) * t + p) for a, f, p in comps)
    return t, x, v, acc


def test_fusion_recovers_velocity_and_displacement_below_the_sensor_noise():
    t, x, v, acc = motion()
    rng = np.random.default_rng(0)
    sa, sx = 1e-3, 1e-4
    acc_m = (acc + sa * rng.standard_normal(acc.shape))[:, None]
    x_m = (x + sx * rng.standard_normal(x.shape))[:, None]
    fused = fuse_acceleration_displacement(acc_m, x_m, 200.0, sa, sx)
    inner = slice(200, -200)
    v_err = np.sqrt(np.mean((fused.v[inner, 0] - v[inner]) ** 2))
    x_err = np.sqrt(np.mean((fused.x[inner, 0] - x[inner]) ** 2))
    assert v_err < 5e-4  # m/s: under 0.5 mm/s
    assert x_err < sx  # below the wire noise
    # the reported uncertainty has the right order of magnitude (it is optimistic by up to
    # ~3x: the trapezoid rule's error is not white, which the model assumes)
    assert 0.5 < v_err / fused.v_sigma[inner, 0].mean() < 4.0
    assert 0.5 < x_err / fused.x_sigma[inner, 0].mean() < 4.0
    # plain integration of the accelerometer with a linear detrend is far worse
    v_int = np.concatenate(([0.0], np.cumsum(0.5 * (acc_m[1:, 0] + acc_m[:-1, 0])) / 200.0))
    v_int -= np.polyval(np.polyfit(t, v_int, 1), t)
    assert np.sqrt(np.mean((v_int[inner] - v[inner]) ** 2)) > 3 * v_err


def test_fusion_rejects_bad_input():
    with pytest.raises(InputDataError, match="expected equal shapes"):
        fuse_acceleration_displacement(np.zeros((100, 2)), np.zeros((100, 3)), 200.0, 1e-3, 1e-4)
    bad = np.zeros((100, 1))
    bad[5, 0] = np.nan
    with pytest.raises(InputDataError, match="non-finite"):
        fuse_acceleration_displacement(bad, np.zeros((100, 1)), 200.0, 1e-3, 1e-4)
    with pytest.raises(InputDataError, match="must be positive"):
        fuse_acceleration_displacement(np.zeros((100, 1)), np.zeros((100, 1)), 200.0, 0.0, 1e-4)
