"""End to end: synthetic bag → ingest → PINN → results, and the command line around it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pier_monitor.bags import read_bag, write_bag
from pier_monitor.bags.synthetic_bag import write_synthetic_edefense_bag
from pier_monitor.cli import main
from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.errors import BagError, ReportError
from pier_monitor.core.ingest.recording import Recording
from pier_monitor.core.ingest.window import load_window
from pier_monitor.core.identify.methods import IdentifySettings, PinnSettings
from pier_monitor.pipeline import identify_bag


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    out = tmp_path_factory.mktemp("pipeline") / "edefense.mcap"
    return write_synthetic_edefense_bag(out, fmt="mcap", seed=3)


@pytest.fixture(scope="module")
def identified(bag, tmp_path_factory):
    out = tmp_path_factory.mktemp("results")
    # short: the start is already close
    settings = IdentifySettings(pinn_settings=PinnSettings(max_epochs=150, min_epochs=50))
    return identify_bag(bag.bag.path, out, settings=settings), out


def test_second_run_shows_the_larger_stiffness_loss_where_the_truth_has_it(bag, identified):
    outcome, _ = identified
    truth = bag.truth.runs
    assert len(outcome.events) == 2
    r1, r2 = (ev.result for ev in outcome.events)
    est_change = 100 * (r2.params.k1 / r1.params.k1 - 1)
    true_change = 100 * (truth[1].params.k1 / truth[0].params.k1 - 1)
    # direction and ranking: the sections weakened in the truth lose the most stiffness
    damaged = np.argsort(true_change)[:2]
    intact = np.argsort(true_change)[2:]
    assert set(np.argsort(est_change)[:2]) == set(damaged)
    np.testing.assert_allclose(est_change, true_change, atol=2.0)  # percentage points
    assert np.all(est_change[damaged] < -10) and np.all(np.abs(est_change[intact]) < 3)
    # ductility: run 2 drives sections 1-2 far into yield
    df1, df2 = r1.ductility_factors, r2.ductility_factors
    assert np.all(df2[damaged] > df1[damaged])
    # the event's own DF (its own springs' yield rotation) is run 2's true DF; the DF that
    # decides is the cumulative one: the peak so far over run 1's (virgin) yield rotation
    # where run 1 yielded (section 1), else over run 2's fy on run 1's k1 (section 2, whose
    # bilinear springs in this bag also lost 22 % of their strength in run 2)
    own = np.array([s.event_ductility_factor for s in r2.sections])
    np.testing.assert_allclose(own[damaged], truth[1].ductility_factors[damaged], rtol=0.02)
    p1, p2 = truth[0].params, truth[1].params
    peak_so_far = np.maximum(truth[1].ductility_factors * p2.yield_angles,
                             truth[0].ductility_factors * p1.yield_angles)
    reference = np.where(truth[0].ductility_factors > 1.0, p1.yield_angles, p2.fy / p1.k1)
    np.testing.assert_allclose(df2[damaged], (peak_so_far / reference)[damaged], rtol=0.03)
    assert r1.sections[0].yielded and not r1.sections[1].yielded
    assert [s.state for s in r2.sections][:2] == ["damaged", "damaged"]
    # the second event's k1 change is relative to the first event
    assert r2.sections[0].k1_change_pct == pytest.approx(est_change[0], abs=1e-6)


def test_every_event_leaves_its_window_results_and_figures(identified):
    outcome, out = identified
    for ev in outcome.events:
        window = load_window(ev.window_file)
        np.testing.assert_array_equal(window.x, ev.window.x)
        result = IdentificationResult.load_json(ev.out_dir / "result.json")
        # as text: a method that does not train has no loss (NaN, which equals nothing)
        assert (json.dumps(result.to_dict(), sort_keys=True)
                == json.dumps(ev.result.to_dict(), sort_keys=True))
        for name in ("damage_state.mcap", "profile.png", "hysteresis.png", "responses.png",
                     "training.png"):
            assert (ev.out_dir / name).stat().st_size > 1000, name


def test_bag_without_sensor_samples_is_a_clear_error(bag, tmp_path):
    rec = read_bag(bag.bag.path)
    empty = Recording(rec.config, {}, source="empty")
    with pytest.raises(BagError, match="no samples"):
        write_bag(empty, tmp_path / "empty.mcap")


def test_unwritable_output_directory_names_it(bag, tmp_path):
    blocked = tmp_path / "file"
    blocked.write_text("not a directory")
    with pytest.raises(ReportError, match="file"):
        identify_bag(bag.bag.path, blocked / "results")


def test_command_line_identify_and_compare(bag, tmp_path, capsys):
    out = tmp_path / "cli"
    rc = main(["identify", str(bag.bag.path), "--out", str(out), "--max-epochs", "60",
               "--no-progress"])
    text = capsys.readouterr().out
    assert rc == 0
    assert text.count("overall state") == 2 and "k1 change" in text
    # a fully measured bag: the equation-error route, its 90 % intervals by default
    # (methods.DEFAULT_MEMBERS: 16 members)
    assert text.count("uncertainty over 16 members") == 2
    assert "no interval" not in text
    events = sorted(p for p in out.iterdir() if p.is_dir())
    rc = main(["compare", str(events[0]), str(events[1]), "--out", str(tmp_path / "cmp")])
    text = capsys.readouterr().out
    assert rc == 0 and "section 1 (0.0-2.0 m): k1 -" in text
    doc = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    assert len(doc["sections"]) == 4


def test_command_line_reports_a_missing_bag(tmp_path, capsys):
    rc = main(["identify", str(tmp_path / "nope.mcap"), "--out", str(tmp_path / "o")])
    assert rc == 2
    assert "nope.mcap: no such bag" in capsys.readouterr().err


def test_bag_without_configuration_needs_one_given(bag, tmp_path, capsys):
    """A bag recorded without its configuration: a clear error, and it reads with --pier."""
    from pier_monitor.bags.writer import _messages, write_mcap_messages

    rec = read_bag(bag.bag.path)
    conns, msgs = _messages(rec, 0.1)
    keep = [i for i, (topic, _, _) in enumerate(conns) if not topic.endswith("pier_configuration")]
    remap = {old: new for new, old in enumerate(keep)}
    bare = tmp_path / "bare.mcap"
    write_mcap_messages(bare, [conns[i] for i in keep],
                        [(t, remap[c], d) for t, c, d in msgs if c in remap])
    with pytest.raises(BagError, match="bare.mcap: no pier configuration in the bag.*--pier"):
        read_bag(bare)
    cfg_file = tmp_path / "pier.yaml"
    cfg_file.write_text(rec.config.to_yaml())
    rc = main(["identify", str(bare), "--pier", str(cfg_file), "--out", str(tmp_path / "o"),
               "--max-epochs", "30", "--no-progress", "--members", "1"])
    assert rc == 0
    text = capsys.readouterr().out
    assert text.count("overall state") == 2
    assert text.count("intervals: no interval (1 member)") == 2
