"""The RC test-bed: modified-Takeda springs, Rayleigh damping, RC truth, recordings, CLI."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from pier_monitor.bags.reader import read_bag
from pier_monitor.bags.synthetic_bag import truth_paths
from pier_monitor.cli import main
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.config import PierGeometry, SpringParameters, load_config
from pier_monitor.core.model.ground_motion import synthetic_near_fault
from pier_monitor.core.model.link_model import angle_matrix
from pier_monitor.core.model.solver import simulate
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.rc import (RCSprings, drive_spring, idealised_yield_rotation,
                                            integrate_rc, rc_springs_from_design, rc_truth,
                                            skeleton_moment, stiffness_periods)
from pier_monitor.core.synthetic.shaking_table import (edefense_scenario, generate_recording,
                                                       load_truth)

MY = 5e6  # N·m
K1 = 1e9  # N·m/rad
TY = MY / K1  # rad


@pytest.fixture(scope="module")
def one_spring() -> RCSprings:
    return rc_springs_from_design(SpringParameters([K1], [1e8], [MY], [1e7]))


@pytest.fixture(scope="module")
def edefense():
    return load_config(find_config_file("edefense_like.yaml"))


def _ramp(*targets: float, per_unit: int = 2000) -> np.ndarray:
    """Angles through ``targets`` (rad), in small steps from 0."""
    pts = [0.0, *targets]
    parts = [np.linspace(a, b, max(2, int(abs(b - a) / TY * per_unit)))[1:]
             for a, b in zip(pts[:-1], pts[1:])]
    return np.concatenate(parts)


def test_design_mapping_keeps_the_bilinear_yield_point(one_spring):
    s = one_spring
    assert s.k0[0] == pytest.approx(1.6 * K1)
    assert s.my[0] == MY and s.mc[0] == pytest.approx(0.25 * MY)
    assert s.theta_y[0] == pytest.approx(TY) and s.k_y[0] == pytest.approx(K1)
    assert s.kp[0] == pytest.approx(0.03 * 1.6 * K1)
    with pytest.raises(InputDataError, match="section 1: expected 0 < mc < my"):
        RCSprings(k0=[2e9], mc=[6e6], my=[5e6], theta_y=[TY], kp=[0.0], theta_u=[0.1])


def test_takeda_cycle_follows_the_hand_checked_rules(one_spring):
    s = one_spring
    k0, mc, kp = s.k0[0], s.mc[0], s.kp[0]
    tc = mc / k0
    kc = (MY - mc) / (TY - tc)
    # uncracked, cracked, post-yield branches of the skeleton
    th = _ramp(0.5 * tc, 0.5 * TY, 3.0 * TY)
    m, state = drive_spring(s, 0, th)
    at = lambda x: m[np.argmin(np.abs(th - x))]  # noqa: E731
    assert at(0.5 * tc) == pytest.approx(k0 * 0.5 * tc, rel=1e-9)
    assert at(0.5 * TY) == pytest.approx(mc + kc * (0.5 * TY - tc), rel=1e-9)
    assert m[-1] == pytest.approx(MY + kp * 2.0 * TY, rel=1e-9)
    # unloading at k_u = k_y (θy / θmax)^α, from the peak down to zero moment
    ku = K1 * (1.0 / 3.0) ** 0.4
    back = np.linspace(3.0 * TY, 3.0 * TY - 0.5 * m[-1] / ku, 50)[1:]
    m_back, _ = drive_spring(s, 0, back, state)
    assert np.diff(m_back) / np.diff(back) == pytest.approx(np.full(48, ku), rel=1e-9)
    assert state.unloading_stiffness(s)[0] == pytest.approx(ku, rel=1e-12)
    # past the zero crossing, reloading aims at the pinch point on the way to the negative
    # peak, still the cracking point (−θc, −Mc): the pinch moment is pinch_y of the peak's
    cross = 3.0 * TY - m[-1] / ku
    rotmp2 = -tc + (1.0 - s.pinch_y) * mc / ku
    rotch = cross + s.pinch_x * (rotmp2 - cross)
    down = np.linspace(3.0 * TY, rotch, 4001)[1:]
    m_down, _ = drive_spring(s, 0, down, state)
    assert m_down[-1] == pytest.approx(-s.pinch_y * mc, rel=1e-9)


def _loop(springs: RCSprings, amplitude: float, cycles: int = 1) -> tuple[np.ndarray, np.ndarray]:
    th = _ramp(*([amplitude, -amplitude] * cycles), amplitude)
    m, _ = drive_spring(springs, 0, th)
    return th, m


def test_pinching_narrows_the_loop_at_zero_rotation(one_spring):
    open_loops = dataclasses.replace(one_spring, pinch_x=1.0, pinch_y=1.0, beta_e=0.0)
    pinched = dataclasses.replace(one_spring, beta_e=0.0)
    widths, energies = [], []
    for springs in (open_loops, pinched):
        th, m = _loop(springs, 4.0 * TY, cycles=2)
        second = slice(th.size // 2, None)  # second cycle: both sides have peaked
        t2, m2 = th[second], m[second]
        crossings = np.flatnonzero(np.diff(np.sign(t2)) != 0)
        widths.append(np.ptp(m2[crossings]))  # moment span of the loop at θ = 0
        energies.append(np.trapezoid(m2, t2))
    assert widths[1] < 0.8 * widths[0]
    assert 0.3 * energies[0] < energies[1] < 0.9 * energies[0]
    # the unpinched reload goes straight from the zero crossing to the previous peak
    assert widths[0] > 0.5 * MY


def test_strength_degrades_a_few_percent_per_large_cycle(one_spring):
    th, m = _loop(one_spring, 4.0 * TY, cycles=5)
    peaks = m[np.isclose(th, 4.0 * TY)]
    assert peaks.size == 6
    loss = 1.0 - peaks[1:] / peaks[:-1]
    assert np.all(loss > 0.01) and np.all(loss < 0.06)
    # a monotonic push follows the virgin skeleton: no loss without reversals
    push = _ramp(6.0 * TY)
    m_push, _ = drive_spring(one_spring, 0, push)
    assert m_push == pytest.approx(skeleton_moment(one_spring, 0, push), rel=1e-12)


def test_monotonic_push_truth(one_spring):
    push = _ramp(4.0 * TY)
    _, end = drive_spring(one_spring, 0, push)
    from pier_monitor.core.synthetic.rc import RCState

    truth = rc_truth(one_spring, RCState.virgin(one_spring), end)
    # equal-energy bilinear, elastic slope k_y = K1, computed here by quadrature
    grid = np.linspace(0.0, 4.0 * TY, 400_001)
    area = np.trapezoid(skeleton_moment(one_spring, 0, grid), grid)
    mp = skeleton_moment(one_spring, 0, np.array([4.0 * TY]))[0]
    ty_id = (2.0 * area - mp * 4.0 * TY) / (K1 * 4.0 * TY - mp)
    assert 1.0 * TY < ty_id < 1.1 * TY
    assert truth.idealised_yield_rotation_rad[0] == pytest.approx(ty_id, rel=1e-6)
    assert truth.ductility_factor[0] == pytest.approx(4.0 * TY / ty_id, rel=1e-6)
    assert truth.yielded[0] and truth.cracked[0]
    assert truth.k_small_before[0] == pytest.approx(1.6 * K1)
    assert truth.k_small_after[0] == pytest.approx(K1 * 0.25 ** 0.4)
    # not yet yielded: the idealised yield is first yield, and it never runs off past it
    assert idealised_yield_rotation(one_spring, np.array([0.8 * TY]))[0] == TY
    just = idealised_yield_rotation(one_spring, np.array([1.01 * TY]))[0]
    assert TY <= just <= skeleton_moment(one_spring, 0, np.array([1.01 * TY]))[0] / K1


def _two_level():
    geometry = PierGeometry(np.array([2.0, 2.0]), np.array([20_000.0, 200_000.0]))
    params = SpringParameters([1.5e9, 1.2e9], [1.5e8, 1.2e8], [9e6, 7e6], [1.0, 1.0])
    return geometry, params


def test_springs_that_never_crack_match_the_bilinear_solver():
    geometry, params = _two_level()
    elastic = RCSprings(k0=params.k1, mc=[1e15, 1e15], my=[2e15, 2e15],
                        theta_y=2e15 / params.k1 * 1.5, kp=[0.0, 0.0], theta_u=[1e9, 1e9])
    gm = synthetic_near_fault(pga_mps2=4.0, seed=3, duration_s=12.0, dt=0.005, strong_start_s=2.0,
                              strong_duration_s=6.0)
    a1 = 0.003  # stiffness-proportional Rayleigh = a rotational damper a1 k1 per spring
    rc = integrate_rc(geometry, elastic, gm.acc, gm.dt, rayleigh=(0.0, a1)).response
    ref = simulate(geometry, SpringParameters(params.k1, params.k2, params.fy * 1e9,
                                              a1 * params.k1), gm.acc, gm.dt)
    scale = np.abs(ref.x).max()
    assert scale > 1e-3
    assert np.abs(rc.x - ref.x).max() < 1e-9 * scale
    assert np.abs(rc.a - ref.a).max() < 1e-9 * np.abs(ref.a).max()
    assert np.abs(rc.moment - ref.moment).max() < 1e-9 * np.abs(ref.moment).max()


def test_mass_and_stiffness_damping_matches_the_closed_form_sdof():
    m, k, v0 = 1.0e5, 4.0e7, 0.2
    geometry = PierGeometry(np.array([2.0]), np.array([m]))
    kl = k * 4.0  # θ = x / h: the spring sees k h² for the mass's k
    springs = RCSprings(k0=[kl], mc=[1e15], my=[2e15], theta_y=[2e15 / kl * 1.5], kp=[0.0],
                        theta_u=[1e9])
    w = np.sqrt(k / m)
    a0, a1 = 0.4, 0.001
    zeta = 0.5 * (a0 / w + a1 * w)
    wd = w * np.sqrt(1.0 - zeta ** 2)
    run = integrate_rc(geometry, springs, np.zeros(3001), 0.001, rayleigh=(a0, a1),
                       v0=np.array([v0]))
    t = run.response.t
    exact = v0 / wd * np.exp(-zeta * w * t) * np.sin(wd * t)
    # linear-acceleration Newmark: period error ~ (ω dt)² / 24, 2e-5 here
    assert np.abs(run.response.x[:, 0] - exact).max() < 1e-3 * v0 / wd
    assert run.rayleigh == (a0, a1)


@pytest.mark.parametrize("family", ["takeda", "bwbn"])
def test_energy_balance_of_an_rc_run(edefense, family):
    params = edefense.design
    springs = rc_springs_from_design(params, family=family)
    pga = {"takeda": 5.0, "bwbn": 7.0}[family]  # smooth loops dissipate more: shake harder
    gm = synthetic_near_fault(pga_mps2=pga, seed=1994, duration_s=20.0, dt=0.005,
                              strong_start_s=4.0, strong_duration_s=8.0)
    run = integrate_rc(edefense.geometry, springs, gm.acc, gm.dt, output_dt=0.001)
    r = run.response
    b = angle_matrix(edefense.geometry.section_heights_m)
    mass = edefense.geometry.masses_kg
    a0, a1 = run.rayleigh
    cmat = a0 * np.diag(mass) + a1 * (b.T @ (springs.k0[:, None] * b))
    dt = 0.001
    trap = lambda y: float(np.sum(0.5 * (y[1:] + y[:-1])) * dt)  # noqa: E731
    e_input = trap(-(r.v @ mass) * r.ag)
    e_damp = trap(np.einsum("ti,ij,tj->t", r.v, cmat, r.v))
    e_kin = 0.5 * float(r.v[-1] ** 2 @ mass)
    work = run.state_end.values[:, 7]  # ∫ M dθ of each spring, accumulated by the solver
    assert np.sum(work) == pytest.approx(trap(np.sum(r.moment * np.gradient(r.theta, dt, axis=0),
                                                     axis=1)), rel=2e-3)
    assert e_kin + e_damp + np.sum(work) == pytest.approx(e_input, rel=2e-3)
    truth = rc_truth(springs, run.state_start, run.state_end)
    assert truth.yielded[0] and truth.ductility_factor[0] > 1.5
    stored = run.state_end.moment ** 2 / (2.0 * run.state_end.unloading_stiffness(springs))
    assert truth.hysteretic_energy_J == pytest.approx(work - stored, rel=1e-12)
    assert np.all(truth.hysteretic_energy_J > 0)
    # hysteresis dissipates a good share of the input, damping the rest
    assert 0.1 * e_input < np.sum(truth.hysteretic_energy_J) < 0.9 * e_input


def test_bwbn_is_smooth_pinches_more_and_degrades_with_cycles():
    s = rc_springs_from_design(SpringParameters([K1], [1e8], [MY], [1e7]), family="bwbn")
    # the virgin curve: initial slope k0, through the yield point, final slope kp
    sk = skeleton_moment(s, 0, np.array([1e-6 * TY, TY, 20.0 * TY, 21.0 * TY]))
    assert sk[0] / (1e-6 * TY) == pytest.approx(s.k0[0], rel=1e-4)
    assert sk[1] == pytest.approx(MY, rel=1e-8)
    assert sk[3] - sk[2] == pytest.approx(s.kp[0] * TY, rel=1e-3)
    # a first push follows it closely (the degradation has hardly begun)
    push = _ramp(2.0 * TY)
    m_push, _ = drive_spring(s, 0, push)
    np.testing.assert_allclose(m_push, skeleton_moment(s, 0, push), rtol=0.01, atol=0.002 * MY)
    # no corner: the tangent changes gradually through yield
    slopes = np.diff(m_push) / np.diff(push)
    assert np.abs(np.diff(slopes)).max() < 0.01 * s.k0[0]
    th, m = _loop(s, 4.0 * TY, cycles=4)
    peaks = m[np.isclose(th, 4.0 * TY)]
    assert np.all(np.diff(peaks) < 0) and peaks[-1] > 0.85 * peaks[0]
    # the loop narrows at zero rotation from cycle to cycle (pinching grows with energy)
    n = th.size // 4
    widths = []
    for c in range(4):
        t2, m2 = th[c * n:(c + 1) * n], m[c * n:(c + 1) * n]
        crossings = np.flatnonzero(np.diff(np.sign(t2)) != 0)
        widths.append(np.ptp(m2[crossings]))
    assert widths[3] < 0.85 * widths[1]


def _short(**kw):
    return edefense_scenario(record_s=14.0, lead_s=2.0, gap_s=4.0, tail_s=2.0, **kw)


def test_bilinear_option_is_the_default(edefense):
    default = generate_recording(edefense, _short(), seed=3)
    explicit = generate_recording(edefense, _short(hysteresis="bilinear"), seed=3,
                                  hysteresis="bilinear")
    assert default.truth.hysteresis == "bilinear"
    for sid, rec in default.recording.sensors.items():
        np.testing.assert_array_equal(rec.data, explicit.recording.sensors[sid].data)
    for a, b in zip(default.truth.runs, explicit.truth.runs):
        assert a.rc is None and b.rc is None
        np.testing.assert_array_equal(a.response.x, b.response.x)
    assert "rc" not in default.truth.runs[0].summary()
    with pytest.raises(InputDataError, match="hysteresis: expected one of"):
        generate_recording(edefense, _short(), hysteresis="trilinear")


def test_takeda_runs_carry_the_damage_into_the_next_run(edefense):
    rec = generate_recording(edefense, _short(hysteresis="takeda"), seed=3, hysteresis="takeda")
    run1, run2 = rec.truth.runs
    assert run1.rc is not None and run2.rc is not None
    np.testing.assert_array_equal(run2.rc.k_small_before, run1.rc.k_small_after)
    assert np.all(run1.rc.k_small_after < run1.rc.k_small_before)
    assert np.all(run2.rc.peak_rotation_rad >= run1.rc.peak_rotation_rad)
    np.testing.assert_array_equal(run1.ductility_factors, run1.rc.ductility_factor)
    # the springs' angles include the residual rotation: θ = B (offset + x)
    b = angle_matrix(run2.geometry.section_heights_m)
    np.testing.assert_allclose(run2.response.theta, (run2.initial_offset_m + run2.response.x)
                               @ b.T, rtol=0, atol=1e-12)
    # the same springs in both runs (run 2's parameter factors are damage of the bilinear)
    assert run1.params == run2.params
    # periods of the small-amplitude stiffnesses: the cracked pier starts run 2 softer
    np.testing.assert_allclose(run2.periods_s,
                               stiffness_periods(run2.geometry, run1.rc.k_small_after))
    assert run2.periods_s[0] > 1.2 * run1.periods_s[0]
    after = run1.summary()["rc_small_amplitude_periods_s"]["after"]
    assert after[0] > run1.periods_s[0]


@pytest.mark.parametrize("family", ["takeda", "bwbn"])
def test_simulate_rc_writes_a_readable_bag_and_truth(tmp_path, capsys, family):
    out = tmp_path / "rc.mcap"
    rc = main(["simulate", "--out", str(out), "--hysteresis", family, "--layout", "sparse",
               "--scenario", "just_yield", "--no-imperfections"])
    text = capsys.readouterr().out
    assert rc == 0
    assert f"RC springs ({family})" in text
    recording = read_bag(out)
    assert {s.kind for s in recording.config.sensors} == {"acceleration"}
    assert {s.level for s in recording.config.sensors} == {0, 2, 4}
    npz, js = truth_paths(out)
    meta = json.loads(js.read_text())
    assert meta["hysteresis"] == family
    run = meta["runs"][0]
    assert set(run["rc"]) >= {"ductility_factor", "yielded", "k_small_before", "k_small_after",
                              "hysteretic_energy_J", "idealised_yield_rotation_rad"}
    assert 1.2 <= run["rc"]["ductility_factor"][0] <= 1.5
    assert run["rc"]["yielded"] == [True, False, False, False]
    truth = load_truth(npz, js)
    assert truth.hysteresis == family
    np.testing.assert_allclose(truth.runs[0].rc.ductility_factor, run["rc"]["ductility_factor"])
    assert truth.runs[0].rc_springs.k0 == pytest.approx(run["rc_springs"]["k0_Nm_per_rad"])
    rc = main(["simulate", "--out", str(tmp_path / "r.npz"), "--hysteresis", "takeda"])
    assert rc == 2
    assert "--hysteresis apply to bags" in capsys.readouterr().err
