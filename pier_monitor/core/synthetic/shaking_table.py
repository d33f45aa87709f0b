"""Seeded synthetic shaking-table recordings of a pier, with their ground truth (SPEC §6).

:func:`generate_recording` plays an E-Defense-style test: a long, continuous 3-D recording of
every sensor in a pier configuration's sensor map, with quiet (ambient) stretches before,
between and after several table runs of increasing damage on the same pier.  Each run has
its own dynamic parameters (the pier weakens from run to run; the deck may be made heavier)
and its own table motion.

Physics of one run
    The link model (SPEC §3) is integrated in the principal direction with
    :func:`~pier_monitor.core.model.solver.simulate` (internal step 1 ms, output at the sensors'
    rate; with ``hysteresis`` ``takeda`` or ``bwbn`` the RC test-bed's
    :func:`~pier_monitor.core.synthetic.rc.integrate_rc` instead) under the principal component of the table acceleration, a
    :func:`~pier_monitor.core.model.ground_motion.synthetic_near_fault` record.  The table also
    moves transversely (a weaker record of its own) and vertically (a higher-frequency
    record); the transverse response is the same link model kept elastic, the pier is rigid
    vertically.  The table idles with a small broadband noise all the time.  Parameters switch
    from one run to the next in the middle of the quiet stretch between them (when weights
    are added and the pier is inspected); a later run starts at rest about the residual
    (permanent) displacement left by the earlier ones, which the displacement transducers keep
    seeing.

Measurement
    Every sensor records, per the configuration's measurement model
    ``recorded_j = gain * signs_j * (u · e_j) / unit_factor + offsets_j + noise``
    (:class:`~pier_monitor.core.model.config.SensorSpec`), the true 3-D motion ``u`` at its level:
    accelerometers the absolute acceleration (foundation: the table's), velocity meters the
    absolute velocity, displacement transducers (and a differential GNSS) the displacement
    relative to the table (a frame fixed to it, or the reference receiver).  The offsets of
    the configuration are the channels' biases (for a DC-coupled vertical accelerometer they
    include gravity); the noise is white Gaussian with the sensor's ``noise_rms``.  Each
    sensor samples at its own rate (``rate_hz`` of the map, else the pier's), on a grid
    from the start of the recording.  Optionally the true sensors differ from the nominal
    ones (gain, orientation, tilt, bias: :class:`~pier_monitor.core.synthetic.measurement.
    SensorImperfections`) and every sensor low-passes its signal before sampling it (anti-
    aliasing); see :mod:`pier_monitor.core.synthetic.measurement`.

Everything random derives from one seed: the same configuration, scenario and seed give
bit-identical recordings.
"""

from __future__ import annotations

import dataclasses

import json
import re
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
from scipy import signal

from pier_monitor.core.model.config import PierConfig, PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.fileio import to_strict_json
from pier_monitor.core.identify.damage import ductility_factors
from pier_monitor.core.model.ground_motion import el_centro_1940, synthetic_near_fault
from pier_monitor.core.model.link_model import angle_matrix, natural_periods
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord, sample_times_ns
from pier_monitor.core.model.solver import Response, simulate
from pier_monitor.core.synthetic.rc import (HYSTERESIS_FAMILIES, RCSectionTruth, RCSprings,
                                            RCState, integrate_rc, rc_springs_from_design,
                                            rc_truth, stiffness_periods)
from pier_monitor.core.synthetic.measurement import (ANTI_ALIAS_CUTOFF_FRACTION, ANTI_ALIAS_ORDER,
                                                     SensorError, SensorImperfections,
                                                     anti_alias_filter, draw_sensor_errors,
                                                     record_sensor)

__all__ = [
    "DEFAULT_START_NS",
    "DEFAULT_PRINCIPAL_DIRECTION_DEG",
    "RC_EDEFENSE_PGA_MPS2",
    "RunSpec",
    "Scenario",
    "RunTruth",
    "SyntheticTruth",
    "SyntheticRecording",
    "edefense_scenario",
    "generate_recording",
    "save_truth",
    "load_truth",
]

#: Default start of a synthetic recording: 2024-03-12T01:00:00Z, ns since the Unix epoch.
DEFAULT_START_NS = 1_710_205_200 * NS_PER_S
#: Shaking direction used when the configuration leaves ``principal_direction_deg`` open.
DEFAULT_PRINCIPAL_DIRECTION_DEG = 196.0

_INTERNAL_DT_S = 0.001  # SPEC §3: Newmark internal step
#: ``principal_response(ag, dt) -> (x, v, a)`` of :func:`generate_recording`.
PrincipalResponse = Callable[[np.ndarray, float], tuple[np.ndarray, np.ndarray, np.ndarray]]
#: Table PGAs (m/s²) of the two runs of :func:`edefense_scenario` with RC springs, by family.
RC_EDEFENSE_PGA_MPS2 = {"takeda": (3.7, 5.5), "bwbn": (5.5, 6.0)}
_RESPONSE_KEYS = ("t", "ag", "x", "v", "a", "theta", "moment")
_TABLE_KEYS = ("table_velocity", "ag_transverse", "ag_vertical")


@dataclass(frozen=True)
class RunSpec:
    """One table run (shaking) of a scenario.

    Parameter factors multiply the configuration's design values section by section
    (bottom to top); an empty tuple means all ones.  ``k2_factors`` defaults to
    ``k1_factors`` (the ratio k2/k1 of the design is kept), ``c_factors`` to all ones.

    Attributes
    ----------
    name : str
        Label of the run, e.g. ``"run1"``.
    pga_mps2 : float
        Peak table acceleration in the principal direction, m/s².
    duration_s : float
        Length of the table record, s.
    strong_start_s, strong_duration_s : float
        Onset (from the start of the record) and length of the strong motion, s.
    pulse_period_s : float
        Period of the near-fault velocity pulse of the principal component, s.
    transverse_ratio, vertical_ratio : float
        PGA of the transverse and vertical table components relative to ``pga_mps2``.
    k1_factors, k2_factors, fy_factors, c_factors : tuple of float
        True parameters of the run relative to the design values.
    added_top_mass_kg : float
        Mass added at the top level for this run (extra deck weights), kg.
    motion_seed : int or None
        Seed of the principal record (the transverse and vertical records' seeds derive from
        it); ``None`` derives all three from the seed of :func:`generate_recording`.
    record : {"synthetic", "el_centro_1940"}
        Principal component: the seeded synthetic near-fault record, or the 1940 El Centro NS
        record shipped with the package (scaled to ``pga_mps2``, cut or padded with zeros to
        ``duration_s``; the strong-motion and pulse fields are then unused).
    """

    name: str
    pga_mps2: float
    duration_s: float = 40.0
    strong_start_s: float = 10.0
    strong_duration_s: float = 8.0
    pulse_period_s: float = 1.2
    transverse_ratio: float = 0.2
    vertical_ratio: float = 0.3
    k1_factors: tuple[float, ...] = ()
    k2_factors: tuple[float, ...] = ()
    fy_factors: tuple[float, ...] = ()
    c_factors: tuple[float, ...] = ()
    added_top_mass_kg: float = 0.0
    motion_seed: int | None = None
    record: str = "synthetic"

    def _factors(self, name: str, n: int, default: tuple[float, ...] = ()) -> np.ndarray:
        values = getattr(self, name) or default
        if not values:
            return np.ones(n)
        arr = np.asarray(values, dtype=float)
        if arr.shape != (n,) or not np.all(np.isfinite(arr) & (arr > 0)):
            raise InputDataError(f"run {self.name}: {name}: expected {n} positive factors (one "
                                 f"per section), got {list(values)}")
        return arr

    def parameters(self, design: SpringParameters) -> SpringParameters:
        """The run's true spring parameters from the design values."""
        n = design.n_springs
        k1f = self._factors("k1_factors", n)
        return SpringParameters(design.k1 * k1f,
                                design.k2 * self._factors("k2_factors", n, tuple(k1f)),
                                design.fy * self._factors("fy_factors", n),
                                design.c * self._factors("c_factors", n))

    def geometry(self, design: PierGeometry) -> PierGeometry:
        """The run's geometry: the design one with ``added_top_mass_kg`` at the top level."""
        if not (np.isfinite(self.added_top_mass_kg) and self.added_top_mass_kg >= 0):
            raise InputDataError(f"run {self.name}: added_top_mass_kg: expected a non-negative "
                                 f"mass, got {self.added_top_mass_kg}")
        masses = np.array(design.masses_kg)
        masses[-1] += self.added_top_mass_kg
        return PierGeometry(design.section_heights_m, masses)


@dataclass(frozen=True)
class Scenario:
    """A shaking-table test: runs separated by quiet stretches, on one continuous recording.

    Attributes
    ----------
    runs : tuple of RunSpec
        The runs, in the order they are played.
    lead_s, gap_s, tail_s : float
        Quiet recording before the first run, between runs, and after the last run, s.
    start_ns : int
        Time of the first sample, ns since the Unix epoch.
    ambient_rms_mps2 : float
        RMS of the table's idle motion (band 0.5-20 Hz), per direction, m/s².
    window_pre_s, window_post_s : float
        Padding of the reference mainshock window before the 5 % and after the 95 % point of
        the run's Arias intensity (principal direction), s.
    """

    runs: tuple[RunSpec, ...]
    lead_s: float = 20.0
    gap_s: float = 30.0
    tail_s: float = 20.0
    start_ns: int = DEFAULT_START_NS
    ambient_rms_mps2: float = 2e-3
    window_pre_s: float = 2.0
    window_post_s: float = 8.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "runs", tuple(self.runs))
        if not self.runs:
            raise InputDataError("scenario: expected at least one run")
        names = [r.name for r in self.runs]
        if len(set(names)) != len(names):
            raise InputDataError(f"scenario: run names must be distinct, got {names}")
        for name in ("lead_s", "gap_s", "tail_s", "ambient_rms_mps2", "window_pre_s",
                     "window_post_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise InputDataError(f"scenario: {name}: expected a non-negative number, "
                                     f"got {value}")
        for run in self.runs:
            for name in ("pga_mps2", "duration_s", "strong_duration_s", "pulse_period_s"):
                value = getattr(run, name)
                if not (np.isfinite(value) and value > 0):
                    raise InputDataError(f"run {run.name}: {name}: expected a positive number, "
                                         f"got {value}")
            if not (np.isfinite(run.strong_start_s) and 0 <= run.strong_start_s < run.duration_s):
                raise InputDataError(f"run {run.name}: strong_start_s: expected 0 <= value < "
                                     f"duration_s={run.duration_s}, got {run.strong_start_s}")
            for name in ("transverse_ratio", "vertical_ratio"):
                value = getattr(run, name)
                if not (np.isfinite(value) and value >= 0):
                    raise InputDataError(f"run {run.name}: {name}: expected a non-negative "
                                         f"number, got {value}")

    def as_dict(self) -> dict[str, Any]:
        """Plain form, for JSON."""
        out = asdict(self)
        out["runs"] = [asdict(r) for r in self.runs]
        return out


def edefense_scenario(*, record_s: float = 40.0, lead_s: float = 20.0, gap_s: float = 30.0,
                      tail_s: float = 20.0, start_ns: int = DEFAULT_START_NS,
                      motion_seeds: tuple[int, int] | None = (1994, 1995),
                      hysteresis: str = "bilinear") -> Scenario:
    """The default two-run test of ``config/edefense_like.yaml`` (paper section 7).

    Run 1: the as-built pier (k1 within ±5 % of design at 0-6 m, the top section about 20 %
    softer: bearings and deck) under a near-fault record of PGA 3.5 m/s²; the bottom
    section yields moderately.  Run 2: the pier weakened by run 1 (k1 of sections 1-2 down by
    13 %, their yield moments by 11-22 %, less damping there; sections 3-4 as in run 1) with
    17 % more deck mass
    (+52 t) under a stronger record (PGA 5.5 m/s²); sections 1-2 yield heavily, 3-4 stay
    elastic.

    The table records are fixed by ``motion_seeds`` (like a laboratory replaying its chosen
    input waves), so that the damage pattern is the documented one whatever the seed of
    :func:`generate_recording`, which then varies the ambient motion and the sensor noise.
    With the defaults the ductility factors are about 1.65, 0.96, 0.86, 0.57 (run 1) and
    4.4, 3.9, 0.92, 0.61 (run 2); first periods 1.02 s and 1.17 s.  ``motion_seeds=None`` derives the records from the seed
    of :func:`generate_recording` instead (other waves, other damage).

    Parameters
    ----------
    record_s : float
        Length of each table record, s; the strong motion starts 10 s into it.
    lead_s, gap_s, tail_s : float
        Quiet stretches before, between and after the runs, s.
    start_ns : int
        Time of the first sample, ns since the Unix epoch.
    motion_seeds : tuple of two int, or None
        Seeds of the two runs' table records; ``None``: derived from the generator's seed.
    hysteresis : str
        ``bilinear``: the runs above.  An RC family (:mod:`~pier_monitor.core.synthetic.rc`):
        the same records scaled to :data:`RC_EDEFENSE_PGA_MPS2`, chosen so that run 1 just
        yields the base of the RC pier and run 2 damages it heavily (see that module).
    """
    if hysteresis not in HYSTERESIS_FAMILIES:
        raise InputDataError(f"hysteresis: expected one of {list(HYSTERESIS_FAMILIES)}, got "
                             f"{hysteresis!r}")
    pga = (3.5, 5.5) if hysteresis == "bilinear" else RC_EDEFENSE_PGA_MPS2[hysteresis]
    seeds = (None, None) if motion_seeds is None else tuple(int(s) for s in motion_seeds)
    if len(seeds) != 2:
        raise InputDataError(f"motion_seeds: expected two seeds (one per run), got {motion_seeds}")
    runs = (
        RunSpec("run1", pga_mps2=pga[0], duration_s=record_s,
                k1_factors=(1.0, 0.95, 1.05, 0.8), fy_factors=(1.05, 1.0, 1.0, 1.0),
                motion_seed=seeds[0]),
        RunSpec("run2", pga_mps2=pga[1], duration_s=record_s,
                k1_factors=(0.87, 0.83, 1.05, 0.8), fy_factors=(0.89, 0.78, 1.0, 1.0),
                c_factors=(0.75, 0.75, 1.0, 1.0), added_top_mass_kg=52_000.0,
                motion_seed=seeds[1]),
    )
    return Scenario(runs=runs, lead_s=lead_s, gap_s=gap_s, tail_s=tail_s, start_ns=start_ns)


@dataclass(frozen=True, eq=False)
class RunTruth:
    """Ground truth of one run.

    Times are ns since the Unix epoch; intervals are half-open ``[start, end)`` on the
    sample grid.  Responses are relative to the foundation, in the principal direction, SI,
    sampled at the recording's rate; ``response.t`` counts seconds from ``start_ns``.

    Attributes
    ----------
    name : str
        Run label.
    start_ns, end_ns : int
        The table record of the run.
    window_start_ns, window_end_ns : int
        Reference mainshock window: from ``window_pre_s`` before the 5 % point to
        ``window_post_s`` after the 95 % point of the Arias intensity of the principal table
        acceleration, within the record.
    params : SpringParameters
        True spring parameters of the run.
    geometry : PierGeometry
        True heights and masses of the run.
    principal_direction_deg : float
        Azimuth of the principal (shaking) direction in the pier frame, deg.
    response : Response
        True relative responses of the link model over the record, shape (T, N) each.
    table_velocity : ndarray, shape (T,)
        Table (foundation) velocity in the principal direction, m/s.
    ag_transverse, ag_vertical : ndarray, shape (T,)
        Table acceleration across the principal direction (azimuth + 90°) and vertically, m/s².
    initial_offset_m : ndarray, shape (N,)
        Residual displacement left by earlier runs, principal direction, m: the displacement
        transducers record ``initial_offset_m + response.x``.
    ductility_factors : ndarray, shape (N,)
        ``max |θ_n| / θy_n`` over the record.
    periods_s : ndarray, shape (N,)
        Elastic natural periods of the run's pier, longest first, s (RC springs: those of
        the small-amplitude stiffnesses at the start of the run).
    pga_mps2 : float
        Peak principal table acceleration over the record (idle motion included), m/s².
    motion_seeds : tuple of int
        Seeds of the principal, transverse and vertical records.
    rc : RCSectionTruth or None
        With RC springs (``hysteresis`` other than ``bilinear``): the per-section truth an
        engineer compares with (:mod:`~pier_monitor.core.synthetic.rc`); then
        ``ductility_factors`` are its idealised ductility factors, ``periods_s`` those of its
        small-amplitude stiffnesses at the start, ``params`` the as-built
        bilinear design the springs derive from, ``response.theta`` the springs' true angles
        (``B (initial_offset_m + response.x)``: they include the residual rotation).
    rc_springs : RCSprings or None
        The RC springs of the run.
    rayleigh : tuple of float or None
        ``(a0, a1)`` of the Rayleigh damping matrix ``a0 M + a1 K0`` of an RC run, 1/s and s.
    """

    name: str
    start_ns: int
    end_ns: int
    window_start_ns: int
    window_end_ns: int
    params: SpringParameters
    geometry: PierGeometry
    principal_direction_deg: float
    response: Response
    table_velocity: np.ndarray
    ag_transverse: np.ndarray
    ag_vertical: np.ndarray
    initial_offset_m: np.ndarray
    ductility_factors: np.ndarray
    periods_s: np.ndarray
    pga_mps2: float
    motion_seeds: tuple[int, int, int]
    rc: RCSectionTruth | None = None
    rc_springs: RCSprings | None = None
    rayleigh: tuple[float, float] | None = None

    @property
    def window_response(self) -> Response:
        """:attr:`response` restricted to the reference mainshock window."""
        t0 = (self.window_start_ns - self.start_ns) / NS_PER_S
        t1 = (self.window_end_ns - self.start_ns) / NS_PER_S
        return self.response.window(t0, t1)

    def summary(self) -> dict[str, Any]:
        """JSON-ready description (parameters, geometry, times, indices; no time series)."""
        return {
            "name": self.name,
            "start_ns": self.start_ns,
            "end_ns": self.end_ns,
            "window_start_ns": self.window_start_ns,
            "window_end_ns": self.window_end_ns,
            "duration_s": (self.end_ns - self.start_ns) / NS_PER_S,
            "window_duration_s": (self.window_end_ns - self.window_start_ns) / NS_PER_S,
            "principal_direction_deg": self.principal_direction_deg,
            "pga_mps2": self.pga_mps2,
            "motion_seeds": list(self.motion_seeds),
            "geometry": {"section_heights_m": self.geometry.section_heights_m.tolist(),
                         "masses_kg": self.geometry.masses_kg.tolist()},
            "params": {"k1_Nm_per_rad": self.params.k1.tolist(),
                       "k2_Nm_per_rad": self.params.k2.tolist(),
                       "fy_Nm": self.params.fy.tolist(),
                       "c_Nms_per_rad": self.params.c.tolist()},
            "yield_angles_rad": self.params.yield_angles.tolist(),
            "periods_s": self.periods_s.tolist(),
            "ductility_factors": self.ductility_factors.tolist(),
            "max_abs_displacement_m": np.max(np.abs(self.response.x), axis=0).tolist(),
            "residual_displacement_m": self.response.x[-1].tolist(),
            "initial_offset_m": self.initial_offset_m.tolist(),
            **({} if self.rc is None else {
                "rc": self.rc.as_dict(),
                "rc_small_amplitude_periods_s": {
                    "before": stiffness_periods(self.geometry, self.rc.k_small_before).tolist(),
                    "after": stiffness_periods(self.geometry, self.rc.k_small_after).tolist()},
                "rc_springs": self.rc_springs.as_dict(),  # type: ignore[union-attr]
                "rayleigh_a0_per_s_a1_s": list(self.rayleigh or ())}),
        }


@dataclass(frozen=True, eq=False)
class SyntheticTruth:
    """Ground truth of a synthetic recording.

    Attributes
    ----------
    seed : int
        Seed the recording was generated with.
    pier_id : str
        Pier of the configuration.
    principal_direction_deg : float
        Azimuth of the shaking direction in the pier frame, deg.
    sample_rate_hz : float
        The pier's rate: of the responses and of every sensor without a rate of its own, Hz.
    start_ns, end_ns : int
        First sample and one period (at ``sample_rate_hz``) past the last sample of the
        recording, ns.
    runs : tuple of RunTruth
        The runs, in order.
    noise_rms : dict of str to float
        Noise RMS of each sensor's channels, in the sensor's unit.
    scenario : Scenario
        The scenario that was played.
    imperfections : SensorImperfections or None
        Spread of the sensor errors, when the true sensors differed from the nominal ones.
    sensor_errors : dict of str to SensorError
        The errors actually drawn, by sensor id (empty without imperfections).
    anti_alias : bool
        Whether every sensor low-passed its signal before sampling it.
    hysteresis : str
        Spring family of the principal response: ``bilinear`` (the identifier's own model)
        or an RC family of :mod:`~pier_monitor.core.synthetic.rc`.
    """

    seed: int
    pier_id: str
    principal_direction_deg: float
    sample_rate_hz: float
    start_ns: int
    end_ns: int
    runs: tuple[RunTruth, ...]
    noise_rms: Mapping[str, float]
    scenario: Scenario
    imperfections: SensorImperfections | None = None
    sensor_errors: Mapping[str, SensorError] = dataclasses.field(default_factory=dict)
    anti_alias: bool = False
    hysteresis: str = "bilinear"

    def run(self, name: str) -> RunTruth:
        """The run with this name; :class:`InputDataError` if there is none."""
        for r in self.runs:
            if r.name == name:
                return r
        raise InputDataError(f"no run {name!r}; runs are {[r.name for r in self.runs]}")


@dataclass(frozen=True, eq=False)
class SyntheticRecording:
    """A synthetic recording and its ground truth."""

    recording: Recording
    truth: SyntheticTruth


# ---------------------------------------------------------------------------------------------
# generation


def _child_seed(seq: np.random.SeedSequence) -> int:
    return int(seq.generate_state(1, dtype=np.uint32)[0])


def _ambient(rng: np.random.Generator, n: int, rate_hz: float, rms: float) -> np.ndarray:
    """Band-limited (0.5-20 Hz) Gaussian idle motion of the table, shape (n, 3), m/s²."""
    if rms == 0 or n < 2:
        return np.zeros((n, 3))
    high = min(20.0, 0.45 * rate_hz)
    sos = signal.butter(4, [0.5, high], btype="bandpass", fs=rate_hz, output="sos")
    noise = signal.sosfiltfilt(sos, rng.standard_normal((n, 3)), axis=0)
    return noise * (rms / np.sqrt(np.mean(noise ** 2, axis=0)))


def _zero_final_velocity(acc: np.ndarray, dt: float) -> np.ndarray:
    """Baseline-correct a record so that its trapezoidal integral (final velocity) is zero."""
    v_end = np.trapezoid(acc, dx=dt)
    w = np.sin(np.linspace(0.0, np.pi, acc.size)) ** 2
    return acc - v_end * w / np.trapezoid(w, dx=dt)


def _integrate(acc: np.ndarray, dt: float) -> np.ndarray:
    """Cumulative trapezoidal integral from 0, along axis 0."""
    out = np.zeros_like(acc)
    out[1:] = np.cumsum(0.5 * (acc[1:] + acc[:-1]) * dt, axis=0)
    return out


#: Principal records a run can play (:attr:`RunSpec.record`).
RECORDS = ("synthetic", "el_centro_1940")


def _principal_record(run: RunSpec, dt: float, seed: int, kwargs: dict) -> np.ndarray:
    """The principal table record of ``run`` at step ``dt``, m/s²."""
    if run.record == "synthetic":
        return synthetic_near_fault(pga_mps2=run.pga_mps2, pulse_period_s=run.pulse_period_s,
                                    seed=seed, **kwargs).acc
    if run.record == "el_centro_1940":
        acc = el_centro_1940().resampled(dt).scaled_to_pga(run.pga_mps2).acc
        n = int(round(run.duration_s / dt)) + 1
        return np.pad(acc[:n], (0, max(0, n - acc.size)))
    raise InputDataError(f"run {run.name}: record: expected one of {list(RECORDS)}, got "
                         f"{run.record!r}")


def _table_records(run: RunSpec, rate_hz: float,
                   seeds: tuple[int, int, int]) -> tuple[np.ndarray, ...]:
    dt = 1.0 / rate_hz
    kwargs = dict(duration_s=run.duration_s, dt=dt, strong_start_s=run.strong_start_s,
                  strong_duration_s=run.strong_duration_s)
    p = _principal_record(run, dt, seeds[0], kwargs)
    comps = [_zero_final_velocity(p, dt)]
    for ratio, seed, extra in ((run.transverse_ratio, seeds[1],
                                dict(pulse_share=0.15, pulse_period_s=0.8 * run.pulse_period_s)),
                               (run.vertical_ratio, seeds[2],
                                dict(pulse_share=0.0, dominant_hz=6.0))):
        if ratio == 0:
            comps.append(np.zeros_like(p))
        else:
            rec = synthetic_near_fault(pga_mps2=ratio * run.pga_mps2, seed=seed, **extra,
                                       **kwargs).acc
            comps.append(_zero_final_velocity(rec, dt))
    return tuple(comps)


def _arias_window(ag: np.ndarray, rate_hz: float, pre_s: float,
                  post_s: float) -> tuple[int, int]:
    """Sample range ``[i0, i1)`` from ``pre_s`` before 5 % to ``post_s`` after 95 % Arias."""
    energy = np.cumsum(ag ** 2)
    total = energy[-1]
    i5 = int(np.searchsorted(energy, 0.05 * total))
    i95 = int(np.searchsorted(energy, 0.95 * total))
    i0 = max(0, i5 - int(round(pre_s * rate_hz)))
    i1 = min(ag.size, i95 + int(round(post_s * rate_hz)) + 1)
    return i0, i1


def _elastic(params: SpringParameters) -> SpringParameters:
    """The same springs with yield moments so high that they never yield."""
    return SpringParameters(params.k1, params.k2, params.fy * 1e6, params.c)


def _upsample_linear(x: np.ndarray, factor: int) -> np.ndarray:
    """Linear interpolation of (S, C) samples to ``factor`` times the rate, (S·factor, C).

    The original samples are kept exactly; after the last one the value is held.
    """
    if factor == 1:
        return x
    following = np.concatenate([x[1:], x[-1:]])
    frac = np.arange(factor) / factor
    return (x[:, None, :] + (following - x)[:, None, :] * frac[None, :, None]).reshape(
        -1, x.shape[1])


def _timeline(scenario: Scenario, rate: float, run_seqs: list[np.random.SeedSequence]
              ) -> tuple[list[tuple[tuple[int, int, int], tuple[np.ndarray, ...]]], list[int],
                         int, int]:
    """Table records of the runs, their first samples, the total and the gap in samples."""
    n_lead = int(round(scenario.lead_s * rate))
    n_gap = int(round(scenario.gap_s * rate))
    n_tail = int(round(scenario.tail_s * rate))
    records = []
    starts = []
    cursor = n_lead
    for run, seq in zip(scenario.runs, run_seqs):
        if run.motion_seed is None:
            seeds = tuple(_child_seed(s) for s in seq.spawn(3))
        else:  # transverse and vertical records get seeds of their own, derived from it
            seeds = (int(run.motion_seed),
                     *(_child_seed(np.random.SeedSequence([int(run.motion_seed), k]))
                       for k in (1, 2)))
        comps = _table_records(run, rate, seeds)  # principal, transverse, vertical
        records.append((seeds, comps))
        starts.append(cursor)
        cursor += comps[0].size + n_gap
    return records, starts, cursor - n_gap + n_tail, n_gap


def _motion_vectors(principal_direction_deg: float, table: np.ndarray, table_vel: np.ndarray,
                    rel: Mapping[str, np.ndarray]) -> Callable[[str, int], np.ndarray]:
    """A function ``(kind, level) -> (T, 3)``: the true motion of a level, pier frame, SI.

    Accelerometers sense the absolute acceleration, velocity meters the absolute velocity,
    displacement sensors the displacement relative to the foundation.  Computed once per
    (kind, level) when first asked for.
    """
    phi = np.radians(principal_direction_deg)
    e_p = np.array([np.cos(phi), np.sin(phi), 0.0])
    e_t = np.array([-np.sin(phi), np.cos(phi), 0.0])
    e_z = np.array([0.0, 0.0, 1.0])
    zeros = np.zeros((table.shape[0], 1))
    cache: dict[tuple[str, int], np.ndarray] = {}

    def vector(p: np.ndarray, t: np.ndarray, z: np.ndarray | None) -> np.ndarray:
        """(T, 3) from principal, transverse and vertical components of shape (T, 1)."""
        out = p * e_p + t * e_t
        return out if z is None else out + z * e_z

    def motion(kind: str, level: int) -> np.ndarray:
        if (kind, level) not in cache:
            # relative motion of the level (the foundation has none)
            r = {k: rel[k][:, level - 1:level] if level else zeros for k in rel}
            if kind == "acceleration":
                out = vector(table[:, 0:1] + r["ap"], table[:, 1:2] + r["at"], table[:, 2:3])
            elif kind == "velocity":
                out = vector(table_vel[:, 0:1] + r["vp"], table_vel[:, 1:2] + r["vt"],
                             table_vel[:, 2:3])
            else:
                out = vector(r["xp"], r["xt"], None)
            cache[kind, level] = out
        return cache[kind, level]

    return motion


def generate_recording(config: PierConfig, scenario: Scenario | None = None, *, seed: int = 0,
                       principal_direction_deg: float | None = None,
                       imperfections: SensorImperfections | None = None,
                       anti_alias: bool = False, hysteresis: str = "bilinear",
                       rayleigh_zeta: float = 0.03,
                       principal_response: PrincipalResponse | None = None
                       ) -> SyntheticRecording:
    """Simulate a shaking-table test of the pier and record it with its sensor map.

    Parameters
    ----------
    config : PierConfig
        The pier: geometry and design parameters (scaled per run by the scenario) and the
        sensor map (levels, kinds, units, axes, orientations, signs, gains, offsets,
        noise levels, rates); ``sample_rate_hz`` is the rate of the responses and of every
        sensor without a ``rate_hz`` of its own; its period must be a whole number of
        milliseconds (the solver's internal step).
    scenario : Scenario, optional
        Runs and quiet stretches; default :func:`edefense_scenario`.
    seed : int
        Seed of everything random (ambient motion, table records without a fixed
        ``motion_seed``, sensor noise, sensor errors unless ``imperfections.seed`` is set).
    principal_direction_deg : float, optional
        Azimuth of the shaking direction, deg; default the configuration's, else 196°.
    imperfections : SensorImperfections, optional
        Record with true sensors that differ from the nominal ones of the configuration
        (gain, orientation, tilt, bias); the recording keeps the nominal configuration and
        the truth holds the errors drawn.  Default: the sensors are exactly the nominal ones.
    anti_alias : bool
        Low-pass every sensor's signal at 0.4 × its rate on the simulation's 1 ms signal
        before sampling it (:func:`~pier_monitor.core.synthetic.measurement.anti_alias_filter`).
        Default: sample the signal as it is.
    hysteresis : {"bilinear", "takeda", "bwbn"}
        Springs of the principal response.  ``bilinear``: the link model the identifier
        assumes (:func:`~pier_monitor.core.model.solver.simulate`, per-spring dampers).
        ``takeda``, ``bwbn``: the RC test-bed
        (:func:`~pier_monitor.core.synthetic.rc.integrate_rc`): modified-Takeda or
        Bouc–Wen–Baber–Noori springs derived from the first run's parameters
        (:func:`~pier_monitor.core.synthetic.rc.rc_springs_from_design`) and Rayleigh
        damping; the springs' state (cracks, yielding, strength loss) and the displacements
        carry from one run to the next, so the later runs' k1/k2/fy/c factors are not used
        (their added mass is).  The transverse response stays the elastic bilinear model.
    rayleigh_zeta : float
        Damping ratio of the Rayleigh matrix of RC springs (modes 1 and 2 of the uncracked
        pier).
    principal_response : callable, optional
        A structural model of its own for the principal response, e.g. the fiber-section
        column of :mod:`~pier_monitor.core.synthetic.fiber`: called once as
        ``principal_response(ag, dt)`` with the principal table acceleration of the whole
        recording (ambient motion, runs and gaps, shape (T,), m/s²) at the motion's step
        ``dt`` (1 ms with ``anti_alias``, else the pier's period), it returns the levels'
        displacements, velocities and accelerations relative to the foundation, shape (T, N)
        each.  The runs' parameter factors are then unused (the model carries its own
        damage from run to run), the runs' truths hold the configuration's design values as
        ``params``, ``ductility_factors`` of NaN (the model's owner has the truth) and the
        spring angles ``B x`` with zero moments; ``truth.hysteresis`` is ``"external"``.
        The transverse response stays the elastic link model.  Requires ``hysteresis``
        ``bilinear``.

    Returns
    -------
    SyntheticRecording
        Per-sensor samples (time_ns shape (T,), data shape (T, n_axes) in the sensor's unit,
        each sensor on its own grid from the start of the recording) and the ground truth.

    Raises
    ------
    InputDataError
        If the configuration has no sensors, or the scenario or rate cannot be simulated.
    """
    if hysteresis not in HYSTERESIS_FAMILIES:
        raise InputDataError(f"hysteresis: expected one of {list(HYSTERESIS_FAMILIES)}, got "
                             f"{hysteresis!r}")
    rc = hysteresis != "bilinear"
    if principal_response is not None and rc:
        raise InputDataError("principal_response replaces the springs: use it with "
                             "hysteresis 'bilinear'")
    if scenario is None:
        scenario = edefense_scenario(hysteresis=hysteresis)
    if not config.sensors:
        raise InputDataError(f"pier {config.pier_id}: the configuration has no sensor map; "
                             "nothing to record")
    if principal_direction_deg is None:
        principal_direction_deg = (config.principal_direction_deg
                                   if config.principal_direction_deg is not None
                                   else DEFAULT_PRINCIPAL_DIRECTION_DEG)
    if not np.isfinite(principal_direction_deg):
        raise InputDataError(f"principal_direction_deg: expected a finite angle, got "
                             f"{principal_direction_deg}")
    rate = float(config.sample_rate_hz)
    dt = 1.0 / rate
    steps = dt / _INTERNAL_DT_S
    if abs(steps - round(steps)) > 1e-9 or round(steps) < 1:
        raise InputDataError(f"sample_rate_hz: the sampling period 1/{rate:g} s must be a whole "
                             f"number of the solver's {_INTERNAL_DT_S * 1e3:g} ms steps")
    # the motion is simulated at the rate it is sampled from: the pier's, or 1 ms to filter it
    up = int(round(steps)) if anti_alias else 1
    motion_rate = rate * up
    dt_m = 1.0 / motion_rate
    n = config.n_levels

    # the runs' piers first: a bad factor fails before anything is simulated
    piers = [(run.geometry(config.geometry), run.parameters(config.design))
             for run in scenario.runs]
    springs: RCSprings | None = None
    rc_state: RCState | None = None
    if rc:  # one pier through every run: damage is the springs' state, not new parameters
        piers = [(geometry, piers[0][1]) for geometry, _ in piers]
        springs = rc_springs_from_design(piers[0][1], family=hysteresis)

    root = np.random.SeedSequence(seed)
    ambient_seq, noise_seq, *run_seqs = root.spawn(2 + len(scenario.runs))
    errors = ({} if imperfections is None
              else draw_sensor_errors(config, imperfections, root.spawn(1)[0]))

    records, starts, total, n_gap = _timeline(scenario, rate, run_seqs)

    # table acceleration in (principal, transverse, vertical) components, m/s²
    table = _ambient(np.random.default_rng(ambient_seq), total, rate, scenario.ambient_rms_mps2)
    for s0, (_, comps) in zip(starts, records):
        table[s0:s0 + comps[0].size] += np.stack(comps, axis=1)
    table_vel = _integrate(table, dt)
    table_m = _upsample_linear(table, up)
    table_vel_m = table_vel if up == 1 else _integrate(table_m, dt_m)

    # structural response, run by run, at the motion rate; parameters switch halfway through
    # each gap.  The next segment starts with the velocities the last one ended with (and,
    # elastic across the shaking, the transverse displacements): no jump in a velocity meter
    # at the switch.  Its springs start unloaded, the principal drift carried as an offset.
    bounds = [0] + [s - n_gap // 2 for s in starts[1:]] + [total]
    rel = {k: np.zeros((total * up, n)) for k in ("xp", "vp", "ap", "xt", "vt", "at")}
    offset = np.zeros(n)
    v_end, xt_end, vt_end = np.zeros(n), np.zeros(n), np.zeros(n)
    run_truths: list[RunTruth] = []
    times = sample_times_ns(scenario.start_ns, total, rate)
    external = None
    if principal_response is not None:  # one analysis over the whole recording
        external = tuple(np.asarray(arr, dtype=float) for arr in
                         principal_response(table_m[:, 0].copy(), dt_m))
        if any(arr.shape != (total * up, n) or not np.all(np.isfinite(arr))
               for arr in external):
            raise InputDataError(f"principal_response: expected finite (x, v, a) of shape "
                                 f"{(total * up, n)} each")
    end_ns = int(times[-1]) + int(round(NS_PER_S / rate))
    for i, (run, (seeds, comps), s0) in enumerate(zip(scenario.runs, records, starts)):
        b0, b1 = bounds[i] * up, bounds[i + 1] * up
        geometry, params = piers[i]
        rc_run = None
        if external is not None:  # the segment's displacements relative to where it started
            x_ext, v_ext, a_ext = (arr[b0:b1] for arr in external)
            offset = x_ext[0].copy()
            x_seg = x_ext - offset
            resp = Response(t=np.arange(b1 - b0) * dt_m, ag=table_m[b0:b1, 0].copy(),
                            x=x_seg, v=v_ext.copy(), a=a_ext.copy(),
                            theta=(offset + x_seg) @ angle_matrix(
                                geometry.section_heights_m).T,
                            moment=np.zeros_like(x_seg))
        elif springs is None:
            resp = simulate(geometry, params, table_m[b0:b1, 0], dt_m, dt=_INTERNAL_DT_S,
                            output_dt=dt_m, v0=v_end)
        else:  # starts where the last segment ended: displaced, with its cracks and yielding
            rc_run = integrate_rc(geometry, springs, table_m[b0:b1, 0], dt_m,
                                  dt=_INTERNAL_DT_S, output_dt=dt_m, x0=offset, v0=v_end,
                                  state=rc_state, rayleigh_zeta=rayleigh_zeta)
            rc_state = rc_run.state_end
            resp = rc_run.response
            # the segment's displacements relative to where it started, as for bilinear runs
            resp = dataclasses.replace(resp, x=resp.x - offset)
        resp_t = simulate(geometry, _elastic(params), table_m[b0:b1, 1], dt_m,
                          dt=_INTERNAL_DT_S, x0=xt_end, v0=vt_end, output_dt=dt_m)
        rel["xp"][b0:b1] = resp.x + offset
        rel["vp"][b0:b1] = resp.v
        rel["ap"][b0:b1] = resp.a
        rel["xt"][b0:b1] = resp_t.x
        rel["vt"][b0:b1] = resp_t.v
        rel["at"][b0:b1] = resp_t.a

        n_rec = comps[0].size
        sel = slice(s0 * up - b0, (s0 + n_rec) * up - b0, up)  # the record, at the pier's rate
        response = Response(t=np.arange(n_rec) * dt, ag=resp.ag[sel], x=resp.x[sel],
                            v=resp.v[sel], a=resp.a[sel], theta=resp.theta[sel],
                            moment=resp.moment[sel])
        truth_rc = None if rc_run is None else rc_truth(springs, rc_run.state_start,
                                                        rc_run.state_end)
        w0, w1 = _arias_window(response.ag, rate, scenario.window_pre_s, scenario.window_post_s)
        start_ns = int(times[s0])
        run_truths.append(RunTruth(
            name=run.name,
            start_ns=start_ns,
            end_ns=start_ns + int(round(n_rec * NS_PER_S / rate)),
            window_start_ns=int(times[s0 + w0]),
            window_end_ns=start_ns + int(round(w1 * NS_PER_S / rate)),
            params=params,
            geometry=geometry,
            principal_direction_deg=float(principal_direction_deg),
            response=response,
            table_velocity=table_vel[s0:s0 + n_rec, 0].copy(),
            ag_transverse=table[s0:s0 + n_rec, 1].copy(),
            ag_vertical=table[s0:s0 + n_rec, 2].copy(),
            initial_offset_m=offset.copy(),
            ductility_factors=(np.full(n, np.nan) if external is not None
                               else ductility_factors(response.theta, params)
                               if truth_rc is None else truth_rc.ductility_factor),
            periods_s=(natural_periods(geometry, params) if truth_rc is None
                       else stiffness_periods(geometry, truth_rc.k_small_before)),
            pga_mps2=float(np.max(np.abs(response.ag))),
            motion_seeds=seeds,
            rc=truth_rc,
            rc_springs=springs,
            rayleigh=None if rc_run is None else rc_run.rayleigh,
        ))
        offset = offset + resp.x[-1]
        v_end, xt_end, vt_end = resp.v[-1], resp_t.x[-1], resp_t.v[-1]

    # every sensor samples the true motion of its level on its own grid
    motion = _motion_vectors(principal_direction_deg, table_m, table_vel_m, rel)
    filtered: dict[tuple[str, int, float], np.ndarray] = {}
    sensor_seqs = noise_seq.spawn(len(config.sensors))
    sensors: dict[str, SensorRecord] = {}
    for spec, seq in zip(config.sensors, sensor_seqs):
        sensor_rate = config.sensor_rate_hz(spec)
        key = (spec.kind, spec.level, sensor_rate)
        if key not in filtered:
            signal_m = motion(spec.kind, spec.level)
            if anti_alias:
                signal_m = anti_alias_filter(signal_m, motion_rate, sensor_rate)
            filtered[key] = signal_m[::int(round(motion_rate / sensor_rate))]
        sampled = filtered[key]
        data = record_sensor(spec, sampled, np.random.default_rng(seq),
                             errors.get(spec.sensor_id))
        sensors[spec.sensor_id] = SensorRecord(
            spec.sensor_id, sample_times_ns(scenario.start_ns, sampled.shape[0], sensor_rate),
            data, sensor_rate)

    source = f"synthetic shaking-table recording of {config.pier_id} (seed {seed})"
    truth = SyntheticTruth(
        seed=int(seed), pier_id=config.pier_id,
        principal_direction_deg=float(principal_direction_deg), sample_rate_hz=rate,
        start_ns=int(times[0]), end_ns=end_ns, runs=tuple(run_truths),
        noise_rms={s.sensor_id: s.noise_rms for s in config.sensors}, scenario=scenario,
        imperfections=imperfections, sensor_errors=errors, anti_alias=anti_alias,
        hysteresis="external" if external is not None else hysteresis)
    # the operators record added deck mass as a configuration update before the run
    updates = tuple((int(times[bounds[i]]), dataclasses.replace(config, geometry=piers[i][0]))
                    for i in range(1, len(piers)) if piers[i][0] != config.geometry)
    return SyntheticRecording(Recording(config, sensors, source=source, config_updates=updates),
                              truth)


# ---------------------------------------------------------------------------------------------
# saving and loading the truth


def _truth_json(truth: SyntheticTruth, config: PierConfig | None) -> dict[str, Any]:
    units = {s.sensor_id: s.unit for s in config.sensors} if config is not None else {}
    kinds = {s.sensor_id: s.kind for s in config.sensors} if config is not None else {}
    noise = {}
    for sid, rms in truth.noise_rms.items():
        entry: dict[str, Any] = {"noise_rms": rms}
        if sid in units:
            spec = config.sensor(sid)  # type: ignore[union-attr]
            entry.update(unit=units[sid], kind=kinds[sid], noise_rms_si=rms * spec.si_factor)
            if spec.rate_hz is not None:
                entry.update(rate_hz=spec.rate_hz)
        noise[sid] = entry
    out = {
        "format": "pier_monitor synthetic truth 1",
        "seed": truth.seed,
        "pier_id": truth.pier_id,
        "principal_direction_deg": truth.principal_direction_deg,
        "sample_rate_hz": truth.sample_rate_hz,
        "start_ns": truth.start_ns,
        "end_ns": truth.end_ns,
        "conventions": {
            "time": "integer ns since the Unix epoch; intervals are [start, end)",
            "responses": "relative to the foundation, principal direction, SI (m, m/s, m/s^2, "
                         "rad, N*m); t in s from the run's start_ns; arrays in the .npz as "
                         "<run>/<name>",
            "ductility_factor": "max |theta_n| / (fy_n / k1_n) over the run's record",
            "window": "reference mainshock window: window_pre_s before the 5% to window_post_s "
                      "after the 95% point of the Arias intensity of the principal table "
                      "acceleration",
        },
        "runs": [r.summary() for r in truth.runs],
        "noise": noise,
        "scenario": truth.scenario.as_dict(),
    }
    if truth.hysteresis != "bilinear":  # RC test-bed only: bilinear truth files unchanged
        out["hysteresis"] = truth.hysteresis
        out["conventions"]["ductility_factor"] = (
            "RC springs: peak |theta_n| / idealised yield rotation (equal-energy bilinear of "
            "the skeleton up to the peak, elastic branch through first yield); details per "
            "run under 'rc'")
        out["conventions"]["rc"] = (
            "per section, bottom to top: peak rotation so far, idealised yield rotation, DF, "
            "first-yield rotation and whether it was passed (reinforcement yielded), "
            "cracking, energy dissipated in the run's segment (J), small-amplitude "
            "(unloading) stiffness at the segment's start and end (N*m/rad), strength factor; "
            "theta in the .npz is the springs' true angle (residual rotation included), "
            "params are the as-built bilinear design the springs derive from, damping is "
            "the Rayleigh matrix a0 M + a1 K0 (c is not used)")
    # measurement realism, only when used (the shaking-table truth files stay as they were)
    if truth.anti_alias:
        out["anti_alias"] = {
            "filter": f"Butterworth low-pass of order {ANTI_ALIAS_ORDER}, zero-phase (forward "
                      "and backward) on the 1 ms simulated signal, before sampling",
            "cutoff_fraction_of_sensor_rate": ANTI_ALIAS_CUTOFF_FRACTION}
    if truth.imperfections is not None:
        out["imperfections"] = truth.imperfections.as_dict()
    if truth.sensor_errors:
        out["sensor_errors_conventions"] = (
            "true sensor = nominal sensor of the configuration with each channel's gain times "
            "gain_factors, azimuth + orientation_error_deg, tilted by tilt_deg about the pier's "
            "X and Y axes; offset_error = static reading the configuration's offsets miss "
            "(tilted gravity, gain error on gravity, bias), in the sensor's unit (_si: SI)")
        out["sensor_errors"] = {
            sid: err.as_dict(config.sensor(sid) if sid in units else None)  # type: ignore[union-attr]
            for sid, err in truth.sensor_errors.items()}
    return out


def _springs_from_dict(d: Mapping[str, Any]) -> RCSprings:
    return RCSprings(k0=np.array(d["k0_Nm_per_rad"]), mc=np.array(d["mc_Nm"]),
                     my=np.array(d["my_Nm"]), theta_y=np.array(d["theta_y_rad"]),
                     kp=np.array(d["kp_Nm_per_rad"]), theta_u=np.array(d["theta_u_rad"]),
                     alpha=d["alpha"], pinch_x=d["pinch_x"], pinch_y=d["pinch_y"],
                     beta_e=d["beta_e"], d_min=d["d_min"], family=d["family"])


_SCALAR_LIST = re.compile(r"\[\s*([^\[\]{}]*?)\s*\]", re.DOTALL)


def _compact_json(obj: Any) -> str:
    """Indented JSON with lists of numbers and strings kept on one line."""
    text = to_strict_json(obj, indent=2)
    return _SCALAR_LIST.sub(lambda m: "[" + re.sub(r"\s*\n\s*", " ", m.group(1)) + "]", text)


def save_truth(truth: SyntheticTruth, npz_path: str | Path, json_path: str | Path, *,
               config: PierConfig | None = None) -> None:
    """Write the truth: time series to ``npz_path``, everything else to ``json_path``.

    The JSON file is human-readable (indented): parameters, geometry, periods, run and
    mainshock windows, ductility factors, principal direction, noise levels (with units when
    ``config`` is given).  The ``.npz`` holds ``<run>/<name>`` arrays: the response
    (``t, ag, x, v, a, theta, moment``), ``table_velocity``, ``ag_transverse``,
    ``ag_vertical``, and ``<run>/time_ns``.
    """
    arrays: dict[str, np.ndarray] = {}
    for r in truth.runs:
        for key, value in r.response.as_dict().items():
            arrays[f"{r.name}/{key}"] = np.asarray(value)
        for key in _TABLE_KEYS:
            arrays[f"{r.name}/{key}"] = np.asarray(getattr(r, key))
        arrays[f"{r.name}/time_ns"] = r.start_ns + np.rint(
            r.response.t * NS_PER_S).astype(np.int64)
    npz_path, json_path = Path(npz_path), Path(json_path)
    with npz_path.open("wb") as fh:
        np.savez_compressed(fh, **arrays)
    json_path.write_text(_compact_json(_truth_json(truth, config)) + "\n", encoding="utf-8")


def load_truth(npz_path: str | Path, json_path: str | Path) -> SyntheticTruth:
    """Read a truth written by :func:`save_truth`.

    Raises
    ------
    InputDataError
        If a file is missing, unreadable or not a truth file.
    """
    npz_path, json_path = Path(npz_path), Path(json_path)
    try:
        meta = json.loads(json_path.read_text(encoding="utf-8"))
        with np.load(npz_path) as npz:
            arrays = {k: npz[k] for k in npz.files}
    except (OSError, ValueError) as err:
        raise InputDataError(f"cannot read synthetic truth {json_path.name} / "
                             f"{npz_path.name}: {err}") from err
    if meta.get("format") != "pier_monitor synthetic truth 1":
        raise InputDataError(f"{json_path.name}: not a pier_monitor synthetic truth file")
    try:
        sc = dict(meta["scenario"])
        scenario = Scenario(runs=tuple(RunSpec(**{k: tuple(v) if isinstance(v, list) else v
                                                  for k, v in r.items()})
                                       for r in sc.pop("runs")), **sc)
        runs = []
        for r in meta["runs"]:
            name = r["name"]
            p = r["params"]
            runs.append(RunTruth(
                name=name, start_ns=int(r["start_ns"]), end_ns=int(r["end_ns"]),
                window_start_ns=int(r["window_start_ns"]), window_end_ns=int(r["window_end_ns"]),
                params=SpringParameters(np.array(p["k1_Nm_per_rad"]), np.array(p["k2_Nm_per_rad"]),
                                        np.array(p["fy_Nm"]), np.array(p["c_Nms_per_rad"])),
                geometry=PierGeometry(np.array(r["geometry"]["section_heights_m"]),
                                      np.array(r["geometry"]["masses_kg"])),
                principal_direction_deg=float(r["principal_direction_deg"]),
                response=Response(**{k: arrays[f"{name}/{k}"] for k in _RESPONSE_KEYS}),
                **{k: arrays[f"{name}/{k}"] for k in _TABLE_KEYS},
                initial_offset_m=np.array(r["initial_offset_m"]),
                ductility_factors=np.array(r["ductility_factors"]),
                periods_s=np.array(r["periods_s"]),
                pga_mps2=float(r["pga_mps2"]),
                motion_seeds=tuple(int(s) for s in r["motion_seeds"]),
                **({} if "rc" not in r else dict(
                    rc=RCSectionTruth.from_dict(r["rc"]),
                    rc_springs=_springs_from_dict(r["rc_springs"]),
                    rayleigh=tuple(float(v) for v in r["rayleigh_a0_per_s_a1_s"]))),
            ))
        imperfections = meta.get("imperfections")
        return SyntheticTruth(
            seed=int(meta["seed"]), pier_id=meta["pier_id"],
            principal_direction_deg=float(meta["principal_direction_deg"]),
            sample_rate_hz=float(meta["sample_rate_hz"]), start_ns=int(meta["start_ns"]),
            end_ns=int(meta["end_ns"]), runs=tuple(runs),
            noise_rms={k: float(v["noise_rms"]) for k, v in meta["noise"].items()},
            scenario=scenario,
            imperfections=None if imperfections is None else SensorImperfections(**imperfections),
            sensor_errors={k: SensorError.from_dict(v)
                           for k, v in meta.get("sensor_errors", {}).items()},
            anti_alias="anti_alias" in meta,
            hysteresis=meta.get("hysteresis", "bilinear"))
    except (KeyError, TypeError) as err:
        raise InputDataError(f"{json_path.name}: incomplete synthetic truth ({err!r} missing "
                             "or malformed)") from err
