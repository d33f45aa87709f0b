"""Messages ↔ core types: sensor blocks checked against the map, windows lossless both ways.

A window crosses three boundaries (function call, ``.npz`` on disk, ``MainshockWindow`` on
the wire) and must come out of each equal to what went in, every field
(:meth:`MeasuredWindow.__eq__`: arrays exactly, NaN equal to NaN, noise model, coverage,
start time, report).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]

START_NS = 1_710_205_227_180_000_000


def sparse(window: Any) -> Any:
    """The window as a field network sees it: accelerometers at levels 2 and 5 only."""
    from pier_monitor.core.ingest.window import Coverage, MeasuredWindow

    acc = np.zeros(window.n_levels, dtype=bool)
    acc[[1, 4]] = True
    cov = Coverage(acceleration=acc, displacement=np.zeros_like(acc), highpass_hz=0.1)
    keep = lambda arr: np.where(acc, arr, np.nan)
    return MeasuredWindow(window.pier_id, "sparse_event", window.geometry, window.design,
                          window.t, window.ag, keep(window.a), keep(window.v), keep(window.x),
                          noise=window.noise, coverage=cov, start_time_ns=START_NS,
                          report={"layout": "sparse", "levels": [2, 5]})


@pytest.fixture(scope="module")
def windows() -> dict[str, Any]:
    """Windows that use every field: moments, increment noise, gain, coverage, a report."""
    from pier_monitor.core.synthetic.reference import paper_case_window, realistic_case_window

    moments, _, _ = paper_case_window(moments_measured=True, seed=2)
    realistic, _, _ = realistic_case_window(seed=0)
    noise = replace(realistic.noise, gain_rel=0.01)
    return {
        "moments_measured": replace(moments, start_time_ns=START_NS),
        "smoothed_with_increment_noise": replace(realistic, noise=noise,
                                                 start_time_ns=-5_000_000_001),
        "sparse_with_nan_columns": sparse(realistic),
    }


@pytest.mark.parametrize("name", ["moments_measured", "smoothed_with_increment_noise",
                                  "sparse_with_nan_columns"])
def test_window_to_message_and_to_npz_and_back_are_equal_in_every_field(
        windows, name, tmp_path: Path) -> None:
    from pier_monitor_msgs.msg import MainshockWindow
    from rclpy.serialization import deserialize_message, serialize_message

    from pier_monitor.core.ingest.window import load_window, save_window
    from pier_monitor.nodes.conversions import window_from_msg, window_to_msg

    window = windows[name]
    wire = deserialize_message(serialize_message(window_to_msg(window)), MainshockWindow)
    from_msg = window_from_msg(wire)  # as the identifier node receives it
    from_npz = load_window(save_window(window, tmp_path / "w.npz"))
    assert from_msg == window
    assert from_npz == window
    assert from_msg == from_npz
    # the comparison is strict: one noise value off is another window
    wire.velocity_sigma[0] *= 1.0 + 1e-12
    assert window_from_msg(wire) != window


def test_the_message_carries_the_noise_model_and_coverage_in_named_fields(windows) -> None:
    from pier_monitor.nodes.conversions import window_to_msg

    window = windows["sparse_with_nan_columns"]
    msg = window_to_msg(window)
    assert list(msg.acceleration_measured) == [False, True, False, False, True, False]
    assert not any(msg.displacement_measured) and msg.highpass_hz == 0.1
    np.testing.assert_array_equal(msg.displacement_increment_sigma, window.noise.dx)
    np.testing.assert_array_equal(msg.velocity_increment_sigma, window.noise.dv)
    assert msg.ground_acceleration_sigma == window.noise.ag
    assert np.isnan(np.asarray(msg.acceleration).reshape(-1, 6)[:, 0]).all()
    assert len(msg.moments) == 0 and msg.pier_config_yaml == ""
    assert '"layout": "sparse"' in msg.report and "noise" not in msg.report


def test_a_window_message_that_contradicts_itself_is_refused_naming_the_field(windows) -> None:
    from pier_monitor.nodes.conversions import MessageError, window_from_msg, window_to_msg

    window = windows["moments_measured"]
    cases = [("acceleration", lambda m: m.acceleration.pop(),
              r"acceleration has \d+ values, expected n_samples x n_levels"),
             ("time_s", lambda m: setattr(m, "time_s", m.time_s[:-1]),
              r"time_s has \d+ values, expected n_samples"),
             ("masses_kg", lambda m: setattr(m, "masses_kg", [1.0]),
              "masses_kg has 1 values, expected n_levels = 6"),
             ("acceleration_measured", lambda m: setattr(m, "acceleration_measured", [True]),
              "acceleration_measured has 1 values"),
             ("report", lambda m: setattr(m, "report", "[1, 2]"), "report is not a JSON object"),
             ("design_k2", lambda m: setattr(m, "design_k2", [2e9] * 6),
              "k2.*second stiffness must be below")]
    for field, spoil, match in cases:
        msg = window_to_msg(window)
        spoil(msg)
        with pytest.raises(MessageError, match=r"/p/mainshock_window: MainshockWindow "
                                               rf"'paper_case_seed2': .*{match}"):
            window_from_msg(msg, "/p/mainshock_window")


def test_sensor_messages_are_checked_against_the_sensor_map() -> None:
    from pier_monitor_msgs.msg import SampleBlock
    from sensor_msgs.msg import Imu

    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.nodes.conversions import MessageError, block_arrays, imu_arrays

    config = load_config(find_config_file("edefense_like.yaml"))
    acc = next(s for s in config.sensors if s.kind == "acceleration" and len(s.axes) == 3)
    msg = SampleBlock(sensor_id=acc.sensor_id, kind=0, unit=acc.unit, sample_rate_hz=200.0,
                      first_sample_index=40, axes=list(acc.axes), data=[1.0] * 12)
    msg.header.stamp.sec = 10
    times, data, index = block_arrays(msg, acc, 200.0, "/p/acc")
    assert data.shape == (4, 3) and list(index) == [40, 41, 42, 43]
    assert list(times) == [10_000_000_000 + 5_000_000 * i for i in range(4)]
    msg.data = [1.0] * 11
    with pytest.raises(MessageError, match=r"/p/acc: SampleBlock: 11 values"):
        block_arrays(msg, acc, 200.0, "/p/acc")
    msg.data, msg.sensor_id = [1.0] * 12, "other"
    with pytest.raises(MessageError, match=r"block of sensor 'other' on the topic of sensor"):
        block_arrays(msg, acc, 200.0, "/p/acc")

    imu = Imu()
    imu.header.stamp.sec = 3
    imu.linear_acceleration.x = 0.5
    if acc.unit in ("m/s^2", "m/s2"):
        t, d = imu_arrays(imu, acc, "/p/imu")
        assert t[0] == 3_000_000_000 and d.tolist() == [[0.5, 0.0, 0.0]]
    wire = next(s for s in config.sensors if s.kind == "displacement")
    with pytest.raises(MessageError, match="sensor_msgs/Imu"):
        imu_arrays(imu, wire, "/p/wire")


def _ensemble_result() -> Any:
    """Two sections: one at DF 1.17 ± 0.1 (straddles 1.2), one that may have yielded."""
    from ensemble_helpers import ensemble_result, normal_members, yielded_members

    return ensemble_result("run2", [normal_members(1e9, 0.02e9), normal_members(0.9e9, 0.01e9)],
                           [normal_members(1.17, 0.1), normal_members(0.9, 0.05)],
                           [yielded_members(1.0), yielded_members(0.3)],
                           baseline_k1=np.array([1.0e9, 1.0e9]), window_start_ns=START_NS)


def test_damage_state_with_uncertainty_crosses_the_wire_in_every_field() -> None:
    from pier_monitor_msgs.msg import PierDamageState
    from rclpy.serialization import deserialize_message, serialize_message

    from pier_monitor.nodes.conversions import damage_state_msg
    from pier_monitor.report.results import damage_state_fields

    result = _ensemble_result()
    fields = damage_state_fields(result)
    wire = deserialize_message(serialize_message(damage_state_msg(fields)), PierDamageState)
    assert wire.members == result.members == 200
    assert (wire.p_overall_intact, wire.p_overall_suspicious, wire.p_overall_damaged) == \
        pytest.approx(result.p_overall_state)
    for got, want in zip(wire.sections, fields["sections"]):
        for key, value in want.items():
            if key == "reasons":
                assert list(got.reasons) == value
            else:
                assert getattr(got, key) == pytest.approx(value, nan_ok=True), key
    assert [s.state for s in wire.sections] == [1, 1]
    assert wire.sections[1].reasons[0].startswith("may have yielded (P(yielded) 0.30")


def test_diagnostics_give_intervals_probabilities_and_reasons() -> None:
    from diagnostic_msgs.msg import DiagnosticStatus

    from pier_monitor.nodes.conversions import damage_diagnostics
    from pier_monitor.report.results import damage_state_fields

    result = _ensemble_result()
    arr = damage_diagnostics(damage_state_fields(result), START_NS)
    first, second, identifier = arr.status
    values = {kv.key: kv.value for kv in first.values}
    u = result.sections[0].uncertainty
    assert first.level == DiagnosticStatus.WARN
    assert values["k1_90pct"] == f"[{u.k1.lo:.6g}, {u.k1.hi:.6g}]"
    assert values["ductility_factor_90pct"] == (f"[{u.ductility_factor.lo:.6g}, "
                                                f"{u.ductility_factor.hi:.6g}]")
    assert float(values["p_yielded"]) == 1.0
    assert [float(values[f"p_{s}"]) for s in ("intact", "suspicious", "damaged")] == \
        pytest.approx(u.p_state, abs=1e-6)
    assert values["reasons"] == "; ".join(result.sections[0].reasons) != ""
    assert "straddles 1.2" in first.message and "200 members" in first.message
    assert {kv.key: kv.value for kv in second.values}["reasons"].startswith("may have yielded")
    assert {kv.key: kv.value for kv in identifier.values}["members"] == "200"


def test_diagnostics_of_a_single_identification_have_no_uncertainty_values() -> None:
    from ensemble_helpers import ensemble_result

    from pier_monitor.nodes.conversions import damage_diagnostics
    from pier_monitor.report.results import damage_state_fields

    single = ensemble_result("run1", [np.full(1, 1e9)], [np.full(1, 1.3)], [np.ones(1, bool)],
                             baseline_k1=np.array([1.1e9]))
    arr = damage_diagnostics(damage_state_fields(single), START_NS)
    section = arr.status[0]
    assert [kv.key for kv in section.values] == [
        "event_id", "state", "z_bottom_m", "z_top_m", "k1", "k1_change_pct",
        "ductility_factor", "ductility_factor_upper_bound", "k2", "fy", "c"]
    assert section.message == "suspicious: DF 1.3, k1 change -9.09091 % (event run1)"
