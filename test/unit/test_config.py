"""Pier configuration loading and validation."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from pier_monitor.core.model.config import SpringParameters, config_from_yaml, load_config
from pier_monitor.core.errors import ConfigError, PierMonitorError
from pier_monitor.core.synthetic.reference import table1_model

CONFIG_DIR = Path(__file__).resolve().parents[2] / "config"


def table1_dict() -> dict:
    return yaml.safe_load((CONFIG_DIR / "table1.yaml").read_text())


def test_table1_config_loads_with_paper_values():
    cfg = load_config(CONFIG_DIR / "table1.yaml")
    geometry, params = table1_model()
    assert cfg.geometry == geometry and cfg.design == params
    assert cfg.n_levels == 6
    np.testing.assert_allclose(cfg.geometry.masses_kg, [14400, 9600, 9600, 9600, 9600, 1033800])
    np.testing.assert_allclose(cfg.design.k1, np.array([1, 0.9, 1, 1, 1, 1]) * 1e9)
    np.testing.assert_allclose(cfg.design.k2, cfg.design.k1 / 10)
    np.testing.assert_allclose(cfg.design.yield_angles, [0.005] * 6)
    np.testing.assert_allclose(cfg.geometry.level_heights_m, np.arange(7.0))
    assert cfg.sensors_at(0, "acceleration")[0].sensor_id == "acc_l0"


def test_every_shipped_config_loads_and_round_trips_through_yaml():
    # pier configurations; the ROS parameter files (``ros__parameters``) are for the nodes
    files = sorted(p for p in CONFIG_DIR.glob("*.yaml") if "ros__parameters" not in p.read_text())
    assert len(files) >= 2
    for path in files:
        cfg = load_config(path)
        again = config_from_yaml(cfg.to_yaml(), source="again")
        assert again == cfg, path.name


def test_config_arrays_are_read_only():
    cfg = load_config(CONFIG_DIR / "table1.yaml")
    with pytest.raises(ValueError):
        cfg.design.k1[0] = 0.0


@pytest.mark.parametrize("mutate, match", [
    (lambda d: d["sections"][2].__setitem__("k1_Nm_per_rad", -1.0),
     r"table1.yaml: sections\[2\]\.k1_Nm_per_rad: expected a positive number, got -1.0"),
    (lambda d: d["sections"][1].pop("mass_kg"),
     r"sections\[1\]\.mass_kg: missing required field"),
    (lambda d: d["sections"][0].__setitem__("k2_Nm_per_rad", 2e9),
     r"sections\[0\]\.k2_Nm_per_rad: second stiffness must be below"),
    (lambda d: d["sections"][0].__setitem__("fy_Nm", "5e6 Nm"),
     r"sections\[0\]\.fy_Nm: expected a number, got '5e6 Nm'"),
    (lambda d: d["sections"][0].__setitem__("heigth_m", 1.0),
     r"sections\[0\]\.heigth_m: unknown field"),
    (lambda d: d.__setitem__("sections", []), r"sections: expected a non-empty list"),
    (lambda d: d.pop("pier_id"), r"pier_id: missing required field"),
    (lambda d: d["sensors"][3].__setitem__("level", 7), r"sensors\[3\]\.level: expected an integer level 0\.\.6, got 7"),
    (lambda d: d["sensors"][1].__setitem__("unit", "furlong"), r"sensors\[1\]\.unit: unknown unit 'furlong' for acceleration"),
    (lambda d: d["sensors"][2].__setitem__("kind", "strain"), r"sensors\[2\]\.kind: expected one of"),
    (lambda d: d["sensors"][2].__setitem__("id", "acc_l1"), r"sensors\[2\]\.id: duplicate sensor id 'acc_l1'"),
    (lambda d: d["sensors"][2].__setitem__("signs", [2]), r"sensors\[2\]\.signs: expected 1 values of \+1 or -1"),
    (lambda d: d["sensors"][2].__setitem__("axes", ["x", "x"]), r"sensors\[2\]\.axes: expected a list of distinct axes"),
    (lambda d: d.__setitem__("sample_rate_hz", 0), r"sample_rate_hz: expected a positive number, got 0"),
    (lambda d: d.__setitem__("pier_id", "../../x"), r"table1.yaml: pier_id: '\.\./\.\./x' holds '\./'"),
    (lambda d: d.__setitem__("pier_id", "/abs/y"), r"table1.yaml: pier_id: '/abs/y' holds '/'"),
    (lambda d: d.__setitem__("pier_id", "pier 7"), r"pier_id: 'pier 7' holds ' '; only A-Z"),
    (lambda d: d.__setitem__("pier_id", ""), r"pier_id: expected a non-empty string, got ''"),
    (lambda d: d.__setitem__("pier_id", "p" * 65), r"pier_id: 65 characters .* at most 64"),
    (lambda d: d.__setitem__("pier_id", 7), r"pier_id: expected a non-empty string, got 7"),
    (lambda d: d["sensors"][2].__setitem__("full_scale", 1.0),
     r"sensors\[2\]\.full_scale: a displacement sensor states its range"),
    (lambda d: d["sensors"][1].__setitem__("range", [0.0, 1.0]),
     r"sensors\[1\]\.range: only displacement sensors have a range"),
    (lambda d: d["sensors"][2].__setitem__("range", [1.0, 0.0]),
     r"sensors\[2\]\.range: expected \[min, max\] with min < max in m, got \[1.0, 0.0\]"),
    (lambda d: d["sensors"][1].__setitem__("full_scale", -1.0),
     r"sensors\[1\]\.full_scale: expected a positive number, got -1.0"),
    (lambda d: d["sensors"][1].__setitem__("offsets", [50.0]),
     r"sensors\[1\]\.full_scale: 40 m/s\^2 does not cover the offset 50 m/s\^2"),
    (lambda d: d["sensors"][2].__setitem__("offsets", [2.0]),
     r"sensors\[2\]\.range: \[-1.0, 1.0\] m does not hold the offset 2 m"),
    (lambda d: d["sensors"][2].__setitem__("rate_hz", -10), r"sensors\[2\]\.rate_hz: expected a positive number, got -10"),
    (lambda d: d["sensors"][2].__setitem__("rate_hz", 30.0),
     r"sensors\[2\]\.rate_hz: must divide the pier's sample_rate_hz=100 into a whole number, got 30"),
    (lambda d: d["sensors"][2].__setitem__("rate_hz", 200.0),
     r"sensors\[2\]\.rate_hz: must divide the pier's sample_rate_hz=100 into a whole number, got 200"),
])
def test_bad_configuration_names_the_field(tmp_path, mutate, match):
    data = table1_dict()
    mutate(data)
    path = tmp_path / "table1.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=match):
        load_config(path)


def test_unreadable_and_malformed_files_give_config_errors(tmp_path):
    with pytest.raises(ConfigError, match="missing.yaml: cannot read pier configuration"):
        load_config(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("pier_id: [unclosed\n")
    with pytest.raises(ConfigError, match="bad.yaml: not valid YAML"):
        load_config(bad)
    bad.write_text("- just\n- a list\n")
    with pytest.raises(ConfigError, match=r"bad.yaml: \(top level\): expected a mapping"):
        load_config(bad)


def test_configuration_that_is_not_utf8_is_a_config_error(tmp_path):
    path = tmp_path / "latin1.yaml"
    path.write_bytes("pier_id: pier_café\n".encode("latin-1"))
    with pytest.raises(ConfigError, match=r"latin1.yaml: not UTF-8 text \(byte 0xe9 at offset "
                                          r"17\); save the configuration as UTF-8"):
        load_config(path)


def test_sensor_bounds_round_trip_and_give_the_recorded_interval():
    cfg = load_config(CONFIG_DIR / "table1.yaml")
    assert cfg.sensor("acc_l1").recorded_bounds() == (-40.0, 40.0)
    assert cfg.sensor("disp_l1").recorded_bounds() == (-1.0, 1.0)
    raw = table1_dict()
    del raw["sensors"][1]["full_scale"]
    bare = config_from_yaml(yaml.safe_dump(raw))
    assert bare.sensor("acc_l1").recorded_bounds() is None
    assert "full_scale" not in bare.sensor("acc_l1").as_dict()


def test_spring_parameters_validate_shapes_and_constraints():
    with pytest.raises(ConfigError, match="c: expected 2 values"):
        SpringParameters([1e9, 1e9], [1e8, 1e8], [1e6, 1e6], [1e7])
    with pytest.raises(ConfigError, match=r"fy\[1\]: expected a positive value"):
        SpringParameters([1e9, 1e9], [1e8, 1e8], [1e6, 0.0], [1e7, 1e7])
    with pytest.raises(ConfigError, match=r"k2\[0\]: second stiffness must be below"):
        SpringParameters([1e9], [1e9], [1e6], [1e7])
    assert issubclass(ConfigError, PierMonitorError)


def test_sensor_rate_defaults_to_the_pier_rate_and_round_trips():
    data = table1_dict()
    data["sensors"][2]["rate_hz"] = 10.0  # disp_l1, e.g. a GNSS-like slow sensor
    cfg = config_from_yaml(yaml.safe_dump(data), source="slow.yaml")
    slow, fast = cfg.sensor("disp_l1"), cfg.sensor("acc_l1")
    assert slow.rate_hz == 10.0 and cfg.sensor_rate_hz(slow) == 10.0
    assert fast.rate_hz is None and cfg.sensor_rate_hz(fast) == cfg.sample_rate_hz == 100.0
    assert slow.as_dict()["rate_hz"] == 10.0 and "rate_hz" not in fast.as_dict()
    again = config_from_yaml(cfg.to_yaml(), source="again")
    assert again == cfg and again.sensor("disp_l1").rate_hz == 10.0


def test_sensor_rate_is_checked_when_the_pier_rate_changes():
    data = table1_dict()
    data["sensors"][2]["rate_hz"] = 20.0
    cfg = config_from_yaml(yaml.safe_dump(data), source="slow.yaml")
    with pytest.raises(ConfigError, match=r"slow.yaml: sensor disp_l1: rate_hz: must divide the "
                                          r"pier's sample_rate_hz=30 into a whole number, got 20"):
        replace(cfg, sample_rate_hz=30.0)
