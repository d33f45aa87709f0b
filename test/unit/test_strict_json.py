"""Every JSON file the package writes is strict JSON (RFC 8259): no bare NaN or Infinity.

A number that is not finite is written as ``null`` and read back as NaN where a float is
expected.  Each file is parsed with a parser that refuses ``NaN``, ``Infinity`` and
``-Infinity``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ensemble_helpers import ensemble_result, normal_members
from pier_monitor.core.fileio import finite_or_none, nan_if_none, to_strict_json
from pier_monitor.core.identify.damage import IdentificationResult, failed_event_result
from pier_monitor.core.model.config import PierGeometry
from pier_monitor.report.compare import write_comparison
from pier_monitor.fleet.summary import summarize_store
from pier_monitor.report.fleet import write_fleet_summary
from pier_monitor.store import FAILED_JSON, ResultsStore


def _refuse(name: str) -> Any:
    raise ValueError(f"not strict JSON: bare {name}")


def strict_load(path: Path) -> Any:
    """Parse a file as a strict reader does (JSON.parse, serde_json, ...)."""
    return json.loads(path.read_text(encoding="utf-8"), parse_constant=_refuse)


def _unyielded_pair() -> tuple[IdentificationResult, IdentificationResult]:
    """Two ensemble results of one pier whose second section never yielded in any member:
    its k2, fy spreads are NaN."""
    k1 = normal_members(1e9, 0.01e9)
    df_yield, df_elastic = normal_members(2.0, 0.05), normal_members(0.8, 0.03)
    yes, no = np.ones_like(df_yield, dtype=bool), np.zeros_like(df_yield, dtype=bool)
    before = ensemble_result("run1", [k1, k1], [df_yield, df_elastic], [yes, no],
                             window_start_ns=1_000)
    after = ensemble_result("run2", [0.9 * k1, k1], [df_yield, df_elastic], [yes, no],
                            window_start_ns=2_000).with_baseline(before)
    return before, after


def test_strict_json_writes_non_finite_numbers_as_null() -> None:
    doc = {"a": math.nan, "b": [1.0, math.inf, -math.inf], "c": np.float64("nan"),
           "d": np.array([1.5, np.nan]), "e": (2, None, True), 3: "key"}
    text = to_strict_json(doc)
    assert json.loads(text, parse_constant=_refuse) == {
        "a": None, "b": [1.0, None, None], "c": None, "d": [1.5, None], "e": [2, None, True],
        "3": "key"}
    assert finite_or_none(np.int64(7)) == 7 and finite_or_none(0.25) == 0.25
    assert math.isnan(nan_if_none(None)) and nan_if_none(2) == 2.0
    with pytest.raises(TypeError):
        to_strict_json({"x": object()})


def test_failed_json_is_strict_and_reads_back_nan(tmp_path: Path) -> None:
    geometry = PierGeometry(np.full(3, 2.0), np.full(3, 1.0e5))
    failed = failed_event_result(geometry, pier_id="p1", event_id="run1", start_ns=5,
                                 duration_s=20.0, message="data end during shaking")
    path = ResultsStore(tmp_path).record_failure(failed)
    assert path.name == FAILED_JSON
    doc = strict_load(path)
    assert doc["final_loss"] is None and doc["sections"][0]["k1"] is None
    assert doc["sections"][0]["ductility_factor"] is None
    loaded = IdentificationResult.load_json(path)
    assert math.isnan(loaded.final_loss)
    assert all(math.isnan(s.k1) and math.isnan(s.ductility_factor) for s in loaded.sections)
    assert [s.state for s in loaded.sections] == ["unknown"] * 3
    assert doc["sections"][0]["ductility_factor_upper_bound"] is False  # no DF at all
    assert loaded.message == failed.message


def test_result_json_of_an_unyielded_section_is_strict_and_round_trips(tmp_path: Path) -> None:
    _, after = _unyielded_pair()
    elastic = after.sections[1]
    assert not elastic.yielded and math.isnan(elastic.uncertainty.k2.mean)  # NaN to write
    path = after.save_json(tmp_path / "result.json")
    doc = strict_load(path)
    section = doc["sections"][1]
    assert section["uncertainty"]["k2"] == {"mean": None, "std": None, "lo": None, "hi": None}
    assert section["ductility_factor_upper_bound"] is True
    assert doc["sections"][0]["ductility_factor_upper_bound"] is False
    loaded = IdentificationResult.load_json(path)
    # NaN comes back where it was: the plain forms are equal as strict JSON
    assert to_strict_json(loaded.to_dict()) == to_strict_json(after.to_dict())
    assert math.isnan(loaded.sections[1].uncertainty.fy.lo)
    assert loaded.sections[0] == after.sections[0]  # no NaN in a yielded section


def test_store_reads_an_earlier_result_with_null_numbers_as_a_baseline(tmp_path: Path) -> None:
    before, _ = _unyielded_pair()
    store = ResultsStore(tmp_path)
    (tmp_path / "run1").mkdir()
    before.save_json(tmp_path / "run1" / "result.json")
    (got,) = store.results("p1")
    assert got.event_id == "run1" and got.reliable
    assert math.isnan(got.sections[1].uncertainty.k2.std)
    np.testing.assert_array_equal(got.params.k1, before.params.k1)


def test_compare_and_fleet_json_are_strict(tmp_path: Path) -> None:
    before, after = _unyielded_pair()
    _, paths = write_comparison(before, after, tmp_path / "cmp")
    doc = strict_load(paths.compare_json)
    assert doc["sections"][1]["df_after_bound"] is True
    store = ResultsStore(tmp_path / "results")
    for r in (before, after):
        (store.root / r.event_id).mkdir(parents=True)
        r.save_json(store.root / r.event_id / "result.json")
    geometry = PierGeometry(np.full(2, 2.0), np.full(2, 1.0e5))
    store.record_failure(failed_event_result(geometry, pier_id="p2", event_id="cut1",
                                             start_ns=3_000, duration_s=10.0,
                                             message="cut"))
    fleet = write_fleet_summary(summarize_store(store), tmp_path / "fleet")
    doc = strict_load(fleet.fleet_json)
    rows = {row["pier_id"]: row for row in doc["piers"]}
    assert rows["p2"]["sections"][0]["k1"] is None  # the failed event's NaN k1
    assert rows["p1"]["sections"][1]["ductility_factor_upper_bound"] is True
