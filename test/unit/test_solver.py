"""Verification of the Newmark solver against independent solutions (SPEC §3)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate, linalg, signal

from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.link_model import (angle_matrix, bilinear_step, damping_matrix,
                                     elastic_stiffness_matrix, estimated_moments,
                                     natural_periods)
from pier_monitor.core.model.solver import simulate

DT = 0.001


def rel_rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b ** 2)))


def elastic_sdof(k=1.6e7, m=1.0e5, c=2.5e5, h=2.0):
    """An SDOF link model that never yields (huge fy): period 1.0 s, 5 % damping."""
    return (PierGeometry(np.array([h]), np.array([m])),
            SpringParameters(np.array([k]), np.array([k / 10]), np.array([1e12]), np.array([c])))


def test_angle_matrix_matches_paper_equations():
    h = np.array([1.0, 2.0, 0.5, 1.5])
    x = np.array([0.011, 0.037, 0.023, 0.052])
    theta = angle_matrix(h) @ x
    expected = [x[0] / h[0],
                (x[1] - x[0]) / h[1] - x[0] / h[0],
                (x[2] - x[1]) / h[2] - (x[1] - x[0]) / h[1],
                (x[3] - x[2]) / h[3] - (x[2] - x[1]) / h[2]]
    np.testing.assert_allclose(theta, expected, rtol=1e-12, atol=1e-15)


def test_table1_first_period_is_about_1_97_s(table1):
    periods = natural_periods(*table1)
    assert periods[0] == pytest.approx(1.97, abs=0.01)


def test_free_vibration_matches_closed_form_sdof():
    geometry, params = elastic_sdof()
    h, m = geometry.section_heights_m[0], geometry.masses_kg[0]
    k, c = params.k1[0] / h ** 2, params.c[0] / h ** 2  # translational, N/m and N·s/m
    w = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    wd = w * np.sqrt(1 - zeta ** 2)
    x0, v0 = 0.02, -0.1
    resp = simulate(geometry, params, np.zeros(10001), DT, x0=[x0], v0=[v0])
    t = resp.t
    exact = np.exp(-zeta * w * t) * (x0 * np.cos(wd * t) + (v0 + zeta * w * x0) / wd * np.sin(wd * t))
    assert rel_rms(resp.x[:, 0], exact) < 1e-4
    assert resp.theta[:, 0] == pytest.approx(resp.x[:, 0] / h, rel=1e-12)


def test_harmonic_ground_motion_matches_closed_form_sdof():
    geometry, params = elastic_sdof()
    h, m = geometry.section_heights_m[0], geometry.masses_kg[0]
    k, c = params.k1[0] / h ** 2, params.c[0] / h ** 2
    w = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    wd = w * np.sqrt(1 - zeta ** 2)
    amp, big_w = 3.0, 0.7 * w
    t = np.arange(0, 8.0 + DT / 2, DT)
    resp = simulate(geometry, params, amp * np.sin(big_w * t), DT)
    # x'' + 2ζωx' + ω²x = −A sin Ωt, at rest at t = 0
    mat = np.array([[w ** 2 - big_w ** 2, -2 * zeta * w * big_w],
                     [2 * zeta * w * big_w, w ** 2 - big_w ** 2]])
    p, q = np.linalg.solve(mat, [-amp, 0.0])
    xh0, vh0 = -q, -p * big_w
    exact = (p * np.sin(big_w * t) + q * np.cos(big_w * t)
             + np.exp(-zeta * w * t) * (xh0 * np.cos(wd * t)
                                       + (vh0 + zeta * w * xh0) / wd * np.sin(wd * t)))
    assert rel_rms(resp.x[:, 0], exact) < 1e-4


def _modal_superposition(geometry, params, ag, dt):
    """Elastic response of a classically damped model (C = βK) from exact modal solutions."""
    b = angle_matrix(geometry.section_heights_m)
    k = elastic_stiffness_matrix(b, params.k1)
    m = np.diag(geometry.masses_kg)
    omega2, phi = linalg.eigh(k, m)  # mass-normalised modes
    beta = params.c[0] / params.k1[0]
    t = np.arange(ag.size) * dt
    x = np.zeros((ag.size, geometry.n_levels))
    gamma = phi.T @ m @ np.ones(geometry.n_levels)
    for j, w2 in enumerate(omega2):
        sys = signal.StateSpace([[0, 1], [-w2, -beta * w2]], [[0], [-gamma[j]]], [[1, 0]], [[0]])
        _, q, _ = signal.lsim(sys, ag, t, interp=True)  # exact for piecewise-linear input
        x += np.outer(q, phi[:, j])
    return x


def test_elastic_six_mass_model_matches_modal_superposition(table1):
    geometry, table = table1
    k1 = table.k1
    params = SpringParameters(k1, k1 / 10, np.full(6, 1e12), 0.02 * k1)  # C = 0.02 K: classical
    t = np.arange(0, 20.0 + DT / 2, DT)
    ag = 3.0 * np.sin(2 * np.pi * 0.8 * t) * np.exp(-((t - 6) / 3) ** 2)
    resp = simulate(geometry, params, ag, DT)
    exact = _modal_superposition(geometry, params, ag, DT)
    for n in range(6):
        assert rel_rms(resp.x[:, n], exact[:, n]) < 1e-4, n


def test_elastic_nonclassical_damping_matches_state_space_solution(table1):
    """Table 1 damping (spring 2 differs) is not proportional: compare with the exact
    first-order-hold solution of the state-space form."""
    geometry, table = table1
    params = SpringParameters(table.k1, table.k2, np.full(6, 1e12), table.c)
    b = angle_matrix(geometry.section_heights_m)
    minv = np.diag(1 / geometry.masses_kg)
    kmat, cmat = elastic_stiffness_matrix(b, params.k1), damping_matrix(b, params.c)
    a_ss = np.block([[np.zeros((6, 6)), np.eye(6)], [-minv @ kmat, -minv @ cmat]])
    b_ss = np.concatenate([np.zeros(6), -np.ones(6)])[:, None]
    c_ss = np.hstack([np.eye(6), np.zeros((6, 6))])
    t = np.arange(0, 15.0 + DT / 2, DT)
    ag = 2.0 * np.sin(2 * np.pi * 0.5 * t) + 1.0 * np.sin(2 * np.pi * 3.1 * t)
    _, exact, _ = signal.lsim(signal.StateSpace(a_ss, b_ss, c_ss, np.zeros((6, 1))), ag, t,
                              interp=True)
    resp = simulate(geometry, params, ag, DT)
    for n in range(6):
        assert rel_rms(resp.x[:, n], exact[:, n]) < 1e-4, n


def test_bilinear_step_hand_checked_cycle():
    """θ: 0 → 2θy → unload to zero moment → reverse yield, values worked out by hand."""
    k1, k2, fy = 1.0e9, 1.0e8, 5.0e6
    ty = fy / k1  # 0.005 rad
    s = fy * (1 - k2 / k1)  # 4.5e6
    path = [0.0, 0.5 * ty, ty, 1.5 * ty, 2 * ty, 1.5 * ty, 0.0, -ty, -2 * ty]
    f, th = 0.0, 0.0
    got = []
    for target in path[1:]:
        # fine sub-steps, as the solver takes them
        for sub in np.linspace(th, target, 50)[1:]:
            f = float(bilinear_step(f, th, sub, k1, k2, fy))
            th = sub
        got.append(f)
    f_peak = fy + k2 * ty  # 5.5e6 at 2θy on the second branch
    expected = [
        0.5 * fy,                      # elastic
        fy,                            # yield point
        fy + k2 * 0.5 * ty,            # on the upper skeleton line
        f_peak,
        f_peak - k1 * 0.5 * ty,        # unloading at slope k1: 0.5e6
        f_peak - k1 * 2 * ty,          # still elastic at θ = 0: -4.5e6 (> lower line -4.5e6)
        k2 * (-ty) - s,                # reverse yield: lower line at −θy: -5.0e6
        k2 * (-2 * ty) - s,            # -5.5e6
    ]
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-6)
    # residual angle after unloading from the peak: θ = 2θy − f_peak/k1
    assert 2 * ty - f_peak / k1 == pytest.approx(ty * (1 - k2 / k1))


def test_bilinear_is_history_dependent_not_memoryless():
    """The memoryless reading of the paper's eq. 8 would return k1 θ after unloading."""
    k1, k2, fy = 1.0e9, 1.0e8, 5.0e6
    f1 = float(bilinear_step(0.0, 0.0, 0.02, k1, k2, fy))   # big yield in one step
    f2 = float(bilinear_step(f1, 0.02, 0.018, k1, k2, fy))   # unload a little
    assert f1 == pytest.approx(k2 * 0.02 + fy * (1 - k2 / k1))
    assert f2 == pytest.approx(f1 - k1 * 0.002)
    assert f2 != pytest.approx(min(k1 * 0.018, k2 * 0.018 + fy * 0.9))


def test_bilinear_sdof_free_vibration_yield_unload_and_residual_angle():
    """Undamped SDOF kicked past yield: the peak angle follows from the energy balance,
    unloading is at slope k1, and it then oscillates elastically about the residual angle."""
    h, m = 1.0, 6.0e5  # period 0.49 s
    k1, k2, fy = 1.0e8, 1.0e7, 1.0e5
    geometry = PierGeometry(np.array([h]), np.array([m]))
    params = SpringParameters(np.array([k1]), np.array([k2]), np.array([fy]), np.array([0.0]))
    ty = fy / k1
    v0 = 0.03  # m/s; kinetic energy 270 J, elastic capacity fy θy / 2 = 50 J
    resp = simulate(geometry, params, np.zeros(3001), DT, v0=[v0])
    th, f = resp.theta[:, 0], resp.moment[:, 0]
    # hand solution: ½ m v0² = ½ fy θy + (fy + ½ k2 (θm − θy)) (θm − θy)
    e = 0.5 * m * v0 ** 2 - 0.5 * fy * ty
    d = (-fy + np.sqrt(fy ** 2 + 2 * k2 * e)) / k2
    theta_max = ty + d
    f_max = fy + k2 * d
    assert th.max() == pytest.approx(theta_max, rel=1e-4)
    assert f.max() == pytest.approx(f_max, rel=1e-4)
    # unloading at slope k1 from the peak; zero moment at the residual angle θm − fm/k1;
    # kinematic hardening: reverse yield where the unloading line meets k2 θ − s
    s = fy * (1 - k2 / k1)
    residual = theta_max - f_max / k1
    theta_rev = (f_max - k1 * theta_max + s) / (k2 - k1)
    i_peak = int(np.argmax(th))
    i_rev = i_peak + int(np.argmax(th[i_peak:] <= theta_rev))
    unload = slice(i_peak + 1, i_rev)
    np.testing.assert_allclose(f[unload], f_max - k1 * (theta_max - th[unload]),
                               atol=2e-3 * f_max)
    i0 = i_peak + int(np.argmax(f[i_peak:] <= 0))
    theta_zero = np.interp(0.0, [f[i0], f[i0 - 1]], [th[i0], th[i0 - 1]])
    assert theta_zero == pytest.approx(residual, rel=1e-3)
    i_min = i_rev + int(np.argmin(th[i_rev:i_rev + 400]))
    reverse = slice(i_rev + 2, i_min)
    assert i_min - i_rev > 10
    np.testing.assert_allclose(f[reverse], k2 * th[reverse] - s, atol=1e-6 * f_max)


def test_bilinear_sdof_matches_independent_ode_integration():
    """Damped bilinear SDOF under a ground pulse against scipy's DOP853 with the spring
    written as a rate equation (df/dt = k1 θ' inside the bounds, k2 θ' on them)."""
    h, m = 1.5, 3.0e5  # period 0.37 s
    k1, k2, fy, c = 2.0e8, 2.0e7, 3.0e5, 4.0e6
    geometry = PierGeometry(np.array([h]), np.array([m]))
    params = SpringParameters(np.array([k1]), np.array([k2]), np.array([fy]), np.array([c]))
    t_end = 4.0
    t = np.arange(0, t_end + DT / 2, DT)
    ag = 2.0 * np.sin(2 * np.pi * 1.3 * t) * np.exp(-((t - 1.5) / 0.6) ** 2)
    resp = simulate(geometry, params, ag, DT)
    s = fy * (1 - k2 / k1)

    def rhs(tt, y):
        x, v, f = y
        th_dot = v / h
        a_g = np.interp(tt, t, ag)
        acc = -a_g - (c * th_dot / h + f / h) / m
        on_upper = f >= k2 * x / h + s - 1e-9 * fy and th_dot > 0
        on_lower = f <= k2 * x / h - s + 1e-9 * fy and th_dot < 0
        df = (k2 if (on_upper or on_lower) else k1) * th_dot
        return [v, acc, df]

    sol = integrate.solve_ivp(rhs, (0, t_end), [0.0, 0.0, 0.0], method="DOP853", t_eval=t,
                              rtol=1e-10, atol=1e-12, max_step=2e-4)
    x_ref = sol.y[0]
    assert np.abs(resp.theta[:, 0]).max() / (fy / k1) > 2.0  # it did yield
    assert rel_rms(resp.x[:, 0], x_ref) < 2e-3


def _energy_terms(resp, geometry, params):
    b = angle_matrix(geometry.section_heights_m)
    m = geometry.masses_kg
    dt = resp.dt
    th_dot = resp.v @ b.T
    e_in = -integrate.cumulative_trapezoid(resp.v @ m * resp.ag, dx=dt, initial=0)
    e_kin = 0.5 * (resp.v ** 2) @ m
    e_damp = integrate.cumulative_trapezoid((th_dot ** 2) @ params.c, dx=dt, initial=0)
    e_spring = integrate.cumulative_trapezoid(np.sum(resp.moment * th_dot, axis=1), dx=dt,
                                              initial=0)
    e_strain = np.sum(resp.moment ** 2 / (2 * params.k1), axis=1)
    e_hyst = e_spring - e_strain
    return e_in, e_kin, e_damp, e_strain, e_hyst


def test_energy_balance_table1_within_half_percent(table1):
    geometry, params = table1
    from pier_monitor.core.model.ground_motion import synthetic_near_fault

    gm = synthetic_near_fault(pga_mps2=8.0).resampled(DT)
    resp = simulate(geometry, params, gm.acc, gm.dt)
    e_in, e_kin, e_damp, e_strain, e_hyst = _energy_terms(resp, geometry, params)
    balance = e_kin + e_damp + e_strain + e_hyst
    assert e_hyst[-1] > 0.05 * e_in[-1]  # the pier dissipated energy by yielding
    assert np.max(np.abs(balance - e_in)) < 0.005 * np.max(np.abs(e_in))


def test_table1_ductility_pattern_follows_the_paper(table1, table1_response):
    """Paper Table 2: springs 1-2 yield strongly (DF 5.3, 4.1), spring 3 about 1, 4-6 elastic."""
    _, params = table1
    _, resp = table1_response
    df = np.abs(resp.theta).max(axis=0) / params.yield_angles
    assert 3.5 < df[0] < 6.5 and 3.0 < df[1] < 5.5
    assert df[0] > df[1]
    assert 0.9 < df[2] < 1.3
    assert np.all(df[3:] < 1.0)


def test_converged_iteration_satisfies_step_equations_exactly(table1, table1_response):
    """The equation of motion holds at every output sample of the nonlinear run."""
    geometry, params = table1
    _, resp = table1_response
    b = angle_matrix(geometry.section_heights_m)
    lhs = (resp.a + resp.ag[:, None]) * geometry.masses_kg + (resp.v @ b.T * params.c) @ b \
        + resp.moment @ b
    scale = np.abs(resp.ag[:, None] * geometry.masses_kg).max()
    assert np.abs(lhs).max() < 1e-9 * scale


def test_estimated_moments_reproduce_true_moments(table1, table1_response):
    geometry, params = table1
    _, resp = table1_response
    f_hat = estimated_moments(geometry, params.c, resp.a, resp.v, resp.ag)
    np.testing.assert_allclose(f_hat, resp.moment, atol=1e-8 * np.abs(resp.moment).max())


def test_simulate_rejects_bad_input(table1):
    geometry, params = table1
    with pytest.raises(InputDataError, match="non-finite value at sample 3"):
        simulate(geometry, params, np.array([0, 0, 0, np.nan, 0.0]), 0.01)
    with pytest.raises(InputDataError, match="integer multiple"):
        simulate(geometry, params, np.zeros(10), 0.01, output_dt=0.0025)
    with pytest.raises(InputDataError, match="expected 6 springs"):
        simulate(geometry, SpringParameters([1e9], [1e8], [1e6], [1e6]), np.zeros(10), 0.01)
