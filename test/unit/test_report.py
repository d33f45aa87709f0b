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

from ensemble_helpers import MEMBERS, ensemble_result, normal_members, yielded_members
from pier_monitor import __version__
from pier_monitor.core.identify.damage import IdentificationResult, SectionResult, classify_ductility
from pier_monitor.core.identify.uncertainty import (MemberResponses, overall_state_probabilities,
                                                    summarize_members)
from pier_monitor.core.errors import ReportError
from pier_monitor.report.results import DAMAGE_STATE_TYPE
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
    from pier_monitor.core.identify.methods import IdentifySettings, PinnSettings, identify

    import torch

    window, _, _ = paper_case_window(moments_measured=True, seed=0)
    window = replace(window, start_time_ns=START_NS)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # a small problem: one thread is faster, and robust to a busy CPU
    try:
        run = identify(window, IdentifySettings(method="pinn", device="cpu",
                                                pinn_settings=PinnSettings(max_epochs=20,
                                                                           min_epochs=5)))
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
    expected = replace(run.result.without_k1_baseline().with_design_k1(window.design.k1),
                       window_start_ns=START_NS, software_version=__version__)
    assert loaded == expected == written.result  # what write_results returns is what it saved
    assert loaded.to_dict() == json.loads(paths.result_json.read_text())
    assert loaded.settings == run.result.settings and loaded.history == run.result.history
    # the paper case's design values are half the true k1: k1 is about +100 % against them,
    # which is no change (a first event has none) and has its own key
    assert all(abs(s.k1_vs_design_pct - 100.0) < 1.0 for s in loaded.sections)
    assert all(s.k1_change_pct is None for s in loaded.sections) and loaded.k1_baseline == ""
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
    assert sorted(msgs) == ["/diagnostics", "/table1/damage_markers", "/table1/damage_state",
                            "/tf_static"]
    # the markers' frame resolves: map -> table1, identity, latched
    schema, channel, message, tf = msgs["/tf_static"]
    assert schema.name == "tf2_msgs/msg/TFMessage" and message.log_time == START_NS
    assert "transient_local" in channel.metadata.get("offered_qos_profiles", "")
    (t,) = tf.transforms
    assert (t.header.frame_id, t.child_frame_id) == ("map", "table1")
    assert (t.transform.translation.x, t.transform.translation.y,
            t.transform.translation.z) == (0.0, 0.0, 0.0)
    assert (t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z,
            t.transform.rotation.w) == (0.0, 0.0, 0.0, 1.0)
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
        assert math.isnan(got.k1_change_pct) and want.k1_change_pct is None  # first event
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
    assert lines[3] == "section 3 (4.0-6.0 m): k1 +2.5 %, DF ≤ 0.90 -> ≤ 0.95, intact -> intact"
    assert lines[-1].startswith("≤: the spring did not yield")
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


REASONS = ("section 2: c = 1.2e-09 N·m·s/rad is near zero (1e-16 of the reference 1.2e+07)",
           "level 3: the reproduced displacement departs from the measured by 80% RMS "
           "(allowed 26%)")


def test_an_unreliable_result_is_no_diagnosis_in_any_output(identified, tmp_path,
                                                            msg_typestore) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    window, run = identified
    written = write_results(run, window, tmp_path / "event", check_reasons=REASONS)
    result = written.result
    assert result.overall_state == "unreliable" and result.success and not result.reliable
    assert result.unreliable_reasons == REASONS
    assert result.message.startswith(f"unreliable: {REASONS[0]}; {REASONS[1]}")
    assert {s.state for s in result.sections} == {"unreliable"}
    assert result.sections[1].reasons == REASONS  # its own, and the one naming no section
    assert result.sections[0].reasons == REASONS[1:]
    assert load_result(tmp_path / "event") == result
    # a later baseline keeps it unreliable
    assert result.with_baseline(written.result).overall_state == "unreliable"
    with written.paths.damage_state_mcap.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        msgs = {ch.topic: decoded for _, ch, _, decoded in reader.iter_decoded_messages()}
    state = msgs[damage_state_topic("table1")]
    assert state.overall_state == 4 and state.success
    assert [s.state for s in state.sections] == [4] * 6
    assert list(state.sections[1].reasons) == list(REASONS)
    check_markers(msgs["/table1/damage_markers"], result)
    statuses = msgs["/diagnostics"].status
    assert [st.level for st in statuses] == [1] * 7  # every section and the identifier: WARN
    assert statuses[1].message.startswith(f"unreliable, no diagnosis: {REASONS[0]}")
    assert statuses[-1].message.startswith("unreliable: section 2: c = ")
    assert _png_size(written.paths.profile_png)[0] > 0


def test_compare_with_an_unreliable_result_concludes_no_change_of_state() -> None:
    a = _result("p1", "run1", [1.0e9, 0.8e9], [4.4, 1.1])
    b = _result("p1", "run2", [1e-10, 0.8e9], [0.5, 0.9]).with_check_reasons(
        ["section 1: k1 = 1e-10 N·m/rad is near zero (1e-19 of the design 1e+09)"])
    cmp = compare_results(a, b)
    assert cmp.overall_after == "unreliable"
    assert [s.state_after for s in cmp.sections] == ["unreliable", "unreliable"]
    assert not any(s.worsened for s in cmp.sections)
    lines = cmp.summary_lines()
    assert lines[0].startswith("pier p1: run1 -> run2: overall damaged -> unreliable (no "
                               "diagnosis: an unreliable identification)")
    assert lines[1].startswith("B (run2) is unreliable, no diagnosis: section 1: k1 = 1e-10")
    assert "damaged -> intact" not in "\n".join(lines)
    assert cmp.to_dict()["unreliable"] == [lines[1]]


def test_the_identify_summary_names_sensor_action_and_time() -> None:
    from pier_monitor.cli import ingest_summary
    from pier_monitor.core.ingest.findings import Finding

    t = START_NS
    findings = [Finding("glitch", "l3_wire_n", "one sample", t, t, "repaired"),
                Finding("glitch", "l3_wire_n", "one sample", t + 10**9, t + 10**9, "repaired"),
                Finding("principal_direction", "ev", "estimated", t, t + 10**9, "noted"),
                Finding("gap_excluded", "l2_wire_n", "400 missing", t, t + 2 * 10**9,
                        "excluded")] + [
        Finding("frozen", f"l1_acc_{i}.x", "flat", t, t, "excluded") for i in range(6)]
    lines = ingest_summary(findings)
    assert lines[0] == "ingest: 10 findings (all in result.json / failed.json)"
    assert lines[1] == ("  repaired  l3_wire_n: glitch (x2, first 2023-11-14T22:13:20.250Z for "
                        "0.00 s)")
    assert lines[2] == ("  excluded  l2_wire_n: gap_excluded (2023-11-14T22:13:20.250Z for "
                        "2.00 s)")
    assert lines[-1] == "  ... and 2 more" and len(lines) == 8
    assert ingest_summary(findings[2:3]) == []  # only noted: nothing to say


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


# --------------------------------------------------------------- ensemble (uncertainty)

ENSEMBLE_MEMBERS = 8


def _same(a: Any, b: Any) -> bool:
    """Equal, NaN equal to NaN."""
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


@pytest.fixture(scope="module")
def ensemble_written(identified: tuple[Any, Any], tmp_path_factory: pytest.TempPathFactory
                     ) -> tuple[Any, Any]:
    """The identified run made an ensemble: hand-made members scattered around it."""
    window, run = identified
    rng = np.random.default_rng(1)
    m, n = ENSEMBLE_MEMBERS, len(run.result.sections)
    p = run.result.params
    point = np.stack([p.k1, p.k2, p.fy, p.c], axis=-1)
    params = point[None] * (1.0 + 0.02 * rng.standard_normal((m, n, 4)))
    df = run.result.ductility_factors[None] * (1.0 + 0.05 * rng.standard_normal((m, n)))
    yielded = np.tile([s.yielded for s in run.result.sections], (m, 1))
    uncertainty = summarize_members(params, df, yielded)
    result = replace(run.result,
                     sections=tuple(replace(s, uncertainty=u)
                                    for s, u in zip(run.result.sections, uncertainty)),
                     p_overall_state=overall_state_probabilities(df, yielded))
    rep = run.reproduced
    scale = 1.0 + 0.03 * np.linspace(-1.0, 1.0, m)[:, None, None]
    members = MemberResponses(theta=rep.theta[None] * scale, moment=rep.moment[None] * scale,
                              x=rep.x[None] * scale, a=rep.a[None] * scale)
    out = tmp_path_factory.mktemp("report") / "ensemble"
    return members, write_results(replace(run, result=result), window, out, members=members)


def test_ensemble_result_json_round_trips_its_uncertainty(ensemble_written) -> None:
    _, written = ensemble_written
    result = written.result
    assert result.members == ENSEMBLE_MEMBERS and sum(result.p_overall_state) == pytest.approx(1)
    # a first event: no change and no change interval, its difference from design apart
    assert all(s.uncertainty is not None and s.k1_change_pct is None
               and s.k1_change_lo_pct is None and s.k1_vs_design_pct is not None
               for s in result.sections)
    loaded = load_result(written.paths.out_dir)
    assert json.dumps(loaded.to_dict(), sort_keys=True) == json.dumps(result.to_dict(),
                                                                      sort_keys=True)
    # dataclass equality where no spread is NaN (k2, fy of springs that yielded)
    yielded = [i for i, s in enumerate(result.sections) if s.yielded]
    assert yielded and all(loaded.sections[i] == result.sections[i] for i in yielded)


def test_ensemble_damage_state_decodes_from_the_mcap_with_only_the_msg_text(
        ensemble_written) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    _, written = ensemble_written
    result = written.result
    with written.paths.damage_state_mcap.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        ((schema, _, _, decoded),) = [m for m in reader.iter_decoded_messages()
                                      if m[0].name == DAMAGE_STATE_TYPE]
    assert b"float64 k1_lo" in schema.data and b"string[] reasons" in schema.data
    assert decoded.members == ENSEMBLE_MEMBERS
    assert (decoded.p_overall_intact, decoded.p_overall_suspicious,
            decoded.p_overall_damaged) == result.p_overall_state
    for got, want in zip(decoded.sections, result.sections):
        u = want.uncertainty
        for name in ("k1", "k2", "fy", "c", "ductility_factor"):
            spread = getattr(u, name)
            assert all(_same(getattr(got, f"{name}_{key}"), getattr(spread, key))
                       for key in ("mean", "std", "lo", "hi")), name
        assert got.p_yielded == u.p_yielded
        assert (got.p_intact, got.p_suspicious, got.p_damaged) == u.p_state
        assert all(math.isnan(v) for v in (got.k1_change_lo_pct, got.k1_change_hi_pct,
                                           got.k1_change_scatter_pct))  # no earlier event
        assert list(got.reasons) == list(want.reasons)
        assert got.state == int(want.damage_state)


def test_single_identification_fills_the_uncertainty_fields_with_nan(msg_typestore) -> None:
    fields = damage_state_fields(_result("p1", "e1", [1e9, 1e9], [1.3, 0.9]))
    assert fields["members"] == 1 and math.isnan(fields["p_overall_damaged"])
    s = fields["sections"][0]
    assert all(math.isnan(s[k]) for k in ("k1_mean", "k1_lo", "ductility_factor_hi",
                                          "p_yielded", "p_damaged", "k1_change_lo_pct"))
    assert s["reasons"] == []


def test_ensemble_message_round_trips_through_cdr_of_the_msg_text(ensemble_written,
                                                                   msg_typestore) -> None:
    from pier_monitor.report.results import damage_state_message

    _, written = ensemble_written
    msg = damage_state_message(written.result)
    cdr = msg_typestore.serialize_cdr(msg, "pier_monitor_msgs/msg/PierDamageState")
    back = msg_typestore.deserialize_cdr(cdr, "pier_monitor_msgs/msg/PierDamageState")
    fields = damage_state_fields(written.result)
    assert back.members == fields["members"] == ENSEMBLE_MEMBERS
    for got, want in zip(back.sections, fields["sections"]):
        assert all(_same(getattr(got, k), v) for k, v in want.items() if k != "reasons")
        assert list(got.reasons) == want["reasons"]


def test_ensemble_figures_draw_bars_and_bands(identified, written, ensemble_written,
                                              tmp_path) -> None:
    from matplotlib.image import imread

    _, ens = ensemble_written
    for single, banded in zip(written.paths.figures[:3], ens.paths.figures[:3]):
        assert _png_size(single) == _png_size(banded)
        assert not np.array_equal(imread(single), imread(banded)), \
            f"{banded.name}: no bars or band drawn"


def test_member_histories_of_another_shape_are_refused_before_writing(identified,
                                                                       tmp_path) -> None:
    window, run = identified
    theta = np.asarray(run.reproduced.theta)
    members = MemberResponses(theta=theta[None, :-1], moment=theta[None, :-1])
    with pytest.raises(ReportError, match=r"member histories: expected shape \(M, \d+, 6\)"):
        write_results(run, window, tmp_path / "event", members=members)
    assert not (tmp_path / "event").exists()


def test_cli_compare_prints_k1_change_intervals_and_cracking(tmp_path: Path, capsys) -> None:
    from pier_monitor.cli import main

    k1, df = normal_members(1e9, 0.01e9), normal_members(0.8, 0.03)
    no = np.zeros_like(df, dtype=bool)
    before = ensemble_result("run1", [k1, k1], [df, df], [no, no])
    after = ensemble_result("run2", [0.86 * k1, 0.995 * k1], [df, df], [no, no])
    for r in (before, after):
        (tmp_path / r.event_id).mkdir()
        r.save_json(tmp_path / r.event_id / "result.json")
    assert main(["compare", str(tmp_path / "run1"), str(tmp_path / "run2")]) == 0
    out = capsys.readouterr().out
    cmp = compare_results(before, after)
    s1, s2 = cmp.sections
    assert "90 % interval" in out
    assert (f"section 1 (0.0-2.0 m): k1 -14.0 % [{s1.k1_change_lo_pct:+.1f}, "
            f"{s1.k1_change_hi_pct:+.1f}], DF ≤ 0.80 -> ≤ 0.80, intact -> suspicious (worse): "
            f"k1 -14.0 % [{s1.k1_change_lo_pct:+.1f}, {s1.k1_change_hi_pct:+.1f}] against event "
            f"run1, beyond the identification scatter ({s1.k1_change_scatter_pct:.1f} %): "
            "cracking") in out
    assert "section 2 (2.0-4.0 m): k1 -0.5 % [" in out and s2.state_after == "intact"
    assert cmp.overall_after == "suspicious"
    doc = json.loads((tmp_path / "run2" / "compare.json").read_text())
    assert doc["sections"][0]["reasons"] == list(s1.reasons)


def test_identify_tables_print_intervals_and_state_probabilities(tmp_path: Path,
                                                                 capsys) -> None:
    from pier_monitor.cli import _print_outcome
    from pier_monitor.core.ingest.settings import IngestReport
    from pier_monitor.core.synthetic.reference import paper_case_window
    from pier_monitor.events import EventOutcome
    from pier_monitor.pipeline import BagOutcome

    window, _, _ = paper_case_window(seed=0)
    df = [normal_members(0.9 + 0.15 * i, 0.1) for i in range(window.n_levels)]
    k1 = [normal_members(1e9, 0.02e9) for _ in range(window.n_levels)]
    yielded = [yielded_members(0.2 * i) for i in range(window.n_levels)]
    result = ensemble_result(window.event_id, k1, df, yielded, pier_id=window.pier_id,
                             baseline_k1=np.full(window.n_levels, 1.05e9))
    event = EventOutcome(window=window, result=result, out_dir=tmp_path, window_file=tmp_path,
                         paths=None)
    _print_outcome(BagOutcome(bag=tmp_path, events=(event,), ingest_report=IngestReport()))
    out = capsys.readouterr().out
    assert f"uncertainty over {MEMBERS} members" in out
    assert "P(intact/susp./dam.)" in out
    for s in result.sections:
        u = s.uncertainty
        p = " / ".join(f"{v:.2f}" for v in u.p_state)
        row = next(line for line in out.splitlines()
                   if line.startswith(f"{s.index + 1:>7}  ") and p in line)
        assert (f"{u.ductility_factor.mean:.2f} [{u.ductility_factor.lo:.2f}, "
                f"{u.ductility_factor.hi:.2f}]") in row
        assert f"{u.k1.mean / 1e9:.3f} [{u.k1.lo / 1e9:.3f}, {u.k1.hi / 1e9:.3f}]" in row
        assert f"{u.p_yielded:.2f}" in row
        for reason in s.reasons:
            assert f"section {s.index + 1}: {s.state}: {reason}" in out
    assert any(s.reasons for s in result.sections)


def test_diagnostics_of_a_first_event_show_design_apart_and_an_unyielded_df_as_a_bound() -> None:
    from pier_monitor.report.diagnostics import diagnostics_fields
    from pier_monitor.report.results import k1_vs_design

    # section 1 yielded (DF 1.3), section 2 did not (DF bound 1); design k1 1.66e9: k1 of
    # 1e9 is -39.8 % against it, which is no change and no basis of the level
    first = _result("p1", "run1", [1e9, 1e9], [1.3, 1.0]).with_design_k1(np.array([1.66e9] * 2))
    assert [s.k1_vs_design_pct for s in first.sections] == pytest.approx([-39.759] * 2, abs=1e-3)
    diag = diagnostics_fields(damage_state_fields(first), START_NS,
                              k1_vs_design_pct=k1_vs_design(first))
    s1, s2, _ = diag["status"]
    v1 = {kv["key"]: kv["value"] for kv in s1["values"]}
    v2 = {kv["key"]: kv["value"] for kv in s2["values"]}
    assert (v1["ductility_factor"], v1["ductility_factor_upper_bound"]) == ("1.3", "false")
    assert (v2["ductility_factor"], v2["ductility_factor_upper_bound"]) == ("≤ 1", "true")
    assert v1["k1_change_pct"] == v2["k1_change_pct"] == "n/a"
    assert v2["k1_vs_design_pct"] == "-39.759"
    assert (s1["level"], s2["level"]) == (1, 0)  # suspicious by its DF, intact: not by design
    assert s2["message"] == ("intact: DF ≤ 1, no k1 change (no earlier event), k1 vs design "
                             "-39.8 % (event run1)")
    # a later event: the change against the first one, the design values still apart
    second = _result("p1", "run2", [0.9e9, 1e9], [1.3, 1.0]).with_design_k1(
        np.array([1.66e9] * 2)).with_baseline(first)
    diag = diagnostics_fields(damage_state_fields(second), START_NS,
                              k1_vs_design_pct=k1_vs_design(second))
    v1 = {kv["key"]: kv["value"] for kv in diag["status"][0]["values"]}
    assert v1["k1_change_pct"] == "-10" and v1["k1_vs_design_pct"] == "-45.7831"
    assert "k1 change -10 %" in diag["status"][0]["message"]


def test_uncertainty_table_marks_the_df_bound_and_a_first_event_has_no_change() -> None:
    k1 = normal_members(1e9, 0.01e9)
    df = normal_members(0.8, 0.03)
    no = np.zeros_like(df, dtype=bool)
    first = ensemble_result("run1", [k1], [df], [no]).with_design_k1(np.array([1.25e9]))
    from pier_monitor.report.tables import uncertainty_table

    row = uncertainty_table(first).splitlines()[3]
    assert "≤ 0.80 [" in row  # the members' DF of a spring that did not yield: a bound
    assert row.split()[-2:] == ["-", "-20.0"]  # no k1 change; -20 % against design


def test_ingest_goes_warn_then_stale_when_every_channel_is_silent() -> None:
    from pier_monitor.report.diagnostics import LEVEL_STALE, LEVEL_WARN, ingest_silence

    # one channel of three alive (1 s old): no silence status
    assert ingest_silence(3, [1.0, 40.0, 50.0], alive_timeout_s=2.0, stale_timeout_s=30.0) is None
    # every channel silent past the alive timeout: WARN, for the newest message's age
    assert ingest_silence(3, [5.0, 40.0, 50.0], 2.0, 30.0) == (
        LEVEL_WARN, "every channel silent for 5.0 s (0 of 3 channels alive)")
    # past the stale timeout: STALE
    level, message = ingest_silence(3, [31.0, 40.0, 50.0], 2.0, 30.0)
    assert level == LEVEL_STALE and message.startswith("stale: every channel silent for 31.0 s")
    # nothing received yet: WARN, waiting; no channels (no configuration): nothing to say
    assert ingest_silence(2, [], 2.0, 30.0) == (
        LEVEL_WARN, "no data yet: none of the 2 channels has sent a message")
    assert ingest_silence(0, [], 2.0, 30.0) is None


def test_pier_transforms_hang_every_pier_frame_from_the_parent() -> None:
    from pier_monitor.report.markers import pier_transform_fields

    fields = pier_transform_fields(["p1", "p2"], {"sec": 3, "nanosec": 4}, parent_frame="site")
    assert [(t["header"]["frame_id"], t["child_frame_id"]) for t in fields["transforms"]] == [
        ("site", "p1"), ("site", "p2")]
    assert fields["transforms"][1]["header"]["stamp"] == {"sec": 3, "nanosec": 4}
    assert fields["transforms"][0]["transform"]["rotation"]["w"] == 1.0
    with pytest.raises(ValueError, match=r"parent_frame: expected a frame other than the "
                                         r"piers' \['p1'\], got 'p1'"):
        pier_transform_fields(["p1"], {"sec": 0, "nanosec": 0}, parent_frame="p1")
