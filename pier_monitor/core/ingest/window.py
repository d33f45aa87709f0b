"""The mainshock window: the identifier's input.

A :class:`MeasuredWindow` holds, for one event, the foundation acceleration and the
per-level responses relative to the foundation in the principal direction, uniformly sampled
(time-first, SI), with the pier geometry, masses and design values, and the 1-sigma noise of
each quantity.  The ingest produces it from sensor streams; the benchmark builds it from a
simulation with known truth.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.link_model import check_response_array

__all__ = ["MeasuredWindow", "Reproduced", "QUANTITIES", "save_window", "load_window"]

#: Response quantities of a window, in the order of the PINN's outputs.
QUANTITIES = ("a", "v", "x", "f")


@dataclass(frozen=True, eq=False)
class MeasuredWindow:
    """One event window of measured responses.

    Attributes
    ----------
    pier_id, event_id : str
        Names of the pier and the event.
    geometry : PierGeometry
        Section heights and masses (``N`` levels).
    design : SpringParameters
        Design (or prior) parameters, the starting point of the identification.
    t : ndarray, shape (T,)
        Sample times, s (uniform; origin as the source defines it).
    ag : ndarray, shape (T,)
        Foundation acceleration, m/s².
    a, v, x : ndarray, shape (T, N)
        Relative acceleration (m/s²), velocity (m/s), displacement (m) of the levels.
    moments : ndarray, shape (T, N), or None
        Measured restoring moments, N·m, when a test provides them (not in the field).
    sigma : dict
        1-sigma noise per quantity: ``"ag"`` a float, ``"a" "v" "x" "f"`` arrays of shape
        (N,), SI.  Missing entries mean unknown.
    start_time_ns : int
        Absolute time of the first sample, ns since the Unix epoch (0 if not known).
    report : dict
        Notes from the ingest (exclusions, gaps, ...), JSON-serialisable.
    """

    pier_id: str
    event_id: str
    geometry: PierGeometry
    design: SpringParameters
    t: np.ndarray
    ag: np.ndarray
    a: np.ndarray
    v: np.ndarray
    x: np.ndarray
    moments: np.ndarray | None = None
    sigma: dict[str, Any] = field(default_factory=dict)
    start_time_ns: int = 0
    report: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        n = self.geometry.n_levels
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 10:
            raise InputDataError(f"window t: expected at least 10 samples, got shape {t.shape}")
        steps = np.diff(t)
        if np.any(steps <= 0) or np.ptp(steps) > 1e-6 * steps.mean():
            raise InputDataError("window t: samples must be uniformly spaced and increasing")
        ag = np.asarray(self.ag, dtype=float)
        if ag.shape != t.shape or not np.all(np.isfinite(ag)):
            raise InputDataError(f"window ag: expected {t.size} finite values, got shape {ag.shape}")
        for name in ("a", "v", "x"):
            object.__setattr__(self, name, check_response_array(
                f"window {name}", getattr(self, name), n=n, length=t.size))
        if self.moments is not None:
            object.__setattr__(self, "moments", check_response_array(
                "window moments", self.moments, n=n, length=t.size))
        if self.design.n_springs != n:
            raise InputDataError(
                f"window design: expected {n} springs, got {self.design.n_springs}")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "ag", ag)

    @property
    def n_levels(self) -> int:
        """Number of levels ``N``."""
        return self.geometry.n_levels

    @property
    def dt(self) -> float:
        """Sampling period, s."""
        return float(self.t[1] - self.t[0])

    @property
    def duration_s(self) -> float:
        """Length of the window, s."""
        return float(self.t[-1] - self.t[0] + self.dt)

    @property
    def moments_measured(self) -> bool:
        """Whether restoring moments were measured."""
        return self.moments is not None


@dataclass(frozen=True)
class Reproduced:
    """Responses reproduced by an identification over its window, time-first, SI.

    ``t`` (T,) s; ``a, v, x`` (T, N) relative acceleration, velocity, displacement;
    ``theta`` (T, N) spring angles, rad; ``moment`` (T, N) restoring moments, N·m.
    """

    t: np.ndarray
    a: np.ndarray
    v: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    moment: np.ndarray


def save_window(window: MeasuredWindow, path: str | Path) -> Path:
    """Write a window to one ``.npz`` file (arrays plus a JSON header); returns the path.

    The identifier writes every window to disk before it trains on it, so that a crash
    loses no event.
    """
    path = Path(path)
    header = {
        "pier_id": window.pier_id, "event_id": window.event_id,
        "start_time_ns": int(window.start_time_ns),
        "section_heights_m": window.geometry.section_heights_m.tolist(),
        "masses_kg": window.geometry.masses_kg.tolist(), "design": window.design.as_dict(),
        "sigma": {k: np.asarray(v, dtype=float).tolist() for k, v in window.sigma.items()},
        "report": window.report,
    }
    arrays = {"t": window.t, "ag": window.ag, "a": window.a, "v": window.v, "x": window.x}
    if window.moments is not None:
        arrays["moments"] = window.moments
    tmp = path.with_name(path.name + ".part")
    with tmp.open("wb") as fh:
        np.savez(fh, header=np.array(json.dumps(header)), **arrays)
    tmp.replace(path)  # atomic: a reader never sees half a window
    return path


def load_window(path: str | Path) -> MeasuredWindow:
    """Read a file written by :func:`save_window`.

    Raises
    ------
    InputDataError
        Naming the file when it is missing, truncated or not a window.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            header = json.loads(str(data["header"]))
            arrays = {k: np.array(data[k]) for k in data.files if k != "header"}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, json.JSONDecodeError) as err:
        raise InputDataError(f"{path}: not a readable window file: {err}") from err
    try:
        return MeasuredWindow(
            pier_id=header["pier_id"], event_id=header["event_id"],
            geometry=PierGeometry(np.array(header["section_heights_m"]),
                                  np.array(header["masses_kg"])),
            design=SpringParameters(**{k: np.array(v) for k, v in header["design"].items()}),
            t=arrays["t"], ag=arrays["ag"], a=arrays["a"], v=arrays["v"], x=arrays["x"],
            moments=arrays.get("moments"),
            sigma={k: (np.array(v) if isinstance(v, list) else v)
                   for k, v in header["sigma"].items()},
            start_time_ns=int(header["start_time_ns"]), report=header["report"])
    except KeyError as err:
        raise InputDataError(f"{path}: window file lacks {err}") from err
