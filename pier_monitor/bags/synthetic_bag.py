"""Write a realistic synthetic E-Defense-style bag with its ground truth beside it (SPEC §6).

The default scenario (:func:`~pier_monitor.core.synthetic.shaking_table.edefense_scenario`: two runs of
increasing damage) is played on ``config/edefense_like.yaml``, recorded with that
configuration's sensor map, written as a rosbag2 directory or a plain ``.mcap`` file, and the
ground truth is written next to the bag as ``<bag stem>.truth.npz`` (time series) and
``<bag stem>.truth.json`` (parameters, geometry, periods, run and mainshock windows,
ductility factors, principal direction, noise levels; human-readable).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pier_monitor.core.model.config import load_config
from pier_monitor.core.ingest.recording import NS_PER_S
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.shaking_table import (Scenario, SyntheticTruth, generate_recording,
                                         save_truth)

from .errors import BagError
from .writer import BagFormat, BagSummary, DEFAULT_BLOCK_S, write_bag

__all__ = ["EDEFENSE_CONFIG_NAME", "SyntheticBagInfo", "default_edefense_config",
           "truth_paths", "write_synthetic_edefense_bag"]

#: File name of the E-Defense-like pier configuration shipped with the package.
EDEFENSE_CONFIG_NAME = "edefense_like.yaml"


@dataclass(frozen=True, eq=False)
class SyntheticBagInfo:
    """What :func:`write_synthetic_edefense_bag` wrote.

    Attributes
    ----------
    bag : BagSummary
        The bag (path, format, size, message count, topics).
    truth_npz, truth_json : Path
        The ground truth files.
    config_path : Path
        The pier configuration that was simulated (also embedded in the bag).
    truth : SyntheticTruth
        The ground truth itself.
    elapsed_s : float
        Wall time of simulation and writing, s.
    """

    bag: BagSummary
    truth_npz: Path
    truth_json: Path
    config_path: Path
    truth: SyntheticTruth
    elapsed_s: float

    def summary(self) -> dict[str, Any]:
        """A JSON-ready overview: files, size, runs with periods, windows and DFs."""
        t0 = self.truth.start_ns
        return {
            "bag": str(self.bag.path), "format": self.bag.fmt,
            "size_bytes": self.bag.size_bytes, "messages": self.bag.n_messages,
            "truth_npz": str(self.truth_npz), "truth_json": str(self.truth_json),
            "config": str(self.config_path), "seed": self.truth.seed,
            "duration_s": (self.truth.end_ns - t0) / NS_PER_S, "elapsed_s": self.elapsed_s,
            "runs": [{
                "name": r.name,
                "start_s": (r.start_ns - t0) / NS_PER_S,
                "window_s": [(r.window_start_ns - t0) / NS_PER_S,
                             (r.window_end_ns - t0) / NS_PER_S],
                "pga_mps2": r.pga_mps2,
                "first_period_s": float(r.periods_s[0]),
                "ductility_factors": [round(float(d), 3) for d in r.ductility_factors],
            } for r in self.truth.runs],
        }


def default_edefense_config() -> Path:
    """Path of ``edefense_like.yaml``: installed ``share/pier_monitor/config``, else the repo's."""
    return find_config_file(EDEFENSE_CONFIG_NAME)


def truth_paths(bag_path: str | Path) -> tuple[Path, Path]:
    """``(<stem>.truth.npz, <stem>.truth.json)`` beside a bag (``.mcap`` suffix dropped)."""
    bag_path = Path(bag_path)
    stem = bag_path.stem if bag_path.suffix.lower() == ".mcap" else bag_path.name
    return (bag_path.with_name(f"{stem}.truth.npz"), bag_path.with_name(f"{stem}.truth.json"))


def write_synthetic_edefense_bag(out_path: str | Path, *, fmt: BagFormat = "rosbag2",
                                 seed: int = 0, config_path: str | Path | None = None,
                                 scenario: Scenario | None = None,
                                 block_s: float = DEFAULT_BLOCK_S) -> SyntheticBagInfo:
    """Simulate the E-Defense-like shaking-table test and write it as a bag plus ground truth.

    Parameters
    ----------
    out_path : str or Path
        The bag to create: a rosbag2 directory (``fmt="rosbag2"``) or an mcap file
        (``fmt="mcap"``; ``.mcap`` is appended when missing).  Must not exist, nor must the
        truth files beside it.
    fmt : {"rosbag2", "mcap"}
        Bag format.
    seed : int
        Seed of the ambient motion and the sensor noise (and of the table records when the
        scenario does not fix them); the same seed gives the same bag contents.
    config_path : str or Path, optional
        Pier configuration with a sensor map; default ``edefense_like.yaml`` of the package.
    scenario : Scenario, optional
        Runs and quiet stretches; default the two-run
        :func:`~pier_monitor.core.synthetic.shaking_table.edefense_scenario`.
    block_s : float
        Length of a SampleBlock message, s.

    Returns
    -------
    SyntheticBagInfo
        Paths, bag summary, truth; ``summary()`` gives a printable overview.

    Raises
    ------
    BagError
        The bag or truth files exist, the format is unknown, or writing fails.
    ConfigError
        The configuration cannot be found or is invalid.
    """
    started = time.perf_counter()
    out_path = Path(out_path)
    if fmt == "mcap" and out_path.suffix.lower() != ".mcap":
        out_path = out_path.with_name(out_path.name + ".mcap")
    elif fmt == "rosbag2" and out_path.suffix.lower() == ".mcap":
        raise BagError(f"{out_path}: a rosbag2 bag is a directory; drop the .mcap suffix or "
                       "use fmt='mcap'")
    elif fmt not in ("rosbag2", "mcap"):
        raise BagError(f"{out_path}: unknown bag format {fmt!r}; expected 'rosbag2' or 'mcap'")
    npz_path, json_path = truth_paths(out_path)
    for p in (out_path, npz_path, json_path):
        if p.exists():
            raise BagError(f"{p}: exists already, not overwriting")
    config_path = Path(config_path) if config_path is not None else default_edefense_config()
    config = load_config(config_path)
    synthetic = generate_recording(config, scenario, seed=seed)
    bag = write_bag(synthetic.recording, out_path, fmt=fmt, block_s=block_s)
    save_truth(synthetic.truth, npz_path, json_path, config=config)
    return SyntheticBagInfo(bag=bag, truth_npz=npz_path, truth_json=json_path,
                            config_path=config_path, truth=synthetic.truth,
                            elapsed_s=time.perf_counter() - started)
