"""The field reconstruction (``method="field"``) on synthetic field-network windows with
imperfect sensors: springs, yield decisions, states, ensembles and the method choice."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pier_monitor.bench import field_case
from pier_monitor.core.errors import IdentificationError
from pier_monitor.core.identify.states import classify_ductility
from pier_monitor.core.identify.methods import IdentifySettings, identify


@pytest.fixture(scope="module")
def accel_case():
    return field_case("edefense", "accel", False, "strong", 0)


def _true_df(truth, theta):
    return np.abs(theta).max(axis=0) / truth.yield_angles


def test_accelerometers_alone_give_the_yielded_springs_and_every_state(accel_case):
    window, truth, theta = accel_case
    assert window.coverage.acceleration.all() and not window.coverage.displacement.any()
    run = identify(window, IdentifySettings(seed=0, members=1))  # the fit, no intervals
    result = run.result
    df_true = _true_df(truth, theta)
    yielded = df_true >= 1.0
    assert [s.yielded for s in result.sections] == yielded.tolist()
    k1 = np.array([s.k1 for s in result.sections])
    assert np.abs(k1[yielded] / truth.k1[yielded] - 1).max() < 0.02
    df = np.array([s.ductility_factor for s in result.sections])
    np.testing.assert_allclose(df[yielded], df_true[yielded], rtol=0.03)
    assert [s.state for s in result.sections] == [
        classify_ductility(d).name.lower() for d in df_true]
    # every stage recorded, the reconstruction's displacements reported for every level
    assert list(run.stages) == ["increments", "springs", "joint"]
    assert np.isfinite(run.reproduced.x).all() and run.reproduced.x.shape == window.x.shape


def test_three_instrumented_levels_give_the_ductility_of_the_yielded_springs():
    window, truth, theta = field_case("edefense", "sparse", False, "strong", 1)
    assert window.coverage.acceleration.tolist() == [False, True, False, True]
    result = identify(window, IdentifySettings(seed=1, members=1)).result
    df_true = _true_df(truth, theta)
    df = np.array([s.ductility_factor for s in result.sections])
    yielded = df_true >= 1.0
    np.testing.assert_allclose(df[yielded], df_true[yielded], rtol=0.10)
    assert [s.state for s in result.sections] == [
        classify_ductility(d).name.lower() for d in df_true]


def test_an_ensemble_gives_intervals_and_state_probabilities(accel_case):
    window, truth, theta = accel_case
    result = identify(window, IdentifySettings(seed=0, members=8)).result
    for sec in result.sections:
        u = sec.uncertainty
        assert u is not None and u.k1.lo < u.k1.hi and u.k1.std > 0
        assert abs(sec.k1 - u.k1.mean) < 4 * u.k1.std
        assert sum(u.p_state) == pytest.approx(1.0)
    assert result.p_overall_state is not None


def test_every_field_member_refits_a_perturbed_window_and_decides_its_own_yield():
    """Randomise-then-optimise on the field route: member 0 is the fit itself, the others
    refit windows perturbed as the sensors allow, each deciding whether its springs yielded.
    Table-1 pier, accelerometers only, strong shaking: sections 1 and 2 are far beyond yield
    (true DF 3.19, 2.23) and every member says so (weighed against the fit's chi-square, not
    the member's own, which the perturbations raise: before, the members disagreed on
    section 2); section 3 (true DF 0.85) is near yield, and a member may call it yielded;
    the upper sections stay elastic in every member."""
    from pier_monitor.core.identify.field import fit_field

    window, truth, theta = field_case("table1", "accel", False, "strong", 0)
    fit = fit_field(window, members=9, seed=0)
    ens = fit.members
    assert ens.params.shape == (9, 6, 4)
    np.testing.assert_array_equal(ens.yielded[0], fit.yielded)
    np.testing.assert_allclose(ens.params[0, :, 0], fit.params.k1)
    p_yield = ens.yielded.mean(axis=0)
    df_true = _true_df(truth, theta)
    assert df_true[0] > 3 and p_yield[0] == 1.0
    assert df_true[1] > 2 and p_yield[1] == 1.0
    assert np.all(df_true[2:] < 1) and p_yield[2] <= 1 / 9 and np.all(p_yield[3:] == 0.0)
    # the yielded members' DFs of section 2 hold the truth
    assert ens.ductility[:, 1].min() < df_true[1] < ens.ductility[:, 1].max()
    # the members differ by the data, not by a start: every k1 moves; that of the yielded
    # section by a few percent (the fit's residuals, not only the sensors' noise, perturb
    # the members), those of springs the data say little about (the elastic upper ones) as
    # far as their prior about the design values allows
    spread = np.abs(ens.params[1:, :, 0] / ens.params[0, :, 0] - 1).max(axis=0)
    assert np.all(spread > 0) and spread[0] < 0.05 and spread[5] > 5 * spread[0]
    # a member that did not yield has its DF bound (at most 1)
    assert np.all(ens.ductility[~ens.yielded] <= 1.0 + 1e-9)


def test_the_method_choice(accel_case):
    window, _, _ = accel_case
    with pytest.raises(IdentificationError, match="method 'pinn' needs a displacement"):
        identify(window, IdentifySettings(method="pinn"))
    with pytest.raises(Exception, match="method"):
        identify(window, IdentifySettings(method="guess"))
    # without an accelerometer at the top the moments are unknown: a clear error
    cov = dataclasses.replace(window.coverage,
                              acceleration=np.array([True, True, True, False]))
    a, v, x = (getattr(window, q).copy() for q in ("a", "v", "x"))
    for arr in (a, v, x):
        arr[:, -1] = np.nan
    with pytest.raises(IdentificationError, match="top level"):
        identify(dataclasses.replace(window, coverage=cov, a=a, v=v, x=x), IdentifySettings())


def test_residual_surrogates_keep_level_spectrum_and_cross_correlation():
    """The members' residual perturbations: a phase-randomised copy of the fit's residuals has
    their amplitude spectrum per channel (so their RMS) and their cross-correlation at lag 0,
    yet is a different series."""
    from pier_monitor.core.identify.ensemble import phase_randomised

    rng = np.random.default_rng(3)
    t = np.arange(2000) * 0.01
    base = np.sin(2 * np.pi * 0.3 * t) + 0.3 * rng.standard_normal(t.size)
    res = np.column_stack([base, 0.5 * base + 0.1 * rng.standard_normal(t.size)])
    res -= res.mean(axis=0)
    sur = phase_randomised(np.random.default_rng(0), res)
    np.testing.assert_allclose(np.abs(np.fft.rfft(sur, axis=0)),
                               np.abs(np.fft.rfft(res, axis=0)), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.sqrt(np.mean(sur ** 2, axis=0)),
                               np.sqrt(np.mean(res ** 2, axis=0)), rtol=1e-9)
    np.testing.assert_allclose(np.mean(sur[:, 0] * sur[:, 1]), np.mean(res[:, 0] * res[:, 1]),
                               rtol=1e-9)
    assert np.corrcoef(sur[:, 0], res[:, 0])[0, 1] < 0.5


def test_members_decide_yield_against_the_fits_model_error_so_a_just_yielded_df_is_covered():
    """A member's data carry the perturbations drawn on purpose (noise, gains, the fit's own
    residuals times ``residual_scale``), which raise its remaining chi-square about threefold;
    its yield test weighs the gain of the yield branch against the fit's chi-square (the
    model error of the data themselves), not against its own.  E-Defense pier,
    accelerometers only, a drawn case of the held-out suite's kind on a tuning seed (624, El
    Centro record): section 2 just yielded (true DF 1.34).  Weighed against the members' own
    chi-square, 5 of 32 members kept its yield and its 90 % DF interval was [1.00, 1.29],
    short of the truth; now most members yield and the interval holds it."""
    from pier_monitor.bench_heldout import heldout_case
    from pier_monitor.core.identify.field import fit_field
    from pier_monitor.core.identify.uncertainty import summarize_members

    window, truth, true_df, yielded, _ = heldout_case("edefense", "accel", 624)
    assert yielded[1] and 1.3 < true_df[1] < 1.4 and not yielded[2:].any()
    fit = fit_field(window, members=32, seed=624)
    ens = fit.members
    assert fit.yielded[1]
    p_yield = ens.yielded.mean(axis=0)
    assert p_yield[0] == 1.0 and p_yield[1] >= 0.5
    # the elastic sections above: the fit does not yield them, and few members do (none on
    # one CPU, 4 and 1 of 32 on another: a member's yield test near its threshold goes
    # either way with the floating-point rounding; such a section is "may have yielded",
    # never damaged)
    assert not fit.yielded[2:].any() and np.all(p_yield[2:] <= 0.2)
    u = summarize_members(ens.params, ens.ductility, ens.yielded)
    df = u[1].ductility_factor
    assert df.lo <= true_df[1] <= df.hi
    assert df.hi - df.lo < 0.6  # an interval, not everything
    # the well-identified section 1 (true DF 2.63) stays narrow and right
    assert u[0].ductility_factor.lo <= true_df[0] <= u[0].ductility_factor.hi
    assert u[0].ductility_factor.hi - u[0].ductility_factor.lo < 0.15


def test_the_joint_box_holds_the_design_value_so_a_far_start_does_not_pin_k1():
    """Held-out seed 602 (Table 1 pier, accelerometers only, El Centro 1940 at 2.6 m/s²,
    design values drawn 20-30 % about the truth): the top spring's small rotations integrate
    poorly, its own fit started at -75 %, and in a box about that start alone the joint fit
    and every member ended on the box at -32 % (k1 'identified' within 0.1 %).  The box now
    holds the design value too: the fit lands within 10 % and no member is on the box."""
    from pier_monitor.bench_heldout import heldout_case
    from pier_monitor.core.identify.field import fit_field

    window, truth, _, _, _ = heldout_case("table1", "accel", 602)
    fit = fit_field(window, members=8, seed=602)
    assert fit.stages["springs"].k1[5] / truth.k1[5] - 1 < -0.5  # the far start
    assert abs(fit.params.k1[5] / truth.k1[5] - 1) < 0.10
    assert fit.members.k1_at_bound.shape == (6,) and not fit.members.k1_at_bound[5]


def test_a_k1_ended_on_its_search_box_has_no_interval_and_is_flagged():
    """A spring whose k1 the box, not the data, ends: no interval, so poorly identified
    (unless its interval is already wider than the limit: then it is kept)."""
    from ensemble_helpers import ensemble_result, normal_members, yielded_members
    from pier_monitor.core.identify.damage import poorly_identified
    from pier_monitor.core.identify.uncertainty import without_k1_on_bound

    k1 = [normal_members(1.2e9, 1e6), normal_members(1.2e9, 1e6)]  # ±0.14 %: narrow
    result = ensemble_result("run1", k1, [normal_members(0.8, 0.02)] * 2,
                             [yielded_members(0.0)] * 2)
    own = tuple(s.uncertainty for s in result.sections)
    out = without_k1_on_bound(own, np.array([True, False]), 0.10)
    assert not out[0].k1.defined and out[0].c == own[0].c and out[1] == own[1]
    assert without_k1_on_bound(own, None, 0.10) == own
    # an interval already wider than the limit is flagged by its width and kept
    assert without_k1_on_bound(own, np.array([True, True]), 0.001) == own
    flags = [poorly_identified(dataclasses.replace(s, uncertainty=u))
             for s, u in zip(result.sections, out)]
    assert "k1" in flags[0] and "k1" not in flags[1]


def test_a_field_routes_yielded_df_interval_carries_its_resolution():
    """Table 1 pier, accelerometers only, a drawn case of the held-out suite's kind on a
    tuning seed (628): the base far past yield (true DF 3.44).  The members agree on its DF
    to about ±3 % and their interval misses the truth; the field route's DF resolution
    (``FIELD_DF_RESOLUTION``, ±6 %) is what holds it.  A section that did not yield keeps
    its own interval (its DF a bound at 1)."""
    from pier_monitor.bench_heldout import heldout_case
    from pier_monitor.core.identify.uncertainty import FIELD_DF_RESOLUTION

    window, _, true_df, yielded, _ = heldout_case("table1", "accel", 628)
    assert yielded[:2].all() and not yielded[2:].any() and 3.3 < true_df[0] < 3.6
    run = identify(window, IdentifySettings(seed=628))
    assert list(run.stages) == ["increments", "springs", "joint"]  # the field route
    base = run.result.sections[0]
    df, iv = base.ductility_factor, base.uncertainty.ductility_factor
    assert FIELD_DF_RESOLUTION == 0.06
    assert iv.lo == pytest.approx(df * 0.94, rel=1e-9) and iv.hi >= df * 1.06 - 1e-9
    assert iv.lo <= true_df[0] <= iv.hi
    assert abs(df / true_df[0] - 1.0) > 0.02  # the members' own ±3 % would not hold it
    top = run.result.sections[-1]
    assert top.yield_status == "not yielded" and top.uncertainty.ductility_factor.hi <= 1.0


def test_a_yield_test_just_short_makes_an_elastic_reading_suspicious_and_stays():
    """E-Defense pier, accelerometers only, the held-out suite's tuning draw 655: section 2
    truly yielded (true DF 1.60, past twice the yield strain), but the fit's yield test
    gained 0.78 of its remaining chi-square, short of the 2 that calls it yielded, and only
    one member in 32 yielded (rule 3 does not fire).  Rule 13 makes it suspicious with the
    test's share in the reason, never intact; the self-check's evidence keeps the line once
    (``with_evidence``), and a section whose test gained nothing stays as it was."""
    from pier_monitor.bench_heldout import heldout_case
    from pier_monitor.core.identify.damage import P_YIELD_LOW, YIELD_TEST_SHORT

    window, _, true_df, yielded, _ = heldout_case("edefense", "accel", 655)
    assert yielded[1] and 1.5 <= true_df[1] < 1.7
    result = identify(window, IdentifySettings(seed=655)).result
    s2 = result.sections[1]
    assert not s2.yielded and s2.uncertainty.p_yielded < P_YIELD_LOW
    assert s2.state == "suspicious"
    line = next(r for r in s2.reasons if r.startswith(YIELD_TEST_SHORT))
    share = float(line.split("chi-square by ")[1].split(" of")[0])
    assert 0.5 <= share < 2.0
    assert s2.evidence == (line,)
    top = result.sections[-1]
    assert top.evidence == () and top.state == "intact"
    assert s2.yield_status == "may have yielded"
    assert result.p_overall_state[0] == 0.0  # no intact share where a section is raised
    checked = result.with_evidence(np.zeros(4), [("hysteretic energy",)] * 4)
    assert checked.sections[1].evidence == (line, "hysteretic energy")
    assert checked.sections[1].reasons.count(line) == 1
    assert checked.sections[1].state == "suspicious"
    # kept through a re-decision against a baseline and through the result file
    from pier_monitor.core.identify.damage import IdentificationResult
    rebased = result.with_baseline(result).sections[1]
    assert rebased.state == "suspicious" and line in rebased.reasons
    loaded = IdentificationResult.from_dict(result.to_dict()).sections[1]
    assert loaded.evidence == (line,) and loaded.yield_status == "may have yielded"


def test_a_rotation_small_beside_what_gain_errors_make_leaves_k1_poorly_identified():
    """Table 1 pier, accelerometers only, the held-out suite's tuning draw 636: sections 4
    and 5 stay elastic with rotations 1.7 and 1.3 times what a 1 % gain error between the
    levels makes.  Their members agree to within ±4 %, yet their k1 are off by +29 % and
    −25 % (traded against each other): shown as poorly identified, not as known.  The base,
    whose rotation is far above that, keeps its k1 identified and within its interval."""
    from pier_monitor.bench_heldout import heldout_case
    from pier_monitor.core.identify.damage import IDENTIFIABILITY_LIMITS
    from pier_monitor.core.identify.field import FieldSettings, rotation_gain_ratio

    window, truth, _, _, _ = heldout_case("table1", "accel", 636)
    run = identify(window, IdentifySettings(seed=636))
    ratio = rotation_gain_ratio(window, run.reproduced.theta, run.reproduced.x)
    limit = FieldSettings().k1_min_gain_ratio
    assert limit == 2.5 and ratio[0] > 50 and (ratio[3:5] < 2.0).all()
    for i in (3, 4):
        s = run.result.sections[i]
        assert s.uncertainty.k1.relative_half_width() < IDENTIFIABILITY_LIMITS["k1"]
        assert abs(s.k1 / truth.k1[i] - 1.0) > 0.2
        assert not s.uncertainty.k1.lo <= truth.k1[i] <= s.uncertainty.k1.hi
        assert "k1" in s.poorly_identified and s.state == "intact"
    base = run.result.sections[0]
    assert "k1" not in base.poorly_identified
    assert base.uncertainty.k1.lo <= truth.k1[0] <= base.uncertainty.k1.hi
