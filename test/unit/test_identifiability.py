"""Identifiability in the open: a quantity whose 90 % interval is wider than its limit is
"poorly identified", shown with its interval in every output, and never changes a state.

Hand-made members with a known spread (test/ensemble_helpers.py) go through the one
assembly rule (:func:`~pier_monitor.core.identify.damage.with_identifiability`), the
result file, the printed table and the /diagnostics key-values.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from ensemble_helpers import MEMBERS, ensemble_result, normal_members
from pier_monitor.core.identify.damage import (IDENTIFIABILITY_LIMITS, NO_INTERVAL,
                                               IdentificationResult, with_identifiability)
from pier_monitor.report.diagnostics import diagnostics_fields
from pier_monitor.report.results import damage_state_fields
from pier_monitor.report.tables import uncertainty_table

K1 = 1.0e9  # N·m/rad
ALL = np.ones(MEMBERS, dtype=bool)


def _flagged(result: IdentificationResult) -> IdentificationResult:
    return replace(result, sections=with_identifiability(result.sections))


def _wide_and_narrow() -> tuple[IdentificationResult, IdentificationResult]:
    """Section 1: k1 members N(K1, (0.1 K1)²), a 90 % half-width of 16 %; section 2: 2 %
    (3.3 %); both DF N(1.3, 0.02²), every member yielded."""
    df = normal_members(1.3, 0.02)
    plain = ensemble_result("e1", [normal_members(K1, 0.1 * K1), normal_members(K1, 0.02 * K1)],
                            [df, df], [ALL, ALL])
    return plain, _flagged(plain)


def test_a_k1_interval_wider_than_10_percent_is_poorly_identified_and_keeps_its_state() -> None:
    plain, result = _wide_and_narrow()
    wide, narrow = result.sections
    assert wide.uncertainty.k1.relative_half_width() == pytest.approx(1.645 * 0.1, rel=0.03)
    assert narrow.uncertainty.k1.relative_half_width() == pytest.approx(1.645 * 0.02, rel=0.03)
    assert wide.poorly_identified == ("k1",)  # k2 = k1/10: 16 % < 30 %; fy, c exact
    assert narrow.poorly_identified == ()
    # the flag decides nothing: every other field as before
    assert [replace(s, poorly_identified=()) for s in result.sections] == list(plain.sections)
    assert [s.state for s in result.sections] == ["suspicious", "suspicious"]


def test_a_df_interval_wider_than_30_percent_is_flagged_and_the_state_is_unchanged() -> None:
    df_wide = normal_members(1.3, 0.3)  # 90 % half-width 0.49 / 1.3 = 38 %
    plain = ensemble_result("e1", [normal_members(K1, 0.01 * K1)], [df_wide], [ALL])
    (section,) = _flagged(plain).sections
    assert section.uncertainty.ductility_factor.relative_half_width() > IDENTIFIABILITY_LIMITS["DF"]
    assert section.poorly_identified == ("DF",)
    assert (section.state, section.reasons) == (plain.sections[0].state, plain.sections[0].reasons)


def test_k2_and_fy_are_judged_only_where_the_section_yielded() -> None:
    # reported not yielded (most members did not): k2 and fy are no numbers, not flagged,
    # whatever the few yielded members say
    few = np.zeros(MEMBERS, dtype=bool)
    few[:1] = True  # one yielded member: an interval of one value
    plain = ensemble_result("e1", [normal_members(K1, 0.01 * K1)],
                            [np.minimum(normal_members(0.9, 0.01), 1.0)], [few])
    (section,) = _flagged(plain).sections
    assert not section.yielded and section.poorly_identified == ()


def test_a_single_identification_flags_nothing_and_says_it_has_no_interval(tmp_path: Path
                                                                           ) -> None:
    single = _flagged(ensemble_result("e1", [np.full(1, K1)], [np.full(1, 1.3)],
                                      [np.ones(1, bool)]))
    assert single.members == 1 and single.sections[0].poorly_identified == ()
    assert single.intervals == NO_INTERVAL == "no interval (1 member)"
    assert uncertainty_table(single) == "intervals: no interval (1 member)"
    values = _diagnostic_values(single, 0)
    assert values["poorly_identified"] == "no interval (1 member)"
    doc = single.to_dict()
    assert doc["intervals"] == "no interval (1 member)"
    assert doc["sections"][0]["poorly_identified"] == []


def _diagnostic_values(result: IdentificationResult, section: int) -> dict[str, str]:
    diag = diagnostics_fields(damage_state_fields(result), 0,
                              poorly_identified=[s.poorly_identified for s in result.sections])
    return {kv["key"]: kv["value"] for kv in diag["status"][section]["values"]}


def test_the_flag_is_shown_with_its_interval_in_the_table_and_the_diagnostics() -> None:
    _, result = _wide_and_narrow()
    table = uncertainty_table(result)
    lo, hi = result.sections[0].uncertainty.k1.lo, result.sections[0].uncertainty.k1.hi
    assert "section 1: * poorly identified" in table
    assert f"k1 [{lo:.3g}, {hi:.3g}] ±16 %" in table
    assert "section 2: * poorly identified" not in table
    row1 = table.splitlines()[3]
    assert row1.split()[0] == "1" and "]*" in row1  # the k1 cell marked
    wide, narrow = _diagnostic_values(result, 0), _diagnostic_values(result, 1)
    assert wide["poorly_identified"] == f"k1 [{lo:.6g}, {hi:.6g}] ±16 %"
    assert narrow["poorly_identified"] == "none"
    diag = diagnostics_fields(damage_state_fields(result), 0,
                              poorly_identified=[s.poorly_identified for s in result.sections])
    assert diag["status"][0]["message"].endswith("; poorly identified: k1")
    # without the flags given, the key is left out (as before)
    plain = diagnostics_fields(damage_state_fields(result), 0)
    assert "poorly_identified" not in {kv["key"] for kv in plain["status"][0]["values"]}


def test_the_flags_round_trip_through_result_json(tmp_path: Path) -> None:
    _, result = _wide_and_narrow()
    loaded = IdentificationResult.load_json(result.save_json(tmp_path / "result.json"))
    assert loaded == result
    assert loaded.sections[0].poorly_identified == ("k1",)
    assert isinstance(loaded.sections[0].poorly_identified, tuple)
    assert loaded.intervals == f"90 % interval over {MEMBERS} members"
    # a file written before the flag existed loads with none
    doc = result.to_dict()
    for s in doc["sections"]:
        del s["poorly_identified"]
    del doc["intervals"]
    assert IdentificationResult.from_dict(doc).sections[0].poorly_identified == ()


def test_k1_and_c_of_a_section_with_an_unmeasured_end_are_poorly_identified() -> None:
    """Levels 1 and 3 unmeasured (the 'sparse' field layout): every section has an
    unmeasured end but the one between two measured levels; narrow intervals do not help
    (the stiffness and the damping of such sections trade off with their neighbours').
    The sections yielded (DF about 1.3 in every member): their DF is poorly identified
    there too."""
    df = normal_members(1.3, 0.02)
    narrow = normal_members(K1, 0.01 * K1)
    plain = _flagged(ensemble_result("e1", [narrow] * 4, [df] * 4, [ALL] * 4))
    assert [s.poorly_identified for s in plain.sections] == [()] * 4
    measured = np.array([False, True, False, True])
    sections = with_identifiability(plain.sections, measured)
    assert [s.poorly_identified for s in sections] == [("k1", "c", "DF")] * 4
    measured = np.array([True, True, False, True])
    sections = with_identifiability(plain.sections, measured)
    assert [s.poorly_identified for s in sections] == [(), (), ("k1", "c", "DF"),
                                                       ("k1", "c", "DF")]
    assert [s.state for s in sections] == [s.state for s in plain.sections]
