"""Damage indices, decisions on a section's state, identification results (SPEC §5, paper §4.5).

``DF_n = max_t |θ_n(t)| / θy_n`` from the reproduced responses; DF < 1.2 intact,
1.2 <= DF < 1.5 suspicious, DF >= 1.5 damaged.  A spring that never yielded has no
identifiable ``k2``/``fy``: its DF is only bounded (``DF <= max|θ| k1 / max|f| ≈ 1``) and it is
reported as intact with the identifiable flags false — never as numbers that look measured.

Without uncertainty (a single identification) that is the whole rule.  A section identified by
an ensemble carries a :class:`~pier_monitor.core.identify.uncertainty.SectionUncertainty`, and
:func:`decide_state` then decides (each promotion adds a plain-language reason):

1. the state is the most probable one over the members (a tie goes to the worse state);
2. where the 90 % DF interval straddles 1.2 or 1.5 (``lo < threshold <= hi``) an intact state
   becomes suspicious: the members do not agree on the class.  A straddle never demotes a
   state and never makes a section damaged (an interval across 1.5 says "suspicious or
   damaged", and the most probable state already chose between them);
3. "not yielded" (``k2``/``fy`` not identifiable, DF <= 1) stands only while the probability
   that the spring yielded is below :data:`P_YIELD_LOW`; a section reported as not yielded
   with a larger probability "may have yielded" and is at least suspicious, and never more
   than suspicious by the members alone: the identification itself says elastic, and the
   members that yielded are perturbed copies of its data (on the equation-error route a
   drawn gain difference between neighbouring levels is a rotation the moments do not
   explain, which a member's yield test may take for yielding);
4. a ``k1`` loss against an earlier event whose 90 % interval lies below zero by more than the
   identification's own scatter (:func:`k1_loss_beyond_scatter`) is cracking: the section
   is at least suspicious.  Against design values the rule does not apply: a design value
   is no measurement, its difference from an identified ``k1`` is no evidence of damage.

Evidence from the self-check by output error (:mod:`~pier_monitor.core.identify.selfcheck`)
applies with or without an ensemble, and only raises a state
(:meth:`IdentificationResult.with_evidence`):

5. a section whose energy index (hysteretic energy of its moment–rotation loop over the
   elastic energy at its peak) reaches ``ENERGY_INDEX_LARGE`` dissipated far more than an
   elastic section can: it is at least suspicious, whatever its DF;
6. when the identified model misfits the data systematically ("model misfit", several
   levels or a residual that follows the response), its DF is that of a model that does not
   follow the pier: a section whose energy index reaches ``ENERGY_INDEX_MISFIT``, or under a
   level whose misfit is beyond its allowance, is at least suspicious with the reason
   ``model misfit: ...``;
7. a misfit at one level only that the response does not explain is a sensor's, not the
   model's: the result is unreliable (the reason goes to the self-check's reasons);
8. a model misfit where the springs identified are bilinear (no reinforced-concrete family
   was chosen, or none could be fitted) says the bilinear spring
   does not follow the pier: every section's ``k1`` and ``DF`` are poorly identified, with
   the reason :data:`BILINEAR_MISFIT` and the size, and a DF that is not identified never
   makes a section damaged (at most suspicious, rule 6 making it at least that);
9. under a model misfit with any family, a section is damaged only where its 90 % DF interval
   lies wholly at or above 1.5: the members' spread leaves out the model's error, and their
   most probable state is no evidence of damage on its own.  (Where a modified-Takeda family
   was chosen the misfit is that of the bilinear fit beside it, which the self-check
   simulates: it says the bilinear does not follow the pier, and the Takeda's own model
   error is measured by nothing, so the rule asks the same of its DF.)  A damaged section
   whose interval reaches below 1.5, or that has no interval, is suspicious with the reason.
   Chosen on the tuning seeds of the RC test-bed (``rc_tuning``, 300-301): of the sections
   called damaged under a model misfit only one had an interval reaching below 1.5, Table 1,
   full layout, strong, seed 301,
   section 3, DF 1.73 [1.34, 2.07] where the reinforcement stayed elastic (true DF 0.74);
   the modified-Takeda springs followed the base, not the displacement errors of 2-3 % at
   levels 3-4.  A ``k1`` that rule 8 says is not identified, here or in the baseline, is no
   evidence of a ``k1`` loss either (rule 4 does not apply to it).
10. a section whose fit ended at a limit (:func:`~pier_monitor.core.identify.checks.
    section_fit_limits`: its damper near zero or far above its reference, its ``k2`` at its
    cap) has its ``c`` (or ``k2``) and DF not identified: it is suspicious, never intact
    or damaged, with the reason :data:`FIT_AT_LIMIT` (evidence, kept as rule 8's is), and
    its ``k1`` is no evidence of a loss; the other sections keep their states.  Before, such
    a section made the whole event unreliable, and with it no baseline for the next.
11. under a model misfit, or where a reinforced-concrete family was chosen (the pier is not
    bilinear, and the family's own error is measured by nothing), sections whose rotations
    no sensor tells apart (a level between them with neither an accelerometer nor a
    displacement sensor: the three-level layout) share what they show: where one of them is
    reported yielded, each of them gets the evidence :data:`SPLIT_UNMEASURED`
    (:func:`split_unmeasured_evidence`), so none is intact, and its DF is not identified
    (never damaged on it).  The measured levels bound the rotation of the whole span; a
    model that is not the pier's puts it in one section or another.  Found on the held-out
    suite's RC draws of the three-level layout once the field route's Takeda ran there
    (Table 1, seed 618: section 2 damaged at DF 1.94 against a true 1.10, the base 0.95
    against 2.72; seed 616: the base 0.04 against 4.14 beside section 2 at 3.66 against
    2.40), so those draws are no longer held out for it; and on the RC suite's held-out BWBN
    runs (Table 1, just-yield, seed 303: section 2 damaged at 1.68 against a true 0.99 with
    the Takeda chosen and no model misfit), so that suite's three-level rows are no longer
    held out for it either.  Bilinear springs that reproduce the data resolve the split by
    their yield moments, and keep their states.
12. where a reinforced-concrete family was chosen, a section whose spring puts its yield
    rotation beyond :data:`MAX_YIELD_ROTATION_RATIO` times the design's ``fy/k1``
    (:func:`yield_out_of_reach_evidence`) is no RC section: the fit traded its yielding for
    a soft spring that never yields, and its neighbours may carry the plastic rotation that
    is its.  It gets the evidence :data:`YIELD_OUT_OF_REACH` (never intact, its DF not
    identified), and so does each neighbour where one of the three is reported yielded
    (never damaged on its own DF).  Found on the RC test-bed's tuning seeds (``rc_tuning``,
    Table 1, accelerometers, strong shaking, seed 300): section 2 (true DF 2.42) fitted a
    yield rotation about 100 times the design's and read DF 0.02, and section 3 was damaged
    at DF 2.55 against a true 0.74.  On the held-out suite's tuning draws (accelerometers,
    seeds 620-656, both piers, 358 Takeda sections) the ratio reached 8.9 at most; the
    same failure on its RC seeds 616 and 618 (Table 1, accelerometers: ratios 94 and 20 at
    the base, read DF 0.04 and 0.13 against 4.14 and 2.72) had been seen before the rule
    was made, so those draws are no longer held out for it.
13. on the field reconstruction with bilinear springs, a section reported not yielded, both
    of whose end levels are measured, whose spring reaches its fitted yield line and whose
    yield test gained at least ``FieldSettings.yield_hint_share`` (0.5) of the fit's
    remaining chi-square, short of the
    ``yield_share`` (2) that calls it yielded, "may have yielded" by the fit's own test
    (:func:`yield_test_evidence`, the evidence :data:`YIELD_TEST_SHORT`): at least
    suspicious, kept as the self-check's evidence is.  Rule 3 reads the members, whose yield
    tests a share near the threshold splits so that few of them yield: on the held-out
    suite's tuning draws (E-Defense, accelerometers, seed 655) section 2 at a true DF of 1.60
    was reported intact with P(yield) 0.03 and a share of 0.78.
14. where a reinforced-concrete family was chosen, a section reported not yielded whose
    rotation no displacement sensor measures (an end level without one: the field
    reconstruction), whose reconstructed peak rotation passes the idealised yield rotation of
    its identified skeleton, next to a section reported yielded, "may have yielded"
    (:func:`yield_split_evidence`, the evidence :data:`YIELD_SPLIT`): the accelerations
    hardly tell how the plastic rotation is split between two neighbouring springs, and the
    fit's yield test, which holds the spring elastic while its neighbours take up the
    rotation, cannot confirm its yield.  Its DF is not identified (flagged, and its 90 %
    interval reaches up to its yielded neighbour's DF), it is at least suspicious, and its
    ``yield_status`` says "may have yielded".  Found on the drawn two-shaking sequences' tuning
    seeds (``rc_sequence_drawn_tuning``, Table 1, accelerometers): section 2, beside a
    yielded base, read DF 1.00 [1.00, 1.00] "not yielded" against true DFs of 1.07-4.11 in
    6 events.  Of the Takeda sections on accelerometers that passed their yield rotation
    without passing the test (those sequences' tuning seeds and the held-out suite's tuning
    draws 620-639, both piers: 59 sections), the 20 beside a yielded section held those 6
    and 14 elastic ones at true DFs of 0.70-0.97; none of the 39 elsewhere had yielded
    (true DFs up to 0.98), so they keep "not yielded".
15. a section both of whose end levels are measured, whose ``k1``, ``c`` and DF are all
    poorly identified, is never damaged on a DF of 1.5 or more (:func:`unidentified_evidence`,
    the evidence :data:`SECTION_UNIDENTIFIED`): nothing the data pin down of its spring
    bears the call (rule 9 lets a DF interval clear of 1.5 make a section damaged under a
    model misfit, however wide; with the section's stiffness and damping unidentified too,
    that interval is the posterior of a model the data do not fix).  Over the benchmark
    suites' full and accelerometer layouts that record the flags, the default route's
    sections with a DF of 1.5 or more and those three flags were 19: 17 elastic (true DFs
    0.16-1.00, all suspicious but one) and 2 yielded (true DFs 1.64 and 3.16, both
    suspicious).  The one was found on the drawn sequences' tuning seed 620 (Table 1,
    accelerometers, second shaking: section 4 damaged at DF 3.22 [1.84, 3.86] against a
    true 0.52).  It costs a right call where the data happened to clear 1.5: the ``rc``
    suite's BWBN E-Defense full strong run, seed 303, base damaged at 4.49 [1.51, 9.21]
    against a true 3.26, is suspicious with it.  On the three-level layout the flags of a section with an
    unmeasured end say where the sensors are, not what the data fix, and the rule does not
    apply.
16. under a model misfit, or where a reinforced-concrete family was chosen, a section
    reported yielded above a section reported not yielded (not the base: its neighbour
    below) is never damaged on its DF (:func:`yield_above_elastic_evidence`, the evidence
    :data:`YIELD_ABOVE_ELASTIC`), and its DF is not identified.  The moment a pier carries
    grows towards its base, so a section yields above one that stays elastic only where its
    strength drops by more than the moment does (a cut-off of the bars, which a bridge
    engineer wants inspected: the section stays at least suspicious); a spring family that
    is not the pier's puts crack-opening loops there as yielding at a low yield moment.
    Found on the drawn two-shaking sequences' second held-out set
    (``rc_sequence_drawn_fresh``, seeds 660-671, Table 1, full layout, second shaking):
    section 4 damaged at DF 3.77 [1.99, 4.89] and 3.18 [1.77, 8.89] against true DFs of
    0.58 and 0.61 (seeds 663 and 666), with section 3 below reported not yielded (0.90 and
    1.00 against 0.81 and 0.85), so that set is no longer held out for it.  No section of
    the other suites was damaged with its lower neighbour not yielded, and no RC test-bed
    section yielded above an elastic one (their true DFs fall with height); bilinear springs
    that reproduce the data keep their states.

A section's state probabilities (``uncertainty.p_state``, the members' shares) follow the
self-check's evidence as its state does (:func:`_p_state_with_evidence`): the members never
saw it, and a section raised to suspicious by it was shown "suspicious (P 0.00)".
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import atomic_path, nan_if_none, to_strict_json
from pier_monitor.core.ingest.window import MeasuredWindow

from pier_monitor.core.ingest.findings import Finding

from .states import DAMAGED_DF, SUSPICIOUS_DF, DamageState, classify_ductility, is_diagnosis
from .uncertainty import (K1ChangeInterval, SectionUncertainty, Spread, df_reaching,
                          k1_change_interval)

__all__ = [
    "RESIDUAL_ROTATION_S",
    "VIRGIN_START_STIFFNESS",
    "RC_STIFFNESS_RESOLUTION",
    "rotation_peaks_after",
    "BILINEAR_MISFIT",
    "MODEL_MISFIT_NOT_DAMAGED",
    "FIT_AT_LIMIT",
    "SPLIT_UNMEASURED",
    "DAMAGED_DF",
    "P_YIELD_LOW",
    "SUSPICIOUS_DF",
    "DamageState",
    "classify_ductility",
    "decide_state",
    "k1_loss_beyond_scatter",
    "k1_loss_reason",
    "overall_state",
    "split_unmeasured_evidence",
    "yield_out_of_reach_evidence",
    "YIELD_OUT_OF_REACH",
    "MAX_YIELD_ROTATION_RATIO",
    "YIELD_TEST_SHORT",
    "yield_test_evidence",
    "YIELD_SPLIT",
    "yield_split_evidence",
    "SECTION_UNIDENTIFIED",
    "unidentified_evidence",
    "YIELD_ABOVE_ELASTIC",
    "yield_above_elastic_evidence",
    "sections_ends_measured",
    "with_section_evidence",
    "with_k1_unresolved",
    "p_overall_with_section_evidence",
    "ductility_factors",
    "SectionResult",
    "IdentificationResult",
    "build_sections",
    "IDENTIFIABILITY_LIMITS",
    "NO_INTERVAL",
    "NO_INTERVAL_FAMILY",
    "poorly_identified",
    "with_identifiability",
    "capped_ductility",
    "member_ductility",
    "failed_result",
    "failed_event_result",
    "k1_change_pct",
]

#: Length of the end of a window over which its residual rotation is averaged, s
#: (:func:`rotation_peaks_after`): a few periods of the piers' free vibration.
RESIDUAL_ROTATION_S = 1.0


def rotation_peaks_after(theta: np.ndarray, dt: float,
                         prior: np.ndarray | None = None) -> np.ndarray:
    """The rotation history a window leaves its springs with, in the next window's frame.

    Per section the largest positive and negative rotation reached, in the window or before
    it (``prior``, in its frame), less the residual rotation the window ends with (the mean
    of its last :data:`RESIDUAL_ROTATION_S`): the next window's displacements start from
    rest, its zero.

    Parameters
    ----------
    theta : ndarray, shape (T, N)
        The window's spring rotations, rad (measured, or the reconstruction's).
    dt : float
        Sampling period, s.
    prior : ndarray, shape (2, N), optional
        The peaks before the window (row 0 ``>= 0``, row 1 ``<= 0``), rad.

    Returns
    -------
    ndarray, shape (2, N)
        Row 0 the positive peaks (``>= 0``), row 1 the negative (``<= 0``), rad.
    """
    th = np.asarray(theta, dtype=float)
    if th.ndim != 2 or th.shape[0] < 1 or not np.all(np.isfinite(th)):
        raise InputDataError(f"theta: expected finite rotations of shape (T, N), got "
                             f"shape {th.shape}")
    if not (math.isfinite(dt) and dt > 0):
        raise InputDataError(f"dt: expected a positive sampling period in s, got {dt}")
    before = np.zeros((2, th.shape[1])) if prior is None else np.asarray(prior, dtype=float)
    if before.shape != (2, th.shape[1]):
        raise InputDataError(f"prior: expected shape (2, {th.shape[1]}), got {before.shape}")
    tail = min(th.shape[0], max(1, int(round(RESIDUAL_ROTATION_S / dt))))
    residual = th[-tail:].mean(axis=0)
    return np.stack([np.maximum(np.maximum(before[0], th.max(axis=0)) - residual, 0.0),
                     np.minimum(np.minimum(before[1], th.min(axis=0)) - residual, 0.0)])


#: The float fields of a section (``null`` in a result file is NaN).
_SECTION_FLOATS = ("z_bottom_m", "z_top_m", "k1", "k2", "fy", "c", "yield_angle_rad",
                   "max_angle_rad", "ductility_factor")

#: Largest relative half-width of a 90 % interval (``(hi − lo) / (2 |mean|)``, see
#: :meth:`~pier_monitor.core.identify.uncertainty.Spread.relative_half_width`) of a
#: well-identified quantity; a wider one is "poorly identified" (:func:`poorly_identified`):
#:
#: * ``k1`` ±10 %: a crack costs a section 10-30 % of its initial stiffness, and the k1 loss
#:   against an earlier event is the evidence of it; an interval wider than ±10 % cannot tell
#:   a cracked section from an intact one;
#: * ``DF`` ±30 %: the states change at DF 1.2 and 1.5, 25 % apart; an interval wider than
#:   ±30 % spans more than a class, the DF does not say which;
#: * ``k2``, ``fy`` ±30 %: the yield angle ``fy / k1``, and with it the DF, moves as ``fy``
#:   does, so ``fy`` has the DF's limit; ``k2`` (the post-yield slope, a tenth of ``k1`` or
#:   less) sets the plastic excursion at the same order;
#: * ``c`` ±30 %: the damper carries a small share of the moment and is the least identified
#:   of the four on every route; ±30 % still tells a lightly damped section from a heavily
#:   damped one.
IDENTIFIABILITY_LIMITS = {"k1": 0.10, "k2": 0.30, "fy": 0.30, "c": 0.30, "DF": 0.30}

#: What the outputs say where there is no interval: a single identification.
NO_INTERVAL = "no interval (1 member)"
#: ... and where the spring family chosen is not the bilinear and its own posterior was not
#: drawn: the ensemble's members refit bilinear springs, so their spread is not the chosen
#: family's and is not shown.
NO_INTERVAL_FAMILY = ("no interval (modified-Takeda springs chosen; the ensemble refits "
                      "bilinear springs)")

#: The start of rule 8's evidence line: the self-check found a model misfit and the springs
#: identified are bilinear.  Measured on the RC test-bed (``rc`` benchmark, tuning seeds 300-301,
#: both piers, strong and just-yield shakings, all three layouts): where it applies (24 of 48
#: RC runs: the modified-Takeda and Bouc-Wen springs on the three-level layout, and wherever
#: the bilinear was kept on them) the 90 % DF intervals of the 12 reliable runs held 1 of 16
#: yielded sections' true DF, and a section whose reinforcement stayed elastic was called
#: damaged on a bilinear DF of 53; where a Takeda family was chosen, 16 of 18 (on the
#: bilinear test-bed the check never fired).
BILINEAR_MISFIT = "bilinear springs misfit"

#: The start of rule 9's reason: a section called damaged on a model that misfits, whose DF
#: interval does not clear 1.5.
MODEL_MISFIT_NOT_DAMAGED = "model misfit, DF not clear of damaged"

#: The start of rule 10's evidence: a section whose fit ended at a limit (its damper near
#: zero or far above its reference, its ``k2`` at its cap); its DF is not identified.
FIT_AT_LIMIT = "fit at a limit"

#: The start of rule 11's evidence: a section whose rotation no sensor tells apart from a
#: neighbour's, under a model misfit, in a span where one of them yielded; its DF is not
#: identified.
SPLIT_UNMEASURED = "split not measured"

#: The start of rule 15's evidence: a section with both end levels measured whose ``k1``,
#: ``c`` and DF are all poorly identified; its DF is not identified.
SECTION_UNIDENTIFIED = "section not identified"

#: The start of rule 16's evidence: a section reported yielded above a section reported not
#: yielded, under a model misfit or with a reinforced-concrete family; its DF is not
#: identified.
YIELD_ABOVE_ELASTIC = "yielded above a section that did not"

#: The start of rule 12's evidence: a section whose spring puts its yield rotation out of
#: reach (beyond :data:`MAX_YIELD_ROTATION_RATIO` times the design's), or its neighbour where
#: one of them yielded; its DF is not identified.
YIELD_OUT_OF_REACH = "yield out of reach"

#: Largest ratio of an RC family's yield rotation to the design's ``fy/k1`` that is still an
#: RC section's (rule 12).  Design values are known to tens of per cent; on the held-out
#: suite's tuning draws (:func:`~pier_monitor.bench_heldout.heldout_case`, Takeda springs,
#: accelerometers, seeds 620-656, both piers) the field reconstruction's Takeda sections
#: reached 8.9 at most (Table 1, seed 641, section 3, true DF 0.83); the degenerate spring of
#: the RC test-bed's tuning seed 300 (rc_tuning, Table 1, accelerometers, strong) about 100.
#: On the three-level layout (seeds 620-645, Table 1, 150 sections) one section passed 10:
#: seed 628, section 2 at 13.6, true DF 2.77 read 0.14 (a degenerate spring too).
MAX_YIELD_ROTATION_RATIO = 10.0
#: Relative error, upward, of the stiffness a modified-Takeda fit leaves a section with when
#: it started from a virgin spring after an earlier event (the pier's history not measured:
#: accelerometer layouts, :meth:`SectionResult.rebased`): the fit takes the cracked
#: section's first reloading for a stiff virgin skeleton and ends too soft, so the change
#: against the earlier event overstates the loss (two-shaking sequences, tuning seeds
#: 620-625, both piers, accelerometers: E-Defense base -30.6 % against a true -17.1 %).
#: The change's 90 % interval reaches this much higher (in quadrature with the draws').
#: Chosen on those tuning sequences: the shown changes' intervals held the true change in
#: 6 of 15 without it, 12 with 0.2 (and 0.25), 13 with 0.4; the three still missed are two
#: Table 1 second sections with too little loss and one elastic section's +6.8 %.
VIRGIN_START_STIFFNESS = 0.2
#: Relative resolution of the stiffness an RC family (a modified-Takeda fit) leaves a
#: section with, that its draws do not show: the draws hold the window's data, not the
#: history the spring started from (itself reconstructed where only accelerations are
#: measured) nor the family's own error.  A change against an earlier event combines it,
#: once for each of the two events, in quadrature with the draws' into both ends of its
#: 90 % interval (:func:`~pier_monitor.core.identify.uncertainty.k1_change_interval`).
#: Chosen on the two-shaking sequences' tuning seeds (``rc_sequence_drawn_tuning``, seeds
#: 610-615 and 620-625, both piers, full and accelerometer layouts) as the smallest step of
#: 0.01 at which the shown changes' intervals held the true change in at least the nominal
#: 90 %: 36 of 46 without it, 40 with 0.04, 43 with 0.05 (accelerometers 16 → 21 of 24).
#: Most misses were by one or two points (e.g. Table 1 seed 610, section 2: -31.2 %
#: [-33.3, -17.2] against -34.9 %).  A loss smaller than about 7 % is no longer beyond the
#: scatter (no "cracking" line) where it is not beyond this resolution.
RC_STIFFNESS_RESOLUTION = 0.05
#: Rule 13's evidence: a section reported elastic whose yield test's share reached
#: ``FieldSettings.yield_hint_share``, short of what calls it yielded
#: (:func:`yield_test_evidence`).
YIELD_TEST_SHORT = "may have yielded by the yield test"
#: Rule 14's evidence: a section reported elastic whose reconstructed rotation passes its
#: idealised yield rotation beside a yielded section, on rotations no displacement sensor
#: measures (:func:`yield_split_evidence`).
YIELD_SPLIT = "may have yielded beside a yielded section"

#: A section is reported "not yielded" only while the probability that its spring yielded
#: (the share of the ensemble's members) is below this.
P_YIELD_LOW = 0.1


def ductility_factors(theta: np.ndarray, params: SpringParameters) -> np.ndarray:
    """``max_t |θ_n| / θy_n`` for angles of shape (T, N); returns shape (N,)."""
    theta = np.asarray(theta, dtype=float)
    if theta.ndim != 2 or theta.shape[1] != params.n_springs:
        raise InputDataError(f"theta: expected shape (T, {params.n_springs}), got {theta.shape}")
    return np.max(np.abs(theta), axis=0) / params.yield_angles


def capped_ductility(max_angle: np.ndarray, yield_angle: np.ndarray,
                     yielded: np.ndarray) -> np.ndarray:
    """Ductility factors ``max|θ| / θy``, at most 1 where the spring did not yield.

    A spring that never yielded has ``θy >= max|θ|``: its DF is at most 1, whatever ``fy``
    bound the fit could give (a poorly converged ``k1`` would otherwise turn the bound into a
    large DF).  Arrays broadcast together (e.g. (N,) or (M, N)).
    """
    df = np.asarray(max_angle, dtype=float) / np.asarray(yield_angle, dtype=float)
    return np.where(np.asarray(yielded, dtype=bool), df, np.minimum(df, 1.0))


def member_ductility(theta: np.ndarray, params: np.ndarray, yielded: np.ndarray) -> np.ndarray:
    """Ductility factors of every member of an ensemble, (M, N), from its angles (M, T, N),
    rad, and parameters (M, N, 4) ``k1, k2, fy, c``, with the rule of
    :func:`capped_ductility`."""
    return capped_ductility(np.abs(theta).max(axis=1), params[..., 2] / params[..., 0], yielded)


def k1_change_pct(k1: np.ndarray, baseline_k1: np.ndarray) -> np.ndarray:
    """Change of ``k1`` against a baseline, %: ``100 (k1 / k1_baseline - 1)``, shape (N,).

    Raises
    ------
    InputDataError
        If the shapes differ or a baseline value is not finite and positive.
    """
    k1 = np.asarray(k1, dtype=float)
    base = np.asarray(baseline_k1, dtype=float)
    if base.shape != k1.shape:
        raise InputDataError(f"baseline k1: expected shape {k1.shape}, got {base.shape}")
    if not np.all(np.isfinite(base) & (base > 0)):
        raise InputDataError(f"baseline k1: expected finite positive values in N*m/rad, got "
                             f"{base.tolist()}")
    return 100.0 * (k1 / base - 1.0)


def k1_loss_beyond_scatter(change_pct: float, interval: K1ChangeInterval) -> bool:
    """Whether a ``k1`` change is a loss beyond the identification's own scatter.

    True when the change's 90 % interval lies below zero by more than the scatter:
    ``hi_pct < −scatter_pct`` (both in %), and the change itself is a loss.
    """
    return change_pct < 0 and interval.hi_pct < -interval.scatter_pct


def k1_loss_reason(change_pct: float, interval: K1ChangeInterval, baseline: str) -> str:
    """The reason line of a ``k1`` loss beyond the scatter (see :func:`k1_loss_beyond_scatter`).

    E.g. ``k1 -13.3 % [-15.1, -11.4] against event run1, beyond the identification scatter
    (1.2 %): cracking``.
    """
    return (f"k1 {change_pct:+.1f} % [{interval.lo_pct:+.1f}, {interval.hi_pct:+.1f}] against "
            f"{baseline}, beyond the identification scatter ({interval.scatter_pct:.1f} %): "
            "cracking")


def _too_wide(spread: Spread, name: str) -> bool:
    """Whether the 90 % interval ``spread`` of quantity ``name`` is wider than its
    :data:`IDENTIFIABILITY_LIMITS` (an interval of one member or none, NaN, is too wide)."""
    return not spread.relative_half_width() <= IDENTIFIABILITY_LIMITS[name]


def _may_have_yielded(yielded: bool, uncertainty: SectionUncertainty | None) -> bool:
    """Reported as not yielded, but the ensemble gives a probability of at least P_YIELD_LOW."""
    return (not yielded and uncertainty is not None and uncertainty.members >= 2
            and uncertainty.p_yielded >= P_YIELD_LOW)


def _is_model_misfit(model_misfit: dict[str, Any] | None) -> bool:
    """Whether the self-check's summary (``ModelMisfit.as_dict``) found a misfit of the
    model (kind ``model``), the condition of rules 8 and 9."""
    return (model_misfit or {}).get("kind") == "model"


#: The self-check lines that say a section's DF is not identified: rules 8
#: (:data:`BILINEAR_MISFIT`: nor is its ``k1``), 10 (:data:`FIT_AT_LIMIT`), 11
#: (:data:`SPLIT_UNMEASURED`), 12 (:data:`YIELD_OUT_OF_REACH`) and 16
#: (:data:`YIELD_ABOVE_ELASTIC`).
_DF_UNIDENTIFIED_EVIDENCE = (BILINEAR_MISFIT, FIT_AT_LIMIT, SPLIT_UNMEASURED, YIELD_OUT_OF_REACH,
                             YIELD_ABOVE_ELASTIC)


def _evidence_says_unidentified(evidence: Sequence[str]) -> bool:
    """Whether ``evidence`` holds a line of :data:`_DF_UNIDENTIFIED_EVIDENCE` (rules 8, 10,
    11, 12, 16: the section's DF is not identified) or rule 15's
    (:data:`SECTION_UNIDENTIFIED`: neither are its ``k1`` and ``c``)."""
    return any(e.startswith((*_DF_UNIDENTIFIED_EVIDENCE, SECTION_UNIDENTIFIED))
               for e in evidence)


def split_unmeasured_evidence(ductility: Sequence[float] | np.ndarray,
                              yielded: Sequence[bool] | np.ndarray,
                              measured_levels: Sequence[bool] | np.ndarray
                              ) -> list[tuple[str, ...]]:
    """Rule 11's evidence per section: one line for each section of a span whose inner
    levels no sensor measures, where a section of that span is reported yielded (DF above
    1); none otherwise (rule 11: apply it under a model misfit or a reinforced-concrete
    family).

    Parameters
    ----------
    ductility : sequence of float, shape (N,)
        The DF each section shows, from the base up (section ``i`` spans levels ``i - 1``
        to ``i``).
    yielded : sequence of bool, shape (N,)
        Whether each section is reported yielded.
    measured_levels : sequence of bool, shape (N,)
        Whether level ``i`` (1..N; the foundation, level 0, always is) has a sensor of its
        motion (an accelerometer or a displacement sensor).

    Raises
    ------
    InputDataError
        If ``yielded`` or ``measured_levels`` does not have one entry per DF.
    """
    df = np.asarray(ductility, dtype=float)
    measured = np.asarray(measured_levels, dtype=bool)
    n = df.size
    if np.shape(yielded) != (n,):
        raise InputDataError(f"yielded: expected {n} entries, got shape {np.shape(yielded)}")
    if measured.shape != (n,):
        raise InputDataError(f"measured levels: expected {n} entries, got shape "
                             f"{measured.shape}")
    out: list[tuple[str, ...]] = [()] * n
    first = 0
    for i in range(n):
        if i < n - 1 and not measured[i]:
            continue  # the span goes on above the unmeasured level i + 1
        span = range(first, i + 1)
        first = i + 1
        if len(span) < 2:
            continue
        shown = [j for j in span if yielded[j] or df[j] > 1.0]
        if not shown:
            continue
        dfs = ", ".join(f"section {j + 1} DF {df[j]:.2f}" for j in shown)
        line = (f"{SPLIT_UNMEASURED}: no sensor between levels {span[0]} and {span[-1] + 1} "
                f"tells the rotations of sections {span[0] + 1}-{span[-1] + 1} apart, and the "
                f"springs are not the pier's ({dfs}): damage anywhere in this span, its DF "
                "not identified")
        for j in span:
            out[j] = (line,)
    return out


def yield_test_evidence(yielded: Sequence[bool] | np.ndarray,
                        gain_share: Sequence[float] | np.ndarray | None,
                        hint_share: float, yield_share: float) -> list[tuple[str, ...]]:
    """Rule 13's evidence per section: a line for each section reported not yielded whose
    yield test's gain reached ``hint_share`` of the fit's remaining chi-square (short of
    ``yield_share``, which calls a spring yielded); none otherwise.

    Parameters
    ----------
    yielded : sequence of bool, shape (N,)
        Whether each section is reported yielded.
    gain_share : sequence of float, shape (N,), or None
        The field reconstruction's yield test per spring
        (:attr:`~pier_monitor.core.identify.field.FieldFit.yield_gain_share`: the rise of
        the chi-square when the spring is held elastic over the remaining chi-square; NaN
        where the yield line is never reached).  None or empty: no evidence.
    hint_share, yield_share : float
        The share from which a section "may have yielded", and the one that calls it
        yielded (``FieldSettings.yield_hint_share``, ``yield_share``).

    Raises
    ------
    InputDataError
        If ``gain_share`` does not have one entry per section.
    """
    y = np.asarray(yielded, dtype=bool)
    n = y.size
    if gain_share is None or np.size(gain_share) == 0:
        return [()] * n
    share = np.asarray(gain_share, dtype=float)
    if share.shape != (n,):
        raise InputDataError(f"yield test shares: expected {n} entries, got shape "
                             f"{share.shape}")
    return [(f"{YIELD_TEST_SHORT}: holding section {i + 1}'s spring elastic raises the "
             f"fit's chi-square by {share[i]:.2f} of what the fit leaves (yielded from "
             f"{yield_share:g} with a significant gain, may have yielded from "
             f"{hint_share:g})",)
            if not y[i] and np.isfinite(share[i]) and share[i] >= hint_share else ()
            for i in range(n)]


def with_section_evidence(sections: Sequence[SectionResult],
                          evidence: Sequence[Sequence[str]]) -> tuple[SectionResult, ...]:
    """``sections`` with each one's ``evidence`` (N sequences of reason lines) added to its
    own and applied as the self-check's is: a diagnosed section with evidence is at least
    suspicious, with the reasons, and its state probabilities follow
    (:func:`_p_state_with_evidence`).  For evidence the identification itself gives (rule
    13); :meth:`IdentificationResult.with_evidence` keeps it beside the self-check's.

    Raises
    ------
    InputDataError
        If ``evidence`` does not have one entry per section.
    """
    if len(evidence) != len(sections):
        raise InputDataError(f"section evidence: expected {len(sections)} entries, got "
                             f"{len(evidence)}")
    out = []
    for s, ev in zip(sections, evidence):
        ev = tuple(str(r) for r in ev)
        if ev and is_diagnosis(s.damage_state):
            s = _raised_by(replace(s, evidence=(*s.evidence, *ev)), ev, False)
        out.append(s)
    return tuple(out)


def _raised_by(section: SectionResult, evidence: tuple[str, ...], misfit: bool
               ) -> SectionResult:
    """``section`` with ``evidence`` applied to its state, reasons and state probabilities
    (at least suspicious; under a model misfit, rule 9's cap on damaged), where it is a
    diagnosis and there is evidence or a misfit; unchanged otherwise."""
    if not (is_diagnosis(section.damage_state) and (evidence or misfit)):
        return section
    state, reasons = _with_evidence(section.damage_state, section.reasons, evidence)
    if misfit:  # rule 9
        state, reasons = _misfit_caps_damaged(state, reasons, section.uncertainty)
    return replace(section, state=state.name.lower(), reasons=reasons,
                   uncertainty=_p_state_with_evidence(section.uncertainty, evidence, misfit))


def yield_out_of_reach_evidence(ductility: Sequence[float] | np.ndarray,
                                yielded: Sequence[bool] | np.ndarray,
                                yield_rotation_vs_design: Sequence[float] | np.ndarray | None
                                ) -> list[tuple[str, ...]]:
    """Rule 12's evidence per section: a line for each section whose yield rotation is
    beyond :data:`MAX_YIELD_ROTATION_RATIO` times the design's, and for its neighbours where
    one of the three is reported yielded (DF above 1); none otherwise.

    Parameters
    ----------
    ductility : sequence of float, shape (N,)
        The DF each section shows, from the base up.
    yielded : sequence of bool, shape (N,)
        Whether each section is reported yielded.
    yield_rotation_vs_design : sequence of float, shape (N,), or None
        The chosen RC family's yield rotation over the design's ``fy/k1``
        (:class:`~pier_monitor.core.identify.families.FamilyChoice`); None (the bilinear
        chosen, or no design): no evidence.

    Raises
    ------
    InputDataError
        If ``yielded`` or ``yield_rotation_vs_design`` does not have one entry per DF.
    """
    df = np.asarray(ductility, dtype=float)
    n = df.size
    if yield_rotation_vs_design is None:
        return [()] * n
    ratio = np.asarray(yield_rotation_vs_design, dtype=float)
    if np.shape(yielded) != (n,) or ratio.shape != (n,):
        raise InputDataError(f"yielded and yield rotations against the design: expected {n} "
                             f"entries, got shapes {np.shape(yielded)} and {ratio.shape}")
    shown = np.asarray(yielded, dtype=bool) | (df > 1.0)
    out: list[tuple[str, ...]] = [()] * n
    for i in np.flatnonzero(ratio > MAX_YIELD_ROTATION_RATIO):
        near = [j for j in (i - 1, i, i + 1) if 0 <= j < n]
        own = (f"{YIELD_OUT_OF_REACH}: section {i + 1}'s spring puts its yield rotation at "
               f"{ratio[i]:.0f} times the design's, where no RC section yields: whether it "
               "yielded is not identified, its DF not identified")
        out[i] = (*out[i], own)
        if not shown[near].any():
            continue
        dfs = ", ".join(f"section {j + 1} DF {df[j]:.2f}" for j in near if shown[j])
        for j in near:
            if j != i:
                out[j] = (*out[j], (
                    f"{YIELD_OUT_OF_REACH}: section {i + 1} beside it does not yield ({ratio[i]:.0f} "
                    f"times the design's yield rotation), so the rotation it shows may be its "
                    f"neighbour's ({dfs}): its DF not identified"))
    return out


def yield_split_evidence(ductility: Sequence[float] | np.ndarray,
                         yielded: Sequence[bool] | np.ndarray,
                         passed_yield: Sequence[float] | np.ndarray | None,
                         displacement_levels: Sequence[bool] | np.ndarray | None
                         ) -> list[tuple[tuple[str, ...], float]]:
    """Rule 14's evidence per section, with the upper end its DF interval reaches.

    A section reported not yielded whose ``passed_yield`` is above 1, whose rotation is not
    measured (one of its end levels has no displacement sensor), next to a section reported
    yielded, gets one line and the largest DF of its yielded neighbours; every other
    section ``((), nan)``.

    Parameters
    ----------
    ductility : sequence of float, shape (N,)
        The DF each section shows, from the base up.
    yielded : sequence of bool, shape (N,)
        Whether each section is reported yielded.
    passed_yield : sequence of float, shape (N,), or None
        The chosen RC family's reconstructed peak rotation over the idealised yield
        rotation of its skeleton (:class:`~pier_monitor.core.identify.families.
        FamilyChoice`: ``peak_rotation / idealised_yield_rotation``, dimensionless); None (the
        bilinear chosen): no evidence.
    displacement_levels : sequence of bool, shape (N,), or None
        Whether level ``i`` (1..N) has a displacement sensor (the foundation, level 0, is
        the reference of every displacement); None: no evidence.

    Raises
    ------
    InputDataError
        If ``yielded``, ``passed_yield`` or ``displacement_levels`` does not have one entry
        per DF.
    """
    df = np.asarray(ductility, dtype=float)
    n = df.size
    none: list[tuple[tuple[str, ...], float]] = [((), math.nan)] * n
    if passed_yield is None or displacement_levels is None:
        return none
    ratio = np.asarray(passed_yield, dtype=float)
    disp = np.asarray(displacement_levels, dtype=bool)
    y = np.asarray(yielded, dtype=bool)
    if y.shape != (n,) or ratio.shape != (n,) or disp.shape != (n,):
        raise InputDataError(f"yielded, passed yield and displacement levels: expected {n} "
                             f"entries, got shapes {y.shape}, {ratio.shape} and {disp.shape}")
    measured = sections_ends_measured(disp)
    out = list(none)
    for i in range(n):
        near = [j for j in (i - 1, i + 1) if 0 <= j < n and y[j]]
        if y[i] or measured[i] or not near or not ratio[i] > 1.0:
            continue
        bound = float(max(df[j] for j in near))
        dfs = ", ".join(f"section {j + 1} DF {df[j]:.2f}" for j in near)
        out[i] = ((f"{YIELD_SPLIT}: its reconstructed rotation passes its yield rotation "
                   f"({ratio[i]:.2f} times) beside a yielded section ({dfs}), and the "
                   "accelerations hardly tell how the plastic rotation is split between "
                   f"them: its DF not identified (up to {bound:.2f})",), bound)
    return out


def unidentified_evidence(ductility: Sequence[float] | np.ndarray,
                          flags: Sequence[Sequence[str]],
                          ends_measured: Sequence[bool] | np.ndarray
                          ) -> list[tuple[str, ...]]:
    """Rule 15's evidence per section: a line for each section whose DF is 1.5 or more,
    whose ``k1``, ``c`` and DF are all in its ``flags`` (``poorly_identified``), and both of
    whose end levels are measured; none otherwise.

    Parameters
    ----------
    ductility : sequence of float, shape (N,)
        The DF each section shows, from the base up.
    flags : sequence of sequence of str, N of them
        Each section's poorly identified quantities.
    ends_measured : sequence of bool, shape (N,)
        Whether both end levels of each section have a sensor of their motion
        (:func:`sections_ends_measured`).

    Raises
    ------
    InputDataError
        If ``flags`` or ``ends_measured`` does not have one entry per DF.
    """
    df = np.asarray(ductility, dtype=float)
    n = df.size
    ends = np.asarray(ends_measured, dtype=bool)
    if len(flags) != n or ends.shape != (n,):
        raise InputDataError(f"flags and measured ends: expected {n} entries, got "
                             f"{len(flags)} and shape {ends.shape}")
    return [(f"{SECTION_UNIDENTIFIED}: its k1, c and DF are all poorly identified although "
             f"both its end levels are measured: DF {df[i]:.2f} not identified",)
            if ends[i] and df[i] >= DAMAGED_DF and {"k1", "c", "DF"} <= set(flags[i]) else ()
            for i in range(n)]


def yield_above_elastic_evidence(ductility: Sequence[float] | np.ndarray,
                                 yielded: Sequence[bool] | np.ndarray
                                 ) -> list[tuple[str, ...]]:
    """Rule 16's evidence per section: a line for each section reported yielded whose
    neighbour below (not the foundation) is reported not yielded; none otherwise.

    Parameters
    ----------
    ductility : sequence of float, shape (N,)
        The DF each section shows, from the base up.
    yielded : sequence of bool, shape (N,)
        Whether each section is reported yielded.

    Raises
    ------
    InputDataError
        If ``yielded`` does not have one entry per DF.
    """
    df = np.asarray(ductility, dtype=float)
    y = np.asarray(yielded, dtype=bool)
    if y.shape != df.shape or df.ndim != 1:
        raise InputDataError(f"yielded: expected {df.size} entries, got shape {y.shape}")
    return [(f"{YIELD_ABOVE_ELASTIC}: reported yielded (DF {df[i]:.2f}) above section {i} "
             f"(DF {df[i - 1]:.2f}), which carries the larger moment and did not yield: a "
             "strength that drops by more than the moment (a cut-off of the bars) or loops "
             "the spring family misreads; its DF not identified",)
            if i > 0 and y[i] and not y[i - 1] else ()
            for i in range(df.size)]


def sections_ends_measured(measured_levels: Sequence[bool] | np.ndarray) -> np.ndarray:
    """Per section, shape (N,): whether both its end levels have a sensor (section ``i``
    spans levels ``i - 1`` and ``i``; the foundation, level 0, always has), from whether each
    level 1..N has one, shape (N,)."""
    measured = np.asarray(measured_levels, dtype=bool)
    return measured & np.r_[True, measured[:-1]]


def _k1_unidentified(section: SectionResult) -> bool:
    """Whether ``section``'s ``k1`` is no reference for a ``k1`` loss: rule 8 or 10 says it
    (or its fit) is not identified, or its ensemble left it without an interval (a ``k1``
    the search box ended, :func:`~pier_monitor.core.identify.uncertainty.
    without_k1_on_bound`); taken as exact it would turn its error into a loss beyond the
    scatter."""
    u = section.uncertainty
    return _evidence_says_unidentified(section.evidence) or (
        u is not None and u.members >= 2 and not u.k1.defined)


def _flagged(flags: tuple[str, ...], *names: str) -> tuple[str, ...]:
    """``flags`` (a section's ``poorly_identified``) with ``names`` added, in the order of
    :data:`IDENTIFIABILITY_LIMITS`."""
    return tuple(k for k in IDENTIFIABILITY_LIMITS if k in flags or k in names)


def _bilinear_misfit(model_misfit: dict[str, Any] | None, family: dict[str, Any] | None
                     ) -> str | None:
    """Rule 8's evidence line where the self-check's misfit (``model_misfit``, its
    ``as_dict``) is the model's and the springs identified are bilinear (``family`` None or
    the bilinear); None otherwise."""
    m = model_misfit or {}
    if not _is_model_misfit(m) or (family or {}).get("family") not in (None, "bilinear"):
        return None
    size = ""
    if m.get("worst_misfit_rel") is not None and m.get("worst_allowed_rel") is not None:
        size = (f" (level {m.get('worst_level')}'s {m.get('worst_quantity')} "
                f"{m['worst_misfit_rel']:.0%} RMS, allowed {m['worst_allowed_rel']:.0%})")
    return (f"{BILINEAR_MISFIT}: the bilinear springs identified do not reproduce the "
            f"measurements{size}, so the pier's springs are not bilinear: k1 and DF not "
            "identified")


def _df_clear_of_damaged(uncertainty: SectionUncertainty | None) -> bool:
    """Whether an ensemble's 90 % DF interval lies wholly at or above 1.5 (rule 9)."""
    if uncertainty is None or uncertainty.members < 2:
        return False
    df = uncertainty.ductility_factor
    return bool(df.defined and df.lo >= DAMAGED_DF)


def _p_state_with_evidence(uncertainty: SectionUncertainty | None, evidence: Sequence[str],
                           model_misfit: bool) -> SectionUncertainty | None:
    """The members' state probabilities with the self-check's evidence applied as the state
    is: evidence moves the intact share to suspicious (rules 5-8, 10-15); a DF the evidence
    says is not identified (rules 8, 10-12, 15), or one under a model misfit whose interval
    does not clear 1.5 (rule 9), moves the damaged share to suspicious.  The members never saw
    the self-check: a section raised to suspicious by it showed "suspicious (P 0.00)"."""
    if uncertainty is None or uncertainty.members < 2 or not (evidence or model_misfit):
        return uncertainty
    return replace(uncertainty, p_state=_shares_to_suspicious(
        uncertainty.p_state, intact=bool(evidence),
        damaged=_evidence_says_unidentified(evidence) or (
            model_misfit and not _df_clear_of_damaged(uncertainty))))


def _shares_to_suspicious(p: Sequence[float], *, intact: bool, damaged: bool
                          ) -> tuple[float, float, float]:
    """State probabilities ``p`` (intact, suspicious, damaged) with the intact share and/or
    the damaged share moved to suspicious."""
    p_i, p_s, p_d = (float(v) for v in p)
    if intact:
        p_i, p_s = 0.0, p_s + p_i
    if damaged:
        p_s, p_d = p_s + p_d, 0.0
    return p_i, p_s, p_d


def _misfit_caps_damaged(state: DamageState, reasons: tuple[str, ...],
                         uncertainty: SectionUncertainty | None
                         ) -> tuple[DamageState, tuple[str, ...]]:
    """Rule 9: under a model misfit, damaged only on a 90 % DF interval at or above 1.5
    (``uncertainty`` the section's, its DF interval the one the state is decided on);
    otherwise suspicious with the reason :data:`MODEL_MISFIT_NOT_DAMAGED`."""
    if state != DamageState.DAMAGED or _df_clear_of_damaged(uncertainty):
        return state, reasons
    df = None if uncertainty is None or uncertainty.members < 2 else uncertainty.ductility_factor
    what = (f"90 % interval [{df.lo:.2f}, {df.hi:.2f}]" if df is not None and df.defined
            else "no interval")
    return DamageState.SUSPICIOUS, (
        *reasons, f"{MODEL_MISFIT_NOT_DAMAGED} ({what}): the self-check found a model misfit, "
                  "not called damaged on it")


def _reference_spread(baseline: SectionResult) -> Spread | None:
    """The baseline's spread that the cumulative DF's reference rotation inherits, as a
    spread whose relative bounds move the DF the same way (None where the baseline has no
    members' spread).

    Where the baseline yielded the reference is its yield rotation ``θ*`` and its DF interval
    is that of ``θp / θ*``: a DF low in it is a ``θ*`` high in it, so a cumulative DF low too.
    Otherwise the reference is ``fy / k1_baseline`` and the cumulative DF goes with the
    baseline's ``k1`` (its spread where the uncertainty is of ``k1`` itself,
    :meth:`SectionResult.k1_spread_of`: a Takeda section's is of ``k_small_after``).
    """
    u = baseline.uncertainty
    if u is None:
        return None
    s = u.ductility_factor if baseline.yielded else baseline.k1_spread_of(baseline.k1)
    return s if s is not None and s.defined else None


def _cumulative_df_spread(own: Spread, event_df: float, df: float,
                          reference: Spread | None) -> Spread:
    """The cumulative DF's spread from the event's members' DF spread ``own`` (about the
    event's DF ``event_df``): scaled to the cumulative ``df``, and where ``reference`` is
    given (:func:`_reference_spread`) its relative bounds and scatter combined in quadrature
    with the event's, taken about ``df`` (as :func:`~.uncertainty.k1_change_interval` combines
    two events' ``k1``)."""
    scale = df / event_df
    s = replace(own, mean=own.mean * scale, std=own.std * scale, lo=own.lo * scale,
                hi=own.hi * scale)
    if reference is None or not s.defined or not df > 0:
        return s
    b_lo, b_hi, b_s = reference.relative_bounds()
    a_lo, a_hi = max(df - s.lo, 0.0) / df, max(s.hi - df, 0.0) / df
    std = s.std if math.isfinite(s.std) else 0.0
    # a DF is not negative: relative bounds below 100 % combine past zero
    return replace(s, lo=df * max(1.0 - math.hypot(a_lo, b_lo), 0.0),
                   hi=df * (1.0 + math.hypot(a_hi, b_hi)), std=math.hypot(std, df * b_s))


def decide_state(ductility_factor: float, yielded: bool,
                 uncertainty: SectionUncertainty | None = None, *,
                 k1_loss: str | None = None,
                 evidence: Sequence[str] = (),
                 cumulative: bool = False,
                 model_misfit: bool = False
                 ) -> tuple[DamageState, tuple[str, ...]]:
    """The state of a section and the reasons for every promotion (see the module's rules).

    Parameters
    ----------
    ductility_factor : float
        The section's DF (NaN: no diagnosis, the state is unknown).
    yielded : bool
        Whether the section is reported as yielded (its ``k2``/``fy`` identifiable).
    uncertainty : SectionUncertainty, optional
        The ensemble's uncertainty; without it (or with one member) the state is
        :func:`classify_ductility` of the DF and there are no reasons.
    k1_loss : str, optional
        The reason line of a ``k1`` loss beyond the scatter against an earlier event
        (:func:`k1_loss_reason`); it makes the section at least suspicious.  Used only with
        an uncertainty.
    evidence : sequence of str
        Reason lines of the self-check (a large energy index, a model misfit) or of the
        identification's own tests (rule 13): each makes the section at least suspicious,
        with or without an uncertainty.
    cumulative : bool
        True when ``ductility_factor`` is the cumulative DF on an earlier event's (virgin)
        yield rotation (:meth:`IdentificationResult.with_cumulative_ductility`).  The
        ensemble's members judged the event's own DF, so their most probable state does not
        apply: the state starts from the cumulative DF's class.  The uncertainty's DF interval
        is then the cumulative one (the members' interval scaled by the cumulative DF over the
        event's own and widened by the reference's uncertainty,
        :meth:`SectionResult.cumulative`), which the straddle rule reads.
    model_misfit : bool
        The self-check found a model misfit: damaged only on a DF interval clear of 1.5
        (rule 9).

    Returns
    -------
    state : DamageState
    reasons : tuple of str
        One plain-language line per promotion above the most probable state.
    """
    if not math.isfinite(ductility_factor):
        return DamageState.UNKNOWN, ()
    state, reasons = _decide(ductility_factor, yielded, uncertainty, k1_loss, evidence,
                             cumulative)
    return _misfit_caps_damaged(state, reasons, uncertainty) if model_misfit \
        else (state, reasons)


def _decide(ductility_factor: float, yielded: bool, uncertainty: SectionUncertainty | None,
            k1_loss: str | None, evidence: Sequence[str], cumulative: bool
            ) -> tuple[DamageState, tuple[str, ...]]:
    """:func:`decide_state` before rule 9, for a finite DF."""
    if uncertainty is None or uncertainty.members < 2:
        return _with_evidence(classify_ductility(ductility_factor), (), evidence)
    state = uncertainty.most_probable_state
    if not yielded:
        # the identification says elastic: the members that yielded make it "may have
        # yielded" (rule 3), never damaged on their own
        state = min(state, DamageState.SUSPICIOUS)
    reasons = []
    df = uncertainty.ductility_factor
    if cumulative:  # the members judged the event alone
        state = classify_ductility(ductility_factor)
    if state == DamageState.DAMAGED and df.lo < DAMAGED_DF and _too_wide(df, "DF"):
        # a poorly identified DF never drives a state: damaged only on an interval past 1.5
        state = DamageState.SUSPICIOUS
        reasons.append(f"DF poorly identified (90 % interval [{df.lo:.2f}, {df.hi:.2f}]): "
                       "not called damaged on it")
    crossed = [t for t in (SUSPICIOUS_DF, DAMAGED_DF) if df.straddles(t)]
    if crossed and state == DamageState.INTACT:
        state = DamageState.SUSPICIOUS
        reasons.append(f"DF 90 % interval [{df.lo:.2f}, {df.hi:.2f}] straddles "
                       f"{' and '.join(f'{t:g}' for t in crossed)}")
    if _may_have_yielded(yielded, uncertainty):
        state = max(state, DamageState.SUSPICIOUS)
        reasons.append(f"may have yielded (P(yielded) {uncertainty.p_yielded:.2f} of "
                       f"{uncertainty.members} members)")
    if k1_loss:
        state = max(state, DamageState.SUSPICIOUS)
        reasons.append(k1_loss)
    return _with_evidence(state, tuple(reasons), evidence)


def _with_evidence(state: DamageState, reasons: tuple[str, ...], evidence: Sequence[str]
                   ) -> tuple[DamageState, tuple[str, ...]]:
    """At least suspicious, with the evidence's reasons, when there is any evidence; not
    damaged on a DF that the evidence of rules 8, 10, 11, 12, 15 or 16
    (:func:`_evidence_says_unidentified`) says is not identified."""
    evidence = tuple(str(e) for e in evidence)
    if not evidence:
        return state, reasons
    if state == DamageState.DAMAGED and _evidence_says_unidentified(evidence):
        state = DamageState.SUSPICIOUS
        why = ("the bilinear springs misfit" if any(e.startswith(BILINEAR_MISFIT)
                                                    for e in evidence)
               else "the section's fit ended at a limit" if any(e.startswith(FIT_AT_LIMIT)
                                                               for e in evidence)
               else "its rotation is not told apart from its neighbours'"
               if any(e.startswith(SPLIT_UNMEASURED) for e in evidence)
               else "its k1, c and DF are all poorly identified"
               if any(e.startswith(SECTION_UNIDENTIFIED) for e in evidence)
               else "a neighbour's spring does not yield, its rotation may be this one's"
               if any(e.startswith(YIELD_OUT_OF_REACH) for e in evidence)
               else "it yielded above a section that did not")
        reasons = (*reasons, f"DF not identified ({why}): not called damaged on it")
    return max(state, DamageState.SUSPICIOUS), reasons + evidence


@dataclass(frozen=True)
class SectionResult:
    """Identified state of one section (spring ``index`` + 1 and its damper), SI units.

    ``k1_change_pct`` is the change of ``k1`` against the result's baseline (%, None without
    one: the first event of a pier has no change); against an earlier event, of the
    stiffness each event leaves the section with, ``k_small_after`` for a family other than
    the bilinear (:meth:`IdentificationResult.with_baseline`).  ``k1_vs_design_pct`` is the difference of
    ``k1`` from the design values (%, None when not known): no change and never a basis of a
    state (:meth:`IdentificationResult.with_design_k1`).  ``ductility_factor_upper_bound``
    (in :meth:`to_dict` too) says that the DF is only an upper bound.  A section identified
    by an ensemble also has its ``uncertainty``, the 90 % interval of that change
    (``k1_change_lo_pct``, ``k1_change_hi_pct``, %) with the identification scatter it is
    judged against (``k1_change_scatter_pct``, percentage
    points), and the ``reasons`` for a state promoted above the most probable one
    (:func:`decide_state`); all None / empty for a single identification.

    ``energy_index`` is the hysteretic energy of the section's moment–rotation loop over the
    elastic energy at its peak (dimensionless, :func:`~pier_monitor.core.identify.selfcheck.
    energy_indices`; None when not computed); ``evidence`` the reasons that make the section
    at least suspicious (the identification's own, rule 13, then the self-check's, rules 5-12
    of the module), kept when the state is decided again against another baseline.

    ``poorly_identified`` names the quantities (``k1``, ``k2``, ``fy``, ``c``, ``DF``) whose
    90 % interval is wider than :data:`IDENTIFIABILITY_LIMITS` allows
    (:func:`poorly_identified`): shown with their interval, never a basis of a state.
    Empty without an ensemble (no interval: nothing flagged), except for ``k1`` and ``DF``
    under rule 8 of the module (a model misfit of bilinear springs, with or without one).

    ``ductility_factor`` and ``yield_angle_rad`` are what the state is decided on.  An event
    identified alone assumes springs undamaged at the window start; with an earlier event
    of the pier as baseline the DF is the cumulative one, the largest rotation so far over
    the virgin section's yield rotation
    (:meth:`IdentificationResult.with_cumulative_ductility`): then ``ductility_reference``
    says what it is measured on, and ``event_ductility_factor`` / ``event_yield_angle_rad``
    keep the event's own (on its own fit's yield rotation); None and ``""`` otherwise (the
    DF is the event's own).

    ``rotation_peaks_after_rad`` ``(θ+ >= 0, θ− <= 0)``, rad: the largest positive and
    negative spring rotation the section has reached, this event's and those it started
    from, less the residual rotation this event left (:func:`rotation_peaks_after`): what
    the next event's modified-Takeda spring starts from
    (:meth:`~pier_monitor.store.ResultsStore.rotation_peaks_before`).  Where the
    rotations were measured (displacements at every level), or reconstructed from an
    accelerometer at every level; None otherwise, and None for a reconstructed rotation whose
    DF is poorly identified (:meth:`IdentificationResult.with_history_identified`): carried
    without that, a reconstructed history put the Table 1 pier's plastic rotation in the
    wrong one of its two lowest sections (tuning sequences, README "The pier's history
    carried into the next event"; a DF flagged only because the data do not exclude a yield,
    :attr:`df_flagged_by_yield_profile_only`, keeps them: its peak rotation is identified).
    ``rotation_peaks_unidentified_rad``: that section's
    peaks where they are None for that reason; the next event's field reconstruction tries
    them too, beside the identified history and virgin springs, and keeps them only where
    they fit its data best
    (:func:`~pier_monitor.core.identify.field_families.fit_field_families`).
    ``history_known``: the family's spring (a modified Takeda) started from the pier's
    identified history (kept where it fitted better than a virgin spring), not from a
    virgin spring nor from peaks that were not identified;
    a change against an earlier event of one that did not carries
    :data:`VIRGIN_START_STIFFNESS` (:meth:`rebased`).

    ``df_yield_not_excluded`` ``(hi_draws, hi)``: for a section reported not yielded whose
    yield the data do not exclude (the field reconstruction's yield profile,
    :attr:`~pier_monitor.core.identify.families.FamilyChoice.yield_not_excluded_df`), the
    upper end of its DF interval from the posterior draws alone (NaN without draws: no
    interval) and the DF the profile's refit reached, up to which the event's own interval
    now reaches (a cumulative DF's interval, on another yield rotation, is rescaled; these two
    numbers are the event's); None elsewhere.  ``df_flagged_by_yield_profile``: its DF is
    poorly identified by the width of that interval, and would not be by the draws' own.
    """

    index: int
    z_bottom_m: float
    z_top_m: float
    k1: float
    k2: float
    fy: float
    c: float
    yield_angle_rad: float
    max_angle_rad: float
    ductility_factor: float
    state: str
    yielded: bool
    k2_identifiable: bool
    fy_identifiable: bool
    k1_change_pct: float | None = None
    uncertainty: SectionUncertainty | None = None
    k1_change_lo_pct: float | None = None
    k1_change_hi_pct: float | None = None
    k1_change_scatter_pct: float | None = None
    reasons: tuple[str, ...] = ()
    k1_vs_design_pct: float | None = None
    energy_index: float | None = None
    evidence: tuple[str, ...] = ()
    family: str = "bilinear"
    k_secant: float | None = None
    k_small_after: float | None = None
    stiffness_loss_pct: float | None = None
    poorly_identified: tuple[str, ...] = ()
    event_ductility_factor: float | None = None
    event_yield_angle_rad: float | None = None
    ductility_reference: str = ""
    rotation_peaks_after_rad: tuple[float, float] | None = None
    history_known: bool = False
    rotation_peaks_unidentified_rad: tuple[float, float] | None = None
    df_yield_not_excluded: tuple[float, float] | None = None
    df_flagged_by_yield_profile: bool = False

    @property
    def df_flagged_by_yield_profile_only(self) -> bool:
        """Whether the DF is poorly identified only because its interval reaches up to the
        DF whose yield the data do not exclude (``df_flagged_by_yield_profile``, and no rule
        of the self-check flagged it: 8, 10, 11, 12, 14, 16).  Its peak rotation is then
        identified, its yield rotation is not."""
        return (self.df_flagged_by_yield_profile and "DF" in self.poorly_identified
                and not any(str(e).startswith((*_DF_UNIDENTIFIED_EVIDENCE, YIELD_SPLIT))
                            for e in self.evidence))

    @property
    def ductility_factor_upper_bound(self) -> bool:
        """Whether the DF is only an upper bound (about 1): the spring did not yield.

        False where there is no DF (NaN: a failed identification), where the section
        may have yielded beside a yielded section (rule 14, evidence :data:`YIELD_SPLIT`):
        its DF is not identified, and its interval reaches past 1; and where the data do not
        exclude its yield (``df_yield_not_excluded``, the interval reaching past 1).
        """
        return (not self.yielded and math.isfinite(self.ductility_factor)
                and not any(str(e).startswith(YIELD_SPLIT) for e in self.evidence)
                and not (self.df_yield_not_excluded is not None
                         and self.df_yield_not_excluded[1] > 1.0))

    @property
    def damage_state(self) -> DamageState:
        """The state as an enum."""
        return DamageState[self.state.upper()]

    @property
    def yield_status(self) -> str:
        """``"yielded"``, ``"not yielded"`` or ``"may have yielded"``.

        A section reported as not yielded "may have yielded" when its ensemble gives a
        probability of yielding of at least :data:`P_YIELD_LOW` (rule 3), or its own yield
        test fell just short (rule 13, evidence :data:`YIELD_TEST_SHORT`), or it passed its
        yield rotation beside a yielded section (rule 14, :data:`YIELD_SPLIT`).
        """
        if self.yielded:
            return "yielded"
        short = any(str(e).startswith((YIELD_TEST_SHORT, YIELD_SPLIT)) for e in self.evidence)
        return ("may have yielded" if short or _may_have_yielded(False, self.uncertainty)
                else "not yielded")

    def k1_spread_of(self, stiffness: float) -> Spread | None:
        """The 90 % spread of ``stiffness`` (N·m/rad) where this section's uncertainty is
        of it, else None.  ``uncertainty.k1`` is the spread of ``k1`` for bilinear springs
        and of ``k_small_after`` for another family (the stiffness a change against an
        earlier event compares, :meth:`IdentificationResult.small_amplitude_stiffness`;
        :func:`~pier_monitor.core.identify.families.takeda_draws`)."""
        u = self.uncertainty
        own = self.k1 if self.family == "bilinear" else self.k_small_after
        if u is None or own is None or not math.isfinite(own) or stiffness != own:
            return None
        return u.k1

    def rebased(self, baseline_k1: float, change_pct: float, baseline_label: str,
                baseline_spread: Spread | None = None, *, event: bool = False,
                stiffness: float | None = None, baseline_unidentified: bool = False,
                model_misfit: bool = False) -> SectionResult:
        """A copy with its ``k1`` change against a new baseline, and its state decided again.

        Parameters
        ----------
        baseline_k1 : float
            The baseline's ``k1``, N·m/rad.
        change_pct : float
            ``100 (k1 / baseline_k1 − 1)`` (:func:`k1_change_pct`).
        baseline_label : str
            What the baseline is (for the reason line).
        baseline_spread : Spread, optional
            The baseline identification's ``k1`` spread.
        event : bool
            The baseline is an earlier event: a ``k1`` loss beyond the scatter is cracking.
        stiffness : float, optional
            The stiffness compared with the baseline, N·m/rad (default ``k1``); the change
            has an interval only where the uncertainty is of it (:meth:`k1_spread_of`).
        baseline_unidentified : bool
            The baseline's ``k1`` is not identified (rule 8 there): no loss against it is
            evidence of cracking, nor is one of this section's ``k1`` where rule 8 applies here.
        model_misfit : bool
            The self-check found a model misfit (rule 9 of the module).

        A stiffness gain beyond the interval (its lower end above zero) against an earlier
        event, of a section of an RC family, flags its ``k1`` poorly identified: a
        reinforced-concrete section does not stiffen in an earthquake.  On the two-shaking
        sequences (``bench_rc_sequence_drawn``) every such change was wrong: 7 of 7 on the
        tuning seeds (true changes -6.6 to 0 %, six already flagged), 3 of 3 on the held-out
        ones (one shown: E-Defense accelerometers, seed 642, section 2, +35.8 %
        [+29.0, +64.7] against a true -1.9 %; that one was seen before the rule was made).
        Counted before :data:`RC_STIFFNESS_RESOLUTION` widened the intervals; with it the
        rule no longer fires on gains within it (held out 643, Table 1 base, +4.4 %
        [-3.1, +11.8] against 0.0 %).
        """
        lo = hi = scatter = None
        loss = None
        u = self.uncertainty
        own = self.k1 if stiffness is None else float(stiffness)
        spread = self.k1_spread_of(own)
        if u is not None and u.members >= 2 and spread is not None and spread.defined:
            # an RC family's stiffness after an earlier event: known to RC_STIFFNESS_RESOLUTION;
            # a Takeda fit started virgin after one: the stiffness it leaves is low by up to
            # VIRGIN_START_STIFFNESS (the truth lies above)
            rc = event and self.family != "bilinear"
            virgin = rc and not self.history_known
            interval = k1_change_interval(own, spread, baseline_k1, baseline_spread,
                                          stiffer_by=VIRGIN_START_STIFFNESS if virgin else 0.0,
                                          resolution=RC_STIFFNESS_RESOLUTION if rc else 0.0)
            lo, hi, scatter = interval.lo_pct, interval.hi_pct, interval.scatter_pct
            identified = not (baseline_unidentified or _k1_unidentified(self))
            if event and identified and k1_loss_beyond_scatter(change_pct, interval):
                loss = k1_loss_reason(change_pct, interval, baseline_label)
        state, reasons = decide_state(self.ductility_factor, self.yielded, u, k1_loss=loss,
                                      evidence=self.evidence,
                                      cumulative=bool(self.ductility_reference),
                                      model_misfit=model_misfit)
        flags = self.poorly_identified
        if event and self.family != "bilinear" and lo is not None and lo > 0:
            flags = _flagged(flags, "k1")  # a cracked section does not stiffen
        return replace(self, k1_change_pct=float(change_pct), k1_change_lo_pct=lo,
                       k1_change_hi_pct=hi, k1_change_scatter_pct=scatter,
                       state=state.name.lower(), reasons=reasons, poorly_identified=flags)

    def cumulative(self, baseline: SectionResult, peak_so_far: float,
                   baseline_label: str, *, model_misfit: bool = False) -> SectionResult:
        """A copy whose DF is the cumulative one on ``baseline``'s virgin yield rotation.

        The reference yield rotation (:meth:`IdentificationResult.with_cumulative_ductility`):
        the baseline's own where its spring yielded (its yield rotation identified on the
        virgin section); otherwise this event's ``fy`` over the baseline's ``k1`` (the yield
        moment reached now on the virgin section's elastic stiffness).  The section counts as
        yielded if it yielded now or in the baseline; the DF is ``peak_so_far`` over the
        reference, at most 1 where it yielded in neither (as for a single event).  The state
        is decided again on that DF.  A section without a DF (NaN), a reference that is no
        positive finite rotation, or a baseline section whose DF rule 8 or 10 says is not
        identified (:data:`BILINEAR_MISFIT`, :data:`FIT_AT_LIMIT`), stays as it is.

        The DF interval goes with the DF shown: this event's members' interval, scaled by the
        cumulative DF over the event's own, and, where the section yielded, widened by the
        reference rotation's own uncertainty, which the baseline identified
        (:func:`_cumulative_df_spread`); where that makes it wider than its limit the DF is
        flagged poorly identified.  A section whose spring started from its measured history
        (``history_known``) on the baseline's yield rotation has the reference's
        uncertainty alone: its peak is measured, and its own yield rotation (what its
        members' DFs spread over) is not in the cumulative DF; nor is the flag its own
        interval's width gave it (a flag of the evidence, rules 8 and 10-12, stays).  ``model_misfit``: this event's self-check found a model
        misfit (rule 9 of the module).
        """
        if not math.isfinite(self.ductility_factor) or _evidence_says_unidentified(
                baseline.evidence):
            return self  # rules 8, 10: the baseline's yield rotation is not identified
        if baseline.yielded and math.isfinite(baseline.yield_angle_rad):
            theta_y = float(baseline.yield_angle_rad)
            what = f"the virgin yield rotation of {baseline_label}"
        else:
            theta_y = float(self.fy / baseline.k1)
            what = f"this event's fy over k1 of {baseline_label} (virgin)"
        if not (math.isfinite(theta_y) and theta_y > 0 and math.isfinite(peak_so_far)):
            return self
        yielded = bool(self.k2_identifiable or baseline.yielded)  # k2_identifiable: the event's own
        peak = max(float(peak_so_far), float(self.max_angle_rad))
        df = float(capped_ductility(peak, theta_y, yielded))
        own = self if not self.ductility_reference else replace(
            self, ductility_factor=self.event_ductility_factor,
            yield_angle_rad=self.event_yield_angle_rad)
        # the spring started from its measured history, on the baseline's yield rotation
        on_reference = self.history_known and baseline.yielded
        u = self.uncertainty
        if u is not None and self.ductility_factor > 0:
            event_spread = u.ductility_factor
            if on_reference:
                # the spring started from its measured history, the reference is the
                # baseline's yield rotation: this event's own, which a window starting past
                # yield tells poorly, is not in the cumulative DF, nor its spread
                own_df = float(self.ductility_factor)
                event_spread = Spread(own_df, 0.0, own_df, own_df)
            u = replace(u, ductility_factor=_cumulative_df_spread(
                event_spread, float(self.ductility_factor), df,
                _reference_spread(baseline) if yielded else None))
        flags = self.poorly_identified
        if on_reference and not _evidence_says_unidentified(self.evidence):
            # the event's own DF interval, whose width flagged it, is not this DF's
            flags = tuple(f for f in flags if f != "DF")
        if u is not None and _too_wide(u.ductility_factor, "DF"):
            # the reference's uncertainty can widen the interval past the DF's limit
            flags = _flagged(flags, "DF")
        # on the reference the event's own interval is not this DF's, nor is its profile;
        # and a yielded reference's spread can flag the DF on its own
        profile_only = self.df_flagged_by_yield_profile_only and not on_reference and not yielded
        out = replace(self, ductility_factor=df, yield_angle_rad=theta_y, yielded=yielded,
                      uncertainty=u, poorly_identified=flags,
                      df_flagged_by_yield_profile=profile_only,
                      event_ductility_factor=float(own.ductility_factor),
                      event_yield_angle_rad=float(own.yield_angle_rad),
                      ductility_reference=(f"cumulative: peak rotation so far {peak:.4g} rad "
                                           f"on {what}, {theta_y:.4g} rad"))
        state, reasons = decide_state(df, yielded, out.uncertainty, evidence=out.evidence,
                                      cumulative=True, model_misfit=model_misfit)
        # the k1-loss reason of a rebase stays (it does not depend on the DF)
        loss = tuple(r for r in self.reasons if r.startswith("k1 ") and "cracking" in r)
        if loss:
            state = max(state, DamageState.SUSPICIOUS)
            reasons = reasons + tuple(r for r in loss if r not in reasons)
        return replace(out, state=state.name.lower(), reasons=reasons)

    def to_dict(self) -> dict[str, Any]:
        """Plain form for JSON (the uncertainty as a dict or None, reasons as a list)."""
        d = asdict(self)
        d["uncertainty"] = None if self.uncertainty is None else self.uncertainty.to_dict()
        d["reasons"] = list(self.reasons)
        d["ductility_factor_upper_bound"] = self.ductility_factor_upper_bound
        d["evidence"] = list(self.evidence)
        d["poorly_identified"] = list(self.poorly_identified)
        for name in ("rotation_peaks_after_rad", "rotation_peaks_unidentified_rad",
                     "df_yield_not_excluded"):
            peaks = getattr(self, name)
            d[name] = None if peaks is None else list(peaks)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SectionResult:
        """Inverse of :meth:`to_dict`; a section written before uncertainty existed loads.

        A ``null`` number (strict JSON's form of NaN) is read as NaN.
        """
        d = dict(d)
        d.pop("ductility_factor_upper_bound", None)  # derived from ``yielded``
        for name in _SECTION_FLOATS:
            d[name] = nan_if_none(d[name])
        if d.get("uncertainty") is not None:
            d["uncertainty"] = SectionUncertainty.from_dict(d["uncertainty"])
        d["reasons"] = tuple(d.get("reasons", ()))
        d["evidence"] = tuple(d.get("evidence", ()))
        d["poorly_identified"] = tuple(d.get("poorly_identified", ()))
        for name in ("rotation_peaks_after_rad", "rotation_peaks_unidentified_rad",
                     "df_yield_not_excluded"):
            if d.get(name) is not None:
                d[name] = tuple(nan_if_none(v) for v in d[name])
        return cls(**d)


@dataclass(frozen=True)
class IdentificationResult:
    """Result of one identification (one event window).

    ``window_start_s`` is the window's first sample on the source's clock (s);
    ``window_start_ns`` the same instant in ns since the Unix epoch (0 when not known).
    ``k1_baseline`` says what the sections' ``k1_change_pct`` is relative to ("" when not
    stated), ``software_version`` the pier_monitor version that wrote the result.
    ``p_overall_state`` is, for an ensemble identification, the probability that the worst
    section is intact, suspicious, damaged
    (:func:`~pier_monitor.core.identify.uncertainty.overall_state_probabilities`), with the
    self-check's evidence applied as the states apply it (:meth:`with_evidence`); None for a
    single identification.

    ``unreliable_reasons`` are the reasons the result failed its self-check
    (:func:`~pier_monitor.core.identify.checks.check_identification`): when there are any,
    every section and the overall state are ``unreliable`` (:meth:`with_check_reasons`),
    whatever the ductility factors say.  ``findings`` are the ingest's findings about the
    event's data (repairs, exclusions, failures; sensor and time in each).  ``partial`` is
    why the window is partial (the data end during the shaking, after its strong motion),
    None for a complete event; result.json writes it as ``"partial": {"reason": ...}`` or
    ``null``.  ``model_misfit`` is the self-check by output error
    (:meth:`~pier_monitor.core.identify.selfcheck.ModelMisfit.as_dict`: ``fires``, ``kind``
    ``none``/``sensor``/``model``, ``reasons``, the worst relative RMS misfit and its
    allowance, one entry per level and quantity); None when it was not run.  ``family`` is
    the spring family chosen by evidence and why
    (:meth:`~pier_monitor.core.identify.families.FamilyChoice.as_dict`), None where the
    method did not compare families.
    """

    pier_id: str
    event_id: str
    sections: tuple[SectionResult, ...]
    overall_state: str
    window_start_s: float
    window_duration_s: float
    epochs: int
    final_loss: float
    wall_time_s: float
    device: str
    success: bool = True
    message: str = ""
    settings: dict[str, Any] = field(default_factory=dict)
    history: dict[str, list[float]] = field(default_factory=dict)
    window_start_ns: int = 0
    k1_baseline: str = ""
    software_version: str = ""
    p_overall_state: tuple[float, float, float] | None = None
    unreliable_reasons: tuple[str, ...] = ()
    findings: tuple[Finding, ...] = ()
    partial: str | None = None
    model_misfit: dict[str, Any] | None = None
    family: dict[str, Any] | None = None

    def __eq__(self, other: object) -> bool:
        """Field by field, a NaN equal to a NaN (a method that does not train has no loss;
        an unyielded spring has no ``k2``): a result equals its own saved copy."""
        if not isinstance(other, IdentificationResult):
            return NotImplemented
        return (json.dumps(self.to_dict(), sort_keys=True, default=str)
                == json.dumps(other.to_dict(), sort_keys=True, default=str))

    __hash__ = None  # mutable-looking contents (dicts, arrays): not hashable

    @property
    def reliable(self) -> bool:
        """An identification that ran and passed its self-check (its states are diagnoses)."""
        return self.success and not self.unreliable_reasons

    @property
    def misfit_is_model(self) -> bool:
        """Whether the self-check found a model misfit (``model_misfit``'s kind ``model``):
        rule 9 of the module applies to every state decided on this result."""
        return _is_model_misfit(self.model_misfit)

    @property
    def members(self) -> int:
        """Number of ensemble members behind the sections (1: a single identification)."""
        return max((s.uncertainty.members for s in self.sections
                    if s.uncertainty is not None), default=1)

    @property
    def intervals(self) -> str:
        """What the sections' intervals are, as result.json says it: ``90 % interval over M
        members`` for an ensemble, :data:`NO_INTERVAL` for a single identification,
        :data:`NO_INTERVAL_FAMILY` where a non-bilinear family was chosen and its own
        posterior not drawn; ``90 % interval over M draws of the modified-Takeda fit's
        posterior`` where it was (:func:`~pier_monitor.core.identify.families.takeda_draws`
        on a fully measured window, the field reconstruction's posterior otherwise)."""
        m = self.members
        bilinear = (self.family or {}).get("family") in (None, "bilinear")
        if m >= 2:
            return (f"90 % interval over {m} members" if bilinear
                    else f"90 % interval over {m} draws of the modified-Takeda fit's posterior")
        return NO_INTERVAL if bilinear or (self.settings or {}).get("members") == 1 \
            else NO_INTERVAL_FAMILY

    @property
    def params(self) -> SpringParameters:
        """The identified parameters as one set."""
        return SpringParameters(*(np.array([getattr(s, k) for s in self.sections])
                                  for k in ("k1", "k2", "fy", "c")))

    @property
    def ductility_factors(self) -> np.ndarray:
        """DF per section, shape (N,)."""
        return np.array([s.ductility_factor for s in self.sections])

    def with_k1_baseline(self, baseline_k1: np.ndarray, label: str, *,
                         spreads: Sequence[Spread | None] | None = None,
                         event: bool = False,
                         own_k1: np.ndarray | None = None,
                         unidentified: Sequence[bool] | None = None) -> IdentificationResult:
        """A copy whose ``k1`` changes are relative to ``baseline_k1`` (N,), N·m/rad.

        ``label`` names the baseline (e.g. ``"design values"``, ``"event run1"``).  The
        sections' change intervals and states are decided again (:meth:`SectionResult.rebased`):
        ``spreads`` are the baseline's ``k1`` spreads per section (None where it has none),
        ``event`` says that the baseline is an earlier event (:meth:`with_baseline`).
        ``own_k1`` (N,) is the stiffness compared with it (default the sections' ``k1``);
        ``unidentified`` (N,) says where the baseline's ``k1`` is not identified (rule 8 there,
        or no interval: no loss against it is cracking).
        """
        own = self.params.k1 if own_k1 is None else np.asarray(own_k1, dtype=float)
        change = k1_change_pct(own, baseline_k1)
        base = np.asarray(baseline_k1, dtype=float)
        spreads = [None] * len(self.sections) if spreads is None else list(spreads)
        if len(spreads) != len(self.sections):
            raise InputDataError(f"baseline k1 spreads: expected {len(self.sections)}, got "
                                 f"{len(spreads)}")
        unidentified = [False] * len(self.sections) if unidentified is None else list(unidentified)
        if len(unidentified) != len(self.sections):
            raise InputDataError(f"baseline k1 unidentified flags: expected {len(self.sections)}, "
                                 f"got {len(unidentified)}")
        sections = tuple(s.rebased(float(b), float(d), label, sp, event=event,
                                   stiffness=float(k), baseline_unidentified=bool(x),
                                   model_misfit=self.misfit_is_model)
                         for s, b, d, sp, k, x in zip(self.sections, base, change, spreads, own,
                                                      unidentified))
        if self.unreliable_reasons:  # a new baseline never makes an unreliable result a diagnosis
            sections = _unreliable_sections(sections, self.unreliable_reasons)
        overall = overall_state(sections) if self.success else self.overall_state
        return replace(self, sections=sections, k1_baseline=label, overall_state=overall)

    def without_k1_baseline(self) -> IdentificationResult:
        """A copy with no ``k1`` change (the first event of a pier: nothing to change from).

        The sections' changes and change intervals become None and ``k1_baseline`` empty;
        the states stay (a change against no earlier event never decided one).
        """
        sections = tuple(replace(s, k1_change_pct=None, k1_change_lo_pct=None,
                                 k1_change_hi_pct=None, k1_change_scatter_pct=None)
                         for s in self.sections)
        return replace(self, sections=sections, k1_baseline="")

    def with_design_k1(self, design_k1: np.ndarray) -> IdentificationResult:
        """A copy whose sections carry ``k1_vs_design_pct``, ``k1``'s difference from the
        design values ``design_k1`` (N,), N·m/rad.

        A design value is no measurement: the difference is shown beside the parameters
        and never decides a state, nor is it called a change.
        """
        diff = k1_change_pct(self.params.k1, design_k1)
        sections = tuple(replace(s, k1_vs_design_pct=float(d) if math.isfinite(d) else None)
                         for s, d in zip(self.sections, diff))
        return replace(self, sections=sections)

    def with_check_reasons(self, reasons: Sequence[str]) -> IdentificationResult:
        """A copy that failed its self-check for ``reasons`` (none: the result unchanged).

        Every section and the overall state become ``unreliable``; each section's
        ``reasons`` are the reasons naming it and those naming no section; ``message`` starts
        with ``unreliable:`` and the reasons.  The parameters and ductility factors stay, to
        be read as what the identification gave, not as a diagnosis.
        """
        reasons = tuple(str(r) for r in reasons)
        if not reasons:
            return self
        text = "unreliable: " + "; ".join(reasons)
        return replace(self, sections=_unreliable_sections(self.sections, reasons),
                       overall_state=DamageState.UNRELIABLE.name.lower(),
                       unreliable_reasons=reasons,
                       message=f"{text}; {self.message}" if self.message else text)

    def with_evidence(self, energy_index: Sequence[float] | np.ndarray,
                      evidence: Sequence[Sequence[str]],
                      model_misfit: dict[str, Any] | None = None,
                      fit_limits: Sequence[Sequence[tuple[str, str]]] | None = None,
                      measured_levels: Sequence[bool] | np.ndarray | None = None,
                      displacement_levels: Sequence[bool] | np.ndarray | None = None
                      ) -> IdentificationResult:
        """A copy with the self-check's energy indices, evidence and misfit summary.

        Every section with evidence becomes at least suspicious (a diagnosis only: unknown
        and unreliable sections stay so), its reasons extended by the evidence; later
        re-decisions (:meth:`with_k1_baseline`) keep it.  A model misfit of bilinear springs
        (rule 8 of the module) adds :data:`BILINEAR_MISFIT`'s line to every diagnosed
        section's evidence and ``k1`` and ``DF`` to its ``poorly_identified``.  A section
        with ``fit_limits`` (rule 10) gets a :data:`FIT_AT_LIMIT` line per reason, and the
        quantity at its limit (``c`` or ``k2``) and ``DF`` in its ``poorly_identified``.  Under
        a model misfit or with a reinforced-concrete family, with ``measured_levels``, the
        sections of a span whose inner levels no sensor measures get rule 11's line (:func:`split_unmeasured_evidence`) where one of
        them yielded, and ``DF`` in their ``poorly_identified``.  Where a reinforced-concrete
        family was chosen, a section whose yield rotation is out of reach, and its
        neighbours where one of them yielded, get rule 12's line
        (:func:`yield_out_of_reach_evidence`) and ``DF`` in their ``poorly_identified``; with
        ``displacement_levels``, a section not yielded whose reconstructed rotation passes its
        yield rotation beside a yielded section gets rule 14's line
        (:func:`yield_split_evidence`), ``DF`` in its ``poorly_identified`` and its DF
        interval up to that neighbour's DF.  Under a model misfit or with a reinforced-concrete
        family, a section reported yielded above one reported not yielded gets rule 16's
        line (:func:`yield_above_elastic_evidence`) and ``DF`` in its ``poorly_identified``.  A section at a DF of 1.5 or more with both end
        levels measured whose ``k1``, ``c`` and DF are all flagged (by then) gets rule 15's
        line (:func:`unidentified_evidence`): never damaged on that DF.
        The evidence the identification gave itself (rule 13, :func:`with_section_evidence`)
        stays, first, and is not applied again.

        Parameters
        ----------
        energy_index : sequence of float, shape (N,)
            Energy index per section (dimensionless).
        evidence : sequence of sequence of str, N of them
            The reasons that make each section at least suspicious (empty: none).
        model_misfit : dict, optional
            The misfit summary for ``result.json``
            (:meth:`~pier_monitor.core.identify.selfcheck.ModelMisfit.as_dict`).
        fit_limits : sequence of sequence of (str, str), N of them, optional
            Per section the quantities at a limit and the reasons
            (:func:`~pier_monitor.core.identify.checks.section_fit_limits`).
        measured_levels : sequence of bool, shape (N,), optional
            Whether each level (1..N) has a sensor of its motion (rules 11 and 15; None:
            every level).
        displacement_levels : sequence of bool, shape (N,), optional
            Whether each level (1..N) has a displacement sensor (rule 14; None: no rule 14).

        Raises
        ------
        InputDataError
            If ``energy_index``, ``evidence`` or ``fit_limits`` do not have one entry per
            section.
        """
        n = len(self.sections)
        energy = np.asarray(energy_index, dtype=float)
        limits = [()] * n if fit_limits is None else list(fit_limits)
        if energy.shape != (n,) or len(evidence) != n or len(limits) != n:
            raise InputDataError(f"self-check evidence: expected {n} sections, got energy "
                                 f"indices of shape {energy.shape}, {len(evidence)} "
                                 f"evidence lists and {len(limits)} fit-limit lists")
        bilinear_misfit = _bilinear_misfit(model_misfit, self.family)
        misfit = _is_model_misfit(model_misfit)
        rc_family = (self.family or {}).get("family") not in (None, "bilinear")
        split = ([()] * n if not (misfit or rc_family) or measured_levels is None
                 else split_unmeasured_evidence(
                     [x.ductility_factor for x in self.sections],
                     [x.yielded for x in self.sections], measured_levels))
        fam = self.family or {}
        reach = yield_out_of_reach_evidence(
            [x.ductility_factor for x in self.sections], [x.yielded for x in self.sections],
            fam.get("yield_rotation_vs_design") if rc_family else None)
        passed = (np.asarray(fam["peak_rotation"], dtype=float)
                  / np.asarray(fam["idealised_yield_rotation"], dtype=float)
                  if rc_family and fam.get("peak_rotation") is not None else None)
        apart = yield_split_evidence([x.ductility_factor for x in self.sections],
                                     [x.yielded for x in self.sections], passed,
                                     displacement_levels)
        above = ([()] * n if not (misfit or rc_family) else yield_above_elastic_evidence(
            [x.ductility_factor for x in self.sections], [x.yielded for x in self.sections]))
        if measured_levels is not None and np.shape(measured_levels) != (n,):
            raise InputDataError(f"measured levels: expected {n} entries, got shape "
                                 f"{np.shape(measured_levels)}")
        ends = sections_ends_measured(np.ones(n, dtype=bool) if measured_levels is None
                                      else measured_levels)
        sections = []
        for s, e, ev, lim, sp, far, (sv, upto), up in zip(self.sections, energy, evidence,
                                                         limits, split, reach, apart, above):
            # the identification's own evidence (rule 13), already applied, stays beside
            # the self-check's
            own = tuple(e for e in s.evidence if str(e).startswith(YIELD_TEST_SHORT))
            ev = tuple(r for r in (str(r) for r in ev) if r not in own)
            if sp and is_diagnosis(s.damage_state):  # rule 11
                ev = (*ev, *sp)
                s = replace(s, poorly_identified=_flagged(s.poorly_identified, "DF"))
            if far and is_diagnosis(s.damage_state):  # rule 12
                ev = (*ev, *far)
                s = replace(s, poorly_identified=_flagged(s.poorly_identified, "DF"))
            if sv and is_diagnosis(s.damage_state):  # rule 14
                ev = (*ev, *sv)
                s = replace(s, poorly_identified=_flagged(s.poorly_identified, "DF"),
                            uncertainty=df_reaching(s.uncertainty, upto))
            if up and is_diagnosis(s.damage_state):  # rule 16
                ev = (*ev, *up)
                s = replace(s, poorly_identified=_flagged(s.poorly_identified, "DF"))
            if bilinear_misfit and is_diagnosis(s.damage_state):  # rule 8
                ev = (*ev, bilinear_misfit)
                s = replace(s, poorly_identified=_flagged(s.poorly_identified, "k1", "DF"))
            if lim and is_diagnosis(s.damage_state):  # rule 10
                ev = (*ev, *(f"{FIT_AT_LIMIT}: {r}: its DF is not identified" for _, r in lim))
                s = replace(s, poorly_identified=_flagged(s.poorly_identified,
                                                          *(q for q, _ in lim), "DF"))
            if is_diagnosis(s.damage_state):  # rule 15, on the flags of all the rules above
                ev = (*ev, *unidentified_evidence([s.ductility_factor], [s.poorly_identified],
                                                  [bool(ends[s.index])])[0])
            s = _raised_by(replace(s, energy_index=float(e), evidence=(*own, *ev)), ev, misfit)
            sections.append(s)
        sections = tuple(sections)
        overall = overall_state(sections) if self.success else self.overall_state
        return replace(self, sections=sections, overall_state=overall,
                       model_misfit=model_misfit,
                       p_overall_state=_p_overall_with_evidence(
                           self.p_overall_state, sections, overall, misfit))

    def with_history_identified(self, displacement_levels: Sequence[bool] | np.ndarray
                                ) -> IdentificationResult:
        """A copy without the rotation history (``rotation_peaks_after_rad`` None) of each
        section whose rotation was reconstructed, not measured (an end level without a
        displacement sensor), and whose DF is poorly identified: its peak rotation is what
        the DF says is not identified, and the next event starts that spring virgin
        (:meth:`~pier_monitor.store.ResultsStore.rotation_peaks_before`), unless starting
        from those peaks fits its data better: they move to
        ``rotation_peaks_unidentified_rad``
        (:meth:`~pier_monitor.store.ResultsStore.history_before`).

        Parameters
        ----------
        displacement_levels : sequence of bool, shape (N,)
            Whether each level (1..N) has a displacement sensor.

        Raises
        ------
        InputDataError
            If ``displacement_levels`` does not have one entry per section.
        """
        n = len(self.sections)
        if np.shape(displacement_levels) != (n,):
            raise InputDataError(f"displacement levels: expected {n} entries, got shape "
                                 f"{np.shape(displacement_levels)}")
        measured = sections_ends_measured(np.asarray(displacement_levels, dtype=bool))
        return replace(self, sections=tuple(
            replace(s, rotation_peaks_after_rad=None,
                    rotation_peaks_unidentified_rad=s.rotation_peaks_after_rad)
            if not measured[s.index] and "DF" in s.poorly_identified
            and not s.df_flagged_by_yield_profile_only else s
            for s in self.sections))

    def with_baseline(self, baseline: IdentificationResult) -> IdentificationResult:
        """A copy whose ``k1`` changes are relative to an earlier event's result.

        The change is between the two identified events, of the stiffness each leaves the
        section with (:meth:`small_amplitude_stiffness`): ``k1`` for bilinear springs, the
        small-amplitude (unloading) stiffness after the event, ``k_small_after``, for a
        family whose stiffness degrades with the peak (the modified Takeda).  The bilinear
        ``k1`` of a degrading section is a secant over the event's cracked and yielded
        branches: between two shakings of the RC test-bed (``bench_rc_sequence``, seed 302)
        it fell by 63 % at the base where the springs' small-amplitude stiffness fell by 32 %,
        and ``k_small_after`` by 38 %.

        The baseline's ``k1`` spreads widen the change intervals, and a loss beyond the two
        identifications' scatter makes a section at least suspicious (cracking).
        """
        base = baseline.small_amplitude_stiffness
        return self.with_k1_baseline(
            base, f"event {baseline.event_id}", event=True,
            spreads=[s.k1_spread_of(float(k)) for s, k in zip(baseline.sections, base)],
            own_k1=self.small_amplitude_stiffness,
            unidentified=[_k1_unidentified(s) for s in baseline.sections])

    @property
    def small_amplitude_stiffness(self) -> np.ndarray:
        """Per section, N·m/rad: the stiffness the event leaves it with, what a ``k1`` change
        against an earlier event compares (:meth:`with_baseline`): ``k_small_after`` where
        the section's family is not the bilinear and it is a positive finite value, else
        ``k1`` (a bilinear spring unloads on ``k1``)."""
        return np.array([s.k_small_after if (s.family != "bilinear"
                                             and s.k_small_after is not None
                                             and math.isfinite(s.k_small_after)
                                             and s.k_small_after > 0) else s.k1
                         for s in self.sections], dtype=float)

    def with_cumulative_ductility(self, baseline: IdentificationResult,
                                  peak_so_far: np.ndarray | None = None
                                  ) -> IdentificationResult:
        """A copy whose DFs are the cumulative ones, on the virgin section's yield rotation.

        An event is identified alone, from springs taken as undamaged at its window start; a
        section cracked or yielded by an earlier event then fits a softer spring whose yield
        rotation is too large, and its own DF means less than it says (an engineer's DF is
        the peak rotation over the idealised yield rotation of the virgin section, RC_NOTES).
        With ``baseline`` (the pier's earliest reliable event, the virgin section as far as
        the monitoring knows it) each section's DF becomes (:meth:`SectionResult.cumulative`)

        * reference yield rotation: the baseline's own where its spring yielded there (its
          yield rotation was identified on the virgin section: the idealised yield of the
          identified skeleton, ``fy/k1`` for the bilinear); otherwise this event's ``fy``
          over the baseline's ``k1``: the yield moment is a strength, which cracking barely
          changes, while the stiffness that turns it into a rotation must be the virgin one;
        * peak rotation: the largest of this event's and ``peak_so_far`` (the earlier
          events' peaks, default the baseline's);
        * yielded where it yielded now or in the baseline; the DF at most 1 elsewhere.

        The event's own DF and yield rotation stay in ``event_ductility_factor`` and
        ``event_yield_angle_rad``, what the DF is measured on in ``ductility_reference``;
        the states are decided on the cumulative DF.  An unreliable or failed result, or a
        baseline of other sections, is returned unchanged.
        """
        if not self.reliable or len(baseline.sections) != len(self.sections):
            return self
        label = f"event {baseline.event_id}"
        peaks = (np.array([b.max_angle_rad for b in baseline.sections], dtype=float)
                 if peak_so_far is None else np.asarray(peak_so_far, dtype=float))
        if peaks.shape != (len(self.sections),):
            raise InputDataError(f"peak_so_far: expected {len(self.sections)} rotations, got "
                                 f"shape {peaks.shape}")
        peaks = np.where(np.isfinite(peaks), peaks, 0.0)
        sections = tuple(s.cumulative(b, float(p), label, model_misfit=self.misfit_is_model)
                         for s, b, p in zip(self.sections, baseline.sections, peaks))
        return replace(self, sections=sections, overall_state=overall_state(sections))

    def to_dict(self) -> dict[str, Any]:
        """Plain form for JSON."""
        d = asdict(self)
        d["sections"] = [s.to_dict() for s in self.sections]
        if self.p_overall_state is not None:
            d["p_overall_state"] = list(self.p_overall_state)
        d["unreliable_reasons"] = list(self.unreliable_reasons)
        d["findings"] = [f.as_dict() for f in self.findings]
        d["partial"] = None if self.partial is None else {"reason": self.partial}
        d["intervals"] = self.intervals
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> IdentificationResult:
        """Inverse of :meth:`to_dict`; a result written before uncertainty, the self-check or
        the findings existed loads."""
        d = dict(d)
        d.pop("intervals", None)  # derived from the sections' uncertainty
        d["sections"] = tuple(SectionResult.from_dict(s) for s in d["sections"])
        for name in ("window_start_s", "window_duration_s", "final_loss", "wall_time_s"):
            d[name] = nan_if_none(d[name])
        d["history"] = {k: [math.nan if v is None else v for v in vs]
                        if isinstance(vs, list) else vs
                        for k, vs in d.get("history", {}).items()}
        if d.get("p_overall_state") is not None:
            d["p_overall_state"] = tuple(float(v) for v in d["p_overall_state"])
        d["unreliable_reasons"] = tuple(str(r) for r in d.get("unreliable_reasons", ()))
        d["findings"] = tuple(Finding.from_dict(f) for f in d.get("findings", ()))
        d["partial"] = (d.get("partial") or {}).get("reason")
        return cls(**d)

    def save_json(self, path: str | Path) -> Path:
        """Write :meth:`to_dict` as strict JSON, atomically (a reader never sees half a file).

        A number that is not finite (a parameter of a failed identification, an undefined
        spread) is written as ``null`` (:func:`~pier_monitor.core.fileio.to_strict_json`);
        :meth:`load_json` reads it back as NaN.  Raises ``OSError`` when the file cannot be
        written.
        """
        path = Path(path)
        with atomic_path(path) as tmp:
            tmp.write_text(to_strict_json(self.to_dict(), indent=2) + "\n", encoding="utf-8")
        return path

    @classmethod
    def load_json(cls, path: str | Path) -> "IdentificationResult":
        """Read a file written by :meth:`save_json`."""
        return cls.from_dict(json.loads(Path(path).read_text()))


def build_sections(geometry: PierGeometry, params: SpringParameters, theta: np.ndarray,
                   yielded: np.ndarray, baseline_k1: np.ndarray | None = None,
                   uncertainty: Sequence[SectionUncertainty] | None = None,
                   yield_angles: np.ndarray | None = None) -> tuple[SectionResult, ...]:
    """Per-section results from identified parameters and reproduced angles (T, N).

    For springs that did not yield, ``fy`` is the lower bound ``max|f|`` the fit reports,
    so the DF given is an upper bound (about 1) and the identifiable flags are false.

    Parameters
    ----------
    geometry : PierGeometry
        The pier (N levels).
    params : SpringParameters
        The identified parameters (the ensemble's point estimate).
    theta : ndarray, shape (T, N)
        Reproduced spring angles, rad.
    yielded : ndarray of bool, shape (N,)
        Whether each spring is reported as yielded.
    baseline_k1 : ndarray, shape (N,), optional
        Reference of ``k1_change_pct``, N·m/rad (not an event: no cracking rule).
    uncertainty : sequence of SectionUncertainty, optional
        One per section from :func:`~pier_monitor.core.identify.uncertainty.summarize_members`;
        the states are then decided by :func:`decide_state`.  With one member it is dropped:
        the result is that of a single identification.
    yield_angles : ndarray, shape (N,), optional
        The yield rotations the DF is measured on, rad: the idealised yield of a skeleton
        other than the bilinear (default ``fy / k1``).
    """
    z = geometry.level_heights_m
    max_angle = np.max(np.abs(theta), axis=0)
    theta_y = params.yield_angles if yield_angles is None else np.asarray(yield_angles, float)
    df = capped_ductility(max_angle, theta_y, yielded)
    if uncertainty is not None:
        uncertainty = tuple(uncertainty)
        if len(uncertainty) != geometry.n_levels:
            raise InputDataError(f"uncertainty: expected {geometry.n_levels} sections, got "
                                 f"{len(uncertainty)}")
        if all(u.members < 2 for u in uncertainty):
            uncertainty = None
    out = []
    for i in range(geometry.n_levels):
        y = bool(yielded[i])
        u = None if uncertainty is None else uncertainty[i]
        state, reasons = decide_state(float(df[i]), y, u)
        out.append(SectionResult(
            index=i, z_bottom_m=float(z[i]), z_top_m=float(z[i + 1]), k1=float(params.k1[i]),
            k2=float(params.k2[i]), fy=float(params.fy[i]), c=float(params.c[i]),
            yield_angle_rad=float(theta_y[i]), max_angle_rad=float(max_angle[i]),
            ductility_factor=float(df[i]), state=state.name.lower(), yielded=y,
            k2_identifiable=y, fy_identifiable=y, uncertainty=u, reasons=reasons))
    if baseline_k1 is None:
        return tuple(out)
    change = k1_change_pct(params.k1, baseline_k1)
    base = np.asarray(baseline_k1, dtype=float)
    return tuple(s.rebased(float(b), float(d), "baseline") for s, b, d in zip(out, base, change))


def poorly_identified(section: SectionResult, ends_measured: bool = True) -> tuple[str, ...]:
    """The quantities of ``section`` whose 90 % interval is wider than
    :data:`IDENTIFIABILITY_LIMITS` allows, in the order ``k1, k2, fy, c, DF``.

    ``k2`` and ``fy`` count only where the section is reported yielded (elsewhere they are
    reported as not identifiable, no number); there an interval that fewer than two members
    made (the others did not yield) is poorly identified too.  Without an ensemble
    (``uncertainty`` None or one member) nothing is flagged: there is no interval.

    ``k1`` and ``c`` are poorly identified whatever their interval where a level at either
    end of the section has no sensor (``ends_measured`` False).  The stiffnesses of
    neighbouring sections between unmeasured levels trade off against each other and against
    the masses interpolated at those levels, a model error the members cannot see: on the coverage
    benchmark (E-Defense pier, "sparse" layout, accelerometers at levels 2 and 4 only,
    held-out seeds 200-204) sections 1-3 were off by 3-7 %, 11-26 % and 5-12 % alike in
    every seed, with their intervals' k1 coverage 65 % (strong) and 70 % (just_yield) even
    with the residuals in the members' perturbations.

    So is its ``c``: its damping trades off against its neighbours' as its stiffness does.
    On the held-out suite's tuning draws (bilinear springs, "sparse" layout, both piers,
    seeds 620-631 and the E-Defense pier's 632) the 90 % ``c`` intervals that were not
    flagged held the truth in 29 of 46 (63 %; of yielded sections 23 of 28); every one that
    missed was of such a section (17 of 17, off by 7-53 %).

    For the same reason the ``DF`` of such a section is poorly identified where it is
    reported yielded or its members give it a probability of yielding of at least
    :data:`P_YIELD_LOW`: its 90 % interval held the true DF of 7 of 10 truly yielded
    sections on drawn cases of the held-out suite's kind (E-Defense pier, "sparse", tuning
    seeds 620-627; the members' yield test there stays the strict one of
    :func:`~pier_monitor.core.identify.field._perturbed_members`).  A DF that is at most 1
    in every member but a few (a bound, not a value) is not flagged by this rule.
    """
    u = section.uncertainty
    if u is None or u.members < 2:
        return ()
    spreads = {"k1": u.k1, "k2": u.k2, "fy": u.fy, "c": u.c, "DF": u.ductility_factor}
    out = []
    for name in IDENTIFIABILITY_LIMITS:
        if name in ("k2", "fy") and not section.yielded:
            continue
        unmeasured_end = not ends_measured and (
            name in ("k1", "c")
            or (name == "DF" and (section.yielded or u.p_yielded >= P_YIELD_LOW)))
        if _too_wide(spreads[name], name) or unmeasured_end:
            out.append(name)  # NaN (an interval of one member or none) is no interval
    return tuple(out)


def with_identifiability(sections: tuple[SectionResult, ...],
                         measured: np.ndarray | None = None) -> tuple[SectionResult, ...]:
    """The sections with their :attr:`SectionResult.poorly_identified` (states unchanged).

    ``measured`` (N,), when given: whether level ``i + 1`` has an accelerometer or a
    displacement sensor (the foundation always counts as measured); a section with an
    unmeasured end has its ``k1`` and ``c``, and its ``DF`` where it may have yielded, poorly
    identified (:func:`poorly_identified`)."""
    if measured is None:
        return tuple(replace(s, poorly_identified=poorly_identified(s)) for s in sections)
    ends = np.asarray(measured, dtype=bool)
    ends = ends & np.concatenate([[True], ends[:-1]])
    return tuple(replace(s, poorly_identified=poorly_identified(s, bool(e)))
                 for s, e in zip(sections, ends, strict=True))


def with_k1_unresolved(sections: tuple[SectionResult, ...], unresolved: np.ndarray
                       ) -> tuple[SectionResult, ...]:
    """The sections with ``k1`` poorly identified where ``unresolved`` (N,) says the method
    cannot resolve it (states unchanged); only where there is an interval (an ensemble):
    without one nothing is flagged."""
    flags = np.asarray(unresolved, dtype=bool)
    if flags.shape != (len(sections),):
        raise InputDataError(f"unresolved k1: expected {len(sections)} sections, got shape "
                             f"{flags.shape}")
    return tuple(replace(s, poorly_identified=_flagged(s.poorly_identified, "k1"))
                 if f and s.uncertainty is not None and s.uncertainty.members >= 2 else s
                 for s, f in zip(sections, flags))


def with_family(sections: tuple[SectionResult, ...], family: Any) -> tuple[SectionResult, ...]:
    """The sections with what the spring family chosen for the event says of them: its
    name, the cracked/secant stiffness to yield, the small-amplitude stiffness after the
    event and the loss the event caused (``family`` a
    :class:`~pier_monitor.core.identify.families.FamilyChoice`)."""
    return tuple(replace(
        s, family=family.family, k_secant=float(family.secant_yield_stiffness[s.index]),
        k_small_after=float(family.small_amplitude_stiffness[s.index]),
        stiffness_loss_pct=float(-100.0 * family.stiffness_degradation[s.index]),
        history_known=bool(family.sections[s.index].prior_peak > 0
                           and family.sections[s.index].prior_peaks_identified))
        for s in sections)


def _p_overall_with_evidence(p: tuple[float, float, float] | None,
                             sections: tuple[SectionResult, ...], overall: str, misfit: bool
                             ) -> tuple[float, float, float] | None:
    """The members' probabilities of the worst section's state (intact, suspicious,
    damaged) with the self-check's evidence applied as the states apply it: where a
    diagnosed section has evidence the worst section is at least suspicious (the intact share
    goes to suspicious); where no section stays damaged and either a model misfit (rules
    8-9: members refitting a model that does not follow the pier) or a section's evidence
    that its DF is not identified (rules 8, 10: a fit at a limit) capped the damaged calls,
    the damaged share goes to suspicious too.  None stays None (a single
    identification)."""
    if p is None:
        return None
    diagnosed = [s for s in sections if is_diagnosis(s.damage_state)]
    capped = misfit or any(_evidence_says_unidentified(s.evidence) for s in diagnosed)
    return _shares_to_suspicious(
        p, intact=any(s.evidence for s in diagnosed),
        damaged=capped and overall != DamageState.DAMAGED.name.lower())


def p_overall_with_section_evidence(p: tuple[float, float, float] | None,
                                    sections: tuple[SectionResult, ...]
                                    ) -> tuple[float, float, float] | None:
    """The overall states' probabilities ``p`` (intact, suspicious, damaged) with the
    sections' own evidence (rule 13, :func:`with_section_evidence`) applied as their states
    apply it: the intact share goes to suspicious where a diagnosed section has evidence.
    Applying it again (:meth:`IdentificationResult.with_evidence`) changes nothing."""
    return _p_overall_with_evidence(p, tuple(sections), overall_state(tuple(sections)), False)


def overall_state(sections: tuple[SectionResult, ...]) -> str:
    """The worst diagnosis over the sections; ``unreliable`` if any section is.

    Sections without a diagnosis (unknown) are left out; ``unknown`` when none has one.
    """
    states = [s.damage_state for s in sections]
    if DamageState.UNRELIABLE in states:
        return DamageState.UNRELIABLE.name.lower()
    known = [s for s in states if is_diagnosis(s)]
    return (max(known) if known else DamageState.UNKNOWN).name.lower()


def _section_check_reasons(index: int, reasons: tuple[str, ...]) -> tuple[str, ...]:
    """The check reasons that concern section ``index`` (0-based): those naming it and those
    naming no section; a reason about another section only is summarised."""
    own = tuple(r for r in reasons if r.startswith(f"section {index + 1}:"))
    general = tuple(r for r in reasons if not r.startswith("section "))
    if own or general:
        return own + general
    return (f"the event's identification is unreliable ({reasons[0]})",)


def _unreliable_sections(sections: tuple[SectionResult, ...], reasons: tuple[str, ...]
                         ) -> tuple[SectionResult, ...]:
    """Every section ``unreliable``, with the reasons that concern it."""
    return tuple(replace(s, state=DamageState.UNRELIABLE.name.lower(),
                         reasons=_section_check_reasons(s.index, reasons)) for s in sections)


def failed_result(window: MeasuredWindow, *, device: str, message: str) -> IdentificationResult:
    """The result of an identification of ``window`` that failed (``success`` false).

    Every section is ``unknown`` with NaN parameters and no identifiable ``k2``/``fy``, so
    that a failure travels the same way as a diagnosis (result files, damage-state message)
    and is never read as one.  The window's findings are kept.

    Parameters
    ----------
    window : MeasuredWindow
        The window the identification was run on.
    device : str
        The training device asked for.
    message : str
        What went wrong.
    """
    return replace(failed_event_result(
        window.geometry, pier_id=window.pier_id, event_id=window.event_id,
        start_ns=window.start_time_ns, duration_s=window.duration_s,
        window_start_s=float(window.t[0]), device=device, message=message,
        findings=window.findings), partial=window.partial)


def failed_event_result(geometry: PierGeometry, *, pier_id: str, event_id: str, start_ns: int,
                        duration_s: float, message: str, device: str = "",
                        window_start_s: float = 0.0, findings: Sequence[Finding] = ()
                        ) -> IdentificationResult:
    """The failure record of an event, also one without a window (the ingest failed, or the
    data end during it): every section ``unknown``, NaN parameters, ``success`` false.

    Parameters
    ----------
    geometry : PierGeometry
        The pier's geometry at the event (N sections).
    pier_id, event_id : str
    start_ns : int
        Start of the event's window (or of its span), ns since the Unix epoch.
    duration_s : float
        Length of that span, s.
    message : str
        What went wrong, naming the sensor, level, time or field.
    device : str
        The training device asked for ("" when no training was started).
    window_start_s : float
        ``start_ns`` on the source's clock, s (0 when not known).
    findings : sequence of Finding
        The ingest's findings about the event.
    """
    nan = float("nan")
    z = geometry.level_heights_m
    sections = tuple(SectionResult(
        index=i, z_bottom_m=float(z[i]), z_top_m=float(z[i + 1]), k1=nan, k2=nan, fy=nan, c=nan,
        yield_angle_rad=nan, max_angle_rad=nan, ductility_factor=nan,
        state=DamageState.UNKNOWN.name.lower(), yielded=False, k2_identifiable=False,
        fy_identifiable=False) for i in range(geometry.n_levels))
    return IdentificationResult(
        pier_id=pier_id, event_id=event_id, sections=sections,
        overall_state=DamageState.UNKNOWN.name.lower(), window_start_s=float(window_start_s),
        window_duration_s=float(duration_s), epochs=0, final_loss=nan, wall_time_s=0.0,
        device=device, success=False, message=message, window_start_ns=int(start_ns),
        findings=tuple(findings))
