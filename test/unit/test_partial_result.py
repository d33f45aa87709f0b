"""A partial window (the data end during the shaking, after its strong motion) is marked
partial, with its reason, in result.json, failed.json and the CLI's event lines."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.identify.damage import IdentificationResult, failed_result

REASON = ("the data end at 2024-03-12T01:00:35.270Z while the ground is still shaking; the "
          "largest foundation acceleration (2024-03-12T01:00:25.270Z) lies 10.0 s before the "
          "end of the data")


@pytest.fixture(scope="module")
def identified():
    """A short real identification of the paper case, on a window marked partial."""
    import torch

    from pier_monitor.core.synthetic.reference import paper_case_window
    from pier_monitor.core.identify.methods import IdentifySettings, PinnSettings, identify

    window, _, _ = paper_case_window(moments_measured=True, seed=0)
    window = replace(window, report={**window.report, "partial": {"reason": REASON}})
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        run = identify(window, IdentifySettings(device="cpu", pinn_settings=PinnSettings(
            max_epochs=5, min_epochs=2)))
    finally:
        torch.set_num_threads(threads)
    return window, run


def test_result_json_of_a_partial_window_carries_the_reason(identified, tmp_path) -> None:
    from pier_monitor.report import load_result, write_results

    window, run = identified
    written = write_results(run, window, tmp_path / "partial", figures=False)
    saved = json.loads(written.paths.result_json.read_text())
    assert saved["partial"] == {"reason": REASON}
    assert written.result.partial == REASON
    assert load_result(tmp_path / "partial") == written.result
    # a complete window: null
    whole = replace(window, report={k: v for k, v in window.report.items() if k != "partial"})
    bare = write_results(run, whole, tmp_path / "whole", figures=False)
    assert json.loads(bare.paths.result_json.read_text())["partial"] is None
    assert bare.result.partial is None


def test_failed_identification_of_a_partial_window_keeps_the_mark(identified, tmp_path) -> None:
    window, _ = identified
    failed = failed_result(window, device="cpu", message="identification failed: test")
    assert failed.to_dict()["partial"] == {"reason": REASON}
    path = failed.save_json(tmp_path / "failed.json")
    assert IdentificationResult.load_json(path).partial == REASON


def test_a_malformed_partial_mark_is_named(identified) -> None:
    window, _ = identified
    bad = replace(window, report={**window.report, "partial": "yes"})
    with pytest.raises(InputDataError, match=r"report\['partial'\] must be null"):
        _ = bad.partial


def test_the_cli_event_lines_say_partial_and_why(identified, tmp_path, capsys) -> None:
    from pier_monitor.cli import _print_event
    from pier_monitor.events import EventOutcome
    from pier_monitor.report import write_results

    window, run = identified
    written = write_results(run, window, tmp_path / "partial", figures=False)
    _print_event(EventOutcome(window=window, result=written.result, out_dir=tmp_path / "partial",
                              window_file=None, paths=written.paths))
    out = capsys.readouterr().out
    event_line = next(line for line in out.splitlines() if line.startswith("event "))
    assert "(PARTIAL: the data end during the shaking)" in event_line
    assert f"partial: {REASON}" in out
