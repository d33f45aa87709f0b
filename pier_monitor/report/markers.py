"""The pier as RViz / Foxglove markers: one cylinder per section, coloured by its state.

:func:`damage_markers_fields` maps the fields of a damage state
(:func:`~pier_monitor.report.results.damage_state_fields`) to those of a
``visualization_msgs/MarkerArray`` in the pier's frame (``frame_id`` = the pier id, z up from
the foundation, m):

* a ``DELETEALL`` marker first, so that a display keeps no marker of an earlier state;
* namespace ``sections``: a ``CYLINDER`` per section, from its bottom to its top (a small
  gap between sections), diameter a quarter of the pier's height (a display choice; the
  model has no diameter), coloured by state (:data:`~pier_monitor.report._common.
  STATE_COLORS`: intact green, suspicious amber, damaged red, unknown and unreliable grey);
* namespace ``labels``: a ``TEXT_VIEW_FACING`` beside each section, ``S<n> <state> DF <DF>
  k1 <change> %`` (``DF <=1.00`` for a section that never yielded; ``k1 n/a`` without a
  baseline; ``S<n> unreliable: no diagnosis (DF <DF>)`` for a result that failed its
  self-check), in the section's colour;
* namespace ``pier``: a title above the top, ``<pier> <OVERALL STATE> <event>``.

Markers of section ``n`` have id ``n`` (0-based) in their namespace.  The identifier node
publishes them on ``damage_markers`` (latched) and the results mcap carries them on
``/<pier>/damage_markers``.

The pier's frame resolves through a static transform from a parent frame (``map`` by
default; the identifier's ``parent_frame`` parameter) to ``<pier>``, identity: the pier's
foundation at the parent's origin (:func:`pier_transform_fields`, a ``tf2_msgs/TFMessage``
on ``/tf_static``, latched).  The results mcap carries it, and the identifier node publishes
it where ``tf2_msgs`` is installed (a ROS 2 installation; the PyPI wheels of the project's
environment have none: there the node logs that the markers are in frame ``<pier>``, which a
display resolves when it is the display's fixed frame).
"""

from __future__ import annotations

import math
from typing import Any

from pier_monitor.core.identify.damage import DamageState

from ._common import STATE_COLORS, format_df

__all__ = ["DEFAULT_PARENT_FRAME", "MARKER_ARRAY_TYPE", "MARKER_CYLINDER", "MARKER_DELETEALL",
           "MARKER_TEXT", "TF_MESSAGE_TYPE", "TF_STATIC_TOPIC", "damage_markers_fields",
           "damage_markers_topic", "pier_transform_fields", "section_label", "state_rgba"]

#: Message type of the markers.
MARKER_ARRAY_TYPE = "visualization_msgs/msg/MarkerArray"
#: ``Marker`` type and action codes used here.
MARKER_CYLINDER = 3
MARKER_TEXT = 9
MARKER_ADD = 0
MARKER_DELETEALL = 3
#: The static transforms: topic, type and the default parent of the pier frames.
TF_STATIC_TOPIC = "/tf_static"
TF_MESSAGE_TYPE = "tf2_msgs/msg/TFMessage"
DEFAULT_PARENT_FRAME = "map"
_DIAMETER_SHARE = 0.25  # cylinder diameter / pier height
_GAP_SHARE = 0.04  # gap between two cylinders / section height
_TEXT_SHARE = 0.05  # text height / pier height


def _rgba(hex_colour: str) -> tuple[float, float, float, float]:
    """``#rrggbb`` as red, green, blue, alpha in [0, 1] (opaque), without Matplotlib."""
    return (*(int(hex_colour[k:k + 2], 16) / 255.0 for k in (1, 3, 5)), 1.0)


def damage_markers_topic(pier_id: str) -> str:
    """Absolute topic of a pier's markers: ``/<pier_id>/damage_markers``."""
    return f"/{pier_id}/damage_markers"


def state_rgba(state: DamageState | int) -> dict[str, float]:
    """``std_msgs/ColorRGBA`` fields of a section state (alpha 1)."""
    r, g, b, a = _rgba(STATE_COLORS[DamageState(state).name.lower()])
    return {"r": float(r), "g": float(g), "b": float(b), "a": float(a)}


def section_label(section: dict[str, Any]) -> str:
    """The text beside a section: ``S<n> <state> DF <DF> k1 <change> %``.

    ``section`` is one of the ``sections`` of
    :func:`~pier_monitor.report.results.damage_state_fields`.
    """
    state = DamageState(section["state"])
    head = f"S{section['index'] + 1} {state.name.lower()}"
    if state == DamageState.UNKNOWN:
        return f"{head}: no diagnosis"
    if state == DamageState.UNRELIABLE:
        return f"{head}: no diagnosis (DF {section['ductility_factor']:.2f})"
    change = section["k1_change_pct"]
    k1 = "k1 n/a" if change is None or not math.isfinite(change) else f"k1 {change:+.1f} %"
    bounded = section.get("ductility_factor_upper_bound", not section["k2_identifiable"])
    return f"{head} DF {format_df(section['ductility_factor'], not bounded, bound='<=')} {k1}"


def _marker(header: dict[str, Any], ns: str, index: int, kind: int, xyz: tuple[float, ...],
            scale: tuple[float, ...], color: dict[str, float], text: str = "") -> dict[str, Any]:
    return {"header": header, "ns": ns, "id": index, "type": kind, "action": MARKER_ADD,
            "pose": {"position": dict(zip("xyz", xyz)),
                     "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
            "scale": dict(zip("xyz", scale)), "color": color, "text": text}


def damage_markers_fields(fields: dict[str, Any]) -> dict[str, Any]:
    """The ``MarkerArray`` of a damage state, as plain fields (see the module documentation).

    Parameters
    ----------
    fields : dict
        :func:`~pier_monitor.report.results.damage_state_fields` of the result.

    Returns
    -------
    dict
        ``{"markers": [...]}``, each marker a dict of ``Marker`` fields (nested dicts; the
        fields left out are zero: no lifetime, not frame-locked, no points).
    """
    header = {"stamp": dict(fields["header"]["stamp"]), "frame_id": fields["pier_id"]}
    sections = fields["sections"]
    height = max((float(s["z_top_m"]) for s in sections), default=1.0)
    diameter = _DIAMETER_SHARE * height
    text_h = _TEXT_SHARE * height
    markers = [{"header": header, "ns": "", "id": 0, "action": MARKER_DELETEALL,
                "pose": {"orientation": {"w": 1.0}}}]
    for s in sections:
        z0, z1 = float(s["z_bottom_m"]), float(s["z_top_m"])
        length = (z1 - z0) * (1.0 - _GAP_SHARE)
        color = state_rgba(s["state"])
        markers.append(_marker(header, "sections", int(s["index"]), MARKER_CYLINDER,
                               (0.0, 0.0, 0.5 * (z0 + z1)), (diameter, diameter, length),
                               {**color, "a": 0.9}))
        markers.append(_marker(header, "labels", int(s["index"]), MARKER_TEXT,
                               (diameter, 0.0, 0.5 * (z0 + z1)), (0.0, 0.0, text_h), color,
                               section_label(s)))
    overall = DamageState(fields["overall_state"])
    title = f"{fields['pier_id']} {overall.name} {fields['event_id']}"
    markers.append(_marker(header, "pier", 0, MARKER_TEXT, (0.0, 0.0, height + 2 * text_h),
                           (0.0, 0.0, 1.4 * text_h), state_rgba(overall), title))
    return {"markers": markers}


def pier_transform_fields(pier_ids: list[str] | tuple[str, ...], stamp: dict[str, int], *,
                          parent_frame: str = DEFAULT_PARENT_FRAME) -> dict[str, Any]:
    """The ``TFMessage`` of the static transforms ``parent_frame`` → ``<pier>``, as plain fields.

    Identity transforms (the pier's foundation at the parent's origin, z up), one per pier
    in ``pier_ids``: a latched ``/tf_static`` publisher keeps only its last message, so that
    message holds every pier's transform.

    Parameters
    ----------
    pier_ids : sequence of str
        The pier frames (the markers' ``frame_id``).
    stamp : dict
        ``{"sec", "nanosec"}`` of the transforms.
    parent_frame : str
        The frame they hang from (default ``map``).

    Returns
    -------
    dict
        ``{"transforms": [...]}``, each a ``geometry_msgs/TransformStamped`` as nested dicts.

    Raises
    ------
    ValueError
        If ``parent_frame`` is empty or equals a pier id (a frame cannot be its own parent).
    """
    if not parent_frame or parent_frame in pier_ids:
        raise ValueError(f"parent_frame: expected a frame other than the piers' "
                         f"{list(pier_ids)}, got {parent_frame!r}")
    return {"transforms": [
        {"header": {"stamp": dict(stamp), "frame_id": parent_frame}, "child_frame_id": pier,
         "transform": {"translation": {"x": 0.0, "y": 0.0, "z": 0.0},
                       "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
        for pier in pier_ids]}
