"""The typed window: noise model, coverage of partial sensor layouts, npz round trip."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.window import (Coverage, MeasuredWindow, NoiseModel, load_window,
                                             save_window)
from pier_monitor.core.synthetic.reference import paper_case_window


def _sparse(window: MeasuredWindow) -> MeasuredWindow:
    """The window as a field network sees it: accelerometers at levels 3 and 6 only."""
    acc = np.zeros(6, dtype=bool)
    acc[[2, 5]] = True
    cov = Coverage(acceleration=acc, displacement=np.zeros(6, dtype=bool), highpass_hz=0.1)
    nan = lambda arr: np.where(acc, arr, np.nan)
    return MeasuredWindow(window.pier_id, "sparse", window.geometry, window.design, window.t,
                          window.ag, nan(window.a), nan(window.v), nan(window.x),
                          noise=window.noise, coverage=cov, start_time_ns=17)


def test_sparse_window_round_trips_every_field_through_npz(tmp_path):
    window = _sparse(paper_case_window(moments_measured=False, seed=0)[0])
    assert window.coverage.layout == "sparse"
    back = load_window(save_window(window, tmp_path / "w.npz"))
    assert back == window
    assert np.isnan(back.a[:, 0]).all() and np.isfinite(back.a[:, 2]).all()


def test_window_rejects_data_that_contradict_its_coverage():
    full, _, _ = paper_case_window(moments_measured=False, seed=0)
    cov = Coverage(np.array([True] * 5 + [False]), np.zeros(6, dtype=bool))
    with pytest.raises(InputDataError, match="window a: level 6 is not measured"):
        MeasuredWindow("p", "e", full.geometry, full.design, full.t, full.ag, full.a, full.v,
                       full.x, coverage=cov)
    a = np.array(full.a)
    a[3, 1] = np.nan
    with pytest.raises(InputDataError, match="window a: level 2 is measured but has non-finite"):
        MeasuredWindow("p", "e", full.geometry, full.design, full.t, full.ag, a, full.v, full.x)


def test_noise_model_validates_and_defaults_to_unknown():
    noise = NoiseModel.unknown(3)
    assert np.isnan(noise.a).all() and np.isnan(noise.ag)
    assert NoiseModel.from_dict(noise.as_dict()) == noise
    with pytest.raises(InputDataError, match="noise v: expected 3 non-negative values"):
        NoiseModel(ag=1e-3, a=np.ones(3), v=-np.ones(3), x=np.ones(3), dx=np.ones(3),
                   dv=np.ones(3), f=np.ones(3))
