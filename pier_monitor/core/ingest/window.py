"""The mainshock window: the identifier's input.

A :class:`MeasuredWindow` holds, for one event, the foundation acceleration and the
per-level responses relative to the foundation in the principal direction, uniformly sampled
(time-first, SI), with the pier geometry, masses and design values, the 1-sigma noise of
each quantity (:class:`NoiseModel`) and what was measured at each level
(:class:`Coverage`).  The ingest produces it from sensor streams; the benchmark builds it
from a simulation with known truth.  :func:`save_window` / :func:`load_window` are its one
conversion to and from disk.

Field networks do not measure everything: a level may have no sensor at all, or
accelerometers but no displacement sensor.  The arrays then hold NaN where nothing was
measured (``a`` of a level without accelerometer; ``v`` and ``x`` of a level with neither),
and ``v``, ``x`` of a level with accelerometers but no displacement sensor are integrals of
its acceleration whose content below ``coverage.highpass_hz`` is not known.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import atomic_path
from pier_monitor.core.ingest.findings import Finding
from pier_monitor.core.model.config import PierGeometry, SpringParameters

__all__ = ["NoiseModel", "Coverage", "MeasuredWindow", "Reproduced", "QUANTITIES",
           "save_window", "load_window"]

#: Response quantities of a window, in the order of the PINN's outputs.
QUANTITIES = ("a", "v", "x", "f")

_NOISE_LEVEL_FIELDS = ("a", "v", "x", "dx", "dv", "f")


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr = np.array(arr, copy=True)
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class NoiseModel:
    """1-sigma noise of a window's quantities, SI units; NaN where unknown.

    Attributes
    ----------
    ag : float
        Foundation acceleration, m/s².
    a, v, x : ndarray, shape (N,)
        Relative acceleration (m/s²), velocity (m/s) and displacement (m) of each level.
    dx, dv : ndarray, shape (N,)
        Noise of the increments of ``x`` (m) and ``v`` (m/s) over one sample.  Smoothed
        data have correlated errors, so their increments are far less noisy than the
        ``√2 σ`` of white noise; NaN = white.
    f : ndarray, shape (N,)
        Noise of measured restoring moments, N·m (NaN when moments are not measured).
    gain_rel : float
        Relative 1-sigma uncertainty of the sensors' gains (0.01 = 1 %): a misfit floor
        proportional to the signal, far above the noise on strong shaking.
    """

    ag: float
    a: np.ndarray
    v: np.ndarray
    x: np.ndarray
    dx: np.ndarray
    dv: np.ndarray
    f: np.ndarray
    gain_rel: float = 0.0

    def __post_init__(self) -> None:
        n = np.asarray(self.a).size
        for name in _NOISE_LEVEL_FIELDS:
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            if arr.shape != (n,) or np.any(arr[np.isfinite(arr)] < 0) or np.any(np.isinf(arr)):
                raise InputDataError(f"noise {name}: expected {n} non-negative values (or NaN "
                                     f"for unknown), got {arr.tolist()}")
            object.__setattr__(self, name, _readonly(arr))
        for name in ("ag", "gain_rel"):
            value = float(getattr(self, name))
            if math.isinf(value) or value < 0:
                raise InputDataError(f"noise {name}: expected a non-negative value (or NaN for "
                                     f"unknown), got {value}")
            object.__setattr__(self, name, value)

    @classmethod
    def unknown(cls, n_levels: int) -> "NoiseModel":
        """A noise model that knows nothing (every value NaN)."""
        nan = np.full(n_levels, np.nan)
        return cls(ag=float("nan"), a=nan, v=nan, x=nan, dx=nan, dv=nan, f=nan)

    @property
    def n_levels(self) -> int:
        """Number of levels ``N``."""
        return int(self.a.size)

    def as_dict(self) -> dict[str, Any]:
        """Plain form (lists, NaN kept), the inverse of :meth:`from_dict`."""
        out: dict[str, Any] = {name: getattr(self, name).tolist() for name in _NOISE_LEVEL_FIELDS}
        out.update(ag=self.ag, gain_rel=self.gain_rel)
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "NoiseModel":
        """Read :meth:`as_dict`'s form."""
        return cls(**{k: (np.array(v, dtype=float) if isinstance(v, list) else v)
                      for k, v in d.items()})

    def __eq__(self, other: object) -> bool:
        return isinstance(other, NoiseModel) and all(
            np.array_equal(getattr(self, k), getattr(other, k), equal_nan=True)
            for k in (*_NOISE_LEVEL_FIELDS, "ag", "gain_rel"))

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, eq=False)
class Coverage:
    """What the sensors measured at each level of a window.

    Attributes
    ----------
    acceleration : ndarray of bool, shape (N,)
        The level's relative acceleration is measured (it has accelerometers).
    displacement : ndarray of bool, shape (N,)
        The level's displacement relative to the foundation is measured down to zero
        frequency (wire transducers to a fixed frame, GNSS).
    highpass_hz : float
        Levels with acceleration but no displacement sensor carry ``v`` and ``x`` integrated
        from their acceleration, with nothing below this frequency, Hz (0 when every
        covered level has a displacement sensor).
    """

    acceleration: np.ndarray
    displacement: np.ndarray
    highpass_hz: float = 0.0

    def __post_init__(self) -> None:
        acc = np.atleast_1d(np.asarray(self.acceleration))
        disp = np.atleast_1d(np.asarray(self.displacement))
        if acc.dtype != bool or disp.dtype != bool or acc.ndim != 1 or disp.shape != acc.shape:
            raise InputDataError(f"coverage: expected two boolean arrays of N levels, got "
                                 f"{acc.tolist()} and {disp.tolist()}")
        hp = float(self.highpass_hz)
        if not (math.isfinite(hp) and hp >= 0):
            raise InputDataError(f"coverage highpass_hz: expected a non-negative frequency, "
                                 f"got {hp}")
        object.__setattr__(self, "acceleration", _readonly(acc))
        object.__setattr__(self, "displacement", _readonly(disp))
        object.__setattr__(self, "highpass_hz", hp)

    @classmethod
    def full(cls, n_levels: int) -> "Coverage":
        """Every level with accelerometers and displacement sensors (a shaking table)."""
        return cls(np.ones(n_levels, dtype=bool), np.ones(n_levels, dtype=bool))

    @property
    def n_levels(self) -> int:
        """Number of levels ``N``."""
        return int(self.acceleration.size)

    @property
    def is_full(self) -> bool:
        """Acceleration and displacement measured at every level."""
        return bool(self.acceleration.all() and self.displacement.all())

    @property
    def motion(self) -> np.ndarray:
        """Levels whose motion is known at all (acceleration or displacement), (N,) bool."""
        return self.acceleration | self.displacement

    @property
    def section_ends_measured(self) -> np.ndarray:
        """Sections both of whose end levels have a motion sensor (the foundation always
        counts as measured), (N,) bool, section ``i`` between levels ``i`` and ``i + 1``."""
        motion = self.motion
        return motion & np.r_[True, motion[:-1]]

    @property
    def layout(self) -> str:
        """``"full"``, ``"accel"`` (accelerometers everywhere, no displacement sensor),
        ``"sparse"`` (some levels without sensors), or ``"mixed"``; ``"+gnss"``-style
        suffixes are not added: see :attr:`displacement`."""
        if self.is_full:
            return "full"
        if not self.motion.all():
            return "sparse"
        if self.acceleration.all() and not self.displacement.any():
            return "accel"
        return "mixed"

    def as_dict(self) -> dict[str, Any]:
        """Plain form, the inverse of :meth:`from_dict`."""
        return {"acceleration": self.acceleration.tolist(),
                "displacement": self.displacement.tolist(), "highpass_hz": self.highpass_hz}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Coverage":
        """Read :meth:`as_dict`'s form."""
        return cls(np.array(d["acceleration"], dtype=bool), np.array(d["displacement"], dtype=bool),
                   float(d.get("highpass_hz", 0.0)))

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Coverage) and self.highpass_hz == other.highpass_hz
                and np.array_equal(self.acceleration, other.acceleration)
                and np.array_equal(self.displacement, other.displacement))

    __hash__ = None  # type: ignore[assignment]


def _check_columns(name: str, arr: Any, t_len: int, n: int, covered: np.ndarray) -> np.ndarray:
    """``arr`` as a (T, N) float array, finite on covered columns and NaN elsewhere."""
    a = np.asarray(arr, dtype=float)
    if a.shape != (t_len, n):
        raise InputDataError(f"window {name}: expected shape ({t_len}, {n}), got {a.shape}")
    finite = np.isfinite(a).all(axis=0)
    bad = np.flatnonzero(covered & ~finite)
    if bad.size:
        raise InputDataError(f"window {name}: level {bad[0] + 1} is measured but has "
                             "non-finite samples")
    stray = np.flatnonzero(~covered & ~np.isnan(a).all(axis=0))
    if stray.size:
        raise InputDataError(f"window {name}: level {stray[0] + 1} is not measured, so its "
                             "column must be NaN")
    return _readonly(a)


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
        Relative acceleration (m/s²), velocity (m/s), displacement (m) of the levels; NaN
        columns where not measured (see :class:`Coverage` and the module documentation).
    moments : ndarray, shape (T, N), or None
        Measured restoring moments, N·m, when a test provides them (not in the field).
    noise : NoiseModel, optional
        1-sigma noise of every quantity; default unknown (all NaN).
    coverage : Coverage, optional
        What was measured at each level; default: everything.
    start_time_ns : int
        Absolute time of the first sample, ns since the Unix epoch (0 if not known).
    report : dict
        Notes from the ingest (exclusions, gaps, ...), JSON-serialisable.
    prior_rotation_peaks : ndarray, shape (2, N), or None
        The pier's history before the window, as the modified-Takeda springs start from it
        (both routes): per section the largest positive (row 0, ``>= 0``) and negative (row
        1, ``<= 0``) spring rotation of the earlier events, rad, in this window's frame (the
        residual rotation they left removed).  None: a virgin pier, or a history not known.
        Not stored with the window: the store supplies it
        (:meth:`~pier_monitor.store.ResultsStore.rotation_peaks_before`).
    prior_rotation_peaks_unidentified : ndarray, shape (2, N), or None
        ``prior_rotation_peaks`` with, in addition, the reconstructed peaks of the sections
        whose DF the earlier event left poorly identified, rad, as above; the field
        reconstruction tries them as a third start of the springs' history and keeps them
        where they fit best.  None: there are no such peaks.  Not stored with the window
        (:attr:`~pier_monitor.store.PierHistory.rotation_peaks_unidentified`).
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
    noise: NoiseModel | None = None
    coverage: Coverage | None = None
    start_time_ns: int = 0
    report: dict[str, Any] = field(default_factory=dict)
    prior_rotation_peaks: np.ndarray | None = None
    prior_rotation_peaks_unidentified: np.ndarray | None = None

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
        cov = self.coverage if self.coverage is not None else Coverage.full(n)
        if cov.n_levels != n:
            raise InputDataError(f"window coverage: expected {n} levels, got {cov.n_levels}")
        if not cov.motion.any():
            raise InputDataError("window coverage: no level above the foundation is measured")
        noise = self.noise if self.noise is not None else NoiseModel.unknown(n)
        if noise.n_levels != n:
            raise InputDataError(f"window noise: expected {n} levels, got {noise.n_levels}")
        object.__setattr__(self, "a", _check_columns("a", self.a, t.size, n, cov.acceleration))
        for name in ("v", "x"):
            object.__setattr__(self, name, _check_columns(name, getattr(self, name), t.size, n,
                                                          cov.motion))
        if self.moments is not None:
            object.__setattr__(self, "moments", _check_columns(
                "moments", self.moments, t.size, n, np.ones(n, dtype=bool)))
        if self.design.n_springs != n:
            raise InputDataError(
                f"window design: expected {n} springs, got {self.design.n_springs}")
        object.__setattr__(self, "t", _readonly(t))
        object.__setattr__(self, "ag", _readonly(ag))
        object.__setattr__(self, "coverage", cov)
        object.__setattr__(self, "noise", noise)
        object.__setattr__(self, "start_time_ns", int(self.start_time_ns))
        for name in ("prior_rotation_peaks", "prior_rotation_peaks_unidentified"):
            if getattr(self, name) is None:
                continue
            prior = np.array(getattr(self, name), dtype=float)
            if (prior.shape != (2, n) or not np.all(np.isfinite(prior))
                    or np.any(prior[0] < 0) or np.any(prior[1] > 0)):
                raise InputDataError(f"window {name}: expected shape (2, {n}), finite, row 0 "
                                     f">= 0 and row 1 <= 0 (rad), got {prior.tolist()}")
            object.__setattr__(self, name, _readonly(prior))

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

    @property
    def findings(self) -> tuple[Finding, ...]:
        """The ingest's findings about this window's data (``report["findings"]``).

        Raises
        ------
        InputDataError
            If ``report["findings"]`` is not a list of findings.
        """
        try:
            return tuple(Finding.from_dict(f) for f in self.report.get("findings", ()))
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise InputDataError(f"window {self.event_id!r}: report['findings'] is not a list "
                                 f"of findings ({type(err).__name__}: {err})") from err

    @property
    def partial(self) -> str | None:
        """Why the window is partial (the data end during the event, after its strong
        motion: ``report["partial"]["reason"]``); None for a complete event.

        Raises
        ------
        InputDataError
            If ``report["partial"]`` is neither None nor ``{"reason": <text>}``.
        """
        mark = self.report.get("partial")
        if mark is None:
            return None
        if not (isinstance(mark, dict) and isinstance(mark.get("reason"), str)):
            raise InputDataError(f"window {self.event_id!r}: report['partial'] must be null or "
                                 f"{{'reason': <text>}}, got {mark!r}")
        return mark["reason"]

    def __eq__(self, other: object) -> bool:
        """Every field equal (arrays exactly, NaN equal to NaN)."""
        if not isinstance(other, MeasuredWindow):
            return NotImplemented
        same = lambda a, b: (a is None and b is None) or (
            a is not None and b is not None and np.array_equal(a, b, equal_nan=True))
        return (self.pier_id == other.pier_id and self.event_id == other.event_id
                and self.geometry == other.geometry and self.design == other.design
                and all(same(getattr(self, k), getattr(other, k))
                        for k in ("t", "ag", "a", "v", "x", "moments"))
                and self.noise == other.noise and self.coverage == other.coverage
                and self.start_time_ns == other.start_time_ns and self.report == other.report)

    __hash__ = None  # type: ignore[assignment]


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
    loses no event.  :func:`load_window` gives back an equal window.
    """
    path = Path(path)
    header = {
        "format": "pier_monitor window 2",
        "pier_id": window.pier_id, "event_id": window.event_id,
        "start_time_ns": int(window.start_time_ns),
        "section_heights_m": window.geometry.section_heights_m.tolist(),
        "masses_kg": window.geometry.masses_kg.tolist(), "design": window.design.as_dict(),
        "noise": window.noise.as_dict(), "coverage": window.coverage.as_dict(),
        "report": window.report,
    }
    arrays = {"t": window.t, "ag": window.ag, "a": window.a, "v": window.v, "x": window.x}
    if window.moments is not None:
        arrays["moments"] = window.moments
    with atomic_path(path) as tmp, tmp.open("wb") as fh:  # a reader never sees half a window
        np.savez(fh, header=np.array(json.dumps(header)), **arrays)
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
    if header.get("format") != "pier_monitor window 2":
        raise InputDataError(f"{path}: not a pier_monitor window file of format 2 "
                             f"(format {header.get('format')!r})")
    try:
        return MeasuredWindow(
            pier_id=header["pier_id"], event_id=header["event_id"],
            geometry=PierGeometry(np.array(header["section_heights_m"]),
                                  np.array(header["masses_kg"])),
            design=SpringParameters(**{k: np.array(v) for k, v in header["design"].items()}),
            t=arrays["t"], ag=arrays["ag"], a=arrays["a"], v=arrays["v"], x=arrays["x"],
            moments=arrays.get("moments"), noise=NoiseModel.from_dict(header["noise"]),
            coverage=Coverage.from_dict(header["coverage"]),
            start_time_ns=int(header["start_time_ns"]), report=header["report"])
    except KeyError as err:
        raise InputDataError(f"{path}: window file lacks {err}") from err
