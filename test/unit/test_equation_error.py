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


def test_the_method_reads_its_own_settings_and_each_method_owns_its_settings_class():
    from pier_monitor.core.identify.field import FieldSettings
    from pier_monitor.core.identify.methods import (EquationErrorMethod,
                                                    EquationErrorSettings, FieldMethod,
                                                    IdentifySettings, PinnMethod,
                                                    PinnSettings, identify)

    assert (PinnMethod.settings_type, FieldMethod.settings_type,
            EquationErrorMethod.settings_type) == (PinnSettings, FieldSettings,
                                                   EquationErrorSettings)
    for method in (PinnMethod, FieldMethod, EquationErrorMethod):  # held as <name>_settings
        assert type(getattr(IdentifySettings(), f"{method.name}_settings")) is \
            method.settings_type
    # flat keywords (the command line's, the node's, a result's) go to their owners
    flat = IdentifySettings.from_flat(method="equation_error", members=3, max_epochs=60,
                                      yield_score=40.0)
    assert (flat.method, flat.members) == ("equation_error", 3)
    assert flat.pinn_settings == PinnSettings(max_epochs=60)
    assert flat.equation_error_settings == EquationErrorSettings(yield_score=40.0)
    doc = flat.as_dict()  # written flat, as before the split
    assert doc["max_epochs"] == 60 and doc["yield_score"] == 40.0 and doc["members"] == 3
    assert not {"pinn_settings", "equation_error_settings"} & set(doc)
    assert doc["field_settings"]["max_nfev"] == FieldSettings().max_nfev
    with pytest.raises(TypeError):
        IdentifySettings.from_flat(max_epoch=60)

    # the yield test's threshold is the method's own setting: springs 1-3 yield by default,
    # none when no score can pass it
    window, _, _ = paper_case_window(moments_measured=True, seed=2)
    runs = [identify(window, IdentifySettings(method="equation_error", members=1,
                                              equation_error_settings=own)).result
            for own in (EquationErrorSettings(), EquationErrorSettings(yield_score=1e300))]
    assert [s.yielded for s in runs[0].sections] == [True] * 3 + [False] * 3
    assert [s.yielded for s in runs[1].sections] == [False] * 6
    assert runs[1].settings["yield_score"] == 1e300


def test_the_ensemble_of_perturbed_windows_holds_the_truth_and_each_member_decides_yield():
    """Randomise-then-optimise on a constructed clean case: displacements, velocities and
    accelerations exact, the measured moments with white noise of 2 % of each section's
    peak (the noise model says so).  The members fit copies with more such noise, so for
    the springs that stay elastic (a linear regression) their interval is the regression's:
    it holds the truth.  Section 3 only just yields (true DF 1.03): the members disagree."""
    import dataclasses

    from pier_monitor.core.identify.methods import DEFAULT_MEMBERS, IdentifySettings, identify
    from pier_monitor.core.ingest.window import NoiseModel

    w0, truth, resp = paper_case_window(moments_measured=True, seed=2)
    n = w0.n_levels
    sf = 0.02 * np.abs(resp.moment).max(axis=0)
    zero, unknown = np.zeros(n), np.full(n, np.nan)
    noise = NoiseModel(ag=0.0, a=zero, v=zero, x=zero, dx=unknown, dv=unknown, f=sf)
    moments = resp.moment + sf * np.random.default_rng(5).standard_normal(resp.moment.shape)
    window = dataclasses.replace(w0, x=resp.x, v=resp.v, a=resp.a, moments=moments,
                                 noise=noise)
    result = identify(window, IdentifySettings(method="equation_error", seed=0,
                                               members=16)).result
    assert result.members == 16
    assert DEFAULT_MEMBERS["equation_error"] == 16  # intervals by default on this route
    for s in result.sections:
        assert s.uncertainty.k1.std > 0 and s.uncertainty.c.std > 0  # the members differ
    for i in (3, 4, 5):  # elastic: the truth inside the 90 % intervals of k1 and c
        u = result.sections[i].uncertainty
        assert u.k1.lo <= truth.k1[i] <= u.k1.hi and u.c.lo <= truth.c[i] <= u.c.hi
        assert u.p_yielded == 0.0
        np.testing.assert_allclose(result.sections[i].k1, truth.k1[i], rtol=3e-3)
    # far beyond yield: (nearly) every member yielded; just yielding: the members disagree
    assert result.sections[1].uncertainty.p_yielded == 1.0
    assert 0.0 < result.sections[2].uncertainty.p_yielded < 1.0
    assert result.sections[2].yield_status == "may have yielded"


def test_the_global_search_minimises_the_hysteresis_cost_over_fy_exactly():
    """The profile's cost at each ratio, from one sort per ratio, is the summed squared
    residuals of one residual pass at its share, and no share of a fine grid does better;
    the search starts from local minima of distinct cost, the lowest first."""
    from pier_monitor.core.identify import equation_error as ee

    window, truth, resp = paper_case_window(moments_measured=True, seed=2)
    theta, f = resp.theta[:, 0], window.moments[:, 0]
    k1, fmax = float(truth.k1[0]), float(np.max(np.abs(f)))
    cost, share = ee._profile(f, theta, k1, fmax)
    assert cost.shape == share.shape == ee.GRID_RATIOS.shape
    assert np.all((share >= ee.SHARE_RANGE[0]) & (share <= ee.SHARE_RANGE[1]))

    def direct(r, s):
        return np.sum(ee._hyst_residual(f, theta, k1, k1 * r, fmax * s) ** 2)

    # cumulative sums: rounding of the order of the largest cost times the machine epsilon
    tol = 1e-12 * cost.max()
    np.testing.assert_allclose(cost, [direct(r, s) for r, s in zip(ee.GRID_RATIOS, share)],
                               rtol=1e-9, atol=tol)
    fine = np.linspace(*ee.SHARE_RANGE, 2001)
    for i in range(0, ee.GRID_RATIOS.size, 8):
        assert cost[i] <= min(direct(ee.GRID_RATIOS[i], s) for s in fine) + tol
    starts = ee._grid_starts(f, theta, k1, fmax)
    assert 1 <= len(starts) <= ee.GRID_POLISHED
    index = [int(np.argmin(np.abs(ee.GRID_RATIOS - x[0]))) for x in starts]
    at = [cost[i] for i in index]
    assert at == sorted(at) and len(set(at)) == len(at)
    assert at[0] == cost.min()  # the profile's lowest point is a local minimum
    # spring 1 yields at k2/k1 = truth, fy/fmax = truth: the best start is near them
    assert abs(starts[0][0] - truth.k2[0] / truth.k1[0]) < 0.05
    assert abs(starts[0][1] - truth.fy[0] / fmax) < 0.02
