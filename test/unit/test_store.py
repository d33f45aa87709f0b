"""The results store: baseline rule, pending windows, failure records (no training)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from pier_monitor.core.errors import ReportError, UnsafeNameError
from pier_monitor.core.identify.damage import (IdentificationResult, SectionResult,
                                               failed_result)
from pier_monitor.core.ingest.window import MeasuredWindow, load_window, save_window
from pier_monitor.core.synthetic.reference import paper_case_window
from pier_monitor.store import FAILED_JSON, WINDOW_NPZ, ResultsStore

T0 = 1_700_000_000 * 10 ** 9


@pytest.fixture(scope="module")
def base_window() -> MeasuredWindow:
    return paper_case_window(moments_measured=False, seed=0)[0]


def window(base: MeasuredWindow, event_id: str, start_s: float,
           pier_id: str = "table1") -> MeasuredWindow:
    return replace(base, pier_id=pier_id, event_id=event_id,
                   start_time_ns=T0 + int(start_s * 1e9))


def result(w: MeasuredWindow, k1: float, success: bool = True) -> IdentificationResult:
    """A hand-made result of window ``w``: every section with ``k1``."""
    sections = tuple(SectionResult(
        index=i, z_bottom_m=float(i), z_top_m=float(i + 1), k1=k1, k2=k1 / 10, fy=5e6, c=2e7,
        yield_angle_rad=5e6 / k1, max_angle_rad=1e-3, ductility_factor=0.5, state="intact",
        yielded=False, k2_identifiable=False, fy_identifiable=False)
        for i in range(w.n_levels))
    return IdentificationResult(
        pier_id=w.pier_id, event_id=w.event_id, sections=sections, overall_state="intact",
        window_start_s=0.0, window_duration_s=w.duration_s, epochs=3, final_loss=1e-3,
        wall_time_s=1.0, device="cpu", success=success, window_start_ns=w.start_time_ns)


def store_with(tmp_path, *results: IdentificationResult) -> ResultsStore:
    store = ResultsStore(tmp_path / "results")
    for r in results:
        d = store.event_dir(r.event_id)
        d.mkdir(parents=True, exist_ok=True)
        r.save_json(d / ("result.json" if r.success else FAILED_JSON))
    return store


def test_baseline_is_the_earliest_earlier_successful_result_of_the_same_pier(
        base_window, tmp_path):
    w = {name: window(base_window, name, t) for name, t in
         (("e1", 10.0), ("e2", 20.0), ("e3", 30.0), ("e4", 40.0))}
    other_pier = window(base_window, "p2_e0", 0.0, pier_id="other")
    store = store_with(tmp_path, result(w["e2"], 1e9), result(w["e3"], 0.9e9),
                       result(other_pier, 2e9), result(w["e1"], 1.1e9, success=False))
    # e1 failed, the other pier does not count: e2 is the earliest earlier success
    assert store.baseline_for(w["e4"]).event_id == "e2"
    assert store.baseline_for(w["e3"]).event_id == "e2"
    assert store.baseline_for(w["e2"]) is None  # nothing before it: design values
    assert store.baseline_for(w["e1"]) is None  # only later results
    assert [r.event_id for r in store.results("table1")] == ["e2", "e3"]
    assert [r.event_id for r in store.failures()] == ["e1"]
    assert store.is_done("e1") and store.is_done("e3") and not store.is_done("e4")


def test_a_bag_into_an_empty_store_compares_with_its_first_event(base_window, tmp_path):
    store = ResultsStore(tmp_path / "results")
    first, second = window(base_window, "run1", 10.0), window(base_window, "run2", 90.0)
    assert store.baseline_for(first) is None
    store.start_event(first)
    result(first, 1e9).save_json(store.event_dir("run1") / "result.json")
    assert store.baseline_for(second).event_id == "run1"


def test_pending_windows_come_from_event_directories_and_the_inbox_oldest_first(
        base_window, tmp_path):
    store = ResultsStore(tmp_path / "results")
    inbox = tmp_path / "windows"
    inbox.mkdir()
    late, early, done = (window(base_window, n, t) for n, t in
                         (("late", 50.0), ("early", 5.0), ("done", 1.0)))
    stored = store.start_event(late)  # stored, training never finished (a kill)
    assert stored == store.event_dir("late") / WINDOW_NPZ and load_window(stored) == late
    save_window(early, inbox / "early.npz")
    save_window(late, inbox / "late.npz")  # the same event in both places: listed once
    save_window(done, inbox / "done.npz")
    store.event_dir("done").mkdir()
    result(done, 1e9).save_json(store.event_dir("done") / "result.json")
    (inbox / "broken.npz").write_bytes(b"not a zip")
    pending = store.pending(inbox)
    assert [w.event_id for w in pending.windows] == ["early", "late"]
    assert pending.windows[0] == early  # every field, as stored
    assert len(pending.unreadable) == 1 and "broken.npz" in pending.unreadable[0]
    assert ResultsStore(tmp_path / "nothing").pending().windows == ()


def test_a_new_start_removes_the_earlier_outcome_and_leftovers_and_failures_are_recorded(
        base_window, tmp_path):
    w = window(base_window, "ev", 10.0)
    store = store_with(tmp_path, result(w, 1e9))
    assert store.is_done("ev")
    left = store.event_dir("ev") / ".damage_state.mcap.4242.139.tmp"  # a killed writer's
    left.write_bytes(b"half")
    store.start_event(w)
    assert not left.exists()
    assert not store.is_done("ev") and [x.event_id for x in store.pending().windows] == ["ev"]
    failed = failed_result(w, device="cuda", message="identification failed: no GPU")
    path = store.record_failure(failed)
    assert path.name == FAILED_JSON and store.is_done("ev")
    (back,) = store.failures()
    assert back.event_id == "ev" and not back.success and back.message.endswith("no GPU")
    assert back.overall_state == "unknown" and all(s.state == "unknown" for s in back.sections)
    assert math.isnan(back.sections[0].k1) and back.window_start_ns == w.start_time_ns
    np.testing.assert_allclose([s.z_top_m for s in back.sections],
                               w.geometry.level_heights_m[1:])
    assert store.baseline_for(window(base_window, "later", 20.0)) is None  # a failure is no baseline
    unreliable = result(w, 1e9).with_check_reasons(["section 2: c = 1e-16 N·m·s/rad is near zero"])
    unreliable.save_json(store.event_dir("ev") / "result.json")
    assert store.baseline_for(window(base_window, "later", 20.0)) is None  # nor an unreliable one
    with pytest.raises(ReportError, match="takes a failed result"):
        store.record_failure(result(w, 1e9))


@pytest.mark.parametrize("bad, match", [("", "event_id: empty"), ("..", r"holds '\.'"),
                                        ("a/b", "holds '/'"), ("../../x", r"holds '\./'"),
                                        ("/abs/y", "holds '/'"), ("a\\b", r"holds '\\\\'")])
def test_event_ids_that_are_not_directory_names_are_refused(base_window, tmp_path, bad, match):
    store = ResultsStore(tmp_path / "results")
    with pytest.raises(UnsafeNameError, match=match):
        store.event_dir(bad)
    w = failed_result(window(base_window, bad, 1.0), device="cpu", message="x")
    with pytest.raises(UnsafeNameError, match=match):
        store.record_failure(w)
    assert not any(tmp_path.rglob("failed.json"))


def test_an_event_directory_linked_out_of_the_root_is_refused(tmp_path):
    root = tmp_path / "results"
    root.mkdir()
    (root / "run1").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    with pytest.raises(UnsafeNameError, match="outside"):
        ResultsStore(root).event_dir("run1")


def test_the_fleet_waits_for_the_baseline_that_identify_would_choose_after_an_unreliable_event(
        base_window, tmp_path):
    """An unreliable result is no baseline, for ``identify`` and for the fleet alike: the
    fleet hands out a later event only once the event that will be its baseline is done."""
    from pier_monitor.fleet.runner import _Schedule

    w = {name: window(base_window, name, t) for name, t in
         (("e1", 10.0), ("e2", 20.0), ("e3", 30.0))}
    unreliable = result(w["e1"], 1e9).with_check_reasons(
        ["level 2: the reproduced acceleration departs from the measured by 60 % RMS"])
    assert unreliable.success and not unreliable.reliable
    store = store_with(tmp_path, unreliable)
    schedule = _Schedule(store)
    schedule.add(w["e2"])
    schedule.add(w["e3"])
    assert store.baseline_for(w["e2"]) is None
    # e3's baseline will be e2 (e1 is unreliable): e3 waits for it
    assert [x.event_id for x in schedule.ready()] == ["e2"]
    done = result(w["e2"], 0.9e9)
    store_with(tmp_path, done)
    schedule.settle("e2", done)
    assert [x.event_id for x in schedule.ready()] == ["e3"]
    assert store.baseline_for(w["e3"]).event_id == "e2"


def test_a_result_that_is_no_baseline_is_named_by_its_file_never_by_a_path_from_its_data(
        base_window, tmp_path, caplog):
    """The warning names the result's file in the store; an event id read from a file's
    content that is no safe id is named as it is, and no path is built from it."""
    store = ResultsStore(tmp_path)
    caplog.set_level("WARNING", logger="pier_monitor.store")
    good = result(window(base_window, "run1", 1.0), math.nan)
    assert not store.is_baseline(good)
    assert f"{tmp_path / 'run1' / 'result.json'}: not a baseline" in caplog.text
    caplog.clear()
    bad = result(window(base_window, "../../etc", 1.0), math.nan)
    assert not store.is_baseline(bad)
    assert "result of event '../../etc': not a baseline" in caplog.text
    assert "etc/result.json" not in caplog.text
