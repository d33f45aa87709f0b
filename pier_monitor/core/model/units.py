"""Unit conversion of measured quantities to SI.

Units are plain strings as they appear in pier configurations and in the
``unit`` field of sample blocks.  Conversion factors multiply a value in the
named unit to give SI (m/s^2, m/s, m).
"""

from __future__ import annotations

from pier_monitor.core.errors import ConfigError

__all__ = ["G_STANDARD", "UNIT_FACTORS", "to_si_factor"]

G_STANDARD = 9.80665  # m/s^2

# kind -> unit -> factor to SI
UNIT_FACTORS: dict[str, dict[str, float]] = {
    "acceleration": {"m/s^2": 1.0, "mps2": 1.0, "g": G_STANDARD, "gal": 0.01, "cm/s^2": 0.01,
                     "mgal": 1e-5},
    "velocity": {"m/s": 1.0, "cm/s": 0.01, "kine": 0.01, "mm/s": 1e-3},
    "displacement": {"m": 1.0, "cm": 0.01, "mm": 1e-3},
}


def to_si_factor(kind: str, unit: str) -> float:
    """Return the factor that converts a value of ``kind`` in ``unit`` to SI.

    Raises
    ------
    ConfigError
        If the kind or the unit is unknown.
    """
    try:
        table = UNIT_FACTORS[kind]
    except KeyError:
        raise ConfigError(
            f"unknown quantity kind {kind!r}; expected one of {sorted(UNIT_FACTORS)}") from None
    try:
        return table[unit]
    except KeyError:
        raise ConfigError(
            f"unknown unit {unit!r} for {kind}; expected one of {sorted(table)}") from None
