"""Hand-made ensemble identifications: member arrays with a known spread, and their results.

The members are deterministic: :func:`normal_members` places M values at the quantiles of a
normal distribution, so their mean is exact and their standard deviation and percentiles
are those of the distribution to within a few per cent.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import norm

from pier_monitor.core.identify.damage import IdentificationResult, build_sections, overall_state
from pier_monitor.core.identify.uncertainty import overall_state_probabilities, summarize_members
from pier_monitor.core.model.config import PierGeometry, SpringParameters

#: Members of the hand-made ensembles.
MEMBERS = 200
FY = 5.0e6  # N·m
C = 2.0e7  # N·m·s/rad


def normal_members(mean: float, std: float, m: int = MEMBERS) -> np.ndarray:
    """M values at the normal quantiles ``(i + 0.5) / M`` of N(mean, std²), shape (M,)."""
    return mean + std * norm.ppf((np.arange(m) + 0.5) / m)


def yielded_members(p: float, m: int = MEMBERS) -> np.ndarray:
    """Yield flags of M members of which a share ``p`` (rounded) yielded, shape (M,)."""
    flags = np.zeros(m, dtype=bool)
    flags[:round(p * m)] = True
    return flags


def ensemble_result(event_id: str, k1: Sequence[np.ndarray], df: Sequence[np.ndarray],
                    yielded: Sequence[np.ndarray], *, pier_id: str = "p1",
                    baseline_k1: np.ndarray | None = None,
                    window_start_ns: int = 0) -> IdentificationResult:
    """A result of sections 2 m high from member arrays, one (M,) array per section.

    ``k2 = k1 / 10``, ``fy`` and ``c`` are the same in every member.  The point estimate is
    the members' mean; a section is reported yielded when most members yielded, and its
    DF is the members' mean (capped at 1 where it is reported not yielded).
    """
    k1 = np.stack(k1, axis=1)
    df = np.stack(df, axis=1)
    yielded = np.stack(yielded, axis=1)
    m, n = k1.shape
    params = np.stack([k1, k1 / 10.0, np.full((m, n), FY), np.full((m, n), C)], axis=-1)
    uncertainty = summarize_members(params, df, yielded)
    mean = params.mean(axis=0)
    point = SpringParameters(mean[:, 0], mean[:, 1], mean[:, 2], mean[:, 3])
    df_point = df.mean(axis=0)
    # angles whose largest magnitude gives the point DF exactly
    theta = np.array([[0.0], [1.0], [-0.5]]) * (df_point * point.yield_angles)[None, :]
    geometry = PierGeometry(np.full(n, 2.0), np.full(n, 1.0e5))
    sections = build_sections(geometry, point, theta, yielded.mean(axis=0) >= 0.5,
                              baseline_k1=baseline_k1, uncertainty=uncertainty)
    return IdentificationResult(
        pier_id=pier_id, event_id=event_id, sections=sections,
        overall_state=overall_state(sections), window_start_s=10.0, window_duration_s=20.0,
        epochs=300, final_loss=1e-5, wall_time_s=12.0, device="cpu",
        window_start_ns=window_start_ns,
        p_overall_state=overall_state_probabilities(df, yielded) if m > 1 else None)
