"""Bad-input corpus of the ingest: faults injected into a synthetic shaking-table recording.

Each fault is injected into a copy of one recording (two runs of increasing damage) and the
ingest's outcome is asserted: the right finding (code, sensor, time, repaired or excluded),
windows still within tolerance of the clean run's, a level whose displacement sensors are
lost reported unmeasured for that event (the identifier reconstructs it; the other levels'
data unchanged), or an event that fails with a reason naming the level, the sensor and the
cause (never a window built on the bad data), or the right error.  Ingest only, no training.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pytest
from fault_injection import (Timeline, at_sample, clipped_above_run1, clock_jump, config_rate,
                             disconnected, drop, duplicated, edit, frozen_from, idx, keep_span,
                             offset_jump, reordered, replace_sensor, respec, scaled,
                             short_recording, timestamps_at, unmapped, without)

from pier_monitor.core.ingest import IngestError, ingest_recording
from pier_monitor.core.ingest.recording import NS_PER_S, Recording
#: Largest relative RMS change of ``a``, ``v``, ``x`` of any level against the clean window.
TOLERANCE = 0.02


@pytest.fixture(scope="module")
def clean():
    """The recording (88 s, runs at about 20-32 s and 58-70 s), its clean windows, times."""
    synthetic, timeline = short_recording(seed=0)
    rec = synthetic.recording
    windows, report = ingest_recording(rec)
    assert [o.status for o in report.outcomes] == ["ingested", "ingested"]
    assert report.findings == []  # clean data: nothing found
    return rec, windows, timeline


# -- the corpus ----------------------------------------------------------------------------

@dataclass(frozen=True)
class Fault:
    """One injected fault and what the ingest must make of it.

    ``code``/``where``/``action``: a finding that must be there (``code`` may list
    alternatives); ``at``: ``(run, share)`` of the time its span must cover; ``failed``: the
    runs (1, 2) that must get no window, their failure matching ``match`` and naming
    ``where``; ``status``: their status; ``same``: the other windows equal the clean ones
    exactly (else within :data:`TOLERANCE`); ``error``: the ingest must raise an
    :class:`IngestError` matching it.
    """

    name: str
    make: Callable[[Recording, Timeline], Recording]
    code: str | tuple[str, ...] = ()
    where: str = ""
    action: str = ""
    at: tuple[int, float] | None = None
    failed: tuple[int, ...] = ()
    degraded: tuple[int, ...] = ()
    level: int = 0
    match: str = ""
    status: str = "failed"
    same: bool = False
    error: str = ""


FAULTS = [
    # glitches: repaired, the windows as if nothing had happened
    Fault("wire_spike_+500mm_run2", at_sample("l3_wire_n", 2, 0.5, 0, 500.0), "glitch",
          "l3_wire_n", "repaired", (2, 0.5)),
    Fault("wire_spike_+500mm_run1", at_sample("l1_wire_w", 1, 0.4, 0, 500.0), "glitch",
          "l1_wire_w", "repaired", (1, 0.4)),
    Fault("wire_spike_-300mm", at_sample("l4_wire_w", 2, 0.3, 0, -300.0), "glitch",
          "l4_wire_w", "repaired", (2, 0.3)),
    Fault("wire_1e30", at_sample("l2_wire_w", 2, 0.4, 0, 1e30, add=False), "out_of_range",
          "l2_wire_w", "repaired", (2, 0.4)),
    Fault("wire_1e30_no_range_configured",
          respec("l2_wire_w", at_sample("l2_wire_w", 2, 0.4, 0, 1e30, add=False),
                 value_range=None), "glitch", "l2_wire_w", "repaired", (2, 0.4)),
    Fault("wire_nan_sample", at_sample("l1_wire_n", 1, 0.5, 0, np.nan, add=False),
          "gap_interpolated", "l1_wire_n", "repaired", (1, 0.5)),
    Fault("wire_burst_5_samples", at_sample("l2_wire_n", 2, 0.5, 0, 80.0, n=5), "glitch",
          "l2_wire_n", "repaired", (2, 0.5)),
    Fault("acc_spike_+500gal", at_sample("l2_acc_n", 1, 0.5, 1, 500.0), "glitch",
          "l2_acc_n.y", "repaired", (1, 0.5)),
    Fault("acc_spike_+5mps2", at_sample("l3_acc_e", 2, 0.5, 0, 5.0), "glitch", "l3_acc_e.x",
          "repaired", (2, 0.5)),
    Fault("acc_burst_5_samples", at_sample("l1_acc_e", 1, 0.4, 0, 3.0, n=5, add=False),
          "glitch", "l1_acc_e.x", "repaired", (1, 0.4)),
    Fault("acc_1e30", at_sample("l2_acc_s", 1, 0.45, 0, 1e30, add=False), "out_of_range",
          "l2_acc_s.x", "repaired", (1, 0.45)),
    Fault("acc_1e30_no_full_scale_configured",
          respec("l2_acc_s", at_sample("l2_acc_s", 1, 0.45, 0, 1e30, add=False),
                 full_scale=None), "glitch", "l2_acc_s.x", "repaired", (1, 0.45)),
    Fault("acc_nan_burst", edit("l4_acc_nw", lambda d, o, tl: d.__setitem__(
        slice(idx(tl.at(2, 0.6)), idx(tl.at(2, 0.6)) + 8), np.nan)), "gap_interpolated",
          "l4_acc_nw", "repaired", (2, 0.6)),
    Fault("foundation_acc_spike", at_sample("l0_acc_nw", 1, 0.5, 0, 8.0), "glitch",
          "l0_acc_nw.x", "repaired", (1, 0.5)),
    Fault("velocity_meter_spike", at_sample("l4_vel", 1, 0.5, 1, 50.0), "glitch", "l4_vel.y",
          "repaired", (1, 0.5)),
    Fault("wire_burst_0.5s_run2", at_sample("l2_wire_w", 2, 0.5, 0, 100.0, n=100), "glitch",
          "l2_wire_w", "excluded", (2, 0.5), degraded=(2,), level=2),
    # physically impossible values
    Fault("wire_beyond_range_4_samples", at_sample("l3_wire_n", 1, 0.5, 0, -50.0, n=4,
                                                   add=False), "out_of_range", "l3_wire_n",
          "repaired", (1, 0.5)),
    Fault("wire_beyond_range_0.5s", at_sample("l3_wire_n", 1, 0.5, 0, -50.0, n=100, add=False),
          "out_of_range", "l3_wire_n", "excluded", (1, 0.5), degraded=(1,), level=3),
    Fault("acc_beyond_full_scale_1s", at_sample("l1_acc_n", 2, 0.5, 0, 2500.0, n=200,
                                                add=False), "out_of_range", "l1_acc_n.x",
          "excluded", (2, 0.5)),
    # frozen, dead and clipped channels
    Fault("acc_frozen_from_mid_run2", frozen_from("l3_acc_e", 2, 0.2), "frozen", "l3_acc_e.x",
          "excluded", (2, 0.2)),
    Fault("acc_frozen_3s_in_run1", frozen_from("l1_acc_w", 1, 0.3, 3.0), "frozen", "l1_acc_w.y",
          "excluded", (1, 0.4)),
    Fault("wire_frozen_from_mid_run2", frozen_from("l1_wire_n", 2, 0.3), "frozen", "l1_wire_n",
          "excluded", (2, 0.3), degraded=(2,), level=1, same=True),
    Fault("velocity_meter_frozen", frozen_from("l0_vel", 1, 0.5), "frozen", "l0_vel.x",
          "excluded", (1, 0.5)),
    Fault("acc_dead", edit("l2_acc_w", lambda d, o, tl: d.__setitem__(slice(None), o)), "dead",
          "l2_acc_w.x", "excluded"),
    Fault("wire_dead", edit("l3_wire_w", lambda d, o, tl: d.__setitem__(slice(None), 400.0)),
          "dead", "l3_wire_w", "excluded", degraded=(1, 2), level=3),
    Fault("acc_clipped", edit("l3_acc_s", lambda d, o, tl: d.__setitem__(
        (slice(None), 1), np.clip(d[:, 1], -0.3 * np.abs(d[:, 1]).max(),
                                  0.3 * np.abs(d[:, 1]).max()))), "saturated", "l3_acc_s.y",
          "excluded", (2, 0.5)),
    Fault("wire_clipped_in_run2", clipped_above_run1("l4_wire_n"), "saturated", "l4_wire_n",
          "excluded", degraded=(2,), level=4, same=True),
    # gaps
    Fault("acc_gap_2s_run1", drop("l2_acc_n", 1, 0.5, 2.0), "gap_excluded", "l2_acc_n",
          "excluded", (1, 0.6)),
    Fault("wire_gap_2s_run2", drop("l2_wire_n", 2, 0.5, 2.0), "gap_excluded", "l2_wire_n",
          "excluded", (2, 0.6), degraded=(2,), level=2, same=True),
    Fault("wire_gap_2s_run1", drop("l1_wire_w", 1, 0.5, 2.0), "gap_excluded", "l1_wire_w",
          "excluded", (1, 0.6), degraded=(1,), level=1,
          same=True),
    Fault("wire_gap_30ms", drop("l4_wire_w", 2, 0.5, 0.03), "gap_interpolated", "l4_wire_w",
          "repaired", (2, 0.5)),
    Fault("foundation_gap_2s_run2",
          edit("l0_acc_ne", lambda d, o, tl: d.__setitem__(
              slice(idx(tl.at(2, 0.5)), idx(tl.at(2, 0.5)) + 400), np.nan),
               "l0_acc_nw", "l0_acc_sw", "l0_acc_se"),
          "gap_excluded", "l0_acc_se", "excluded", (2, 0.6), failed=(2,),
          match=r"level 0: no usable acceleration sensor .*l0_acc_ne: gap_excluded", same=True),
    # timing
    Fault("duplicated_samples", duplicated("l1_acc_n"), "duplicate", "l1_acc_n", "repaired",
          same=True),
    Fault("samples_out_of_order", reordered("l1_acc_n"), "out_of_order", "l1_acc_n", "repaired",
          same=True),
    Fault("timestamp_jump", clock_jump("l1_acc_n"), "timestamp_jump", "l1_acc_n", "repaired",
          (1, 0.6), same=True),
    Fault("one_sensor_timestamps_at_100hz", timestamps_at("l1_acc_s", 100.0), "rate_mismatch",
          "l1_acc_s", "excluded"),
    Fault("one_sensor_declared_100hz",
          lambda rec, tl: replace_sensor(rec, "l2_acc_e", rate_hz=100.0), "rate_mismatch",
          "l2_acc_e", "excluded"),
    Fault("configuration_says_100hz", config_rate(100.0),
          error=r"sample_rate_hz 100 Hz contradicts the data: all 32 sensors are recorded at "
                r"200 Hz"),
    Fault("configuration_says_400hz", config_rate(400.0),
          error=r"sample_rate_hz 400 Hz contradicts the data"),
    # units
    Fault("acc_in_gal_declared_mps2", respec("l1_acc_s", unit="m/s^2"), "implausible_units",
          "l1_acc_s", "excluded"),
    Fault("wire_in_mm_declared_m", respec("l1_wire_n", unit="m"), "inconsistent", "l1_wire_n",
          "excluded", degraded=(1, 2), level=1),
    # missing and unknown sensors
    Fault("missing_accelerometer", without("l4_acc_ne"), "missing_sensor", "l4_acc_ne",
          "excluded"),
    Fault("missing_wire", without("l2_wire_w"), "missing_sensor", "l2_wire_w", "excluded",
          degraded=(1, 2), level=2),
    Fault("unmapped_topic", unmapped, "unmapped_topic", "/edefense_pier/sensors/level9/acc",
          "noted", same=True),
    # sensors that disagree with their level
    Fault("acc_gain_x1.5", scaled("l2_acc_e", 1.5), "inconsistent", "l2_acc_e", "excluded",
          (1, 0.5)),
    Fault("acc_sign_reversed", scaled("l4_acc_ne", -1.0, axis=0), "inconsistent",
          "l4_acc_ne.x", "excluded", (2, 0.5)),
    Fault("acc_disconnected", disconnected("l1_acc_s"), ("implausible_units", "inconsistent"),
          "l1_acc_s", "excluded"),
    # an accelerometer's offset that changes: found against the level's other
    # accelerometers, excluded from where it starts
    Fault("acc_offset_step_0.3_in_run1", edit("l2_acc_e", lambda d, o, tl: d.__setitem__(
        (slice(idx(tl.at(1, 0.6)), None), 0), d[idx(tl.at(1, 0.6)):, 0] + 0.3)),
          "offset_step", "l2_acc_e.x", "excluded", (1, 0.6)),
    Fault("acc_offset_step_0.1mps2_between_runs", edit("l3_acc_n", lambda d, o, tl: d.__setitem__(
        (slice(idx(45.0), None), 0), d[idx(45.0):, 0] - 10.0)),  # gal
          "offset_step", "l3_acc_n.x", "excluded"),
    Fault("acc_slow_bias_0.005_per_s", edit("l1_acc_w", lambda d, o, tl: d.__setitem__(
        (slice(idx(40.0), None), 1), d[idx(40.0):, 1] + 0.005 * np.arange(d.shape[0]
                                                                        - idx(40.0)) / 200.0)),
          "drift", "l1_acc_w.y", "excluded", (2, 0.5)),
    Fault("wire_drift_30mm_per_min", edit("l2_wire_w", lambda d, o, tl: d.__setitem__(
        (slice(None), 0), d[:, 0] + 30.0 * np.arange(d.shape[0]) / (60.0 * 200.0))),
          "drift", "l2_wire_w.x", "excluded", (1, 0.5), degraded=(1, 2), level=2),
    Fault("wire_gain_x1.5", scaled("l2_wire_w", 1.5), "inconsistent", "l2_wire_w", "excluded",
          (1, 0.5), degraded=(1, 2), level=2),
    Fault("wire_sign_reversed", scaled("l4_wire_n", -1.0), "inconsistent", "l4_wire_n",
          "excluded", (2, 0.5), degraded=(1, 2), level=4),
    Fault("wire_offset_jump_in_run2", offset_jump("l2_wire_n", 2, 0.4, 20.0), "offset_jump",
          "l2_wire_n", "repaired", (2, 0.4)),
    Fault("wire_offset_jump_between_runs",
          edit("l3_wire_w", lambda d, o, tl: d.__setitem__(slice(idx(45.0), None),
                                                       d[idx(45.0):] + 30.0)),
          "offset_jump", "l3_wire_w", "repaired"),
    # recordings cut short
    Fault("data_end_inside_run2", keep_span(lambda tl: 0.0, lambda tl: tl.at(2, 0.5)),
          "event_cut", "", "failed", failed=(2,), status="cut",
          match=r"is cut: the data end at .* while the ground is still shaking", same=True),
    Fault("data_start_inside_run1", keep_span(lambda tl: tl.at(1, 0.3), lambda tl: 1e3),
          "event_cut", "", "failed", failed=(1,), status="cut",
          match=r"is cut: the data begin at .* while the ground is still shaking"),
    Fault("data_end_between_runs", keep_span(lambda tl: 0.0, lambda tl: 48.0), same=True),
]


def rel_rms(got, want, levels=None) -> float:
    """Largest relative RMS difference of a, v, x over the levels (all, or a mask)."""
    keep = slice(None) if levels is None else levels
    return max(float(np.max(np.sqrt(np.mean((getattr(got, k) - getattr(want, k))[:, keep] ** 2,
                                            axis=0))
                            / np.sqrt(np.mean(getattr(want, k)[:, keep] ** 2, axis=0))))
               for k in ("a", "v", "x"))


def test_the_corpus_covers_every_class_with_at_least_40_faults():
    assert len(FAULTS) >= 40 and len({f.name for f in FAULTS}) == len(FAULTS)


@pytest.mark.parametrize("fault", FAULTS, ids=[f.name for f in FAULTS])
def test_injected_fault(clean, fault):
    rec, clean_windows, timeline = clean
    bad = fault.make(rec, timeline)
    if fault.error:
        with pytest.raises(IngestError, match=fault.error):
            ingest_recording(bad)
        return
    windows, report = ingest_recording(bad)
    if fault.code:
        codes = (fault.code,) if isinstance(fault.code, str) else fault.code
        found = [f for f in report.findings if f.code in codes
                 and (not fault.where or fault.where in (f.where, f.sensor_id))]
        assert found, f"no {codes} finding for {fault.where}: {report.findings}"
        assert all(f.action == fault.action for f in found), found
        if fault.at is not None:
            t_ns = rec.start_ns + int(timeline.at(*fault.at) * NS_PER_S)
            slack = NS_PER_S // 100
            assert any(f.start_ns - slack <= t_ns <= f.end_ns + slack for f in found), found
    by_run = {}
    for outcome in report.outcomes:  # each outcome to the run whose window it overlaps
        run = 1 + int(outcome.start_ns > rec.start_ns + int(timeline.windows[1][0] * NS_PER_S)
                      - 5 * NS_PER_S)
        by_run[run] = outcome
    expected_runs = {1, 2} if fault.name != "data_end_between_runs" else {1}
    assert set(by_run) == expected_runs
    for run, outcome in by_run.items():
        if run in fault.failed:
            assert outcome.window is None and outcome.status == fault.status
            assert re.search(fault.match, outcome.failure), outcome.failure
            continue
        assert outcome.status == "ingested", outcome.failure
        want = clean_windows[run - 1]
        got = outcome.window
        keep = np.ones(got.n_levels, dtype=bool)
        if run in fault.degraded:  # the level's wires are lost: its displacement unmeasured
            assert not got.coverage.displacement[fault.level - 1]
            assert got.coverage.displacement.sum() == got.n_levels - 1
            assert any(f.code == "unmeasured_level" and f.where == f"level {fault.level}"
                       and f.overlaps(outcome.start_ns, outcome.end_ns) for f in report.findings)
            keep[fault.level - 1] = False
        if fault.same:
            for key in ("t", "ag", "a"):
                np.testing.assert_array_equal(getattr(got, key), getattr(want, key))
            for key in ("v", "x"):
                np.testing.assert_array_equal(getattr(got, key)[:, keep],
                                              getattr(want, key)[:, keep])
        elif run in fault.degraded:
            assert got.event_id == want.event_id
            assert rel_rms(got, want, keep) < TOLERANCE
        else:
            assert got.event_id == want.event_id
            assert rel_rms(got, want) < TOLERANCE
    assert windows == [o.window for o in report.outcomes if o.window is not None]
