"""pier-monitor simulate refuses implausible or ambiguous input with a clear message."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.cli import main


@pytest.fixture
def three_columns(tmp_path):
    """A 2 s accelerogram file: time, the acceleration in g, and a constant third column."""
    t = np.arange(200) * 0.01
    acc = 0.2 * np.sin(2 * np.pi * 2.0 * t) * np.exp(-t)
    path = tmp_path / "three.txt"
    np.savetxt(path, np.column_stack([t, acc, np.full_like(t, 7.0)]))
    return path


def run(capsys, *args: str) -> tuple[int, str]:
    rc = main(["simulate", *args])
    return rc, capsys.readouterr().err


def test_implausible_pga_and_scale_are_refused(tmp_path, capsys):
    rc, err = run(capsys, "--pga", "1e30", "--out", str(tmp_path / "r.npz"))
    assert rc == 2 and "PGA 1e+30 m/s^2 is implausible for a ground motion" in err
    rc, err = run(capsys, "--scale", "1e6", "--out", str(tmp_path / "r.npz"))
    assert rc == 2 and "is implausible for a ground motion (> 50 m/s^2 = 5 g)" in err
    assert not (tmp_path / "r.npz").exists()


def test_three_column_file_needs_the_acceleration_column(three_columns, tmp_path, capsys):
    out = tmp_path / "r.npz"
    rc, err = run(capsys, "--ground-motion", str(three_columns), "--units", "g", "--out",
                  str(out))
    assert rc == 2 and "three.txt: 3 columns; choose the acceleration column" in err
    rc, err = run(capsys, "--ground-motion", str(three_columns), "--units", "g", "--column",
                  "2", "--out", str(out))
    assert rc == 0, err
    with np.load(out) as data:
        assert data["ag"].shape == (200,)
        assert np.abs(data["ag"]).max() == pytest.approx(np.abs(np.loadtxt(three_columns)[:, 1]).max()
                                                         * 9.80665, rel=0.05)


def test_output_below_an_existing_file_is_refused(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    rc, err = run(capsys, "--out", str(tmp_path / "afile" / "r.npz"))
    assert rc == 2 and f"{tmp_path / 'afile'} is a file, not a directory" in err
    rc, err = run(capsys, "--out", str(tmp_path / "afile" / "bag.mcap"))
    assert rc == 2 and "is a file, not a directory" in err


def test_pier_file_that_is_not_utf8_is_refused(tmp_path, capsys):
    pier = tmp_path / "pier.yaml"
    pier.write_bytes(b"pier_id: caf\xe9\n")
    rc, err = run(capsys, "--pier", str(pier), "--out", str(tmp_path / "r.npz"))
    assert rc == 2 and "pier.yaml: not UTF-8 text (byte 0xe9 at offset 12)" in err


def test_column_does_not_apply_to_a_bag(tmp_path, capsys):
    rc, err = run(capsys, "--column", "2", "--out", str(tmp_path / "bag.mcap"))
    assert rc == 2 and "--ground-motion/--column/--scale/--pga apply to .npz output" in err
