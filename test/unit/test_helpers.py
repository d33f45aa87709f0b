"""The core's one-of-a-kind helpers: time stamps and atomic writes."""

from __future__ import annotations

import pytest

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import atomic_path
from pier_monitor.core.ingest.recording import ns_to_stamp, stamp_to_ns


@pytest.mark.parametrize("t_ns, stamp", [
    (0, (0, 0)),
    (1_710_205_227_180_000_001, (1_710_205_227, 180_000_001)),
    (-5_000_000_001, (-6, 999_999_999)),  # before the epoch: nanosec stays in [0, 1e9)
    (2 ** 31 * 10 ** 9 - 1, (2 ** 31 - 1, 999_999_999)),
])
def test_stamps_split_and_join_exactly(t_ns: int, stamp: tuple[int, int]) -> None:
    assert ns_to_stamp(t_ns) == stamp
    assert stamp_to_ns(*stamp) == t_ns


def test_a_time_beyond_int32_seconds_is_refused() -> None:
    with pytest.raises(InputDataError, match=r"time 2147483648000000000 ns does not fit"):
        ns_to_stamp(2 ** 31 * 10 ** 9)


def test_atomic_path_replaces_on_success_and_keeps_the_old_file_on_error(tmp_path) -> None:
    path = tmp_path / "result.json"
    with atomic_path(path) as tmp:
        tmp.write_text("first")
    assert path.read_text() == "first"
    with pytest.raises(RuntimeError, match="interrupted"):
        with atomic_path(path) as tmp:
            tmp.write_text("half of the sec")
            raise RuntimeError("interrupted")
    assert path.read_text() == "first"
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]  # no temporary left
