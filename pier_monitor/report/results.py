"""Results of one identification on disk: JSON, a damage-state mcap and the figures.

:func:`write_results` writes, into one directory:

* ``damage_state.mcap`` — one ``pier_monitor_msgs/msg/PierDamageState`` on
  ``/<pier_id>/damage_state`` (``ros2`` profile, CDR, offered latched), what the identifier
  node publishes, with the pier's ``visualization_msgs/MarkerArray`` on
  ``/<pier_id>/damage_markers``, the static transform ``map`` → ``<pier_id>`` of the markers'
  frame on ``/tf_static`` and its ``/diagnostics``; readable by the standard mcap
  tools, ``mcap-ros2-support`` and Foxglove (``config/foxglove_layout.json``);
* ``profile.png``, ``hysteresis.png``, ``responses.png``, ``training.png`` (see
  :mod:`~pier_monitor.report.figures`), unless figures are turned off;
* ``result.json``, last, so that its presence marks a complete report —
  :meth:`IdentificationResult.to_dict` (parameters, DF and state per section, settings, loss
  history; for an ensemble each section's uncertainty, ``k1`` change interval and reasons,
  and the overall-state probabilities) with the software version, the absolute window start
  and what ``k1_change_pct`` is relative to; :meth:`IdentificationResult.load_json` reads it
  back exactly.

It returns the saved result with the paths, so nobody reads ``result.json`` back.
:func:`damage_state_fields` is the one mapping from a result to the message's fields.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor import __version__
from pier_monitor.bags.types import get_typestore, message_from_fields
from pier_monitor.bags.writer import write_mcap_messages
from pier_monitor.core.errors import BagError, InputDataError, ReportError
from pier_monitor.core.fileio import atomic_path
from pier_monitor.core.ids import EVENT_ID_MAX_LEN, check_id
from pier_monitor.core.identify.damage import DamageState, IdentificationResult, SectionResult
from pier_monitor.core.identify.uncertainty import MemberResponses, Spread
from pier_monitor.core.ingest.recording import NS_PER_S, ns_to_stamp, stamp_to_ns
from pier_monitor.core.ingest.window import MeasuredWindow, Reproduced
from pier_monitor.core.model.config import SpringParameters

from ._common import check_same_pier, ensure_dir
from .diagnostics import DIAGNOSTIC_ARRAY_TYPE, DIAGNOSTICS_TOPIC, diagnostics_fields
from .figures import (RunLike, check_members_match, check_window_matches, plot_hysteresis,
                      plot_profile, plot_responses, plot_training)
from .markers import (MARKER_ARRAY_TYPE, TF_MESSAGE_TYPE, TF_STATIC_TOPIC, damage_markers_fields,
                      damage_markers_topic, pier_transform_fields)

__all__ = [
    "DAMAGE_STATE_TYPE",
    "RESULT_JSON",
    "ResultsPaths",
    "WrittenResult",
    "damage_state_fields",
    "damage_state_message",
    "damage_state_topic",
    "k1_vs_design",
    "load_result",
    "prepare_result",
    "write_damage_state_mcap",
    "write_damage_states_mcap",
    "write_results",
]

#: Message type of the damage state.
DAMAGE_STATE_TYPE = "pier_monitor_msgs/msg/PierDamageState"
_SECTION_TYPE = "pier_monitor_msgs/msg/SectionState"
#: File names inside a results directory.
RESULT_JSON = "result.json"
DAMAGE_STATE_MCAP = "damage_state.mcap"
FIGURE_FILES = ("profile.png", "hysteresis.png", "responses.png", "training.png")


@dataclass(frozen=True)
class ResultsPaths:
    """The files :func:`write_results` wrote (all inside ``out_dir``).

    ``figures`` holds the four PNG files (profile, hysteresis, responses, training), or
    nothing when figures were turned off.
    """

    out_dir: Path
    result_json: Path
    damage_state_mcap: Path
    figures: tuple[Path, ...] = ()

    @property
    def profile_png(self) -> Path | None:
        """The profile figure (paper Fig. 18), or None when no figures were written."""
        return self.figures[0] if self.figures else None


@dataclass(frozen=True)
class WrittenResult:
    """What :func:`write_results` saved: the result as in ``result.json``, and the files."""

    result: IdentificationResult
    paths: ResultsPaths


def damage_state_topic(pier_id: str) -> str:
    """Absolute topic of a pier's damage state: ``/<pier_id>/damage_state``."""
    return f"/{pier_id}/damage_state"


def _time(t_ns: int) -> dict[str, int]:
    try:
        sec, nanosec = ns_to_stamp(t_ns)
    except InputDataError as err:
        raise ReportError(str(err)) from err
    return {"sec": sec, "nanosec": nanosec}


def _window_start_ns(result: IdentificationResult) -> int:
    """Absolute window start, ns; the source's clock (``window_start_s``) where unknown."""
    if result.window_start_ns:
        return int(result.window_start_ns)
    return int(round(result.window_start_s * NS_PER_S))


def damage_state_fields(result: IdentificationResult, *, stamp_ns: int | None = None
                        ) -> dict[str, Any]:
    """The fields of a ``PierDamageState`` message for a result, as plain Python values.

    Nested messages are dicts (``header``, ``window_start``, each of ``sections``), times
    are ``{"sec", "nanosec"}``, states are the ``SectionState.STATE_*`` codes, and a
    ``k1_change_pct`` of ``None`` (no baseline) is NaN.  A section without uncertainty (a
    single identification) has NaN spreads, probabilities and change interval, and no
    reasons.  Both the results mcap and the identifier node build their messages from this
    mapping.

    Parameters
    ----------
    result : IdentificationResult
        The identification.
    stamp_ns : int, optional
        ``header.stamp``, ns since the Unix epoch; default the window start (reproducible
        for offline runs; a live node passes its clock).

    Returns
    -------
    dict
        Keys are exactly the fields of ``PierDamageState.msg``.
    """
    start_ns = _window_start_ns(result)
    sections = []
    for s in result.sections:
        sections.append(_uncertainty_fields(s) | {
            "index": int(s.index),
            "z_bottom_m": float(s.z_bottom_m),
            "z_top_m": float(s.z_top_m),
            "k1": float(s.k1),
            "k2": float(s.k2),
            "fy": float(s.fy),
            "c": float(s.c),
            "yield_angle_rad": float(s.yield_angle_rad),
            "max_angle_rad": float(s.max_angle_rad),
            "ductility_factor": float(s.ductility_factor),
            "k1_change_pct": float("nan") if s.k1_change_pct is None else float(s.k1_change_pct),
            "k2_identifiable": bool(s.k2_identifiable),
            "fy_identifiable": bool(s.fy_identifiable),
            "state": int(s.damage_state),
        })
    return {
        "header": {"stamp": _time(start_ns if stamp_ns is None else stamp_ns),
                   "frame_id": result.pier_id},
        "pier_id": result.pier_id,
        "event_id": result.event_id,
        "window_start": _time(start_ns),
        "window_duration_s": float(result.window_duration_s),
        "sections": sections,
        "overall_state": int(DamageState[result.overall_state.upper()]),
        "members": int(result.members),
        **{f"p_overall_{name}": _nan_if_none(None if result.p_overall_state is None
                                             else result.p_overall_state[i])
           for i, name in enumerate(("intact", "suspicious", "damaged"))},
        "epochs": int(result.epochs),
        "final_loss": float(result.final_loss),
        "wall_time_s": float(result.wall_time_s),
        "device": str(result.device),
        "message": str(result.message),
        "success": bool(result.success),
    }


def k1_vs_design(result: IdentificationResult) -> list[float | None]:
    """Per section, ``k1``'s difference from the design values, % (None where not known).

    The damage-state message has no field for it; the diagnostics show it beside the ``k1``
    change (:func:`~pier_monitor.report.diagnostics.diagnostics_fields`).
    """
    return [s.k1_vs_design_pct for s in result.sections]


def _nan_if_none(value: float | None) -> float:
    return float("nan") if value is None else float(value)


def _uncertainty_fields(s: SectionResult) -> dict[str, Any]:
    """The uncertainty fields of a ``SectionState`` (NaN / empty without uncertainty)."""
    u = s.uncertainty
    out: dict[str, Any] = {}
    for name in ("k1", "k2", "fy", "c", "ductility_factor"):
        spread = Spread.undefined() if u is None else getattr(u, name)
        for key in ("mean", "std", "lo", "hi"):
            out[f"{name}_{key}"] = float(getattr(spread, key))
    out["p_yielded"] = _nan_if_none(None if u is None else u.p_yielded)
    for i, name in enumerate(("intact", "suspicious", "damaged")):
        out[f"p_{name}"] = _nan_if_none(None if u is None else u.p_state[i])
    for key in ("k1_change_lo_pct", "k1_change_hi_pct", "k1_change_scatter_pct"):
        out[key] = _nan_if_none(getattr(s, key))
    out["reasons"] = [str(r) for r in s.reasons]
    return out


def damage_state_message(result: IdentificationResult, *, stamp_ns: int | None = None) -> Any:
    """The ``PierDamageState`` of a result as a rosbags message object (for CDR/bags).

    See :func:`damage_state_fields` for the mapping and ``stamp_ns``.
    """
    types = get_typestore().types
    time_cls = types["builtin_interfaces/msg/Time"]
    fields = damage_state_fields(result, stamp_ns=stamp_ns)
    header = fields["header"]
    fields["header"] = types["std_msgs/msg/Header"](stamp=time_cls(**header["stamp"]),
                                                    frame_id=header["frame_id"])
    fields["window_start"] = time_cls(**fields["window_start"])
    fields["sections"] = [types[_SECTION_TYPE](**s) for s in fields["sections"]]
    return types[DAMAGE_STATE_TYPE](**fields)


def write_damage_state_mcap(result: IdentificationResult, path: str | Path, *,
                            stamp_ns: int | None = None) -> Path:
    """Write the result's damage state, markers and diagnostics as an mcap file.

    See :func:`write_damage_states_mcap` (one result).
    """
    return write_damage_states_mcap([result], path, stamp_ns=stamp_ns)


def write_damage_states_mcap(results: Sequence[IdentificationResult], path: str | Path, *,
                             stamp_ns: int | None = None) -> Path:
    """Write the damage states of one or more piers as an mcap file (replacing ``path``).

    Per result: its ``PierDamageState`` on :func:`damage_state_topic`, its
    ``MarkerArray`` on :func:`~pier_monitor.report.markers.damage_markers_topic` and the
    static transform of its frame (``map`` → ``<pier>``) on ``/tf_static`` (all offered
    latched), and its ``DiagnosticArray`` on ``/diagnostics``, all logged at the
    message's ``header.stamp``.

    Raises
    ------
    ReportError
        Naming the path, if it cannot be written.
    """
    path = Path(path)
    typestore = get_typestore()
    connections: list[tuple[str, str, bool]] = []
    records = []
    for result in results:
        msg = damage_state_message(result, stamp_ns=stamp_ns)
        log_ns = max(stamp_to_ns(msg.header.stamp.sec, msg.header.stamp.nanosec), 0)
        fields = damage_state_fields(result, stamp_ns=stamp_ns)
        for topic, typename, latched, message in (
                (damage_state_topic(result.pier_id), DAMAGE_STATE_TYPE, True, msg),
                (damage_markers_topic(result.pier_id), MARKER_ARRAY_TYPE, True,
                 message_from_fields(MARKER_ARRAY_TYPE, damage_markers_fields(fields))),
                (TF_STATIC_TOPIC, TF_MESSAGE_TYPE, True, message_from_fields(
                    TF_MESSAGE_TYPE, pier_transform_fields([result.pier_id],
                                                           fields["header"]["stamp"]))),
                (DIAGNOSTICS_TOPIC, DIAGNOSTIC_ARRAY_TYPE, False,
                 message_from_fields(DIAGNOSTIC_ARRAY_TYPE, diagnostics_fields(
                     fields, log_ns, k1_vs_design_pct=k1_vs_design(result),
                     poorly_identified=[s.poorly_identified for s in result.sections])))):
            if (topic, typename, latched) not in connections:
                connections.append((topic, typename, latched))
            cdr = bytes(typestore.serialize_cdr(message, typename))
            records.append((log_ns, connections.index((topic, typename, latched)), cdr))
    records.sort(key=lambda r: r[0])
    try:
        with atomic_path(path) as tmp:
            write_mcap_messages(tmp, connections, records)
    except (BagError, OSError) as err:
        raise ReportError(f"{path}: cannot write the damage-state mcap: {err}") from err
    return path


def prepare_result(run: RunLike, window: MeasuredWindow, *,
                   baseline: IdentificationResult | np.ndarray | None = None,
                   version: str = __version__,
                   check_reasons: Sequence[str] = ()) -> IdentificationResult:
    """The run's result as it is saved: window start, ``k1`` baseline, version, the window's
    findings and the self-check filled in.

    ``check_reasons`` (from :func:`~pier_monitor.core.identify.checks.check_identification`)
    make the result unreliable (:meth:`IdentificationResult.with_check_reasons`), whatever
    the baseline.  ``k1_change_pct`` is recomputed against ``baseline``: none when ``None``
    (the first event of a pier has no change, :meth:`IdentificationResult.without_k1_baseline`),
    an earlier result of the same pier (its ``k1`` and, for an ensemble, its ``k1``
    spread: a loss beyond the scatter is cracking, see
    :meth:`IdentificationResult.with_baseline`), or an array (N,) in N·m/rad.  The sections'
    states are decided again against it.  Every section also gets ``k1_vs_design_pct``, its
    difference from the window's design values (:meth:`IdentificationResult.with_design_k1`),
    which never decides a state.

    Raises
    ------
    ReportError
        If the run is not of this window, or the baseline is of another pier or shape.
    """
    check_window_matches(window, run)
    try:
        findings, partial = window.findings, window.partial
    except InputDataError as err:
        raise ReportError(str(err)) from err
    result = replace(run.result, findings=findings, partial=partial
                     ).with_check_reasons(check_reasons)
    if baseline is None:
        result = result.without_k1_baseline()
    elif isinstance(baseline, IdentificationResult):
        check_same_pier([baseline, result], [f"baseline {baseline.event_id!r}",
                                             f"result {result.event_id!r}"])
        result = result.with_baseline(baseline)
    else:
        base_k1 = np.asarray(baseline, dtype=float)
        if base_k1.shape != (len(result.sections),) or not np.all(
                np.isfinite(base_k1) & (base_k1 > 0)):
            raise ReportError(f"baseline k1: expected {len(result.sections)} finite positive "
                              f"values in N·m/rad, got {base_k1.tolist()}")
        result = result.with_k1_baseline(base_k1, "given baseline")
    result = result.with_design_k1(window.design.k1)
    return replace(result, window_start_ns=int(window.start_time_ns), software_version=version)


def write_results(run: RunLike, window: MeasuredWindow, out_dir: str | Path, *,
                  baseline: IdentificationResult | np.ndarray | None = None,
                  figures: bool = True, version: str = __version__,
                  members: MemberResponses | None = None,
                  check_reasons: Sequence[str] = ()) -> WrittenResult:
    """Write damage_state.mcap, the four figures and result.json of one identification.

    Existing files of an earlier report in ``out_dir`` are replaced; ``result.json`` is
    written last, so that its presence marks a complete report.

    Parameters
    ----------
    run : IdentificationRun
        What :func:`pier_monitor.core.identify.methods.identify` returned for ``window``.
    window : MeasuredWindow
        The measured window (for the responses figure, the design values and the absolute
        start time).
    out_dir : str or Path
        Directory to write into; created with its parents when missing.
    baseline : IdentificationResult or ndarray (N,), optional
        Reference of ``k1_change_pct``: default the design values; an earlier result of the
        same pier (the profile then shows both events, like the paper's Fig. 18); or ``k1``
        values in N·m/rad (the profile then shows ``k1`` relative to them).
    figures : bool
        Also draw the four PNG figures (a few seconds).
    version : str
        Software version recorded in result.json.
    members : MemberResponses, optional
        The histories of an ensemble's members, (M, T, N): the hysteresis and responses
        figures draw their band.
    check_reasons : sequence of str
        Reasons the identification failed its self-check: the result is written as
        unreliable (see :func:`prepare_result`).

    Returns
    -------
    WrittenResult
        The result as saved (window start, baseline and version filled in) and the paths.

    Raises
    ------
    ReportError
        If ``out_dir`` cannot be created or written (the message names it), or the run,
        window and baseline do not belong together.
    UnsafeNameError
        If the window's pier or event id is not a safe name (it becomes a topic and a
        directory name).
    """
    check_id("pier_id", window.pier_id)
    check_id("event_id", window.event_id, max_len=EVENT_ID_MAX_LEN)
    check_members_match(members, run.reproduced)
    out = ensure_dir(out_dir)
    result = prepare_result(run, window, baseline=baseline, version=version,
                            check_reasons=check_reasons)
    paths = ResultsPaths(out_dir=out, result_json=out / RESULT_JSON,
                         damage_state_mcap=out / DAMAGE_STATE_MCAP,
                         figures=tuple(out / name for name in FIGURE_FILES) if figures else ())
    write_damage_state_mcap(result, paths.damage_state_mcap)
    if figures:
        _write_figures(_RunWithResult(run, result), window, baseline, paths.figures, members)
    try:
        result.save_json(paths.result_json)
    except OSError as err:
        raise ReportError(f"{paths.result_json}: cannot write: {err.strerror or err}") from err
    return WrittenResult(result=result, paths=paths)


def _write_figures(saved: _RunWithResult, window: MeasuredWindow,
                   baseline: IdentificationResult | np.ndarray | None,
                   files: tuple[Path, ...], members: MemberResponses | None) -> None:
    profile, hysteresis, responses, training = files
    if isinstance(baseline, IdentificationResult):
        plot_profile([baseline, saved.result], None, profile)
    elif baseline is not None:
        plot_profile([saved.result], None, profile, baseline_k1=np.asarray(baseline),
                     baseline_label="the baseline")
    else:
        plot_profile([saved.result], None, profile)
    plot_hysteresis(saved, hysteresis, members=members)
    plot_responses(window, saved, responses, members=members)
    plot_training(saved, training)


@dataclass(frozen=True)
class _RunWithResult:
    """A run whose result is replaced by the saved one (same responses and history)."""

    run: RunLike
    result: IdentificationResult

    @property
    def reproduced(self) -> Reproduced:
        return self.run.reproduced

    @property
    def initial(self) -> SpringParameters:
        return self.run.initial

    @property
    def history(self) -> dict[str, list[Any]]:
        return self.run.history


def load_result(path: str | Path) -> IdentificationResult:
    """Read a result.json, or the result.json of a results directory.

    Raises
    ------
    ReportError
        Naming the path: missing, not a results directory, or not a pier_monitor result.
    """
    path = Path(path)
    file = path / RESULT_JSON if path.is_dir() else path
    if not file.is_file():
        where = f"{path}: no {RESULT_JSON} in this directory" if path.is_dir() else \
            f"{path}: no such file (expected a {RESULT_JSON} or a directory holding one)"
        raise ReportError(where)
    try:
        return IdentificationResult.load_json(file)
    except (OSError, ValueError) as err:
        raise ReportError(f"{file}: cannot read: {err}") from err
    except (KeyError, TypeError) as err:
        raise ReportError(f"{file}: not a pier_monitor identification result ({err})") from err
