"""The mainshock window: the identifier's input.

A :class:`MeasuredWindow` holds, for one event, the foundation acceleration and the
per-level responses relative to the foundation in the principal direction, uniformly sampled
(time-first, SI), with the pier geometry, masses and design values, and the 1-sigma noise of
each quantity.  The ingest produces it from sensor streams; the benchmark builds it from a
simulation with known truth.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .config import PierGeometry, SpringParameters
from .errors import InputDataError
from .model import check_response_array

__all__ = ["MeasuredWindow", "QUANTITIES"]

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
