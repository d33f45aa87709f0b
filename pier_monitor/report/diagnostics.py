"""``/diagnostics`` of a damage state as plain fields: what the identifier node publishes and
what the results mcap carries.

One ``DiagnosticStatus`` per section (OK / WARN / ERROR for intact / suspicious / damaged,
WARN for an unreliable result, with the reasons, STALE when there is no diagnosis), then the
identifier's (OK; WARN with the reasons when the result is unreliable; ERROR when the
identification failed).  :func:`diagnostics_fields` maps the fields of a damage state
(:func:`~pier_monitor.report.results.damage_state_fields`) to those of a
``diagnostic_msgs/DiagnosticArray``, levels as integers.

Two rules of what an operator reads:

* the DF of a spring that did not yield is only an upper bound: it reads ``≤ 1`` (the bound,
  usually 1) and ``ductility_factor_upper_bound`` is ``true``; except where the data do not
  exclude that it yielded (its interval reaching past 1: a yield beside a yielded section,
  or the field reconstruction's yield profile), then ``false``;
* ``k1_change_pct`` is only a change between two identified events; the first event of a pier
  has none (``n/a``) and its difference from the design values has its own key,
  ``k1_vs_design_pct``, which is never a basis of the level (a design value is no
  measurement).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from pier_monitor.core.identify.damage import NO_INTERVAL, NO_INTERVAL_FAMILY, DamageState
from pier_monitor.core.ingest.recording import ns_to_stamp

__all__ = ["DIAGNOSTICS_TOPIC", "DIAGNOSTIC_ARRAY_TYPE", "DIAGNOSTIC_LEVELS", "LEVEL_OK",
           "LEVEL_WARN", "LEVEL_ERROR", "LEVEL_STALE", "diagnostics_fields", "ingest_silence"]

#: Topic and type of the diagnostics.
DIAGNOSTICS_TOPIC = "/diagnostics"
DIAGNOSTIC_ARRAY_TYPE = "diagnostic_msgs/msg/DiagnosticArray"
#: ``DiagnosticStatus`` levels.
LEVEL_OK, LEVEL_WARN, LEVEL_ERROR, LEVEL_STALE = 0, 1, 2, 3
#: ``DiagnosticStatus`` level (OK 0, WARN 1, ERROR 2, STALE 3) of each section state.
DIAGNOSTIC_LEVELS = {DamageState.INTACT: 0, DamageState.SUSPICIOUS: 1, DamageState.DAMAGED: 2,
                     DamageState.UNKNOWN: 3, DamageState.UNRELIABLE: 1}


def _fmt(value: float | None) -> str:
    return "nan" if value is None or not math.isfinite(value) else f"{value:.6g}"


def _interval(lo: float, hi: float) -> str:
    return f"[{_fmt(lo)}, {_fmt(hi)}]"


def _has_uncertainty(section: dict[str, Any]) -> bool:
    return math.isfinite(section["p_yielded"])


def _df_bound(s: dict[str, Any]) -> bool:
    """The section's DF is only an upper bound: its spring did not yield (``result.json``'s
    ``ductility_factor_upper_bound``; not there, a result written before it: not yielded)."""
    if "ductility_factor_upper_bound" in s:
        return bool(s["ductility_factor_upper_bound"])
    return not s["k2_identifiable"] and math.isfinite(s["ductility_factor"])


def _df_text(s: dict[str, Any]) -> str:
    """The DF as text: ``≤ 1`` for the upper bound of a spring that did not yield."""
    text = _fmt(s["ductility_factor"])
    return f"≤ {text}" if _df_bound(s) else text


def _has_change(s: dict[str, Any]) -> bool:
    return math.isfinite(s["k1_change_pct"])


def _k1_text(s: dict[str, Any], vs_design: float | None, interval: bool) -> str:
    """``k1 change -5.2 % [..]`` against an earlier event, else the difference from the design
    values, named as such."""
    if _has_change(s):
        text = f"k1 change {_fmt(s['k1_change_pct'])} %"
        if interval:
            text += f" {_interval(s['k1_change_lo_pct'], s['k1_change_hi_pct'])}"
        return text
    if vs_design is None or not math.isfinite(vs_design):
        return "no k1 change (no earlier event)"
    return f"no k1 change (no earlier event), k1 vs design {vs_design:+.1f} %"


def _section_message(fields: dict[str, Any], s: dict[str, Any], state: str,
                     vs_design: float | None) -> str:
    if not fields["success"]:
        return f"no diagnosis: {fields['message']}"[:500]
    if state == "unreliable":
        return (f"unreliable, no diagnosis: {'; '.join(s['reasons'])} (DF "
                f"{_df_text(s)}, event {fields['event_id']})")[:500]
    if not _has_uncertainty(s):
        return (f"{state}: DF {_df_text(s)}, {_k1_text(s, vs_design, False)} "
                f"(event {fields['event_id']})")
    p_state = s[f"p_{state}"] if state in ("intact", "suspicious", "damaged") else math.nan
    text = (f"{state} (P {p_state:.2f}): DF {_df_text(s)} "
            f"{_interval(s['ductility_factor_lo'], s['ductility_factor_hi'])}, "
            f"{_k1_text(s, vs_design, True)} "
            f"(event {fields['event_id']}, {fields['members']} members)")
    if s["reasons"]:
        text += "; " + "; ".join(s["reasons"])
    return text[:500]


#: The field of a section's 90 % interval of each quantity ``poorly_identified`` may name.
_FLAG_FIELDS = {"k1": "k1", "k2": "k2", "fy": "fy", "c": "c", "DF": "ductility_factor"}


def poorly_identified_text(s: dict[str, Any], names: Sequence[str]) -> str:
    """``poorly_identified``'s value: each quantity named with its 90 % interval and the
    interval's relative half-width (``c [1.1e+07, 2.3e+07] ±35 %; ...``), ``none`` when
    every interval is within its limit, :data:`NO_INTERVAL` for a single identification."""
    if not _has_uncertainty(s):
        return NO_INTERVAL if s.get("family") in (None, "bilinear") else NO_INTERVAL_FAMILY
    parts = []
    for name in names:
        key = _FLAG_FIELDS[name]
        lo, hi, mean = s[f"{key}_lo"], s[f"{key}_hi"], s[f"{key}_mean"]
        half = 50.0 * (hi - lo) / abs(mean) if math.isfinite(mean) and mean else math.nan
        parts.append(f"{name} {_interval(lo, hi)}"
                     + (f" ±{half:.0f} %" if math.isfinite(half) and hi > lo else
                        " (too few members yielded)"))
    return "; ".join(parts) or "none"


def _uncertainty_values(s: dict[str, Any]) -> list[tuple[str, str]]:
    """Key-values of a section's uncertainty (none for a single identification)."""
    if not _has_uncertainty(s):
        return []
    change = [("k1_change_90pct", _interval(s["k1_change_lo_pct"], s["k1_change_hi_pct"])),
              ("k1_change_scatter_pct", _fmt(s["k1_change_scatter_pct"]))] \
        if _has_change(s) else []
    return [("k1_std", _fmt(s["k1_std"])), ("k1_90pct", _interval(s["k1_lo"], s["k1_hi"])),
            *change,
            ("ductility_factor_90pct",
             _interval(s["ductility_factor_lo"], s["ductility_factor_hi"])),
            ("p_yielded", _fmt(s["p_yielded"])), ("p_intact", _fmt(s["p_intact"])),
            ("p_suspicious", _fmt(s["p_suspicious"])), ("p_damaged", _fmt(s["p_damaged"])),
            ("reasons", "; ".join(s["reasons"]))]


def diagnostics_fields(fields: dict[str, Any], stamp_ns: int, *,
                       k1_vs_design_pct: Sequence[float | None] = (),
                       poorly_identified: Sequence[Sequence[str]] | None = None
                       ) -> dict[str, Any]:
    """The fields of the ``DiagnosticArray`` of a damage state.

    A section's status has the values k1, ``k1_change_pct`` (its change from an earlier
    event; ``n/a`` for the first event of a pier), ``k1_vs_design_pct`` (the difference from
    the design values, when given; never a basis of the level), DF (``≤ 1`` for a spring that
    did not yield), ``ductility_factor_upper_bound`` (``true`` / ``false``), k2, fy and c; a
    section identified by an ensemble also ``k1_std``, the 90 % intervals ``k1_90pct``,
    ``k1_change_90pct`` (with a change only) and ``ductility_factor_90pct`` (``[lo, hi]``),
    ``k1_change_scatter_pct`` (with a change only), ``p_yielded``, ``p_intact``,
    ``p_suspicious``, ``p_damaged`` and ``reasons`` (``; ``-separated, empty when the state
    is the most probable one).  With ``poorly_identified`` given, every section also has
    ``poorly_identified``: the quantities whose 90 % interval is wider than
    :data:`~pier_monitor.core.identify.damage.IDENTIFIABILITY_LIMITS` allows, each with its
    interval (:func:`poorly_identified_text`; ``none``, or ``no interval (1 member)``), and
    a section's message names them.  The identifier's status has the event, epochs, device
    and number of members.

    Parameters
    ----------
    fields : dict
        :func:`~pier_monitor.report.results.damage_state_fields` of the result.
    stamp_ns : int
        ``header.stamp``, ns since the Unix epoch.
    k1_vs_design_pct : sequence of float or None, optional
        Per section, ``k1``'s difference from the design values, % (the result's
        ``SectionResult.k1_vs_design_pct``); none given: the key is left out.
    poorly_identified : sequence of sequence of str, optional
        Per section, the result's ``SectionResult.poorly_identified``; None: the key is
        left out.

    Returns
    -------
    dict
        ``header`` and ``status`` (a list of dicts with ``level`` an int 0-3, ``name``,
        ``message``, ``hardware_id`` and ``values``, a list of ``{"key", "value"}``).
    """
    sec, nanosec = ns_to_stamp(stamp_ns)
    pier = fields["pier_id"]
    status = []
    vs_design = list(k1_vs_design_pct)
    for i, s in enumerate(fields["sections"]):
        state = DamageState(s["state"]).name.lower()
        design = vs_design[i] if i < len(vs_design) else None
        message = _section_message(fields, s, state, design)
        flags = () if poorly_identified is None or i >= len(poorly_identified) \
            else tuple(poorly_identified[i])
        if flags and fields["success"]:
            message = (message + "; poorly identified: " + ", ".join(flags))[:500]
        values = (("event_id", fields["event_id"]), ("state", state),
                  ("z_bottom_m", _fmt(s["z_bottom_m"])), ("z_top_m", _fmt(s["z_top_m"])),
                  ("k1", _fmt(s["k1"])),
                  ("k1_change_pct", _fmt(s["k1_change_pct"]) if _has_change(s) else "n/a"),
                  *((("k1_vs_design_pct", _fmt(design)),) if vs_design else ()),
                  ("ductility_factor", _df_text(s)),
                  ("ductility_factor_upper_bound", "true" if _df_bound(s) else "false"),
                  ("k2", _fmt(s["k2"]) if s["k2_identifiable"] else "not identifiable"),
                  ("fy", _fmt(s["fy"]) if s["fy_identifiable"] else "not identifiable"),
                  ("c", _fmt(s["c"])), *_uncertainty_values(s),
                  *((("poorly_identified", poorly_identified_text(s, flags)),)
                    if poorly_identified is not None else ()))
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


def ingest_silence(channels: int, ages_s: Sequence[float], alive_timeout_s: float,
                   stale_timeout_s: float) -> tuple[int, str] | None:
    """Level and message of an ingest whose every channel is silent; None while one is alive.

    A channel is alive while its last message is at most ``alive_timeout_s`` old.  With no
    channel alive the ingest is WARN; once the newest message of all is older than
    ``stale_timeout_s`` it is STALE: its status says nothing of the pier any more.  Before
    any message arrived it is WARN (waiting for data, nothing to be stale).

    Parameters
    ----------
    channels : int
        Sensors of the map (0: no configuration yet; None is returned).
    ages_s : sequence of float
        Age of the last message of each sensor that has sent one, s.
    alive_timeout_s, stale_timeout_s : float
        s.

    Returns
    -------
    (level, message) or None
        ``LEVEL_WARN`` or ``LEVEL_STALE`` and a message naming how long the data have been
        silent; None when at least one channel is alive (or there are no channels).
    """
    if channels <= 0:
        return None
    ages = [float(a) for a in ages_s]
    if any(a <= alive_timeout_s for a in ages):
        return None
    if not ages:
        return LEVEL_WARN, f"no data yet: none of the {channels} channels has sent a message"
    silent_s = min(ages)
    text = f"every channel silent for {silent_s:.1f} s (0 of {channels} channels alive)"
    if silent_s > stale_timeout_s:
        return LEVEL_STALE, f"stale: {text}"
    return LEVEL_WARN, text
