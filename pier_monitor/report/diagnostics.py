"""``/diagnostics`` of a damage state as plain fields: what the identifier node publishes and
what the results mcap carries.

One ``DiagnosticStatus`` per section (OK / WARN / ERROR for intact / suspicious / damaged,
STALE when there is no diagnosis), then the identifier's (OK, or ERROR when the
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
                     DamageState.UNKNOWN: 3}


def _fmt(value: float | None) -> str:
    return "nan" if value is None or not math.isfinite(value) else f"{value:.6g}"


def diagnostics_fields(fields: dict[str, Any], stamp_ns: int) -> dict[str, Any]:
    """The fields of the ``DiagnosticArray`` of a damage state.

    A section's status has the values k1, its change from the baseline, DF, k2, fy and c;
    the identifier's the event, epochs and device.

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
        if fields["success"]:
            message = (f"{state}: DF {_fmt(s['ductility_factor'])}, k1 change "
                       f"{_fmt(s['k1_change_pct'])} % (event {fields['event_id']})")
        else:
            message = f"no diagnosis: {fields['message']}"[:500]
        values = (("event_id", fields["event_id"]), ("state", state),
                  ("z_bottom_m", _fmt(s["z_bottom_m"])), ("z_top_m", _fmt(s["z_top_m"])),
                  ("k1", _fmt(s["k1"])), ("k1_change_pct", _fmt(s["k1_change_pct"])),
                  ("ductility_factor", _fmt(s["ductility_factor"])),
                  ("k2", _fmt(s["k2"]) if s["k2_identifiable"] else "not identifiable"),
                  ("fy", _fmt(s["fy"]) if s["fy_identifiable"] else "not identifiable"),
                  ("c", _fmt(s["c"])))
        status.append({"level": DIAGNOSTIC_LEVELS[DamageState(s["state"])],
                       "name": f"pier_monitor/{pier}/section_{s['index'] + 1}",
                       "message": message, "hardware_id": pier,
                       "values": [{"key": k, "value": v} for k, v in values]})
    status.append({"level": 0 if fields["success"] else 2,
                   "name": f"pier_monitor/{pier}/identifier", "hardware_id": pier,
                   "message": fields["message"][:500] or "ok",
                   "values": [{"key": "event_id", "value": fields["event_id"]},
                              {"key": "epochs", "value": str(fields["epochs"])},
                              {"key": "device", "value": fields["device"]}]})
    return {"header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": ""},
            "status": status}
