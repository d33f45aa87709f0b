"""Mainshock detection: a causal trigger on the foundation acceleration, Arias windows."""

from __future__ import annotations

from datetime import datetime, timezone
from typing import NamedTuple

import numpy as np

from pier_monitor.core.ingest.recording import NS_PER_S
from pier_monitor.core.ingest.settings import IngestSettings
from pier_monitor.core.model.config import PierConfig

__all__ = ["EventSpan", "detect_events", "make_event_id", "trigger_threshold"]


def _moving_rms(x: np.ndarray, n_win: int) -> np.ndarray:
    """Causal moving RMS about the moving mean over the last ``n_win`` samples, shape like
    ``x`` (T,) or (T, C) summed over columns: a sensor bias does not trigger."""
    x = x.reshape(x.shape[0], -1)
    c1 = np.concatenate((np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)))
    c2 = np.concatenate((np.zeros((1, x.shape[1])), np.cumsum(x * x, axis=0)))
    i = np.arange(1, x.shape[0] + 1)
    lo = np.maximum(0, i - n_win)
    cnt = np.maximum(i - lo, 1)[:, None]
    mean = (c1[i] - c1[lo]) / cnt
    var = np.maximum((c2[i] - c2[lo]) / cnt - mean ** 2, 0.0)
    return np.sqrt(var.sum(axis=1))


class EventSpan(NamedTuple):
    """A detected event: window ``[start, end)`` in samples, and whether the data begin or
    end while the ground is still shaking (the event is then cut, not complete)."""

    start: int
    end: int
    cut_start: bool = False
    cut_end: bool = False


def detect_events(ag: np.ndarray, rate_hz: float, threshold_mps2: float,
                  settings: IngestSettings) -> list[EventSpan]:
    """Event windows in a foundation acceleration record (m/s²), shape (T,) or (T, C)
    (horizontal components); NaN rows are samples without data.

    A causal moving RMS (about the moving mean) above ``threshold_mps2`` triggers; triggers
    closer than ``merge_gap_s`` merge; spans shorter than ``min_event_s`` are dropped; each
    event's window spans ``arias_bounds`` of its Arias intensity, padded by ``pad_s``.  An
    event whose trigger is still on within ``merge_gap_s`` of the last sample with data (or
    was already on at the first) is cut by the end (start) of the data.
    """
    ag = np.asarray(ag, dtype=float)
    ag = ag.reshape(ag.shape[0], -1)
    valid = np.flatnonzero(np.isfinite(ag).all(axis=1))
    if valid.size == 0:
        return []
    ag = np.nan_to_num(ag)
    n_win = max(1, int(round(settings.trigger_window_s * rate_hz)))
    on = _moving_rms(ag, n_win) > threshold_mps2
    idx = np.flatnonzero(on)
    if idx.size == 0:
        return []
    gap = int(round(settings.merge_gap_s * rate_hz))
    breaks = np.flatnonzero(np.diff(idx) > gap)
    spans = zip(np.concatenate(([idx[0]], idx[breaks + 1])), np.concatenate((idx[breaks], [idx[-1]])))
    out = []
    n = ag.shape[0]
    for s0, s1 in spans:
        # the trigger lags by the RMS window: the event began up to n_win earlier
        a0 = max(0, s0 - n_win)
        a1 = min(n, s1 + 1)
        if (a1 - a0) / rate_hz < settings.min_event_s:
            continue
        seg = ag[a0:a1]
        energy = np.cumsum(np.sum((seg - seg.mean(axis=0)) ** 2, axis=1))
        lo = a0 + int(np.searchsorted(energy, settings.arias_bounds[0] * energy[-1]))
        hi = a0 + int(np.searchsorted(energy, settings.arias_bounds[1] * energy[-1])) + 1
        pad = int(round(settings.pad_s * rate_hz))
        out.append(EventSpan(max(0, lo - pad), min(n, hi + pad),
                             cut_start=s0 - n_win <= valid[0],
                             cut_end=s1 > valid[-1] - gap))
    return out


def make_event_id(pier_id: str, start_ns: int) -> str:
    """``<pier>_<UTC start of the window>``, e.g. ``pier7_20240312T010027Z``."""
    stamp = datetime.fromtimestamp(start_ns // NS_PER_S, tz=timezone.utc)
    return f"{pier_id}_{stamp.strftime('%Y%m%dT%H%M%SZ')}"


def trigger_threshold(config: PierConfig, settings: IngestSettings) -> float:
    noise = [s.noise_rms * s.si_factor / abs(s.gain) for s in config.sensors
             if s.level == 0 and s.kind == "acceleration"]
    return max(settings.trigger_floor_mps2,
               settings.trigger_noise_factor * (max(noise) if noise else 0.0))
