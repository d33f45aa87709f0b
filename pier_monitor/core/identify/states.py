"""Damage states of a section and the ductility-factor thresholds between them (SPEC §5).

DF < 1.2 intact, 1.2 <= DF < 1.5 suspicious, DF >= 1.5 damaged.  A spring that never yielded
is intact whatever bound of its DF the fit gives.  Two states are no diagnosis: *unknown*
(nothing was identified: the identification or the ingest of the event failed) and
*unreliable* (an identification ran, but its result failed its self-check,
:func:`~pier_monitor.core.identify.checks.check_identification`: its numbers are reported,
its state is not intact, suspicious or damaged).  :mod:`~pier_monitor.core.identify.damage`
re-exports these names; the decisions that use them live there.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np

__all__ = ["DamageState", "SUSPICIOUS_DF", "DAMAGED_DF", "DIAGNOSES", "classify_ductility",
           "is_diagnosis", "member_states"]

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
    UNRELIABLE = 4


#: The states that are a diagnosis, from the best to the worst; the others (unknown,
#: unreliable) say that there is none and are never ordered against them.
DIAGNOSES = (DamageState.INTACT, DamageState.SUSPICIOUS, DamageState.DAMAGED)


def is_diagnosis(state: DamageState | str) -> bool:
    """Whether ``state`` (an enum or its lower-case name) is intact, suspicious or damaged."""
    if isinstance(state, str):
        state = DamageState[state.upper()]
    return state in DIAGNOSES


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
