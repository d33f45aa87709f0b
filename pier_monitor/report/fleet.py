"""The state of a network of piers: a ranked table, JSON, figure, mcap.

Renders only: the rows come read from a results store
(:func:`~pier_monitor.fleet.summary.summarize_store`: each pier's latest event — a result,
or a failure record — and, with its previous reliable event, the change of each section's
``k1`` against it).  :meth:`FleetSummary.ranked` ranks the piers by the worst state
(damaged, suspicious, unreliable, unknown — a pier whose identification failed or failed its
self-check cannot be cleared — then intact) and then by the largest ductility factor.

:func:`write_fleet_summary` writes into a directory:

* ``fleet.json`` — the ranked piers (state, DF and state per section, k1 change against the
  previous event), the state counts, the failed events with their reasons, and what the run
  that wrote it did;
* ``fleet.png`` — piers down the side (worst first), sections along the height (bottom to
  top, left to right), each cell coloured by its state and labelled with its DF;
* ``fleet_state.mcap`` — per pier its latest ``PierDamageState``, markers and diagnostics
  (:func:`~pier_monitor.report.results.write_damage_states_mcap`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.patches import Patch, Rectangle

from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.fileio import to_strict_json

from ._common import STATE_COLORS, atomic_write_text, ensure_dir, format_df
from .figures import _figure, _save, _style
from .results import write_damage_states_mcap

__all__ = ["FLEET_JSON", "FLEET_PNG", "FLEET_STATE_MCAP", "FleetPaths", "FleetSummary",
           "PierRow", "STATE_RANK", "plot_fleet", "write_fleet_summary"]

FLEET_JSON = "fleet.json"
FLEET_PNG = "fleet.png"
FLEET_STATE_MCAP = "fleet_state.mcap"
#: Order of the piers in the summary: worst state first.
STATE_RANK = {"damaged": 0, "suspicious": 1, "unreliable": 2, "unknown": 3, "intact": 4}


@dataclass(frozen=True)
class PierRow:
    """One pier in the fleet summary.

    Attributes
    ----------
    result : IdentificationResult
        The pier's latest event (a failure record when its identification failed).
    events : int
        Events of the pier in the store (results and failures).
    previous : IdentificationResult or None
        The pier's latest reliable event before ``result``.
    k1_change_pct : ndarray (N,) or None
        ``k1`` of each section against ``previous``, %; None without one.
    """

    result: IdentificationResult
    events: int
    previous: IdentificationResult | None
    k1_change_pct: np.ndarray | None

    @property
    def pier_id(self) -> str:
        return self.result.pier_id

    @property
    def state(self) -> str:
        """The latest event's overall state (``unknown`` when it failed)."""
        return self.result.overall_state if self.result.success else "unknown"

    @property
    def max_df(self) -> tuple[float, int | None]:
        """The largest DF and its section (1-based); NaN, None without a diagnosis."""
        df = self.result.ductility_factors
        if not self.result.success or not np.any(np.isfinite(df)):
            return math.nan, None
        i = int(np.nanargmax(df))
        return float(df[i]), i + 1

    def sort_key(self) -> tuple[int, float, str]:
        df, _ = self.max_df
        return STATE_RANK[self.state], -(df if math.isfinite(df) else -math.inf), self.pier_id

    def to_dict(self) -> dict[str, Any]:
        """Plain form, for JSON."""
        df, section = self.max_df
        r = self.result
        return {
            "pier_id": self.pier_id, "state": self.state, "event_id": r.event_id,
            "events": self.events, "success": r.success, "message": r.message,
            "max_ductility_factor": None if section is None else df,
            "max_ductility_factor_section": section,
            "previous_event_id": None if self.previous is None else self.previous.event_id,
            "k1_change_vs_previous_pct": None if self.k1_change_pct is None
            else [float(v) for v in self.k1_change_pct],
            "sections": [{"index": s.index, "z_bottom_m": s.z_bottom_m, "z_top_m": s.z_top_m,
                          "state": s.state, "ductility_factor": None if not math.isfinite(
                              s.ductility_factor) else s.ductility_factor,
                          "yielded": s.yielded,
                          "ductility_factor_upper_bound": s.ductility_factor_upper_bound,
                          "k1": None if not math.isfinite(s.k1) else s.k1}
                         for s in r.sections],
        }


@dataclass(frozen=True)
class FleetSummary:
    """The ranked piers of a store and its failed events."""

    rows: tuple[PierRow, ...]
    failures: tuple[IdentificationResult, ...]

    @classmethod
    def ranked(cls, rows: Sequence[PierRow], failures: Sequence[IdentificationResult]
               ) -> FleetSummary:
        """The summary of ``rows`` ranked worst first (module documentation), and the failed
        events ``failures``."""
        return cls(rows=tuple(sorted(rows, key=PierRow.sort_key)), failures=tuple(failures))

    def counts(self) -> dict[str, int]:
        """Piers per state."""
        return {state: sum(r.state == state for r in self.rows) for state in STATE_RANK}

    def to_dict(self) -> dict[str, Any]:
        """Plain form, for JSON."""
        return {"format": "pier_monitor fleet 1", "piers": [r.to_dict() for r in self.rows],
                "counts": self.counts(),
                "failed_events": [{"event_id": f.event_id, "pier_id": f.pier_id,
                                   "message": f.message} for f in self.failures]}

    def table(self) -> str:
        """The ranked table: state, largest DF, largest k1 loss against the previous event."""
        lines = [f"{'#':>3} {'pier':<16} {'state':<10} {'max DF':>12} "
                 f"{'k1 vs previous event':>24} {'events':>6}  latest event"]
        for i, row in enumerate(self.rows, 1):
            df, section = row.max_df
            df_text = "n/a" if section is None else \
                f"{format_df(df, not row.result.sections[section - 1].ductility_factor_upper_bound)} (S{section})"
            if row.k1_change_pct is None:
                change = "-"
            else:
                j = int(np.argmin(row.k1_change_pct))
                change = f"{row.k1_change_pct[j]:+.1f} % (S{j + 1})"
            tail = row.result.event_id if row.result.success else \
                f"{row.result.event_id}: {row.result.message}"
            lines.append(f"{i:>3} {row.pier_id:<16} {row.state:<10} {df_text:>12} "
                         f"{change:>24} {row.events:>6}  {tail}")
        counts = self.counts()
        lines.append(f"{len(self.rows)} piers: " + ", ".join(f"{counts[s]} {s}"
                                                              for s in STATE_RANK))
        return "\n".join(lines)


def plot_fleet(summary: FleetSummary, path: str | Path) -> Path:
    """Piers down the side (worst first), sections along the height, state colours, DF labels.

    Raises
    ------
    ReportError
        Naming the path, if it cannot be written.
    """
    rows = summary.rows
    n_cols = max((len(r.result.sections) for r in rows), default=1)
    height = min(0.32 * len(rows) + 1.6, 120.0)
    with _style():
        fig = _figure((max(5.0, 1.1 * n_cols + 3.2), height))
        ax = fig.add_subplot()
        for i, row in enumerate(rows):
            for s in row.result.sections:
                state = s.state if row.result.success else "unknown"
                ax.add_patch(_cell(s.index, i, STATE_COLORS[state]))
                label = format_df(s.ductility_factor, not s.ductility_factor_upper_bound) if row.result.success else "—"
                ax.text(s.index, i, label, ha="center", va="center", fontsize=8)
        ax.set_xlim(-0.5, n_cols - 0.5)
        ax.set_ylim(max(len(rows), 1) - 0.5, -0.5)
        ax.set_xticks(range(n_cols), [f"S{k + 1}" for k in range(n_cols)])
        ax.set_yticks(range(len(rows)), [r.pier_id for r in rows])
        ax.set_xlabel("section, bottom to top (label: ductility factor)")
        ax.grid(False)
        counts = summary.counts()
        ax.set_title(f"{len(rows)} piers: " + ", ".join(f"{counts[s]} {s}" for s in STATE_RANK))
        ax.legend(handles=[Patch(color=STATE_COLORS[s], label=s) for s in STATE_RANK],
                  loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
        return _save(fig, path)


def _cell(x: int, y: int, color: str) -> Rectangle:
    return Rectangle((x - 0.46, y - 0.42), 0.92, 0.84, color=color, lw=0)


@dataclass(frozen=True)
class FleetPaths:
    """The files :func:`write_fleet_summary` wrote."""

    fleet_json: Path
    fleet_png: Path
    fleet_state_mcap: Path | None


def write_fleet_summary(summary: FleetSummary, out_dir: str | Path, *,
                        run: dict[str, Any] | None = None) -> FleetPaths:
    """Write ``fleet.json``, ``fleet.png`` and ``fleet_state.mcap`` (no mcap without piers).

    Parameters
    ----------
    summary : FleetSummary
        What to write.
    out_dir : str or Path
        The results root.
    run : dict, optional
        What the run did (counts, times, backend), stored under ``"run"`` in the JSON.

    Raises
    ------
    ReportError
        Naming the file that cannot be written.
    """
    out = ensure_dir(out_dir)
    paths = FleetPaths(out / FLEET_JSON, out / FLEET_PNG,
                       out / FLEET_STATE_MCAP if summary.rows else None)
    if paths.fleet_state_mcap is not None:
        write_damage_states_mcap([r.result for r in summary.rows], paths.fleet_state_mcap)
    plot_fleet(summary, paths.fleet_png)
    doc = {**summary.to_dict(), "run": run or {}}
    atomic_write_text(paths.fleet_json, to_strict_json(doc, indent=1) + "\n")
    return paths
