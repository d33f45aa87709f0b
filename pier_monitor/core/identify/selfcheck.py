"""Self-check by output error: does the identified model reproduce what was measured?

The responses an identification reproduces cannot test it: on the PINN route they are the
data plus a learned correction, on the field route the measured accelerations themselves.
:func:`simulate_identified` therefore runs the identified bilinear model
(:func:`pier_monitor.core.model.solver.simulate`, the window's geometry, the identified
``k1, k2, fy, c``) under the measured foundation acceleration ``window.ag``, from rest at the
window's first sample (windows begin before the shaking), and :func:`model_misfit`
compares the simulation with what was measured:

* the relative acceleration of every level with accelerometers
  (``window.coverage.acceleration``), in every layout;
* the displacement of the levels with a displacement sensor (``window.coverage.displacement``).

The point estimate is simulated, not every member of an ensemble: the members differ by
what the data allow, and a misfit of the point estimate beyond the noise model is one of
the model, not of the scatter.

Per level and quantity it gives (:class:`MisfitEntry`):

``misfit``
    the relative RMS misfit ``rms(sim − meas) / rms(meas)``;
``allowed``
    what the noise model and the identification allow:
    ``max(limits.model_rel, limits.noise_factor · sqrt((σ / rms(meas))² + gain_rel²))``, with
    ``σ`` the level's 1-sigma noise (``window.noise.a`` or ``.x``) and ``gain_rel`` the
    sensors' relative gain uncertainty (a floor proportional to the signal).
    ``model_rel`` is the output error of a correct bilinear model identified from noisy
    data (its parameters are off by their own scatter); it was chosen on the tuning seeds
    of the ``selfcheck`` benchmark (1.5 times the largest clean misfit there, 0.35 at the
    base level of the Table 1 pier, whose relative acceleration is the smallest);
``systematic``
    the share of the residual's energy that the pier's response explains: the ``R²`` of a
    least-squares fit of the residual by the identified model's simulated histories of the
    quantity at every measured level and the measured histories of the other measured
    levels (not the level's own: it holds its sensor's fault), with their derivatives and
    integrals (over the window, means removed).  A wrong stiffness, pinched or degrading
    loops, another damping leave residuals that follow the response (a shifted phase, a
    changed amplitude, higher modes that ring otherwise), ``R²`` near 1; noise and a sensor
    fault (an offset step, a spike) do not, ``R²`` near 0 (white noise of 0.8 times a
    level's RMS on the E-Defense pier's run 2: 0.015).  The level's own response alone
    explained too little of a model's error at one level: on the RC test-bed's held-out
    seeds (302-303) the misfit of BWBN and Takeda springs at one level (the base of the
    accelerometer layout, mid-height of the three-level one) followed it by 11-29 % and was
    read as a sensor fault in 5 runs; with every level's response the 2 runs of the
    accelerometer layout read as the model's misfit.  On the three-level layout (two
    levels with accelerometers besides the foundation) it read 7 runs' misfit at one level
    as a sensor's: each level answers for its own sections there, so a model's error stays
    at one level, and such a misfit is the model's (``sensor_min_levels``); an offset is a
    sensor's in every layout.

and, for accelerations, ``offset``: the RMS of the residual's moving mean over
``limits.offset_span_s`` (4 s, several periods of the pier) relative to ``rms(meas)``.  A
relative acceleration has no lasting mean; an accelerometer's offset or step has.

The check *fires* (:attr:`ModelMisfit.fires`) when a level's misfit exceeds its allowance or
a level's offset stands out, and says what kind of misfit it is (:attr:`ModelMisfit.kind`):

``"sensor"``
    a level's offset exceeds ``limits.offset_rel`` and is either half its misfit or more, or
    three times the other levels' offsets or more; or the misfit is at one level only and
    the response does not explain it (``systematic < limits.systematic``) and at least
    ``limits.sensor_min_levels`` levels have accelerometers.  A sensor at that
    level, not the physics, is suspect; the result is unreliable (the identification was
    misled by the sensor: its states are no diagnosis);
``"model"``
    any other misfit (several levels, or a residual that follows the response): the
    bilinear model does not follow the pier; the states can only go up
    (:func:`~pier_monitor.core.identify.damage.decide_state`, rules 5-6), with the reason
    ``model misfit: ...`` and its size.

:func:`energy_indices` is the damage indicator that does not depend on the spring family:
the hysteretic energy of every section's moment–rotation loop, normalised by the elastic
energy at its peak.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pier_monitor.core.errors import InputDataError, SolverError
from pier_monitor.core.identify.checks import level_misfits
from pier_monitor.core.identify.equation_error import inertia_moments
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.config import SpringParameters
from pier_monitor.core.model.solver import Response, simulate

__all__ = ["MisfitLimits", "MisfitEntry", "ModelMisfit", "simulate_identified",
           "model_misfit", "judge_misfit", "allowed_misfit", "energy_indices", "ENERGY_INDEX_LARGE",
           "ENERGY_INDEX_MISFIT", "SelfCheck", "self_check", "section_evidence"]

#: Energy index (hysteretic energy / elastic energy at the peak) above which a section has
#: dissipated more than damping errors and noise give an elastic section: it makes a
#: section at least suspicious.  Twice the largest index of the sections that stayed
#: elastic (true DF < 1) on the clean tuning runs of the ``selfcheck`` benchmark (0.64, a
#: spring at DF 0.98), rounded up; a bilinear spring at DF 1.35 reaches 0.5-2, at DF 3.2
#: about 3.
ENERGY_INDEX_LARGE = 1.3
#: Energy index above which a section is at least suspicious when the model misfits (half
#: of :data:`ENERGY_INDEX_LARGE`).
ENERGY_INDEX_MISFIT = 0.65

_NAMES = {"a": "acceleration", "x": "displacement"}


def _finite(value: float) -> float | None:
    """``value`` as a float, None when it is not finite (strict JSON)."""
    value = float(value)
    return value if math.isfinite(value) else None


@dataclass(frozen=True)
class MisfitLimits:
    """Thresholds of the output-error check (dimensionless).

    Attributes
    ----------
    model_rel : float
        Relative RMS misfit that a correct model identified from noisy data may leave.
    noise_factor : float
        Factor on the noise-and-gain allowance.
    systematic : float
        ``R²`` of the residual on the response above which a misfit is systematic (the
        model's), below which a misfit at one level is a sensor's.
    offset_rel : float
        Relative RMS of the residual's moving mean (accelerations) above which a sensor is
        suspect (an offset, a step) ...
    offset_share : float
        ... when that moving mean is also at least this share of the residual's RMS (a
        model's residual oscillates with the response, a long-period one leaves a little of
        itself in the moving mean), or
    offset_contrast : float
        ... at least this many times the largest offset of the other levels (a faulty
        sensor misleads the identification, whose model then misfits every level; the
        faulty level's offset still stands out).
    offset_span_s : float
        Span of that moving mean, s.
    sensor_min_levels : int
        Levels with accelerometers needed to read a misfit at one level that the response
        does not explain as a sensor's: with fewer (the three-level layout: mid-height and
        top) each level answers for its own sections, a model's error stays at one level,
        and the misfit is read as the model's (offsets are a sensor's in every layout).
    internal_dt : float
        Largest integration step of the simulation, s.
    """

    model_rel: float = 0.55
    noise_factor: float = 3.0
    systematic: float = 0.3
    offset_rel: float = 0.02
    offset_share: float = 0.5
    offset_contrast: float = 3.0
    offset_span_s: float = 4.0
    sensor_min_levels: int = 3
    internal_dt: float = 0.001


@dataclass(frozen=True)
class MisfitEntry:
    """The misfit of one level and quantity (see the module documentation).

    ``level`` is 1-based, ``quantity`` ``"acceleration"`` or ``"displacement"``;
    ``misfit``, ``allowed`` relative RMS; ``systematic`` the ``R²`` in [0, 1];
    ``noise_rel`` the noise-and-gain allowance before its factor,
    ``sqrt((σ / rms(meas))² + gain_rel²)``; ``offset`` the RMS of the residual's moving
    mean over ``MisfitLimits.offset_span_s``, relative to ``rms(meas)`` (accelerations only:
    a relative acceleration has no lasting mean, a sensor's offset has);
    ``exceeded`` whether ``misfit > allowed``.
    """

    level: int
    quantity: str
    misfit: float
    allowed: float
    systematic: float
    noise_rel: float = 0.0
    offset: float = 0.0

    @property
    def exceeded(self) -> bool:
        """The misfit is beyond its allowance (or not finite)."""
        return not math.isfinite(self.misfit) or self.misfit > self.allowed

    def as_dict(self) -> dict[str, Any]:
        """Plain form for JSON (a non-finite number as None)."""
        return {"level": self.level, "quantity": self.quantity,
                "misfit_rel": _finite(self.misfit), "allowed_rel": _finite(self.allowed),
                "systematic_r2": _finite(self.systematic), "noise_rel": _finite(self.noise_rel),
                "offset_rel": _finite(self.offset), "exceeded": self.exceeded}


@dataclass(frozen=True)
class ModelMisfit:
    """Result of :func:`model_misfit`.

    Attributes
    ----------
    entries : tuple of MisfitEntry
        One per measured level and quantity.
    kind : str
        ``"none"`` (the check passed), ``"sensor"`` or ``"model"`` (see the module).
    reasons : tuple of str
        One plain-language line per level and quantity beyond its allowance, naming the
        level, the quantity and the size; empty when the check passed.
    simulated : Response or None
        The simulation of the identified model (None when it failed: then ``reasons`` say
        why and ``kind`` is ``"model"``).
    """

    entries: tuple[MisfitEntry, ...]
    kind: str = "none"
    reasons: tuple[str, ...] = ()
    simulated: Response | None = field(default=None, repr=False, compare=False)

    @property
    def fires(self) -> bool:
        """The check found a misfit beyond the noise model."""
        return self.kind != "none"

    @property
    def worst(self) -> MisfitEntry | None:
        """The entry with the largest ``misfit / allowed``."""
        if not self.entries:
            return None
        return max(self.entries, key=lambda e: (e.misfit / e.allowed
                                                if math.isfinite(e.misfit) else math.inf))

    def as_dict(self) -> dict[str, Any]:
        """Plain form for JSON (``result.json``'s ``model_misfit``)."""
        worst = self.worst
        return {"fires": self.fires, "kind": self.kind, "reasons": list(self.reasons),
                "worst_level": None if worst is None else worst.level,
                "worst_quantity": None if worst is None else worst.quantity,
                "worst_misfit_rel": None if worst is None else _finite(worst.misfit),
                "worst_allowed_rel": None if worst is None else _finite(worst.allowed),
                "entries": [e.as_dict() for e in self.entries]}


def simulate_identified(window: MeasuredWindow, params: SpringParameters, *,
                        internal_dt: float = 0.001) -> Response:
    """The identified model simulated under the window's foundation acceleration, from rest.

    Parameters
    ----------
    window : MeasuredWindow
        The measured window (uniform ``t``; ``ag`` m/s²; N levels).
    params : SpringParameters
        The identified ``k1, k2, fy, c`` (N springs, SI).
    internal_dt : float
        Largest integration step, s; the step used divides ``window.dt``.

    Returns
    -------
    Response
        Responses at the window's samples (T of them), ``t`` from 0.

    Raises
    ------
    InputDataError
        If ``params`` does not have N finite positive ``k1``, ``fy``, non-negative ``c`` and
        ``0 <= k2 < k1``.
    SolverError
        If the simulation diverges.
    """
    n = window.n_levels
    if params.n_springs != n:
        raise InputDataError(f"params: expected {n} springs, got {params.n_springs}")
    for name in ("k1", "k2", "fy", "c"):
        v = np.asarray(getattr(params, name), dtype=float)
        if not np.all(np.isfinite(v)) or np.any(v < 0) or (name in ("k1", "fy")
                                                           and np.any(v <= 0)):
            raise InputDataError(f"params {name}: expected finite positive values, got "
                                 f"{v.tolist()}")
    if np.any(params.k2 >= params.k1):
        raise InputDataError(f"params k2: expected below k1, got k2 {params.k2.tolist()}, "
                             f"k1 {params.k1.tolist()}")
    if not (math.isfinite(internal_dt) and internal_dt > 0):
        raise InputDataError(f"internal_dt: expected a positive step in s, got {internal_dt}")
    sub = max(1, int(math.ceil(window.dt / internal_dt - 1e-9)))
    sim = simulate(window.geometry, params, np.asarray(window.ag), window.dt,
                   dt=window.dt / sub, output_dt=window.dt)
    short = window.t.size - sim.t.size  # rounding of the step may drop the last sample
    if short > 0:
        pad = lambda arr: np.pad(arr, [(0, short)] + [(0, 0)] * (arr.ndim - 1), mode="edge")
        sim = Response(t=np.arange(window.t.size) * window.dt, ag=np.asarray(window.ag),
                       **{k: pad(getattr(sim, k)) for k in ("x", "v", "a", "theta", "moment")})
    return sim


def _response_columns(response: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The regressors of :func:`_systematic_share` from responses ``response`` (T, M): each
    response, its derivative and its integral (means removed), ``(T, 3M)`` in that order,
    scaled to unit norm, and which of them are not all zero ``(3M,)``."""
    y = response - response.mean(axis=0)
    iy = np.cumsum(y, axis=0) * dt
    iy -= iy.mean(axis=0)
    cols = np.concatenate([y, np.gradient(y, dt, axis=0), iy], axis=1)
    norms = np.linalg.norm(cols, axis=0)
    nonzero = norms > 0
    return cols / np.where(nonzero, norms, 1.0), nonzero


def _systematic_share(residual: np.ndarray, cols: np.ndarray) -> float:
    """``R²`` of the residual (T,) fitted by the unit-norm regressors ``cols`` (T, K)
    (:func:`_response_columns`)."""
    r = residual - residual.mean()
    energy = float(r @ r)
    if energy <= 0 or cols.shape[1] == 0:
        return 0.0
    coef, *_ = np.linalg.lstsq(cols, r, rcond=None)
    fitted = cols @ coef
    return float(np.clip((fitted @ fitted) / energy, 0.0, 1.0))


def model_misfit(window: MeasuredWindow, params: SpringParameters,
                 limits: MisfitLimits | None = None) -> ModelMisfit:
    """Compare the identified model's simulation with the measured responses.

    Parameters
    ----------
    window : MeasuredWindow
        The measured window the parameters were identified from.
    params : SpringParameters
        The identified parameters (the point estimate).
    limits : MisfitLimits, optional

    Returns
    -------
    ModelMisfit
        Entries per measured level and quantity, whether and why the check fires.
    """
    lim = limits or MisfitLimits()
    try:
        sim = simulate_identified(window, params, internal_dt=lim.internal_dt)
    except (InputDataError, SolverError) as err:
        return ModelMisfit(entries=(), kind="model",
                           reasons=(f"model misfit: the identified model cannot be simulated "
                                    f"under the measured foundation motion ({err})",))
    gain = float(window.noise.gain_rel) if math.isfinite(window.noise.gain_rel) else 0.0
    entries = []
    for q, covered in (("a", window.coverage.acceleration), ("x", window.coverage.displacement)):
        levels = np.flatnonzero(covered)
        simulated = np.asarray(getattr(sim, q))[:, levels]
        finite = bool(np.all(np.isfinite(simulated)))
        measured = np.asarray(getattr(window, q))[:, levels]
        # the regressors of every level's share, once: the model's response at every
        # measured level and the measured ones (T, 3 * 2L)
        if finite:
            cols, nonzero = _response_columns(np.concatenate([simulated, measured], axis=1),
                                              window.dt)
        for lv, meas, res, scale, misfit, sigma in level_misfits(
                getattr(window, q), getattr(sim, q), getattr(window.noise, q), covered):
            noise_rel = math.hypot(sigma / scale, gain)
            # the model's response everywhere and the other levels' measurements: not the
            # level's own measurement, which holds its sensor's fault
            share = 1.0
            if math.isfinite(misfit) and finite:
                use = np.tile(np.r_[np.ones(levels.size, dtype=bool), levels != lv], 3)
                share = _systematic_share(res, cols[:, use & nonzero])
            offset = (_moving_mean_rms(res, int(round(lim.offset_span_s / window.dt))) / scale
                      if q == "a" else 0.0)
            entries.append(MisfitEntry(level=int(lv + 1), quantity=_NAMES[q], misfit=misfit,
                                       allowed=allowed_misfit(noise_rel, lim),
                                       systematic=share, noise_rel=noise_rel, offset=offset))
    return judge_misfit(entries, lim, simulated=sim)


def _moving_mean_rms(residual: np.ndarray, span: int) -> float:
    """RMS of the moving mean of ``residual`` over ``span`` samples (NaN if not finite)."""
    if not np.all(np.isfinite(residual)):
        return float("nan")
    span = int(min(max(span, 1), residual.size))
    c = np.concatenate([[0.0], np.cumsum(residual)])
    mean = (c[span:] - c[:-span]) / span
    return float(np.sqrt(np.mean(mean ** 2)))


def allowed_misfit(noise_rel: float, limits: MisfitLimits) -> float:
    """The relative RMS misfit allowed at a noise-and-gain level ``noise_rel``."""
    return max(limits.model_rel, limits.noise_factor * noise_rel)


def judge_misfit(entries: list[MisfitEntry] | tuple[MisfitEntry, ...], limits: MisfitLimits,
                 simulated: Response | None = None) -> ModelMisfit:
    """Whether and why the check fires on ``entries`` (their allowances taken from
    ``limits``), and what kind of misfit it is (see the module documentation)."""
    entries = tuple(MisfitEntry(e.level, e.quantity, e.misfit,
                                allowed_misfit(e.noise_rel, limits), e.systematic, e.noise_rel,
                                e.offset)
                    for e in entries)
    offsets = [e for e in entries if not math.isfinite(e.offset) or (
        e.offset > limits.offset_rel and (
            e.offset > limits.offset_share * e.misfit
            or e.offset > limits.offset_contrast * max(
                (o.offset for o in entries if o.level != e.level and math.isfinite(o.offset)),
                default=0.0)))]
    bad = [e for e in entries if e.exceeded]
    if offsets:  # a lasting mean in a relative acceleration: no structure does that
        reasons = tuple(
            f"suspect sensor at level {e.level}: the measured {e.quantity} has a lasting "
            f"offset from the identified model's, {e.offset:.0%} of its RMS over "
            f"{limits.offset_span_s:g} s (allowed {limits.offset_rel:.0%}; misfit "
            f"{e.misfit:.0%} RMS)" for e in offsets)
        return ModelMisfit(entries=entries, kind="sensor", reasons=reasons,
                           simulated=simulated)
    if not bad:
        return ModelMisfit(entries=entries, simulated=simulated)
    levels = {e.level for e in bad}
    # a misfit at one level is a sensor's only where enough levels are measured for a
    # model's error to show elsewhere as well
    measured = {e.level for e in entries if e.quantity == _NAMES["a"]}
    sensor = (len(levels) == 1 and len(measured) >= limits.sensor_min_levels
              and all(e.systematic < limits.systematic for e in bad))
    reasons = []
    for e in bad:
        what = (f"level {e.level}: the identified model's {e.quantity} departs from the "
                f"measured by {e.misfit:.0%} RMS (allowed {e.allowed:.0%}; "
                f"{e.systematic:.0%} of it follows the response)")
        reasons.append(f"suspect sensor at {what}" if sensor else f"model misfit: {what}")
    return ModelMisfit(entries=entries, kind="sensor" if sensor else "model",
                       reasons=tuple(reasons), simulated=simulated)


def energy_indices(window: MeasuredWindow, params: SpringParameters, theta: np.ndarray,
                   a_rel: np.ndarray) -> np.ndarray:
    """Hysteretic energy of every section's moment–rotation loop, normalised; shape (N,).

    ``E_h = ∫ M dθ − M(T)² / (2 k1)``: the work of the restoring moment over the window
    less what the spring still stores at its end (the elastic part), with the restoring
    moment ``M = g − c θ̇`` the moment the inertia forces give
    (:func:`~pier_monitor.core.identify.equation_error.inertia_moments`) less the identified
    damper's (the viscous part).  The index is ``E_h / (½ max|M| max|θ|)``, the hysteretic
    energy in units of the elastic energy at the peak: about 0 for an elastic section
    (what damping errors and noise leave), several for a section that yielded, whatever the
    spring family.

    Parameters
    ----------
    window : MeasuredWindow
        The window (geometry, ``ag`` m/s², ``dt``).
    params : SpringParameters
        Identified ``k1`` (N·m/rad) and ``c`` (N·m·s/rad) are used.
    theta : ndarray, shape (T, N)
        Spring angles the identification reproduces, rad.
    a_rel : ndarray, shape (T, N)
        Relative accelerations, m/s²: measured where measured, reproduced elsewhere.

    Returns
    -------
    ndarray, shape (N,)
        Energy index per section (NaN where the section did not move).
    """
    n = window.n_levels
    theta = np.asarray(theta, dtype=float)
    a_rel = np.asarray(a_rel, dtype=float)
    for name, arr in (("theta", theta), ("a_rel", a_rel)):
        if arr.shape != (window.t.size, n) or not np.all(np.isfinite(arr)):
            raise InputDataError(f"energy index {name}: expected finite values of shape "
                                 f"({window.t.size}, {n}), got {arr.shape}")
    g = inertia_moments(window.geometry, a_rel, np.asarray(window.ag))
    moment = g - np.gradient(theta, window.dt, axis=0) * np.asarray(params.c)
    work = np.sum(0.5 * (moment[1:] + moment[:-1]) * np.diff(theta, axis=0), axis=0)
    stored = moment[-1] ** 2 / (2.0 * np.asarray(params.k1))
    peak = 0.5 * np.max(np.abs(moment), axis=0) * np.max(np.abs(theta), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(peak > 0, (work - stored) / peak, np.nan)


def section_evidence(misfit: ModelMisfit, energy: np.ndarray, *,
                     energy_large: float = ENERGY_INDEX_LARGE,
                     energy_misfit: float = ENERGY_INDEX_MISFIT) -> list[tuple[str, ...]]:
    """The reasons that make each section at least suspicious (rules 5-6 of
    :mod:`~pier_monitor.core.identify.damage`), one tuple per section (N of them).

    * energy index >= ``energy_large``: a large dissipated energy, whatever the misfit;
    * with a model misfit (``misfit.kind == "model"``): energy index >= ``energy_misfit``, or
      the nearest measured level at or above the section (level ``n`` for section ``n`` when
      it is measured; in a sparse layout the next measured one up, whose motion the section
      carries) misfits beyond its allowance: ``model misfit: ...`` with the size.
    """
    energy = np.asarray(energy, dtype=float)
    out: list[tuple[str, ...]] = []
    exceeded = {e.level: e for e in misfit.entries if e.exceeded}
    measured = sorted({e.level for e in misfit.entries})
    worst = misfit.worst
    size = ("" if worst is None else
            f"{worst.misfit:.0%} RMS at level {worst.level} ({worst.quantity}, allowed "
            f"{worst.allowed:.0%})")
    for i, e in enumerate(energy):
        reasons = []
        large = math.isfinite(e) and e >= energy_large
        if large:
            reasons.append(f"hysteretic energy {e:.2f} times the elastic energy at the peak "
                           f"(at least {energy_large:g}): the section dissipated energy")
        if misfit.kind == "model":
            above = next((lv for lv in measured if lv >= i + 1), None)
            here = None if above is None else exceeded.get(above)
            if here is not None:
                reasons.append(f"model misfit: the identified model departs from level "
                               f"{here.level}'s {here.quantity} by {here.misfit:.0%} RMS "
                               f"(allowed {here.allowed:.0%})")
            elif math.isfinite(e) and e >= energy_misfit and not large:
                reasons.append(f"model misfit ({size}) and hysteretic energy {e:.2f} times "
                               f"the elastic energy at the peak")
            elif not misfit.entries:
                reasons.extend(misfit.reasons)
        out.append(tuple(reasons))
    return out


@dataclass(frozen=True)
class SelfCheck:
    """The output-error self-check of one identification.

    Attributes
    ----------
    misfit : ModelMisfit
        The identified model against the measured responses.
    energy_index : ndarray, shape (N,)
        Energy index per section (:func:`energy_indices`).
    evidence : tuple of tuple of str
        Per section, the reasons that make it at least suspicious (:func:`section_evidence`).
    unreliable_reasons : tuple of str
        The reasons that make the result unreliable (a sensor's misfit; empty otherwise).
    """

    misfit: ModelMisfit
    energy_index: np.ndarray
    evidence: tuple[tuple[str, ...], ...]
    unreliable_reasons: tuple[str, ...]


def self_check(window: MeasuredWindow, params: SpringParameters, theta: np.ndarray,
               a_rel: np.ndarray, limits: MisfitLimits | None = None) -> SelfCheck:
    """Run the output-error check and the energy indices of one identification.

    Parameters
    ----------
    window : MeasuredWindow
        The measured window.
    params : SpringParameters
        The identified parameters (point estimate).
    theta : ndarray, shape (T, N)
        Spring angles the identification reproduces, rad.
    a_rel : ndarray, shape (T, N)
        Relative accelerations the identification reproduces, m/s²; the measured ones are
        used where ``window.coverage.acceleration``.

    Returns
    -------
    SelfCheck
    """
    misfit = model_misfit(window, params, limits)
    a = np.where(window.coverage.acceleration, window.a, np.asarray(a_rel, dtype=float))
    try:
        energy = energy_indices(window, params, theta, a)
    except InputDataError:
        energy = np.full(window.n_levels, np.nan)
    unreliable = misfit.reasons if misfit.kind == "sensor" else ()
    return SelfCheck(misfit=misfit, energy_index=energy,
                     evidence=tuple(section_evidence(misfit, energy)),
                     unreliable_reasons=tuple(unreliable))
