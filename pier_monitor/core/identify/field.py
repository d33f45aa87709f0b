"""Springs from accelerations: the reconstruction of what a field network does not measure.

A monitoring network on a pier in service has accelerometers (at the foundation, the pier
head, some intermediate heights) and no displacement transducer: nothing stands still to
anchor a wire.  Integrating accelerations gives displacements only above the drift band, and
the part that matters most for damage, the plastic offset left by yielding, lies below it.
The physics gives it back (SPEC §3):

* the restoring moment of every spring follows from the accelerations of the masses above
  it (``g = (Bᵀ)⁻¹ (−M (ẍ + 1 a_g))``, so ``f = g − c θ̇``), also where a level has no sensor
  of its own (its small mass is interpolated between the measured ones);
* a bilinear kinematic-hardening spring driven by its moment has one angle history
  (:func:`~pier_monitor.core.model.link_model.inverse_bilinear`), with the plastic offsets,
  the drift and the residual angle that integration cannot see;
* ``x = B⁻¹ θ`` then gives every level's displacement, measured or not.

The parameters are those that make these reconstructed displacements match what was
measured: double-integrated accelerations where there is nothing else (compared after both
are stripped of a low-order polynomial over the window, the band that integration loses to
sensor noise and bias), displacements where a wire or a GNSS receiver measures them.  The
accelerometers' gains are known only to about 1 % (``noise.gain_rel``); a gain error ``ε``
of a level turns into ``ε (x + x_g)`` in its integrated displacement, and ``x_g``, the
ground's displacement, is large in a strong shaking.  The relative gains of the levels are
estimated with the springs, against a prior of ``gain_rel``.

Stages (each result kept, so that a benchmark measures every one):

1. ``increments`` — with every level measured, ``k1`` and ``c`` of each spring by a robust
   regression of moment increments on angle and angular-velocity increments (the part of
   ``θ`` that integration gets right); else the design values;
2. ``springs`` — with every level measured, each spring fitted on its own (``k1, k2, fy,
   c``; several starts of ``fy``), gains held at one;
3. ``joint`` — all springs and the gains together.

This module uses no torch; the PINN (:mod:`pier_monitor.pinn`) starts from its result.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy import optimize

from pier_monitor.core._blas import single_blas_thread
from pier_monitor.core.errors import IdentificationError
from pier_monitor.core.identify.damage import member_ductility
from pier_monitor.core.identify.ensemble import EnsembleDraws, member_windows, phase_randomised
from pier_monitor.core.identify.equation_error import robust_increments
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.config import SpringParameters
from pier_monitor.core.model.link_model import angle_matrix, damped_bilinear
from pier_monitor.core.numerics import Detrend, cumulative_trapezoid

__all__ = ["FieldSettings", "FieldFit", "FieldMembers", "fit_field", "rotation_gain_ratio"]


@dataclass(frozen=True)
class FieldSettings:
    """Settings of the field reconstruction.

    Attributes
    ----------
    detrend_degree : int
        Degree of the polynomial (over the window) removed from integrated and reconstructed
        displacements before they are compared.
    gain_sd : float or None
        Prior 1-sigma relative gain error of the level accelerations; None: the window's
        ``noise.gain_rel``, else 1 %.
    fy_shares : tuple of float
        Starts of each spring's yield moment, as shares of its largest moment.
    max_nfev : int
        Evaluation limit of the joint fit.
    yield_chi2 : float
        A spring counts as yielded when holding it elastic raises the fit's chi-square
        (residuals in units of their standard deviations) by more than this: a
        likelihood-ratio test of the yield branch (13.8 is the 99.9 % point of chi-square
        with the two parameters, k2 and fy, that the elastic spring drops).
    yield_share : float
        ... and by more than this share of the fit's remaining chi-square: a model error the
        fit leaves (design values far off, uncalibrated sensors) must not be explained away
        by a yielding spring.  On the field benchmark (both piers, both shakings, five
        seeds) springs that yield gained at least 10 times the remaining chi-square, elastic
        springs that the chi-square test alone called yielded at most 1.2 times.  An
        ensemble's member weighs its gain against the fit's remaining chi-square, not its
        own where both end levels of its section are measured (see
        :func:`_perturbed_members`).
    yield_hint_share : float
        A spring reported elastic whose yield line the fit reaches, and whose gain from
        yielding is at least this share of the fit's remaining chi-square (short of
        ``yield_share``), "may have yielded": its section is at least suspicious
        (:func:`~pier_monitor.core.identify.damage.yield_test_evidence`).  The members'
        yield decisions rarely see it: near the threshold their decisions split, and
        P(yield) stays below 0.1.  Chosen on the held-out suite's tuning draws
        (seeds 620-655 of :func:`~pier_monitor.bench_heldout.heldout_case`, bilinear springs,
        accelerometers at every level, both piers, 72 runs): of 18 sections that yielded
        but were reported elastic (true DF 1.01-1.60), 9 reached 0.5 (the two past 1.3: DF
        1.41 and 1.60, section 2 of the E-Defense pier, seeds 642 and 655, the latter
        reported intact with P(yield) 0.03), while 13 of 238 elastic sections did (true DF
        0.62-0.99, 11 of them above 0.88); at 1.0, 5 and 5 (the 1.41 not); at 0.3, 10 and
        16.  Applied where both end levels of the section are measured (see
        :class:`~pier_monitor.core.identify.methods.FieldMethod`).
    k1_min_gain_ratio : float
        A section's ``k1`` is poorly identified, whatever its members' interval, where its
        peak rotation is less than this many times the rotation that the levels' gain errors
        alone make (:func:`rotation_gain_ratio`).  A rotation is a second difference of the
        displacements; high on a tall pier it is small beside the displacements, and a gain
        error of a per cent between two levels is a share of it that the members, which
        draw the gains about the fit's own estimate, do not show: two neighbours' ``k1``
        trade off against each other.  Chosen on the held-out suite's tuning draws (seeds
        620-655 of :func:`~pier_monitor.bench_heldout.heldout_case`, bilinear springs,
        accelerometers at every level, both piers, 72 runs, 360 sections): of the 222
        sections whose ``k1`` was shown as identified, 3 were off by more than their
        interval plus 5 % (Table 1, seeds 636 and 621, sections 4-5: +28.7 % against an
        interval of [+26.9, +33.8] %, −25.4 % against [−26.7, −21.9], −8.7 % against
        [−10.3, −7.5]), at ratios of 1.28, 1.71 and 2.43.  At 2.5, 51 more sections are
        flagged (3 yielded; 7 off by more than 5 %, at most 28.7 %) and none of the 171
        left is off by more than its interval plus 5 % (at most 8.5 %, coverage 94 %); at
        2.0, 31 more and one left (the 2.43); at 1.5, 10 and two.
    misfit_floor : float
        Expected misfit of the reconstructed displacements, as a share of each level's
        signal: the sensors' gain errors and the model's own error, far above the noise.
    decorrelation : float
        Samples per independent piece of information in a smooth displacement record.
    disp_decorrelation_s : float
        Time (s) over which the error of a measured displacement stays correlated: a GNSS
        reading fused with the accelerations is smoothed over about a second, so its
        samples are far from independent.
    prior_k1, prior_other, prior_shift : float
        Prior standard deviations about the design values: of log k1, of log (k2/k1) and
        log c, and of the yield-line offset (in units of fy).  They matter only where the
        data say little (a spring between two unmeasured levels, a spring that stays
        elastic), and keep those near the design instead of anywhere.
    residual_scale : float
        The ensemble's members (:func:`_perturbed_members`) also see the data perturbed by
        the fit's own residuals, phase-randomised, times this (0: only the noise model's
        perturbations); 1.5 chosen on the coverage benchmark's tuning seeds (see
        :func:`_perturbed_members`).
    residual_floor : bool
        ... and at least at the misfit the likelihood assumes (``misfit_floor`` of each
        level's signal) where the residuals are smaller.
    """

    detrend_degree: int = 5
    gain_sd: float | None = None
    fy_shares: tuple[float, ...] = (0.5, 0.7, 0.85, 1.0, 1.5)
    max_nfev: int = 200
    yield_chi2: float = 13.8
    yield_share: float = 2.0
    yield_hint_share: float = 0.5
    k1_min_gain_ratio: float = 2.5
    misfit_floor: float = 0.01
    decorrelation: float = 20.0
    disp_decorrelation_s: float = 1.0
    prior_k1: float = 0.3
    prior_other: float = 1.0
    prior_shift: float = 0.3
    residual_scale: float = 1.5
    residual_floor: bool = True


@dataclass(frozen=True)
class FieldMembers(EnsembleDraws):
    """An ensemble around a field reconstruction (M members; member 0 the fit itself): the
    members' parameters, yield decisions and ductility factors
    (:class:`~pier_monitor.core.identify.ensemble.EnsembleDraws`, ``params`` (M, N, 4) SI,
    ``fy`` of a spring that did not yield its largest moment) and their histories.

    Attributes
    ----------
    theta, moment : ndarray, shape (M, T, N)
        Each member's angles (rad) and spring moments (N·m).
    k1_at_bound : ndarray of bool, shape (N,)
        Springs whose ``k1`` ended on the joint fit's search box in the fit, or on one side
        of it in more than 5 % of the members (where the 90 % interval's end lies): the box,
        not the data, ends their interval (None when not computed).
    """

    theta: np.ndarray
    moment: np.ndarray
    k1_at_bound: np.ndarray | None = None


@dataclass(frozen=True)
class FieldFit:
    """What the field reconstruction found.

    Attributes
    ----------
    params : SpringParameters
        The final parameters (stage ``joint``).
    stages : dict of str to SpringParameters
        Parameters after each stage, in order (``increments``, ``springs``, ``joint``).
    yielded : ndarray of bool, shape (N,)
        Springs whose data show yielding.
    gains : ndarray, shape (N,)
        Estimated relative gain error of each level's acceleration against the foundation's
        (0 where the level has no accelerometer).
    theta, moment : ndarray, shape (T, N)
        Reconstructed spring angles (rad) and moments (N·m).
    x, v : ndarray, shape (T, N)
        Reconstructed displacements (m) and velocities (m/s) of every level, relative to the
        foundation.
    misfit : ndarray, shape (N,)
        RMS of the displacement residual of each measured level over the RMS of its
        measured (detrended) displacement; NaN where not measured.
    members : FieldMembers or None
        The ensemble, when one was asked for.
    yield_gain_share : ndarray, shape (N,)
        Per spring, the rise of the accelerations' chi-square when it is held elastic over
        the fit's remaining chi-square (the share test of ``FieldSettings.yield_share``); NaN
        where the fitted yield line is never reached (no test); empty where not computed.
    """

    params: SpringParameters
    stages: dict[str, SpringParameters]
    yielded: np.ndarray
    gains: np.ndarray
    theta: np.ndarray
    moment: np.ndarray
    x: np.ndarray
    v: np.ndarray
    misfit: np.ndarray = field(default_factory=lambda: np.zeros(0))
    members: FieldMembers | None = None
    yield_gain_share: np.ndarray = field(default_factory=lambda: np.zeros(0))


class _FieldProblem:
    """Data and model of one window (see the module documentation)."""

    def __init__(self, window: MeasuredWindow, settings: FieldSettings) -> None:
        g = window.geometry
        cov = window.coverage
        self.n = n = g.n_levels
        self.t_len = t_len = window.t.size
        self.dt = dt = window.dt
        self.b = angle_matrix(g.section_heights_m)
        self.b_inv = np.linalg.inv(self.b)
        self.bt_inv = np.linalg.inv(self.b.T)
        self.m = g.masses_kg
        self.acc = np.flatnonzero(cov.acceleration)
        if not cov.acceleration[-1]:
            raise IdentificationError(
                f"window {window.event_id}: the top level (level {n}) has no accelerometer; "
                "the moments of the springs cannot be known without the motion of its mass")
        self.disp = np.flatnonzero(cov.displacement)
        self.full = bool(cov.acceleration.all())
        gain_sd = settings.gain_sd
        if gain_sd is None:
            gain_sd = _gain_rel(window)
        self.gain_sd = float(gain_sd)
        # absolute accelerations of every mass; levels without a sensor interpolated in height
        z = g.level_heights_m
        known_z = np.r_[0.0, z[1:][self.acc]]
        known = np.column_stack([window.ag, window.a[:, self.acc] + window.ag[:, None]])
        self.a_abs = np.empty((t_len, n))
        for j in range(n):
            k = int(np.searchsorted(known_z, z[j + 1]))
            if k < known_z.size and known_z[k] == z[j + 1]:
                self.a_abs[:, j] = known[:, k]
            else:
                w = (z[j + 1] - known_z[k - 1]) / (known_z[k] - known_z[k - 1])
                self.a_abs[:, j] = (1.0 - w) * known[:, k - 1] + w * known[:, k]
        self.detrend = Detrend(t_len, settings.detrend_degree)
        a_acc = window.a[:, self.acc]
        v_int = cumulative_trapezoid(a_acc, dt)
        self.x_int = self.detrend(cumulative_trapezoid(v_int, dt))
        self.v_int = self.detrend(v_int)
        v_g = cumulative_trapezoid(window.ag, dt)
        self.x_g = cumulative_trapezoid(v_g, dt)
        self.scale = np.sqrt(np.mean(self.x_int ** 2, axis=0))
        self.scale = np.where(self.scale > 0, self.scale, 1.0)
        # measured displacements (wires, GNSS): compared as they are
        self.x_meas = window.x[:, self.disp]
        sig = window.noise.x[self.disp]
        self.x_sigma = np.where(np.isfinite(sig) & (sig > 0), sig,
                                1e-3 * np.abs(self.x_meas).max(axis=0) + 1e-12)
        self.disp_scale = np.sqrt(np.mean(self.x_meas ** 2, axis=0)) if self.disp.size else 0.0
        self.floor = settings.misfit_floor
        self.weight = 1.0 / np.sqrt(settings.decorrelation)
        self.disp_weight = 1.0 / np.sqrt(max(settings.decorrelation,
                                             settings.disp_decorrelation_s / dt))
        self.prior_sd = np.array([settings.prior_k1, settings.prior_other, np.inf,
                                  settings.prior_other, settings.prior_shift])
        self.prior_mean = np.zeros((n, 5))
        self.g0 = self.moments(np.zeros(self.acc.size))
        self.f_max = np.maximum(np.abs(self.g0).max(axis=0), 1e-12)
        # angular velocities (detrended integrals) for the start from increments
        self.theta_dot_meas = (self.v_int @ self.b.T) if self.full else None

    def moments(self, eps: np.ndarray) -> np.ndarray:
        """``g`` (T, N) with the level accelerations corrected by the gain errors ``eps``."""
        e = np.zeros(self.n)
        e[self.acc] = eps
        return (-(self.a_abs / (1.0 + e)) * self.m) @ self.bt_inv.T

    def angles(self, p: np.ndarray, g: np.ndarray, springs: range | list[int] | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
        """Angles and spring moments (T, N) for parameters ``p`` (N, 5): log k1, log k2/k1,
        log fy, log c, and the offset of the yield lines in units of ``fy`` (the back moment
        left by yielding before the window).  Only ``springs`` are computed (others zero)."""
        k1 = np.exp(p[:, 0])
        k2 = k1 * np.exp(p[:, 1])
        fy, c = np.exp(p[:, 2]), np.exp(p[:, 3])
        c = np.maximum(c, k1 * self.dt / 20.0)  # keeps the trapezoidal rule from ringing
        theta = np.zeros((self.t_len, self.n))
        moment = np.zeros((self.t_len, self.n))
        for i in range(self.n) if springs is None else springs:
            theta[:, i], moment[:, i] = damped_bilinear(g[:, i], self.dt, k1[i], k2[i], fy[i],
                                                        c[i], p[i, 4] * fy[i])
        return theta, moment

    def held_elastic(self, p: np.ndarray, elastic: np.ndarray) -> np.ndarray:
        """A copy of ``p`` (N, 5) with the springs of the mask ``elastic`` (N,) held
        elastic: yield lines far above their largest moment, no offset."""
        out = p.copy()
        out[elastic, 2] = np.log(10.0 * self.f_max[elastic])
        out[elastic, 4] = 0.0
        return out

    def residual(self, p: np.ndarray, eps: np.ndarray,
                 theta: np.ndarray | None = None) -> np.ndarray:
        """Residuals in units of their standard deviations: the displacements of the
        measured levels (a misfit floor of ``misfit_floor`` of each level's signal; samples
        of smooth displacements are far from independent, hence the ``decorrelation``),
        then the priors of the parameters and of the gains.  ``theta``: the angles of
        ``p`` and ``eps`` when already computed."""
        if theta is None:
            theta = self.angles(p, self.moments(eps))[0]
        x = theta @ self.b_inv.T
        xa = x[:, self.acc]
        pred = self.detrend(xa + eps * (xa + self.x_g[:, None]))
        parts = [((pred - self.x_int) / (self.floor * self.scale)).ravel() * self.weight]
        if self.disp.size:
            # a displacement fused with the level's accelerometer carries its gain error
            # in the band the accelerometer dominates
            e = np.zeros(self.n)
            e[self.acc] = eps
            xd = x[:, self.disp]
            xd = xd + e[self.disp] * (xd + self.x_g[:, None])
            sd = np.sqrt(self.x_sigma ** 2 + (self.floor * self.disp_scale) ** 2)
            parts.append(((xd - self.x_meas) / sd).ravel() * self.disp_weight)
        parts.append(((p - self.prior_mean) / self.prior_sd).ravel())
        parts.append(eps / self.gain_sd)
        return np.concatenate(parts)

    def set_prior(self, mean: np.ndarray) -> None:
        """Prior means (N, 5) of the parameters (the design values)."""
        self.prior_mean = mean


def _gain_rel(window: MeasuredWindow) -> float:
    """The accelerometers' relative gain error the window's noise model states, else 1 %."""
    return window.noise.gain_rel if window.noise.gain_rel > 0 else 0.01


def rotation_gain_ratio(window: MeasuredWindow, theta: np.ndarray, x: np.ndarray
                        ) -> np.ndarray:
    """Per section, its peak rotation over the rotation that the levels' gain errors make,
    (N,): ``max|θ_i| / Σ_j |B_ij| g max|x_j|`` with ``B`` the angle matrix (``θ = B x``),
    ``g`` the accelerometers' relative gain error (``noise.gain_rel``, else 1 %), ``theta``
    (T, N) the reconstructed rotations (rad) and ``x`` (T, N) the displacements relative to
    the foundation (m).  Infinite where no gain error reaches the section."""
    b = angle_matrix(window.geometry.section_heights_m)
    from_gains = np.abs(b) @ (_gain_rel(window) * np.abs(x).max(axis=0))
    peak = np.abs(theta).max(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(from_gains > 0, peak / np.where(from_gains > 0, from_gains, 1.0),
                        np.inf)


def _smooth_derivative(y: np.ndarray, dt: float, half: int = 2) -> np.ndarray:
    """Central difference over ``2 half`` samples (a derivative that does not amplify noise)."""
    out = np.empty_like(y)
    out[half:-half] = (y[2 * half:] - y[:-2 * half]) / (2 * half * dt)
    out[:half] = out[half]
    out[-half:] = out[-half - 1]
    return out


_COLUMNS = 5  # log k1, log k2/k1, log fy, log c, yield-line offset / fy


def _params(p: np.ndarray) -> SpringParameters:
    k1 = np.exp(p[:, 0])
    return SpringParameters(k1, k1 * np.exp(p[:, 1]), np.exp(p[:, 2]), np.exp(p[:, 3]))


def _bounds(p: np.ndarray, f_max: np.ndarray, width_k1: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (N, 5) around ``p``: k1 within a factor e^width_k1, k2/k1 in [1e-3, 0.5], fy
    within [0.1, 10] of the largest moment, c within e^±5, offset within ±0.9 fy."""
    n = p.shape[0]
    lo = np.column_stack([p[:, 0] - width_k1, np.full(n, np.log(1e-3)), np.log(0.1 * f_max),
                          p[:, 3] - 5.0, np.full(n, -0.9)])
    hi = np.column_stack([p[:, 0] + width_k1, np.full(n, np.log(0.5)), np.log(10.0 * f_max),
                          p[:, 3] + 5.0, np.full(n, 0.9)])
    return lo, hi


_X_SCALE = np.array([0.01, 0.1, 0.02, 0.1, 0.05])


class _JointResiduals:
    """The joint fit's residuals of ``z`` (the parameters (N, 5) raveled, then the gains),
    with the last point evaluated in full remembered: a point of the finite-difference
    Jacobian that moves one parameter of one spring from it (:meth:`map`, the ``workers``
    of :func:`scipy.optimize.least_squares`) integrates that spring alone, one that moves a
    gain the springs whose moments it changes (those below its level).  The other springs'
    angles are the very numbers a full evaluation computes (each spring is driven by its
    own moment), so the Jacobian is the same, for about one integration per column instead
    of N."""

    def __init__(self, pb: _FieldProblem) -> None:
        self.pb = pb
        self._last: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def _split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = self.pb.n
        return z[:_COLUMNS * n].reshape(n, _COLUMNS), z[_COLUMNS * n:]

    def __call__(self, z: np.ndarray) -> np.ndarray:
        p, eps = self._split(z)
        g = self.pb.moments(eps)
        theta = self.pb.angles(p, g)[0]
        self._last = (np.array(z, dtype=float), g, theta)
        return self.pb.residual(p, eps, theta)

    def _moved_spring(self, z: np.ndarray) -> np.ndarray | None:
        """The residuals of ``z`` when it moves one coordinate of the last point (a spring
        parameter or a gain); None otherwise."""
        if self._last is None or self._last[0].shape != z.shape:
            return None
        z0, g, theta0 = self._last
        moved = np.flatnonzero(z != z0)
        if moved.size != 1:
            return None
        p, eps = self._split(z)
        if moved[0] < _COLUMNS * self.pb.n:
            springs = [int(moved[0]) // _COLUMNS]
        else:
            g = self.pb.moments(eps)
            springs = [int(i) for i in np.flatnonzero(~np.all(g == self._last[1], axis=0))]
        theta = theta0.copy()
        if springs:
            theta[:, springs] = self.pb.angles(p, g, springs=springs)[0][:, springs]
        return self.pb.residual(p, eps, theta)

    def map(self, fun: Callable[[np.ndarray], np.ndarray], points) -> list[np.ndarray]:
        """``[fun(z) for z in points]`` (``fun`` is this residual; a point that moves one
        coordinate of the last point is evaluated as above)."""
        out = []
        for z in points:
            r = self._moved_spring(z)
            if r is None:
                p, eps = self._split(z)
                r = self.pb.residual(p, eps)  # in full, the last point kept
            out.append(r)
        return out


@single_blas_thread
def fit_field(window: MeasuredWindow, settings: FieldSettings | None = None,
              members: int = 1, seed: int = 0,
              members_if: Callable[[FieldFit], bool] | None = None) -> FieldFit:
    """Identify the springs of a window measured by a field network (see the module doc).

    Parameters
    ----------
    window : MeasuredWindow
        The event window; ``coverage`` says which levels have accelerometers and which
        displacement sensors.  The structure should be at rest at the first sample (the
        ingest pads windows with the quiet lead-in).
    settings : FieldSettings, optional
    members : int
        With more than one, also an ensemble by randomise-then-optimise on windows perturbed
        as the sensors allow (:class:`FieldMembers`, :func:`_perturbed_members`; member 0
        is the fit itself), each member with its own yield decision.
    seed : int
        Seed of the perturbations.
    members_if : callable, optional
        Called with the fit (no ensemble yet) before the ensemble is drawn; the ensemble is
        drawn only when it returns True (e.g. only when the bilinear family is kept, the
        members being bilinear).

    Raises
    ------
    IdentificationError
        When the top level has no accelerometer.
    """
    settings = settings or FieldSettings()
    pb = _FieldProblem(window, settings)
    n = pb.n
    design = window.design
    stages: dict[str, SpringParameters] = {}
    ratio = np.clip(design.k2 / design.k1, 1e-3, 0.5)
    pb.set_prior(np.column_stack([np.log(design.k1), np.log(ratio), np.zeros(n),
                                  np.log(np.maximum(design.c, 1e-6 * design.k1)), np.zeros(n)]))

    # 1. increments (every level measured), else the design values
    k1 = np.array(design.k1, dtype=float)
    c = np.maximum(np.array(design.c, dtype=float), 1e-6 * k1)
    if pb.full:
        theta = pb.x_int @ pb.b.T
        for i in range(n):
            cols = np.column_stack([np.diff(theta[:, i]), np.diff(pb.theta_dot_meas[:, i])])
            unloading = pb.g0[:-1, i] * np.diff(pb.g0[:, i]) < 0
            k_i, c_i = robust_increments(np.diff(pb.g0[:, i]), cols, rows=unloading)
            if k_i > 0:
                k1[i] = k_i
            c[i] = max(c_i, 1e-4 * k1[i])
    p = np.column_stack([np.log(k1), np.log(ratio), np.log(0.85 * pb.f_max), np.log(c),
                         np.zeros(n)])
    stages["increments" if pb.full else "design"] = _params(p)

    # 2. each spring on its own (every level measured), gains held
    if pb.full:
        theta_meas = pb.x_int @ pb.b.T
        lo, hi = _bounds(p, pb.f_max, 0.7)
        for i in range(n):
            target = theta_meas[:, i]
            norm = max(float(np.std(target)), 1e-15)

            def res_i(q: np.ndarray, i: int = i, target: np.ndarray = target,
                      norm: float = norm) -> np.ndarray:
                pp = p.copy()
                pp[i] = q
                th = pb.angles(pp, pb.g0, springs=[i])[0][:, i]
                return (pb.detrend(th) - target) / norm

            best = None
            for share in settings.fy_shares:
                q0 = np.clip([p[i, 0], p[i, 1], np.log(share * pb.f_max[i]), p[i, 3], 0.0],
                             lo[i] + 1e-9, hi[i] - 1e-9)
                sol = optimize.least_squares(res_i, q0, bounds=(lo[i], hi[i]),
                                             x_scale=_X_SCALE, max_nfev=60)
                if best is None or sol.cost < best.cost:
                    best = sol
            p[i] = best.x
        stages["springs"] = _params(p)

    # 3. joint: every spring and the gains (several starts of fy without stage 2)
    n_eps = pb.acc.size
    width = 1.0 if pb.full else 1.5
    lo, hi = _bounds(p, pb.f_max, width)
    # k1's box holds the prior's mean as well as the start: a start far off (a spring whose
    # small rotations integrate poorly) must not cut off the design value and what lies
    # around it (held-out seed 602, Table 1 pier, accelerometers: the top spring started
    # at -75 % and ended on the box at -32 %, every member with it)
    lo[:, 0] = np.minimum(lo[:, 0], pb.prior_mean[:, 0] - width)
    hi[:, 0] = np.maximum(hi[:, 0], pb.prior_mean[:, 0] + width)
    lo = np.r_[lo.ravel(), np.full(n_eps, -5 * pb.gain_sd)]
    hi = np.r_[hi.ravel(), np.full(n_eps, 5 * pb.gain_sd)]
    scales = np.r_[np.tile(_X_SCALE, n), np.full(n_eps, 0.2 * pb.gain_sd)]

    res_joint = _JointResiduals(pb)
    starts = [p] if pb.full else [
        np.column_stack([p[:, :2], np.log(share * pb.f_max), p[:, 3:]])
        for share in settings.fy_shares]
    sol = None
    for p0 in starts:
        z0 = np.clip(np.r_[p0.ravel(), np.zeros(n_eps)], lo + 1e-9, hi - 1e-9)
        trial = optimize.least_squares(res_joint, z0, bounds=(lo, hi), x_scale=scales,
                                       max_nfev=settings.max_nfev, workers=res_joint.map)
        if sol is None or trial.cost < sol.cost:
            sol = trial
    p = sol.x[:_COLUMNS * n].reshape(n, _COLUMNS).copy()
    eps = sol.x[_COLUMNS * n:]
    # the test weighs the accelerations' evidence only: a displacement fused from a GNSS
    # receiver and an accelerometer carries slow errors of its own (the accelerometer's
    # tilt with the section, the fusion's crossover) that a yielding top spring, carrying
    # the smallest moment, explains too easily
    base_cost = float(np.sum(sol.fun[:pb.t_len * pb.acc.size] ** 2))

    yielded, gain_share = _yield_decision(pb, p, eps, base_cost, settings)
    p_model = pb.held_elastic(p, ~yielded)  # elastic springs stay elastic
    g_fit = pb.moments(eps)
    theta, moment = pb.angles(p_model, g_fit)
    # a spring that never yielded: fy only bounded below by its largest moment
    p_report = p_model.copy()
    p_report[~yielded, 2] = np.log(np.abs(g_fit[:, ~yielded]).max(axis=0))
    # ... and k2 not identifiable: the design's ratio (what the fit left there is arbitrary)
    p_report[~yielded, 1] = pb.prior_mean[~yielded, 1]
    params = _params(p_report)
    stages["joint"] = params
    x = theta @ pb.b_inv.T
    v = _smooth_derivative(x, pb.dt, half=1)
    gains = np.zeros(n)
    gains[pb.acc] = eps
    xa = x[:, pb.acc]
    res = pb.detrend(xa + eps * (xa + pb.x_g[:, None])) - pb.x_int
    misfit = np.full(n, np.nan)
    misfit[pb.acc] = np.sqrt(np.mean(res ** 2, axis=0)) / pb.scale
    out = FieldFit(params=params, stages=stages, yielded=yielded, gains=gains, theta=theta,
                   moment=moment, x=x, v=v, misfit=misfit, yield_gain_share=gain_share)
    if members > 1 and (members_if is None or members_if(out)):
        ensemble = _perturbed_members(window, settings, pb, sol, (lo, hi, scales), members, seed,
                                      _fit_residuals(pb, p, eps, settings))
        out = dataclasses.replace(out, members=ensemble)
    return out


def _yield_decision(pb: _FieldProblem, p: np.ndarray, eps: np.ndarray, base_cost: float,
                    settings: FieldSettings, share_cost: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Which springs yielded (N,) bool: does holding a spring elastic worsen the fit?  And
    each spring's gain over ``share_cost`` (N,), NaN where not tested.

    The likelihood-ratio test of ``yield_chi2`` and ``yield_share`` on the chi-square of the
    accelerations' residuals (``base_cost``: that of the fit ``p``, ``eps``).  The share
    test weighs each spring's gain against ``share_cost`` (N,) where given (default
    ``base_cost``): see :func:`_perturbed_members`.  A spring whose fitted yield lines are
    never reached is not tested."""
    share_cost = np.broadcast_to(base_cost if share_cost is None else share_cost, (pb.n,))
    n_acc = pb.t_len * pb.acc.size
    yielded = np.zeros(pb.n, dtype=bool)
    share = np.full(pb.n, np.nan)
    for i in range(pb.n):
        if np.exp(p[i, 2]) * (1.0 - abs(p[i, 4])) >= pb.f_max[i]:
            continue  # the fitted yield lines are never reached
        pe = pb.held_elastic(p, np.arange(pb.n) == i)
        cost_el = float(np.sum(pb.residual(pe, eps)[:n_acc] ** 2))
        gain = cost_el - base_cost
        share[i] = (gain / share_cost[i] if share_cost[i] > 0
                    else np.inf if gain > 0 else np.nan)
        yielded[i] = gain > settings.yield_chi2 and gain > settings.yield_share * share_cost[i]
    return yielded, share


def _gauss_newton(res: Callable[[np.ndarray], np.ndarray], z0: np.ndarray, jac: np.ndarray,
                  lo: np.ndarray, hi: np.ndarray, scales: np.ndarray, steps: int = 12
                  ) -> np.ndarray:
    """Minimise ``|res(z)|²`` from ``z0`` by Levenberg-Marquardt steps with the Jacobian
    ``jac`` of the fit at ``z0`` (a perturbed member's problem differs from the fit's by its
    data, not its model: the Jacobian holds), within the bounds.  The damping grows tenfold
    after a step that does not lower the cost and shrinks after one that does, so that
    directions the data and priors hardly determine take small steps.  At most ``steps``
    residual evaluations after the first."""
    js = jac * scales
    jtj = js.T @ js
    diag = np.maximum(np.diag(jtj), 1e-12 * max(float(np.diag(jtj).max()), 1e-300))
    z, r = z0, res(z0)
    cost = float(r @ r)
    mu = 1e-3
    for _ in range(steps):
        step = np.linalg.solve(jtj + mu * np.diag(diag), -(js.T @ r)) * scales
        trial = np.clip(z + step, lo, hi)
        r_t = res(trial)
        c_t = float(r_t @ r_t)
        if c_t < cost:
            done = cost - c_t < 1e-4 * cost
            z, r, cost, mu = trial, r_t, c_t, mu / 10.0
            if done:
                break
        else:
            mu *= 10.0
    return z


def _fit_residuals(pb: _FieldProblem, p: np.ndarray, eps: np.ndarray,
                   settings: FieldSettings) -> tuple[np.ndarray, np.ndarray]:
    """The fit's residuals (model minus data, m): of the integrated displacements of the
    accelerometer levels (T, A), detrended, and of the measured displacements (T, D); each
    channel raised to the misfit the likelihood assumes where it is smaller
    (``residual_floor``), times ``residual_scale``."""
    theta = pb.angles(p, pb.moments(eps))[0]
    x = theta @ pb.b_inv.T
    xa = x[:, pb.acc]
    res_a = pb.detrend(xa + eps * (xa + pb.x_g[:, None])) - pb.x_int
    sd_a = pb.floor * pb.scale
    res_d = np.zeros((pb.t_len, 0))
    sd_d = np.zeros(0)
    if pb.disp.size:
        e = np.zeros(pb.n)
        e[pb.acc] = eps
        xd = x[:, pb.disp]
        res_d = xd + e[pb.disp] * (xd + pb.x_g[:, None]) - pb.x_meas
        sd_d = np.sqrt(pb.x_sigma ** 2 + (pb.floor * pb.disp_scale) ** 2)
    out = []
    for res, sd in ((res_a, sd_a), (res_d, sd_d)):
        rms = np.sqrt(np.mean(res ** 2, axis=0))
        gain = np.ones_like(rms)
        if settings.residual_floor:
            gain = np.where(rms > 0, np.maximum(1.0, sd / np.maximum(rms, 1e-300)), 1.0)
        out.append(res * gain * settings.residual_scale)
    return out[0], out[1]


def _perturbed_members(window: MeasuredWindow, settings: FieldSettings, pb: _FieldProblem,
                       sol: optimize.OptimizeResult,
                       box: tuple[np.ndarray, np.ndarray, np.ndarray], members: int, seed: int,
                       residuals: tuple[np.ndarray, np.ndarray] | None = None
                       ) -> FieldMembers:
    """The ensemble by randomise-then-optimise (member 0: the fit itself).

    Member ``m`` fits the joint problem again on the window perturbed as its sensors allow
    (:func:`~pier_monitor.core.identify.ensemble.member_windows`: the accelerations' noise
    and each level's gain, known to ``noise.gain_rel``; the drift of measured displacements
    and velocities), with the prior means of the parameters drawn from the priors
    themselves (``prior_k1``, ``prior_other``, ``prior_shift`` about the design values): for
    a linear Gaussian problem such members are exact draws of the posterior, and a
    parameter the data say little about (a spring between unmeasured levels) spreads as
    wide as its prior allows.  Each member starts from the fit's solution (the start is no
    source of spread), is optimised by Gauss-Newton steps with the fit's Jacobian
    (:func:`_gauss_newton`: exact for a linear problem, a few residual evaluations where a
    new joint fit would take hundreds) and makes its own yield decision (:func:`_yield_decision`), so that
    the share of the members whose spring yielded is the probability the data give it; a
    spring that did not yield reports ``fy`` as its largest moment.  The member's test
    weighs the gain of the yield branch against the fit's remaining chi-square (the model
    error of the data themselves, what ``yield_share`` guards against), not against the
    member's own: the perturbations drawn on purpose (below) raise a member's chi-square
    about threefold (``1 + residual_scale²``), and weighed against it a section that just
    yielded kept its yield in few members, its DF interval then ending at about 1, below
    the truth (see the second table).  Only where both end levels of the section are
    measured: next to an unmeasured level the fit's chi-square understates the model error
    (the masses interpolated there), a yield branch can absorb it, and the stricter test
    of the member's own chi-square stays (tuning seed 622, "sparse": the top spring, true
    DF 0.62, fitted as yielded at 6 % of its yield moment, held yielded by 16 % of the
    members with the member's own chi-square, by 94 % with the fit's).

    The noise model knows the sensors' noise, drift and gains, not their azimuth, tilt or
    bias errors nor the model's own error, and members perturbed by it alone were far too
    alike.  Each member's data are therefore also perturbed by the fit's own residuals
    (``residuals``, :func:`_fit_residuals`): a phase-randomised copy
    (:func:`~pier_monitor.core.identify.ensemble.phase_randomised`: the residuals'
    spectrum, so their level and correlation in time, and their cross-correlation between
    levels) times ``residual_scale``, each channel at least at
    the misfit the likelihood assumes.  Where the residuals exceed what the likelihood
    expects, the members spread by as much (the Birge ratio, the noise estimated from the
    residuals); ``residual_scale`` above one stands for the part of a systematic error that
    the fit absorbs and its residuals no longer show.

    Coverage of the 90 % intervals (:func:`pier_monitor.bench.bench_coverage`, E-Defense
    pier, 32 members; k1 / c / DF of all sections, in brackets of the truly yielded ones):

    ===========================  ===================================  ==================================
    layout, shaking              noise model only                     with the residuals (scale 1.5)
    ===========================  ===================================  ==================================
    tuning seeds 100-102
    accel, strong                58 (50) / 92 (83) / 58 (33) %        100 (100) / 100 (100) / 92 (100) %
    accel, just_yield            17 (33) / 58 (33) / 83 (67) %        83 (100) / 83 (100) / 83 (67) %
    sparse, strong               75 (50) / 83 (67) / 92 (83) %        92 (83) / 100 (100) / 100 (100) %
    sparse, just_yield           100 (100) / 100 / 100 %              100 (100) / 100 / 100 %
    held-out seeds 200-202
    accel, strong                42 (17) / 75 (67) / 75 (50) %        100 (100) / 100 (100) / 100 (100) %
    accel, just_yield            33 (33) / 50 (33) / 75 (0) %         92 (100) / 75 (67) / 92 (67) %
    sparse, strong               83 (67) / 75 (50) / 100 (100) %      83 (67) / 100 (100) / 100 (100) %
    sparse, just_yield           100 (100) / 100 / 83 (67) %          92 (100) / 100 (100) / 92 (100) %
    ===========================  ===================================  ==================================

    On the tuning seeds ``residual_scale`` 1.0 gave k1 67 % on sparse/strong (the two lower
    sections biased 4-6 % and 12-19 % alike in every seed), 1.25 gave 83 %, 1.5 92 %.
    held-out seeds 200-204 with the residuals: accel, strong 100 (100) / 100 (100) / 100
    (100) %; accel, just_yield 95 (100) / 85 (80) / 90 (60) %; sparse, strong 65 (40) / 100
    (100) / 95 (90) %; sparse, just_yield 70 (60) / 95 (100) / 90 (80) %.  The sparse
    layout's k1 falls short: its sections 1-3, with an unmeasured level at an end, are off
    alike in every seed (a trade-off with the masses interpolated there that no member
    sees), so their k1 is flagged poorly identified
    (:func:`~pier_monitor.core.identify.damage.with_identifiability`).  The yielded DF on
    accel, just_yield (3 of 5) rests on one yielded section per seed.
    k1 of the sections not flagged poorly identified by their width, held-out 200-202:
    100 / 100 / 80 / 100 % (before: 22 / 33 / 67 / 100 %).  Every state as before (held-out: all right but one
    sparse/just_yield seed, whose section 2, true DF 0.95, is called yielded with or without
    the residuals).  Time per event (32 members, two shared cores): accel 7-14 s (before
    5-9 s), sparse 24-26 s (before 22-28 s).

    The members' yield test (weighed against the member's own chi-square or the fit's), 90 %
    DF coverage of the truly yielded sections (in brackets: of all sections), 32 members,
    drawn cases of the held-out suite's kind (:func:`pier_monitor.bench_heldout.heldout_case`,
    E-Defense pier, tuning seeds 620-627; the held-out suite's seeds 600-603 after it):

    ========================  ==================  ==================
    layout                    member's own        the fit's
    ========================  ==================  ==================
    accel                     80 (91) %           100 (97) %
    sparse                    70 (84) %           90 (91) %
    held-out, accel           67 %                89 (94) %
    held-out, Table-1 accel   75 %                75 (92) %
    ========================  ==================  ==================

    k1 and c are the same either way (the test decides the yield branch only).  The
    remaining Table-1 misses are sections far beyond yield (true DF 4-5.4) whose DF is
    3-8 % low with a narrow interval, no yield decision.  On "sparse" every section has an
    unmeasured end, so the member's own test stays (above) and the DF of a section that may
    have yielded is flagged poorly identified
    (:func:`~pier_monitor.core.identify.damage.poorly_identified`).  Time unchanged: the
    test costs the same residual evaluations either way.
    """
    n = pb.n
    lo, hi, scales = box  # the joint fit's bounds and scales
    rng = np.random.default_rng([seed, 1])  # the prior draws, apart from the windows'
    rng_res = np.random.default_rng([seed, 2])  # the residuals' surrogates
    params = np.empty((members, n, 4))
    theta = np.empty((members, pb.t_len, n))
    moment = np.empty_like(theta)
    yielded = np.zeros((members, n), dtype=bool)
    on_lo, on_hi = np.zeros((members, n), dtype=bool), np.zeros((members, n), dtype=bool)
    k1_lo, k1_hi = lo[0:_COLUMNS * n:_COLUMNS], hi[0:_COLUMNS * n:_COLUMNS]
    finite_sd = np.where(np.isfinite(pb.prior_sd), pb.prior_sd, 0.0)
    ends_measured = window.coverage.section_ends_measured
    for m, w in enumerate(member_windows(window, members, seed=seed)):
        if m == 0:
            pm, z = pb, sol.x
        else:
            pm = _FieldProblem(w, settings)
            pm.set_prior(pb.prior_mean + finite_sd * rng.standard_normal(pb.prior_mean.shape))
            if residuals is not None:
                pm.x_int = pm.x_int + pm.detrend(phase_randomised(rng_res, residuals[0]))
                if pm.disp.size:
                    pm.x_meas = pm.x_meas + phase_randomised(rng_res, residuals[1])

            z = _gauss_newton(
                lambda zv, pm=pm: pm.residual(zv[:_COLUMNS * n].reshape(n, _COLUMNS),
                                              zv[_COLUMNS * n:]),
                sol.x, np.asarray(sol.jac), lo, hi, scales)
        p = z[:_COLUMNS * n].reshape(n, _COLUMNS).copy()
        eps = z[_COLUMNS * n:]
        on_lo[m], on_hi[m] = p[:, 0] <= k1_lo + 1e-6, p[:, 0] >= k1_hi - 1e-6
        base = float(np.sum(pm.residual(p, eps)[:pm.t_len * pm.acc.size] ** 2))
        if m == 0:
            fit_base = base
        yielded[m] = _yield_decision(pm, p, eps, base, settings,
                                     share_cost=np.where(ends_measured, fit_base, base))[0]
        p_model = pm.held_elastic(p, ~yielded[m])
        g = pm.moments(eps)
        theta[m], moment[m] = pm.angles(p_model, g)
        k1 = np.exp(p_model[:, 0])
        params[m] = np.column_stack([k1, k1 * np.exp(p_model[:, 1]), np.exp(p_model[:, 2]),
                                     np.exp(p_model[:, 3])])
        params[m, ~yielded[m], 2] = np.abs(g[:, ~yielded[m]]).max(axis=0)
    ductility = member_ductility(theta, params, yielded)
    # one member on the box (of 32) is an outlier the 5-95 % interval leaves out; two set it
    k1_at_bound = on_lo[0] | on_hi[0] | (on_lo.mean(axis=0) > 0.05) | (on_hi.mean(axis=0) > 0.05)
    return FieldMembers(params=params, theta=theta, moment=moment, yielded=yielded,
                        ductility=ductility, k1_at_bound=k1_at_bound)
