"""Synthetic field-network recordings: layouts, imperfect sensors, anti-aliasing, scenarios."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from scipy import signal

from pier_monitor.core.errors import ConfigError, InputDataError
from pier_monitor.core.ingest.recording import NS_PER_S
from pier_monitor.core.model.config import PierConfig, SensorSpec, config_from_yaml, load_config
from pier_monitor.core.model.units import G_STANDARD
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.fleet import fleet_piers
from pier_monitor.core.synthetic.field import (FIELD_PIERS, field_case_recording, field_scenario,
                                               field_recording)
from pier_monitor.core.synthetic.layouts import (GNSS_SENSOR_ID, layout_config,
                                                 mid_height_level)
from pier_monitor.core.synthetic.measurement import (SensorImperfections, anti_alias_filter,
                                                     draw_sensor_errors, record_sensor)
from pier_monitor.core.synthetic.shaking_table import (DEFAULT_START_NS, generate_recording,
                                                       load_truth, save_truth)


@pytest.fixture(scope="module")
def edefense() -> PierConfig:
    return load_config(find_config_file("edefense_like.yaml"))


@pytest.fixture(scope="module")
def table1() -> PierConfig:
    return load_config(find_config_file("table1_field.yaml"))


def short_field_scenario(pier: str = "edefense", shaking: str = "strong"):
    return field_scenario(pier, shaking, lead_s=4.0, tail_s=4.0)


def unit_vector(deg: float) -> np.ndarray:
    return np.array([np.cos(np.radians(deg)), np.sin(np.radians(deg))])


# --- layouts ----------------------------------------------------------------------------------


def test_table1_field_config_is_the_table1_pier_with_a_monitoring_map(table1):
    paper = load_config(find_config_file("table1.yaml"))
    assert table1.geometry == paper.geometry and table1.design == paper.design
    assert table1.sample_rate_hz == 200.0
    for level in range(table1.n_levels + 1):
        accs = table1.sensors_at(level, "acceleration")
        assert len(accs) == 2 and len({s.orientation_deg for s in accs}) == 2
        assert all(s.axes == ("x", "y", "z") and s.noise_rms == 0.001 for s in accs)
        # DC-coupled: the vertical channel reads gravity
        assert all(abs(s.offsets[2] * s.signs[2]) == pytest.approx(G_STANDARD, abs=0.05)
                   for s in accs)
        if level:
            assert len(table1.sensors_at(level, "displacement")) == 2


@pytest.mark.parametrize("name", ["edefense", "table1"])
def test_layouts_keep_the_sensors_a_field_network_has(name, edefense, table1):
    config = {"edefense": edefense, "table1": table1}[name]
    top = config.n_levels
    assert layout_config(config, "full") is config

    accel = layout_config(config, "accel")
    assert {s.kind for s in accel.sensors} == {"acceleration"}
    assert accel.sensors == tuple(s for s in config.sensors if s.kind == "acceleration")
    assert {s.level for s in accel.sensors} == set(range(top + 1))

    sparse = layout_config(config, "sparse")
    mid = {"edefense": 2, "table1": 3}[name]  # 4.0 m of 7.5 m; 3 m of 6 m
    assert mid_height_level(config) == mid
    assert {s.level for s in sparse.sensors} == {0, mid, top}
    assert sparse.sensors == tuple(s for s in config.sensors
                                   if s.kind == "acceleration" and s.level in (0, mid, top))
    two = layout_config(config, "sparse", intermediate_levels=[top - 1, 1])
    assert {s.level for s in two.sensors} == {0, 1, top - 1, top}

    for layout in ("full", "accel", "sparse"):
        field = layout_config(config, layout, gnss=True)
        gnss = field.sensor(GNSS_SENSOR_ID)
        assert field.sensors[-1] == gnss and field.sensors[:-1] == layout_config(
            config, layout).sensors
        assert (gnss.level, gnss.kind, gnss.unit, gnss.axes) == (top, "displacement", "m",
                                                                ("x", "y"))
        assert gnss.rate_hz == 10.0 and field.sensor_rate_hz(gnss) == 10.0
        assert gnss.noise_rms == 0.005 and gnss.topic == f"sensors/level{top}/gnss"
        assert layout in field.description and "GNSS" in field.description
        # the pier is the same; the configuration survives the YAML a bag carries
        assert field.geometry == config.geometry and field.design == config.design
        assert config_from_yaml(field.to_yaml()) == field


def test_bad_layouts_are_config_errors(edefense):
    with pytest.raises(ConfigError, match=r"layout: expected one of \['full', 'accel', "
                                          r"'sparse'\], got 'dense'"):
        layout_config(edefense, "dense")
    with pytest.raises(ConfigError, match=r"intermediate_levels: expected levels between 1 "
                                          r"and 3, got \[4\]"):
        layout_config(edefense, "sparse", intermediate_levels=[4])
    no_top = dataclasses.replace(edefense, sensors=tuple(
        s for s in edefense.sensors if not (s.level == 4 and s.kind == "acceleration")))
    with pytest.raises(ConfigError, match="layout accel: no accelerometer at level 4"):
        layout_config(no_top, "accel")
    with pytest.raises(ConfigError, match="sensor gnss_top: rate_hz: must divide the pier's "
                                          "sample_rate_hz=200 into a whole number, got 30"):
        layout_config(edefense, "sparse", gnss=True, gnss_rate_hz=30.0)
    twice = layout_config(edefense, "accel", gnss=True)
    with pytest.raises(ConfigError, match="sensor gnss_top already uses"):
        layout_config(twice, "full", gnss=True)


# --- imperfect sensors ------------------------------------------------------------------------


def one_sensor_config(edefense: PierConfig, spec: SensorSpec) -> PierConfig:
    return dataclasses.replace(edefense, sensors=(spec,))


def test_tilt_leaks_gravity_into_the_horizontal_channels(edefense):
    spec = SensorSpec("acc", "sensors/level1/acc", 1, "acceleration", "m/s^2", ("x", "y", "z"),
                      orientation_deg=0.0, offsets=(0.0, 0.0, G_STANDARD))
    tilt_only = SensorImperfections(gain_sd=0.0, misalignment_sd_deg=0.0, tilt_sd_deg=0.5,
                                    acc_bias_sd_mps2=0.0, seed=4)
    error = draw_sensor_errors(one_sensor_config(edefense, spec), tilt_only,
                               np.random.SeedSequence(0))["acc"]
    tx, ty = np.radians(error.tilt_deg)
    assert 0 < np.hypot(tx, ty) < np.radians(2.0)
    # x axis tipped about Y by ty points down by ty: it reads -g·ty; y reads +g·tx
    expected = [-G_STANDARD * ty, G_STANDARD * tx, -G_STANDARD * (tx ** 2 + ty ** 2) / 2]
    assert np.allclose(error.offset_error, expected, rtol=1e-3, atol=1e-9)
    at_rest = record_sensor(spec, np.zeros((5, 3)), np.random.default_rng(0), error)
    assert np.allclose(at_rest, np.array(spec.offsets) + error.offset_error)


def test_gain_and_azimuth_errors_change_what_a_sensor_reads(edefense):
    wire = SensorSpec("wire", "sensors/level1/wire", 1, "displacement", "mm", ("x",),
                      orientation_deg=90.0, signs=(-1.0,), gain=2.0)
    imperfections = SensorImperfections(gain_sd=0.01, misalignment_sd_deg=0.5, seed=9)
    error = draw_sensor_errors(one_sensor_config(edefense, wire), imperfections,
                               np.random.SeedSequence(0))["wire"]
    assert error.tilt_deg == (0.0, 0.0) and error.bias == (0.0,)  # accelerometers only
    motion = np.zeros((3, 3))
    motion[:, 1] = 0.01  # 10 mm north: along the wire
    nominal = record_sensor(wire, motion, np.random.default_rng(0))
    true = record_sensor(wire, motion, np.random.default_rng(0), error)
    assert np.allclose(nominal, -20.0)  # gain 2, sign -1, mm
    delta = np.radians(error.orientation_error_deg)
    assert np.allclose(true / nominal, error.gain_factors[0] * np.cos(delta), rtol=1e-12)
    motion[:, 1], motion[:, 0] = 0.0, 0.01  # 10 mm east: across the wire, seen by a turned one
    assert np.allclose(record_sensor(wire, motion, np.random.default_rng(0), error),
                       -20.0 * error.gain_factors[0] * -np.sin(delta), rtol=1e-12)


def test_imperfections_are_seeded_reported_in_the_truth_and_not_in_the_configuration(
        tmp_path, edefense):
    field = layout_config(edefense, "accel", gnss=True)
    scenario = short_field_scenario()
    imperfect = SensorImperfections()
    a = generate_recording(field, scenario, seed=3, imperfections=imperfect)
    b = generate_recording(field, scenario, seed=3, imperfections=imperfect)
    assert a.recording.equals(b.recording) and a.truth.sensor_errors == b.truth.sensor_errors
    other = generate_recording(field, scenario, seed=4, imperfections=imperfect)
    assert other.truth.sensor_errors["l1_acc_n"] != a.truth.sensor_errors["l1_acc_n"]
    fixed = SensorImperfections(seed=11)  # one installation, several noise seeds
    assert (generate_recording(field, scenario, seed=3, imperfections=fixed).truth.sensor_errors
            == generate_recording(field, scenario, seed=4,
                                  imperfections=fixed).truth.sensor_errors)

    # the recording carries the nominal configuration; the truth the errors of every sensor
    assert a.recording.config == field
    errors = a.truth.sensor_errors
    assert list(errors) == [s.sensor_id for s in field.sensors]
    gains = np.concatenate([e.gain_factors for e in errors.values()])
    assert gains.size == 3 * 22 + 2 and 0.005 < np.std(gains - 1) < 0.015
    assert 0.25 < np.std([e.orientation_error_deg for e in errors.values()]) < 0.75

    # same seed, ideal sensors: the same noise, so the difference is the sensor error alone
    ideal = generate_recording(field, scenario, seed=3)
    assert ideal.truth.sensor_errors == {} and ideal.truth.imperfections is None
    spec = field.sensor("l4_acc_ne")  # gal, azimuth 0
    error = errors[spec.sensor_id]
    diff = a.recording.sensor(spec.sensor_id).data - ideal.recording.sensor(spec.sensor_id).data
    ideal_unit = ideal.recording.sensor(spec.sensor_id).data - np.asarray(spec.offsets)
    x = spec.axes.index("x")
    coef = np.linalg.lstsq(np.column_stack([ideal_unit, np.ones(len(diff))]), diff[:, x],
                           rcond=None)[0]
    g, d = error.gain_factors[x], np.radians(error.orientation_error_deg)
    assert coef[0] == pytest.approx(g * np.cos(d) - 1, abs=2e-4)  # gain error
    assert coef[1] == pytest.approx(g * np.sin(d), abs=2e-4)  # the turned x axis sees y
    assert coef[3] == pytest.approx(error.offset_error[x], abs=0.02)  # tilted gravity + bias

    npz, js = tmp_path / "f.truth.npz", tmp_path / "f.truth.json"
    save_truth(a.truth, npz, js, config=field)
    meta = json.loads(js.read_text())
    assert meta["imperfections"]["gain_sd"] == 0.01 and "anti_alias" not in meta
    entry = meta["sensor_errors"]["l1_acc_n"]
    assert entry["unit"] == "gal" and len(entry["gain_factors"]) == 3
    assert entry["offset_error_si"] == pytest.approx([o * 0.01 for o in entry["offset_error"]])
    assert meta["noise"][GNSS_SENSOR_ID]["rate_hz"] == 10.0
    loaded = load_truth(npz, js)
    assert loaded.sensor_errors == a.truth.sensor_errors
    assert loaded.imperfections == imperfect


def test_default_recordings_have_ideal_sensors_and_plain_truth_files(tmp_path, edefense):
    ideal = generate_recording(edefense, short_field_scenario(), seed=0)
    npz, js = tmp_path / "d.truth.npz", tmp_path / "d.truth.json"
    save_truth(ideal.truth, npz, js, config=edefense)
    meta = json.loads(js.read_text())
    assert not {"imperfections", "sensor_errors", "anti_alias"} & set(meta)
    assert not load_truth(npz, js).anti_alias


def test_bad_imperfections_are_rejected():
    with pytest.raises(InputDataError, match="gain_sd: expected a non-negative number"):
        SensorImperfections(gain_sd=-0.01)
    with pytest.raises(InputDataError, match="misalignment_sd_deg"):
        SensorImperfections(misalignment_sd_deg=float("nan"))


# --- anti-aliasing and slower sensors ---------------------------------------------------------


def test_anti_alias_filter_passes_the_band_and_stops_what_would_alias():
    rate, sensor_rate = 1000.0, 200.0
    t = np.arange(20000) / rate

    def gain(f: float) -> float:
        x = np.sin(2 * np.pi * f * t)[:, None]
        y = anti_alias_filter(x, rate, sensor_rate)[2000:-2000]
        return float(np.sqrt(np.mean(y ** 2)) / np.sqrt(np.mean(x[2000:-2000] ** 2)))

    assert gain(2.0) == pytest.approx(1.0, abs=1e-6)
    assert gain(20.0) == pytest.approx(1.0, abs=1e-4)
    assert gain(80.0) == pytest.approx(0.5, abs=0.01)  # corner at 0.4 x rate, -6 dB zero-phase
    assert gain(180.0) < 1e-5  # would alias to 20 Hz at 200 Hz
    with pytest.raises(InputDataError, match="at most the signal's"):
        anti_alias_filter(t[:, None], rate, 2000.0)


def test_anti_aliasing_removes_the_higher_modes_above_the_band(edefense):
    field = layout_config(edefense, "accel")
    scenario = short_field_scenario()
    plain = generate_recording(field, scenario, seed=0)
    filtered = generate_recording(field, scenario, seed=0, anti_alias=True)
    assert filtered.truth.anti_alias and not plain.truth.anti_alias
    # the physics is the same (simulated at 1 ms either way)
    assert np.allclose(filtered.truth.runs[0].ductility_factors,
                       plain.truth.runs[0].ductility_factors, rtol=1e-9)

    def psd(rec, sid: str) -> tuple[np.ndarray, np.ndarray]:
        return signal.welch(rec.recording.sensor(sid).data[:, 0], fs=200.0, nperseg=1024)

    f, p_plain = psd(plain, "l1_acc_e")
    _, p_filtered = psd(filtered, "l1_acc_e")
    high, band = f > 85.0, f < 20.0
    assert p_filtered[high].mean() < 0.1 * p_plain[high].mean()
    assert p_filtered[band].sum() == pytest.approx(p_plain[band].sum(), rel=0.01)


def test_a_gnss_receiver_samples_the_top_displacement_on_its_own_grid(edefense):
    field = layout_config(edefense, "sparse", gnss=True)
    synthetic = generate_recording(field, short_field_scenario(), seed=2, anti_alias=True)
    truth, run = synthetic.truth, synthetic.truth.runs[0]
    gnss = synthetic.recording.sensor(GNSS_SENSOR_ID)
    acc = synthetic.recording.sensor("l4_acc_ne")
    assert gnss.rate_hz == 10.0 and acc.rate_hz == 200.0
    n_acc = acc.n_samples
    assert gnss.n_samples == -(-n_acc // 20)  # every 20th sample of the recording's grid
    assert gnss.time_ns[0] == acc.time_ns[0] == DEFAULT_START_NS
    assert np.all(np.diff(gnss.time_ns) == NS_PER_S // 10)
    assert np.array_equal(gnss.time_ns, acc.time_ns[::20])
    assert np.array_equal(gnss.sample_index, np.arange(gnss.n_samples))
    # east/north components of the top displacement, 5 mm of noise
    sel = (gnss.time_ns >= run.start_ns) & (gnss.time_ns < run.end_ns)
    measured = gnss.data[sel] @ unit_vector(truth.principal_direction_deg)
    expected = run.response.x[::20, -1][:sel.sum()]
    err = measured - expected
    assert np.max(np.abs(expected)) > 0.03  # the top moves centimetres: GNSS sees it
    assert np.sqrt(np.mean(err ** 2)) == pytest.approx(0.005, rel=0.15)


# --- field scenarios --------------------------------------------------------------------------


@pytest.mark.parametrize("pier", sorted(FIELD_PIERS))
def test_field_scenarios_yield_the_lower_sections_or_only_just_yield(pier):
    strong = field_case_recording(pier, "sparse", shaking="strong", seed=1).truth.runs[0]
    df = strong.ductility_factors
    assert np.all(df[:2] >= 1.5) and np.all(df[2:] < 1.0), df  # lower sections damaged
    just = field_case_recording(pier, "sparse", shaking="just_yield", seed=1).truth.runs[0]
    df = just.ductility_factors
    assert 1.2 <= df.max() <= 1.5 and np.argmax(df) == 0, df  # the base: suspicious
    assert np.all(df[1:] < 1.0), df
    assert len(just.name) and just.pga_mps2 < strong.pga_mps2


def test_field_case_recording_is_a_field_network_with_imperfect_sensors():
    case = field_case_recording("table1", "sparse", gnss=True, shaking="just_yield", seed=2)
    config = case.recording.config
    assert config.pier_id == "table1" and config.sample_rate_hz == 200.0
    assert {s.level for s in config.sensors} == {0, 3, 6}
    assert config.sensors[-1].sensor_id == GNSS_SENSOR_ID
    assert set(case.truth.sensor_errors) == {s.sensor_id for s in config.sensors}
    assert case.truth.anti_alias and case.truth.imperfections == SensorImperfections()
    again = field_case_recording("table1", "sparse", gnss=True, shaking="just_yield", seed=2)
    assert case.recording.equals(again.recording)
    ideal = field_case_recording("table1", "sparse", gnss=True, shaking="just_yield", seed=2,
                                 imperfections=False)
    assert ideal.truth.sensor_errors == {}
    level = SensorImperfections(tilt_sd_deg=0.0, acc_bias_sd_mps2=0.0)  # gains and azimuths
    leveled = field_case_recording("table1", "sparse", shaking="just_yield", seed=2,
                                   imperfections=level)
    assert all(e.tilt_deg == (0.0, 0.0) and not any(e.bias)
               for e in leveled.truth.sensor_errors.values())
    with pytest.raises(InputDataError, match="no field scenario for pier 'pier9'"):
        field_case_recording("pier9", "accel")
    with pytest.raises(InputDataError, match="shaking: expected one of"):
        field_scenario("table1", "weak")


def test_field_recording_takes_any_scenario_and_layout(edefense):
    case = field_recording(edefense, "accel", short_field_scenario("edefense", "just_yield"),
                           seed=5, imperfections=None)
    assert {s.kind for s in case.recording.config.sensors} == {"acceleration"}
    assert case.truth.anti_alias and case.truth.sensor_errors == {}
    assert [r.name for r in case.truth.runs] == ["just_yield"]


def test_fleet_piers_take_the_field_layouts():
    full, accel, sparse = fleet_piers(3, 0, layouts=("full", "accel", "sparse"))
    assert {s.kind for s in full.config.sensors} == {"acceleration", "displacement", "velocity"}
    for pier, layout in ((accel, "accel"), (sparse, "sparse")):
        assert {s.kind for s in pier.config.sensors} == {"acceleration"}
        assert pier.layout == layout and layout in pier.config.description
    top = sparse.config.n_levels
    assert {s.level for s in sparse.config.sensors} == {0, mid_height_level(sparse.config), top}
    assert {s.level for s in accel.config.sensors} == set(range(accel.config.n_levels + 1))
