"""One event, from its window to its results on disk: the step both entrances share.

:func:`identify_window` is what happens to every mainshock window, whether it comes from a
bag (:func:`pier_monitor.pipeline.identify_bag`, offline) or from the live ingest (the
identifier node): store the window, choose the baseline, train, check the result, write
the results, and return them.  The rules (where files go, which earlier event is the
baseline, what a failure leaves behind) are those of
:class:`~pier_monitor.store.ResultsStore`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor.core.identify.checks import (check_identification, reproduction_misfits,
                                               section_fit_limits)
from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.identify.selfcheck import self_check
from pier_monitor.core.ingest.settings import EventIngest
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.config import SpringParameters
from pier_monitor.core.identify.methods import IdentifySettings, Progress, identify
from pier_monitor.report.results import ResultsPaths, write_results
from pier_monitor.store import ResultsStore

__all__ = ["EventOutcome", "TrainingStopped", "identify_window"]


class TrainingStopped(Exception):  # noqa: N818 - a signal, not an error of the project
    """Raise it from a progress callback to stop a training without recording a failure.

    The window stays stored and the event pending (e.g. a node shutting down).
    """


@dataclass(frozen=True)
class EventOutcome:
    """What became of one event: identified, unreliable, or failed.

    Attributes
    ----------
    window : MeasuredWindow or None
        The window identified; None when the ingest gave no window (see ``ingest``).
    result : IdentificationResult
        The saved result; ``result.success`` is false when the training or the ingest
        failed (every section ``unknown``, the reason in ``result.message``), and its
        states are ``unreliable`` when it failed its self-check
        (``result.unreliable_reasons``).
    out_dir : Path
        The event's results directory.
    window_file : Path or None
        The stored window (None without a window).
    paths : ResultsPaths or None
        The files written for a successful identification; None after a failure (then
        ``out_dir / "failed.json"`` holds the result).
    ingest : EventIngest or None
        What the ingest made of the event (its findings, or why it gave no window), when
        known (offline: always; a window received live: None).
    """

    window: MeasuredWindow | None
    result: IdentificationResult
    out_dir: Path
    window_file: Path | None
    paths: ResultsPaths | None
    ingest: EventIngest | None = None

    @property
    def status(self) -> str:
        """``identified``, ``unreliable``, ``failed`` (training or ingest) or ``cut`` (the
        data begin or end during the event)."""
        if self.ingest is not None and self.ingest.window is None:
            return "cut" if self.ingest.status == "cut" else "failed"
        if not self.result.success:
            return "failed"
        return "unreliable" if self.result.unreliable_reasons else "identified"


def _checked_params(result: IdentificationResult, window: MeasuredWindow) -> SpringParameters:
    """The parameters the reproduction check judges: the identified ones, with ``k2`` of the
    springs that did not yield (``k2`` not identifiable, never reported) the design's where
    that is below the fit's.

    A spring that stayed on its elastic branch gives its fit no information on ``k2``, so
    the fit's ``k2`` may sit anywhere, at its bound too, and that says nothing of the
    identification (the field reconstruction reports the design's there already).  On the
    RC test-bed's ``just_yield`` shaking (E-Defense pier, full layout, seed 302) the upper
    section's ``k2`` sat at its bound ``0.5 k1`` while the section stayed elastic; judged as
    a fit at a limit it would make that section suspicious (rule 10 of
    :mod:`~pier_monitor.core.identify.damage`) for a parameter it never had."""
    p = result.params
    elastic = np.array([not s.k2_identifiable for s in result.sections])
    k2 = np.where(elastic, np.minimum(window.design.k2, p.k2), p.k2)  # never above the fit's
    return SpringParameters(p.k1, k2, p.fy, p.c)


def _models_misfit(reproduction: list[tuple[int, str]], misfit: dict[str, Any]) -> bool:
    """Whether the reproduced responses' misfit (:func:`~pier_monitor.core.identify.checks.
    reproduction_misfits`, ``(level, reason)``) is the model's: at two levels or more while
    the self-check (``misfit``, :meth:`~pier_monitor.core.identify.selfcheck.ModelMisfit.
    as_dict`) found a model misfit.  One level's is a sensor's, or a glitch's (the
    +500 mm wire sample that reaches the identification misfits level 3 alone), and makes
    the result unreliable.

    A field reconstruction of springs that cannot follow the pier misfits the measured
    displacements at every level: on the RC test-bed (BWBN springs, Table 1 pier, full
    layout, where the equation-error springs misfit and the field route is taken) by
    30-40 % RMS at just-yield (held-out seed 302) and 86-93 % strong (tuning seeds
    300-301), against 25-26 % allowed, while the self-check found the same model misfit.
    That is the model misfit the self-check reports, not a result to discard: it is
    evidence on every section (at least suspicious, rule 6 of
    :mod:`~pier_monitor.core.identify.damage`), and with bilinear springs their ``k1`` and
    DF are not identified (rule 8).
    """
    return misfit.get("kind") == "model" and len({lv for lv, _ in reproduction}) >= 2


def identify_window(window: MeasuredWindow, settings: IdentifySettings, store: ResultsStore, *,
                    progress: Callable[[Progress], None] | None = None,
                    figures: bool = True) -> EventOutcome:
    """Identify one window and write its results into the store.

    1. The window is stored in its event directory before training starts.
    2. The baseline is :meth:`ResultsStore.baseline_for` (the earliest earlier successful
       result of the same pier; none: the event has no ``k1`` change, only its difference
       from the design values).
    3. The method chosen identifies it (:func:`pier_monitor.core.identify.methods.identify`).
       With a baseline, the window carries the pier's rotation history before it
       (:meth:`ResultsStore.rotation_peaks_before`): the modified-Takeda springs start
       from the peaks the earlier events reached, not virgin.
    4. The result checks itself
       (:func:`~pier_monitor.core.identify.checks.check_identification`): any reason makes
       it *unreliable* — every state ``unreliable``, never intact, suspicious or damaged.
       Reproduced responses that misfit at two levels or more while the self-check below
       finds a model misfit are that misfit (:func:`_models_misfit`; ``result.json``'s
       ``model_misfit.reproduction_misfits``), not a reason to discard the result.
       A section whose fit ended at a limit (its damper near zero or far above its
       reference, its ``k2`` at its cap: :func:`~pier_monitor.core.identify.checks.
       section_fit_limits`) is that section's: it is suspicious, its ``c`` (``k2``) and DF
       not identified, and the other sections keep their states (rule 10 of
       :mod:`~pier_monitor.core.identify.damage`).  On the equation-error route, where each
       section's spring is fitted to its own moment, so is a ``k1`` out of its range.
       The identified model is simulated under the measured foundation motion and compared
       with the measured responses (:func:`~pier_monitor.core.identify.selfcheck.self_check`):
       a misfit at one level that the response does not explain (a sensor's) makes the
       result unreliable; a model misfit, a large hysteretic energy make sections at least
       suspicious (:meth:`IdentificationResult.with_evidence`), never a reliable intact.
       Sections whose rotations no sensor tells apart (a level between them unmeasured)
       share their damage under a model misfit or a reinforced-concrete family: none
       intact where one yielded, none damaged on its own DF (rule 11).  With a
       reinforced-concrete family, a section whose rotation no displacement sensor measures
       and whose reconstruction passes its yield rotation beside a yielded section "may
       have yielded", its DF not identified (rule 14).
       ``result.json`` holds the misfit (``model_misfit``) and each section's
       ``energy_index`` and ``evidence``.
    5. With a baseline, each section's DF is the cumulative one, on the virgin section's
       yield rotation (the baseline's, or this event's ``fy`` over the baseline's ``k1``)
       and the largest rotation so far; the event's own DF is kept beside it and the states
       are decided on the cumulative one
       (:meth:`~pier_monitor.core.identify.damage.IdentificationResult.with_cumulative_ductility`).
       The ``k1`` change is against the baseline, of the stiffness each event leaves the
       section with (:meth:`~pier_monitor.core.identify.damage.IdentificationResult.with_baseline`).
    6. The results are written (:func:`~pier_monitor.report.results.write_results`), with
       the window's ingest findings.

    A training that fails (a NaN loss, no GPU for ``device="cuda"``, out of memory) does not
    raise: it is recorded in the store as a failed result, which is returned.

    Parameters
    ----------
    window : MeasuredWindow
        The event window.
    settings : IdentifySettings
        Training settings.
    store : ResultsStore
        Where the window and the results go, and where the baseline comes from.
    progress : callable, optional
        ``progress(Progress)`` after every epoch; it may raise :class:`TrainingStopped`.
    figures : bool
        Also draw the report figures (a few seconds per event).

    Returns
    -------
    EventOutcome

    Raises
    ------
    TrainingStopped
        When ``progress`` raised it; nothing but the window was written.
    ReportError
        When the store cannot be written (names the file or directory).
    """
    window_file = store.start_event(window)
    out_dir = store.event_dir(window.event_id)
    history = store.history_before(window)  # the pier's earlier results, read once
    baseline, given = history.baseline, window
    if history.rotation_peaks is not None:
        given = replace(given, prior_rotation_peaks=history.rotation_peaks)
    if history.rotation_peaks_unidentified is not None:
        given = replace(given,
                        prior_rotation_peaks_unidentified=history.rotation_peaks_unidentified)
    try:
        run = identify(given, settings, callback=progress,
                       baseline_k1=None if baseline is None else baseline.params.k1)
    except TrainingStopped:
        raise
    except Exception as err:  # divergence, no GPU, out of memory: a failed result, not a crash
        failed = store.fail_window(window, device=settings.device, message=(
            f"identification failed: {type(err).__name__}: {err}"))
        return EventOutcome(window=window, result=failed, out_dir=out_dir,
                            window_file=window_file, paths=None)
    checked = _checked_params(run.result, window)
    bilinear = (run.result.family or {}).get("family") in (None, "bilinear")  # as rule 8
    own_fits = list(run.stages) == ["equation_error"]  # every section's fit its own
    reasons = check_identification(
        checked, run.reproduced, window, sections_apart=True, misfits_apart=True,
        k1_apart=own_fits, ductility=None if bilinear else run.result.ductility_factors)
    check = self_check(window, run.result.params, run.reproduced.theta, run.reproduced.a)
    misfit = check.misfit.as_dict()
    evidence = list(check.evidence)
    reproduction = reproduction_misfits(run.reproduced, window)
    if _models_misfit(reproduction, misfit):
        misfit["reproduction_misfits"] = [r for _, r in reproduction]
        levels = sorted({lv for lv, _ in reproduction})
        line = (f"model misfit: the identification's reproduced responses depart from the "
                f"measured at levels {', '.join(map(str, levels))}")
        evidence = [(*ev, line) for ev in evidence]
    else:
        reasons += [r for _, r in reproduction]
    reasons = [*reasons, *check.unreliable_reasons]
    result = run.result
    if baseline is not None and not reasons:  # an unreliable result's DF is no diagnosis
        result = result.with_cumulative_ductility(baseline, history.peak_rotations)
    result = result.with_evidence(
        check.energy_index, evidence, misfit,
        fit_limits=section_fit_limits(checked, window, k1_too=own_fits),
        measured_levels=window.coverage.motion,
        displacement_levels=window.coverage.displacement)
    run = replace(run, result=result.with_history_identified(window.coverage.displacement))
    written = write_results(run, window, out_dir, baseline=baseline, figures=figures,
                            check_reasons=reasons, members=run.members)
    return EventOutcome(window=window, result=written.result, out_dir=out_dir,
                        window_file=window_file, paths=written.paths)
