"""Reports: result.json, damage-state mcap, figures, comparison, ``pier-monitor compare``."""

from __future__ import annotations

import json
import math
import re
import struct
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from ros_helpers import check_markers

from pier_monitor import __version__
from pier_monitor.core.identify.damage import IdentificationResult, SectionResult, classify_ductility
from pier_monitor.core.errors import ReportError
from pier_monitor.report import (FIGURE_DPI, PROFILE_FIGSIZE_IN, compare_results,
                                 damage_state_fields, damage_state_topic, load_result,
                                 write_results)

START_NS = 1_700_000_000_250_000_000  # absolute time of the window's first sample


def _png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    return struct.unpack(">II", data[16:24])


def _result(pier_id: str, event_id: str, k1: list[float], df: list[float],
            z: list[float] | None = None) -> IdentificationResult:
    """A hand-made result: sections of 2 m, springs with DF <= 1 did not yield."""
    z = z if z is not None else [2.0 * i for i in range(len(k1) + 1)]
    sections = []
    for i, (k, d) in enumerate(zip(k1, df)):
        yielded = d > 1.0
        fy = 5e6
        sections.append(SectionResult(
            index=i, z_bottom_m=z[i], z_top_m=z[i + 1], k1=k, k2=k / 10, fy=fy, c=2e7,
            yield_angle_rad=fy / k, max_angle_rad=d * fy / k, ductility_factor=d,
            state=classify_ductility(d).name.lower(), yielded=yielded, k2_identifiable=yielded,
            fy_identifiable=yielded, k1_change_pct=None))
    worst = max(classify_ductility(d) for d in df)
    return IdentificationResult(pier_id=pier_id, event_id=event_id, sections=tuple(sections),
                                overall_state=worst.name.lower(), window_start_s=10.0,
                                window_duration_s=20.0, epochs=5, final_loss=1e-6,
                                wall_time_s=1.0, device="cpu")


@pytest.fixture(scope="module")
def identified() -> tuple[Any, Any]:
    """A short real identification of the paper case (window with an absolute start time)."""
    from pier_monitor.core.synthetic.reference import paper_case_window
    from pier_monitor.pinn import PinnSettings, identify

    import torch

    window, _, _ = paper_case_window(moments_measured=True, seed=0)
    window = replace(window, start_time_ns=START_NS)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a small problem: one thread is faster, and robust to a busy CPU
    try:
        run = identify(window, PinnSettings(max_epochs=20, min_epochs=5, device="cpu"))
    finally:
        torch.set_num_threads(threads)
    return window, run


@pytest.fixture(scope="module")
def written(identified: tuple[Any, Any], tmp_path_factory: pytest.TempPathFactory) -> Any:
    window, run = identified
    return write_results(run, window, tmp_path_factory.mktemp("report") / "event")


def test_result_json_round_trips_into_identification_result(identified, written) -> None:
    window, run = identified
    paths = written.paths
    loaded = IdentificationResult.load_json(paths.result_json)
    expected = replace(run.result.with_k1_baseline(window.design.k1, "design values"),
                       window_start_ns=START_NS, software_version=__version__)
    assert loaded == expected == written.result  # what write_results returns is what it saved
    assert loaded.to_dict() == json.loads(paths.result_json.read_text())
    assert loaded.settings == run.result.settings and loaded.history == run.result.history
    # the paper case starts from half the true k1: the change against design is about +100 %
    assert all(abs(s.k1_change_pct - 100.0) < 1.0 for s in loaded.sections)
    assert load_result(paths.out_dir) == loaded


def test_results_without_figures_write_the_same_result_and_no_png(identified, written,
                                                                   tmp_path) -> None:
    window, run = identified
    bare = write_results(run, window, tmp_path / "event", figures=False)
    assert bare.result == written.result and bare.paths.figures == ()
    assert sorted(p.name for p in (tmp_path / "event").iterdir()) == ["damage_state.mcap",
                                                                      "result.json"]
    assert load_result(tmp_path / "event") == written.result


def test_damage_state_mcap_decodes_with_mcap_ros2(identified, written) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    result = written.result
    with written.paths.damage_state_mcap.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        msgs = {channel.topic: (schema, channel, message, decoded)
                for schema, channel, message, decoded in reader.iter_decoded_messages()}
    assert sorted(msgs) == ["/diagnostics", "/table1/damage_markers", "/table1/damage_state"]
    schema, channel, message, decoded = msgs[damage_state_topic("table1")]
    assert schema.name == "pier_monitor_msgs/msg/PierDamageState"
    assert message.log_time == START_NS
    assert (decoded.header.stamp.sec, decoded.header.stamp.nanosec) == (1_700_000_000, 250_000_000)
    assert (decoded.window_start.sec, decoded.window_start.nanosec) == (1_700_000_000, 250_000_000)
    assert decoded.pier_id == "table1" and decoded.event_id == result.event_id
    assert decoded.overall_state == 2  # damaged: springs 1-2 reach DF 4-5
    assert decoded.epochs == result.epochs and decoded.success
    assert len(decoded.sections) == len(result.sections) == 6
    for got, want in zip(decoded.sections, result.sections):
        assert got.index == want.index
        assert (got.z_bottom_m, got.z_top_m) == (want.z_bottom_m, want.z_top_m)
        assert (got.k1, got.k2, got.fy, got.c) == (want.k1, want.k2, want.fy, want.c)
        assert got.ductility_factor == want.ductility_factor
        assert got.k1_change_pct == want.k1_change_pct
        assert got.state == int(want.damage_state)
        assert got.k2_identifiable == want.k2_identifiable == want.yielded
    assert [s.state for s in decoded.sections][:2] == [2, 2]
    # the same state as markers (a cylinder and a label per section) and diagnostics
    schema, channel, message, markers = msgs["/table1/damage_markers"]
    assert schema.name == "visualization_msgs/msg/MarkerArray" and message.log_time == START_NS
    check_markers(markers, result)
    *_, diagnostics = msgs["/diagnostics"]
    levels = [st.level for st in diagnostics.status if "/section_" in st.name]
    assert levels == [int(s.damage_state) for s in result.sections]  # OK/WARN/ERROR = 0/1/2


def test_damage_state_fields_are_the_message_fields(msg_typestore) -> None:
    result = _result("p1", "e1", [1e9, 1e9], [1.3, 0.9])
    fields = damage_state_fields(result)
    _, msg_fields = msg_typestore.fielddefs["pier_monitor_msgs/msg/PierDamageState"]
    _, sec_fields = msg_typestore.fielddefs["pier_monitor_msgs/msg/SectionState"]
    assert set(fields) == {name for name, _ in msg_fields}
    assert set(fields["sections"][0]) == {name for name, _ in sec_fields}
    assert math.isnan(fields["sections"][0]["k1_change_pct"])  # no baseline
    assert [s["state"] for s in fields["sections"]] == [1, 0]
    # no absolute start known: the window start on the source's clock (10 s)
    assert fields["window_start"] == fields["header"]["stamp"] == {"sec": 10, "nanosec": 0}
    assert damage_state_fields(result, stamp_ns=5_000_000_001)["header"]["stamp"] == {
        "sec": 5, "nanosec": 1}


def test_figures_are_pngs_of_their_size(written) -> None:
    w, h = _png_size(written.paths.profile_png)
    assert (w, h) == (round(PROFILE_FIGSIZE_IN[0] * FIGURE_DPI),
                      round(PROFILE_FIGSIZE_IN[1] * FIGURE_DPI))
    assert [p.name for p in written.paths.figures] == ["profile.png", "hysteresis.png",
                                                       "responses.png", "training.png"]
    for path in written.paths.figures:
        assert path.stat().st_size > 20_000, f"{path.name} looks empty"
        w, h = _png_size(path)
        assert w >= 1200 and h >= 700, f"{path.name}: {w}x{h} px"


def test_compare_gives_sign_and_ranking_of_k1_changes() -> None:
    a = _result("p1", "run1", [1.0e9, 0.8e9, 0.8e9, 0.5e9], [1.3, 1.1, 0.9, 0.8])
    b = _result("p1", "run3", [0.85e9, 0.76e9, 0.82e9, 0.35e9], [4.2, 1.25, 0.95, 0.9])
    cmp = compare_results(a, b)
    np.testing.assert_allclose([s.k1_change_pct for s in cmp.sections],
                               [-15.0, -5.0, 2.5, -30.0], atol=1e-9)
    assert [s.number for s in cmp.ranked_by_k1_change()] == [4, 1, 2, 3]
    lines = cmp.summary_lines()
    assert lines[0] == ("pier p1: run1 -> run3: overall suspicious -> damaged; largest k1 loss "
                        "in section 4 (6.0-8.0 m, -30.0 %)")
    assert lines[1] == ("section 1 (0.0-2.0 m): k1 -15.0 %, DF 1.30 -> 4.20, "
                        "suspicious -> damaged (worse)")
    assert lines[2] == ("section 2 (2.0-4.0 m): k1 -5.0 %, DF 1.10 -> 1.25, "
                        "intact -> suspicious (worse)")
    # springs that did not yield: DF only bounded
    assert lines[3] == "section 3 (4.0-6.0 m): k1 +2.5 %, DF <=0.90 -> <=0.95, intact -> intact"
    assert lines[-1].startswith("<=: the spring did not yield")
    assert "k1 A (GN*m/rad)" in cmp.table()


def test_compare_rejects_results_of_different_piers() -> None:
    a = _result("pier_a", "run1", [1e9, 1e9], [1.0, 1.0])
    b = _result("pier_b", "run2", [1e9, 1e9], [1.0, 1.0])
    with pytest.raises(ReportError,
                       match=r"different piers: A \(pier 'pier_a'.*B \(pier 'pier_b'"):
        compare_results(a, b)


def test_compare_rejects_different_geometry() -> None:
    a = _result("p1", "run1", [1e9, 1e9], [1.0, 1.0], z=[0.0, 2.0, 4.0])
    b = _result("p1", "run2", [1e9, 1e9], [1.0, 1.0], z=[0.0, 2.0, 4.5])
    with pytest.raises(ReportError, match=r"section 2 spans 2-4 m in A .* but 2-4.5 m in B"):
        compare_results(a, b)
    c = _result("p1", "run2", [1e9, 1e9, 1e9], [1.0, 1.0, 1.0])
    with pytest.raises(ReportError, match="2 sections.*3"):
        compare_results(a, c)


def test_unwritable_output_directory_raises_report_error_naming_it(identified,
                                                                   tmp_path: Path) -> None:
    window, run = identified
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    out = blocker / "results"
    with pytest.raises(ReportError, match=re.escape(str(out))):
        write_results(run, window, out)


def test_cli_compare_prints_summary_and_writes_files(tmp_path: Path, capsys) -> None:
    from pier_monitor.cli import main

    for name, k1, df in (("run1", [1e9, 1e9], [1.3, 0.9]), ("run3", [0.8e9, 0.97e9], [4.4, 0.95])):
        (tmp_path / name).mkdir()
        _result("p1", name, k1, df).save_json(tmp_path / name / "result.json")
    assert main(["compare", str(tmp_path / "run1"), str(tmp_path / "run3" / "result.json")]) == 0
    out = capsys.readouterr().out
    assert "section 1 (0.0-2.0 m): k1 -20.0 %, DF 1.30 -> 4.40, suspicious -> damaged" in out
    doc = json.loads((tmp_path / "run3" / "compare.json").read_text())
    assert doc["event_before"] == "run1"
    assert doc["sections"][0]["k1_change_pct"] == pytest.approx(-20.0)
    assert _png_size(tmp_path / "run3" / "compare_profile.png") == (
        round(PROFILE_FIGSIZE_IN[0] * FIGURE_DPI), round(PROFILE_FIGSIZE_IN[1] * FIGURE_DPI))


def test_cli_compare_names_a_missing_result(tmp_path: Path, capsys) -> None:
    from pier_monitor.cli import main

    assert main(["compare", str(tmp_path / "nope"), str(tmp_path / "nope2")]) == 2
    assert f"{tmp_path / 'nope'}: no such file" in capsys.readouterr().err


def test_foxglove_layout_shows_the_topics_of_a_results_mcap() -> None:
    """config/foxglove_layout.json: the markers in 3D, the section states, the diagnostics."""
    from pier_monitor.report.diagnostics import DIAGNOSTICS_TOPIC
    from pier_monitor.report.markers import damage_markers_topic

    layout = json.loads((Path(__file__).resolve().parents[2] / "config" /
                         "foxglove_layout.json").read_text())
    panels = layout["configById"]
    three_d = next(v for k, v in panels.items() if k.startswith("3D!"))
    assert damage_markers_topic("edefense_pier") in three_d["topics"]
    assert three_d["followTf"] == "edefense_pier"  # the markers' frame: the pier id
    table = next(v for k, v in panels.items() if k.startswith("Table!"))
    assert table["topicPath"] == damage_state_topic("edefense_pier") + ".sections"
    diag = next(v for k, v in panels.items() if k.startswith("DiagnosticSummary!"))
    assert diag["topicToRender"] == DIAGNOSTICS_TOPIC

    def leaves(node):
        return [node] if isinstance(node, str) else leaves(node["first"]) + leaves(node["second"])

    assert sorted(leaves(layout["layout"])) == sorted(panels)
