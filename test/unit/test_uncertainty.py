"""Uncertainty of an ensemble identification and the decisions that use it.

Hand-made member arrays with a known spread (test/ensemble_helpers.py) go through
:func:`summarize_members` and the decision rules of ``core.identify.damage``; results with
uncertainty round-trip through result.json, and a result of one member is exactly a
single identification.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ensemble_helpers import (MEMBERS, ensemble_result, normal_members, yielded_members)
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.identify.damage import (BILINEAR_MISFIT, P_YIELD_LOW,
                                               RC_STIFFNESS_RESOLUTION,
                                               VIRGIN_START_STIFFNESS, DamageState,
                                               IdentificationResult, build_sections,
                                               classify_ductility, decide_state)
from pier_monitor.core.identify.uncertainty import (MemberResponses, Spread, k1_change_interval,
                                                    overall_state_probabilities,
                                                    summarize_members)
from pier_monitor.core.model.config import PierGeometry, SpringParameters

K1 = 1.0e9  # N·m/rad
ALL = np.ones(MEMBERS, dtype=bool)
NONE = np.zeros(MEMBERS, dtype=bool)


def _one_section(df: np.ndarray, yielded: np.ndarray, k1: np.ndarray | None = None
                 ) -> IdentificationResult:
    k1 = np.full(MEMBERS, K1) if k1 is None else k1
    return ensemble_result("e1", [k1], [df], [yielded])


# ----------------------------------------------------------------------- summarize_members


def test_summary_is_mean_sample_std_and_5th_95th_percentiles_of_the_members() -> None:
    k1 = np.array([1.0, 2.0, 3.0, 4.0, 5.0]) * 1e9
    yielded = np.array([True, True, False, False, True])
    df = np.array([1.3, 1.4, 1.6, 0.9, 1.25])
    params = np.stack([k1, k1 / 10, [4e6, 5e6, np.nan, np.nan, 6e6], np.full(5, 2e7)],
                      axis=-1)[:, None, :]
    (u,) = summarize_members(params, df[:, None], yielded[:, None])
    assert u.members == 5
    assert u.k1.mean == pytest.approx(3e9)
    assert u.k1.std == pytest.approx(math.sqrt(2.5) * 1e9)  # ddof = 1
    assert (u.k1.lo, u.k1.hi) == pytest.approx((1.2e9, 4.8e9))  # linear percentiles
    # k2 and fy only over the members that yielded (0, 1, 4); NaN elsewhere is allowed
    assert u.fy.mean == pytest.approx(5e6) and (u.fy.lo, u.fy.hi) == pytest.approx((4.1e6, 5.9e6))
    assert u.k2.mean == pytest.approx((0.1e9 + 0.2e9 + 0.5e9) / 3)
    assert u.c == Spread(2e7, 0.0, 2e7, 2e7)
    # member 2 did not yield: its DF 1.6 is a bound and counts as 1.0, and it is intact
    assert u.ductility_factor.mean == pytest.approx((1.3 + 1.4 + 1.0 + 0.9 + 1.25) / 5)
    assert u.p_yielded == pytest.approx(0.6)
    assert u.p_state == pytest.approx((0.4, 0.6, 0.0))


def test_normal_members_give_the_distributions_interval() -> None:
    (u,) = summarize_members(
        np.stack([normal_members(K1, 0.02 * K1), np.full(MEMBERS, 1e8), np.full(MEMBERS, 5e6),
                  np.full(MEMBERS, 2e7)], axis=-1)[:, None, :],
        normal_members(1.3, 0.1)[:, None], ALL[:, None])
    assert u.k1.mean == pytest.approx(K1, rel=1e-12)
    assert u.k1.std == pytest.approx(0.02 * K1, rel=0.03)
    assert u.k1.lo == pytest.approx(K1 * (1 - 1.645 * 0.02), rel=2e-3)
    assert u.ductility_factor.hi == pytest.approx(1.3 + 1.645 * 0.1, abs=5e-3)


def test_k2_and_fy_of_a_spring_that_yielded_in_no_member_are_undefined() -> None:
    (u,) = _one_section(normal_members(0.8, 0.05), NONE).sections[0].uncertainty,
    assert not u.k2.defined and not u.fy.defined and math.isnan(u.fy.mean)
    assert u.p_yielded == 0.0 and u.p_state == (1.0, 0.0, 0.0)


@pytest.mark.parametrize("params_shape, df_shape, match", [
    ((4, 3), (4, 3), r"member parameters: expected shape \(M, N, 4\)"),
    ((4, 3, 4), (4, 2), r"member ductility factors: expected shape \(4, 3\)"),
])
def test_member_arrays_of_the_wrong_shape_are_refused(params_shape, df_shape, match) -> None:
    with pytest.raises(InputDataError, match=match):
        summarize_members(np.ones(params_shape), np.ones(df_shape), np.ones(df_shape, bool))


def test_a_bad_member_value_is_named_by_member_section_and_quantity() -> None:
    params = np.ones((4, 3, 4))
    params[2, 1, 0] = np.nan
    with pytest.raises(InputDataError, match=r"member 2, section 2: k1 = nan"):
        summarize_members(params, np.ones((4, 3)), np.ones((4, 3), bool))
    params[2, 1, 0] = 1.0
    df = np.ones((4, 3))
    df[3, 0] = np.inf
    with pytest.raises(InputDataError, match=r"member 3, section 1: ductility factor = inf"):
        summarize_members(params, df, np.ones((4, 3), bool))
    with pytest.raises(InputDataError, match="yield flags: expected booleans"):
        summarize_members(params, np.ones((4, 3)), np.ones((4, 3)))


def test_overall_state_probabilities_follow_each_members_worst_section() -> None:
    df = np.array([[1.0, 1.3], [1.6, 0.5], [0.9, 1.0], [1.1, 1.25]])
    yielded = np.array([[True, True], [True, False], [False, False], [True, False]])
    # member states: (intact, suspicious), (damaged, intact), (intact, intact), (intact, intact)
    assert overall_state_probabilities(df, yielded) == (0.5, 0.25, 0.25)


def test_member_responses_check_their_shapes_and_give_a_band() -> None:
    theta = np.stack([np.full((5, 2), v) for v in np.linspace(0.0, 1.0, 11)])
    members = MemberResponses(theta=theta, moment=2 * theta)
    lo, hi = members.band("moment")
    np.testing.assert_allclose(lo, 0.1)
    np.testing.assert_allclose(hi, 1.9)
    assert members.members == 11 and members.band("x") is None
    with pytest.raises(InputDataError, match=r"member moment: expected shape \(11, 5, 2\)"):
        MemberResponses(theta=theta, moment=theta[:, :4])


# ------------------------------------------------------------------------------ decisions


@pytest.mark.parametrize("centre", [1.15, 1.2, 1.25])
def test_a_section_at_df_1_2_plus_minus_0_1_is_never_reported_intact(centre: float) -> None:
    s = _one_section(normal_members(centre, 0.1), ALL).sections[0]
    assert s.state == "suspicious"
    assert not (s.state == "intact" and s.uncertainty.p_state[0] > 0.5)
    if s.uncertainty.most_probable_state == DamageState.INTACT:  # promoted: says why
        assert any("straddles 1.2" in r for r in s.reasons)


def test_the_state_is_the_most_probable_one_when_the_interval_straddles_no_threshold() -> None:
    for centre, state in ((0.9, "intact"), (1.35, "suspicious"), (2.0, "damaged")):
        s = _one_section(normal_members(centre, 0.05), ALL).sections[0]
        assert (s.state, s.reasons) == (state, ())
        assert s.uncertainty.most_probable_state.name.lower() == state


def test_an_interval_straddling_1_5_gives_suspicious() -> None:
    s = _one_section(normal_members(1.45, 0.05), ALL).sections[0]
    assert s.uncertainty.ductility_factor.straddles(1.5)
    assert s.state == "suspicious"


def test_members_split_between_intact_and_damaged_make_an_intact_majority_suspicious() -> None:
    df = np.where(np.arange(MEMBERS) < 0.6 * MEMBERS, 1.0, 1.6)
    s = _one_section(df, ALL).sections[0]
    assert s.uncertainty.p_state == pytest.approx((0.6, 0.0, 0.4))
    assert s.state == "suspicious"
    assert s.reasons == ("DF 90 % interval [1.00, 1.60] straddles 1.2 and 1.5",)


def test_a_straddle_never_demotes_a_damaged_section() -> None:
    s = _one_section(normal_members(1.56, 0.05), ALL).sections[0]
    assert s.uncertainty.ductility_factor.straddles(1.5)
    assert s.uncertainty.p_state[2] > 0.5 and s.state == "damaged" and s.reasons == ()


def test_p_yielded_0_3_is_not_reported_as_not_yielded() -> None:
    s = _one_section(normal_members(0.85, 0.05), yielded_members(0.3)).sections[0]
    assert not s.yielded and not s.k2_identifiable  # most members did not yield
    assert s.uncertainty.p_yielded == pytest.approx(0.3)
    assert s.yield_status == "may have yielded"
    assert s.state == "suspicious"
    assert s.reasons == (f"may have yielded (P(yielded) 0.30 of {MEMBERS} members)",)


def test_a_low_probability_of_yielding_is_reported_not_yielded_and_intact() -> None:
    s = _one_section(normal_members(0.85, 0.05), yielded_members(0.05)).sections[0]
    assert s.uncertainty.p_yielded < P_YIELD_LOW
    assert (s.yield_status, s.state, s.reasons) == ("not yielded", "intact", ())


def _k1_events(loss: float, scatter: float) -> tuple[IdentificationResult, IdentificationResult]:
    """Baseline event at K1 ± 1 % and a later one at K1 (1 − loss) ± scatter, DF 0.8."""
    df = [normal_members(0.8, 0.03)]
    before = ensemble_result("run1", [normal_members(K1, 0.01 * K1)], df, [NONE])
    after = ensemble_result("run2", [normal_members(K1 * (1 - loss), scatter * K1)], df, [NONE])
    return before, after


def test_a_k1_loss_of_13_plus_minus_1_percent_against_an_event_flags_cracking() -> None:
    before, after = _k1_events(0.13, 0.01)
    assert after.sections[0].state == "intact"  # against nothing: DF alone
    s = after.with_baseline(before).sections[0]
    assert s.k1_change_pct == pytest.approx(-13.0, abs=1e-9)
    assert s.k1_change_hi_pct < -s.k1_change_scatter_pct < 0
    assert s.k1_change_scatter_pct == pytest.approx(100 * 0.87 * math.hypot(0.01 / 0.87, 0.01),
                                                    rel=0.05)
    assert s.state == "suspicious"
    assert len(s.reasons) == 1 and s.reasons[0].startswith(
        f"k1 -13.0 % [{s.k1_change_lo_pct:+.1f}, {s.k1_change_hi_pct:+.1f}] against event "
        "run1, beyond the identification scatter (")
    assert s.reasons[0].endswith("%): cracking")
    assert after.with_baseline(before).overall_state == "suspicious"


def test_a_k1_loss_of_a_k1_that_is_not_identified_is_no_cracking() -> None:
    """The same 13 % loss, where the self-check said the bilinear springs do not follow the
    pier (rule 8) in the later event or in the baseline, or where the baseline's k1 has no
    interval: the change is shown, the loss is no reason (the k1 compared is not
    identified)."""
    before, after = _k1_events(0.13, 0.01)
    misfit = (f"{BILINEAR_MISFIT}: the bilinear springs identified do not reproduce ...",)

    def unidentified(r: IdentificationResult) -> IdentificationResult:
        return replace(r, sections=tuple(replace(x, evidence=misfit) for x in r.sections))

    for b, a in ((unidentified(before), after), (before, unidentified(after))):
        s = a.with_baseline(b).sections[0]
        assert s.k1_change_pct == pytest.approx(-13.0, abs=1e-9)
        assert not any("cracking" in r for r in s.reasons)
    assert after.with_baseline(unidentified(before)).sections[0].state == "intact"
    # a baseline k1 left without an interval (the search box ended it) is no reference
    # either: taken as exact it would turn its own error into a loss
    boxed = replace(before, sections=tuple(
        replace(x, uncertainty=replace(x.uncertainty, k1=Spread.undefined()))
        for x in before.sections))
    s = after.with_baseline(boxed).sections[0]
    assert s.k1_change_pct == pytest.approx(-13.0, abs=1e-9)
    assert (s.state, s.reasons) == ("intact", ())


def test_a_k1_loss_of_1_plus_minus_2_percent_does_not_flag_cracking() -> None:
    before, after = _k1_events(0.01, 0.02)
    s = after.with_baseline(before).sections[0]
    assert s.k1_change_lo_pct < 0 < s.k1_change_hi_pct
    assert (s.state, s.reasons) == ("intact", ())


def test_a_loss_just_outside_zero_but_within_the_scatter_does_not_flag_cracking() -> None:
    before, after = _k1_events(0.03, 0.01)  # interval excludes zero, not by the scatter
    s = after.with_baseline(before).sections[0]
    assert -s.k1_change_scatter_pct < s.k1_change_hi_pct < 0
    assert s.state == "intact"


def test_a_k1_difference_from_design_values_is_no_evidence_of_cracking() -> None:
    _, after = _k1_events(0.13, 0.01)
    s = after.with_k1_baseline(np.array([K1]), "design values").sections[0]
    assert s.k1_change_hi_pct < -s.k1_change_scatter_pct  # the same size of change ...
    assert (s.state, s.reasons) == ("intact", ())  # ... but design values are not an event


def test_a_k1_gain_beyond_the_scatter_is_not_damage() -> None:
    before, after = _k1_events(-0.13, 0.01)
    assert after.with_baseline(before).sections[0].state == "intact"


def _takeda(result: IdentificationResult, bilinear_k1: float,
            history_known: bool = True) -> IdentificationResult:
    """``result`` as a Takeda event: its members' ``k1`` are the draws of the stiffness
    after the event (``k_small_after``, their mean), its ``k1`` the bilinear fit's; its
    springs started from the pier's measured history (``history_known``) or virgin."""
    sections = tuple(replace(s, family="takeda", k_small_after=s.k1, k1=bilinear_k1,
                             history_known=history_known)
                     for s in result.sections)
    return replace(result, sections=sections, family={"family": "takeda"})


def test_a_takeda_sections_interval_is_that_of_its_stiffness_after_the_event() -> None:
    """A Takeda section's uncertainty ``k1`` is the spread of ``k_small_after``, the
    stiffness a change against an earlier event compares: that change gets its interval
    and the cracking rule, widened by the family's resolution (``RC_STIFFNESS_RESOLUTION``
    for each event); a change of the bilinear ``k1`` against design values gets none (no
    interval of it was drawn)."""
    before0, after0 = _k1_events(0.13, 0.01)
    before, after = _takeda(before0, 0.6 * K1), _takeda(after0, 0.5 * K1)
    s = after.with_baseline(before).sections[0]
    ks_before, ks_after = before.sections[0].k_small_after, after.sections[0].k_small_after
    assert s.k1_change_pct == pytest.approx(100 * (ks_after / ks_before - 1), abs=1e-9)
    want = k1_change_interval(ks_after, after.sections[0].uncertainty.k1, ks_before,
                              before.sections[0].uncertainty.k1,
                              resolution=RC_STIFFNESS_RESOLUTION)
    assert (s.k1_change_lo_pct, s.k1_change_hi_pct, s.k1_change_scatter_pct) == \
        pytest.approx((want.lo_pct, want.hi_pct, want.scatter_pct), rel=1e-12)
    draws_only = k1_change_interval(ks_after, after.sections[0].uncertainty.k1, ks_before,
                                    before.sections[0].uncertainty.k1)
    assert -15.5 < draws_only.lo_pct and draws_only.hi_pct < -10.5  # the draws' alone
    assert -19.6 < s.k1_change_lo_pct < -19.4 and -6.6 < s.k1_change_hi_pct < -6.4
    assert s.k1_change_scatter_pct == pytest.approx(draws_only.scatter_pct)
    assert s.k1_change_hi_pct < -s.k1_change_scatter_pct < 0
    assert s.state == "suspicious" and s.reasons[0].endswith("%): cracking")
    # a spring that started virgin after the earlier event: the truth may lie higher
    v = _takeda(after0, 0.5 * K1, history_known=False).with_baseline(before).sections[0]
    wide = k1_change_interval(ks_after, after.sections[0].uncertainty.k1, ks_before,
                              before.sections[0].uncertainty.k1,
                              stiffer_by=VIRGIN_START_STIFFNESS,
                              resolution=RC_STIFFNESS_RESOLUTION)
    assert (v.k1_change_lo_pct, v.k1_change_hi_pct) == pytest.approx((want.lo_pct,
                                                                      wide.hi_pct))
    assert v.k1_change_hi_pct > s.k1_change_hi_pct
    d = after.with_k1_baseline(np.array([K1]), "design values").sections[0]
    assert d.k1_change_pct == pytest.approx(-50.0)
    assert (d.k1_change_lo_pct, d.k1_change_hi_pct, d.k1_change_scatter_pct) == (None,) * 3
    assert after.intervals == f"90 % interval over {MEMBERS} draws of the modified-Takeda " \
        "fit's posterior"


def test_k1_change_interval_is_the_members_interval_against_a_baseline_without_spread() -> None:
    spread = Spread(mean=0.9e9, std=0.01e9, lo=0.88e9, hi=0.93e9)
    got = k1_change_interval(0.9e9, spread, 1.0e9)
    assert (got.lo_pct, got.hi_pct) == pytest.approx((-12.0, -7.0))
    assert got.scatter_pct == pytest.approx(1.0)
    base = Spread(mean=1.0e9, std=0.02e9, lo=0.97e9, hi=1.04e9)
    got = k1_change_interval(0.9e9, spread, 1.0e9, base)
    a_lo, a_hi = 0.02 / 0.9, 0.03 / 0.9
    assert got.lo_pct == pytest.approx(100 * (0.9 * (1 - math.hypot(a_lo, 0.04)) - 1))
    assert got.hi_pct == pytest.approx(100 * (0.9 * (1 + math.hypot(a_hi, 0.03)) - 1))
    assert got.scatter_pct == pytest.approx(100 * 0.9 * math.hypot(0.01 / 0.9, 0.02))
    res = k1_change_interval(0.9e9, spread, 1.0e9, base, resolution=0.05)
    assert res.lo_pct == pytest.approx(100 * (0.9 * (1 - math.hypot(a_lo, 0.04, 0.05, 0.05))
                                              - 1))
    assert res.hi_pct == pytest.approx(100 * (0.9 * (1 + math.hypot(a_hi, 0.03, 0.05, 0.05))
                                              - 1))
    assert res.scatter_pct == got.scatter_pct
    with pytest.raises(InputDataError, match="resolution"):
        k1_change_interval(0.9e9, spread, 1.0e9, resolution=-0.01)


def test_one_member_is_exactly_a_single_identification() -> None:
    geometry = PierGeometry(np.full(3, 2.0), np.full(3, 1e5))
    params = SpringParameters(np.full(3, K1), np.full(3, K1 / 10), np.full(3, 5e6),
                              np.full(3, 2e7))
    df = np.array([0.8, 1.3, 1.19])
    theta = np.array([[0.0, 0.0, 0.0], list(df * params.yield_angles)])
    yielded = np.array([False, True, True])
    members = np.stack([params.k1, params.k2, params.fy, params.c], axis=-1)[None]
    one = summarize_members(members, df[None], yielded[None])
    base = np.full(3, 0.9 * K1)
    single = build_sections(geometry, params, theta, yielded, baseline_k1=base)
    assert build_sections(geometry, params, theta, yielded, baseline_k1=base,
                          uncertainty=one) == single
    assert [s.state for s in single] == [classify_ductility(d).name.lower() for d in
                                         np.minimum(df, [1.0, np.inf, np.inf])]
    assert all(s.uncertainty is None and s.reasons == () and s.k1_change_lo_pct is None
               for s in single)
    assert decide_state(1.3, True, one[1]) == (DamageState.SUSPICIOUS, ())
    assert decide_state(float("nan"), True, None) == (DamageState.UNKNOWN, ())


# ----------------------------------------------------------------------------- result.json


def _json(result: IdentificationResult) -> str:
    return json.dumps(result.to_dict(), allow_nan=True, sort_keys=True)


def test_result_with_uncertainty_round_trips_through_result_json(tmp_path: Path) -> None:
    before, after = _k1_events(0.13, 0.01)
    result = after.with_baseline(before)
    assert result.members == MEMBERS and result.p_overall_state == (1.0, 0.0, 0.0)
    assert not result.sections[0].uncertainty.k2.defined  # NaN spreads in the file
    loaded = IdentificationResult.load_json(result.save_json(tmp_path / "result.json"))
    assert _json(loaded) == _json(result)
    s, t = loaded.sections[0], result.sections[0]
    assert (s.uncertainty.k1, s.uncertainty.p_state, s.reasons) == (
        t.uncertainty.k1, t.uncertainty.p_state, t.reasons)
    assert isinstance(s.reasons, tuple) and isinstance(loaded.p_overall_state, tuple)
    assert (s.k1_change_lo_pct, s.k1_change_hi_pct, s.k1_change_scatter_pct) == (
        t.k1_change_lo_pct, t.k1_change_hi_pct, t.k1_change_scatter_pct)
    assert math.isnan(s.uncertainty.fy.lo)


def test_a_result_file_written_before_uncertainty_existed_still_loads(tmp_path: Path) -> None:
    single = ensemble_result("old", [np.full(1, K1)], [np.full(1, 1.3)], [np.ones(1, bool)])
    doc = single.to_dict()
    del doc["p_overall_state"]
    for s in doc["sections"]:
        for key in ("uncertainty", "k1_change_lo_pct", "k1_change_hi_pct",
                    "k1_change_scatter_pct", "reasons"):
            del s[key]
    (tmp_path / "result.json").write_text(json.dumps(doc))
    loaded = IdentificationResult.load_json(tmp_path / "result.json")
    assert loaded == single and loaded.members == 1


def test_a_malformed_uncertainty_in_result_json_is_a_report_error(tmp_path: Path) -> None:
    from pier_monitor.core.errors import ReportError
    from pier_monitor.report.results import load_result

    doc = _one_section(normal_members(1.3, 0.05), ALL).to_dict()
    doc["sections"][0]["uncertainty"]["p_state"] = [0.5, 0.5]
    (tmp_path / "result.json").write_text(json.dumps(doc))
    with pytest.raises(ReportError, match="result.json: cannot read"):
        load_result(tmp_path)


def test_df_interval_of_a_yielded_section_is_never_narrower_than_its_resolution():
    """Members that agree to 1e-4 on a yielded section's DF (a fully measured window) get
    the DF's resolution, ±1.5 %; a wider interval and a section that did not yield keep
    their own."""
    from pier_monitor.core.identify.uncertainty import DF_RESOLUTION, with_df_resolution

    rng = np.random.default_rng(0)
    m = 16
    params = np.tile([1e9, 1e8, 1e6, 1e6], (m, 3, 1)) * (1 + 1e-4 * rng.standard_normal((m, 3, 4)))
    ductility = np.column_stack([2.0 * (1 + 1e-4 * rng.standard_normal(m)),
                                 1.6 * (1 + 0.1 * rng.standard_normal(m)),
                                 np.full(m, 0.7)])
    yielded = np.column_stack([np.ones(m, bool), np.ones(m, bool), np.zeros(m, bool)])
    raw = summarize_members(params, ductility, yielded)
    out = with_df_resolution(raw, ductility[0], yielded[0])
    assert DF_RESOLUTION == 0.015
    s0 = out[0].ductility_factor
    assert raw[0].ductility_factor.hi - raw[0].ductility_factor.lo < 1e-3
    assert s0.lo == pytest.approx(ductility[0, 0] * 0.985) and s0.hi == pytest.approx(ductility[0, 0] * 1.015)
    assert out[1] == raw[1]  # members spread by 10 %: wider than the floor
    assert out[2] == raw[2]  # not yielded: its DF is a bound
    assert out[0].k1 == raw[0].k1 and out[0].p_state == raw[0].p_state



def test_df_interval_of_a_section_whose_yield_is_not_excluded_reaches_up_to_it():
    """A section reported not yielded whose yield the data do not exclude up to DF 1.18 (the
    field reconstruction's yield profile) has its DF interval reach up to 1.18, its lower end
    and mean kept; a NaN bound, or one inside the interval, changes nothing; a bound of the
    wrong shape is refused, naming it."""
    from pier_monitor.core.identify.uncertainty import with_yield_not_excluded

    rng = np.random.default_rng(2)
    m = 16
    params = np.tile([1e9, 1e8, 1e6, 1e6], (m, 3, 1)) * (1 + 1e-3 * rng.standard_normal((m, 3, 4)))
    ductility = np.column_stack([0.93 + 0.01 * rng.standard_normal(m), np.full(m, 0.6),
                                 1.0 + 0.2 * rng.random(m)])
    yielded = np.column_stack([np.zeros(m, bool), np.zeros(m, bool), np.ones(m, bool)])
    raw = summarize_members(params, ductility, yielded)
    assert raw[0].ductility_factor.hi < 0.96
    out = with_yield_not_excluded(raw, np.array([1.18, np.nan, 1.05]))
    s0 = out[0].ductility_factor
    assert s0.hi == 1.18
    assert (s0.lo, s0.mean, s0.std) == (raw[0].ductility_factor.lo, raw[0].ductility_factor.mean,
                                        raw[0].ductility_factor.std)
    assert out[0].k1 == raw[0].k1 and out[0].p_yielded == raw[0].p_yielded
    assert out[1] == raw[1]  # no bound
    assert raw[2].ductility_factor.hi > 1.05 and out[2] == raw[2]  # already past it
    with pytest.raises(InputDataError, match="yield-profile DF bounds: expected 3"):
        with_yield_not_excluded(raw, np.ones(2))


def test_c_interval_is_never_narrower_than_its_resolution():
    """Members that agree to 1e-4 on ``c`` get its resolution, ±2 % of the fit's own ``c``;
    members spread by 10 % keep their own interval; the other quantities are untouched."""
    from pier_monitor.core.identify.uncertainty import C_RESOLUTION, with_c_resolution

    rng = np.random.default_rng(1)
    m = 16
    params = np.tile([1e9, 1e8, 1e6, 2e7], (m, 2, 1)) * (1 + 1e-4 * rng.standard_normal((m, 2, 4)))
    params[:, 1, 3] = 2e7 * (1 + 0.1 * rng.standard_normal(m))
    ductility = np.full((m, 2), 2.0)
    yielded = np.ones((m, 2), bool)
    raw = summarize_members(params, ductility, yielded)
    out = with_c_resolution(raw, params[0, :, 3])
    assert C_RESOLUTION == 0.02
    assert raw[0].c.hi - raw[0].c.lo < 1e-3 * 2e7
    assert out[0].c.lo == pytest.approx(params[0, 0, 3] * 0.98)
    assert out[0].c.hi == pytest.approx(params[0, 0, 3] * 1.02)
    assert out[1].c == raw[1].c  # wider than the floor
    assert out[0].k1 == raw[0].k1 and out[0].ductility_factor == raw[0].ductility_factor

def test_a_poorly_identified_df_never_makes_a_section_damaged():
    """Members spread from DF 1 to 1.8 (±30 % and more), 40 % of them past 1.5: the most
    probable state is damaged, but the DF is poorly identified and its interval reaches
    below 1.5, so the section is suspicious, with the reason; members spread as widely but
    all past 1.5 keep it damaged."""
    from pier_monitor.core.identify.damage import decide_state

    m = 20
    params = np.tile([1e9, 1e8, 1e6, 1e6], (m, 1, 1))
    yielded = np.ones((m, 1), bool)
    low = np.concatenate([np.full(6, 1.0), np.full(6, 1.3), np.linspace(1.55, 1.9, 8)])
    u_low = summarize_members(params, low[:, None], yielded)[0]
    assert u_low.most_probable_state == DamageState.DAMAGED
    state, reasons = decide_state(1.45, True, u_low)
    assert state == DamageState.SUSPICIOUS
    assert any("DF poorly identified (90 % interval [1.00, 1." in r for r in reasons)
    high = np.linspace(1.6, 3.4, m)
    u_high = summarize_members(params, high[:, None], yielded)[0]
    state, reasons = decide_state(2.4, True, u_high)
    assert state == DamageState.DAMAGED and not any("poorly" in r for r in reasons)


def test_a_k1_interval_holds_the_fits_own_value() -> None:
    """The 5th-95th percentile of a few members can leave out the fit (member 0) when it is
    the most extreme of them: the interval shown is stretched to hold the value shown."""
    from pier_monitor.core.identify.uncertainty import with_own_k1

    result = ensemble_result("run1", [normal_members(K1, 0.01 * K1)] * 2,
                             [normal_members(0.8, 0.02)] * 2, [NONE] * 2)
    own = tuple(s.uncertainty for s in result.sections)
    low = own[0].k1.lo * 0.999
    out = with_own_k1(own, np.array([low, K1]))
    assert out[0].k1.lo == pytest.approx(low) and out[0].k1.hi == own[0].k1.hi
    assert out[1] == own[1]  # already inside
