"""Write a synthetic fleet: one bag per pier, its ground truth beside it, and an index.

:func:`write_synthetic_fleet` draws ``N`` piers (:func:`~pier_monitor.core.synthetic.fleet.
fleet_piers`: 2-8 sections, sensor layouts, motions, damage levels), simulates each one's
table runs (:func:`~pier_monitor.core.synthetic.shaking_table.generate_recording`) and
writes into ``out_dir``:

* ``pier_<i>.mcap`` (or a rosbag2 directory ``pier_<i>/``) with the configuration inside;
* ``pier_<i>.truth.json`` and ``pier_<i>.truth.npz`` (see :func:`~pier_monitor.core.
  synthetic.shaking_table.save_truth`);
* ``fleet_truth.json``: per pier its bag, layout, damage level, sections and, per run, the
  true ``k1`` and ductility factors — what a fleet identification should find.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from pier_monitor.core.fileio import atomic_path, to_strict_json
from pier_monitor.core.synthetic.fleet import FleetPier, fleet_piers
from pier_monitor.core.synthetic.shaking_table import SyntheticTruth, generate_recording, save_truth

from .errors import BagError
from .synthetic_bag import truth_paths
from .writer import BagSummary, write_bag

__all__ = ["FLEET_TRUTH_JSON", "FleetBag", "write_synthetic_fleet"]

#: Name of the fleet's truth index in the output directory.
FLEET_TRUTH_JSON = "fleet_truth.json"

FleetFormat = Literal["mcap", "rosbag2", "mixed"]


@dataclass(frozen=True, eq=False)
class FleetBag:
    """One written pier of a synthetic fleet."""

    pier: FleetPier
    bag: BagSummary
    truth: SyntheticTruth
    truth_json: Path

    def summary(self) -> dict[str, Any]:
        """JSON-ready: bag, layout, damage level and the truth of every run."""
        return {
            "pier_id": self.pier.pier_id, "bag": self.bag.path.name, "format": self.bag.fmt,
            "layout": self.pier.layout, "damage": self.pier.damage,
            "sections": self.pier.config.n_levels, "sensors": len(self.pier.config.sensors),
            "truth_json": self.truth_json.name,
            "design_k1_Nm_per_rad": self.pier.config.design.k1.tolist(),
            "runs": [{"name": r.name, "pga_mps2": r.pga_mps2,
                      "window_start_ns": r.window_start_ns, "window_end_ns": r.window_end_ns,
                      "k1_Nm_per_rad": r.params.k1.tolist(),
                      "ductility_factors": [round(float(d), 4) for d in r.ductility_factors]}
                     for r in self.truth.runs],
        }


def write_synthetic_fleet(out_dir: str | Path, n: int, *, seed: int = 0,
                          layouts: tuple[str, ...] = ("full",), fmt: FleetFormat = "mcap",
                          **pier_options: Any) -> tuple[FleetBag, ...]:
    """Simulate ``n`` piers and write one bag each, their truth, and ``fleet_truth.json``.

    Parameters
    ----------
    out_dir : str or Path
        Output directory (created); the bags and truth files must not exist yet.
    n : int
        Number of piers.
    seed : int
        Seed of the fleet (designs, motions, noise); the same seed writes the same fleet.
    layouts : tuple of str
        Sensor layouts, given to the piers in turn.
    fmt : {"mcap", "rosbag2", "mixed"}
        Bag format; ``"mixed"`` alternates, starting with ``.mcap``.
    **pier_options
        Record lengths and the section range of
        :func:`~pier_monitor.core.synthetic.fleet.fleet_pier`.

    Raises
    ------
    BagError
        Naming the file that exists already or cannot be written.
    InputDataError
        For a bad fleet size, layout or option.
    """
    if fmt not in ("mcap", "rosbag2", "mixed"):
        raise BagError(f"{out_dir}: unknown bag format {fmt!r}; expected mcap, rosbag2 or mixed")
    out = Path(out_dir)
    piers = fleet_piers(n, seed, layouts=layouts, **pier_options)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise BagError(f"{out}: cannot create the fleet directory: {err.strerror or err}") from err
    written = []
    for pier in piers:
        bag_fmt = fmt if fmt != "mixed" else ("mcap" if pier.index % 2 == 0 else "rosbag2")
        path = out / (f"{pier.pier_id}.mcap" if bag_fmt == "mcap" else pier.pier_id)
        npz_path, json_path = truth_paths(path)
        for p in (path, npz_path, json_path):
            if p.exists():
                raise BagError(f"{p}: exists already, not overwriting")
        synthetic = generate_recording(pier.config, pier.scenario, seed=seed * 100_003 + pier.index)
        summary = write_bag(synthetic.recording, path, fmt=bag_fmt)
        save_truth(synthetic.truth, npz_path, json_path, config=pier.config)
        written.append(FleetBag(pier=pier, bag=summary, truth=synthetic.truth,
                                truth_json=json_path))
    index = {"format": "pier_monitor synthetic fleet 1", "seed": seed, "piers":
             [w.summary() for w in written]}
    target = out / FLEET_TRUTH_JSON
    try:
        with atomic_path(target) as tmp:
            tmp.write_text(to_strict_json(index, indent=1) + "\n", encoding="utf-8")
    except OSError as err:
        raise BagError(f"{target}: cannot write: {err.strerror or err}") from err
    return tuple(written)
