"""Write a realistic synthetic E-Defense-style bag with its ground truth beside it (SPEC §6).

The default scenario (:func:`~pier_monitor.core.synthetic.shaking_table.edefense_scenario`: two runs of
increasing damage) is played on ``config/edefense_like.yaml``, recorded with that
configuration's sensor map, written as a rosbag2 directory or a plain ``.mcap`` file, and the
ground truth is written next to the bag as ``<bag stem>.truth.npz`` (time series) and
``<bag stem>.truth.json`` (parameters, geometry, periods, run and mainshock windows,
ductility factors, principal direction, noise levels; human-readable).

A field bag (:func:`write_synthetic_bag` with a ``layout``) records instead what a monitoring
network would: the layout's sensors (:mod:`~pier_monitor.core.synthetic.layouts`), optionally
a GNSS receiver at the top, through imperfect sensors and anti-aliasing data loggers
(:func:`~pier_monitor.core.synthetic.field.field_recording`); the bag carries the field
configuration with the nominal sensors, the truth the sensors' true errors.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.config import PierConfig, load_config
from pier_monitor.core.ingest.recording import NS_PER_S
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.field import field_recording, named_scenario
from pier_monitor.core.synthetic.measurement import SensorImperfections
from pier_monitor.core.synthetic.shaking_table import (Scenario, SyntheticTruth, generate_recording,
                                         save_truth)

from .errors import BagError
from .writer import BagFormat, BagSummary, DEFAULT_BLOCK_S, write_bag

__all__ = ["EDEFENSE_CONFIG_NAME", "SyntheticBagInfo", "default_edefense_config",
           "truth_paths", "write_synthetic_bag", "write_synthetic_edefense_bag"]

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
        The pier configuration that was simulated.
    config : PierConfig
        The configuration embedded in the bag (the layout's sensor map for a field bag).
    layout : str or None
        Field layout (``full``, ``accel``, ``sparse``), or ``None``: the file's sensor map.
    gnss : bool
        Whether the field layout has the GNSS receiver at the top.
    truth : SyntheticTruth
        The ground truth itself.
    elapsed_s : float
        Wall time of simulation and writing, s.
    """

    bag: BagSummary
    truth_npz: Path
    truth_json: Path
    config_path: Path
    config: PierConfig
    layout: str | None
    gnss: bool
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
            "layout": self.layout, "gnss": self.gnss, "sensors": len(self.config.sensors),
            "hysteresis": self.truth.hysteresis,
            "imperfect_sensors": self.truth.imperfections is not None,
            "anti_alias": self.truth.anti_alias,
            "duration_s": (self.truth.end_ns - t0) / NS_PER_S, "elapsed_s": self.elapsed_s,
            "runs": [{
                "name": r.name,
                "start_s": (r.start_ns - t0) / NS_PER_S,
                "window_s": [(r.window_start_ns - t0) / NS_PER_S,
                             (r.window_end_ns - t0) / NS_PER_S],
                "pga_mps2": r.pga_mps2,
                "first_period_s": float(r.periods_s[0]),
                "ductility_factors": [round(float(d), 3) for d in r.ductility_factors],
                **({} if r.rc is None else {"rc": r.rc.as_dict()}),
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


def _bag_paths(out_path: str | Path, fmt: BagFormat) -> tuple[Path, Path, Path]:
    """The bag and its two truth files; :class:`BagError` if the format is off or one exists."""
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
    return out_path, npz_path, json_path


def write_synthetic_bag(out_path: str | Path, *, fmt: BagFormat = "rosbag2", seed: int = 0,
                        config_path: str | Path | None = None,
                        scenario: Scenario | str | None = None, layout: str | None = None,
                        gnss: bool = False,
                        imperfections: SensorImperfections | None = None,
                        block_s: float = DEFAULT_BLOCK_S,
                        hysteresis: str = "bilinear") -> SyntheticBagInfo:
    """Simulate a synthetic test of a pier and write it as a bag plus ground truth.

    Without ``layout`` the pier is recorded with its configuration's sensor map, as it is;
    with one, as a field network would record it
    (:func:`~pier_monitor.core.synthetic.field.field_recording`: the layout's sensors, the
    GNSS receiver with ``gnss``, anti-aliasing, and the ``imperfections`` given).

    Parameters
    ----------
    out_path : str or Path
        The bag to create: a rosbag2 directory (``fmt="rosbag2"``) or an mcap file
        (``fmt="mcap"``; ``.mcap`` is appended when missing).  Must not exist, nor must the
        truth files beside it.
    fmt : {"rosbag2", "mcap"}
        Bag format.
    seed : int
        Seed of the ambient motion, the sensor noise and errors (and of the table records
        when the scenario does not fix them); the same seed gives the same bag contents.
    config_path : str or Path, optional
        Pier configuration with a sensor map; default ``edefense_like.yaml`` of the package.
    scenario : Scenario or str, optional
        Runs and quiet stretches, or a name of
        :func:`~pier_monitor.core.synthetic.field.named_scenario`; default the two-run
        :func:`~pier_monitor.core.synthetic.shaking_table.edefense_scenario`.
    layout : {"full", "accel", "sparse"}, optional
        Field layout of the sensors; default the configuration's sensor map, as it is.
    gnss : bool
        Add the GNSS receiver at the top (needs a ``layout``).
    imperfections : SensorImperfections, optional
        True sensors that differ from the nominal ones; default ideal sensors.
    block_s : float
        Length of a SampleBlock message, s.
    hysteresis : {"bilinear", "takeda", "bwbn"}
        Springs of the simulated pier: ``bilinear`` (the identifier's own model) or the RC
        test-bed's modified Takeda or Bouc–Wen–Baber–Noori springs
        (:mod:`~pier_monitor.core.synthetic.rc`), whose named
        scenarios have amplitudes of their own and whose truth adds the RC keys.

    Returns
    -------
    SyntheticBagInfo
        Paths, bag summary, truth; ``summary()`` gives a printable overview.

    Raises
    ------
    BagError
        The bag or truth files exist, the format is unknown, or writing fails.
    ConfigError
        The configuration cannot be found or is invalid, or the layout does not fit it.
    InputDataError
        The scenario is unknown or does not fit the pier, or ``gnss`` without a layout.
    """
    started = time.perf_counter()
    out_path, npz_path, json_path = _bag_paths(out_path, fmt)
    if gnss and layout is None:
        raise InputDataError("gnss: a GNSS receiver is added to a field layout; choose one of "
                             "full, accel, sparse")
    config_path = Path(config_path) if config_path is not None else default_edefense_config()
    config = load_config(config_path)
    if isinstance(scenario, str):
        scenario = named_scenario(scenario, config.pier_id, hysteresis)
    if layout is None:
        synthetic = generate_recording(config, scenario, seed=seed, imperfections=imperfections,
                                       hysteresis=hysteresis)
    else:
        if scenario is None:
            raise InputDataError("scenario: a field bag needs a scenario (e.g. 'strong')")
        synthetic = field_recording(config, layout, scenario, gnss=gnss, seed=seed,
                                    imperfections=imperfections, hysteresis=hysteresis)
    recorded = synthetic.recording.config
    bag = write_bag(synthetic.recording, out_path, fmt=fmt, block_s=block_s)
    save_truth(synthetic.truth, npz_path, json_path, config=recorded)
    return SyntheticBagInfo(bag=bag, truth_npz=npz_path, truth_json=json_path,
                            config_path=config_path, config=recorded, layout=layout,
                            gnss=gnss, truth=synthetic.truth, elapsed_s=time.perf_counter() - started)


def write_synthetic_edefense_bag(out_path: str | Path, *, fmt: BagFormat = "rosbag2",
                                 seed: int = 0, config_path: str | Path | None = None,
                                 scenario: Scenario | None = None,
                                 block_s: float = DEFAULT_BLOCK_S) -> SyntheticBagInfo:
    """The E-Defense-style shaking-table bag: :func:`write_synthetic_bag` with ideal sensors.

    The default two-run test on ``edefense_like.yaml``, recorded with the configuration's
    own sensor map; see :func:`write_synthetic_bag` for the parameters and errors.
    """
    return write_synthetic_bag(out_path, fmt=fmt, seed=seed, config_path=config_path,
                               scenario=scenario, block_s=block_s)
