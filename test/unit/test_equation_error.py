"""The physics-only equation-error fit (the PINN's starting point)."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.core.identify.damage import ductility_factors
from pier_monitor.core.identify.equation_error import fit_equation_error
from pier_monitor.core.synthetic.reference import paper_case_window


@pytest.mark.parametrize("moments", [True, False])
def test_fit_recovers_table1_from_the_papers_starting_point(moments):
    window, truth, resp = paper_case_window(moments_measured=moments, seed=2)
    fit = fit_equation_error(window.geometry, window.x, window.v, window.a, window.ag,
                             window.design, moments=window.moments)
    est = fit.params
    np.testing.assert_allclose(est.k1, truth.k1, rtol=5e-3)
    np.testing.assert_allclose(est.c, truth.c, rtol=1e-2)
    df_true = ductility_factors(resp.theta, truth)
    # springs 1-3 yield (DF 4.9, 3.8, 1.03), 4-6 do not
    assert fit.yielded.tolist() == [True, True, True, False, False, False]
    np.testing.assert_allclose(est.k2[:2], truth.k2[:2], rtol=1e-2)
    np.testing.assert_allclose(est.fy[:3], truth.fy[:3], rtol=1e-2)
    df_est = ductility_factors(resp.theta, est)
    np.testing.assert_allclose(df_est[:3], df_true[:3], rtol=1e-2)
    # elastic springs: fy is only the lower bound max|f|, so DF comes out as about 1
    assert np.all(df_est[3:] <= 1.001) and np.all(df_est[3:] > df_true[3:])


def test_window_file_round_trip_and_damage(tmp_path):
    from pier_monitor.core.errors import InputDataError
    from pier_monitor.core.ingest.window import load_window, save_window

    window, _, _ = paper_case_window(moments_measured=True, seed=0)
    path = save_window(window, tmp_path / "w.npz")
    back = load_window(path)
    assert back == window  # every field, noise model and coverage included
    cut = tmp_path / "cut.npz"
    cut.write_bytes(path.read_bytes()[:1000])
    with pytest.raises(InputDataError, match="cut.npz: not a readable window file"):
        load_window(cut)
