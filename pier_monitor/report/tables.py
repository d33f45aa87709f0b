"""Text tables of an identification's uncertainty (ensemble identifications).

:func:`uncertainty_table` gives, per section, the mean and 90 % interval of ``k1, k2, fy, c``
and the ductility factor, the probability that the spring yielded and the probability of
each state, then the reasons of the promoted states, e.g.::

    uncertainty over 8 members: mean [90 % interval, 5th-95th percentile of the members]
    section  k1 (GN·m/rad)          ...  DF                 P(yielded)  P(intact/susp./dam.)
          1  1.210 [1.190, 1.232]   ...  1.32 [1.18, 1.46]        1.00  0.12 / 0.63 / 0.25
    section 1: DF 90 % interval [1.18, 1.46] straddles 1.2

A ``*`` marks a poorly identified quantity (its 90 % interval wider than
:data:`~pier_monitor.core.identify.damage.IDENTIFIABILITY_LIMITS` allows), named again under
the table with its interval.  A single identification has no interval: the table is the
line ``intervals: no interval (1 member)``.
"""

from __future__ import annotations

from pier_monitor.core.identify.damage import (IDENTIFIABILITY_LIMITS,
                                               IdentificationResult, SectionResult)
from pier_monitor.core.identify.uncertainty import Spread

from ._common import engineering_scale, format_interval

__all__ = ["uncertainty_table"]

#: Quantities of the table: attribute of the uncertainty, column name, SI unit.
_QUANTITIES = (("k1", "k1", "N·m/rad"), ("k2", "k2", "N·m/rad"), ("fy", "fy", "N·m"),
               ("c", "c", "N·m·s/rad"))


def _cell(spread: Spread, factor: float, fmt: str) -> str:
    if not spread.defined:
        return "n/a"
    return (f"{spread.mean / factor:{fmt}} "
            f"{format_interval(spread.lo / factor, spread.hi / factor, fmt)}")


def uncertainty_table(result: IdentificationResult) -> str:
    """The uncertainty of every section as a fixed-width table, then the reasons and the
    poorly identified quantities.

    ``intervals: no interval (1 member)`` for a result without uncertainty (a single
    identification).  ``k2`` and ``fy`` are
    over the members whose spring yielded (``n/a`` when none did); the change of ``k1`` is
    against an earlier event (``-`` for the first event of a pier), ``vs design`` the
    difference from the design values (not a change); ``≤`` marks the DF of a spring that
    did not yield (an upper bound).
    """
    sections = [s for s in result.sections if s.uncertainty is not None]
    if not sections:
        return f"intervals: {result.intervals}"
    scales = {}
    for name, _, unit in _QUANTITIES:
        values = [v for s in sections for v in (getattr(s.uncertainty, name).lo,
                                                getattr(s.uncertainty, name).hi)]
        scales[name] = engineering_scale(values, unit)
    cols = [(f"{label} ({scales[name][1]})", name) for name, label, _ in _QUANTITIES]
    width = 22
    head = (f"{'section':>7}  " + "  ".join(f"{title:<{width}}" for title, _ in cols)
            + f"  {'DF':<18} {'P(yielded)':>10}  {'P(intact/susp./dam.)':<20}  "
            + f"{'k1 change % [90 %]':<20}  vs design %")
    rows = [f"uncertainty over {result.members} members: mean [90 % interval, 5th-95th "
            "percentile of the members]", head, "-" * len(head)]
    for s in sections:
        u = s.uncertainty
        flag = {name: "*" if name in s.poorly_identified else "" for name in IDENTIFIABILITY_LIMITS}
        cells = "  ".join(f"{_cell(getattr(u, name), scales[name][0], '.3f') + flag[name]:<{width}}"
                          for _, name in cols)
        p = " / ".join(f"{v:.2f}" for v in u.p_state)
        change = "-" if s.k1_change_pct is None else (
            f"{s.k1_change_pct:+.1f} "
            f"{format_interval(s.k1_change_lo_pct, s.k1_change_hi_pct, '+.1f')}")
        design = "" if s.k1_vs_design_pct is None else f"{s.k1_vs_design_pct:+.1f}"
        df = ("≤ " if s.ductility_factor_upper_bound else "") + _cell(u.ductility_factor, 1.0, '.2f') + flag["DF"]
        rows.append(f"{s.index + 1:>7}  {cells}  {df:<18} "
                    f"{u.p_yielded:>10.2f}  {p:<20}  {change:<20}  {design}")
    rows += [f"section {s.index + 1}: {s.state}: {reason}" for s in sections
             for reason in s.reasons]
    limits = ", ".join(f"{k} ±{100 * v:.0f} %" for k, v in IDENTIFIABILITY_LIMITS.items())
    for s in sections:
        if s.poorly_identified:
            rows.append(f"section {s.index + 1}: * poorly identified (90 % interval wider than "
                        f"{limits}): " + "; ".join(_flagged(s, name)
                                                   for name in s.poorly_identified))
    return "\n".join(rows)


def _flagged(section: SectionResult, name: str) -> str:
    """A poorly identified quantity with its interval and relative half-width."""
    spread = getattr(section.uncertainty, "ductility_factor" if name == "DF" else name)
    half = spread.relative_half_width()
    width = f" ±{100 * half:.0f} %" if half == half else " (too few members yielded)"
    return f"{name} {format_interval(spread.lo, spread.hi, '.3g')}{width}"
