"""Damage indices and identification results (SPEC §5, paper §4.5).

``DF_n = max_t |θ_n(t)| / θy_n`` from the reproduced responses; DF < 1.2 intact,
1.2 <= DF < 1.5 suspicious, DF >= 1.5 damaged.  A spring that never yielded has no
identifiable ``k2``/``fy``: its DF is only bounded (``DF <= max|θ| k1 / max|f| ≈ 1``) and it is
reported as intact with the identifiable flags false — never as numbers that look measured.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from enum import IntEnum
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import atomic_path
from pier_monitor.core.ingest.window import MeasuredWindow

__all__ = [
    "DamageState",
    "classify_ductility",
    "ductility_factors",
    "SectionResult",
    "IdentificationResult",
    "build_sections",
    "failed_result",
    "k1_change_pct",
]

SUSPICIOUS_DF = 1.2
DAMAGED_DF = 1.5


class DamageState(IntEnum):
    """State of a section; the values match ``SectionState.msg``."""

    INTACT = 0
    SUSPICIOUS = 1
    DAMAGED = 2
    UNKNOWN = 3


def classify_ductility(df: float) -> DamageState:
    """Intact / suspicious / damaged from a ductility factor (NaN → unknown)."""
    if not np.isfinite(df):
        return DamageState.UNKNOWN
    if df < SUSPICIOUS_DF:
        return DamageState.INTACT
    if df < DAMAGED_DF:
        return DamageState.SUSPICIOUS
    return DamageState.DAMAGED


def ductility_factors(theta: np.ndarray, params: SpringParameters) -> np.ndarray:
    """``max_t |θ_n| / θy_n`` for angles of shape (T, N); returns shape (N,)."""
    theta = np.asarray(theta, dtype=float)
    if theta.ndim != 2 or theta.shape[1] != params.n_springs:
        raise InputDataError(f"theta: expected shape (T, {params.n_springs}), got {theta.shape}")
    return np.max(np.abs(theta), axis=0) / params.yield_angles


def k1_change_pct(k1: np.ndarray, baseline_k1: np.ndarray) -> np.ndarray:
    """Change of ``k1`` against a baseline, %: ``100 (k1 / k1_baseline - 1)``, shape (N,).

    Raises
    ------
    InputDataError
        If the shapes differ or a baseline value is not finite and positive.
    """
    k1 = np.asarray(k1, dtype=float)
    base = np.asarray(baseline_k1, dtype=float)
    if base.shape != k1.shape:
        raise InputDataError(f"baseline k1: expected shape {k1.shape}, got {base.shape}")
    if not np.all(np.isfinite(base) & (base > 0)):
        raise InputDataError(f"baseline k1: expected finite positive values in N*m/rad, got "
                             f"{base.tolist()}")
    return 100.0 * (k1 / base - 1.0)


@dataclass(frozen=True)
class SectionResult:
    """Identified state of one section (spring ``index`` + 1 and its damper), SI units."""

    index: int
    z_bottom_m: float
    z_top_m: float
    k1: float
    k2: float
    fy: float
    c: float
    yield_angle_rad: float
    max_angle_rad: float
    ductility_factor: float
    state: str
    yielded: bool
    k2_identifiable: bool
    fy_identifiable: bool
    k1_change_pct: float | None = None

    @property
    def damage_state(self) -> DamageState:
        """The state as an enum."""
        return DamageState[self.state.upper()]


@dataclass(frozen=True)
class IdentificationResult:
    """Result of one identification (one event window).

    ``window_start_s`` is the window's first sample on the source's clock (s);
    ``window_start_ns`` the same instant in ns since the Unix epoch (0 when not known).
    ``k1_baseline`` says what the sections' ``k1_change_pct`` is relative to ("" when not
    stated), ``software_version`` the pier_monitor version that wrote the result.
    """

    pier_id: str
    event_id: str
    sections: tuple[SectionResult, ...]
    overall_state: str
    window_start_s: float
    window_duration_s: float
    epochs: int
    final_loss: float
    wall_time_s: float
    device: str
    success: bool = True
    message: str = ""
    settings: dict[str, Any] = field(default_factory=dict)
    history: dict[str, list[float]] = field(default_factory=dict)
    window_start_ns: int = 0
    k1_baseline: str = ""
    software_version: str = ""

    @property
    def params(self) -> SpringParameters:
        """The identified parameters as one set."""
        return SpringParameters(*(np.array([getattr(s, k) for s in self.sections])
                                  for k in ("k1", "k2", "fy", "c")))

    @property
    def ductility_factors(self) -> np.ndarray:
        """DF per section, shape (N,)."""
        return np.array([s.ductility_factor for s in self.sections])

    def with_k1_baseline(self, baseline_k1: np.ndarray, label: str) -> "IdentificationResult":
        """A copy whose ``k1_change_pct`` is relative to ``baseline_k1`` (N,), N·m/rad.

        ``label`` names the baseline (e.g. ``"design values"``, ``"event run1"``).
        """
        change = k1_change_pct(self.params.k1, baseline_k1)
        sections = tuple(replace(s, k1_change_pct=float(d)) for s, d in zip(self.sections, change))
        return replace(self, sections=sections, k1_baseline=label)

    def to_dict(self) -> dict[str, Any]:
        """Plain form for JSON."""
        d = asdict(self)
        d["sections"] = [asdict(s) for s in self.sections]
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "IdentificationResult":
        """Inverse of :meth:`to_dict`."""
        d = dict(d)
        d["sections"] = tuple(SectionResult(**s) for s in d["sections"])
        return cls(**d)

    def save_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` as JSON, atomically (a reader never sees half a file).

        Raises ``OSError`` when the file cannot be written.
        """
        path = Path(path)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(self.to_dict(), indent=2, allow_nan=True) + "\n",
                           encoding="utf-8")
        return path

    @classmethod
    def load_json(cls, path: str | Path) -> "IdentificationResult":
        """Read a file written by :meth:`save_json`."""
        return cls.from_dict(json.loads(Path(path).read_text()))


def build_sections(geometry: PierGeometry, params: SpringParameters, theta: np.ndarray,
                   yielded: np.ndarray, baseline_k1: np.ndarray | None = None
                   ) -> tuple[SectionResult, ...]:
    """Per-section results from identified parameters and reproduced angles (T, N).

    For springs that did not yield, ``fy`` is the lower bound ``max|f|`` the fit reports,
    so the DF given is an upper bound (about 1) and the identifiable flags are false.
    """
    z = geometry.level_heights_m
    max_angle = np.max(np.abs(theta), axis=0)
    df = max_angle / params.yield_angles
    # a spring that never yielded has θy >= max|θ|: its DF is at most 1, whatever fy bound the
    # fit could give (a poorly converged k1 would otherwise turn the bound into a large DF)
    df = np.where(np.asarray(yielded, dtype=bool), df, np.minimum(df, 1.0))
    change = None if baseline_k1 is None else k1_change_pct(params.k1, baseline_k1)
    out = []
    for i in range(geometry.n_levels):
        y = bool(yielded[i])
        out.append(SectionResult(
            index=i, z_bottom_m=float(z[i]), z_top_m=float(z[i + 1]), k1=float(params.k1[i]),
            k2=float(params.k2[i]), fy=float(params.fy[i]), c=float(params.c[i]),
            yield_angle_rad=float(params.yield_angles[i]), max_angle_rad=float(max_angle[i]),
            ductility_factor=float(df[i]),
            state=classify_ductility(df[i]).name.lower(), yielded=y, k2_identifiable=y,
            fy_identifiable=y, k1_change_pct=None if change is None else float(change[i])))
    return tuple(out)


def overall_state(sections: tuple[SectionResult, ...]) -> str:
    """The worst state over the sections."""
    known = [s.damage_state for s in sections if s.damage_state != DamageState.UNKNOWN]
    return (max(known) if known else DamageState.UNKNOWN).name.lower()


def failed_result(window: MeasuredWindow, *, device: str, message: str) -> IdentificationResult:
    """The result of an identification of ``window`` that failed (``success`` false).

    Every section is ``unknown`` with NaN parameters and no identifiable ``k2``/``fy``, so
    that a failure travels the same way as a diagnosis (result files, damage-state message)
    and is never read as one.

    Parameters
    ----------
    window : MeasuredWindow
        The window the identification was run on.
    device : str
        The training device asked for.
    message : str
        What went wrong.
    """
    nan = float("nan")
    z = window.geometry.level_heights_m
    sections = tuple(SectionResult(
        index=i, z_bottom_m=float(z[i]), z_top_m=float(z[i + 1]), k1=nan, k2=nan, fy=nan, c=nan,
        yield_angle_rad=nan, max_angle_rad=nan, ductility_factor=nan,
        state=DamageState.UNKNOWN.name.lower(), yielded=False, k2_identifiable=False,
        fy_identifiable=False) for i in range(window.n_levels))
    return IdentificationResult(
        pier_id=window.pier_id, event_id=window.event_id, sections=sections,
        overall_state=DamageState.UNKNOWN.name.lower(), window_start_s=float(window.t[0]),
        window_duration_s=window.duration_s, epochs=0, final_loss=nan, wall_time_s=0.0,
        device=device, success=False, message=message, window_start_ns=window.start_time_ns)
