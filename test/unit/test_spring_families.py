"""Spring families: the Takeda rule on hand-checked cycles, skeletons, the idealised yield,
and the family chosen by evidence on simulated bilinear and RC histories."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.identify.equation_error import (
    SpringFit,
    fit_equation_error,
    inertia_moments,
)
from pier_monitor.core.identify.families import (fit_families, moment_noise_variance,
                                                 takeda_yielded)
from pier_monitor.core.model.ground_motion import synthetic_near_fault
from pier_monitor.core.model.link_model import angle_matrix, bilinear_step
from pier_monitor.core.model.springs import (
    TakedaParameters,
    bilinear_moment,
    bilinear_skeleton,
    idealised_yield,
    skeleton,
    takeda_moment,
    takeda_skeleton,
)
from pier_monitor.core.synthetic.rc import integrate_rc, rc_springs_from_design, rc_truth
from pier_monitor.core.synthetic.reference import paper_case_window, table1_model

# k0 = 10, θc = 0.1, cracked slope 3/0.9, k_y = 4, kp = 0.2
SMALL = TakedaParameters(k0=10.0, mc=1.0, my=4.0, theta_y=1.0, kp=0.2)
KU_AT_2 = 4.0 * 0.5 ** 0.4  # unloading stiffness after a peak of 2 = 2 θy


def test_takeda_skeleton_has_three_branches():
    th = np.array([0.05, 0.1, 0.55, 1.0, 3.0, -0.55, -3.0])
    want = np.array([0.5, 1.0, 1.0 + 3.0 * 0.45 / 0.9, 4.0, 4.4, -2.5, -4.4])
    np.testing.assert_allclose(skeleton(th, SMALL), want, rtol=1e-12)


def test_takeda_cycle_unloads_degraded_and_reloads_to_the_previous_peak():
    th = np.array([0.05, 0.1, 0.5, 1.0, 2.0, 1.5, 0.0, -0.5, -1.0, -2.0, -1.0, 0.0, 1.0, 2.0,
                   2.5])
    m = takeda_moment(th, SMALL)
    ku = KU_AT_2
    # loading on the skeleton to the peak (2, 4.2)
    np.testing.assert_allclose(m[:5], [0.5, 1.0, 1.0 + 3.0 * 0.4 / 0.9, 4.0, 4.2], rtol=1e-12)
    assert m[5] == pytest.approx(4.2 - 0.5 * ku, rel=1e-12)  # unloading at k_u
    # past zero moment it aims at the uncracked negative side's cracking point (-0.1, -1)
    t0n = 2.0 - 4.2 / ku
    assert m[6] == pytest.approx(-1.0 * (0.0 - t0n) / (-0.1 - t0n), rel=1e-12)
    np.testing.assert_allclose(m[7:10], [-1.0 - 3.0 * 0.4 / 0.9, -4.0, -4.2], rtol=1e-12)
    assert m[10] == pytest.approx(-4.2 + ku, rel=1e-12)
    # reloading from the crossing towards the previous positive peak (2, 4.2)
    t0p = -2.0 + 4.2 / ku
    for i, t in ((11, 0.0), (12, 1.0)):
        assert m[i] == pytest.approx(4.2 * (t - t0p) / (2.0 - t0p), rel=1e-12)
    np.testing.assert_allclose(m[13:], [4.2, 4.3], rtol=1e-12)


def test_takeda_pinched_reloading_passes_the_pinch_point():
    p = TakedaParameters(k0=10.0, mc=1.0, my=4.0, theta_y=1.0, kp=0.2, pinch_x=0.8,
                         pinch_y=0.2)
    m = takeda_moment(np.array([2.0, -2.0, 0.0, 1.0]), p)
    ku = KU_AT_2
    t0 = -2.0 + 4.2 / ku
    # pinch point: 0.8 of the way to where unloading from the peak reaches 0.2 · 4.2
    t_pinch = t0 + 0.8 * ((2.0 - 0.8 * 4.2 / ku) - t0)
    assert 0.0 < t_pinch < 1.0
    assert m[2] == pytest.approx(0.84 * (0.0 - t0) / (t_pinch - t0), rel=1e-12)
    assert m[3] == pytest.approx(0.84 + 3.36 * (1.0 - t_pinch) / (2.0 - t_pinch), rel=1e-12)
    assert m[2] < takeda_moment(np.array([2.0, -2.0, 0.0]), SMALL)[2]  # pinched is narrower


def test_bilinear_moment_is_the_spec_step_iterated():
    rng = np.random.default_rng(3)
    th = np.cumsum(rng.standard_normal(500)) * 2e-3
    f, prev, want = 0.0, 0.0, []
    for t in th:
        f = float(bilinear_step(f, prev, t, 1e9, 1e8, 5e6))
        prev = t
        want.append(f)
    np.testing.assert_allclose(bilinear_moment(th, 1e9, 1e8, 5e6), want, rtol=1e-12)



def test_bilinear_moment_from_a_yielded_start_continues_the_history():
    # a window cut from a longer record: started from the moment of its first sample, the
    # spring carries on exactly as the whole history; from rest it keeps a plastic offset
    rng = np.random.default_rng(4)
    th = np.cumsum(rng.standard_normal(800)) * 2e-3
    whole = bilinear_moment(th, 1e9, 1e8, 5e6)
    cut = 400
    np.testing.assert_allclose(
        bilinear_moment(th[cut:], 1e9, 1e8, 5e6, start_moment=whole[cut]), whole[cut:],
        rtol=1e-12, atol=1e-6)
    assert np.max(np.abs(bilinear_moment(th[cut:], 1e9, 1e8, 5e6) - whole[cut:])) > 1e5
    # a start beyond the yield surface is held on it
    s = 5e6 * (1 - 0.1)
    assert bilinear_moment(th[cut:], 1e9, 1e8, 5e6, start_moment=1e12)[0] == pytest.approx(
        1e8 * th[cut] + s, rel=1e-12)
    with pytest.raises(InputDataError, match="start_moment"):
        bilinear_moment(th, 1e9, 1e8, 5e6, start_moment=float("nan"))

def test_idealised_yield_is_fy_over_k1_for_the_bilinear():
    sk = bilinear_skeleton(1e9, 1e8, 5e6)
    for peak in (5.5e-3, 1e-2, 3e-2):
        assert idealised_yield(sk, peak) == pytest.approx(5e-3, rel=1e-12)
    assert idealised_yield(sk, 2e-3) == 5e-3  # not yielded: the yield point itself


def test_idealised_yield_of_a_takeda_skeleton_by_equal_energy():
    # area to θp = 4: 0.05 + 0.9·2.5 + 3·4.3 = 15.2, Mp = 4.6, k_y = 4
    assert idealised_yield(takeda_skeleton(SMALL), 4.0) == pytest.approx(
        (2 * 15.2 - 4.6 * 4.0) / (4.0 * 4.0 - 4.6), rel=1e-12)
    # just past yield the equal-energy point runs off; capped at Mp / k_y
    assert idealised_yield(takeda_skeleton(SMALL), 1.1) == pytest.approx(4.02 / 4.0, rel=1e-12)


def test_idealised_yield_floor_moves_an_early_takeda_corner_only():
    """min_yield_fraction: the elastic branch through the skeleton's point at f·Mp where
    that lies beyond the yield corner (a corner fitted on a smooth cracked curve, with a
    steep branch after it); a corner whose peak moment stays below My/f keeps its value."""
    for peak in (1.1, 2.0, 4.0):  # Mp <= 4.6 < 4/0.8: the corner is first yield
        assert idealised_yield(takeda_skeleton(SMALL), peak, 0.8) == idealised_yield(
            takeda_skeleton(SMALL), peak)
    early = takeda_skeleton(TakedaParameters(k0=10.0, mc=1.0, my=4.0, theta_y=1.0, kp=1.5))
    # θp = 3: Mp = 7, area 0.05 + 2.25 + 11 = 13.3; corner secant 4: (26.6 - 21) / (12 - 7)
    assert idealised_yield(early, 3.0) == pytest.approx(5.6 / 5.0, rel=1e-12)
    # floor 0.8·7 = 5.6 at θe = 1 + 1.6/1.5; secant 5.6/θe; equal energy runs past the cap
    # Mp/k_e = θe/0.8
    te = 1.0 + 1.6 / 1.5
    assert idealised_yield(early, 3.0, 0.8) == pytest.approx(te / 0.8, rel=1e-12)
    assert idealised_yield(early, 0.9, 0.8) == 1.0  # not yielded: the corner itself
    assert idealised_yield(bilinear_skeleton(1e9, 1e8, 5e6), 1e-2, 0.0) == pytest.approx(5e-3)
    with pytest.raises(InputDataError, match="min_yield_fraction"):
        idealised_yield(early, 3.0, 1.0)


def test_takeda_parameters_and_histories_are_checked():
    with pytest.raises(InputDataError, match="mc < my"):
        TakedaParameters(k0=10.0, mc=5.0, my=4.0, theta_y=1.0, kp=0.2)
    with pytest.raises(InputDataError, match="non-finite angle .* at sample 1"):
        takeda_moment(np.array([0.0, np.nan]), SMALL)


def test_fit_families_checks_its_inputs():
    th = np.zeros((50, 2))
    fit = SpringFit(1e9, 1e8, 5e6, 2e7, False, 1.0, 1.0, 0)
    with pytest.raises(InputDataError, match=r"g: expected shape \(50, 2\)"):
        fit_families(th, th, th[:, :1], np.ones(2), (fit, fit))
    with pytest.raises(InputDataError, match="angle is zero over the whole window"):
        fit_families(th, th, th, np.ones(2), (fit, fit))


def _fit_pier(geometry, x, v, a, ag, design, noise):
    ee = fit_equation_error(geometry, x, v, a, ag, design)
    b = angle_matrix(geometry.section_heights_m)
    g = inertia_moments(geometry, a, ag)
    nv = moment_noise_variance(geometry, noise, ee.params.k1, ee.params.c)
    return fit_families(x @ b.T, v @ b.T, g, nv, ee.springs)


def test_bilinear_data_choose_the_bilinear_with_its_ductility():
    window, truth, resp = paper_case_window(moments_measured=False, window_s=(30.0, 45.0))
    ch = _fit_pier(window.geometry, window.x, window.v, window.a, window.ag, window.design,
                   window.noise)
    assert ch.family == "bilinear", ch.reason
    assert ch.bic_total["takeda"] - ch.bic_total["bilinear"] > 50.0
    peak = np.abs(resp.theta).max(axis=0)
    df_true = peak / (truth.fy / truth.k1)
    assert ch.ductility_factor[0] == pytest.approx(df_true[0], rel=0.10)
    np.testing.assert_array_equal(ch.stiffness_degradation, 0.0)


def test_rc_data_choose_the_takeda_with_the_idealised_ductility():
    geometry, design = table1_model()
    springs = rc_springs_from_design(design)
    gm = synthetic_near_fault(pga_mps2=4.5)
    run = integrate_rc(geometry, springs, gm.acc[:int(45 / gm.dt)], gm.dt, output_dt=0.01)
    resp = run.response.window(25.0, 45.0)  # every spring still uncracked at 25 s
    rng = np.random.default_rng(0)
    noise = paper_case_window()[0].noise  # 1 mgal accelerations, same SNR elsewhere
    sd = {k: float(np.max(np.abs(getattr(resp, k)))) * 1e-4 for k in ("x", "v")}
    x = resp.x + sd["x"] * rng.standard_normal(resp.x.shape)
    v = resp.v + sd["v"] * rng.standard_normal(resp.v.shape)
    a = resp.a + 1e-5 * rng.standard_normal(resp.a.shape)
    ag = resp.ag + 1e-5 * rng.standard_normal(resp.ag.shape)
    ch = _fit_pier(geometry, x, v, a, ag, design.scaled(k1=0.5, k2=0.5, fy=0.1, c=0.5), noise)
    truth = rc_truth(springs, run.state_start, run.state_end)
    assert ch.family == "takeda", ch.reason
    assert truth.ductility_factor[0] > 2.0
    assert ch.ductility_factor[0] == pytest.approx(truth.ductility_factor[0], rel=0.10)
    # the base lost small-amplitude stiffness; the bilinear's k1 lies between k0 and k_u
    assert ch.stiffness_degradation[0] == pytest.approx(
        truth.k_small_after[0] / truth.k_small_before[0] - 1.0, abs=0.10)
    assert "takeda chosen" in ch.reason


@pytest.mark.parametrize("margin, bilinear, yielded", [
    (8.3, False, False),   # fiber column, shaking 1, section 3: bars at 0.23 of yield
    (157.6, False, True),  # fiber column, shaking 1, base: bars at 3.3 times yield
    (2.2, True, True),     # bwbn springs, 10 s window (n_eff 10), base: DF 2.8
    (20.5, True, True),    # bwbn springs, E-Defense strong, base: DF 3.3
    (-4.3, True, False),   # fiber column, shaking 2, base: the fit held below yield is better
])
def test_a_takeda_yield_needs_very_strong_evidence_or_a_second_witness(margin, bilinear,
                                                                       yielded):
    """Crack opening is no yield: a kink on a smoothly cracking branch fits a little better
    than the Takeda held below yield, and the bilinear finds no yield in it.  The margins
    are those measured (BIC of the unyielded Takeda minus the Takeda's, see
    :data:`YIELD_EVIDENCE`)."""
    assert takeda_yielded(margin, bilinear) is yielded
