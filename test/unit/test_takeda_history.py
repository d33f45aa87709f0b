"""A pier's history carried into its next event: the modified-Takeda spring started from the
peaks an earlier event reached, its fit, the rotation envelope a window leaves and the store
hands to the next (no training)."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import to_strict_json
from pier_monitor.core.identify.damage import (RC_STIFFNESS_RESOLUTION, IdentificationResult,
                                               SectionResult,
                                               rotation_peaks_after)
from pier_monitor.core.identify.equation_error import SpringFit
from pier_monitor.core.identify.families import fit_families, takeda_draws
from pier_monitor.core.identify.field_families import damped_takeda
from pier_monitor.core.identify.methods import IdentifySettings, identify
from pier_monitor.core.identify.uncertainty import (SectionUncertainty, Spread,
                                                    k1_change_interval)
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.link_model import angle_matrix
from pier_monitor.core.model.springs import (TakedaParameters, takeda_moment,
                                             takeda_skeleton, takeda_unloading_stiffness)
from pier_monitor.core.synthetic.reference import paper_case_window
from pier_monitor.store import ResultsStore

# k0 = 10, θc = 0.1, k_y = 4 (θy = 1), kp = 0.2
SMALL = TakedaParameters(k0=10.0, mc=1.0, my=4.0, theta_y=1.0, kp=0.2)
# a pinched RC section (as the spring-family tests'): θy = 0.02 rad
SECTION = TakedaParameters(k0=1e9, mc=2e6, my=8e6, theta_y=0.02, kp=1e7, pinch_x=0.7,
                           pinch_y=0.5)
T0 = 1_700_000_000 * 10 ** 9


def test_a_spring_with_a_history_reloads_towards_its_earlier_peak():
    theta = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    virgin = takeda_moment(theta, SMALL)
    np.testing.assert_allclose(takeda_moment(theta, SMALL, (0.0, 0.0)), virgin)
    skel = takeda_skeleton(SMALL)
    # peaks of +2 and -1 before: from rest at 0 it reloads straight at (2, S(2)) = (2, 4.2)
    m = takeda_moment(theta, SMALL, (2.0, -1.0))
    np.testing.assert_allclose(m[:4], 4.2 * theta[:4] / 2.0, rtol=1e-12)
    assert m[0] < virgin[0]  # the virgin spring is still on its stiffer cracked branch
    assert m[4] == pytest.approx(float(skel(2.5)))  # past the old peak: back on the skeleton
    # unloading from the new peak of 2.5 on the stiffness that peak degraded
    back = takeda_moment(np.append(theta, 2.4), SMALL, (2.0, -1.0))
    ku = takeda_unloading_stiffness(SMALL, 2.5)
    assert back[-1] == pytest.approx(m[4] - 0.1 * ku)
    # the negative side aims at its own peak, (-1, S(-1)) = (-1, -4), but that line is
    # stiffer than the unloading stiffness of the larger peak, which then holds the moment
    neg = takeda_moment(np.array([-0.5]), SMALL, (2.0, -1.0))
    ku2 = takeda_unloading_stiffness(SMALL, 2.0)
    assert ku2 < 4.0 and neg[0] == pytest.approx(-0.5 * ku2)


def test_a_history_within_cracking_is_a_virgin_spring():
    theta = np.linspace(0.0, 0.5, 11)
    np.testing.assert_allclose(takeda_moment(theta, SMALL, (0.05, -0.08)),
                               takeda_moment(theta, SMALL))


@pytest.mark.parametrize("prior", [(-0.1, 0.0), (0.1, 0.2), (math.nan, 0.0)])
def test_a_history_of_the_wrong_sign_is_refused(prior):
    with pytest.raises(InputDataError, match="prior_peaks"):
        takeda_moment(np.zeros(3), SMALL, prior)


def _second_event(noise_rel: float = 0.05, seed: int = 0):
    """A section that an earlier event took to +0.05 / -0.045 rad (2.5 θy), then a second
    event reaching 0.06 rad: its ``(θ, θ̇, g)`` (T, 1), ``g = M + c θ̇`` with white noise of
    ``noise_rel`` of its standard deviation, the noise variance and the history."""
    dt = 0.01
    t = np.arange(2400) * dt
    theta = (0.06 * np.sin(np.pi * t / 24.0) ** 2
             * (np.sin(2 * np.pi * 1.1 * t) + 0.4 * np.sin(2 * np.pi * 2.7 * t + 1.0)))
    theta *= 0.06 / np.abs(theta).max()
    theta_dot = np.gradient(theta, dt)
    prior = (0.05, -0.045)
    g = takeda_moment(theta, SECTION, prior) + 2e6 * theta_dot
    sd = noise_rel * float(np.std(g))
    g = g + sd * np.random.default_rng(seed).standard_normal(g.shape)
    arrays = (theta[:, None], theta_dot[:, None], g[:, None])
    return arrays, sd ** 2, np.array([[prior[0]], [prior[1]]])


def test_the_fit_started_from_the_history_finds_the_stiffness_the_section_is_left_with():
    """The second event of a section fitted as a virgin spring takes its first reloading for
    a stiff skeleton: its Takeda fit leaves ten times the residual, loses to the bilinear,
    and misplaces the stiffness after the event (12 % low); started from the earlier peaks,
    the Takeda is chosen and finds that stiffness and the spring."""
    arrays, var, prior = _second_event()
    start = SpringFit(5e8, 2e7, 7e6, 2e6, True, 1.0, 1.0, 0)
    truth = takeda_unloading_stiffness(SECTION, 0.06)
    virgin = fit_families(*arrays, np.array([var]), (start,))
    known = fit_families(*arrays, np.array([var]), (start,), prior_peaks=prior)
    assert known.family == "takeda", known.reason
    assert virgin.family == "bilinear", virgin.reason
    assert known.sections[0].prior_peaks == (0.05, -0.045)
    assert known.sections[0].fits["takeda"].rss < 0.2 * virgin.sections[0].fits["takeda"].rss
    virgin_takeda = virgin.sections[0].fits["takeda"]
    virgin_small = takeda_unloading_stiffness(
        TakedaParameters(*(virgin_takeda.params[k] for k in (
            "k0", "mc", "my", "theta_y", "kp", "alpha", "pinch_x", "pinch_y"))), 0.06)
    assert abs(virgin_small / truth - 1.0) > 0.05
    assert known.small_amplitude_stiffness[0] == pytest.approx(truth, rel=0.02)
    fit = known.sections[0].fits["takeda"].params
    assert fit["my"] == pytest.approx(SECTION.my, rel=0.05)
    assert fit["theta_y"] == pytest.approx(SECTION.theta_y, rel=0.05)
    # the posterior's draws start from the same history: member 0 is the fit
    d = takeda_draws(*arrays, known, n_draws=20, seed=1)
    assert d.params[0, 0, 0] == pytest.approx(known.small_amplitude_stiffness[0], rel=1e-9)
    lo, hi = np.nanquantile(d.params[:, 0, 0], [0.05, 0.95])
    assert lo < hi


def test_a_history_of_the_wrong_shape_is_refused():
    arrays, var, _ = _second_event()
    start = SpringFit(5e8, 2e7, 7e6, 2e6, True, 1.0, 1.0, 0)
    with pytest.raises(InputDataError, match="prior_peaks"):
        fit_families(*arrays, np.array([var]), (start,), prior_peaks=np.zeros((2, 2)))


def test_a_window_leaves_its_peaks_less_its_residual_rotation():
    dt = 0.01
    t = np.arange(1000) * dt
    # section 1 swings to +4e-3 / -3e-3 rad and comes to rest at +1e-3 rad; section 2 stays
    # within +-5e-4 and ends at rest at 0
    th1 = np.where(t < 5.0, 4e-3 * np.sin(2 * np.pi * t), 0.0)
    th1 = np.where(th1 < -3e-3, -3e-3, th1) + np.where(t >= 5.0, 1e-3, 0.0)
    th2 = np.where(t < 5.0, 5e-4 * np.sin(2 * np.pi * t), 0.0)
    theta = np.column_stack([th1, th2])
    after = rotation_peaks_after(theta, dt)
    np.testing.assert_allclose(after, [[3e-3, 5e-4], [-4e-3, -5e-4]], atol=1e-12)
    # an earlier history, in this window's frame, carries through it
    prior = np.array([[6e-3, 1e-4], [-2e-3, -1e-4]])
    np.testing.assert_allclose(rotation_peaks_after(theta, dt, prior),
                               [[5e-3, 5e-4], [-4e-3, -5e-4]], atol=1e-12)
    with pytest.raises(InputDataError, match="prior"):
        rotation_peaks_after(theta, dt, prior[:, :1])
    with pytest.raises(InputDataError, match="dt"):
        rotation_peaks_after(theta, 0.0)


@pytest.fixture(scope="module")
def base_window() -> MeasuredWindow:
    return paper_case_window(moments_measured=False, seed=0)[0]


def _stored(store: ResultsStore, base: MeasuredWindow, event_id: str, start_s: float,
            peaks: list[tuple[float, float] | None] | None, reliable: bool = True,
            flagged: tuple[int, ...] = (), displacement_levels: np.ndarray | None = None,
            profile_only: tuple[int, ...] = (), evidence: dict[int, str] | None = None
            ) -> MeasuredWindow:
    """``base`` as event ``event_id`` of pier7 with a result whose sections hold ``peaks``
    (their ``rotation_peaks_after_rad``), reliable or not, the DF of the sections
    ``flagged`` poorly identified (of those in ``profile_only`` only because the data do not
    exclude a yield up to DF 1.3; ``evidence``: a section's self-check line); with
    ``displacement_levels``, stored as
    :meth:`~IdentificationResult.with_history_identified` leaves it."""
    w = replace(base, pier_id="pier7", event_id=event_id,
                start_time_ns=T0 + int(start_s * 1e9))
    store.start_event(w)
    z = w.geometry.level_heights_m
    sections = tuple(SectionResult(
        index=i, z_bottom_m=float(z[i]), z_top_m=float(z[i + 1]), k1=2e9, k2=2e8, fy=5e6,
        c=2e7, yield_angle_rad=2.5e-3, max_angle_rad=1e-3, ductility_factor=0.4,
        state="intact", yielded=False, k2_identifiable=False, fy_identifiable=False,
        family="bilinear", k_small_after=2e9,
        rotation_peaks_after_rad=None if peaks is None else peaks[i],
        poorly_identified=("DF",) if i in flagged else (),
        df_yield_not_excluded=(0.5, 1.3) if i in profile_only else None,
        df_flagged_by_yield_profile=i in profile_only,
        evidence=((evidence or {})[i],) if i in (evidence or {}) else ())
        for i in range(w.n_levels))
    result = IdentificationResult(
        pier_id=w.pier_id, event_id=w.event_id, sections=sections, overall_state="intact",
        window_start_s=0.0, window_duration_s=w.duration_s, epochs=0, final_loss=math.nan,
        wall_time_s=1.0, device="cpu", window_start_ns=w.start_time_ns,
        unreliable_reasons=() if reliable else ("a sensor's misfit",),
    )
    if displacement_levels is not None:
        result = result.with_history_identified(displacement_levels)
    result.save_json(store.event_dir(w.event_id) / "result.json")
    return w


def test_the_store_carries_the_latest_reliable_events_peaks_into_the_next_window(
        base_window, tmp_path):
    store = ResultsStore(tmp_path / "results")
    n = base_window.n_levels
    later = replace(base_window, pier_id="pier7", event_id="ev9",
                    start_time_ns=T0 + int(500e9))
    assert store.rotation_peaks_before(later) is None  # a virgin pier
    first = [(1e-3 * (i + 1), -5e-4 * (i + 1)) for i in range(n)]
    _stored(store, base_window, "ev1", 10.0, first)
    np.testing.assert_allclose(store.rotation_peaks_before(later), np.array(first).T)
    # the latest reliable one holds the envelope of all before it; an unreliable one is not
    # read, nor one that does not hold it
    second = [(2e-3 * (i + 1), -1e-3) for i in range(n)]
    _stored(store, base_window, "ev2", 100.0, second)
    _stored(store, base_window, "ev3", 200.0, [(9.0, -9.0)] * n, reliable=False)
    np.testing.assert_allclose(store.rotation_peaks_before(later), np.array(second).T)
    assert store.rotation_peaks_before(
        replace(later, start_time_ns=T0 + int(50e9))) == pytest.approx(np.array(first).T)
    _stored(store, base_window, "ev4", 300.0, None)
    assert store.rotation_peaks_before(later) is None
    # the field travels through result.json
    back = [r for r in store.results("pier7") if r.event_id == "ev2"][0]
    assert back.sections[1].rotation_peaks_after_rad == (4e-3, -1e-3)
    # the window takes it; one of the wrong shape or sign is refused, naming the field
    env = np.array(second).T
    assert replace(later, prior_rotation_peaks=env).prior_rotation_peaks.shape == (2, n)
    with pytest.raises(InputDataError, match="prior_rotation_peaks"):
        replace(later, prior_rotation_peaks=-np.abs(env))


def test_a_reconstructed_rotation_whose_df_is_not_identified_is_no_history(base_window,
                                                                         tmp_path):
    """A section whose rotation was reconstructed (an end level without a displacement
    sensor) and whose DF is poorly identified leaves no rotation history; the next window
    starts that spring virgin (zeros) and the others from theirs.  A measured rotation is
    carried whatever its DF's flag."""
    store = ResultsStore(tmp_path / "results")
    n = base_window.n_levels
    later = replace(base_window, pier_id="pier7", event_id="ev9",
                    start_time_ns=T0 + int(500e9))
    peaks = [(1e-3 * (i + 1), -5e-4 * (i + 1)) for i in range(n)]
    _stored(store, base_window, "ev1", 10.0, peaks, flagged=(0, 2),
            displacement_levels=np.ones(n, dtype=bool))
    np.testing.assert_allclose(store.rotation_peaks_before(later), np.array(peaks).T)
    # accelerometers only (no displacement sensor): sections 1 and 3 start virgin
    _stored(store, base_window, "ev2", 20.0, peaks, flagged=(0, 2),
            displacement_levels=np.zeros(n, dtype=bool))
    back = [r for r in store.results("pier7") if r.event_id == "ev2"][0]
    assert [s.rotation_peaks_after_rad is None for s in back.sections][:3] == [True, False,
                                                                              True]
    want = np.array(peaks).T
    want[:, [0, 2]] = 0.0
    np.testing.assert_allclose(store.rotation_peaks_before(later), want)
    # ... their peaks kept aside, through result.json: the history with them is offered too
    assert back.sections[0].rotation_peaks_unidentified_rad == pytest.approx(peaks[0])
    assert back.sections[1].rotation_peaks_unidentified_rad is None
    history = store.history_before(later)
    np.testing.assert_allclose(history.rotation_peaks, want)
    np.testing.assert_allclose(history.rotation_peaks_unidentified, np.array(peaks).T)
    assert replace(later, prior_rotation_peaks_unidentified=np.array(peaks).T
                   ).prior_rotation_peaks_unidentified.shape == (2, n)
    with pytest.raises(InputDataError, match="prior_rotation_peaks_unidentified"):
        replace(later, prior_rotation_peaks_unidentified=np.zeros((2, n + 1)))
    # a wire at level 1 measures section 1's rotation: its history stays
    disp = np.zeros(n, dtype=bool)
    disp[0] = True
    _stored(store, base_window, "ev3", 30.0, peaks, flagged=(0, 2), displacement_levels=disp)
    want[:, 0] = peaks[0]
    np.testing.assert_allclose(store.rotation_peaks_before(later), want)
    want[:, 2] = peaks[2]
    np.testing.assert_allclose(store.history_before(later).rotation_peaks_unidentified, want)
    # nothing flagged: no second history
    _stored(store, base_window, "ev4", 40.0, peaks, displacement_levels=np.zeros(n, dtype=bool))
    assert store.history_before(later).rotation_peaks_unidentified is None
    with pytest.raises(InputDataError, match="displacement levels"):
        back.with_history_identified(np.ones(n + 1, dtype=bool))


def test_a_df_flagged_only_because_a_yield_is_not_excluded_keeps_its_history(base_window,
                                                                             tmp_path):
    """A reconstructed section whose DF is poorly identified only because the data do not
    exclude a yield (its interval reaches up to the yield profile's DF; its peak rotation is
    identified) keeps its rotation history, through result.json; one that a self-check rule
    flagged as well (a neighbour's yield out of reach) does not."""
    from pier_monitor.core.identify.damage import YIELD_OUT_OF_REACH

    store = ResultsStore(tmp_path / "results")
    n = base_window.n_levels
    later = replace(base_window, pier_id="pier7", event_id="ev9",
                    start_time_ns=T0 + int(500e9))
    peaks = [(1e-3 * (i + 1), -5e-4 * (i + 1)) for i in range(n)]
    _stored(store, base_window, "ev1", 10.0, peaks, flagged=(0, 1, 2),
            displacement_levels=np.zeros(n, dtype=bool), profile_only=(1, 2),
            evidence={2: f"{YIELD_OUT_OF_REACH}: section 4's yield rotation is 6 times the "
                         "design's"})
    back = [r for r in store.results("pier7") if r.event_id == "ev1"][0]
    assert [s.df_flagged_by_yield_profile_only for s in back.sections][:3] == [False, True,
                                                                              False]
    assert back.sections[1].df_yield_not_excluded == (0.5, 1.3)
    # without draws the first number is NaN: written as null, read back as NaN
    lone = replace(back.sections[1], df_yield_not_excluded=(math.nan, 1.3))
    again = SectionResult.from_dict(json.loads(to_strict_json(lone.to_dict())))
    assert math.isnan(again.df_yield_not_excluded[0]) and again.df_yield_not_excluded[1] == 1.3
    assert [s.rotation_peaks_after_rad is None for s in back.sections][:3] == [True, False,
                                                                              True]
    want = np.array(peaks).T
    want[:, [0, 2]] = 0.0
    np.testing.assert_allclose(store.rotation_peaks_before(later), want)


def test_the_field_reconstructions_spring_starts_from_the_same_history():
    """Under a known moment, the damped Takeda spring of the field reconstruction carries the
    history: its moment is the Takeda moment of its own angle started from those peaks, and
    it turns further than the virgin spring under the same moment (6e6 N·m, below yield):
    the virgin climbs its uncracked and cracked branches, the cracked and yielded section
    reloads on its pinched, degraded loop."""
    dt = 0.01
    t = np.arange(600) * dt
    g = 6e6 * np.sin(2 * np.pi * 0.5 * t) * np.minimum(t / 2.0, 1.0)
    prior = (0.03, -0.025)
    theta, moment = damped_takeda(g, dt, SECTION, 2e6, prior)
    np.testing.assert_allclose(moment, takeda_moment(theta, SECTION, prior), rtol=1e-9,
                               atol=1e-9 * 6e6)
    theta0, _ = damped_takeda(g, dt, SECTION, 2e6)
    np.testing.assert_allclose(damped_takeda(g, dt, SECTION, 2e6, (0.0, 0.0))[0], theta0)
    assert np.abs(theta).max() > 1.2 * np.abs(theta0).max()


def test_an_identification_records_the_measured_history_it_leaves(base_window):
    """The fully measured window's own rotations (``θ = B x``) give each section's
    ``rotation_peaks_after_rad``, from the history it was given."""
    b = angle_matrix(base_window.geometry.section_heights_m)
    n = base_window.n_levels
    prior = np.stack([np.full(n, 0.05), np.full(n, -1e-4)])
    run = identify(replace(base_window, prior_rotation_peaks=prior),
                   IdentifySettings(members=1, seed=0))
    want = rotation_peaks_after(base_window.x @ b.T, base_window.dt, prior)
    got = np.array([s.rotation_peaks_after_rad for s in run.result.sections]).T
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert np.all(got[0] > 0.04)  # the history's larger peak carried through


def _takeda_section(k_small: Spread, df: float, yielded: bool) -> SectionResult:
    """A Takeda section of 200 draws: the stiffness after the event ``k_small`` (its mean
    the section's ``k_small_after``), the DF ``df`` within ±10 %, yielded or not, started
    virgin; its state the DF's."""
    u = SectionUncertainty(k1=k_small, k2=Spread.undefined(), fy=Spread.undefined(),
                           c=Spread(2e7, 1e6, 1.9e7, 2.1e7),
                           ductility_factor=Spread(df, 0.05 * df, 0.9 * df, 1.1 * df),
                           p_yielded=float(yielded),
                           p_state=(0.0, 0.0, 1.0) if df >= 1.5 else (1.0, 0.0, 0.0),
                           members=200)
    return SectionResult(
        index=0, z_bottom_m=0.0, z_top_m=2.0, k1=5e8, k2=5e7, fy=8e6, c=2e7,
        yield_angle_rad=0.01, max_angle_rad=0.01 * df, ductility_factor=df,
        state="damaged" if df >= 1.5 else "intact", yielded=yielded,
        k2_identifiable=yielded, fy_identifiable=yielded, uncertainty=u, family="takeda",
        k_small_after=k_small.mean)


def test_a_change_from_a_virgin_start_reaches_higher():
    """A Takeda section's stiffness change against an earlier event, where its spring
    started virgin (the history not measured), has its interval's upper end widened by
    VIRGIN_START_STIFFNESS in quadrature; its lower end and a change of a section that
    started from the measured history are the draws' with the family's resolution
    (RC_STIFFNESS_RESOLUTION for each event) alone."""
    spread = Spread(7e8, 1e7, 6.9e8, 7.1e8)  # ±1.43 %
    plain = k1_change_interval(7e8, spread, 1e9)
    wide = k1_change_interval(7e8, spread, 1e9, stiffer_by=0.2)
    assert wide.lo_pct == pytest.approx(plain.lo_pct)
    assert plain.hi_pct == pytest.approx(100 * (0.7 * (1 + 1e7 / 7e8) - 1), rel=1e-9)
    assert wide.hi_pct == pytest.approx(100 * (0.7 * (1 + math.hypot(1e7 / 7e8, 0.2)) - 1))
    with pytest.raises(InputDataError, match="stiffer_by"):
        k1_change_interval(7e8, spread, 1e9, stiffer_by=-0.1)
    sec = _takeda_section(spread, df=2.0, yielded=True)
    virgin = sec.rebased(1e9, -30.0, "event ev1", event=True, stiffness=7e8)
    known = replace(sec, history_known=True).rebased(1e9, -30.0, "event ev1", event=True,
                                                     stiffness=7e8)
    res = RC_STIFFNESS_RESOLUTION
    assert virgin.k1_change_hi_pct == pytest.approx(
        k1_change_interval(7e8, spread, 1e9, stiffer_by=0.2, resolution=res).hi_pct)
    assert virgin.k1_change_hi_pct == pytest.approx(
        100 * (0.7 * (1 + math.hypot(1e7 / 7e8, 0.2, res, res)) - 1))
    assert known.k1_change_hi_pct == pytest.approx(
        100 * (0.7 * (1 + math.hypot(1e7 / 7e8, res, res)) - 1))
    assert known.k1_change_lo_pct == pytest.approx(
        100 * (0.7 * (1 - math.hypot(1e7 / 7e8, res, res)) - 1))
    assert virgin.k1_change_lo_pct == pytest.approx(known.k1_change_lo_pct)
    # against design values (no earlier event) nothing is widened
    design = sec.rebased(1e9, -30.0, "design values", stiffness=7e8)
    assert design.k1_change_hi_pct == pytest.approx(plain.hi_pct)


def test_an_rc_sections_stiffness_gain_beyond_its_interval_is_not_identified():
    """A Takeda section whose stiffness after the event is clearly above the earlier event's
    (the change's interval wholly above zero) has its ``k1`` flagged poorly identified: a
    cracked section does not stiffen.  A bilinear section's, or a gain within the scatter,
    is not flagged, and against design values nothing is."""
    sec = replace(_takeda_section(Spread(1.3e9, 1e7, 1.28e9, 1.32e9), df=0.8,
                                  yielded=False), history_known=True)
    gain = sec.rebased(1e9, 30.0, "event ev1", event=True, stiffness=1.3e9)
    assert gain.k1_change_lo_pct > 0 and "k1" in gain.poorly_identified
    assert gain.state == "intact"  # a flag, never a state
    within = sec.rebased(1.29e9, 100 * (1.3 / 1.29 - 1), "event ev1", event=True,
                         stiffness=1.3e9)
    assert within.k1_change_lo_pct < 0 and "k1" not in within.poorly_identified
    assert "k1" not in sec.rebased(1e9, 30.0, "design values", stiffness=1.3e9).poorly_identified
    bilinear = replace(sec, family="bilinear", k_small_after=None)
    assert "k1" not in bilinear.rebased(1e9, 30.0, "event ev1", event=True).poorly_identified


def test_the_cumulative_df_of_a_section_started_from_its_history_is_on_the_reference():
    """A yielded base whose second event started from its measured history: its cumulative
    DF (peak so far over the first event's yield rotation) has the first event's relative
    interval alone, and the flag its own wide interval gave it goes; started virgin, the
    event's own spread (scaled) stays in it, and so does the flag."""
    base = replace(_takeda_section(Spread(1e9, 1e7, 0.98e9, 1.02e9), df=1.5, yielded=True),
                   yield_angle_rad=4e-3, max_angle_rad=6e-3)
    base = replace(base, uncertainty=replace(base.uncertainty,
                                             ductility_factor=Spread(1.5, 0.05, 1.4, 1.6)))
    own = replace(_takeda_section(Spread(6e8, 1e7, 5.8e8, 6.2e8), df=2.5, yielded=True),
                  yield_angle_rad=4e-3, max_angle_rad=1e-2, poorly_identified=("DF",))
    own = replace(own, uncertainty=replace(own.uncertainty,
                                           ductility_factor=Spread(2.5, 0.5, 1.0, 3.0)))
    known = replace(own, history_known=True).cumulative(base, 6e-3, "event ev1")
    assert known.ductility_factor == pytest.approx(2.5)
    iv = known.uncertainty.ductility_factor
    assert (iv.lo, iv.hi) == (pytest.approx(2.5 * (1 - 0.1 / 1.5)),
                              pytest.approx(2.5 * (1 + 0.1 / 1.5)))
    assert "DF" not in known.poorly_identified and known.state == "damaged"
    virgin = own.cumulative(base, 6e-3, "event ev1")
    assert virgin.uncertainty.ductility_factor.lo < 1.5 and "DF" in virgin.poorly_identified


def test_the_sequence_summary_counts_dfs_shown_as_identified_and_their_misses():
    """``summarize_rc_sequence``'s DF counts over both events of one sequence: a yielded
    base within its interval, a yielded section 2 shown as "not yielded" (DF 1.00 [1.00,
    1.00] against 4.11), the same flagged, and elastic sections intact and flagged."""
    from pier_monitor.bench import summarize_rc_sequence

    def event(n: int, df2: float, iv2: list[float], flags2: list[str], st2: str) -> dict:
        return {"case": "rcseqdraw_takeda_table1_accel", "seed": 1, "pier": "table1",
                "layout": "accel", "event": n, "states": ["damaged", st2, "intact"],
                "df": [3.0, df2, 0.5], "true_df": [3.3, 4.11, 0.4],
                "df_interval": [[2.7, 3.5], iv2, [0.3, 0.7]],
                "poorly_identified": [[], flags2, ["DF"] if n == 2 else []]}

    runs = [event(1, 1.0, [1.0, 1.0], [], "suspicious"),
            event(2, 1.0, [1.0, 8.6], ["DF"], "suspicious"),
            {"case": "rcseqdraw_takeda_table1_accel_summary", "seed": 1, "pier": "table1",
             "layout": "accel", "reported_k1_change_pct": [None] * 3,
             "reported_k1_change_interval_pct": [None] * 3,
             "true_k_small_change_pct_event2": [None] * 3}]
    d = summarize_rc_sequence(runs)["groups"]["table1/accel"]["df"]
    assert (d["yielded"], d["yielded_within_15pct"], d["yielded_interval_holds"]) == (4, 2, 3)
    assert (d["yielded_shown"], d["yielded_shown_missed"], d["yielded_not_yielded_shown"]) \
        == (3, 1, 1)
    assert (d["elastic"], d["elastic_intact"], d["elastic_df_flagged"]) == (2, 2, 1)
    assert d["intact_at_df_ge_1.5"] == d["damaged_at_df_lt_1.2"] == 0
    errs = [100 * abs(3.0 / 3.3 - 1)] * 2 + [100 * abs(1.0 / 4.11 - 1)] * 2
    assert d["yielded_err_pct_mean"] == pytest.approx(sum(errs) / 4)
