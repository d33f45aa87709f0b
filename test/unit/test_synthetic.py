"""Synthetic E-Defense-style recordings: configuration, physics, measurement model, truth."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from pier_monitor.core.model.config import PierConfig, SensorSpec, load_config
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.link_model import natural_periods
from pier_monitor.core.ingest.recording import Recording, SensorRecord
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.shaking_table import (DEFAULT_START_NS, RunSpec, Scenario,
                                         edefense_scenario, generate_recording, load_truth,
                                         save_truth)

RATE_HZ = 200.0
PERIOD_NS = 5_000_000


@pytest.fixture(scope="module")
def config() -> PierConfig:
    return load_config(find_config_file("edefense_like.yaml"))


@pytest.fixture(scope="module")
def synthetic(config):
    return generate_recording(config, seed=0)


def short_scenario(**kwargs) -> Scenario:
    """The default two runs, with short records and quiet stretches (fast tests)."""
    return edefense_scenario(record_s=20.0, lead_s=4.0, gap_s=6.0, tail_s=4.0, **kwargs)


def si_channels(spec: SensorSpec, data: np.ndarray) -> np.ndarray:
    """Undo offsets, gain, signs and unit: SI motion along each recorded axis, (T, n_axes)."""
    return ((data - np.asarray(spec.offsets)) / (spec.gain * np.asarray(spec.signs))
            * spec.si_factor)


def horizontal(spec: SensorSpec, si: np.ndarray) -> np.ndarray:
    """Pier-frame (X, Y) motion from a sensor's x and y channels, (T, 2)."""
    cols = {a: j for j, a in enumerate(spec.axes)}
    return (si[:, [cols["x"]]] * spec.axis_direction("x")[:2]
            + si[:, [cols["y"]]] * spec.axis_direction("y")[:2])


def unit_vector(deg: float) -> np.ndarray:
    return np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg))])


def run_mask(record: SensorRecord, run) -> np.ndarray:
    return (record.time_ns >= run.start_ns) & (record.time_ns < run.end_ns)


# --- configuration --------------------------------------------------------------------------


def test_edefense_config_is_an_e_defense_like_pier(config):
    g, d = config.geometry, config.design
    assert np.allclose(g.section_heights_m, [2.0, 2.0, 2.0, 1.5])
    assert g.level_heights_m[-1] == pytest.approx(7.5)
    assert 200e3 <= g.masses_kg[-1] <= 500e3  # deck of a few hundred tonnes at the top
    column_per_m = 2400 * np.pi / 4 * 1.8 ** 2
    assert g.masses_kg[0] == pytest.approx(2.0 * column_per_m, rel=0.02)
    assert np.allclose(d.k2, d.k1 / 10)
    assert 0.8 <= natural_periods(g, d)[0] <= 1.5
    zeta1 = d.c[0] / d.k1[0] * (2 * np.pi / natural_periods(g, d)[0]) / 2
    assert 0.01 < zeta1 < 0.06  # a few % damping in the first mode
    assert config.principal_direction_deg == 196.0
    assert config.sample_rate_hz == RATE_HZ


def test_edefense_sensor_map_has_the_paper_layout(config):
    acc0 = config.sensors_at(0, "acceleration")
    assert len(acc0) == 4 and all(s.axes == ("x", "y", "z") for s in acc0)
    for level in range(1, 5):
        accs = config.sensors_at(level, "acceleration")
        wires = config.sensors_at(level, "displacement")
        assert len(accs) >= 4
        assert len({s.orientation_deg for s in accs}) >= 3  # faces/corners, own orientations
        assert len(wires) >= 2 and all(w.axes == ("x",) and w.unit == "mm" for w in wires)
    assert [s.level for s in config.sensors if s.kind == "velocity"] == [0, 4]
    assert {s.unit for s in config.sensors if s.kind == "acceleration"} == {"gal", "m/s^2"}
    assert any(-1.0 in s.signs for s in config.sensors if s.kind == "acceleration")
    for s in config.sensors:
        assert s.topic.startswith(f"sensors/level{s.level}/") and not s.topic.startswith("/")
        noise_si = s.noise_rms * s.si_factor
        expected = {"acceleration": 1e-3, "displacement": 1e-4, "velocity": 5e-4}[s.kind]
        assert noise_si == pytest.approx(expected, rel=0.01), s.sensor_id


# --- recording layout and determinism -------------------------------------------------------


def test_recording_has_every_sensor_on_one_uniform_clock(config, synthetic):
    rec = synthetic.recording
    assert list(rec.sensors) == [s.sensor_id for s in config.sensors]
    assert rec.missing_sensors == ()
    first = next(iter(rec.sensors.values()))
    n = first.n_samples
    assert n == int(round(150.01 * RATE_HZ))  # 20 + 40.005 + 30 + 40.005 + 20 s
    for spec in config.sensors:
        r = rec.sensor(spec.sensor_id)
        assert r.time_ns.dtype == np.int64 and r.time_ns.shape == (n,)
        assert r.data.shape == (n, len(spec.axes)) and r.data.dtype == np.float64
        assert r.time_ns[0] == DEFAULT_START_NS
        assert np.all(np.diff(r.time_ns) == PERIOD_NS)
        assert np.array_equal(r.sample_index, np.arange(n))
        assert np.all(np.isfinite(r.data))
    truth = synthetic.truth
    assert truth.start_ns == DEFAULT_START_NS and truth.end_ns == first.time_ns[-1] + PERIOD_NS
    assert [r.name for r in truth.runs] == ["run1", "run2"]


def test_same_seed_gives_identical_recording_and_truth(config):
    a = generate_recording(config, short_scenario(), seed=7)
    b = generate_recording(config, short_scenario(), seed=7)
    assert a.recording.equals(b.recording)
    for ra, rb in zip(a.truth.runs, b.truth.runs):
        for key, value in ra.response.as_dict().items():
            assert np.array_equal(value, getattr(rb.response, key)), key
        assert np.array_equal(ra.ductility_factors, rb.ductility_factors)
    c = generate_recording(config, short_scenario(), seed=8)
    assert not np.array_equal(a.recording.sensor("l4_acc_n").data,
                              c.recording.sensor("l4_acc_n").data)
    # the default scenario fixes the table records: another seed changes only noise/ambient
    for ra, rc in zip(a.truth.runs, c.truth.runs):
        assert np.allclose(ra.ductility_factors, rc.ductility_factors, rtol=0.02)
    # unless the records are left to the seed
    d = generate_recording(config, short_scenario(motion_seeds=None), seed=8)
    e = generate_recording(config, short_scenario(motion_seeds=None), seed=9)
    assert not np.allclose(d.truth.runs[0].response.ag, e.truth.runs[0].response.ag)


# --- measurement model: recorded channels invert back to the truth --------------------------


def test_accelerometers_invert_to_absolute_acceleration_at_noise_level(config, synthetic):
    e_p = unit_vector(synthetic.truth.principal_direction_deg)
    rec = synthetic.recording
    for spec in config.sensors:
        if spec.kind != "acceleration":
            continue
        record = rec.sensor(spec.sensor_id)
        si = si_channels(spec, record.data)
        measured, expected, vertical, expected_z = [], [], [], []
        for run in synthetic.truth.runs:
            sel = run_mask(record, run)
            measured.append(horizontal(spec, si[sel]) @ e_p)
            rel = run.response.a[:, spec.level - 1] if spec.level else 0.0
            expected.append(run.response.ag + rel)
            vertical.append(si[sel, spec.axes.index("z")])
            expected_z.append(run.ag_vertical)
        noise_si = spec.noise_rms * spec.si_factor / abs(spec.gain)
        err = np.concatenate(measured) - np.concatenate(expected)
        assert np.sqrt(np.mean(err ** 2)) == pytest.approx(noise_si, rel=0.1), spec.sensor_id
        err_z = np.concatenate(vertical) - np.concatenate(expected_z)
        assert np.sqrt(np.mean(err_z ** 2)) == pytest.approx(noise_si, rel=0.1), spec.sensor_id


def test_velocity_meters_invert_to_absolute_velocity_at_noise_level(config, synthetic):
    e_p = unit_vector(synthetic.truth.principal_direction_deg)
    for spec in config.sensors:
        if spec.kind != "velocity":
            continue
        record = synthetic.recording.sensor(spec.sensor_id)
        si = si_channels(spec, record.data)
        for run in synthetic.truth.runs:
            measured = horizontal(spec, si[run_mask(record, run)]) @ e_p
            rel = run.response.v[:, spec.level - 1] if spec.level else 0.0
            err = measured - (run.table_velocity + rel)
            noise_si = spec.noise_rms * spec.si_factor / abs(spec.gain)
            assert np.sqrt(np.mean(err ** 2)) == pytest.approx(noise_si, rel=0.1)


def test_wires_invert_to_displacement_relative_to_the_table(config, synthetic):
    e_p = unit_vector(synthetic.truth.principal_direction_deg)
    for level in range(1, config.n_levels + 1):
        wires = config.sensors_at(level, "displacement")[:2]
        directions = np.stack([w.axis_direction("x")[:2] for w in wires])  # (2, 2)
        records = [synthetic.recording.sensor(w.sensor_id) for w in wires]
        readings = np.column_stack([si_channels(w, r.data)[:, 0] for w, r in zip(wires, records)])
        planar = np.linalg.solve(directions, readings.T).T  # (T, 2) pier frame
        for run in synthetic.truth.runs:
            measured = planar[run_mask(records[0], run)] @ e_p
            expected = run.initial_offset_m[level - 1] + run.response.x[:, level - 1]
            err = measured - expected
            assert np.sqrt(np.mean(err ** 2)) == pytest.approx(1e-4, rel=0.1), (level, run.name)


def test_transverse_and_vertical_motion_is_recorded_but_not_principal(config, synthetic):
    e_t = unit_vector(synthetic.truth.principal_direction_deg + 90.0)
    spec = config.sensor("l4_acc_n")
    record = synthetic.recording.sensor(spec.sensor_id)
    run = synthetic.truth.runs[1]
    sel = run_mask(record, run)
    across = horizontal(spec, si_channels(spec, record.data)[sel]) @ e_t
    assert np.sqrt(np.mean(across ** 2)) > 50 * spec.noise_rms * spec.si_factor
    assert np.max(np.abs(run.ag_transverse)) == pytest.approx(0.2 * run.pga_mps2, rel=0.1)
    assert np.max(np.abs(run.ag_vertical)) == pytest.approx(0.3 * run.pga_mps2, rel=0.1)


def test_quiet_stretches_surround_the_runs(config, synthetic):
    spec = config.sensor("l0_acc_ne")
    record = synthetic.recording.sensor(spec.sensor_id)
    si = si_channels(spec, record.data)[:, :2]
    run1, run2 = synthetic.truth.runs
    lead = record.time_ns < run1.start_ns
    gap = (record.time_ns >= run1.end_ns) & (record.time_ns < run2.start_ns)
    tail = record.time_ns >= run2.end_ns
    assert lead.sum() == 20 * RATE_HZ and gap.sum() >= 29 * RATE_HZ and tail.sum() >= 19 * RATE_HZ
    for quiet in (lead, gap, tail):
        assert np.max(np.abs(si[quiet])) < 0.02  # idle table: a few mm/s² at most
    for run in (run1, run2):
        assert np.max(np.abs(run.response.ag)) > 100 * 0.02


# --- the runs: damage ordering and mainshock windows ----------------------------------------


def test_runs_are_ordered_by_damage(config, synthetic):
    run1, run2 = synthetic.truth.runs
    assert run2.pga_mps2 > run1.pga_mps2
    assert run2.geometry.masses_kg[-1] > run1.geometry.masses_kg[-1]
    assert np.all(run2.params.k1[:2] < run1.params.k1[:2])
    assert np.all(run2.params.fy[:2] < run1.params.fy[:2])
    assert np.all(run2.ductility_factors[:2] > 1.5 * run1.ductility_factors[:2])
    assert run1.ductility_factors[0] > 1.2  # the first run already yields the base
    assert run2.ductility_factors[1] > 1.5
    assert np.all(run1.ductility_factors[2:] < 1.0) and np.all(run2.ductility_factors[2:] < 1.0)
    for run in (run1, run2):
        assert 0.8 <= run.periods_s[0] <= 1.5
        theta_y = run.params.fy / run.params.k1
        assert np.allclose(run.ductility_factors,
                           np.max(np.abs(run.response.theta), axis=0) / theta_y)
    assert np.array_equal(run1.initial_offset_m, np.zeros(4))
    assert np.allclose(run2.initial_offset_m, run1.response.x[-1], atol=1e-3)


def test_mainshock_window_holds_the_peak_response(synthetic):
    for run in synthetic.truth.runs:
        assert run.start_ns < run.window_start_ns < run.window_end_ns <= run.end_ns
        assert 10e9 <= run.window_end_ns - run.window_start_ns <= 30e9
        win = run.window_response
        assert np.max(np.abs(win.theta), axis=0) == pytest.approx(
            np.max(np.abs(run.response.theta), axis=0))
        assert (run.window_start_ns - run.start_ns) % PERIOD_NS == 0


def test_truth_response_is_the_link_model_of_the_run(synthetic):
    """Equation of motion of the truth: M(a + ag) + C v + Bᵀ f = 0 at every sample."""
    from pier_monitor.core.model.link_model import angle_matrix, damping_matrix

    for run in synthetic.truth.runs:
        r, g, p = run.response, run.geometry, run.params
        b = angle_matrix(g.section_heights_m)
        residual = ((r.a + r.ag[:, None]) * g.masses_kg + r.v @ damping_matrix(b, p.c).T
                    + r.moment @ b)
        scale = np.max(np.abs(r.moment @ b))
        assert np.max(np.abs(residual)) < 1e-6 * scale
        assert np.allclose(r.theta, r.x @ b.T)


# --- truth files -----------------------------------------------------------------------------


def test_truth_save_load_round_trip(tmp_path, config, synthetic):
    npz, js = tmp_path / "t.truth.npz", tmp_path / "t.truth.json"
    save_truth(synthetic.truth, npz, js, config=config)
    meta = json.loads(js.read_text())
    assert meta["principal_direction_deg"] == 196.0
    assert meta["noise"]["l1_wire_n"] == {"noise_rms": 0.1, "unit": "mm",
                                          "kind": "displacement", "noise_rms_si": 1e-4}
    assert [r["name"] for r in meta["runs"]] == ["run1", "run2"]
    loaded = load_truth(npz, js)
    for a, b in zip(synthetic.truth.runs, loaded.runs):
        assert a.params == b.params and a.geometry == b.geometry
        assert (a.start_ns, a.end_ns, a.window_start_ns, a.window_end_ns) == (
            b.start_ns, b.end_ns, b.window_start_ns, b.window_end_ns)
        for key, value in a.response.as_dict().items():
            assert np.array_equal(value, getattr(b.response, key)), key
        assert np.array_equal(a.table_velocity, b.table_velocity)
        assert np.array_equal(a.ductility_factors, b.ductility_factors)
    assert loaded.scenario == synthetic.truth.scenario
    assert dict(loaded.noise_rms) == dict(synthetic.truth.noise_rms)


def test_load_truth_names_a_missing_file(tmp_path):
    with pytest.raises(InputDataError, match="x.truth.json"):
        load_truth(tmp_path / "x.truth.npz", tmp_path / "x.truth.json")


# --- bad input -------------------------------------------------------------------------------


def test_generation_rejects_unusable_input(config):
    with pytest.raises(InputDataError, match="no sensor map"):
        generate_recording(replace(config, sensors=()))
    with pytest.raises(InputDataError, match="whole number"):
        generate_recording(replace(config, sample_rate_hz=300.0))
    bad = Scenario(runs=(RunSpec("r", pga_mps2=3.0, duration_s=20.0, k1_factors=(1.0, 0.9)),))
    with pytest.raises(InputDataError, match="k1_factors: expected 4"):
        generate_recording(config, bad)
    with pytest.raises(InputDataError, match="pga_mps2"):
        Scenario(runs=(RunSpec("r", pga_mps2=-1.0),))
    with pytest.raises(InputDataError, match="strong_start_s"):
        Scenario(runs=(RunSpec("r", pga_mps2=3.0, duration_s=10.0),))


def test_recording_rejects_sensors_outside_the_map(config):
    record = SensorRecord("nope", np.arange(3, dtype=np.int64), np.zeros((3, 1)), RATE_HZ)
    with pytest.raises(InputDataError, match="not in the sensor map"):
        Recording(config, {"nope": record})
    with pytest.raises(InputDataError, match=r"expected shape \(3, n_axes\)"):
        SensorRecord("l1_wire_n", np.arange(3, dtype=np.int64), np.zeros(3), RATE_HZ)


def test_missing_configuration_file_is_a_config_error(tmp_path, monkeypatch):
    from pier_monitor.core import resources
    from pier_monitor.core.errors import ConfigError

    monkeypatch.setattr(sys, "prefix", str(tmp_path))
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    monkeypatch.setattr(resources, "REPO_ROOT", tmp_path / "repo")
    with pytest.raises(ConfigError, match="edefense_like.yaml not found; looked in: .*repo/config"):
        find_config_file("edefense_like.yaml")


def test_core_synthetic_imports_no_ros_or_bag_packages():
    code = ("import sys, pier_monitor.core.synthetic.shaking_table, pier_monitor.core.ingest.recording; "
            "bad = [m for m in ('rclpy', 'rosbags', 'mcap', 'torch') if m in sys.modules]; "
            "print(bad); sys.exit(1 if bad else 0)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_a_run_plays_the_el_centro_record_at_its_pga():
    from pier_monitor.core.model.ground_motion import el_centro_1940
    from pier_monitor.core.synthetic.shaking_table import _table_records
    run = RunSpec("elc", pga_mps2=2.0, duration_s=30.0, record="el_centro_1940")
    principal, transverse, _ = _table_records(run, 50.0, (1, 2, 3))
    assert principal.shape == transverse.shape == (1501,)
    ref = el_centro_1940().acc[:1501]  # the record's own 0.02 s step is 50 Hz
    assert np.corrcoef(principal, ref)[0, 1] > 0.99
    assert abs(np.abs(principal).max() - 2.0) < 0.1
    with pytest.raises(InputDataError, match="record"):
        _table_records(replace(run, record="kobe"), 50.0, (1, 2, 3))
