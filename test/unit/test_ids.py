"""Ids that become names on disk, and output paths kept under their root."""

from __future__ import annotations

import os

import pytest

from pier_monitor.core.errors import InputDataError, UnsafeNameError
from pier_monitor.core.ids import EVENT_ID_MAX_LEN, check_id, safe_child


@pytest.mark.parametrize("value", ["edefense_pier", "P-7", "a", "x" * 64,
                                   "edefense_pier_20240312T010027Z"])
def test_safe_ids_pass_unchanged(value):
    assert check_id("pier_id", value) == value


@pytest.mark.parametrize("value, match", [
    ("../../x", r"pier_id: '\.\./\.\./x' holds '\./'; only A-Z, a-z, 0-9, '_' and '-'"),
    ("/abs/y", r"pier_id: '/abs/y' holds '/'"),
    ("a\\b", r"pier_id: 'a\\\\b' holds '\\\\'"),
    ("..", r"pier_id: '\.\.' holds '\.'"),
    ("", r"pier_id: empty; expected 1 to 64 characters"),
    ("x" * 65, r"pier_id: 65 characters \('x+'\.\.\.\); at most 64 are allowed"),
    ("nul\x00", r"holds '\\x00'"),
    (None, r"pier_id: expected a string, got NoneType None"),
])
def test_unsafe_ids_are_refused_naming_the_kind(value, match):
    with pytest.raises(UnsafeNameError, match=match):
        check_id("pier_id", value)
    assert issubclass(UnsafeNameError, InputDataError)


def test_event_ids_may_be_longer():
    long_id = "p" * 64 + "_20240312T010027Z"
    assert check_id("event_id", long_id, max_len=EVENT_ID_MAX_LEN) == long_id
    with pytest.raises(UnsafeNameError, match="event_id: 81 characters"):
        check_id("event_id", long_id)


def test_safe_child_stays_below_its_root(tmp_path):
    assert safe_child(tmp_path, "run1") == tmp_path.resolve() / "run1"
    assert safe_child(tmp_path, "run1/window.npz") == tmp_path.resolve() / "run1" / "window.npz"
    for name in ("../x", "../../x", "run1/../../x", "/abs/y", "", ".", "run1/.."):
        with pytest.raises(UnsafeNameError, match="outside|expected a relative path"):
            safe_child(tmp_path, name)


def test_safe_child_refuses_a_link_out_of_the_root(tmp_path):
    root = tmp_path / "results"
    root.mkdir()
    os.symlink(tmp_path, root / "escape")
    with pytest.raises(UnsafeNameError, match=r"'escape/x' resolves to .*, outside"):
        safe_child(root, "escape/x")
