"""Every pier of a network: a synthetic fleet on a local process pool and on a local Ray
instance gives what ``identify`` gives bag by bag; killed workers are retried, reruns do
nothing, and the fleet summary ranks the piers (SPEC §8).

The fleet is four small piers (2-4 sections, 12 s records; one of them shaken twice) and
the training is tiny: the results must equal sequential identification with the same
settings, not the truth.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from pier_monitor.bags.synthetic_fleet import write_synthetic_fleet
from pier_monitor.cli import main
from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.events import TrainingStopped
from pier_monitor.fleet import (FleetOptions, KillOnce, LocalPool, RayBackend, identify_offloaded,
                                run_fleet)
from pier_monitor.fleet.tasks import IngestTask, ingest_bag
from pier_monitor.core.identify.methods import IdentifySettings, PinnSettings
from pier_monitor.core.ingest import IngestSettings
from pier_monitor.pipeline import identify_bag
from pier_monitor.report.fleet import STATE_RANK
from pier_monitor.store import WINDOW_NPZ, ResultsStore

pytestmark = pytest.mark.timeout(400)

TINY = IdentifySettings(method="pinn", device="cpu", seed=0,
                        pinn_settings=PinnSettings(max_epochs=12, min_epochs=1))


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("fleet") / "bags"
    written = write_synthetic_fleet(out, 4, seed=0, fmt="mixed", record_s=12.0, lead_s=8.0,
                                    gap_s=14.0, tail_s=10.0, sections=(2, 4))
    assert [len(w.truth.runs) for w in written] == [2, 1, 1, 1]
    return out


@pytest.fixture(scope="module")
def sequential(fleet_dir: Path, tmp_path_factory: pytest.TempPathFactory
               ) -> dict[str, IdentificationResult]:
    """``identify`` on each bag, one after another, with the fleet's settings."""
    out = tmp_path_factory.mktemp("sequential")
    results = {}
    for bag in sorted(p for p in fleet_dir.iterdir() if p.suffix == ".mcap" or p.is_dir()):
        outcome = identify_bag(bag, out / bag.name, settings=TINY)
        results.update({ev.result.event_id: ev.result for ev in outcome.events})
    assert len(results) == 5
    return results


def assert_same_results(got: dict[str, IdentificationResult],
                        want: dict[str, IdentificationResult]) -> None:
    assert sorted(got) == sorted(want)
    for event_id, w in want.items():
        g = got[event_id]
        assert g.success and g.epochs == w.epochs and g.k1_baseline == w.k1_baseline, event_id
        assert [s.state for s in g.sections] == [s.state for s in w.sections]
        for key in ("k1", "k2", "fy", "c", "ductility_factor", "k1_change_pct",
                    "k1_vs_design_pct"):
            # None: no change (a first event); equal as NaN
            values = [[np.nan if getattr(s, key) is None else getattr(s, key)
                       for s in r.sections] for r in (g, w)]
            np.testing.assert_allclose(*values, rtol=1e-9, err_msg=f"{event_id} {key}")


def stored(out: Path) -> dict[str, IdentificationResult]:
    """Every result.json under a results root, by event id (one per event directory)."""
    found = {}
    for path in sorted(out.glob("*/result.json")):
        result = IdentificationResult.load_json(path)
        assert result.event_id not in found
        found[result.event_id] = result
    return found


def test_local_pool_equals_sequential_identify_and_retries_a_killed_worker(
        fleet_dir, sequential, tmp_path):
    out = tmp_path / "results"
    victim = min(e for e in sequential if e.startswith("pier_002"))
    options = FleetOptions(settings=TINY, figures=False,
                           fault=KillOnce(victim, tmp_path / "killed"))
    backend = LocalPool(2)
    try:
        run = run_fleet([fleet_dir], out, backend, options)
    finally:
        backend.close()
    assert (tmp_path / "killed").exists()  # the first attempt at the victim did die
    assert run.retried >= 1 and run.failed == 0 and run.identified == 5
    assert_same_results(run.results, sequential)
    assert_same_results(stored(out), sequential)
    assert not list(out.rglob(".*.tmp"))  # no half-written file left by the killed worker

    # the summary: ranked by state, then by the largest DF; k1 change against the previous event
    doc = json.loads((out / "fleet.json").read_text())
    piers = doc["piers"]
    assert [p["pier_id"] for p in piers] == [r.pier_id for r in run.summary.rows]
    keys = [(STATE_RANK[p["state"]], -p["max_ductility_factor"]) for p in piers]
    assert keys == sorted(keys)
    twice = next(p for p in piers if p["events"] == 2)
    first, second = sorted((r for r in sequential.values() if r.pier_id == twice["pier_id"]),
                           key=lambda r: r.window_start_ns)
    assert twice["event_id"] == second.event_id and twice["previous_event_id"] == first.event_id
    np.testing.assert_allclose(twice["k1_change_vs_previous_pct"],
                               100 * (second.params.k1 / first.params.k1 - 1), rtol=1e-9)
    assert doc["run"]["identified"] == 5 and (out / "fleet.png").stat().st_size > 5000

    # fleet_state.mcap: one PierDamageState (and one MarkerArray) per pier, its latest event
    with (out / "fleet_state.mcap").open("rb") as stream:
        msgs = [(c.topic, m) for _, c, _, m in make_reader(
            stream, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    states = {m.pier_id: m for t, m in msgs if t.endswith("/damage_state")}
    assert sorted(states) == sorted(p["pier_id"] for p in piers)
    assert sum(t.endswith("/damage_markers") for t, _ in msgs) == 4
    for p in piers:
        assert states[p["pier_id"]].event_id == p["event_id"]
        assert [s.ductility_factor for s in states[p["pier_id"]].sections] == pytest.approx(
            [s["ductility_factor"] for s in p["sections"]], rel=1e-12)

    # a rerun does nothing: no bag read, no event trained, no file rewritten
    mtimes = {p: p.stat().st_mtime_ns for p in out.glob("*/*")}
    backend = LocalPool(2)
    try:
        again = run_fleet([fleet_dir], out, backend, options)
    finally:
        backend.close()
    assert (again.identified, again.failed, again.skipped) == (0, 0, 5)
    assert {p: p.stat().st_mtime_ns for p in out.glob("*/*")} == mtimes


def test_ray_equals_sequential_retries_a_killed_task_once_and_reruns_nothing(
        fleet_dir, sequential, tmp_path):
    out = tmp_path / "results"
    victim = min(e for e in sequential if e.startswith("pier_000"))  # its pier has two events
    options = FleetOptions(settings=TINY, figures=False,
                           fault=KillOnce(victim, tmp_path / "killed"))
    backend = RayBackend(num_cpus=2)
    try:
        assert backend.cpus == 2
        run = run_fleet([fleet_dir], out, backend, options)
        assert (tmp_path / "killed").exists()
        assert (run.identified, run.failed, run.skipped) == (5, 0, 0)
        assert_same_results(run.results, sequential)
        assert_same_results(stored(out), sequential)  # the victim's result exactly once
        assert len(list((out / victim).glob("result.json"))) == 1

        again = run_fleet([fleet_dir], out, backend, options)
        assert (again.identified, again.failed, again.skipped) == (0, 0, 5)
        forced = run_fleet([fleet_dir / "pier_001"], out, backend,
                           FleetOptions(settings=TINY, figures=False, force=True))
        assert (forced.identified, forced.skipped) == (1, 0)
        assert_same_results(forced.results, {k: v for k, v in sequential.items()
                                             if k.startswith("pier_001")})
    finally:
        backend.close()


def test_one_window_offloaded_to_ray_equals_sequential_and_stops_when_asked(
        fleet_dir, sequential, tmp_path):
    """The identifier node's Ray path: one window as the fleet's task, waited for."""
    (window,) = ingest_bag(IngestTask(fleet_dir / "pier_001")).windows
    backend = RayBackend(num_cpus=1)
    try:
        store = ResultsStore(tmp_path / "results")
        result = identify_offloaded(backend, window, TINY, store, figures=False)
        assert_same_results({result.event_id: result}, {window.event_id:
                                                        sequential[window.event_id]})
        assert store.is_done(window.event_id)
        assert_same_results(stored(store.root), {window.event_id: sequential[window.event_id]})

        stopping = ResultsStore(tmp_path / "stopping")
        with pytest.raises(TrainingStopped):
            identify_offloaded(backend, window, TINY, stopping, figures=False,
                               stopped=lambda: True)
        assert (stopping.root / window.event_id / WINDOW_NPZ).is_file()  # kept for a restart
    finally:
        backend.close()


def test_failed_events_and_unreadable_bags_are_recorded_and_the_fleet_goes_on(
        fleet_dir, tmp_path, capsys):
    bags = tmp_path / "bags"
    bags.mkdir()
    (bags / "broken.mcap").write_bytes(b"not an mcap file")
    (bags / "pier_001").symlink_to(fleet_dir / "pier_001")
    out = tmp_path / "results"
    # a PINN on cuda, on a machine without a GPU (the CI's): the training fails, a failure
    # record results
    rc = main(["fleet", str(bags), "--out", str(out), "--workers", "1", "--method", "pinn",
               "--device", "cuda",
               "--max-epochs", "5", "--no-figures", "--no-progress"])
    text = capsys.readouterr().out
    assert rc == 1
    assert "broken.mcap" in text and "0 events identified, 1 failed" in text
    doc = json.loads((out / "fleet.json").read_text())
    assert doc["run"]["failed_bags"][0]["bag"].endswith("broken.mcap")
    (failed,) = doc["failed_events"]
    assert failed["pier_id"] == "pier_001" and "cuda" in failed["message"]
    assert doc["piers"][0]["state"] == "unknown" and math.isnan(
        IdentificationResult.load_json(out / failed["event_id"] / "failed.json").final_loss)


def test_an_event_without_a_window_gets_failed_json_in_a_fleet_as_in_identify(tmp_path):
    """The data end 1 s after pier_000's second run: with no partial window allowed, the
    ingest cuts that event.  ``identify`` and the fleet read the bag the same way
    (``read_bag_events``) and both write the cut event's ``failed.json``, the same record."""
    (written,) = write_synthetic_fleet(tmp_path / "bags", 1, seed=0, fmt="mcap", record_s=12.0,
                                       lead_s=8.0, gap_s=14.0, tail_s=1.0, sections=(2, 4))
    assert len(written.truth.runs) == 2
    no_partial = IngestSettings(partial_after_peak_s=1e6)
    offline = identify_bag(written.bag.path, tmp_path / "identify", settings=TINY,
                           ingest_settings=no_partial, figures=False)
    assert [ev.status for ev in offline.events] == ["identified", "cut"]
    cut_id = offline.events[1].result.event_id

    out = tmp_path / "fleet"
    options = FleetOptions(settings=TINY, ingest_settings=no_partial, figures=False)
    backend = LocalPool(1)
    try:
        run = run_fleet([tmp_path / "bags"], out, backend, options)
        assert (run.identified, run.failed, run.skipped) == (1, 1, 0)
        assert not run.results[cut_id].success
        assert "is cut: the data end at" in run.results[cut_id].message
        assert_same_results({k: v for k, v in run.results.items() if k != cut_id},
                            {offline.events[0].result.event_id: offline.events[0].result})
        # the cut event's failure record: written, the same as identify's, no window stored
        fleet_doc = json.loads((out / cut_id / "failed.json").read_text())
        offline_doc = json.loads((tmp_path / "identify" / cut_id / "failed.json").read_text())
        assert fleet_doc == offline_doc and fleet_doc["message"].startswith("ingest: event ")
        assert not (out / cut_id / "window.npz").exists()
        assert [f["event_id"] for f in json.loads((out / "fleet.json").read_text())
                ["failed_events"]] == [cut_id]
        # a rerun does nothing: both events are done (the bag's record lists the cut one too)
        again = run_fleet([tmp_path / "bags"], out, backend, options)
        assert (again.identified, again.failed, again.skipped) == (0, 0, 2)
    finally:
        backend.close()
