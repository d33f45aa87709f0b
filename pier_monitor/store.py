"""The results directory of one or more piers: what is done, what is not, what to compare with.

Layout: one directory per event, ``<root>/<event_id>/``, holding

* ``window.npz`` — the window, stored before its identification starts (so that a crash or
  a kill loses no event);
* ``result.json``, ``damage_state.mcap`` and the figures of a successful identification
  (:func:`~pier_monitor.report.results.write_results`; ``result.json`` last);
* ``failed.json`` — a failed identification
  (:func:`~pier_monitor.core.identify.damage.failed_result`: its message says why), or an
  event the ingest could give no window of, failed or cut by the end of the data
  (:func:`~pier_monitor.core.identify.damage.failed_event_result`; no ``window.npz``).

An event is *done* when it has ``result.json`` or ``failed.json``.  Event ids are checked
(:func:`~pier_monitor.core.ids.check_id`) and every event directory stays under the root.

The baseline rule (the reference of ``k1_change_pct``), the same for a bag identified
offline and for the live identifier: the **earliest reliable result of the same pier whose
window started before this one** (a successful identification that passed its self-check;
an unreliable result is never a baseline).  For the first event of a pier there is none, and
it has no ``k1`` change (its difference from the design values is ``k1_vs_design_pct``, never
a change).  Identifying a bag into an empty directory therefore
compares every later event with the bag's first one; a store that already holds an earlier
event of the pier makes that one the baseline.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pier_monitor.core.errors import (InputDataError, PierMonitorError, ReportError,
                                     UnsafeNameError)
from pier_monitor.core.fileio import remove_temporaries
from pier_monitor.core.identify.damage import IdentificationResult, failed_result
from pier_monitor.core.ids import EVENT_ID_MAX_LEN, check_id, safe_child
from pier_monitor.core.ingest.window import MeasuredWindow, load_window, save_window

from pier_monitor.report._common import ensure_dir
from pier_monitor.report.results import RESULT_JSON

__all__ = ["ResultsStore", "PierHistory", "PendingWindows", "WINDOW_NPZ", "FAILED_JSON"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PierHistory:
    """What a results store knows of a pier before a window
    (:meth:`ResultsStore.history_before`).

    Attributes
    ----------
    baseline : IdentificationResult or None
        The window's baseline (:meth:`ResultsStore.baseline_for`).
    peak_rotations : ndarray, shape (N,), or None
        The largest spring rotation per section so far, rad
        (:meth:`ResultsStore.peak_rotations_before`).
    rotation_peaks : ndarray, shape (2, N), or None
        The rotation history the springs start from, rad
        (:meth:`ResultsStore.rotation_peaks_before`).
    rotation_peaks_unidentified : ndarray, shape (2, N), or None
        ``rotation_peaks`` with the reconstructed peaks of the sections whose DF the latest
        result left poorly identified filled in (their
        ``rotation_peaks_unidentified_rad``), rad; None where there are none
        (:attr:`~pier_monitor.core.ingest.window.MeasuredWindow.
        prior_rotation_peaks_unidentified`).
    """

    baseline: IdentificationResult | None
    peak_rotations: np.ndarray | None
    rotation_peaks: np.ndarray | None
    rotation_peaks_unidentified: np.ndarray | None = None


def _peak_rotations(earlier: list[IdentificationResult]) -> np.ndarray | None:
    """The largest ``max_angle_rad`` per section over ``earlier``, rad (N,); None without
    results."""
    peaks = [[s.max_angle_rad for s in r.sections] for r in earlier]
    if not peaks:
        return None
    return np.nanmax(np.array(peaks, dtype=float), axis=0)

#: File names inside an event directory (besides those of ``write_results``).
WINDOW_NPZ = "window.npz"
FAILED_JSON = "failed.json"


@dataclass(frozen=True)
class PendingWindows:
    """Windows without a result yet, oldest first, and the files that could not be read."""

    windows: tuple[MeasuredWindow, ...]
    unreadable: tuple[str, ...]


class ResultsStore:
    """A results directory: event directories, baselines, pending windows, failures.

    Parameters
    ----------
    root : str or Path
        The results root; created when the first event is stored.
    """

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    def __repr__(self) -> str:
        return f"ResultsStore({str(self.root)!r})"

    def create(self) -> ResultsStore:
        """Create the results root (with its parents) now; returns the store.

        Raises
        ------
        ReportError
            Naming the root, if it cannot be created or written.
        """
        ensure_dir(self.root)
        return self

    # -- paths ------------------------------------------------------------------------------
    def event_dir(self, event_id: str) -> Path:
        """``<root>/<event_id>``.

        Raises
        ------
        UnsafeNameError
            If ``event_id`` is not a safe id (:func:`~pier_monitor.core.ids.check_id`: empty,
            too long, a separator, ``..``, ...) or the directory would lie outside the root
            (a symbolic link pointing out of it).
        """
        check_id("event_id", event_id, max_len=EVENT_ID_MAX_LEN)
        safe_child(self.root, event_id)
        return self.root / event_id

    def _result_name(self, result: IdentificationResult) -> str:
        """How a warning names ``result``'s file: its path in the store, through
        :meth:`event_dir`; a result whose event id (read from the file's content) is no safe
        id is named by that id, never by a path built from it."""
        try:
            return str(self.event_dir(result.event_id) / RESULT_JSON)
        except UnsafeNameError:
            return f"result of event {result.event_id!r}"

    def window_file(self, event_id: str) -> Path:
        """Where the window of an event is stored."""
        return self.event_dir(event_id) / WINDOW_NPZ

    # -- writing ----------------------------------------------------------------------------
    def start_event(self, window: MeasuredWindow) -> Path:
        """Store the window of an identification about to start; returns its file.

        An earlier outcome of the same event (``result.json``, ``failed.json``) is removed:
        until the new identification ends, the event is pending.  So are temporary files a
        killed writer of the event left (:func:`~pier_monitor.core.fileio.remove_temporaries`).

        Raises
        ------
        ReportError
            Naming the directory or file that cannot be written.
        """
        out = ensure_dir(self.event_dir(window.event_id))
        try:
            for name in (RESULT_JSON, FAILED_JSON):
                (out / name).unlink(missing_ok=True)
            for tmp in remove_temporaries(out):
                log.warning("%s: removed, left by a writer that did not finish", tmp)
            return save_window(window, out / WINDOW_NPZ)
        except OSError as err:
            raise ReportError(f"{out}: cannot store the window: {err.strerror or err}") from err

    def record_failure(self, result: IdentificationResult) -> Path:
        """Write a failed result (``success`` false) as the event's ``failed.json``.

        A ``result.json`` of an earlier run of the event is removed: the failure is its
        outcome now.

        Raises
        ------
        ReportError
            If the result is not a failure, or the file cannot be written.
        """
        if result.success:
            raise ReportError(f"event {result.event_id!r}: record_failure takes a failed "
                              "result (success false)")
        path = ensure_dir(self.event_dir(result.event_id)) / FAILED_JSON
        try:
            (path.parent / RESULT_JSON).unlink(missing_ok=True)
            return result.save_json(path)
        except OSError as err:
            raise ReportError(f"{path}: cannot write: {err.strerror or err}") from err

    def fail_window(self, window: MeasuredWindow, *, device: str, message: str
                    ) -> IdentificationResult:
        """Record that the identification of ``window`` failed, and return the record.

        The one failure record of every entrance (a bag, the live node, a fleet or Ray
        task): every section ``unknown``, ``message`` saying why (see
        :func:`~pier_monitor.core.identify.damage.failed_result`).

        Raises
        ------
        ReportError
            If the file cannot be written.
        """
        failed = failed_result(window, device=device, message=message)
        self.record_failure(failed)
        return failed

    # -- questions --------------------------------------------------------------------------
    def is_done(self, event_id: str) -> bool:
        """Whether the event has a result or a failure record."""
        d = self.event_dir(event_id)
        return (d / RESULT_JSON).is_file() or (d / FAILED_JSON).is_file()

    def outcome(self, event_id: str) -> IdentificationResult | None:
        """The event's result or failure record; None while it is pending.

        Raises
        ------
        ReportError
            Naming the file, if it exists but cannot be read.
        """
        d = self.event_dir(event_id)
        for name in (RESULT_JSON, FAILED_JSON):
            path = d / name
            if path.is_file():
                try:
                    return IdentificationResult.load_json(path)
                except (OSError, ValueError, KeyError, TypeError, PierMonitorError) as err:
                    raise ReportError(f"{path}: cannot read: {err}") from err
        return None

    def results(self, pier_id: str | None = None) -> list[IdentificationResult]:
        """Every readable ``result.json`` (of ``pier_id`` when given), oldest window first.

        A file that cannot be read is skipped with a warning on this module's logger.
        """
        return self._load(RESULT_JSON, pier_id)

    def failures(self, pier_id: str | None = None) -> list[IdentificationResult]:
        """The failure records (of ``pier_id`` when given), oldest window first."""
        return self._load(FAILED_JSON, pier_id)

    def baseline_for(self, window: MeasuredWindow) -> IdentificationResult | None:
        """The baseline of ``window``'s identification (see the module documentation).

        The earliest reliable result (a successful identification that passed its
        self-check) of the same pier whose window started before ``window.start_time_ns``
        and whose sections are those of ``window`` (the same heights) with positive finite
        k1; None when there is none (compare with the design values).  A result skipped for
        its geometry or its values is named in a warning on this module's logger.
        """
        return self.history_before(window).baseline

    def history_before(self, window: MeasuredWindow) -> PierHistory:
        """What the store knows of ``window``'s pier before it, from one reading of its
        results: the baseline (:meth:`baseline_for`), the peak rotations so far
        (:meth:`peak_rotations_before`) and the rotation history its springs start from
        (:meth:`rotation_peaks_before`)."""
        earlier = self._earlier_results(window)
        return PierHistory(baseline=earlier[0] if earlier else None,
                           peak_rotations=_peak_rotations(earlier),
                           rotation_peaks=self._rotation_peaks(earlier, window),
                           rotation_peaks_unidentified=self._rotation_peaks(
                               earlier, window, unidentified=True))

    def peak_rotations_before(self, window: MeasuredWindow) -> np.ndarray | None:
        """The largest spring rotation per section, rad (N,), over the reliable results of
        ``window``'s pier whose windows started before it and whose sections are those of
        ``window`` (the same rule as :meth:`baseline_for`); None when there is none.  The
        peak so far of the cumulative DF
        (:meth:`~pier_monitor.core.identify.damage.IdentificationResult.with_cumulative_ductility`).
        """
        return _peak_rotations(self._earlier_results(window))

    def _earlier_results(self, window: MeasuredWindow) -> list[IdentificationResult]:
        """The reliable results of ``window``'s pier whose windows started before it and
        whose sections are those of ``window`` (the same heights), oldest window first.  A
        result before the earliest of them skipped for its geometry (not a baseline) is
        named in a warning on this module's logger."""
        z = np.asarray(window.geometry.level_heights_m, dtype=float)
        out = []
        for r in self.results(window.pier_id):
            if not (self.is_baseline(r) and r.window_start_ns < window.start_time_ns):
                continue
            tops = np.array([s.z_top_m for s in r.sections], dtype=float)
            if tops.shape == z[1:].shape and np.allclose(tops, z[1:], rtol=1e-9, atol=1e-6):
                out.append(r)
            elif not out:
                log.warning("%s: not a baseline of event %s: its sections end at %s m, the "
                            "pier's now at %s m (the geometry changed)", self._result_name(r),
                            window.event_id, tops.tolist(), z[1:].tolist())
        return out

    def rotation_peaks_before(self, window: MeasuredWindow) -> np.ndarray | None:
        """The pier's rotation history before ``window``, as its springs carry it into the
        window: per section the largest positive (row 0) and negative (row 1) spring
        rotation reached, rad, shape (2, N), in ``window``'s frame
        (:attr:`~pier_monitor.core.ingest.window.MeasuredWindow.prior_rotation_peaks`).

        The ``rotation_peaks_after_rad`` of the latest reliable result of ``window``'s pier
        whose window started before it and whose sections are those of ``window`` (the
        rule of :meth:`peak_rotations_before`): each event's envelope carries the one it
        started from, less the residual rotation it left
        (:func:`~pier_monitor.core.identify.damage.rotation_peaks_after`).  None where there
        is no such result or it holds the envelope of no section; a section without one
        (:meth:`~pier_monitor.core.identify.damage.IdentificationResult.with_history_identified`)
        starts virgin (zeros).
        """
        return self._rotation_peaks(self._earlier_results(window), window)

    def _rotation_peaks(self, earlier: list[IdentificationResult], window: MeasuredWindow,
                        unidentified: bool = False) -> np.ndarray | None:
        """:meth:`rotation_peaks_before` of the results :meth:`_earlier_results` gave;
        ``unidentified``: with the peaks of the sections whose DF was not identified
        (:attr:`PierHistory.rotation_peaks_unidentified`), None where there are none."""
        latest = earlier[-1] if earlier else None
        if latest is None:
            return None
        if unidentified:
            if all(s.rotation_peaks_unidentified_rad is None for s in latest.sections):
                return None
            peaks = [s.rotation_peaks_after_rad if s.rotation_peaks_unidentified_rad is None
                     else s.rotation_peaks_unidentified_rad for s in latest.sections]
        else:
            peaks = [s.rotation_peaks_after_rad for s in latest.sections]
        if all(p is None for p in peaks):
            return None
        # a section without one (a reconstructed rotation whose DF was not identified) starts
        # virgin
        env = np.array([(0.0, 0.0) if p is None else p for p in peaks], dtype=float).T
        if not (np.all(np.isfinite(env)) and np.all(env[0] >= 0) and np.all(env[1] <= 0)):
            log.warning("%s: its rotation peaks %s are not (θ+ >= 0, θ- <= 0): no history "
                        "before %s", self._result_name(latest), env.tolist(), window.event_id)
            return None
        return env

    def is_baseline(self, result: IdentificationResult) -> bool:
        """Whether ``result`` may be a later event's baseline: a reliable result (a
        successful identification that passed its self-check) whose ``k1`` are all finite
        and positive.  The one rule of :meth:`baseline_for` and of the fleet's scheduler
        (:meth:`baseline_for` also needs the sections of the pier as it is now)."""
        k1 = np.array([s.k1 for s in result.sections], dtype=float)
        if result.reliable and not np.all(np.isfinite(k1) & (k1 > 0)):
            log.warning("%s: not a baseline: its k1 %s are not all positive finite values",
                        self._result_name(result), k1.tolist())
            return False
        return result.reliable

    def pending(self, inbox: str | Path | None = None) -> PendingWindows:
        """Windows that are not done yet, oldest first, one per event.

        Looks at the windows stored in the event directories and, when given, at the
        ``*.npz`` windows of ``inbox`` (e.g. the live ingest's window directory); a window
        stored in its event directory wins over one of the same event in the inbox.
        """
        files = sorted(self.root.glob(f"*/{WINDOW_NPZ}")) if self.root.is_dir() else []
        if inbox is not None and Path(inbox).is_dir():
            files += sorted(Path(inbox).glob("*.npz"))
        found: dict[str, MeasuredWindow] = {}
        unreadable = []
        for path in files:
            try:
                window = load_window(path)
            except InputDataError as err:
                unreadable.append(str(err))
                continue
            if window.event_id not in found and not self.is_done(window.event_id):
                found[window.event_id] = window
        windows = sorted(found.values(), key=lambda w: (w.start_time_ns, w.event_id))
        return PendingWindows(windows=tuple(windows), unreadable=tuple(unreadable))

    def _load(self, name: str, pier_id: str | None) -> list[IdentificationResult]:
        if not self.root.is_dir():
            return []
        out = []
        for path in sorted(self.root.glob(f"*/{name}")):
            try:
                result = IdentificationResult.load_json(path)
            except (OSError, ValueError, KeyError, TypeError, PierMonitorError) as err:
                # e.g. a non-finite k1: never a baseline, never a crash of the command
                log.warning("%s: unreadable, skipped (not a baseline, not listed): %s", path,
                            err)
                continue
            if pier_id is None or result.pier_id == pier_id:
                out.append(result)
        return sorted(out, key=lambda r: (r.window_start_ns, r.event_id))
