"""Ground-motion generation and accelerogram files."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.core.errors import GroundMotionError
from pier_monitor.core.model.ground_motion import load_accelerogram, synthetic_near_fault
from pier_monitor.core.model.units import G_STANDARD


def test_synthetic_near_fault_is_seeded_scaled_and_strong_in_the_mainshock_window():
    a = synthetic_near_fault(pga_mps2=8.0, seed=3)
    b = synthetic_near_fault(pga_mps2=8.0, seed=3)
    c = synthetic_near_fault(pga_mps2=8.0, seed=4)
    np.testing.assert_array_equal(a.acc, b.acc)
    assert not np.allclose(a.acc, c.acc)
    assert a.pga == pytest.approx(8.0, rel=1e-12)
    assert a.dt == 0.01 and a.duration_s == pytest.approx(60.0)
    arias = np.cumsum(a.acc ** 2)
    share = (arias[int(50 / a.dt)] - arias[int(30 / a.dt)]) / arias[-1]
    assert share > 0.85
    # band-limited: no drift, so the integrated velocity returns to rest
    vel = np.cumsum(a.acc) * a.dt
    assert abs(vel[-1]) < 0.02 * np.abs(vel).max()


def test_synthetic_near_fault_rejects_bad_arguments():
    with pytest.raises(GroundMotionError, match="pga_mps2: expected a positive number"):
        synthetic_near_fault(pga_mps2=-1.0)
    with pytest.raises(GroundMotionError, match="strong_start_s"):
        synthetic_near_fault(duration_s=20.0, strong_start_s=30.0)


def test_one_column_file_in_g_with_dt(tmp_path):
    path = tmp_path / "rec.txt"
    path.write_text("# header comment\n0.0\n0.1\n-0.2\n0.05\n")
    gm = load_accelerogram(path, units="g", dt=0.02)
    np.testing.assert_allclose(gm.acc, np.array([0, 0.1, -0.2, 0.05]) * G_STANDARD)
    assert gm.dt == 0.02


def test_time_and_acceleration_columns_in_gal(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text("0.00, 0.0\n0.01, 100.0\n0.02, -50.0\n0.03, 10.0\n")
    gm = load_accelerogram(path, units="gal")
    np.testing.assert_allclose(gm.acc, [0, 1.0, -0.5, 0.1])
    assert gm.dt == pytest.approx(0.01)


def test_peer_at2_file(tmp_path):
    path = tmp_path / "RSN1.AT2"
    path.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nSOME EVENT, STATION\n"
                    "ACCELERATION TIME SERIES IN UNITS OF G\n"
                    "NPTS=    5, DT=   .0200 SEC\n"
                    "  .1000000E-01  .2000000E-01 -.3000000E-01\n  .4000000E-01  .5000000E-01\n")
    gm = load_accelerogram(path, units="g")
    assert gm.dt == pytest.approx(0.02)
    np.testing.assert_allclose(gm.acc, np.array([0.01, 0.02, -0.03, 0.04, 0.05]) * G_STANDARD)


@pytest.mark.parametrize("content, kwargs, match", [
    ("0.0\n0.1\n", {"units": "g"}, r"rec.txt: the file has no time column; give the sampling period dt"),
    ("0.0\nabc\n", {"units": "g", "dt": 0.01}, r"rec.txt: line 2: not a number in 'abc'"),
    ("0.0\nnan\n0.1\n", {"units": "g", "dt": 0.01}, r"rec.txt: non-finite value at sample 1 \(t = 0.010 s\)"),
    ("# nothing\n", {"units": "g", "dt": 0.01}, r"rec.txt: no acceleration values found"),
    ("0.0 1\n0.01 2\n0.03 3\n0.04 1\n", {"units": "gal"}, r"rec.txt: time column is not uniform"),
    ("0.0 1\n0.02 2\n0.01 3\n", {"units": "gal"}, r"rec.txt: time column must increase"),
    ("0.0 1\n0.01 2\n", {"units": "gal", "dt": 0.005}, r"rec.txt: dt=0.005 s given, but the file says 0.01 s"),
    ("0.0\n300.0\n", {"units": "mps2", "dt": 0.01}, r"implausible for a ground motion .* check the declared units"),
    ("0.0\n0.1\n", {"units": "m/s/s", "dt": 0.01}, r"units must be one of"),
    ("1 2 3\n4\n5 6\n", {"units": "g", "dt": 0.01}, r"rows have different numbers of columns"),
])
def test_bad_accelerogram_files_give_clear_errors(tmp_path, content, kwargs, match):
    path = tmp_path / "rec.txt"
    path.write_text(content)
    with pytest.raises(GroundMotionError, match=match):
        load_accelerogram(path, **kwargs)


def test_missing_accelerogram_file(tmp_path):
    with pytest.raises(GroundMotionError, match="cannot read accelerogram"):
        load_accelerogram(tmp_path / "nope.txt", units="g", dt=0.01)


def test_el_centro_record_ships_with_the_package():
    from pier_monitor.core.model.ground_motion import el_centro_1940

    gm = el_centro_1940()
    assert gm.dt == 0.02 and gm.acc.size == 3995
    assert gm.pga == pytest.approx(0.3129 * G_STANDARD, rel=1e-3)


def test_file_of_three_columns_needs_the_acceleration_column(tmp_path):
    path = tmp_path / "three.txt"
    path.write_text("0.00 0.5 9.0\n0.01 1.0 9.0\n0.02 -0.5 9.0\n0.03 0.2 9.0\n")
    with pytest.raises(GroundMotionError, match=r"three.txt: 3 columns; choose the acceleration "
                                                r"column \(column=, pier-monitor simulate "
                                                r"--column N, counted from 1\)"):
        load_accelerogram(path, units="mps2")
    gm = load_accelerogram(path, units="mps2", column=2)
    np.testing.assert_allclose(gm.acc, [0.5, 1.0, -0.5, 0.2])
    assert gm.dt == pytest.approx(0.01)
    gm = load_accelerogram(path, units="mps2", column=3, dt=0.01)
    np.testing.assert_allclose(gm.acc, [9.0] * 4)
    with pytest.raises(GroundMotionError, match="three.txt: column 4 chosen but the rows have 3"):
        load_accelerogram(path, units="mps2", column=4)
    with pytest.raises(GroundMotionError, match="column must be a column number from 1, got 0"):
        load_accelerogram(path, units="mps2", column=0)


def test_column_one_without_dt_has_no_time_column(tmp_path):
    path = tmp_path / "cols.txt"
    path.write_text("0.5 7\n1.0 7\n-0.5 7\n")
    with pytest.raises(GroundMotionError, match="no time column; give the sampling period dt"):
        load_accelerogram(path, units="mps2", column=1)
    np.testing.assert_allclose(load_accelerogram(path, units="mps2", column=1, dt=0.02).acc,
                               [0.5, 1.0, -0.5])


def test_scaling_beyond_a_plausible_peak_is_refused():
    gm = synthetic_near_fault(pga_mps2=8.0)
    with pytest.raises(GroundMotionError, match=r"PGA 1e\+30 m/s\^2 is implausible for a ground "
                                                r"motion \(> 50 m/s\^2 = 5 g\)"):
        gm.scaled_to_pga(1e30)
    with pytest.raises(GroundMotionError, match=r"scaled by 10: peak 80 m/s\^2 is implausible"):
        gm.scaled(10.0)
    assert gm.scaled(6.0).pga == pytest.approx(48.0)
