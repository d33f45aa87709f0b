"""``/diagnostics`` of a damage state as plain fields: what the identifier node publishes and
what the results mcap carries.

One ``DiagnosticStatus`` per section (OK / WARN / ERROR for intact / suspicious / damaged,
WARN for an unreliable result, with the reasons, STALE when there is no diagnosis), then the
identifier's (OK; WARN with the reasons when the result is unreliable; ERROR when the
identification failed).  :func:`diagnostics_fields` maps the fields of a damage state
(:func:`~pier_monitor.report.results.damage_state_fields`) to those of a
``diagnostic_msgs/DiagnosticArray``, levels as integers.
"""

from __future__ import annotations

import math
from typing import Any

from pier_monitor.core.identify.damage import DamageState
from pier_monitor.core.ingest.recording import ns_to_stamp

__all__ = ["DIAGNOSTICS_TOPIC", "DIAGNOSTIC_ARRAY_TYPE", "DIAGNOSTIC_LEVELS",
           "diagnostics_fields"]

#: Topic and type of the diagnostics.
DIAGNOSTICS_TOPIC = "/diagnostics"
DIAGNOSTIC_ARRAY_TYPE = "diagnostic_msgs/msg/DiagnosticArray"
#: ``DiagnosticStatus`` level (OK 0, WARN 1, ERROR 2, STALE 3) of each section state.
DIAGNOSTIC_LEVELS = {DamageState.INTACT: 0, DamageState.SUSPICIOUS: 1, DamageState.DAMAGED: 2,
                     DamageState.UNKNOWN: 3, DamageState.UNRELIABLE: 1}


def _fmt(value: float | None) -> str:
    return "nan" if value is None or not math.isfinite(value) else f"{value:.6g}"


def _interval(lo: float, hi: float) -> str:
    return f"[{_fmt(lo)}, {_fmt(hi)}]"


def _has_uncertainty(section: dict[str, Any]) -> bool:
    return math.isfinite(section["p_yielded"])


def _section_message(fields: dict[str, Any], s: dict[str, Any], state: str) -> str:
    if not fields["success"]:
        return f"no diagnosis: {fields['message']}"[:500]
    if state == "unreliable":
        return (f"unreliable, no diagnosis: {'; '.join(s['reasons'])} (DF "
                f"{_fmt(s['ductility_factor'])}, event {fields['event_id']})")[:500]
    if not _has_uncertainty(s):
        return (f"{state}: DF {_fmt(s['ductility_factor'])}, k1 change "
                f"{_fmt(s['k1_change_pct'])} % (event {fields['event_id']})")
    p_state = s[f"p_{state}"] if state in ("intact", "suspicious", "damaged") else math.nan
    text = (f"{state} (P {p_state:.2f}): DF {_fmt(s['ductility_factor'])} "
            f"{_interval(s['ductility_factor_lo'], s['ductility_factor_hi'])}, k1 change "
            f"{_fmt(s['k1_change_pct'])} % "
            f"{_interval(s['k1_change_lo_pct'], s['k1_change_hi_pct'])} "
            f"(event {fields['event_id']}, {fields['members']} members)")
    if s["reasons"]:
        text += "; " + "; ".join(s["reasons"])
    return text[:500]


def _uncertainty_values(s: dict[str, Any]) -> list[tuple[str, str]]:
    """Key-values of a section's uncertainty (none for a single identification)."""
    if not _has_uncertainty(s):
        return []
    return [("k1_std", _fmt(s["k1_std"])), ("k1_90pct", _interval(s["k1_lo"], s["k1_hi"])),
            ("k1_change_90pct", _interval(s["k1_change_lo_pct"], s["k1_change_hi_pct"])),
            ("k1_change_scatter_pct", _fmt(s["k1_change_scatter_pct"])),
            ("ductility_factor_90pct",
             _interval(s["ductility_factor_lo"], s["ductility_factor_hi"])),
            ("p_yielded", _fmt(s["p_yielded"])), ("p_intact", _fmt(s["p_intact"])),
            ("p_suspicious", _fmt(s["p_suspicious"])), ("p_damaged", _fmt(s["p_damaged"])),
            ("reasons", "; ".join(s["reasons"]))]


def diagnostics_fields(fields: dict[str, Any], stamp_ns: int) -> dict[str, Any]:
    """The fields of the ``DiagnosticArray`` of a damage state.

    A section's status has the values k1, its change from the baseline, DF, k2, fy and c; a
    section identified by an ensemble also ``k1_std``, the 90 % intervals ``k1_90pct``,
    ``k1_change_90pct`` and ``ductility_factor_90pct`` (``[lo, hi]``),
    ``k1_change_scatter_pct``, ``p_yielded``, ``p_intact``, ``p_suspicious``, ``p_damaged``
    and ``reasons`` (``; ``-separated, empty when the state is the most probable one).  The
    identifier's status has the event, epochs, device and number of members.

    Parameters
    ----------
    fields : dict
        :func:`~pier_monitor.report.results.damage_state_fields` of the result.
    stamp_ns : int
        ``header.stamp``, ns since the Unix epoch.

    Returns
    -------
    dict
        ``header`` and ``status`` (a list of dicts with ``level`` an int 0-3, ``name``,
        ``message``, ``hardware_id`` and ``values``, a list of ``{"key", "value"}``).
    """
    sec, nanosec = ns_to_stamp(stamp_ns)
    pier = fields["pier_id"]
    status = []
    for s in fields["sections"]:
        state = DamageState(s["state"]).name.lower()
        message = _section_message(fields, s, state)
        values = (("event_id", fields["event_id"]), ("state", state),
                  ("z_bottom_m", _fmt(s["z_bottom_m"])), ("z_top_m", _fmt(s["z_top_m"])),
                  ("k1", _fmt(s["k1"])), ("k1_change_pct", _fmt(s["k1_change_pct"])),
                  ("ductility_factor", _fmt(s["ductility_factor"])),
                  ("k2", _fmt(s["k2"]) if s["k2_identifiable"] else "not identifiable"),
                  ("fy", _fmt(s["fy"]) if s["fy_identifiable"] else "not identifiable"),
                  ("c", _fmt(s["c"])), *_uncertainty_values(s))
        status.append({"level": DIAGNOSTIC_LEVELS[DamageState(s["state"])],
                       "name": f"pier_monitor/{pier}/section_{s['index'] + 1}",
                       "message": message, "hardware_id": pier,
                       "values": [{"key": k, "value": v} for k, v in values]})
    unreliable = fields["overall_state"] == int(DamageState.UNRELIABLE)
    status.append({"level": 2 if not fields["success"] else 1 if unreliable else 0,
                   "name": f"pier_monitor/{pier}/identifier", "hardware_id": pier,
                   "message": fields["message"][:500] or "ok",
                   "values": [{"key": "event_id", "value": fields["event_id"]},
                              {"key": "epochs", "value": str(fields["epochs"])},
                              {"key": "device", "value": fields["device"]},
                              {"key": "members", "value": str(fields["members"])}]})
    return {"header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
            "status": status}
