"""Damage states of a section and the ductility-factor thresholds between them (SPEC §5).

DF < 1.2 intact, 1.2 <= DF < 1.5 suspicious, DF >= 1.5 damaged.  A spring that never yielded
is intact whatever bound of its DF the fit gives.  :mod:`~pier_monitor.core.identify.damage`
re-exports these names; the decisions that use them live there.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

__all__ = ["DamageState", "SUSPICIOUS_DF", "DAMAGED_DF", "classify_ductility", "member_states"]

#: Lowest ductility factor of a suspicious section (dimensionless).
SUSPICIOUS_DF = 1.2
#: Lowest ductility factor of a damaged section (dimensionless).
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


def member_states(ductility: np.ndarray, yielded: np.ndarray) -> np.ndarray:
    """The state code of every member and section; a spring that did not yield is intact.

    Parameters
    ----------
    ductility : ndarray, shape (M, N)
        Finite ductility factors of M members and N sections.
    yielded : ndarray of bool, shape (M, N)
        Whether the member's spring yielded.

    Returns
    -------
    ndarray of int, shape (M, N)
        :class:`DamageState` codes (never ``UNKNOWN``), as :func:`classify_ductility` gives
        for a spring that yielded.
    """
    codes = np.digitize(np.asarray(ductility, dtype=float), [SUSPICIOUS_DF, DAMAGED_DF])
    return np.where(np.asarray(yielded, dtype=bool), codes, int(DamageState.INTACT))
