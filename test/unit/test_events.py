"""identify_window: the one per-event step, its failure record and its stop signal."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from pier_monitor.core.synthetic.reference import paper_case_window
from pier_monitor.events import TrainingStopped, identify_window
from pier_monitor.core.identify.methods import IdentifySettings, PinnSettings
from pier_monitor.store import ResultsStore


@pytest.fixture(scope="module")
def window():
    w, _, _ = paper_case_window(moments_measured=True, seed=1)
    return replace(w, start_time_ns=1_700_000_000 * 10 ** 9)


def test_a_failed_training_is_recorded_and_returned_not_raised(window, tmp_path) -> None:
    store = ResultsStore(tmp_path)
    outcome = identify_window(window, IdentifySettings(device="cpu", pinn_settings=PinnSettings(max_epochs=0)), store)
    result = outcome.result
    assert not result.success and outcome.paths is None
    assert result.message.startswith("identification failed: InputDataError: identification setting "
                                     "max_epochs")
    assert result.overall_state == "unknown" and math.isnan(result.sections[0].k1)
    (recorded,) = store.failures()  # NaN parameters: compare what is not NaN
    assert store.is_done(window.event_id)
    assert (recorded.event_id, recorded.message, recorded.window_start_ns) == (
        window.event_id, result.message, window.start_time_ns)
    assert outcome.window_file == tmp_path / window.event_id / "window.npz"
    assert store.pending().windows == ()  # done: a restart does not train it again


def test_a_training_stopped_from_the_callback_leaves_the_window_pending(window,
                                                                       tmp_path) -> None:
    store = ResultsStore(tmp_path)

    def stop(progress) -> None:
        raise TrainingStopped()

    with pytest.raises(TrainingStopped):
        identify_window(window, IdentifySettings(method="pinn", device="cpu"), store,
                        progress=stop)
    assert not store.is_done(window.event_id)
    assert store.pending().windows == (window,)  # stored before training, every field
