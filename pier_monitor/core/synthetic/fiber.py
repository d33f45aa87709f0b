"""An independent check: a fiber-section RC column in OpenSees (RC_NOTES "A fiber-section
check, measured"; optional extra ``pip install .[fiber]``).

The RC test-bed of :mod:`~pier_monitor.core.synthetic.rc` is our own model of RC springs.
This module builds a column that knows nothing of springs: a 2-D ``forceBeamColumn`` model in
OpenSees with fiber sections, one element per section of the pier configuration (nodes at its
level heights, its lumped masses at the nodes and their weight as axial load), Concrete02
confined core and unconfined cover, Steel02 (Giuffré–Menegotto–Pinto) bars cut off above
``cutoff_m``, a P-Δ transformation and Rayleigh damping (``zeta`` on modes 1 and 2 of the
uncracked column, stiffness term on the committed stiffness).  The column is the E-Defense-like
pier of RC_NOTES: D = 2 m, 7.5 m tall, about 340 t, T1 ≈ 0.3 s uncracked.

What an engineer compares with, per section ``n`` (the spring at the bottom of section ``n``,
angle ``θ = B x`` of :func:`~pier_monitor.core.model.link_model.spring_angles`, i.e. the
change of chord slope at that level, as the identifier's springs see it):

* **peak rotation** ``max |θ_n|`` over a shaking;
* **bar strain**: the largest tensile strain of the outermost bar at the bottom of the
  section (from the section's axial strain and curvature), over the yield strain;
* **idealised yield rotation** (RC_NOTES "Yield and ductility an engineer can compare"):
  ``θ_y = θ'_y · M_n / M'_y``; ``M'_y`` (first bar yield) and ``M_n`` (extreme concrete
  strain 0.004 or bar strain 0.015, whichever first) from a moment–curvature analysis of the
  section under its axial load; ``θ'_y`` from a pushover of the same column (lateral forces
  ∝ mass × height) at the step where the section's moment reaches ``M'_y``.  A section that
  the pushover does not bring to ``M'_y`` before the base reaches ``M_n`` gets
  ``θ'_y = M'_y / k_sec`` with ``k_sec`` its secant at the pushover's largest moment
  (an extrapolation: flagged ``yield_extrapolated``);
* **DF** = peak rotation / idealised yield rotation;
* the same two numbers on the definition the product reports
  (:func:`~pier_monitor.core.model.springs.idealised_yield`): the **equal-energy idealised
  yield rotation** of the pushover's moment-rotation skeleton of the section up to the peak
  rotation so far, its elastic branch the secant through first yield ``(θ'_y, M'_y)``, and
  the DF on it.  The two differ by what the event never revealed: the RC_NOTES idealisation
  extends the elastic branch to ``M_n``, the equal-energy one ends at the skeleton's moment
  at the event's peak, below ``M_n`` for a section that just yielded (the pushover is
  continued past the base's ``M_n`` to rotations of :data:`PUSHOVER_MAX_ROTATION`, so that
  a heavy shaking's peak stays within the recorded skeleton);
* **small-amplitude stiffness**: a static probe of the column at rest (forces ∝ mass ×
  height giving a base moment of ``probe_fraction`` × the base ``M'_y``, pushed both ways);
  ``k_n = ΔM_n / Δθ_n`` per section, and the first period of the column (eigen analysis of
  the tangent stiffness) at the same instants.

One transient carries the whole recording (quiet stretches and shakings) so that the second
shaking finds the cracks and yielding the first one left.  Results are cached in an ``.npz``
keyed by every parameter and the ground motion.  :func:`fiber_principal_response` plugs the
transient into :func:`~pier_monitor.core.synthetic.shaking_table.generate_recording` (its
``principal_response``), so the column is recorded by the same imperfect sensors as the
product's own synthetic piers.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from pier_monitor.core.errors import InputDataError, PierMonitorError, SolverError
from pier_monitor.core.model.config import PierGeometry
from pier_monitor.core.model.link_model import angle_matrix
from pier_monitor.core.model.springs import Skeleton, idealised_yield

__all__ = ["FiberColumn", "FiberYield", "FiberTransient", "have_openseespy", "import_ops",
           "fiber_yield", "fiber_transient", "fiber_truth", "elastic_first_period",
           "gross_ei", "fiber_principal_response"]

G = 9.80665
_CACHE_VERSION = 2
#: Base spring angle, rad, up to which the pushover's moment-rotation skeleton is recorded
#: (about 5x the base's idealised yield rotation; the heavy shaking's peak is 0.0066).
PUSHOVER_MAX_ROTATION = 0.012


def import_ops():
    """``openseespy.opensees``, imported on first use.

    Raises
    ------
    PierMonitorError
        When openseespy (or the system BLAS/LAPACK it loads) is missing.
    """
    try:
        import openseespy.opensees as ops  # optional heavy dependency (extra 'fiber')
    except Exception as err:  # ImportError, or an OSError from a missing libblas/liblapack
        raise PierMonitorError(
            "the fiber-section column needs openseespy: pip install .[fiber]; needs libblas3 "
            f"liblapack3 (the system BLAS/LAPACK) ({type(err).__name__}: {err})") from err
    return ops


def have_openseespy() -> bool:
    """Whether openseespy can be imported here."""
    try:
        import_ops()
    except PierMonitorError:
        return False
    return True


@dataclass(frozen=True)
class FiberColumn:
    """The fiber-section column: geometry of the cross-section and materials (SI).

    Attributes
    ----------
    diameter_m : float
        Column diameter.
    cover_m : float
        Concrete cover to the bars' centres.
    fc_pa, eps_c0 : float
        Unconfined concrete strength (positive) and its strain at peak (cover; also sets
        the elastic modulus ``2 fc / eps_c0`` of both concretes).
    fcc_pa, eps_cc : float
        Confined (core) strength and strain at peak.
    fcu_core_pa, eps_cu_core : float
        Core crushing strength and strain.
    ft_ratio : float
        Tensile strength over ``fc`` (Concrete02; linear tension softening ``Ets = 0.1 Ec``).
    fy_pa, es_pa, b_steel : float
        Bars: yield stress, modulus, strain-hardening ratio (Steel02 with R0 18, cR1 0.925,
        cR2 0.15).
    bar_area_m2 : float
        Area of one bar.
    n_bars_base, n_bars_upper : int
        Bars below and above ``cutoff_m``.
    cutoff_m : float
        Height where part of the bars is cut off.
    zeta : float
        Rayleigh damping ratio on modes 1 and 2 of the uncracked column.
    n_ip : int
        Gauss–Lobatto integration points per element.
    dt_s : float
        Integration step of the transient, s.
    probe_fraction : float
        Base moment of the small-amplitude probe over the base section's first-yield moment.
    """

    diameter_m: float = 2.0
    cover_m: float = 0.10
    fc_pa: float = 30e6
    eps_c0: float = 0.002
    fcc_pa: float = 39e6
    eps_cc: float = 0.0026
    fcu_core_pa: float = 31e6
    eps_cu_core: float = 0.02
    ft_ratio: float = 0.1
    fy_pa: float = 345e6
    es_pa: float = 200e9
    b_steel: float = 0.01
    bar_area_m2: float = 7.94e-4  # D32
    n_bars_base: int = 64
    n_bars_upper: int = 48
    cutoff_m: float = 2.0
    zeta: float = 0.02
    n_ip: int = 5
    dt_s: float = 0.0025
    probe_fraction: float = 0.05

    @property
    def ec_pa(self) -> float:
        """Initial modulus of the concrete, Pa."""
        return 2.0 * self.fc_pa / self.eps_c0

    @property
    def eps_y(self) -> float:
        """Yield strain of the bars."""
        return self.fy_pa / self.es_pa

    @property
    def bar_radius_m(self) -> float:
        return 0.5 * self.diameter_m - self.cover_m

    def n_bars(self, z_bottom_m: float) -> int:
        """Bars in an element starting at height ``z_bottom_m``."""
        return self.n_bars_base if z_bottom_m < self.cutoff_m - 1e-9 else self.n_bars_upper


def gross_ei(column: FiberColumn, n_bars: int) -> float:
    """Flexural rigidity of the uncracked transformed section (concrete + bars), N·m²:
    what the fiber section starts with (bars smeared on their ring)."""
    r = 0.5 * column.diameter_m
    i_c = np.pi * r ** 4 / 4.0
    i_s = n_bars * column.bar_area_m2 * column.bar_radius_m ** 2 / 2.0
    return column.ec_pa * i_c + (column.es_pa - column.ec_pa) * i_s


# ---------------------------------------------------------------------------------------------
# model


def _sections(ops, column: FiberColumn) -> dict[int, int]:
    """Materials and the two fiber sections; returns ``{n_bars: section tag}``."""
    ec = column.ec_pa
    ft = column.ft_ratio * column.fc_pa
    # Concrete02: tag fpc epsc0 fpcu epsU lambda ft Ets (compression negative)
    ops.uniaxialMaterial("Concrete02", 1, -column.fcc_pa, -column.eps_cc, -column.fcu_core_pa,
                         -column.eps_cu_core, 0.1, ft, 0.1 * ec)
    ops.uniaxialMaterial("Concrete02", 2, -column.fc_pa, -column.eps_c0, -0.2 * column.fc_pa,
                         -0.006, 0.1, ft, 0.1 * ec)
    ops.uniaxialMaterial("Steel02", 3, column.fy_pa, column.es_pa, column.b_steel,
                         18.0, 0.925, 0.15)
    r = 0.5 * column.diameter_m
    r_core = column.bar_radius_m
    tags = {}
    for tag, nb in ((1, column.n_bars_base), (2, column.n_bars_upper)):
        if nb in tags:
            continue
        ops.section("Fiber", tag)
        ops.patch("circ", 1, 24, 10, 0.0, 0.0, 0.0, r_core, 0.0, 360.0)
        ops.patch("circ", 2, 24, 2, 0.0, 0.0, r_core, r, 0.0, 360.0)
        ops.layer("circ", 3, nb, column.bar_area_m2, 0.0, 0.0, r_core, 0.0,
                  360.0 * (nb - 1) / nb)
        tags[nb] = tag
    return tags


def _build(ops, column: FiberColumn, geometry: PierGeometry) -> np.ndarray:
    """The column with gravity applied (held constant, time reset to 0); returns the level
    heights (N+1,) from the base."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    z = np.concatenate([[0.0], np.cumsum(geometry.section_heights_m)])
    for i, zi in enumerate(z):
        ops.node(i + 1, 0.0, float(zi))
    ops.fix(1, 1, 1, 1)
    m = np.asarray(geometry.masses_kg, dtype=float)
    for i, mi in enumerate(m):
        ops.mass(i + 2, float(mi), float(mi), 1e-6 * float(mi))
    tags = _sections(ops, column)
    ops.geomTransf("PDelta", 1)
    for e in range(len(m)):
        sec = tags[column.n_bars(z[e])]
        ops.beamIntegration("Lobatto", e + 1, sec, column.n_ip)
        ops.element("forceBeamColumn", e + 1, e + 1, e + 2, 1, e + 1)
    ops.timeSeries("Constant", 1)
    ops.pattern("Plain", 1, 1)
    for i, mi in enumerate(m):
        ops.load(i + 2, 0.0, -G * float(mi), 0.0)
    _static(ops, 0.1)
    if ops.analyze(10) != 0:
        raise SolverError("fiber column: the gravity analysis did not converge")
    ops.loadConst("-time", 0.0)
    return z


def _analysis(ops, tol: float, max_iter: int, integrator: tuple, kind: str) -> None:
    """A fresh Newton analysis of the model (plain constraints, RCM numbering, banded
    system), converged on the displacement increment ``tol`` within ``max_iter``."""
    ops.wipeAnalysis()
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system("BandGeneral")
    ops.test("NormDispIncr", tol, max_iter)
    ops.algorithm("Newton")
    ops.integrator(*integrator)
    ops.analysis(kind)


def _static(ops, d_lambda: float) -> None:
    _analysis(ops, 1e-9, 50, ("LoadControl", d_lambda), "Static")


def _levels_x(ops, n: int) -> np.ndarray:
    return np.array([ops.nodeDisp(i + 2, 1) for i in range(n)])


def _section_state(ops, n: int, column: FiberColumn) -> tuple[np.ndarray, np.ndarray,
                                                                  np.ndarray]:
    """At the bottom integration point of every element: moment (N·m), largest bar tensile
    strain and extreme concrete compressive strain (positive) for either sign of curvature."""
    mom = np.empty(n)
    bar = np.empty(n)
    conc = np.empty(n)
    rb = column.bar_radius_m
    r = 0.5 * column.diameter_m
    for e in range(n):
        eps0, kappa = ops.sectionDeformation(e + 1, 1)[:2]
        mom[e] = ops.sectionForce(e + 1, 1)[1]
        bar[e] = eps0 + rb * abs(kappa)
        conc[e] = -(eps0 - r * abs(kappa))
    return mom, bar, conc


def _first_period(ops) -> float:
    lam = ops.eigen("-fullGenLapack", 1)
    return float(2.0 * np.pi / np.sqrt(lam[0]))


def elastic_first_period(column: FiberColumn, geometry: PierGeometry) -> float:
    """First period of the uncracked column after gravity (eigen analysis), s."""
    ops = import_ops()
    _build(ops, column, geometry)
    t1 = _first_period(ops)
    ops.wipe()
    return t1


# ---------------------------------------------------------------------------------------------
# yield: moment-curvature and pushover


@dataclass(frozen=True)
class FiberYield:
    """Idealised yield per section (shape (N,) each, bottom to top)."""

    first_yield_moment_Nm: np.ndarray
    nominal_moment_Nm: np.ndarray
    first_yield_rotation_rad: np.ndarray
    idealised_yield_rotation_rad: np.ndarray
    yield_extrapolated: np.ndarray
    axial_load_N: np.ndarray
    pushover_rotation_rad: np.ndarray | None = field(default=None, repr=False)
    pushover_moment_Nm: np.ndarray | None = field(default=None, repr=False)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready yield quantities (the pushover curves are left out)."""
        return {k: np.asarray(v).tolist() for k, v in asdict(self).items()
                if not k.startswith("pushover_")}

    def skeleton(self, section: int) -> Skeleton:
        """The pushover's moment-rotation skeleton of section ``section`` (0-based): its
        spring angle and moment at every pushover step (absolute values, the steps where the
        angle grows), with first yield ``(θ'_y, M'_y)`` as a corner; beyond the last step,
        the last step's slope.  Raises :class:`InputDataError` without a recorded pushover.
        """
        if self.pushover_rotation_rad is None or self.pushover_moment_Nm is None:
            raise InputDataError("fiber yield: no pushover curve recorded")
        th = np.abs(np.asarray(self.pushover_rotation_rad, dtype=float)[:, section])
        mo = np.abs(np.asarray(self.pushover_moment_Nm, dtype=float)[:, section])
        keep = th > np.maximum.accumulate(np.concatenate(([0.0], th[:-1])))
        th, mo = np.concatenate(([0.0], th[keep])), np.concatenate(([0.0], mo[keep]))
        ty = float(self.first_yield_rotation_rad[section])
        my = float(self.first_yield_moment_Nm[section])
        slope = max(float((mo[-1] - mo[-2]) / (th[-1] - th[-2])), 0.0) if th.size > 2 else 0.0
        j = int(np.searchsorted(th, ty))
        if j < th.size and np.isclose(th[j], ty, rtol=1e-12, atol=0.0):
            mo[j] = my
        else:  # (an extrapolated θ'_y of a section the pushover did not yield may lie beyond)
            th, mo = np.insert(th, j, ty), np.insert(mo, j, my)
        return Skeleton(th, mo, slope, ty)

    def equal_energy_yield_rotation(self, peak_rotation: np.ndarray) -> np.ndarray:
        """Equal-energy idealised yield rotation of every section's pushover skeleton up to
        its peak rotation (rad, (N,)), on the product's definition
        (:func:`~pier_monitor.core.model.springs.idealised_yield`: elastic branch through
        first yield, at most ``M_p / k'_y``; ``θ'_y`` while the peak is below it), rad."""
        peak = np.asarray(peak_rotation, dtype=float)
        return np.array([idealised_yield(self.skeleton(i), float(peak[i]))
                         for i in range(peak.size)])


def _moment_curvature(ops, column: FiberColumn, n_bars: int, axial_n: float
                      ) -> tuple[float, float]:
    """``(M'_y, M_n)`` of a section under axial compression ``axial_n`` (N, positive)."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    tags = _sections(ops, column)
    sec = tags[n_bars]
    ops.node(1, 0.0, 0.0)
    ops.node(2, 0.0, 0.0)
    ops.fix(1, 1, 1, 1)
    ops.fix(2, 0, 1, 0)
    ops.element("zeroLengthSection", 1, 1, 2, sec)
    ops.timeSeries("Constant", 1)
    ops.pattern("Plain", 1, 1)
    ops.load(2, -axial_n, 0.0, 0.0)
    _static(ops, 1.0)
    if ops.analyze(1) != 0:
        raise SolverError("fiber column: the axial load of the moment-curvature analysis "
                          "did not converge")
    ops.loadConst("-time", 0.0)
    ops.timeSeries("Linear", 2)
    ops.pattern("Plain", 2, 2)
    ops.load(2, 0.0, 0.0, 1.0)
    dk = 2e-6
    ops.integrator("DisplacementControl", 2, 3, dk)
    ops.analysis("Static")
    rb = column.bar_radius_m
    r = 0.5 * column.diameter_m
    prev = (0.0, 0.0, 0.0)
    my = mn = None
    for _ in range(20000):
        if ops.analyze(1) != 0:
            break
        eps0, kappa = ops.sectionDeformation(1, 1)[:2]
        m = ops.sectionForce(1, 1)[1]
        bar = eps0 + rb * abs(kappa)
        conc = -(eps0 - r * abs(kappa))
        if my is None and bar >= column.eps_y:
            f = (column.eps_y - prev[1]) / (bar - prev[1])
            my = prev[0] + f * (m - prev[0])
        if conc >= 0.004 or bar >= 0.015:
            mn = m
            break
        prev = (m, bar, conc)
    ops.wipe()
    if my is None or mn is None:
        raise SolverError("fiber column: the moment-curvature analysis did not reach first "
                          "yield and the nominal moment")
    return float(my), float(mn)


def fiber_yield(column: FiberColumn, geometry: PierGeometry) -> FiberYield:
    """Idealised yield rotation per section (see the module docstring)."""
    ops = import_ops()
    m = np.asarray(geometry.masses_kg, dtype=float)
    n = m.size
    z = np.concatenate([[0.0], np.cumsum(geometry.section_heights_m)])
    axial = G * np.cumsum(m[::-1])[::-1]  # weight carried at the bottom of each section
    my = np.empty(n)
    mn = np.empty(n)
    for e in range(n):
        my[e], mn[e] = _moment_curvature(ops, column, column.n_bars(z[e]), axial[e])
    # pushover of the column: forces ∝ m z, displacement control at the top
    _build(ops, column, geometry)
    ops.timeSeries("Linear", 2)
    ops.pattern("Plain", 2, 2)
    w = m * z[1:]
    for i in range(n):
        ops.load(i + 2, float(w[i] / w.sum()), 0.0, 0.0)
    _static(ops, 1.0)
    ops.integrator("DisplacementControl", n + 1, 1, 2e-4)
    ops.analysis("Static")
    b = angle_matrix(geometry.section_heights_m)
    prev_th = np.zeros(n)
    prev_m = np.zeros(n)
    th_fy = np.full(n, np.nan)
    k_sec = np.zeros(n)
    m_top = np.zeros(n)
    curve_th, curve_m = [], []
    nominal = False  # the base reached M_n: yield quantities fixed, only the curve goes on
    for _ in range(20000):
        if ops.analyze(1) != 0:
            break
        th = b @ _levels_x(ops, n)
        mom, bar, conc = _section_state(ops, n, column)
        curve_th.append(th)
        curve_m.append(mom)
        if not nominal:
            for e in range(n):
                if np.isnan(th_fy[e]) and abs(mom[e]) >= my[e]:
                    f = (my[e] - abs(prev_m[e])) / (abs(mom[e]) - abs(prev_m[e]))
                    th_fy[e] = abs(prev_th[e]) + f * (abs(th[e]) - abs(prev_th[e]))
                if abs(mom[e]) > m_top[e] and abs(th[e]) > 0:
                    m_top[e] = abs(mom[e])
                    k_sec[e] = abs(mom[e]) / abs(th[e])
            prev_th, prev_m = th, mom
            nominal = bool(conc[0] >= 0.004 or bar[0] >= 0.015)
        if nominal and abs(th[0]) >= PUSHOVER_MAX_ROTATION:
            break
    ops.wipe()
    extrapolated = np.isnan(th_fy)
    if np.any(k_sec[extrapolated] <= 0):
        raise SolverError("fiber column: the pushover gave no stiffness for some sections")
    th_fy = np.where(extrapolated, my / np.where(k_sec > 0, k_sec, 1.0), th_fy)
    return FiberYield(first_yield_moment_Nm=my, nominal_moment_Nm=mn,
                      first_yield_rotation_rad=th_fy,
                      idealised_yield_rotation_rad=th_fy * mn / my,
                      yield_extrapolated=extrapolated, axial_load_N=axial,
                      pushover_rotation_rad=np.array(curve_th).reshape(-1, n),
                      pushover_moment_Nm=np.array(curve_m).reshape(-1, n))


# ---------------------------------------------------------------------------------------------
# transient


@dataclass(frozen=True, eq=False)
class FiberTransient:
    """The column's response over a whole recording, at every integration step.

    Attributes
    ----------
    t : ndarray (T,)
        Time from the start, s, at the integration step ``column.dt_s``.
    x, v, a : ndarray (T, N)
        Level displacements, velocities and accelerations relative to the base (m, m/s,
        m/s²); the absolute acceleration is ``a + ag``.
    ag : ndarray (T,)
        Base acceleration, m/s².
    theta, moment, bar_strain : ndarray (T, N)
        Spring angles ``B x`` (rad), moment (N·m) and largest bar tensile strain at the
        bottom of each section.
    probe_t : ndarray (P,)
        Instants of the small-amplitude probes, s.
    probe_k : ndarray (P, N)
        Small-amplitude stiffness per section at each probe, N·m/rad.
    probe_period_s : ndarray (P,)
        First period (tangent stiffness) at each probe, s.
    wall_s : float
        Time the transient took (not the cache read), s.
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    ag: np.ndarray
    theta: np.ndarray
    moment: np.ndarray
    bar_strain: np.ndarray
    probe_t: np.ndarray
    probe_k: np.ndarray
    probe_period_s: np.ndarray
    wall_s: float


def _transient_analysis(ops, dt: float) -> None:
    # HHT (α = 0.9) damps the spurious high-frequency response of the nearly massless
    # rotations and of the light lower levels, which Newmark's average acceleration keeps
    # at the step's Nyquist frequency (it then aliases into the sampled accelerations)
    _analysis(ops, 1e-8, 30, ("HHT", 0.9), "Transient")


def _probe(ops, column: FiberColumn, geometry: PierGeometry, base_moment: float,
           tag: int) -> np.ndarray:
    """Small-amplitude secant stiffness per section: push both ways from the current state
    (forces ∝ m z, base moment ``base_moment``) and back; N·m/rad, shape (N,)."""
    m = np.asarray(geometry.masses_kg, dtype=float)
    n = m.size
    z = np.cumsum(geometry.section_heights_m)
    w = m * z
    f = w * base_moment / float(w @ z)
    b = angle_matrix(geometry.section_heights_m)
    ops.setTime(0.0)  # the pattern's factor is the (pseudo-)time: start it at zero
    ops.timeSeries("Linear", tag)
    ops.pattern("Plain", tag, tag)
    for i in range(n):
        ops.load(i + 2, float(f[i]), 0.0, 0.0)
    steps = 10
    states = []
    for lam in (1.0, -2.0, 1.0):
        _static(ops, lam / steps)
        if ops.analyze(steps) != 0:
            raise SolverError("fiber column: the small-amplitude probe did not converge")
        th = b @ _levels_x(ops, n)
        mom = _section_state(ops, n, column)[0]
        states.append((th, mom))
    ops.remove("loadPattern", tag)
    (th_p, m_p), (th_m, m_m) = states[0], states[1]
    return np.abs((m_p - m_m) / (th_p - th_m))  # the section moment's sign is OpenSees's


def _cache_key(column: FiberColumn, geometry: PierGeometry, ag: np.ndarray, dt_in: float,
               probe_s: Sequence[float], base_moment: float) -> str:
    h = hashlib.sha256()
    h.update(json.dumps({"v": _CACHE_VERSION, "column": asdict(column),
                         "heights": np.asarray(geometry.section_heights_m).tolist(),
                         "masses": np.asarray(geometry.masses_kg).tolist(), "dt_in": dt_in,
                         "probe_s": [float(p) for p in probe_s],
                         "probe_moment": base_moment}, sort_keys=True).encode())
    h.update(np.ascontiguousarray(ag, dtype=np.float64).tobytes())
    return h.hexdigest()[:20]


def fiber_transient(column: FiberColumn, geometry: PierGeometry, ag: np.ndarray, dt_in: float,
                    probe_s: Sequence[float] = (), *, probe_moment_Nm: float | None = None,
                    cache_dir: str | Path | None = None) -> FiberTransient:
    """The column's response to the base acceleration ``ag`` (sampled at ``dt_in``; the
    integration step is ``column.dt_s``, which must divide ``dt_in``), with a
    small-amplitude probe at each time of ``probe_s`` (choose quiet instants).

    ``probe_moment_Nm`` defaults to ``probe_fraction`` × the base section's first-yield
    moment (:func:`fiber_yield`).  With ``cache_dir`` the result is read from / written to
    ``<cache_dir>/fiber_<key>.npz``.

    Raises
    ------
    PierMonitorError
        Without openseespy.
    SolverError
        When a step does not converge even with smaller steps and other algorithms.
    """
    ag = np.asarray(ag, dtype=float)
    if ag.ndim != 1 or ag.size < 2 or not np.all(np.isfinite(ag)):
        raise InputDataError("fiber column: ag: expected a finite 1-D record")
    sub = dt_in / column.dt_s
    if abs(sub - round(sub)) > 1e-9 or round(sub) < 1:
        raise InputDataError(f"fiber column: the step {column.dt_s} s must divide the record's "
                             f"{dt_in} s")
    sub = int(round(sub))
    if probe_moment_Nm is None:
        probe_moment_Nm = column.probe_fraction * float(
            fiber_yield(column, geometry).first_yield_moment_Nm[0])
    probe_s = sorted(float(p) for p in probe_s)
    key = _cache_key(column, geometry, ag, dt_in, probe_s, probe_moment_Nm)
    path = None if cache_dir is None else Path(cache_dir) / f"fiber_{key}.npz"
    if path is not None and path.is_file():
        with np.load(path) as z:
            return FiberTransient(**{k: z[k] for k in z.files if k != "wall_s"},
                                  wall_s=float(z["wall_s"]))
    started = time.perf_counter()
    ops = import_ops()
    n = geometry.n_levels
    _build(ops, column, geometry)
    # Rayleigh on modes 1 and 2 of the uncracked column
    lam = np.asarray(ops.eigen("-fullGenLapack", 2), dtype=float)
    w1, w2 = np.sqrt(lam[:2])
    a0 = column.zeta * 2.0 * w1 * w2 / (w1 + w2)
    a1 = column.zeta * 2.0 / (w1 + w2)
    ops.rayleigh(a0, 0.0, 0.0, a1)
    ops.timeSeries("Path", 10, "-dt", dt_in, "-values", *ag.tolist())
    ops.pattern("UniformExcitation", 10, 1, "-accel", 10)
    b = angle_matrix(geometry.section_heights_m)
    n_out = ag.size
    n_fine = (n_out - 1) * sub + 1  # every integration step is kept (no aliasing here)
    out = {k: np.zeros((n_fine, n)) for k in ("x", "v", "a", "moment", "bar_strain")}
    probe_idx = {int(round(p / dt_in)): j for j, p in enumerate(probe_s)}
    probe_k = np.full((len(probe_s), n), np.nan)
    probe_t1 = np.full(len(probe_s), np.nan)
    _transient_analysis(ops, column.dt_s)
    dt = column.dt_s

    def record(j: int) -> None:
        out["x"][j] = _levels_x(ops, n)
        out["v"][j] = [ops.nodeVel(k + 2, 1) for k in range(n)]
        out["a"][j] = [ops.nodeAccel(k + 2, 1) for k in range(n)]
        mom, bar, _ = _section_state(ops, n, column)
        out["moment"][j] = mom
        out["bar_strain"][j] = bar

    record(0)
    for i in range(1, n_out):
        if i - 1 in probe_idx:
            j = probe_idx[i - 1]
            now = ops.getTime()
            probe_t1[j] = _first_period(ops)
            probe_k[j] = _probe(ops, column, geometry, probe_moment_Nm, 100 + j)
            ops.setTime(now)
            _transient_analysis(ops, dt)
        for s in range(sub):
            if ops.analyze(1, dt) != 0:
                _hard_step(ops, dt)
            record((i - 1) * sub + s + 1)
    ops.wipe()
    t_fine = np.arange(n_fine) * dt
    res = FiberTransient(t=t_fine, ag=np.interp(t_fine, np.arange(n_out) * dt_in, ag),
                         theta=out["x"] @ b.T,
                         probe_t=np.asarray(probe_s, dtype=float), probe_k=probe_k,
                         probe_period_s=probe_t1, wall_s=time.perf_counter() - started,
                         **{k: out[k] for k in ("x", "v", "a", "moment", "bar_strain")})
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp.npz")
        np.savez_compressed(tmp, **{k: getattr(res, k) for k in (
            "t", "x", "v", "a", "ag", "theta", "moment", "bar_strain", "probe_t", "probe_k",
            "probe_period_s", "wall_s")})
        tmp.replace(path)
    return res


def _hard_step(ops, dt: float) -> None:
    """One step that did not converge: other algorithms, then 10 sub-steps."""
    for algo in (("ModifiedNewton", "-initial"), ("NewtonLineSearch",), ("KrylovNewton",)):
        ops.algorithm(*algo)
        ok = ops.analyze(1, dt)
        ops.algorithm("Newton")
        if ok == 0:
            return
    ops.test("NormDispIncr", 1e-6, 100)
    for _ in range(10):
        if ops.analyze(1, dt / 10) != 0:
            ops.algorithm("KrylovNewton")
            ok = ops.analyze(1, dt / 10)
            ops.algorithm("Newton")
            if ok != 0:
                raise SolverError(f"fiber column: no convergence at t = {ops.getTime():.4f} s")
    ops.test("NormDispIncr", 1e-8, 30)


# ---------------------------------------------------------------------------------------------
# truth per shaking


def fiber_truth(tr: FiberTransient, fy: FiberYield, column: FiberColumn,
                shakings: Sequence[tuple[float, float]]) -> list[dict[str, Any]]:
    """Per shaking ``(t0, t1)`` (s from the start of the transient): per section the peak
    rotation (over that shaking, rad), the peak so far, the bar strain peak over the yield
    strain, the idealised yield rotation (RC_NOTES: ``θ'_y M_n / M'_y``), the DF (peak so far
    / idealised yield), first yield ``θ'_y``; where the pushover curve was recorded the same
    on the product's definition, ``equal_energy_yield_rotation_rad`` (the equal-energy
    bilinearisation of the section's pushover skeleton up to the peak so far,
    :meth:`FiberYield.equal_energy_yield_rotation`) and ``ductility_factor_equal_energy``;
    and the small-amplitude stiffness and first period at the probes just before and just
    after (the nearest probes outside the shaking)."""
    out = []
    so_far = np.zeros(tr.theta.shape[1])
    bar_so_far = np.zeros(tr.theta.shape[1])
    for t0, t1 in shakings:
        sel = (tr.t >= t0) & (tr.t < t1)
        peak = np.max(np.abs(tr.theta[sel]), axis=0)
        so_far = np.maximum(so_far, peak)
        bar = np.max(tr.bar_strain[sel], axis=0) / column.eps_y
        bar_so_far = np.maximum(bar_so_far, bar)
        before = np.flatnonzero(tr.probe_t <= t0)
        after = np.flatnonzero(tr.probe_t >= t1)
        entry: dict[str, Any] = {
            "t0_s": t0, "t1_s": t1,
            "peak_rotation_rad": peak, "peak_rotation_so_far_rad": so_far.copy(),
            "bar_strain_over_yield": bar, "bar_strain_over_yield_so_far": bar_so_far.copy(),
            "yielded": bar_so_far >= 1.0,
            "idealised_yield_rotation_rad": fy.idealised_yield_rotation_rad,
            "ductility_factor": so_far / fy.idealised_yield_rotation_rad,
            "first_yield_rotation_rad": fy.first_yield_rotation_rad,
            "peak_moment_Nm": np.max(np.abs(tr.moment[sel]), axis=0),
            "peak_base_acceleration_mps2": float(np.max(np.abs(tr.ag[sel]))),
        }
        if fy.pushover_rotation_rad is not None:
            ee = fy.equal_energy_yield_rotation(so_far)
            entry.update(equal_energy_yield_rotation_rad=ee,
                         ductility_factor_equal_energy=so_far / ee)
        if before.size and after.size:
            kb, ka = tr.probe_k[before[-1]], tr.probe_k[after[0]]
            entry.update(k_small_before=kb, k_small_after=ka,
                         k_small_change_pct=100.0 * (ka / kb - 1.0),
                         period_before_s=float(tr.probe_period_s[before[-1]]),
                         period_after_s=float(tr.probe_period_s[after[0]]))
        out.append(entry)
    return out


def fiber_principal_response(column: FiberColumn, geometry: PierGeometry, probe_s: Sequence[float],
                             *, cache_dir: str | Path | None = None, store: dict | None = None):
    """A ``principal_response`` for
    :func:`~pier_monitor.core.synthetic.shaking_table.generate_recording`: called with the
    principal table acceleration of the whole recording at the motion rate ``1/dt``, it runs
    the column (:func:`fiber_transient`, on every ``dt_in / dt``-th value, ``dt_in`` the
    smallest multiple of ``dt`` that ``column.dt_s`` divides, e.g. 5 ms for 1 ms) and returns
    ``(x, v, a)`` relative to the base at every integration step, interpolated linearly to
    ``dt`` (the sensors' anti-aliasing filter then acts on it as on the product's own
    simulations).  The transient is put in ``store["transient"]`` when a dict is
    given."""

    def response(acc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        step = 1
        while step * dt < column.dt_s - 1e-12 or abs(
                step * dt / column.dt_s - round(step * dt / column.dt_s)) > 1e-9:
            step += 1
            if step > 1000:
                raise InputDataError(f"fiber column: no common step of {dt} s and "
                                     f"{column.dt_s} s")
        coarse = acc[::step]
        tr = fiber_transient(column, geometry, coarse, step * dt, probe_s, cache_dir=cache_dir)
        if store is not None:
            store["transient"] = tr
        t_fine = np.arange(acc.size) * dt
        interp = [np.stack([np.interp(t_fine, tr.t, arr[:, k]) for k in range(arr.shape[1])],
                           axis=1) for arr in (tr.x, tr.v, tr.a)]
        return interp[0], interp[1], interp[2]

    return response
