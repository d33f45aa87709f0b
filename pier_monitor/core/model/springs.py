"""Rotational spring families driven by a rotation history, and their skeletons.

Each family maps an angle history ``θ(t)`` (rad, shape ``(T,)``, starting from a spring at
rest at ``θ = 0``) to the restoring moment ``M(t)`` (N·m, shape ``(T,)``).  The map is a pure
function of the history and the parameters; the loops are compiled with numba when it is
installed (:mod:`pier_monitor.core._jit`).

``bilinear``
    The identifier's spring (SPEC §3): kinematic hardening,
    ``M_i = clip(M_{i−1} + k1 Δθ, k2 θ − s, k2 θ + s)``, ``s = fy (1 − k2/k1)``.

``takeda``
    Modified Takeda (Takeda, Sozen & Nielsen 1970; Otani 1981), the usual description of a
    reinforced-concrete section in flexure, with optional pinching in the manner of the
    OpenSees ``Hysteretic`` material:

    * *skeleton* (odd in ``θ``): uncracked ``k0 θ`` up to the cracking point ``(θc, Mc)``,
      ``θc = Mc / k0``; the cracked branch straight to the yield point ``(θy, My)``; the
      post-yield slope ``kp = r k0`` beyond;
    * *unloading* at ``k_u = min(k0, k_y (θy / θm)^α)``, ``k_y = My / θy`` the secant to yield
      and ``θm`` the largest ``|θ|`` reached on either side (at least ``θc``), so a section
      unloads the softer the further it has been pushed;
    * *reloading* is peak-oriented: from the zero-moment crossing of the last unloading
      towards the previous peak of that side on the skeleton (the cracking point while that
      side has not cracked), through the pinch point: moment ``pinch_y · Mpeak`` at a fraction
      ``pinch_x`` of the way from the crossing to where unloading from the peak would reach
      that moment.  ``pinch_y = 1`` is the unpinched Takeda rule (straight to the peak;
      ``pinch_x`` is then unused);
    * the moment is the lower (in absolute value) of the reloading curve and the unloading
      line from the last state, so inner loops follow the same two rules; past the previous
      peak the spring is back on the skeleton.

The skeletons of both families are piecewise linear (:class:`Skeleton`), and
:func:`idealised_yield` gives the equal-energy idealised yield rotation of any of them, so
that a ductility factor means the same thing whatever family was identified.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pier_monitor.core._jit import jit, jit_inline
from pier_monitor.core.errors import InputDataError

__all__ = [
    "SPRING_FAMILIES",
    "TakedaParameters",
    "Skeleton",
    "check_prior_peaks",
    "bilinear_moment",
    "bilinear_skeleton",
    "takeda_moment",
    "takeda_skeleton",
    "takeda_unloading_stiffness",
    "skeleton",
    "idealised_yield",
    "TAKEDA_CRACKED_RATIO",
    "TAKEDA_NOMINAL_DUCTILITY",
    "TAKEDA_YIELD_PEAK_FRACTION",
    "yield_peak_fraction",
]

#: The spring families of this module.
SPRING_FAMILIES = ("bilinear", "takeda")

#: Fixed unloading exponent of the Takeda family (RC_NOTES: 0.4–0.5; Otani 1981 used 0.4).
TAKEDA_ALPHA = 0.4


def _check_theta(theta: np.ndarray) -> np.ndarray:
    th = np.ascontiguousarray(theta, dtype=float)
    if th.ndim != 1 or th.size == 0:
        raise InputDataError(f"theta: expected a 1-D angle history (T,), got shape {th.shape}")
    if not np.all(np.isfinite(th)):
        i = int(np.flatnonzero(~np.isfinite(th))[0])
        raise InputDataError(f"theta: non-finite angle {th[i]} at sample {i}")
    return th


@dataclass(frozen=True)
class TakedaParameters:
    """Parameters of one modified-Takeda spring (SI).

    Attributes
    ----------
    k0 : float
        Uncracked (gross-section) stiffness, N·m/rad.
    mc : float
        Cracking moment, N·m, ``0 < mc < my``.
    my : float
        Yield moment, N·m.
    theta_y : float
        Yield rotation, rad, with ``mc / k0 < theta_y`` and the secant ``my / theta_y <= k0``.
    kp : float
        Post-yield slope, N·m/rad, ``0 <= kp`` and below the cracked slope.
    alpha : float
        Unloading exponent, ``0 <= alpha <= 1``.
    pinch_x, pinch_y : float
        Pinch point of reloading (fractions of rotation and of the peak moment), in ``(0, 1]``;
        ``pinch_y = 1``: no pinching.
    """

    k0: float
    mc: float
    my: float
    theta_y: float
    kp: float
    alpha: float = TAKEDA_ALPHA
    pinch_x: float = 1.0
    pinch_y: float = 1.0

    def __post_init__(self) -> None:
        vals = {k: float(getattr(self, k)) for k in ("k0", "mc", "my", "theta_y", "kp", "alpha",
                                                     "pinch_x", "pinch_y")}
        for k, v in vals.items():
            object.__setattr__(self, k, v)
        if not all(np.isfinite(v) for v in vals.values()):
            raise InputDataError(f"Takeda parameters: expected finite values, got {vals}")
        if not (vals["k0"] > 0 and vals["my"] > 0 and vals["theta_y"] > 0):
            raise InputDataError(f"Takeda parameters: k0, my, theta_y must be positive, got "
                                 f"{vals}")
        if not 0 < vals["mc"] < vals["my"]:
            raise InputDataError(f"Takeda parameters: expected 0 < mc < my, got mc={vals['mc']}, "
                                 f"my={vals['my']}")
        if not self.theta_c < vals["theta_y"]:
            raise InputDataError(f"Takeda parameters: cracking rotation mc/k0={self.theta_c} must "
                                 f"be below theta_y={vals['theta_y']}")
        if not 0 <= vals["kp"] <= self.k_cracked:
            raise InputDataError(f"Takeda parameters: expected 0 <= kp <= cracked slope "
                                 f"{self.k_cracked}, got kp={vals['kp']}")
        if not 0 <= vals["alpha"] <= 1:
            raise InputDataError(f"Takeda parameters: expected 0 <= alpha <= 1, got "
                                 f"{vals['alpha']}")
        for k in ("pinch_x", "pinch_y"):
            if not 0 < vals[k] <= 1:
                raise InputDataError(f"Takeda parameters: expected 0 < {k} <= 1, got {vals[k]}")

    @property
    def theta_c(self) -> float:
        """Cracking rotation ``mc / k0``, rad."""
        return self.mc / self.k0

    @property
    def k_y(self) -> float:
        """Secant stiffness to yield ``my / theta_y``, N·m/rad."""
        return self.my / self.theta_y

    @property
    def k_cracked(self) -> float:
        """Slope of the cracked branch, N·m/rad."""
        return (self.my - self.mc) / (self.theta_y - self.theta_c)

    def as_array(self) -> np.ndarray:
        """``[k0, mc, my, theta_y, kp, alpha, pinch_x, pinch_y]``, shape (8,)."""
        return np.array([self.k0, self.mc, self.my, self.theta_y, self.kp, self.alpha,
                         self.pinch_x, self.pinch_y])


@jit
def _takeda_skel(k0, mc, my, ty, kp, th):  # pragma: no cover - compiled
    tc = mc / k0
    a = abs(th)
    sgn = 1.0 if th >= 0.0 else -1.0
    if a <= tc:
        return k0 * th
    if a <= ty:
        return sgn * (mc + (my - mc) * (a - tc) / (ty - tc))
    return sgn * (my + kp * (a - ty))


@jit
def _reload(th, t0, tpk, mpk, ku, px, py):  # pragma: no cover - compiled
    """Reloading curve from the crossing ``t0`` to the peak ``(tpk, mpk)``, either sign."""
    if py >= 1.0:  # no pinching: straight to the peak
        return mpk * (th - t0) / (tpk - t0)
    t2 = tpk - (1.0 - py) * mpk / ku  # where unloading from the peak reaches py·mpk
    tch = t0 + px * (t2 - t0)
    span = tpk - t0
    lo = min(t0 + 1e-9 * span, tpk - 1e-9 * span)
    hi = max(t0 + 1e-9 * span, tpk - 1e-9 * span)
    tch = min(max(tch, lo), hi)
    if (th - tch) * span < 0.0:
        return py * mpk * (th - t0) / (tch - t0)
    return py * mpk + (1.0 - py) * mpk * (th - tch) / (tpk - tch)


#: Length of one Takeda state (:func:`_takeda_step`): ``(θ+peak, θ−peak, θ0+, θ0−, θ_prev, M,
#: direction, θm, k_u)``.
TAKEDA_STATE_SIZE = 9


@jit
def _takeda_init(p):  # pragma: no cover - compiled
    """The virgin state of the spring ``p`` (a tuple of :data:`TAKEDA_STATE_SIZE` floats)."""
    k0, mc, my, ty, alpha = p[0], p[1], p[2], p[3], p[5]
    tc = mc / k0
    return (tc, -tc, 0.0, 0.0, 0.0, 0.0, 0.0, tc, min(k0, my / ty * (ty / tc) ** alpha))


@jit_inline
def _takeda_step(p, s, th):  # pragma: no cover - compiled
    """One step of the Takeda rule to ``th`` from the state ``s``: the new state (its moment is
    item 5).  The state is a tuple so that the loops keep it in registers."""
    k0, mc, my, ty, kp, alpha = p[0], p[1], p[2], p[3], p[4], p[5]
    px, py = p[6], p[7]
    tpos, tneg, t0p, t0n, th_prev, m, direction, tm, ku = s
    dth = th - th_prev
    if max(tpos, -tneg) != tm:  # a new peak: the unloading stiffness degrades
        tm = max(tpos, -tneg)
        ku = min(k0, my / ty * (ty / tm) ** alpha)
    if dth != 0.0:
        if th >= tpos:
            tpos = th
            m = _takeda_skel(k0, mc, my, ty, kp, th)
            direction = 1.0
        elif th <= tneg:
            tneg = th
            m = _takeda_skel(k0, mc, my, ty, kp, th)
            direction = -1.0
        elif dth > 0.0:
            if direction == -1.0 and m <= 0.0:  # reversal on the negative side
                t0p = th_prev - m / ku
            direction = 1.0
            m_new = m + ku * dth
            if th > t0p and tpos - t0p > 1e-12 * tpos:
                mpk = _takeda_skel(k0, mc, my, ty, kp, tpos)
                m_new = min(m_new, _reload(th, t0p, tpos, mpk, ku, px, py))
            m = min(m_new, _takeda_skel(k0, mc, my, ty, kp, th)) if th > ty else m_new
        else:
            if direction == 1.0 and m >= 0.0:
                t0n = th_prev - m / ku
            direction = -1.0
            m_new = m + ku * dth
            if th < t0n and t0n - tneg > -1e-12 * tneg:
                mpk = _takeda_skel(k0, mc, my, ty, kp, tneg)
                m_new = max(m_new, _reload(th, t0n, tneg, mpk, ku, px, py))
            m = max(m_new, _takeda_skel(k0, mc, my, ty, kp, th)) if th < -ty else m_new
        th_prev = th
    return (tpos, tneg, t0p, t0n, th_prev, m, direction, tm, ku)


@jit
def _takeda_state_from(p, peak_pos, peak_neg):  # pragma: no cover - compiled
    """The state of the spring ``p`` at rest at ``θ = 0`` (zero moment) after an earlier
    history whose peaks on either side were ``peak_pos >= 0`` and ``peak_neg <= 0`` (rad, in
    the frame of the history that follows: its residual rotation removed): the virgin state
    where both lie within cracking.  Reloading then aims at those peaks on the skeleton, and
    the unloading stiffness has degraded with the larger of them."""
    s = _takeda_init(p)
    tpos, tneg = max(peak_pos, s[0]), min(peak_neg, s[1])
    if tpos == s[0] and tneg == s[1]:
        return s
    k0, my, ty, alpha = p[0], p[2], p[3], p[5]
    tm = max(tpos, -tneg)
    return (tpos, tneg, 0.0, 0.0, 0.0, 0.0, 0.0, tm, min(k0, my / ty * (ty / tm) ** alpha))


@jit
def _takeda_kernel_from(p, theta, out, peak_pos, peak_neg):  # pragma: no cover - compiled
    s = _takeda_state_from(p, peak_pos, peak_neg)
    for i in range(theta.shape[0]):
        s = _takeda_step(p, s, theta[i])
        out[i] = s[5]


@jit
def _takeda_kernel(p, theta, out):  # pragma: no cover - compiled
    _takeda_kernel_from(p, theta, out, 0.0, 0.0)


@jit
def _bilinear_kernel(k1, k2, fy, theta, out, th_prev, f):  # pragma: no cover - compiled
    # (th_prev, f): the spring's angle and moment before sample 0 (at rest: 0, 0)
    s = fy * (1.0 - k2 / k1)
    for i in range(theta.shape[0]):
        th = theta[i]
        f = min(max(f + k1 * (th - th_prev), k2 * th - s), k2 * th + s)
        th_prev = th
        out[i] = f


def check_prior_peaks(prior_peaks: tuple[float, float]) -> tuple[float, float]:
    """``prior_peaks`` ``(θ+ >= 0, θ− <= 0)``, rad, as floats; InputDataError otherwise."""
    pos, neg = (float(v) for v in prior_peaks)
    if not (np.isfinite(pos) and np.isfinite(neg) and pos >= 0 >= neg):
        raise InputDataError(f"prior_peaks: expected (θ+ >= 0, θ- <= 0) in rad, got "
                             f"{prior_peaks!r}")
    return pos, neg


def takeda_moment(theta: np.ndarray, params: TakedaParameters,
                  prior_peaks: tuple[float, float] = (0.0, 0.0)) -> np.ndarray:
    """Moment history of a modified-Takeda spring, N·m, shape (T,).

    Parameters
    ----------
    theta : ndarray, shape (T,)
        Angle history, rad; the spring is at rest at ``θ = 0`` before sample 0.
    params : TakedaParameters
        The spring.
    prior_peaks : (float, float)
        The peaks ``(θ+ >= 0, θ− <= 0)`` of an earlier history, rad, in the frame of
        ``theta`` (the residual rotation it left removed): the spring has been there, so it
        reloads towards them and unloads on the stiffness they degraded.  ``(0, 0)``: virgin.
    """
    th = _check_theta(theta)
    pos, neg = check_prior_peaks(prior_peaks)
    out = np.empty_like(th)
    _takeda_kernel_from(params.as_array(), th, out, pos, neg)
    return out


def bilinear_moment(theta: np.ndarray, k1: float, k2: float, fy: float,
                    start_moment: float | None = None) -> np.ndarray:
    """Moment history of the bilinear kinematic-hardening spring (SPEC §3), N·m, shape (T,).

    ``theta`` (rad, shape (T,)) starts from a spring at rest at ``θ = 0``, or with
    ``start_moment`` (N·m) from the spring carrying that moment at ``theta[0]`` (held within
    its yield surface there: the state of a spring that yielded before the history starts,
    e.g. a window cut from a longer record); ``k1 > 0``, ``0 <= k2 < k1`` (N·m/rad),
    ``fy > 0`` (N·m).
    """
    th = _check_theta(theta)
    if not (np.isfinite(k1) and np.isfinite(k2) and np.isfinite(fy) and k1 > 0
            and 0 <= k2 < k1 and fy > 0):
        raise InputDataError(f"bilinear spring: expected k1 > 0, 0 <= k2 < k1, fy > 0, got "
                             f"k1={k1}, k2={k2}, fy={fy}")
    out = np.empty_like(th)
    th0 = f0 = 0.0
    if start_moment is not None and th.size:
        if not np.isfinite(start_moment):
            raise InputDataError(f"bilinear spring: start_moment: expected a finite moment, "
                                 f"got {start_moment}")
        th0 = float(th[0])
        s = fy * (1.0 - k2 / k1)
        f0 = float(np.clip(start_moment, k2 * th0 - s, k2 * th0 + s))
    _bilinear_kernel(float(k1), float(k2), float(fy), th, out, th0, f0)
    return out


def takeda_unloading_stiffness(params: TakedaParameters, peak_rotation: float) -> float:
    """Small-amplitude (unloading) stiffness ``min(k0, k_y (θy/θm)^α)`` after a peak, N·m/rad.

    ``peak_rotation`` is the largest ``|θ|`` reached (rad); below cracking it is ``k0``.
    """
    tm = max(float(peak_rotation), params.theta_c)
    return float(min(params.k0, params.k_y * (params.theta_y / tm) ** params.alpha))


@dataclass(frozen=True)
class Skeleton:
    """A piecewise-linear, odd monotonic envelope ``S(θ)`` of a spring family.

    Attributes
    ----------
    theta : ndarray, shape (K,)
        Corner rotations of the positive side, rad, increasing from 0.
    moment : ndarray, shape (K,)
        Moments at the corners, N·m (``moment[0] = 0``).
    final_slope : float
        Slope beyond the last corner, N·m/rad.
    theta_first_yield : float
        The corner where the reinforcement (or the bilinear spring) yields, rad; one of
        ``theta``.  The secant to it is the elastic branch of the idealised bilinear.
    """

    theta: np.ndarray
    moment: np.ndarray
    final_slope: float
    theta_first_yield: float

    def __post_init__(self) -> None:
        th = np.asarray(self.theta, dtype=float)
        m = np.asarray(self.moment, dtype=float)
        if (th.ndim != 1 or th.size < 2 or m.shape != th.shape or th[0] != 0 or m[0] != 0
                or np.any(np.diff(th) <= 0) or not np.all(np.isfinite(m))):
            raise InputDataError(f"skeleton: expected increasing corners from (0, 0), got "
                                 f"theta={th.tolist()}, moment={m.tolist()}")
        if not np.any(np.isclose(th, self.theta_first_yield, rtol=1e-12, atol=0.0)):
            raise InputDataError(f"skeleton: first yield {self.theta_first_yield} is not a "
                                 f"corner of {th.tolist()}")
        object.__setattr__(self, "theta", th)
        object.__setattr__(self, "moment", m)
        object.__setattr__(self, "final_slope", float(self.final_slope))
        object.__setattr__(self, "theta_first_yield", float(self.theta_first_yield))

    def __call__(self, theta: np.ndarray | float) -> np.ndarray:
        """``S(θ)``, N·m, same shape as ``theta`` (rad)."""
        th = np.asarray(theta, dtype=float)
        a = np.abs(th)
        inside = np.interp(a, self.theta, self.moment)
        beyond = self.moment[-1] + self.final_slope * (a - self.theta[-1])
        return np.sign(th) * np.where(a <= self.theta[-1], inside, beyond)

    @property
    def m_first_yield(self) -> float:
        """Moment at first yield, N·m."""
        return float(self(self.theta_first_yield))

    def area(self, theta_peak: float) -> float:
        """``∫₀^θp S(θ) dθ``, J (exact: trapezoids on the corners)."""
        tp = float(theta_peak)
        pts = np.concatenate((self.theta[self.theta < tp], [tp]))
        m = self(pts)
        return float(np.sum(0.5 * (m[1:] + m[:-1]) * np.diff(pts)))


def bilinear_skeleton(k1: float, k2: float, fy: float) -> Skeleton:
    """Skeleton of the bilinear spring: ``k1 θ`` to ``(fy/k1, fy)``, then slope ``k2``."""
    return Skeleton(np.array([0.0, fy / k1]), np.array([0.0, fy]), k2, fy / k1)


def takeda_skeleton(params: TakedaParameters) -> Skeleton:
    """Skeleton of a Takeda spring: corners at cracking and yield, slope ``kp`` beyond."""
    return Skeleton(np.array([0.0, params.theta_c, params.theta_y]),
                    np.array([0.0, params.mc, params.my]), params.kp, params.theta_y)


def skeleton(theta: np.ndarray | float, params: TakedaParameters) -> np.ndarray:
    """The Takeda skeleton ``S(θ)`` at ``theta`` (rad), N·m, same shape."""
    return takeda_skeleton(params)(theta)


#: Lowest point of a fitted Takeda skeleton through which the elastic branch of its idealised
#: bilinear passes, as a fraction of the moment at the event's peak
#: (:func:`idealised_yield`'s ``min_yield_fraction``).  An RC section's first bar yield is at
#: about 0.75-0.8 of its nominal moment (the fiber column of RC_NOTES: 0.755 at the base,
#: 0.78 above the cut-off), and the peak moment of an event that yields a section is near it.
#: Where the section's skeleton is smooth the Takeda's yield corner is a least-squares kink on
#: the cracked curve, not first yield; measured on the fiber column's first shaking (bars at
#: 3.3x yield, ``fiber`` benchmark, full layout): the corner at 0.66 θ'y and 0.87 M'y, a secant
#: 33 % stiffer than the true one to first yield, DF 2.34 where the truth is 1.37 (RC_NOTES)
#: or 1.48 (the same equal-energy idealisation of the column's pushover skeleton); with this
#: floor 1.46.  Sensitive: 0.78 / 0.82 give 1.56 / 1.39.  The RC test-bed's Takeda springs
#: (a sharp corner at first yield) keep their corner: their peak moments stay below 1.25 My.
#:
#: Chosen on the fiber column, so the ``fiber`` benchmark is no longer held out for the DF.
#: Validated on cases not used to choose it, the RC test-bed's BWBN (smooth skeleton) springs,
#: layout full, equation-error route: E-Defense strong, seeds 300 / 301, Takeda family chosen,
#: base DF 7.94 / 7.90 without the floor, 4.46 / 4.56 with it, truth 3.25 / 3.25 (the second
#: section's fit stays below its yield point: DF <= 1 either way, truth 1.23); Table-1 strong
#: (seeds 300-301) and both piers' just-yield shaking (seed 300) choose the bilinear, unchanged
#: (Table-1's Takeda fit is flat past its corner, Mp = My: the floor leaves it).  The test-bed's
#: Takeda springs (E-Defense strong 300 / 301 and just-yield 300, Table-1 strong 300): every
#: section's DF identical with and without the floor.
TAKEDA_YIELD_PEAK_FRACTION = 0.8
#: ... of the moment at the event's peak, or, on a skeleton with a cracked branch, at this
#: multiple of its yield corner ``θ'y`` where the peak lies beyond: the nominal moment, not
#: the hardened one.  A section taken far past yield carries its post-yield slope into the
#: peak moment; 0.8 of it then lies above the yield corner itself, and the secant to that
#: point halves the elastic stiffness.  Held-out suite's draws, tuning seed 633 (Table 1
#: pier, Takeda springs, El Centro, accelerometers at every level): the base's fitted corner
#: at 4.1 mrad, its peak at 52 mrad and 1.34 My, DF 2.9 where the truth is 9.6.  Only where
#: the fit found a cracked branch (its initial stiffness at least :data:`TAKEDA_CRACKED_RATIO`
#: times the secant to the corner) is the corner a second drop of stiffness, the first yield
#: of a sharp-cornered section; a fit that carries its initial stiffness to the corner has put
#: it on a smoothly bending curve (the RC test-bed's BWBN springs, E-Defense pier, strong
#: shaking, full layout, seeds 300-301: initial stiffness 1.02 times the secant, the corner at
#: 0.41 of the true idealised yield rotation, peak at 7.9 corners, DF 7.9 against a true 3.25
#: with the nominal moment, 4.5 with the peak's).
TAKEDA_NOMINAL_DUCTILITY = 4.0
#: See :data:`TAKEDA_NOMINAL_DUCTILITY`: a fitted skeleton has a cracked branch where its
#: initial stiffness is at least this many times its secant to the yield corner (the RC
#: test-bed's Takeda fits: 1.5-1.6; its BWBN fits: 1.02).
TAKEDA_CRACKED_RATIO = 1.2


def yield_peak_fraction(family: str) -> float:
    """:func:`idealised_yield`'s ``min_yield_fraction`` for a fitted skeleton of ``family``:
    :data:`TAKEDA_YIELD_PEAK_FRACTION` for the Takeda (``"takeda"``), 0 (the definition
    itself) for the bilinear, whose skeleton is its own bilinearisation."""
    return TAKEDA_YIELD_PEAK_FRACTION if family == "takeda" else 0.0


def _rotation_at(skel: Skeleton, moment: float) -> float:
    """Smallest rotation where the (increasing) skeleton reaches ``moment``, rad (inf where
    it never does)."""
    if moment <= skel.moment[-1]:
        return float(np.interp(moment, skel.moment, skel.theta))
    if skel.final_slope > 0:
        return float(skel.theta[-1] + (moment - skel.moment[-1]) / skel.final_slope)
    return float("inf")


def idealised_yield(skel: Skeleton, theta_peak: float, min_yield_fraction: float = 0.0) -> float:
    """Equal-energy idealised yield rotation of a skeleton up to a peak rotation, rad.

    The idealised bilinear has the secant to first yield ``k_y = S(θ'y)/θ'y`` as its elastic
    branch and ends at the skeleton point ``(θp, Mp = S(θp))``; its yield rotation ``θ*`` is
    where it encloses the same area (energy) as the skeleton up to ``θp``::

        θ* = (2 A − Mp θp) / (k_y θp − Mp),   A = ∫₀^θp S(θ) dθ

    (RC_NOTES: equal-energy bilinearisation gives much the same as ``θ'y Mn / M'y``).  While
    ``θp <= θ'y`` the spring has not yielded and ``θ* = θ'y``.  ``θ*`` is at most ``Mp / k_y``,
    the elastic branch extended to the peak moment (RC_NOTES' ``θ'y Mn / M'y`` with
    ``Mn = Mp``): just past first yield a skeleton stiffer than ``k_y`` below yield (the
    uncracked branch) holds more energy than the elastic triangle and the equal-energy point
    runs off.  This is the RC test-bed's truth
    (:func:`pier_monitor.core.synthetic.rc.idealised_yield_rotation`).  For the bilinear skeleton
    ``θ* = fy/k1`` exactly whatever ``θp`` (the skeleton is its own bilinearisation), so a
    ductility factor ``θp / θ*`` means the same thing for every family.

    With ``min_yield_fraction`` ``f > 0`` (a fitted Takeda skeleton,
    :data:`TAKEDA_YIELD_PEAK_FRACTION`) the elastic branch is the secant to the skeleton's
    point at ``max(θ'y, θ(f Mn))`` (at most ``θp``), ``Mn`` the skeleton's moment at
    ``min(θp, n θ'y)`` (``n`` = :data:`TAKEDA_NOMINAL_DUCTILITY`) where the skeleton has a
    cracked branch (:data:`TAKEDA_CRACKED_RATIO`), else ``Mp``: the first-yield corner of
    a trilinear fitted to a smooth skeleton sits on the cracked curve below first yield, so
    the secant to it is too stiff and ``θ*`` too small; a skeleton whose corner is first
    yield and whose (nominal) peak moment is below ``My / f`` is unaffected.  The default (0) is the definition itself: the truths
    (:func:`pier_monitor.core.synthetic.rc.idealised_yield_rotation`, the fiber column's
    pushover skeleton) use it.

    Parameters
    ----------
    skel : Skeleton
        The identified skeleton.
    theta_peak : float
        Peak ``|θ|`` reached, rad (non-negative).
    min_yield_fraction : float
        Lowest point of the elastic branch as a fraction of the peak moment, ``[0, 1)``.
    """
    tp = float(theta_peak)
    if not (np.isfinite(tp) and tp >= 0):
        raise InputDataError(f"theta_peak: expected a non-negative rotation, got {theta_peak}")
    f = float(min_yield_fraction)
    if not (np.isfinite(f) and 0 <= f < 1):
        raise InputDataError(f"min_yield_fraction: expected a fraction in [0, 1), got "
                             f"{min_yield_fraction}")
    ty = skel.theta_first_yield
    if tp <= ty:
        return ty
    mp = float(skel(tp))
    te = ty
    if f > 0:  # the floor: f of the nominal moment, on a skeleton with a cracked branch
        k_init = float(skel.moment[1] / skel.theta[1])
        cracked = (ty > skel.theta[1]
                   and k_init >= TAKEDA_CRACKED_RATIO * skel.m_first_yield / ty)
        mn = float(skel(min(tp, TAKEDA_NOMINAL_DUCTILITY * ty))) if cracked else mp
        te = min(max(ty, _rotation_at(skel, f * mn)), tp)
    ky = float(skel(te)) / te
    den = ky * tp - mp
    # Just past first yield a skeleton stiffer than k_y below yield (the uncracked branch)
    # encloses more area than the elastic triangle and the equal-energy point runs off: cap
    # at the elastic branch extended to the peak moment (θ'y Mn / M'y with Mn = Mp).
    cap = mp / ky
    if den <= 0:
        return cap
    return min((2.0 * skel.area(tp) - mp * tp) / den, cap)
