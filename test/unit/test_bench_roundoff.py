"""The round-off suite's counts (``bench --suite rc_sequence_roundoff``): sections of the
same events identified twice, matched by seed, pier, layout and event."""
from __future__ import annotations

from pier_monitor.bench import roundoff_counts


def _event(seed: int, event: int, df: list[float], states: list[str],
           true_df: list[float]) -> dict:
    return {"seed": seed, "pier": "table1", "layout": "accel", "event": event, "df": df,
            "states": states, "true_df": true_df}


def test_roundoff_counts_states_and_dfs_that_moved():
    true_df = [3.16, 1.42, 0.70]
    plain = [_event(643, 2, [3.19, 1.00, 0.98], ["damaged", "suspicious", "suspicious"],
                    true_df),
             _event(643, 1, [1.30, 0.90, 0.50], ["suspicious", "intact", "intact"],
                    [1.30, 0.90, 0.50]),
             {"case": "summary", "seed": 643, "pier": "table1", "layout": "accel"}]
    moved = [_event(643, 2, [0.23, 1.06, 1.00], ["suspicious", "suspicious", "suspicious"],
                    true_df),
             _event(643, 1, [1.30, 0.90, 0.50], ["suspicious", "intact", "intact"],
                    [1.30, 0.90, 0.50]),
             _event(644, 1, [9.0, 9.0, 9.0], ["damaged"] * 3, [1.0, 1.0, 1.0])]  # no pair
    g = roundoff_counts(plain, moved)["table1/accel"]
    # event 2: the base's state and DF (by 2.96, beyond 15 % of 3.16); section 2's DF by
    # 0.06 (under 5 % of 1.42); section 3's by 0.02 (under 5 % of 1); event 1 unchanged
    assert g == {"sections": 6, "state_changed": 1, "df_moved_5pct": 1, "yielded": 3,
                 "yielded_df_moved_15pct": 1}
