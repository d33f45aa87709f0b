"""The grey-box spring (family fit plus a residual network per section) on a short
full-layout window of the RC test-bed's Bouc–Wen–Baber–Noori springs."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.identify.equation_error import fit_equation_error, inertia_moments
from pier_monitor.core.identify.families import fit_families, moment_noise_variance
from pier_monitor.core.model.ground_motion import synthetic_near_fault
from pier_monitor.core.model.link_model import angle_matrix
from pier_monitor.core.synthetic.rc import integrate_rc, rc_springs_from_design, rc_truth
from pier_monitor.core.synthetic.reference import paper_case_window, table1_model
from pier_monitor.pinn import set_threads
from pier_monitor.pinn.greybox import GreyboxSettings, fit_greybox


def test_greybox_trains_below_the_family_residual_with_a_finite_df():
    set_threads(1)
    geometry, design = table1_model()
    springs = rc_springs_from_design(design, family="bwbn")
    gm = synthetic_near_fault(pga_mps2=4.5)
    run = integrate_rc(geometry, springs, gm.acc[:int(36 / gm.dt)], gm.dt, output_dt=0.01)
    resp = run.response.window(26.0, 36.0)
    rng = np.random.default_rng(0)
    noise = paper_case_window()[0].noise
    sd = {k: float(np.max(np.abs(getattr(resp, k)))) * 1e-4 for k in ("x", "v")}
    x = resp.x + sd["x"] * rng.standard_normal(resp.x.shape)
    v = resp.v + sd["v"] * rng.standard_normal(resp.v.shape)
    a = resp.a + 1e-5 * rng.standard_normal(resp.a.shape)
    ag = resp.ag + 1e-5 * rng.standard_normal(resp.ag.shape)
    fit = fit_equation_error(geometry, x, v, a, ag, design.scaled(k1=0.5, k2=0.5, fy=0.1, c=0.5))
    b = angle_matrix(geometry.section_heights_m)
    theta, theta_dot, g = x @ b.T, v @ b.T, inertia_moments(geometry, a, ag)
    nv = moment_noise_variance(geometry, noise, fit.params.k1, fit.params.c)
    choice = fit_families(theta, theta_dot, g, nv, fit.springs)
    gb = fit_greybox(theta, theta_dot, g, nv, choice, GreyboxSettings(epochs=300))
    truth = rc_truth(springs, run.state_start, run.state_end)
    assert gb.family == choice.family
    base = gb.sections[0]
    assert truth.yielded[0] and choice.yielded[0]
    # the network explains part of the systematic misfit the family leaves at the base
    assert base.rms_greybox < base.rms_family
    assert sum(s.rms_greybox for s in gb.sections) < sum(s.rms_family for s in gb.sections)
    assert all(np.isfinite(s.ductility_factor) and s.ductility_factor > 0 for s in gb.sections)
    assert gb.ductility_factor[0] > 1.0
    assert len(gb.states) == geometry.n_levels
    with pytest.raises(InputDataError, match="expected equal"):
        fit_greybox(theta, theta_dot[:-1], g, nv, choice)
