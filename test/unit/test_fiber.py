"""The fiber-section column (optional extra ``fiber``): skipped without openseespy."""

import numpy as np
import pytest
from scipy import linalg

from pier_monitor.core.errors import PierMonitorError
from pier_monitor.core.model.config import PierGeometry
from pier_monitor.core.synthetic import fiber
from pier_monitor.core.synthetic.fiber import FiberColumn, elastic_first_period, gross_ei

requires_ops = pytest.mark.skipif(not fiber.have_openseespy(),
                                  reason="openseespy not installed (pip install .[fiber])")

#: The E-Defense-like pier's levels and masses (config/edefense_like.yaml).
GEOMETRY = PierGeometry(np.array([2.0, 2.0, 2.0, 1.5]),
                        np.array([12200.0, 12200.0, 10700.0, 304000.0]))


def _cantilever_period(geometry: PierGeometry, ei: float) -> float:
    """First period of an Euler-Bernoulli cantilever (uniform EI) with the lumped masses."""
    z = np.cumsum(geometry.section_heights_m)
    lo, hi = np.minimum.outer(z, z), np.maximum.outer(z, z)
    flexibility = lo ** 2 * (3.0 * hi - lo) / (6.0 * ei)
    stiffness = np.linalg.inv(flexibility)
    w2 = linalg.eigh(stiffness, np.diag(geometry.masses_kg), eigvals_only=True)
    return float(2.0 * np.pi / np.sqrt(w2.min()))


def test_gross_ei_adds_the_bars_to_the_concrete():
    col = FiberColumn()
    ig = np.pi * col.diameter_m ** 4 / 64.0
    assert gross_ei(col, 0) == pytest.approx(col.ec_pa * ig)
    # 64 D32 bars (1.6 %) on a 0.9 m ring add (Es/Ec - 1) n As r^2 / 2: about 15 %
    assert 1.12 < gross_ei(col, 64) / (col.ec_pa * ig) < 1.18
    assert gross_ei(col, 48) < gross_ei(col, 64)


@requires_ops
def test_uncracked_first_period_matches_the_sections_ei():
    col = FiberColumn()
    t1 = elastic_first_period(col, GEOMETRY)
    # the upper sections (48 bars) and the base (64) differ by 3 %: bound both ways, 10 %
    t_soft = _cantilever_period(GEOMETRY, gross_ei(col, col.n_bars_upper))
    t_stiff = _cantilever_period(GEOMETRY, gross_ei(col, col.n_bars_base))
    assert 0.9 * t_stiff < t1 < 1.1 * t_soft
    assert 0.2 < t1 < 0.35  # RC_NOTES: about 0.29 s for this pier uncracked


def test_missing_openseespy_is_the_projects_error(monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_ops(name, *args, **kwargs):
        if name.startswith("openseespy"):
            raise ImportError("No module named 'openseespy'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ops)
    with pytest.raises(PierMonitorError, match=r"pip install \.\[fiber\].*libblas3 liblapack3"):
        fiber.import_ops()
    assert not fiber.have_openseespy()


def test_an_external_principal_response_is_recorded_like_the_link_model():
    """generate_recording's principal_response hook: the link model's own response, given
    through the hook over the whole recording, gives the same recording and spring angles."""
    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.model.solver import simulate
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.core.synthetic.shaking_table import RunSpec, Scenario, generate_recording

    config = load_config(find_config_file("edefense_like.yaml"))
    run = RunSpec("r", pga_mps2=1.0, duration_s=8.0, strong_start_s=2.0, strong_duration_s=3.0,
                  motion_seed=5)
    scenario = Scenario(runs=(run,), lead_s=4.0, tail_s=4.0)
    params = run.parameters(config.design)
    calls = []

    def link_model(ag, dt):
        calls.append((ag.size, dt))
        resp = simulate(config.geometry, params, ag, dt, dt=0.001, output_dt=dt)
        return resp.x, resp.v, resp.a

    own = generate_recording(config, scenario, seed=3)
    ext = generate_recording(config, scenario, seed=3, principal_response=link_model)
    assert len(calls) == 1 and calls[0][1] == pytest.approx(1.0 / config.sample_rate_hz)
    assert ext.truth.hysteresis == "external"
    assert np.all(np.isnan(ext.truth.runs[0].ductility_factors))
    np.testing.assert_allclose(ext.truth.runs[0].response.theta, own.truth.runs[0].response.theta,
                               rtol=0, atol=1e-9)
    for sid, rec in own.recording.sensors.items():
        np.testing.assert_allclose(ext.recording.sensors[sid].data, rec.data, rtol=0,
                                   atol=1e-6 * max(1.0, float(np.max(np.abs(rec.data)))))
    with pytest.raises(PierMonitorError, match="hysteresis"):
        generate_recording(config, scenario, seed=3, hysteresis="takeda",
                           principal_response=link_model)


def _hand_yield(curve_th: np.ndarray, curve_m: np.ndarray, ty: float, my: float,
                mn: float) -> fiber.FiberYield:
    """A FiberYield of one section whose pushover curve is given (no OpenSees)."""
    one = np.array
    return fiber.FiberYield(first_yield_moment_Nm=one([my]), nominal_moment_Nm=one([mn]),
                            first_yield_rotation_rad=one([ty]),
                            idealised_yield_rotation_rad=one([ty * mn / my]),
                            yield_extrapolated=one([False]), axial_load_N=one([1e6]),
                            pushover_rotation_rad=curve_th[:, None],
                            pushover_moment_Nm=curve_m[:, None])


def test_equal_energy_yield_of_the_pushover_is_the_products_definition():
    """The pushover's skeleton (first yield a corner) bilinearised by equal energy up to the
    peak: on a trilinear curve, the product's idealised_yield of the same trilinear; below
    first yield, θ'y; between θ'y and θ'y Mn/M'y for a section that just yielded."""
    from pier_monitor.core.model.springs import Skeleton, idealised_yield

    # trilinear: uncracked 3e10 to 4 MN·m, cracked to first yield (1.2e-3, 12 MN·m), then
    # 3e9 N·m/rad; the pushover steps are sampled (signs as OpenSees gives them, negative)
    th = np.linspace(0.0, 4e-3, 401)[1:]
    tri = Skeleton(np.array([0.0, 4e6 / 3e10, 1.2e-3]), np.array([0.0, 4e6, 12e6]), 3e9, 1.2e-3)
    fy = _hand_yield(-th, -tri(th), 1.2e-3, 12e6, 16e6)
    sk = fy.skeleton(0)
    assert sk.theta_first_yield == pytest.approx(1.2e-3)
    assert sk.m_first_yield == pytest.approx(12e6, rel=1e-9)
    # (the 10 µrad steps cut the cracking corner: 1e-4 of the area)
    for peak in (0.6e-3, 1.5e-3, 2.2e-3, 3.5e-3, 5e-3):  # 5e-3: beyond the curve, last slope
        assert fy.equal_energy_yield_rotation(np.array([peak]))[0] == pytest.approx(
            idealised_yield(tri, peak), rel=1e-4)
    assert fy.equal_energy_yield_rotation(np.array([0.6e-3]))[0] == pytest.approx(1.2e-3)
    ee = fy.equal_energy_yield_rotation(np.array([2.2e-3]))[0]
    assert 1.2e-3 < ee < 1.2e-3 * 16e6 / 12e6
    assert "pushover_rotation_rad" not in fy.as_dict()


def test_equal_energy_yield_needs_the_pushover_curve():
    from pier_monitor.core.errors import InputDataError

    fy = fiber.FiberYield(*(np.ones(1) for _ in range(4)), yield_extrapolated=np.array([False]),
                          axial_load_N=np.ones(1))
    with pytest.raises(InputDataError, match="pushover"):
        fy.equal_energy_yield_rotation(np.array([1.0]))


@requires_ops
def test_pushover_skeleton_of_the_column_passes_first_yield_and_goes_on():
    """The column's pushover is recorded past the base's nominal moment (a heavy shaking's
    peak stays within it) and first yield is a corner of each section's skeleton; the
    equal-energy yield of the base just past first yield lies between θ'y and θ'y Mn/M'y."""
    col = FiberColumn()
    fy = fiber.fiber_yield(col, GEOMETRY)
    assert np.abs(fy.pushover_rotation_rad[:, 0]).max() >= fiber.PUSHOVER_MAX_ROTATION
    base = fy.skeleton(0)
    assert base.m_first_yield == pytest.approx(fy.first_yield_moment_Nm[0], rel=1e-12)
    # the pushover's own moment at first yield is M'y (within a step)
    near = np.interp(fy.first_yield_rotation_rad[0], np.abs(fy.pushover_rotation_rad[:, 0]),
                     np.abs(fy.pushover_moment_Nm[:, 0]))
    assert near == pytest.approx(fy.first_yield_moment_Nm[0], rel=0.02)
    peak = 1.8 * fy.first_yield_rotation_rad
    ee = fy.equal_energy_yield_rotation(peak)
    assert fy.first_yield_rotation_rad[0] < ee[0] < fy.idealised_yield_rotation_rad[0]
