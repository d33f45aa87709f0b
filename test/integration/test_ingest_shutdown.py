"""The ingest node finalises a pending event when it shuts down: a bag that ends during the
shaking, after its strong motion, gives the partial window that ``ingest_recording`` gives."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ros_helpers import REPO_ROOT, RUN_SCRIPT, interrupt, params_file, start_node

pytestmark = [pytest.mark.ros, pytest.mark.timeout(170)]


@pytest.fixture(scope="module")
def truncated_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A one-run bag (40 s table record, 8 s of strong motion) that ends 15 s after the peak
    table acceleration, 7 s into the decay of the shaking."""
    from pier_monitor.bags import write_bag
    from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord
    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.core.synthetic.shaking_table import edefense_scenario, generate_recording

    config = load_config(find_config_file("edefense_like.yaml"))
    synthetic = generate_recording(config, edefense_scenario(record_s=40.0, lead_s=12.0),
                                   seed=1)
    run = synthetic.truth.runs[0]
    peak = int(np.argmax(np.abs(run.response.ag)))
    end_ns = run.start_ns + int(round(peak * NS_PER_S / config.sample_rate_hz)) + 15 * NS_PER_S
    sensors = {}
    for sid, s in synthetic.recording.sensors.items():
        keep = s.time_ns < end_ns
        sensors[sid] = SensorRecord(sid, s.time_ns[keep], s.data[keep], s.rate_hz,
                                    s.sample_index[keep])
    path = tmp_path_factory.mktemp("truncated") / "truncated.mcap"
    write_bag(Recording(config, sensors, source="truncated"), path, block_s=0.5)
    return path


def test_an_event_the_bag_ends_in_is_a_partial_window_at_shutdown(truncated_bag, spawn_python,
                                                                  tmp_path):
    from pier_monitor.bags import read_bag
    from pier_monitor.core.ingest import ingest_recording
    from pier_monitor.core.ingest.window import load_window

    windows, report = ingest_recording(read_bag(truncated_bag))
    assert [o.status for o in report.outcomes] == ["partial"]
    ingest = start_node(spawn_python, "ingest_node", params_file(tmp_path / "p.yaml", tmp_path))
    player = spawn_python(RUN_SCRIPT, str(REPO_ROOT / "launch_free_scripts/replay_bag.py"),
                          str(truncated_bag), "--rate", "8")
    player.wait_for_line("SENT", 90)
    assert player.stop() == 0
    assert interrupt(ingest, timeout_s=60.0) == 0
    log = "\n".join(ingest.read_rest())
    assert f"event {windows[0].event_id}: partial window: the data end at" in log
    (saved,) = (tmp_path / "windows").glob("*.npz")
    live = load_window(saved)
    assert live.partial == windows[0].partial == report.outcomes[0].partial
    for key in ("t", "ag", "a", "v", "x"):
        np.testing.assert_array_equal(getattr(live, key), getattr(windows[0], key))
