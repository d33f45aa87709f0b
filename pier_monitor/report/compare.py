"""Change between two identifications of the same pier (e.g. two events).

:func:`compare_results` gives per section the change of ``k1`` (%), the ductility factor and
the state before and after, and a plain-language line such as
``section 1 (0.0-2.0 m): k1 -15.2 %, DF 1.65 -> 4.44, suspicious -> damaged``.  A spring that
never yielded has only an upper bound of its DF (about 1): it is written ``≤ 1.00``.

For ensemble identifications the change has its 90 % interval, and the state after is
decided with B's baseline being A (:meth:`IdentificationResult.with_baseline`): a ``k1`` loss
beyond the two identifications' scatter makes the section at least suspicious, with the
reason at the end of its line, e.g. ``section 2 (2.0-4.0 m): k1 -14.1 % [-16.0, -12.2],
DF ≤ 1.00 -> ≤ 1.00, intact -> suspicious (worse): k1 -14.1 % [-16.0, -12.2] against event
run1, beyond the identification scatter (1.1 %): cracking``.
:func:`write_comparison` writes the comparison as JSON and the two events' profiles as one
figure (the paper's Fig. 18).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from pier_monitor.core.identify.damage import DamageState, IdentificationResult, SectionResult
from pier_monitor.core.identify.states import is_diagnosis
from pier_monitor.core.errors import ReportError
from pier_monitor.core.fileio import to_strict_json

from ._common import (atomic_write_text, check_same_pier, engineering_scale, ensure_dir,
                      format_df, format_interval)
from .figures import plot_profile

__all__ = [
    "COMPARE_JSON",
    "COMPARE_PNG",
    "Comparison",
    "ComparisonPaths",
    "SectionChange",
    "compare_results",
    "write_comparison",
]

#: File names :func:`write_comparison` writes.
COMPARE_JSON = "compare.json"
COMPARE_PNG = "compare_profile.png"


@dataclass(frozen=True)
class SectionChange:
    """Change of one section between two results (``before`` = A, ``after`` = B), SI units.

    ``df_*_bound`` is true where that spring did not yield: the DF is then only an upper
    bound.  ``k1_change_pct = 100 (k1_after / k1_before − 1)``; for ensemble identifications
    ``k1_change_lo_pct``, ``k1_change_hi_pct`` are its 90 % interval and
    ``k1_change_scatter_pct`` the identifications' scatter (None otherwise).  ``state_after``
    is the worse of B's state and the state B gets against A as baseline; ``reasons`` explain
    a promoted state.
    """

    index: int
    z_bottom_m: float
    z_top_m: float
    k1_before: float
    k1_after: float
    k1_change_pct: float
    df_before: float
    df_after: float
    df_before_bound: bool
    df_after_bound: bool
    state_before: str
    state_after: str
    k1_change_lo_pct: float | None = None
    k1_change_hi_pct: float | None = None
    k1_change_scatter_pct: float | None = None
    reasons: tuple[str, ...] = ()

    @property
    def number(self) -> int:
        """1-based section number, counted from the bottom (the paper's spring ``n``)."""
        return self.index + 1

    @property
    def worsened(self) -> bool:
        """The state got worse (both states diagnoses: not unknown, not unreliable)."""
        before = DamageState[self.state_before.upper()]
        after = DamageState[self.state_after.upper()]
        return is_diagnosis(before) and is_diagnosis(after) and after > before

    def summary(self) -> str:
        """One line of plain language.

        E.g. ``section 1 (0.0-2.0 m): k1 -15.2 %, DF 1.65 -> 4.44, suspicious -> damaged``;
        ``≤`` before a DF marks the upper bound of a spring that did not yield, and
        ``(worse)`` ends the line when the state got worse.  With uncertainty the ``k1``
        change has its 90 % interval, and the reasons of a promoted state follow a colon.
        """
        dfa = format_df(self.df_before, not self.df_before_bound)
        dfb = format_df(self.df_after, not self.df_after_bound)
        line = (f"section {self.number} ({_span(self.z_bottom_m, self.z_top_m)}): "
                f"k1 {self.k1_change_pct:+.1f} %{self._interval()}, DF {dfa} -> {dfb}, "
                f"{self.state_before} -> {self.state_after}")
        if self.worsened:
            line += " (worse)"
        if self.reasons:
            line += ": " + "; ".join(self.reasons)
        return line

    def _interval(self) -> str:
        if self.k1_change_lo_pct is None:
            return ""
        return " " + format_interval(self.k1_change_lo_pct, self.k1_change_hi_pct, "+.1f")


@dataclass(frozen=True)
class Comparison:
    """Per-section change between result A (before) and result B (after) of one pier."""

    pier_id: str
    event_before: str
    event_after: str
    overall_before: str
    overall_after: str
    sections: tuple[SectionChange, ...]
    unreliable: tuple[str, ...] = ()

    def ranked_by_k1_change(self) -> tuple[SectionChange, ...]:
        """Sections from the largest ``k1`` loss to the largest gain."""
        return tuple(sorted(self.sections, key=lambda s: s.k1_change_pct))

    def headline(self) -> str:
        """One line over the whole pier: overall states and the largest ``k1`` loss."""
        line = (f"pier {self.pier_id}: {self.event_before} -> {self.event_after}: overall "
                f"{self.overall_before} -> {self.overall_after}")
        if self.unreliable:
            line += " (no diagnosis: an unreliable identification)"
        worst = self.ranked_by_k1_change()[0]
        if worst.k1_change_pct < 0:
            line += (f"; largest k1 loss in section {worst.number} "
                     f"({_span(worst.z_bottom_m, worst.z_top_m)}, {worst.k1_change_pct:+.1f} %"
                     f"{worst._interval()})")
        else:
            line += "; k1 did not decrease in any section"
        return line

    def summary_lines(self) -> list[str]:
        """The headline, then one line per section, bottom to top."""
        lines = [self.headline(), *self.unreliable] + [s.summary() for s in self.sections]
        if any(s.df_before_bound or s.df_after_bound for s in self.sections):
            lines.append("≤: the spring did not yield; its DF is only an upper bound and its "
                         "k2, fy are not identifiable")
        return lines

    def table(self) -> str:
        """A fixed-width table of the sections (k1 in a prefixed N·m/rad).

        With uncertainty a column gives the 90 % interval of the ``k1`` change.
        """
        k1 = [v for s in self.sections for v in (s.k1_before, s.k1_after)]
        fac, unit = engineering_scale(k1, "N*m/rad")
        spread = any(s.k1_change_lo_pct is not None for s in self.sections)
        head = (f"{'section':>7} {'z (m)':>11} {'k1 A (' + unit + ')':>18} "
                f"{'k1 B (' + unit + ')':>18} {'k1 change %':>11} "
                + (f"{'90 % interval':>16} " if spread else "")
                + f"{'DF A':>7} {'DF B':>7}  {'state A':<10} {'state B':<10}")
        rows = [head, "-" * len(head)]
        for s in self.sections:
            interval = (f"{format_interval(s.k1_change_lo_pct, s.k1_change_hi_pct, '+.1f'):>16} "
                        if spread else "")
            rows.append(
                f"{s.number:>7} {_span(s.z_bottom_m, s.z_top_m)[:-2]:>11} "
                f"{s.k1_before / fac:>18.3f} {s.k1_after / fac:>18.3f} "
                f"{s.k1_change_pct:>+11.1f} {interval}"
                f"{format_df(s.df_before, not s.df_before_bound):>7} "
                f"{format_df(s.df_after, not s.df_after_bound):>7}  "
                f"{s.state_before:<10} {s.state_after:<10}")
        return "\n".join([f"A = {self.event_before}, B = {self.event_after} "
                          f"(pier {self.pier_id})", *rows])

    def to_dict(self) -> dict[str, Any]:
        """Plain form for JSON, with the summary lines."""
        d = asdict(self)
        d["sections"] = [dict(asdict(s), reasons=list(s.reasons), summary=s.summary())
                         for s in self.sections]
        d["unreliable"] = list(self.unreliable)
        d["summary"] = self.summary_lines()
        return d


@dataclass(frozen=True)
class ComparisonPaths:
    """The files :func:`write_comparison` wrote."""

    compare_json: Path
    profile_png: Path


def compare_results(a: IdentificationResult, b: IdentificationResult) -> Comparison:
    """Per-section change from result ``a`` (before) to result ``b`` (after).

    An unreliable result (failed its self-check) is compared, but its states stay
    ``unreliable`` and :attr:`Comparison.unreliable` says which result it is and why: no
    change of state is concluded from it.

    Raises
    ------
    ReportError
        If the results are of different piers or geometry (the message says which field
        differs), or either identification failed.
    """
    check_same_pier([a, b], ["A", "B"])
    for name, r in (("A", a), ("B", b)):
        if not r.success:
            raise ReportError(f"result {name} (pier {r.pier_id!r}, event {r.event_id!r}) is a "
                              f"failed identification ({r.message or 'no message'}); its "
                              "sections are not to be trusted")
    against_a = b.with_baseline(a)
    sections = tuple(_section_change(sa, sb, sr)
                     for sa, sb, sr in zip(a.sections, b.sections, against_a.sections))
    unreliable = tuple(f"{name} ({r.event_id}) is unreliable, no diagnosis: "
                       + "; ".join(r.unreliable_reasons)
                       for name, r in (("A", a), ("B", b)) if r.unreliable_reasons)
    return Comparison(pier_id=a.pier_id, event_before=a.event_id, event_after=b.event_id,
                      overall_before=a.overall_state,
                      overall_after=_worse(b.overall_state, against_a.overall_state),
                      sections=sections, unreliable=unreliable)


def _worse(state: str, other: str) -> str:
    """The worse of two diagnoses; ``state`` when either is no diagnosis (unknown,
    unreliable)."""
    s, o = DamageState[state.upper()], DamageState[other.upper()]
    return state if not (is_diagnosis(s) and is_diagnosis(o)) or s >= o else other


def _section_change(sa: SectionResult, sb: SectionResult, against_a: SectionResult
                    ) -> SectionChange:
    """Section ``sb`` of B against ``sa`` of A; ``against_a`` is ``sb`` with A as baseline."""
    state = _worse(sb.state, against_a.state)
    # B's own reasons (e.g. against its stored baseline) stay; those against A come first
    reasons = against_a.reasons + tuple(r for r in sb.reasons if r not in against_a.reasons)
    return SectionChange(
        index=sa.index, z_bottom_m=sa.z_bottom_m, z_top_m=sa.z_top_m, k1_before=sa.k1,
        k1_after=sb.k1, k1_change_pct=float(against_a.k1_change_pct),
        df_before=sa.ductility_factor, df_after=sb.ductility_factor,
        df_before_bound=sa.ductility_factor_upper_bound,
        df_after_bound=sb.ductility_factor_upper_bound,
        state_before=sa.state, state_after=state,
        k1_change_lo_pct=against_a.k1_change_lo_pct, k1_change_hi_pct=against_a.k1_change_hi_pct,
        k1_change_scatter_pct=against_a.k1_change_scatter_pct, reasons=reasons)


def write_comparison(a: IdentificationResult, b: IdentificationResult, out_dir: str | Path, *,
                     sources: tuple[str, str] | None = None) -> tuple[Comparison, ComparisonPaths]:
    """Compare two results; write ``compare.json`` and ``compare_profile.png`` to ``out_dir``.

    Parameters
    ----------
    a, b : IdentificationResult
        Before and after (same pier).
    out_dir : str or Path
        Output directory (created when missing).
    sources : (str, str), optional
        Where the results came from, recorded in the JSON.

    Raises
    ------
    ReportError
        As :func:`compare_results`, or naming ``out_dir`` when it cannot be written.
    """
    comparison = compare_results(a, b)
    out = ensure_dir(out_dir)
    paths = ComparisonPaths(compare_json=out / COMPARE_JSON, profile_png=out / COMPARE_PNG)
    doc = comparison.to_dict()
    if sources is not None:
        doc["sources"] = {"A": str(sources[0]), "B": str(sources[1])}
    atomic_write_text(paths.compare_json, to_strict_json(doc, indent=2) + "\n")
    plot_profile([a, b], [f"A: {a.event_id}", f"B: {b.event_id}"], paths.profile_png)
    return comparison, paths


def _span(z0: float, z1: float) -> str:
    """``0.0-2.0 m`` (one decimal unless that would round the height)."""
    f = lambda z: f"{z:.1f}" if abs(round(z, 1) - z) < 1e-9 else f"{z:g}"
    return f"{f(z0)}-{f(z1)} m"
