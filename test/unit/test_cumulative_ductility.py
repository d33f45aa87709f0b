"""The cumulative ductility factor of a pier's later events, on the virgin section's yield
rotation, and the k1 change between identified events (no training: results by hand)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pier_monitor.core.identify.damage import IdentificationResult, SectionResult
from pier_monitor.core.identify.uncertainty import SectionUncertainty, Spread
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.synthetic.reference import paper_case_window
from pier_monitor.events import _checked_params
from pier_monitor.store import ResultsStore

T0 = 1_700_000_000 * 10 ** 9


@pytest.fixture(scope="module")
def base_window() -> MeasuredWindow:
    return paper_case_window(moments_measured=False, seed=0)[0]


def window(base: MeasuredWindow, event_id: str, start_s: float) -> MeasuredWindow:
    return replace(base, pier_id="pier7", event_id=event_id,
                   start_time_ns=T0 + int(start_s * 1e9))


def section(w: MeasuredWindow, i: int, *, k1: float, fy: float, peak: float, yielded: bool,
            family: str = "bilinear", k_small: float | None = None,
            yield_angle: float | None = None) -> SectionResult:
    """Section ``i`` as the identification reports it: DF on ``yield_angle`` (default
    ``fy / k1``), at most 1 where it did not yield, the state of that DF."""
    z = w.geometry.level_heights_m
    ty = fy / k1 if yield_angle is None else yield_angle
    df = peak / ty if yielded else min(peak / ty, 1.0)
    state = "intact" if df < 1.2 else "suspicious" if df < 1.5 else "damaged"
    return SectionResult(
        index=i, z_bottom_m=float(z[i]), z_top_m=float(z[i + 1]), k1=k1, k2=k1 / 10, fy=fy,
        c=2e7, yield_angle_rad=ty, max_angle_rad=peak, ductility_factor=df, state=state,
        yielded=yielded, k2_identifiable=yielded, fy_identifiable=yielded, family=family,
        k_small_after=k1 if k_small is None and family == "bilinear" else k_small)


def result(w: MeasuredWindow, sections: list[SectionResult]) -> IdentificationResult:
    sections = tuple(sections)
    worst = max(sections, key=lambda s: s.damage_state).state
    return IdentificationResult(
        pier_id=w.pier_id, event_id=w.event_id, sections=sections, overall_state=worst,
        window_start_s=0.0, window_duration_s=w.duration_s, epochs=0, final_loss=math.nan,
        wall_time_s=1.0, device="cpu", window_start_ns=w.start_time_ns)


def save(store: ResultsStore, r: IdentificationResult) -> None:
    d = store.event_dir(r.event_id)
    d.mkdir(parents=True, exist_ok=True)
    r.save_json(d / "result.json")


def first_event(w: MeasuredWindow) -> IdentificationResult:
    """The virgin pier: section 1 yields (θy 4e-3 rad, peak 6e-3 rad: DF 1.5), section 2
    cracks without yielding (peak 2e-3 rad), the others stay elastic (peak 1e-3 rad)."""
    n = w.n_levels
    secs = [section(w, 0, k1=2e9, fy=8e6, peak=6e-3, yielded=True),
            section(w, 1, k1=2e9, fy=5e6, peak=2e-3, yielded=False)]
    secs += [section(w, i, k1=2e9, fy=5e6, peak=1e-3, yielded=False) for i in range(2, n)]
    return result(w, secs)


def second_event(w: MeasuredWindow) -> IdentificationResult:
    """The same pier, cracked: alone, each event fits softer springs with larger yield
    rotations.  Section 1: k1 1.2e9, fy 8.4e6 (θy 7e-3 rad), peak 1e-2 rad, DF 1.43 alone;
    section 2 yields now: k1 1.5e9, fy 6e6 (θy 4e-3), peak 5e-3, DF 1.25 alone; the others
    stay elastic (peak 1e-3 rad, k1 1.8e9, fy 5e6 a bound)."""
    n = w.n_levels
    secs = [section(w, 0, k1=1.2e9, fy=8.4e6, peak=1e-2, yielded=True),
            section(w, 1, k1=1.5e9, fy=6e6, peak=5e-3, yielded=True)]
    secs += [section(w, i, k1=1.8e9, fy=5e6, peak=1e-3, yielded=False) for i in range(2, n)]
    return result(w, secs)


def test_the_second_event_is_judged_on_the_virgin_yield_rotation_of_its_baseline(
        base_window, tmp_path):
    store = ResultsStore(tmp_path / "results")
    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    save(store, first_event(w1))
    baseline = store.baseline_for(w2)
    assert baseline.event_id == "ev1"
    np.testing.assert_allclose(store.peak_rotations_before(w2)[:2], [6e-3, 2e-3])
    own = second_event(w2)
    assert [s.state for s in own.sections[:2]] == ["suspicious", "suspicious"]
    cum = own.with_cumulative_ductility(baseline, store.peak_rotations_before(w2))
    s1, s2, s3 = cum.sections[:3]
    # section 1 yielded in the baseline: its virgin yield rotation 8e6 / 2e9 = 4e-3 rad
    assert s1.yield_angle_rad == pytest.approx(4e-3)
    assert s1.ductility_factor == pytest.approx(1e-2 / 4e-3)  # 2.5, not 1.43
    assert s1.event_ductility_factor == pytest.approx(1e-2 / 7e-3)
    assert s1.event_yield_angle_rad == pytest.approx(7e-3)
    assert s1.state == "damaged" and "virgin yield rotation of event ev1" in \
        s1.ductility_reference
    # section 2 did not yield in the baseline: this event's fy over the baseline's k1
    assert s2.yield_angle_rad == pytest.approx(6e6 / 2e9)
    assert s2.ductility_factor == pytest.approx(5e-3 / 3e-3)  # 1.67, not 1.25
    assert s2.event_ductility_factor == pytest.approx(1.25)
    assert s2.state == "damaged" and "fy over k1 of event ev1" in s2.ductility_reference
    # yielded in neither: at most 1, as for a single event (5e6 / 2e9 = 2.5e-3 rad)
    assert s3.ductility_factor == pytest.approx(1e-3 / 2.5e-3)
    assert not s3.yielded and s3.state == "intact"
    assert cum.overall_state == "damaged"
    # the fields travel through result.json
    save(store, cum)
    back = store.results("pier7")[-1]
    assert back.sections[0].event_ductility_factor == pytest.approx(s1.event_ductility_factor)
    assert back.sections[1].ductility_reference == s2.ductility_reference
    # applied again (e.g. to a result read back), it gives the same
    again = back.with_cumulative_ductility(baseline, store.peak_rotations_before(w2))
    assert again.ductility_factors == pytest.approx(cum.ductility_factors)
    assert again.sections[0].event_ductility_factor == pytest.approx(1e-2 / 7e-3)


def test_a_later_small_event_keeps_the_damage_so_far(base_window, tmp_path):
    store = ResultsStore(tmp_path / "results")
    w1, w2, w3 = (window(base_window, f"ev{i}", 10.0 + 90 * i) for i in (1, 2, 3))
    save(store, first_event(w1))
    second = second_event(w2).with_cumulative_ductility(store.baseline_for(w2),
                                                        store.peak_rotations_before(w2))
    save(store, second)
    n = w3.n_levels
    small = result(w3, [section(w3, i, k1=1.1e9, fy=4e6, peak=1e-3, yielded=False)
                        for i in range(n)])
    assert small.overall_state == "intact"  # alone: springs taken undamaged, nothing yields
    assert store.baseline_for(w3).event_id == "ev1"
    peaks = store.peak_rotations_before(w3)
    np.testing.assert_allclose(peaks[:2], [1e-2, 5e-3])  # the largest of ev1 and ev2
    cum = small.with_cumulative_ductility(store.baseline_for(w3), peaks)
    assert cum.sections[0].ductility_factor == pytest.approx(1e-2 / 4e-3)
    assert cum.sections[0].state == "damaged"
    # section 2 yielded in ev2 only, which is no baseline: this event's fy (a bound, it did
    # not yield now) over the virgin k1, at most 1
    assert cum.sections[1].ductility_factor == pytest.approx(1.0)


def test_an_unreliable_result_or_another_geometry_stays_as_it_is(base_window):
    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    own = second_event(w2).with_check_reasons(["level 2: the reproduced acceleration departs"])
    assert own.with_cumulative_ductility(first_event(w1)) == own
    other = replace(first_event(w1), sections=first_event(w1).sections[:2])
    assert second_event(w2).with_cumulative_ductility(other) == second_event(w2)


def members_elastic() -> SectionUncertainty:
    """32 members that judged a section elastic: k1 1.2e9 N·m/rad within ±1.7 %, DF 0.8 within
    ±10 % (0.72-0.88)."""
    return SectionUncertainty(
        k1=Spread(1.2e9, 1e7, 1.18e9, 1.22e9), k2=Spread.undefined(), fy=Spread.undefined(),
        c=Spread(2e7, 1e6, 1.9e7, 2.1e7), ductility_factor=Spread(0.8, 0.05, 0.72, 0.88),
        p_yielded=0.0, p_state=(1.0, 0.0, 0.0), members=32)


def test_the_cumulative_state_reads_the_members_interval_scaled(base_window):
    """With an ensemble, the members judged the event alone: the state starts from the
    cumulative DF, and their DF interval is scaled to it: the straddle rule reads it, and
    the result reports it with the cumulative DF."""
    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    u = members_elastic()
    own = second_event(w2)
    # section 3: elastic now, but the virgin section's k1 is 2e9: DF 0.4 -> within the class
    s3 = replace(own.sections[2], uncertainty=u, ductility_factor=0.8)
    own = replace(own, sections=(*own.sections[:2], s3, *own.sections[3:]))
    cum = own.with_cumulative_ductility(first_event(w1))
    assert cum.sections[2].state == "intact" and cum.sections[2].reasons == ()
    # section 1 of a result whose members said intact (DF 0.72-0.88 alone, peak 6.4e-3 rad
    # on 8e-3 rad) but whose cumulative DF is 6.4e-3 / 4e-3 = 1.6: damaged (the scaled
    # interval [1.44, 1.76] straddles 1.5, which never demotes a state)
    s1 = replace(own.sections[0], uncertainty=u, ductility_factor=0.8, max_angle_rad=6.4e-3,
                 yield_angle_rad=8e-3, state="intact")
    own = replace(own, sections=(s1, *own.sections[1:]))
    cum = own.with_cumulative_ductility(first_event(w1))
    assert cum.sections[0].ductility_factor == pytest.approx(1.6)
    assert cum.sections[0].state == "damaged" and cum.sections[0].reasons == ()
    # the interval reported with the cumulative DF is the scaled one, holding the DF shown
    shown = cum.sections[0].uncertainty.ductility_factor
    assert (shown.lo, shown.hi) == (pytest.approx(1.44), pytest.approx(1.76))
    assert shown.lo <= cum.sections[0].ductility_factor <= shown.hi
    assert cum.sections[0].event_ductility_factor == pytest.approx(0.8)
    # a cumulative DF of 1.15 (intact) whose scaled interval [1.035, 1.265] straddles 1.2:
    # suspicious, with the reason
    s1 = replace(s1, max_angle_rad=4.6e-3)
    own = replace(own, sections=(s1, *own.sections[1:]))
    cum = own.with_cumulative_ductility(first_event(w1), np.full(w2.n_levels, 4e-3))
    assert cum.sections[0].ductility_factor == pytest.approx(1.15)
    assert cum.sections[0].state == "suspicious"
    assert cum.sections[0].reasons == ("DF 90 % interval [1.03, 1.26] straddles 1.2",)


def first_event_with_base_df(w: MeasuredWindow, df: Spread) -> IdentificationResult:
    """:func:`first_event` whose yielded base section carries members with the DF spread
    ``df`` (every member yielded and damaged)."""
    first = first_event(w)
    u = replace(members_elastic(), ductility_factor=df, p_yielded=1.0, p_state=(0.0, 0.0, 1.0))
    return replace(first, sections=(replace(first.sections[0], uncertainty=u),
                                    *first.sections[1:]))


def test_the_cumulative_df_interval_carries_the_reference_rotation_uncertainty(base_window):
    """The cumulative DF is this event's peak over the baseline's yield rotation: its interval
    holds the baseline's uncertainty of that rotation as well as this event's members'."""
    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    u = members_elastic()
    # the baseline's base section yielded (θy 4e-3 rad, DF 1.5) with a DF interval 10 % below
    # and 20 % above its mean: a yield rotation that may be larger or smaller
    first = first_event_with_base_df(w1, Spread(1.5, 0.1, 1.35, 1.8))
    own = second_event(w2)
    s1 = replace(own.sections[0], uncertainty=u, ductility_factor=0.8, max_angle_rad=6.4e-3,
                 yield_angle_rad=8e-3, state="intact")
    own = replace(own, sections=(s1, *own.sections[1:]))
    cum = own.with_cumulative_ductility(first)
    shown = cum.sections[0].uncertainty.ductility_factor
    # DF 1.6; the members' scaled bounds 10 % either side, the reference's 10 % below and
    # 20 % above, in quadrature: 1.6 (1 - 0.1 √2) and 1.6 (1 + √(0.1² + 0.2²))
    assert cum.sections[0].ductility_factor == pytest.approx(1.6)
    assert shown.lo == pytest.approx(1.6 * (1 - 0.1 * math.sqrt(2)))
    assert shown.hi == pytest.approx(1.6 * (1 + math.hypot(0.1, 0.2)))
    # now the interval straddles 1.5 (damaged either way: a straddle never demotes)
    assert cum.sections[0].state == "damaged"
    # a baseline that did not yield: the reference is this event's fy over the baseline's
    # k1, so its k1 spread (2 % below, 5 % above) widens the interval of a section yielded
    # now, a k1 low with a DF low
    first = first_event(w1)
    k1_u = replace(u, k1=Spread(2e9, 5e7, 1.96e9, 2.1e9))
    first = replace(first, sections=(first.sections[0],
                                     replace(first.sections[1], uncertainty=k1_u),
                                     *first.sections[2:]))
    s2 = replace(own.sections[1], uncertainty=replace(u, ductility_factor=Spread(
        1.25, 0.05, 1.1875, 1.3125)))
    own = replace(own, sections=(own.sections[0], s2, *own.sections[2:]))
    cum = own.with_cumulative_ductility(first)
    df = 5e-3 / (6e6 / 2e9)
    shown = cum.sections[1].uncertainty.ductility_factor
    assert cum.sections[1].ductility_factor == pytest.approx(df)
    assert (shown.lo, shown.hi) == (pytest.approx(df * (1 - math.hypot(0.05, 0.02))),
                                    pytest.approx(df * (1 + math.hypot(0.05, 0.05))))
    assert shown.std == pytest.approx(math.hypot(0.05 * df / 1.25, df * 5e7 / 2e9))
    # a Takeda baseline's spread is of its stiffness after the event, not of its k1: no
    # spread of the reference, the members' interval scaled alone
    takeda = replace(first.sections[1], family="takeda", k_small_after=1.5e9)
    cum = own.with_cumulative_ductility(replace(first, sections=(
        first.sections[0], takeda, *first.sections[2:])))
    shown = cum.sections[1].uncertainty.ductility_factor
    assert (shown.lo, shown.hi) == (pytest.approx(df * 0.95), pytest.approx(df * 1.05))
    # without the baseline's spread the interval is the members' scaled alone
    cum = own.with_cumulative_ductility(first_event(w1))
    shown = cum.sections[1].uncertainty.ductility_factor
    assert (shown.lo, shown.hi) == (pytest.approx(df * 0.95), pytest.approx(df * 1.05))
    assert cum.sections[1].poorly_identified == ()


def test_a_widened_cumulative_interval_is_flagged_and_never_negative(base_window):
    """The reference's uncertainty can widen the cumulative DF interval past its limit (±30 %):
    the DF is then flagged poorly identified, and not called damaged on it; relative bounds
    that add up past 100 % stop the interval at zero."""
    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    u = members_elastic()
    # baseline base section: DF 1.5 with an interval 60 % below and 70 % above its mean
    first = first_event_with_base_df(w1, Spread(1.5, 0.5, 0.6, 2.55))
    own = second_event(w2)
    # this event: DF 0.8 alone, its members 10 % either side (peak 6.4e-3 on 8e-3 rad),
    # then 90 % below: cumulative 1.6, interval combined to 0 below
    s1 = replace(own.sections[0], ductility_factor=0.8, max_angle_rad=6.4e-3,
                 yield_angle_rad=8e-3, state="intact", uncertainty=replace(
                     u, ductility_factor=Spread(0.8, 0.3, 0.08, 0.88)))
    cum = replace(own, sections=(s1, *own.sections[1:])).with_cumulative_ductility(first)
    sec = cum.sections[0]
    shown = sec.uncertainty.ductility_factor
    assert sec.ductility_factor == pytest.approx(1.6)
    assert shown.lo == 0.0 and shown.hi == pytest.approx(1.6 * (1 + math.hypot(0.1, 0.7)))
    assert "DF" in sec.poorly_identified
    assert sec.state == "suspicious"
    assert sec.reasons[0].startswith("DF poorly identified (90 % interval [0.00, ")


def test_a_baseline_whose_springs_misfit_is_no_reference(base_window):
    """Rule 8: where the self-check said the baseline's bilinear springs do not follow the
    pier, its yield rotation and k1 are not identified, so a later event keeps its own DF."""
    from pier_monitor.core.identify.damage import BILINEAR_MISFIT

    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    first = first_event(w1)
    misfit = f"{BILINEAR_MISFIT}: the bilinear springs identified do not reproduce ..."
    first = replace(first, sections=tuple(replace(s, evidence=(misfit,))
                                          for s in first.sections))
    own = second_event(w2)
    assert own.with_cumulative_ductility(first).sections == own.sections


def test_the_k1_change_between_takeda_events_is_of_the_small_amplitude_stiffness(base_window):
    w1, w2 = window(base_window, "ev1", 10.0), window(base_window, "ev2", 100.0)
    n = w1.n_levels
    # modified-Takeda springs: the bilinear k1 of each event is a secant over its branches
    # (2e9 -> 0.8e9: -60 %) while the stiffness the springs unload on fell from 1.0e9 to
    # 0.66e9 (-34 %): the change between the events is the latter
    ev1 = result(w1, [section(w1, i, k1=2e9, fy=8e6, peak=6e-3, yielded=True, family="takeda",
                              k_small=1.0e9, yield_angle=4e-3) for i in range(n)])
    ev2 = result(w2, [section(w2, i, k1=0.8e9, fy=8e6, peak=2e-2, yielded=True,
                              family="takeda", k_small=0.66e9, yield_angle=9e-3)
                      for i in range(n)])
    changed = ev2.with_baseline(ev1)
    assert [s.k1_change_pct for s in changed.sections] == pytest.approx([-34.0] * n)
    assert changed.k1_baseline == "event ev1"
    # bilinear springs: the k1 change as before
    b1 = result(w1, [section(w1, i, k1=2e9, fy=8e6, peak=6e-3, yielded=True)
                     for i in range(n)])
    b2 = result(w2, [section(w2, i, k1=1.5e9, fy=8e6, peak=6e-3, yielded=True)
                     for i in range(n)])
    assert [s.k1_change_pct for s in b2.with_baseline(b1).sections] == pytest.approx([-25.0] * n)


def test_k2_of_a_spring_that_did_not_yield_is_not_judged_at_its_bound(base_window):
    w = window(base_window, "ev1", 10.0)
    r = first_event(w)
    # the fit's k2 of the elastic sections sits at its bound 0.5 k1: not identified
    r = replace(r, sections=tuple(replace(s, k2=0.5 * s.k1) if not s.yielded else s
                                  for s in r.sections))
    p = _checked_params(r, w)
    assert p.k2[0] == pytest.approx(r.sections[0].k2)  # yielded: its own
    np.testing.assert_allclose(p.k2[1:], np.minimum(w.design.k2[1:], 1e9))
