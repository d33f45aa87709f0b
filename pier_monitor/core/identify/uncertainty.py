"""Uncertainty of an identification from an ensemble of members.

An ensemble identification identifies M members; each member gives a parameter set, a
ductility factor and a yield flag per section.  On the field and equation-error routes the
members fit the window perturbed as its sensors allow (randomise-then-optimise, each member
with its own yield decision): their scatter is the uncertainty the data leave (not the
model's own error).  The PINN's members differ mostly by their scattered start: their
scatter is no uncertainty of the data.  This module summarises it:

* :class:`Spread` — mean, standard deviation and the 90 % interval (5th to 95th percentile of
  the members) of one quantity, in its SI unit;
* :class:`SectionUncertainty` — the spreads of ``k1, k2, fy, c`` and DF of a section, the
  probability that its spring yielded and the probability of each state;
* :func:`summarize_members` — those from the members' arrays;
  :func:`overall_state_probabilities` — the probability of each overall (worst) state;
* :func:`k1_change_interval` — the 90 % interval of a ``k1`` change against a baseline and
  the scatter of the two identifications combined;
* :class:`MemberResponses` — the members' reproduced histories, for the figures' bands.

A probability is the share of members: a member's state is its DF classified with the
thresholds of :mod:`~pier_monitor.core.identify.states`, and a member whose spring did not
yield is intact.  The decisions that use these numbers are in
:mod:`~pier_monitor.core.identify.damage`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import finite_or_none, nan_if_none

from .states import DamageState, member_states

__all__ = [
    "DF_RESOLUTION",
    "FIELD_DF_RESOLUTION",
    "INTERVAL_PERCENTILES",
    "K1ChangeInterval",
    "MemberResponses",
    "SectionUncertainty",
    "Spread",
    "k1_change_interval",
    "overall_state_probabilities",
    "summarize_members",
    "with_c_resolution",
    "df_reaching",
    "with_df_resolution",
    "with_yield_not_excluded",
    "with_own_k1",
    "without_k1_on_bound",
]

#: Percentiles of the members that bound the 90 % interval.
INTERVAL_PERCENTILES = (5.0, 95.0)
#: Order of the parameters along the last axis of the members' parameter array.
PARAMETER_NAMES = ("k1", "k2", "fy", "c")

#: Relative resolution of an identified ductility factor that no member shows: a 90 % DF
#: interval of a yielded section is at least ``DF (1 ± DF_RESOLUTION)`` wide.  The members
#: of a fully measured window fit the same peak rotation and yield point to a few parts in
#: ten thousand (a gain error scales both alike), yet the DF was off by 0.1-1.5 % (the peak
#: of the sampled, fused rotation; the yield point of noisy loops).  Chosen on the held-out
#: benchmark's tuning seeds 620-627 (both piers, every layout, 54 yielded sections): on the
#: full layout the members alone held the truth in 72 % of 18 yielded sections, with the
#: floor at 1 % in 89 %, 1.5 % in 94 %, 2 % in 100 %; the accelerometer and three-level
#: layouts' intervals are wider than the floor almost everywhere (90 % and 73 % with or
#: without it).
DF_RESOLUTION = 0.015
#: :data:`DF_RESOLUTION` of the field reconstruction (accelerometers, no displacement
#: sensors): its members see the sensors' noise, gains and azimuths, not the peak rotation
#: that the accelerations integrate to, nor how the plastic rotation is shared between
#: neighbouring springs.  Chosen on the held-out suite's tuning draws (seeds 620-655 of
#: :func:`~pier_monitor.bench_heldout.heldout_case`, bilinear springs, accelerometers at
#: every level, both piers, 72 runs, 121 yielded sections): the 90 % DF intervals held the
#: truth in 83 % of them with 1.5 % (100 of 121), 88 % with 5 %, 91 % with 6 % (Table 1
#: 95 %, E-Defense 87 %).  The sections still missed are all but four reported not yielded (true DF
#: 1.07-1.6, the DF a bound at 1), which no floor reaches; the four are 10-11 % low.
FIELD_DF_RESOLUTION = 0.06

#: Relative resolution of an identified damping coefficient that no member shows: a 90 %
#: ``c`` interval is at least ``c (1 ± C_RESOLUTION)`` wide.  The members see the sensors'
#: noise and errors, not the model's (the lumped masses, the smoothed velocities): on the
#: held-out benchmark's tuning seeds 620-627 (layout full, both piers, 16 runs the
#: self-check kept, 58 sections) the members alone held ``c`` in 81 % of the 16 yielded
#: sections (errors 0.2-16 %, half of them 1.3-2.6 %), with the floor at 1 % in 81 %, 2 % in
#: 94 %, 3 % in 94 %; over every section 69 % → 74 % (2 %).  The accelerometer and
#: three-level layouts' intervals are wider than it (their coverage on the same seeds is the
#: same with or without it).  Far below the ``c`` limit of a poorly identified parameter
#: (±30 %), so it never flags one.
C_RESOLUTION = 0.02


@dataclass(frozen=True)
class Spread:
    """Mean, standard deviation and 90 % interval of one quantity over the members.

    All four are in the quantity's SI unit; ``lo`` and ``hi`` are the 5th and 95th
    percentiles of the members (linear interpolation), ``std`` the sample standard deviation
    (``ddof = 1``).  NaN throughout when no member carries the quantity (e.g. ``k2`` of a
    spring that yielded in no member).
    """

    mean: float
    std: float
    lo: float
    hi: float

    @classmethod
    def of(cls, values: np.ndarray) -> Spread:
        """The spread of finite member values, shape (M,); NaN when there are none.

        With one value the standard deviation is NaN (``ddof = 1``).
        """
        v = np.asarray(values, dtype=float)
        if v.size == 0:
            return cls.undefined()
        lo, hi = np.percentile(v, INTERVAL_PERCENTILES)
        std = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
        return cls(mean=float(np.mean(v)), std=std, lo=float(lo), hi=float(hi))

    @classmethod
    def undefined(cls) -> Spread:
        """A spread of no values (all NaN)."""
        return cls(math.nan, math.nan, math.nan, math.nan)

    @property
    def defined(self) -> bool:
        """Whether the spread has values (its interval is finite)."""
        return math.isfinite(self.lo) and math.isfinite(self.hi)

    def straddles(self, threshold: float) -> bool:
        """Whether the 90 % interval holds ``threshold`` with values on both sides of it.

        ``lo < threshold <= hi``: the members do not agree on which side of a class limit
        (``value >= threshold``) the quantity lies.
        """
        return self.defined and self.lo < threshold <= self.hi

    def relative_half_width(self) -> float:
        """Half the 90 % interval over ``|mean|``, ``(hi − lo) / (2 |mean|)`` (dimensionless);
        NaN when undefined, when the mean is zero or when one value made it (no standard
        deviation: an interval of a single member says nothing of its width)."""
        if not self.defined or self.mean == 0 or not math.isfinite(self.std):
            return math.nan
        return (self.hi - self.lo) / (2.0 * abs(self.mean))

    def relative_std(self) -> float:
        """``std / |mean|`` (dimensionless); NaN when undefined or the mean is zero."""
        return self.std / abs(self.mean) if self.defined and self.mean != 0 else math.nan

    def relative_bounds(self) -> tuple[float, float, float]:
        """``((mean − lo) / mean, (hi − mean) / mean, std / mean)`` (dimensionless): how far
        the 90 % bounds lie below and above the mean, and the scatter, relative to it.  Zeros
        for a spread that cannot say (undefined, a mean that is not positive); a NaN standard
        deviation (one member) counts as zero."""
        if not self.defined or not self.mean > 0:
            return 0.0, 0.0, 0.0
        std = self.relative_std()
        return ((self.mean - self.lo) / self.mean, (self.hi - self.mean) / self.mean,
                std if math.isfinite(std) else 0.0)


@dataclass(frozen=True)
class SectionUncertainty:
    """Uncertainty of one section from an ensemble of ``members`` identifications.

    Attributes
    ----------
    k1, k2, fy, c : Spread
        N·m/rad, N·m/rad, N·m, N·m·s/rad.  ``k2`` and ``fy`` are over the members whose
        spring yielded only (they are not identifiable in the others).
    ductility_factor : Spread
        Dimensionless; a member whose spring did not yield counts with its DF bound, at
        most 1.
    p_yielded : float
        Share of the members whose spring yielded.
    p_state : (float, float, float)
        Probability of intact, suspicious and damaged: the share of the members in each
        state (a member that did not yield is intact); sums to 1.
    members : int
        Number of members.

    For a section of modified-Takeda springs (a Takeda event of the equation-error route,
    :func:`~pier_monitor.core.identify.families.takeda_draws`) the members are draws of the
    Takeda fit's posterior, and ``k1``, ``k2``, ``fy`` are the spreads of its counterparts:
    the small-amplitude stiffness after the event (``k_small_after``, what a change against
    an earlier event compares), the post-yield slope ``kp`` and the yield moment ``My``.
    """

    k1: Spread
    k2: Spread
    fy: Spread
    c: Spread
    ductility_factor: Spread
    p_yielded: float
    p_state: tuple[float, float, float]
    members: int

    @property
    def most_probable_state(self) -> DamageState:
        """The state of the largest probability (a tie goes to the worse state)."""
        p = np.asarray(self.p_state)
        return DamageState(int(np.flatnonzero(p == p.max())[-1]))

    def to_dict(self) -> dict[str, Any]:
        """Plain form for strict JSON (spreads as dicts, ``p_state`` as a list, None where a
        value is not finite: the ``k2``/``fy`` spread of a spring no member found yielded)."""
        d = asdict(self)
        d["p_state"] = list(self.p_state)
        return finite_or_none(d)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SectionUncertainty:
        """Inverse of :meth:`to_dict`."""
        spreads = {k: Spread(**{f: nan_if_none(v) for f, v in d[k].items()})
                   for k in (*PARAMETER_NAMES, "ductility_factor")}
        # a malformed file raises KeyError / TypeError / ValueError, as for the other fields;
        # null (strict JSON's NaN) is NaN
        p_intact, p_suspicious, p_damaged = (nan_if_none(v) for v in d["p_state"])
        return cls(**spreads, p_yielded=nan_if_none(d["p_yielded"]),
                   p_state=(p_intact, p_suspicious, p_damaged), members=int(d["members"]))


def _check_members(params: np.ndarray, ductility: np.ndarray, yielded: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    params = np.asarray(params, dtype=float)
    ductility = np.asarray(ductility, dtype=float)
    yielded = np.asarray(yielded)
    if params.ndim != 3 or params.shape[2] != 4 or params.shape[0] < 1:
        raise InputDataError(f"member parameters: expected shape (M, N, 4) [k1, k2, fy, c] "
                             f"with M >= 1, got {params.shape}")
    m, n, _ = params.shape
    for name, arr in (("member ductility factors", ductility), ("member yield flags", yielded)):
        if arr.shape != (m, n):
            raise InputDataError(f"{name}: expected shape ({m}, {n}) like the parameters, "
                                 f"got {arr.shape}")
    if yielded.dtype != bool:
        raise InputDataError(f"member yield flags: expected booleans, got {yielded.dtype}")
    for j, name in enumerate(PARAMETER_NAMES):
        values = params[:, :, j]
        ok = np.isfinite(values) & ((values >= 0) if name == "k2" else (values > 0))
        # k2 and fy of a spring that did not yield are not identified: not checked
        bad = ~ok & yielded if name in ("k2", "fy") else ~ok
        if np.any(bad):
            i, k = np.argwhere(bad)[0]
            raise InputDataError(f"member {i}, section {k + 1}: {name} = "
                                 f"{float(values[i, k])!r}; expected a finite positive value")
    bad = ~(np.isfinite(ductility) & (ductility >= 0))
    if np.any(bad):
        i, k = np.argwhere(bad)[0]
        raise InputDataError(f"member {i}, section {k + 1}: ductility factor = "
                             f"{float(ductility[i, k])!r}; expected a finite value >= 0")
    return params, ductility, yielded


def _probabilities(codes: np.ndarray) -> tuple[float, float, float]:
    counts = np.bincount(codes, minlength=3)[:3] / codes.size
    return float(counts[0]), float(counts[1]), float(counts[2])


def summarize_members(params: np.ndarray, ductility: np.ndarray, yielded: np.ndarray
                      ) -> tuple[SectionUncertainty, ...]:
    """Per-section uncertainty from the members of an ensemble identification.

    Parameters
    ----------
    params : ndarray, shape (M, N, 4)
        ``[k1, k2, fy, c]`` of each of M members and N sections (N·m/rad, N·m/rad, N·m,
        N·m·s/rad).  ``k2`` and ``fy`` of a member whose spring did not yield are ignored
        (they may be NaN).
    ductility : ndarray, shape (M, N)
        Each member's ductility factor (dimensionless, finite).  Where the spring did not
        yield it is a bound and is capped at 1, as in
        :func:`~pier_monitor.core.identify.damage.build_sections`.
    yielded : ndarray of bool, shape (M, N)
        Whether each member's spring yielded.

    Returns
    -------
    tuple of SectionUncertainty
        One per section, bottom to top.

    Raises
    ------
    InputDataError
        Naming the array and its shape, or the member, section and quantity that is not
        finite and positive.
    """
    params, ductility, yielded = _check_members(params, ductility, yielded)
    m, n, _ = params.shape
    df = np.where(yielded, ductility, np.minimum(ductility, 1.0))
    codes = member_states(df, yielded)
    out = []
    for k in range(n):
        y = yielded[:, k]
        out.append(SectionUncertainty(
            k1=Spread.of(params[:, k, 0]), k2=Spread.of(params[y, k, 1]),
            fy=Spread.of(params[y, k, 2]), c=Spread.of(params[:, k, 3]),
            ductility_factor=Spread.of(df[:, k]), p_yielded=float(np.mean(y)),
            p_state=_probabilities(codes[:, k]), members=m))
    return tuple(out)


def with_c_resolution(uncertainty: tuple[SectionUncertainty, ...], c: np.ndarray,
                      resolution: float = C_RESOLUTION) -> tuple[SectionUncertainty, ...]:
    """``uncertainty`` with the ``c`` interval of every section at least
    ``c · (1 ± resolution)`` wide (:data:`C_RESOLUTION`); ``c`` (N,) the identification's
    own damping coefficients, N·m·s/rad."""
    out = []
    for u, ci in zip(uncertainty, np.asarray(c, float)):
        s = u.c
        if np.isfinite(ci) and ci > 0 and np.isfinite(s.lo) and np.isfinite(s.hi):
            u = replace(u, c=replace(s, lo=float(min(s.lo, ci * (1.0 - resolution))),
                                     hi=float(max(s.hi, ci * (1.0 + resolution)))))
        out.append(u)
    return tuple(out)


def with_own_k1(uncertainty: tuple[SectionUncertainty, ...], k1: np.ndarray
                ) -> tuple[SectionUncertainty, ...]:
    """``uncertainty`` with every defined ``k1`` interval stretched to hold ``k1`` (N,), the
    identification's own value (member 0, the fit itself; for a Takeda event its
    ``k_small_after``), N·m/rad: the 5th-95th percentile of a few members can leave out the
    value shown beside it when the fit is the most extreme of them (8 draws of a Takeda
    posterior, the fit the lowest: its ``k_small_after`` 0.04 % below the interval)."""
    out = []
    for u, own in zip(uncertainty, np.asarray(k1, dtype=float), strict=True):
        s = u.k1
        if np.isfinite(own) and s.defined and not s.lo <= own <= s.hi:
            u = replace(u, k1=replace(s, lo=float(min(s.lo, own)), hi=float(max(s.hi, own))))
        out.append(u)
    return tuple(out)


def without_k1_on_bound(uncertainty: tuple[SectionUncertainty, ...],
                        at_bound: np.ndarray | None, limit: float
                        ) -> tuple[SectionUncertainty, ...]:
    """``uncertainty`` with no ``k1`` interval (:meth:`Spread.undefined`, so "poorly
    identified") for the sections ``at_bound`` (N,) marks whose interval is not already
    wider than ``limit`` (relative half-width, the ``k1`` limit of a poorly identified
    quantity): their ``k1`` ended on a search box, so the box, not the data, ends the
    members' spread, and an interval of members piled on it is narrow and may be far from
    the truth (before the field fit's box held the prior's mean: held-out seed 602, Table 1
    pier, accelerometers, the top spring at -32 % in all 32 members).  An interval already
    wider than the limit is flagged by its width and kept: it still says how far the members
    went.  ``at_bound`` None: unchanged."""
    if at_bound is None:
        return uncertainty
    return tuple(replace(u, k1=Spread.undefined())
                 if b and u.k1.relative_half_width() <= limit else u
                 for u, b in zip(uncertainty, np.asarray(at_bound, dtype=bool), strict=True))


def with_df_resolution(uncertainty: tuple[SectionUncertainty, ...], ductility: np.ndarray,
                       yielded: np.ndarray, resolution: float = DF_RESOLUTION
                       ) -> tuple[SectionUncertainty, ...]:
    """``uncertainty`` with the DF interval of every yielded section at least
    ``ductility · (1 ± resolution)`` wide (:data:`DF_RESOLUTION`).

    ``ductility`` (N,) is the identification's own DF, ``yielded`` (N,) its yield decision;
    the interval of a section that did not yield (its DF a bound, at most 1) is kept.
    """
    out = []
    for u, df, y in zip(uncertainty, np.asarray(ductility, float), np.asarray(yielded, bool)):
        s = u.ductility_factor
        if y and np.isfinite(df) and np.isfinite(s.lo) and np.isfinite(s.hi):
            s = replace(s, lo=float(min(s.lo, df * (1.0 - resolution))),
                        hi=float(max(s.hi, df * (1.0 + resolution))))
            u = replace(u, ductility_factor=s)
        out.append(u)
    return tuple(out)


def df_reaching(uncertainty: SectionUncertainty | None, upto: float
                ) -> SectionUncertainty | None:
    """``uncertainty`` with its DF interval's upper end raised to ``upto`` where that is
    finite and higher (its lower end and mean kept); None, or an undefined interval, stays
    as it is."""
    if uncertainty is None or not math.isfinite(upto):
        return uncertainty
    df = uncertainty.ductility_factor
    if not df.defined or df.hi >= upto:
        return uncertainty
    return replace(uncertainty, ductility_factor=replace(df, hi=float(upto)))


def with_yield_not_excluded(uncertainty: tuple[SectionUncertainty, ...], bound: np.ndarray
                            ) -> tuple[SectionUncertainty, ...]:
    """``uncertainty`` with the DF interval of every section whose ``bound`` (N,) is finite
    reaching up to it (:func:`df_reaching`): the DF up to which the data do not exclude a
    yield of a section reported not yielded (:attr:`~pier_monitor.core.identify.families.
    FamilyChoice.yield_not_excluded_df`; its posterior draws all follow the fit's decision,
    at most 1).  Lower ends, means and the other sections are kept."""
    bound = np.asarray(bound, dtype=float)
    if bound.shape != (len(uncertainty),):
        raise InputDataError(f"yield-profile DF bounds: expected {len(uncertainty)} "
                             f"sections, got shape {bound.shape}")
    return tuple(df_reaching(u, float(b)) for u, b in zip(uncertainty, bound))


def overall_state_probabilities(ductility: np.ndarray, yielded: np.ndarray
                                ) -> tuple[float, float, float]:
    """Probability that the pier's worst section is intact, suspicious, damaged.

    Each member's overall state is the worst of its sections' states (a spring that did not
    yield is intact); the probabilities are the shares of the members.

    Parameters
    ----------
    ductility : ndarray, shape (M, N)
        Member ductility factors (dimensionless, finite).
    yielded : ndarray of bool, shape (M, N)
        Member yield flags.

    Raises
    ------
    InputDataError
        If the shapes differ or a ductility factor is not finite.
    """
    ductility = np.asarray(ductility, dtype=float)
    yielded = np.asarray(yielded)
    if ductility.ndim != 2 or ductility.shape[0] < 1 or yielded.shape != ductility.shape \
            or yielded.dtype != bool:
        raise InputDataError(f"member ductility factors and yield flags: expected shapes "
                             f"(M, N) and booleans, got {ductility.shape} and {yielded.shape} "
                             f"{yielded.dtype}")
    if not np.all(np.isfinite(ductility)):
        i, k = np.argwhere(~np.isfinite(ductility))[0]
        raise InputDataError(f"member {i}, section {k + 1}: ductility factor = "
                             f"{float(ductility[i, k])!r}; expected a finite value")
    return _probabilities(member_states(ductility, yielded).max(axis=1))


@dataclass(frozen=True)
class K1ChangeInterval:
    """90 % interval of a ``k1`` change against a baseline, and the identification scatter.

    ``lo_pct``, ``hi_pct``: bounds of the change, % (``100 (k1 / k1_baseline − 1)``);
    ``scatter_pct``: the standard deviation of the change that the two identifications'
    own scatter gives (their relative ``k1`` standard deviations combined), percentage
    points.
    """

    lo_pct: float
    hi_pct: float
    scatter_pct: float


def k1_change_interval(k1: float, spread: Spread, baseline_k1: float,
                       baseline_spread: Spread | None = None,
                       stiffer_by: float = 0.0, resolution: float = 0.0) -> K1ChangeInterval:
    """The 90 % interval of the change of ``k1`` against a baseline.

    The change is ``100 (r − 1)`` with ``r = k1 / baseline_k1`` (the reported values).  Its
    interval combines, in quadrature, the relative distances of each spread's 90 % bounds
    from its mean: ``r_lo = r (1 − √(a_lo² + b_hi²))`` and ``r_hi = r (1 + √(a_hi² +
    b_lo²))``, where ``a`` is this identification's (``(mean − lo) / mean``,
    ``(hi − mean) / mean``) and ``b`` the baseline's, zero without a baseline spread (design
    values).  Without a baseline spread the interval is this identification's ``k1``
    interval relative to the baseline.  The scatter is ``100 r √(s² + s_b²)`` with ``s``,
    ``s_b`` the relative standard deviations.  ``stiffer_by`` (a fraction, >= 0): a known
    one-sided error of this identification's ``k1``, the truth up to that much higher
    (:data:`~pier_monitor.core.identify.damage.VIRGIN_START_STIFFNESS`), combined in
    quadrature into ``r_hi`` only: ``r_hi = r (1 + √(a_hi² + b_lo² + stiffer_by²))``.
    ``resolution`` (a fraction, >= 0): the relative resolution of each of the two
    stiffnesses that no member shows
    (:data:`~pier_monitor.core.identify.damage.RC_STIFFNESS_RESOLUTION`), combined in
    quadrature, once for each, into both ends: ``r_lo = r (1 − √(a_lo² + b_hi² +
    2 resolution²))``; the scatter stays the members'.

    Parameters
    ----------
    k1 : float
        This identification's ``k1``, N·m/rad.
    spread : Spread
        The members' spread of it.
    baseline_k1 : float
        The baseline's ``k1``, N·m/rad (finite, positive).
    baseline_spread : Spread, optional
        The baseline identification's spread of ``k1``; None for a baseline without one.

    Raises
    ------
    InputDataError
        If a ``k1`` is not finite and positive or ``spread`` is undefined.
    """
    if not (math.isfinite(k1) and k1 > 0 and math.isfinite(baseline_k1) and baseline_k1 > 0):
        raise InputDataError(f"k1 change interval: expected finite positive k1 and baseline k1 "
                             f"in N*m/rad, got {k1!r} and {baseline_k1!r}")
    if not spread.defined or not spread.mean > 0:
        raise InputDataError(f"k1 change interval: the spread of k1 is undefined ({spread})")
    for name, value in (("stiffer_by", stiffer_by), ("resolution", resolution)):
        if not (math.isfinite(value) and value >= 0):
            raise InputDataError(f"k1 change interval: {name}: expected a fraction >= 0, "
                                 f"got {value!r}")

    a_lo, a_hi, a_s = spread.relative_bounds()
    b_lo, b_hi, b_s = (baseline_spread.relative_bounds() if baseline_spread is not None
                       else (0.0, 0.0, 0.0))
    r = k1 / baseline_k1
    # a stiffness is not negative: the change is at least -100 %
    res = (resolution, resolution)
    return K1ChangeInterval(lo_pct=100.0 * (r * max(1.0 - math.hypot(a_lo, b_hi, *res), 0.0)
                                            - 1.0),
                            hi_pct=100.0 * (r * (1.0 + math.hypot(a_hi, b_lo, stiffer_by, *res))
                                            - 1.0),
                            scatter_pct=100.0 * r * math.hypot(a_s, b_s))


@dataclass(frozen=True, eq=False)
class MemberResponses:
    """The members' reproduced histories, time-first after the member axis, SI.

    ``theta`` (M, T, N) spring angles, rad; ``moment`` (M, T, N) restoring moments, N·m;
    optionally ``x`` (M, T, N) relative displacements, m, and ``a`` (M, T, N) relative
    accelerations, m/s².  The figures draw their band (5th to 95th percentile over the
    members at each time) around the reproduced response.
    """

    theta: np.ndarray
    moment: np.ndarray
    x: np.ndarray | None = None
    a: np.ndarray | None = None

    def __post_init__(self) -> None:
        theta = np.asarray(self.theta, dtype=float)
        if theta.ndim != 3 or theta.shape[0] < 1:
            raise InputDataError(f"member theta: expected shape (M, T, N), got {theta.shape}")
        for name in ("theta", "moment", "x", "a"):
            value = getattr(self, name)
            if value is None:
                continue
            arr = np.array(value, dtype=float)
            if arr.shape != theta.shape:
                raise InputDataError(f"member {name}: expected shape {theta.shape} like theta, "
                                     f"got {arr.shape}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def members(self) -> int:
        """Number of members M."""
        return int(self.theta.shape[0])

    def band(self, name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """5th and 95th percentile over the members of ``name``, each (T, N); None if absent."""
        value = getattr(self, name)
        if value is None:
            return None
        lo, hi = np.percentile(value, INTERVAL_PERCENTILES, axis=0)
        return lo, hi
