"""Bad input end to end, through ``pier-monitor identify``: the cases that once gave a silent
wrong answer now give a clear error, a correct repair, or an explicit "unreliable".

A two-run synthetic shaking-table bag (run 2 drives sections 1-2 into yield) with one fault
injected into a copy of its recording is identified with a short training (30 epochs from
the equation-error start, no figures), and the outcome is checked against the clean bag's:
the same states and ductility factors after a repair, the failed event named with its
sensor and time while the other event keeps its result, the exit status that says so.
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from fault_injection import at_sample, drop, edit, frozen_from, idx, short_recording

from pier_monitor.bags import write_bag
from pier_monitor.bags.types import get_typestore
from pier_monitor.bags.writer import write_mcap_messages
from pier_monitor.cli import EXIT_ERROR, EXIT_FAILED, EXIT_OK, main
from pier_monitor.core.identify.damage import IdentificationResult, classify_ductility
from pier_monitor.core.ingest import IngestSettings
from pier_monitor.core.identify.methods import IdentifySettings, PinnSettings
from pier_monitor.pipeline import identify_bag
from pier_monitor.report.compare import compare_results
from pier_monitor.store import ResultsStore

pytestmark = pytest.mark.timeout(600)

EPOCHS = 30
TRAINING = ["--max-epochs", str(EPOCHS), "--device", "cpu", "--no-progress", "--no-figures"]
#: Largest relative change of a ductility factor against the clean bag's after a repair.
DF_RTOL = 0.03


def outcomes(out: Path) -> dict[str, IdentificationResult]:
    """Every event's result or failure record in a results root, by event id."""
    store = ResultsStore(out)
    return {r.event_id: r for r in (*store.results(), *store.failures())}


def identify(capsys, bag: Path, out: Path, *extra: str) -> tuple[int, str, str]:
    """``pier-monitor identify`` with the short training; exit status, stdout, stderr."""
    rc = main(["identify", str(bag), "--out", str(out), *TRAINING, *extra])
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


@pytest.fixture(scope="module")
def source():
    """The recording, its timeline and truth, and the clean bag."""
    synthetic, timeline = short_recording(seed=0)
    return synthetic, timeline


@pytest.fixture(scope="module")
def clean(source, tmp_path_factory):
    """The clean bag identified: its path and results (run 1, run 2)."""
    synthetic, _ = source
    tmp = tmp_path_factory.mktemp("clean")
    bag = tmp / "clean.mcap"
    write_bag(synthetic.recording, bag)
    rc = main(["identify", str(bag), "--out", str(tmp / "out"), *TRAINING])
    assert rc == EXIT_OK
    results = sorted(outcomes(tmp / "out").values(), key=lambda r: r.window_start_ns)
    assert len(results) == 2 and all(r.reliable for r in results)
    return bag, results


def faulty_bag(source, tmp_path: Path, fault) -> Path:
    synthetic, timeline = source
    bag = tmp_path / "faulty.mcap"
    write_bag(fault(synthetic.recording, timeline), bag)
    return bag


def test_the_clean_bag_gives_the_true_states(source, clean):
    synthetic, _ = source
    for result, truth in zip(clean[1], synthetic.truth.runs, strict=True):
        # the true state, or suspicious for a reason the 90 % intervals give (a fully measured
        # bag carries them by default: an elastic upper section's DF interval may straddle 1.2)
        for s, df in zip(result.sections, truth.ductility_factors, strict=True):
            want = classify_ductility(df).name.lower()
            assert s.state == want or (s.state == "suspicious" and want == "intact"
                                        and s.reasons), (s.index, s.state, want, s.reasons)
        assert [s.state for s in result.sections if s.ductility_factor > 1.0] == [
            classify_ductility(df).name.lower() for s, df in
            zip(result.sections, truth.ductility_factors) if s.ductility_factor > 1.0]
        assert result.findings == ()  # nothing to repair


#: Faults the ingest repairs (or excludes the sensor over), all in one bag: the fault, the
#: sensor or channel, the finding's code, the run.
REPAIRED = {
    "+500 mm on one wire sample": (at_sample("l3_wire_n", 2, 0.5, 0, 500.0), "l3_wire_n",
                                   "glitch", 2),
    "1e30 on one wire sample": (at_sample("l1_wire_w", 2, 0.4, 0, 1e30, add=False),
                                "l1_wire_w", "out_of_range", 2),
    "accelerometer frozen from mid-run": (frozen_from("l3_acc_e", 1, 0.3), "l3_acc_e.x",
                                          "frozen", 1),
}


@pytest.fixture(scope="module")
def repaired(source, tmp_path_factory):
    """The bag with every fault of REPAIRED identified: exit status, stdout, results."""
    synthetic, timeline = source
    rec = synthetic.recording
    for fault, *_ in REPAIRED.values():
        rec = fault(rec, timeline)
    tmp = tmp_path_factory.mktemp("repaired")
    write_bag(rec, tmp / "faulty.mcap")
    stdout = io.StringIO()
    with contextlib.redirect_stdout(stdout):  # a module fixture has no capsys
        rc = main(["identify", str(tmp / "faulty.mcap"), "--out", str(tmp / "out"), *TRAINING])
    results = sorted(outcomes(tmp / "out").values(), key=lambda r: r.window_start_ns)
    return rc, stdout.getvalue(), results, tmp / "out"


def test_repaired_faults_give_the_clean_states(clean, repaired):
    rc, out, results, _ = repaired
    assert rc == EXIT_OK, out
    for got, want in zip(results, clean[1], strict=True):
        assert got.reliable and got.overall_state == want.overall_state
        assert [s.state for s in got.sections] == [s.state for s in want.sections]
        np.testing.assert_allclose(got.ductility_factors, want.ductility_factors, rtol=DF_RTOL)


@pytest.mark.parametrize("name", list(REPAIRED))
def test_each_repair_is_printed_and_kept_with_its_sensor_and_time(repaired, name):
    rc, out, results, root = repaired
    _, where, code, run = REPAIRED[name]
    assert any(line.split()[1:3] == [f"{where}:", code] for line in out.splitlines()
               if line.startswith("  ") and len(line.split()) > 2), out
    found = [f for f in results[run - 1].findings if f.code == code and where in
             (f.where, f.sensor_id)]
    assert found and found[0].action in ("repaired", "excluded")
    assert found[0].start_ns >= results[run - 1].window_start_ns - 15 * 10 ** 9  # its time
    doc = json.loads((root / results[run - 1].event_id / "result.json").read_text())
    assert any(f["code"] == code and f["where"].startswith(where.split(".")[0])
               for f in doc["findings"])


def test_an_unrepaired_glitch_makes_the_result_unreliable_never_damaged(source, clean,
                                                                        tmp_path):
    """Defence in depth: with the ingest's glitch and consistency checks turned off, the
    +500 mm sample reaches the identification, and its self-check refuses the result."""
    bag = faulty_bag(source, tmp_path, at_sample("l3_wire_n", 2, 0.5, 0, 500.0))
    blind = IngestSettings(glitch_threshold=1e12, disagree_rel=1e12)
    outcome = identify_bag(bag, tmp_path / "out", ingest_settings=blind, figures=False,
                           settings=IdentifySettings(device="cpu", pinn_settings=PinnSettings(
                               max_epochs=EPOCHS, min_epochs=EPOCHS)))
    run2 = outcome.events[1]
    assert run2.status == "unreliable" and run2.result.overall_state == "unreliable"
    assert {s.state for s in run2.result.sections} == {"unreliable"}
    assert any("section 3" in r or "level 3" in r for r in run2.result.unreliable_reasons)
    # compare says that there is no diagnosis, not "damaged -> intact" or the reverse
    comparison = compare_results(clean[1][0], run2.result)
    assert comparison.overall_after == "unreliable"
    assert not any(s.worsened for s in comparison.sections)
    assert "unreliable, no diagnosis" in "\n".join(comparison.summary_lines())
    # an unreliable result is no baseline: the store has no reliable result of run 2
    assert not any(r.reliable for r in ResultsStore(tmp_path / "out").results()
                   if r.event_id == run2.result.event_id)


def _same_states(result: IdentificationResult, clean_result: IdentificationResult) -> None:
    """The states of the clean bag's result, DFs of the yielded sections within 10 %.

    Intact and suspicious-for-a-reason-of-the-intervals count alike: the clean bag is fully
    measured (the equation-error route, its 90 % intervals by default, which may promote
    an elastic upper section to suspicious), a faulty one may be reconstructed by the field
    route, whose intervals are its own."""
    assert result.reliable, result.message

    def state(s):
        return "intact" if s.state == "suspicious" and not s.yielded and s.reasons else s.state

    assert [state(s) for s in result.sections] == [state(s) for s in clean_result.sections]
    for got, want in zip(result.sections, clean_result.sections, strict=True):
        if want.yielded:
            assert got.ductility_factor == pytest.approx(want.ductility_factor, rel=0.10)


def test_a_two_second_wire_gap_in_run_2_leaves_level_2_unmeasured_there(source, clean,
                                                                        tmp_path, capsys):
    rc, out, _ = identify(capsys, faulty_bag(source, tmp_path, drop("l2_wire_n", 2, 0.5, 2.0)),
                          tmp_path / "out")
    assert rc == EXIT_OK
    got = outcomes(tmp_path / "out")
    run1, run2 = (got[r.event_id] for r in clean[1])
    assert run1.reliable and run1.sections == clean[1][0].sections  # untouched
    # run 2: one wire of level 2 left, one direction only: its displacement is reconstructed
    # from the physics, and the event keeps its diagnosis
    _same_states(run2, clean[1][1])
    codes = {(f.code, f.sensor_id) for f in run2.findings}
    assert ("gap_excluded", "l2_wire_n") in codes
    assert any(code == "unmeasured_level" for code, _ in codes)
    assert "reconstructed from the physics" in run2.message
    assert "2 identified" in out


def test_a_dead_wire_leaves_its_level_unmeasured_in_both_runs(source, clean, tmp_path, capsys):
    dead = edit("l3_wire_w", lambda d, o, tl: d.__setitem__(slice(None), 400.0))
    rc, out, _ = identify(capsys, faulty_bag(source, tmp_path, dead), tmp_path / "out")
    got = outcomes(tmp_path / "out")
    assert rc == EXIT_OK
    for want in clean[1]:
        result = got[want.event_id]
        _same_states(result, want)
        assert any(f.code == "dead" and f.sensor_id == "l3_wire_w" for f in result.findings)


def test_a_foundation_gap_in_run_2_fails_run_2_only(source, clean, tmp_path, capsys):
    def gap(d, _o, tl):
        i = idx(tl.at(2, 0.5))
        d[i:i + 400] = np.nan
    fault = edit("l0_acc_ne", gap, "l0_acc_nw", "l0_acc_sw", "l0_acc_se")
    rc, out, _ = identify(capsys, faulty_bag(source, tmp_path, fault), tmp_path / "out")
    assert rc == EXIT_FAILED
    got = outcomes(tmp_path / "out")
    run1, run2 = (got[r.event_id] for r in clean[1])
    assert run1.reliable and run1.sections == clean[1][0].sections  # untouched
    assert not run2.success and run2.overall_state == "unknown"
    assert "level 0: no usable acceleration sensor" in run2.message
    assert "l0_acc_ne: gap_excluded" in run2.message
    assert (tmp_path / "out" / run2.event_id / "failed.json").is_file()
    assert f"event {run2.event_id}: FAILED: ingest: level 0" in out
    assert "1 identified, 1 failed" in out


def test_a_truncated_bag_gives_run_1_as_the_full_bag(clean, tmp_path, capsys):
    bag, (run1, _) = clean
    data = bag.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[:len(data) // 2])  # a logger that lost power: run 2 never written
    rc, out, err = identify(capsys, cut, tmp_path / "out")
    assert rc == EXIT_FAILED  # the bag is damaged: said by the status too
    assert "warning" in err and "the bag is damaged" in err and "its data end at" in err
    (got,) = outcomes(tmp_path / "out").values()
    assert got.event_id == run1.event_id and got.reliable
    assert got.sections == run1.sections and got.epochs == run1.epochs


def test_a_configured_rate_that_contradicts_the_data_is_named(source, clean, tmp_path, capsys):
    synthetic, _ = source
    raw = synthetic.recording.config.as_dict()
    raw["sample_rate_hz"] = 100.0
    pier = tmp_path / "pier.yaml"
    pier.write_text(yaml.safe_dump(raw))
    rc, _, err = identify(capsys, clean[0], tmp_path / "out", "--pier", str(pier))
    assert rc == EXIT_ERROR
    assert "sample_rate_hz 100 Hz contradicts the data" in err and "200 Hz" in err
    assert "no usable acceleration sensor" not in err


def test_a_pier_file_that_is_not_utf8_is_refused(clean, tmp_path, capsys):
    pier = tmp_path / "pier.yaml"
    pier.write_bytes(b"pier_id: caf\xe9\n")
    rc, _, err = identify(capsys, clean[0], tmp_path / "out", "--pier", str(pier))
    assert rc == EXIT_ERROR and "pier.yaml: not UTF-8 text (byte 0xe9" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("pier_id, shown", [("../../x", r"'../../x' holds './'"),
                                            ("/abs/y", r"'/abs/y' holds '/'"),
                                            ("a/b", r"'a/b' holds '/'")])
def test_an_unsafe_pier_id_is_refused_from_the_bag_and_from_the_pier_file(
        source, clean, tmp_path, capsys, pier_id, shown):
    synthetic, _ = source
    raw = synthetic.recording.config.as_dict()
    raw["pier_id"] = pier_id
    text = yaml.safe_dump(raw)
    root = tmp_path / "a" / "b"
    # the bag's embedded configuration
    typestore = get_typestore()
    cdr = bytes(typestore.serialize_cdr(typestore.types["std_msgs/msg/String"](data=text),
                                        "std_msgs/msg/String"))
    bag = tmp_path / "evil.mcap"
    write_mcap_messages(bag, [("/evil/pier_configuration", "std_msgs/msg/String", True)],
                        [(1, 0, cdr)])
    rc, _, err = identify(capsys, bag, root / "out")
    assert rc == EXIT_ERROR and f"pier_id: {shown}" in err
    # a --pier file
    pier = tmp_path / "pier.yaml"
    pier.write_text(text)
    rc, _, err = identify(capsys, clean[0], root / "out", "--pier", str(pier))
    assert rc == EXIT_ERROR and f"pier_id: {shown}" in err
    assert not (tmp_path / "x").exists() and not list(tmp_path.rglob("result.json"))


def test_an_output_below_a_file_is_refused_before_any_work(clean, tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    rc, _, err = identify(capsys, clean[0], tmp_path / "afile" / "out")
    assert rc == EXIT_ERROR and "is a file, not a directory" in err
