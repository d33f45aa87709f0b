"""Reinforced-concrete test-bed: springs the identifier does not assume, Rayleigh damping.

The link model of SPEC §3 (angles ``θ = B x``, :func:`~pier_monitor.core.model.link_model.
angle_matrix`) is integrated with rotational springs that behave like the sections of an RC
pier rather than like the identifier's bilinear kinematic-hardening springs, and with a
Rayleigh damping matrix instead of one rotational damper per spring::

    M ẍ + C ẋ + Bᵀ f(θ, history) = −M 1 a_g,      C = a0 M + a1 K0

``K0 = Bᵀ diag(k0) B`` is the initial (uncracked) stiffness; ``a0, a1`` give the damping ratio
``ζ`` on modes 1 and 2 of that model (on mode 1, split equally between the mass and stiffness
terms, when there is one level).  The Rayleigh matrix stays the initial one through the run, as
in most nonlinear analyses (RC_NOTES "P-Δ and damping").

Spring families
---------------
``takeda``
    Modified Takeda (Takeda, Sozen & Nielsen 1970; Otani 1981), with pinching and strength
    degradation in the manner of the OpenSees ``Hysteretic`` material (pinchX, pinchY, β).

    *Skeleton* (per sign, ``S(θ)``): uncracked ``k0 θ`` up to the cracking point
    ``(θc, Mc)``, ``θc = Mc / k0``; cracked branch to the yield point ``(θy, My)``; post-yield
    slope ``kp`` up to ``θu``; flat beyond.
    *Unloading* at ``k_u = min(k0, k_y (θy / θm)^α)``, ``k_y = My / θy`` (the secant to yield),
    ``θm`` the largest rotation reached on either side (Takeda's rule; RC_NOTES: α 0.4–0.5).
    *Reloading* is peak-oriented: from the zero-moment crossing of the last unloading it aims
    first at the pinch point (moment ``pinch_y`` × the peak moment, at a fraction
    ``pinch_x`` of the way from the crossing to where unloading from the peak would reach that
    moment), then at the previous peak of that side on the (degraded) skeleton; the moment is
    the lower (in absolute value) of the reloading curve and the unloading line from the last
    state, which makes every inner loop follow the same two rules.
    *Strength degradation*: once the section has yielded, the skeleton beyond cracking is
    scaled by ``D = max(d_min, 1 − β_E E_d / (My θy))`` (never increasing), ``E_d`` the energy
    dissipated so far (``∫ M dθ`` less the elastic energy ``M² / 2 k_u`` still stored), so a
    full cycle at a ductility of about 4 loses about 3 % of strength.

``bwbn``
    Not provided: the smooth Bouc–Wen–Baber–Noori family is left out of this test-bed (and of
    the command line's ``--hysteresis`` choices).

Parameters from design values (:func:`rc_springs_from_design`)
---------------------------------------------------------------
The configurations give a bilinear design: ``k1`` (the cracked flexural stiffness EI/h,
``config/edefense_like.yaml``), ``k2 = k1/10``, ``fy``.  The RC springs keep the bilinear's
yield point and put the cracked-to-gross difference below it:

* ``My = fy`` and ``θy = fy / k1``: the secant to yield ``k_y`` is the design ``k1``;
* ``k0 = 1.6 k1``: the gross (uncracked) stiffness; cracked-to-gross EI ratios of RC columns
  are 0.3–0.7 (ACI 318 uses 0.7 for columns, Priestley, Calvi & Kowalsky 2007 give 0.3–0.6);
  1 / 1.6 = 0.63 makes the small-amplitude stiffness lost at first yield (37 %) close to the
  fiber-section column of RC_NOTES (T1 0.29 s uncracked, 0.37 s after just yielding: −39 %);
* ``Mc = 0.25 My`` (RC_NOTES: cracking at 10–30 % of the yield moment);
* ``kp = 0.03 k0`` (post-yield slope 2–5 % of ``k0``; P-Δ lowers it, RC_NOTES);
* ``θu = 12 θy`` (beyond, the skeleton is flat);
* ``α = 0.4`` (RC_NOTES), ``pinch_x = 0.6``, ``pinch_y = 0.35`` (moderate flexural
  pinching), ``β_E = 0.006``, ``d_min = 0.6``.

Truth an engineer compares with (:class:`RCSectionTruth`)
----------------------------------------------------------
* peak rotation ``θp`` (largest ``|θ|`` so far, rad);
* idealised yield rotation: the equal-energy bilinearisation of the (virgin) skeleton up to
  ``θp``, its elastic branch being the secant through first yield (``k_y``) and its end the
  skeleton point at ``θp``: ``θ* = (2 A − Mp θp) / (k_y θp − Mp)`` with ``A = ∫₀^θp S``,
  ``Mp = S(θp)`` (RC_NOTES: "equal-energy bilinearisation gives much the same" as
  ``θ'y Mn / M'y``), but never beyond ``Mp / k_y`` (``θ'y Mn / M'y`` with ``Mn = Mp``), which
  it is just past first yield; ``θ* = θy`` while ``θp ≤ θy``.  About ``1.05 θy`` at
  ``θp = 4 θy``;
* ductility factor ``θp / θ*``;
* whether the reinforcement yielded: ``θp > θy`` (first yield = the skeleton's yield point);
* hysteretic energy dissipated, J (``E_d`` above);
* the small-amplitude stiffness, N·m/rad: the unloading stiffness ``k_u`` of the state at the
  start and at the end (a small cycle about a state unloads and reloads at ``k_u``).

Amplitudes of the RC scenarios (:data:`RC_PGA_MPS2`) and what they give
------------------------------------------------------------------------
Filled in below (:data:`RC_TRUTH_TABLE`), measured with the default scenarios.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg

from pier_monitor.core._jit import jit
from pier_monitor.core.errors import InputDataError, SolverError
from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.model.link_model import angle_matrix
from pier_monitor.core.model.solver import Response, _check_vector

__all__ = [
    "HYSTERESIS_FAMILIES",
    "RC_FAMILIES",
    "RCSprings",
    "RCState",
    "RCRun",
    "RCSectionTruth",
    "rc_springs_from_design",
    "rayleigh_coefficients",
    "integrate_rc",
    "simulate_rc",
    "skeleton_moment",
    "idealised_yield_rotation",
    "rc_truth",
]

#: Hysteresis choices of the synthetic recordings (``bilinear`` = the identifier's own springs).
HYSTERESIS_FAMILIES = ("bilinear", "takeda")
#: The RC spring families of this module.
RC_FAMILIES = ("takeda",)

_FAMILY_CODE = {"takeda": 0}
_N_PARAMS = 11
_N_STATE = 9
# state columns
_TH, _M, _TMAXP, _TMAXN, _T0P, _T0N, _LOAD, _EINT, _D = range(_N_STATE)


@dataclass(frozen=True)
class RCSprings:
    """Per-section parameters of ``N`` modified-Takeda rotational springs (SI).

    Attributes
    ----------
    k0 : ndarray, shape (N,)
        Uncracked (gross) stiffness, N·m/rad.
    mc : ndarray, shape (N,)
        Cracking moment, N·m, ``0 < mc < my``.
    my : ndarray, shape (N,)
        Yield moment, N·m.
    theta_y : ndarray, shape (N,)
        Yield rotation, rad; ``mc / k0 < theta_y`` and the secant ``my / theta_y < k0``.
    kp : ndarray, shape (N,)
        Post-yield slope, N·m/rad, ``0 <= kp < my / theta_y``.
    theta_u : ndarray, shape (N,)
        Rotation where the post-yield branch ends (flat beyond), rad, ``> theta_y``.
    alpha : float
        Exponent of the unloading-stiffness degradation.
    pinch_x, pinch_y : float
        Pinching: rotation and moment fractions of the pinch point, in (0, 1].
    beta_e : float
        Strength loss per unit of normalised dissipated energy ``E_d / (My θy)``.
    d_min : float
        Lowest strength factor, in (0, 1].
    family : str
        ``"takeda"``.
    """

    k0: np.ndarray
    mc: np.ndarray
    my: np.ndarray
    theta_y: np.ndarray
    kp: np.ndarray
    theta_u: np.ndarray
    alpha: float = 0.4
    pinch_x: float = 0.6
    pinch_y: float = 0.35
    beta_e: float = 0.006
    d_min: float = 0.6
    family: str = "takeda"

    def __post_init__(self) -> None:
        arrays = {}
        for name in ("k0", "mc", "my", "theta_y", "kp", "theta_u"):
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float)).copy()
            if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
                raise InputDataError(f"RC springs: {name}: expected N finite values, got "
                                     f"{arr.tolist()}")
            arrays[name] = arr
        n = arrays["k0"].size
        for name, arr in arrays.items():
            if arr.size != n:
                raise InputDataError(f"RC springs: {name}: expected {n} values (one per "
                                     f"section), got {arr.size}")
        k0, mc, my, ty, kp, tu = (arrays[k] for k in ("k0", "mc", "my", "theta_y", "kp",
                                                      "theta_u"))
        checks = (("k0 > 0", k0 > 0), ("0 < mc < my", (mc > 0) & (mc < my)),
                  ("mc / k0 < theta_y", mc / np.where(k0 > 0, k0, 1.0) < ty),
                  ("my / theta_y < k0", my < k0 * ty),
                  ("0 <= kp < my / theta_y", (kp >= 0) & (kp * ty < my)),
                  ("theta_u > theta_y", tu > ty))
        for what, ok in checks:
            bad = np.flatnonzero(~ok)
            if bad.size:
                i = int(bad[0])
                raise InputDataError(
                    f"RC springs: section {i + 1}: expected {what}, got k0={k0[i]:g}, "
                    f"mc={mc[i]:g}, my={my[i]:g}, theta_y={ty[i]:g}, kp={kp[i]:g}, "
                    f"theta_u={tu[i]:g}")
        for name, lo, hi in (("alpha", 0.0, 5.0), ("pinch_x", 1e-6, 1.0), ("pinch_y", 1e-6, 1.0),
                             ("beta_e", 0.0, 1.0), ("d_min", 1e-6, 1.0)):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and lo <= v <= hi):
                raise InputDataError(f"RC springs: {name}: expected a value in [{lo:g}, {hi:g}], "
                                     f"got {v}")
            object.__setattr__(self, name, v)
        if self.family not in _FAMILY_CODE:
            raise InputDataError(f"RC springs: family: expected one of {list(_FAMILY_CODE)}, "
                                 f"got {self.family!r}")
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_springs(self) -> int:
        """Number of sections ``N``."""
        return int(self.k0.size)

    @property
    def theta_c(self) -> np.ndarray:
        """Cracking rotation ``mc / k0``, rad, shape (N,)."""
        return self.mc / self.k0

    @property
    def k_y(self) -> np.ndarray:
        """Secant stiffness to yield ``my / theta_y``, N·m/rad, shape (N,)."""
        return self.my / self.theta_y

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form (SI, names carry units)."""
        return {"family": self.family, "k0_Nm_per_rad": self.k0.tolist(),
                "mc_Nm": self.mc.tolist(), "my_Nm": self.my.tolist(),
                "theta_y_rad": self.theta_y.tolist(), "kp_Nm_per_rad": self.kp.tolist(),
                "theta_u_rad": self.theta_u.tolist(), "alpha": self.alpha,
                "pinch_x": self.pinch_x, "pinch_y": self.pinch_y, "beta_e": self.beta_e,
                "d_min": self.d_min}

    def _param_matrix(self) -> np.ndarray:
        n = self.n_springs
        p = np.empty((n, _N_PARAMS))
        p[:, 0] = self.k0
        p[:, 1] = self.mc
        p[:, 2] = self.my
        p[:, 3] = self.theta_y
        p[:, 4] = self.kp
        p[:, 5] = self.theta_u
        p[:, 6] = self.alpha
        p[:, 7] = self.pinch_x
        p[:, 8] = self.pinch_y
        p[:, 9] = self.beta_e
        p[:, 10] = self.d_min
        return p


def rc_springs_from_design(params: SpringParameters, *, gross_ratio: float = 1.6,
                           cracking_ratio: float = 0.25, post_yield_ratio: float = 0.03,
                           ultimate_ductility: float = 12.0, family: str = "takeda",
                           **hysteresis: float) -> RCSprings:
    """RC springs from a pier's bilinear design values (module docstring: the choices).

    Parameters
    ----------
    params : SpringParameters
        Design ``k1`` (cracked stiffness, N·m/rad) and ``fy`` (yield moment, N·m) per
        section; ``k2`` and ``c`` are not used (Rayleigh damping replaces ``c``).
    gross_ratio : float
        ``k0 / k1``, > 1.
    cracking_ratio : float
        ``Mc / My``, in (0, 1 / gross_ratio).
    post_yield_ratio : float
        ``kp / k0``.
    ultimate_ductility : float
        ``θu / θy``.
    family : str
        ``"takeda"``.
    **hysteresis
        ``alpha``, ``pinch_x``, ``pinch_y``, ``beta_e``, ``d_min`` (defaults of
        :class:`RCSprings`).
    """
    if not (np.isfinite(gross_ratio) and gross_ratio > 1.0):
        raise InputDataError(f"gross_ratio: expected k0/k1 > 1, got {gross_ratio}")
    if not (0.0 < cracking_ratio < 1.0 / gross_ratio):
        raise InputDataError(f"cracking_ratio: expected Mc/My in (0, {1.0 / gross_ratio:g}) so "
                             f"that the section cracks before it yields, got {cracking_ratio}")
    k0 = gross_ratio * params.k1
    return RCSprings(k0=k0, mc=cracking_ratio * params.fy, my=params.fy.copy(),
                     theta_y=params.fy / params.k1, kp=post_yield_ratio * k0,
                     theta_u=ultimate_ductility * params.fy / params.k1, family=family,
                     **hysteresis)


# ---------------------------------------------------------------------------------------------
# the spring rule (compiled)


@jit
def _skeleton(p, d, th):  # pragma: no cover - compiled
    """Moment and tangent of the skeleton at ``th`` with strength factor ``d``."""
    k0, mc, my, ty, kp, tu = p[0], p[1], p[2], p[3], p[4], p[5]
    tc = mc / k0
    a = abs(th)
    sgn = 1.0 if th >= 0.0 else -1.0
    if a <= tc:
        return k0 * th, k0
    if a <= ty:
        kc = (my - mc) / (ty - tc)
        return sgn * (mc + d * kc * (a - tc)), d * kc
    if a <= tu:
        s = my + kp * (a - ty)
        return sgn * (mc + d * (s - mc)), d * kp
    s = my + kp * (tu - ty)
    return sgn * (mc + d * (s - mc)), 0.0


@jit
def _unload_stiffness(p, tmax_pos, tmax_neg):  # pragma: no cover - compiled
    k0, my, ty, alpha = p[0], p[2], p[3], p[6]
    tm = max(tmax_pos, -tmax_neg)
    ku = (my / ty) * (ty / tm) ** alpha
    return min(k0, ku)


@jit
def _takeda_trial(p, st, th, out):  # pragma: no cover - compiled
    """Moment and tangent at angle ``th`` from the committed state ``st``; new state in ``out``.

    The rule is piecewise linear in ``th`` for a given committed state.
    """
    for j in range(st.shape[0]):
        out[j] = st[j]
    th_c = st[0]
    m_c = st[1]
    d = st[8]
    dth = th - th_c
    ku = _unload_stiffness(p, st[2], st[3])
    px, py = p[7], p[8]
    if dth == 0.0:
        return m_c, ku
    if th >= st[2]:  # beyond the positive peak: on the skeleton
        out[2] = th
        out[6] = 1.0
        return _skeleton(p, d, th)
    if th <= st[3]:
        out[3] = th
        out[6] = 2.0
        return _skeleton(p, d, th)
    big = 1e300
    if dth > 0.0:
        if st[6] == 2.0 and m_c <= 0.0:  # reversal from the negative side: crossing ahead
            out[4] = th_c - m_c / ku
        out[6] = 1.0
        tmax = st[2]
        rotrel = out[4]
        mm, _ = _skeleton(p, d, tmax)
        m_un = m_c + ku * dth
        k_un = ku
        if tmax - rotrel > 1e-12 * tmax and th > rotrel:
            rotmp2 = tmax - (1.0 - py) * mm / ku
            rotch = rotrel + px * (rotmp2 - rotrel)
            lo = rotrel + 1e-9 * (tmax - rotrel)
            hi = tmax - 1e-9 * (tmax - rotrel)
            rotch = min(max(rotch, lo), hi)
            if th < rotch:
                k_re = py * mm / (rotch - rotrel)
                m_re = k_re * (th - rotrel)
            else:
                k_re = (1.0 - py) * mm / (tmax - rotch)
                m_re = py * mm + k_re * (th - rotch)
        else:
            m_re = big
            k_re = 0.0
        if m_re < m_un:
            m, k = m_re, k_re
        else:
            m, k = m_un, k_un
        if th > p[3]:  # past yield, never above the positive skeleton
            m_s, k_s = _skeleton(p, d, th)
            if m_s < m:
                return m_s, k_s
        return m, k
    # dth < 0
    if st[6] == 1.0 and m_c >= 0.0:
        out[5] = th_c - m_c / ku
    out[6] = 2.0
    tmin = st[3]
    rotrel = out[5]
    mm, _ = _skeleton(p, d, tmin)
    m_un = m_c + ku * dth
    k_un = ku
    if rotrel - tmin > -1e-12 * tmin and th < rotrel:
        rotmp2 = tmin - (1.0 - py) * mm / ku
        rotch = rotrel + px * (rotmp2 - rotrel)
        hi = rotrel - 1e-9 * (rotrel - tmin)
        lo = tmin + 1e-9 * (rotrel - tmin)
        rotch = min(max(rotch, lo), hi)
        if th > rotch:
            k_re = py * mm / (rotch - rotrel)
            m_re = k_re * (th - rotrel)
        else:
            k_re = (1.0 - py) * mm / (tmin - rotch)
            m_re = py * mm + k_re * (th - rotch)
    else:
        m_re = -big
        k_re = 0.0
    if m_re > m_un:
        m, k = m_re, k_re
    else:
        m, k = m_un, k_un
    if th < -p[3]:  # past yield, never below the negative skeleton
        m_s, k_s = _skeleton(p, d, th)
        if m_s > m:
            return m_s, k_s
    return m, k


@jit
def _commit(p, st, th, m):  # pragma: no cover - compiled
    """Store the converged angle and moment; update the energy and the strength factor."""
    st[7] += 0.5 * (st[1] + m) * (th - st[0])
    st[0] = th
    st[1] = m
    ty = p[3]
    if max(st[2], -st[3]) > ty:
        ku = _unload_stiffness(p, st[2], st[3])
        ed = st[7] - m * m / (2.0 * ku)
        d = max(p[10], 1.0 - p[9] * ed / (p[2] * ty))
        if d < st[8]:
            st[8] = d


@jit
def _rc_kernel(m, b, cmat, params, state, ag, dt, out_every, x0, v0, max_iter,
               out_x, out_v, out_a, out_th, out_f):  # pragma: no cover - compiled
    n = m.shape[0]
    n_steps = ag.shape[0]
    bt = b.T.copy()
    x = x0.copy()
    v = v0.copy()
    th = b @ x
    f = np.empty(n)
    for i in range(n):
        f[i] = state[i, 1]
    rhs = -m * ag[0] - cmat @ v - bt @ f
    a = rhs / m
    out_x[0] = x
    out_v[0] = v
    out_a[0] = a
    out_th[0] = th
    out_f[0] = f
    h1 = dt * dt / 6.0
    trial = state.copy()
    kt = np.empty(n)
    f_new = np.empty(n)
    jac = np.empty((n, n))
    scale = 0.0
    for i in range(n):
        scale += m[i]
    for step in range(1, n_steps):
        x_known = x + dt * v + (dt * dt / 3.0) * a
        v_known = v + 0.5 * dt * a
        a_new = a.copy()
        converged = False
        for it in range(max_iter):
            x_new = x_known + h1 * a_new
            th_new = b @ x_new
            for i in range(n):
                fi, ki = _takeda_trial(params[i], state[i], th_new[i], trial[i])
                f_new[i] = fi
                kt[i] = ki
            v_new = v_known + 0.5 * dt * a_new
            r = m * (a_new + ag[step]) + cmat @ v_new + bt @ f_new
            for i in range(n):
                for j in range(n):
                    jac[i, j] = 0.5 * dt * cmat[i, j]
                    acc = 0.0
                    for q in range(n):
                        acc += bt[i, q] * kt[q] * b[q, j]
                    jac[i, j] += h1 * acc
                jac[i, i] += m[i]
            delta = np.linalg.solve(jac, r)
            size = 0.0
            ref = 1.0
            for i in range(n):
                size = max(size, abs(delta[i]))
                ref = max(ref, abs(a_new[i]) + abs(ag[step]))
            if size <= 1e-9 * ref:
                converged = True
                break
            # damped after many passes: a corner of the piecewise-linear rule can cycle
            if it >= max_iter // 2:
                a_new = a_new - 0.5 * delta
            else:
                a_new = a_new - delta
        if not converged:
            return -step
        x = x_known + h1 * a_new
        v = v_known + 0.5 * dt * a_new
        a = a_new
        th = b @ x
        for i in range(n):
            fi, _ = _takeda_trial(params[i], state[i], th[i], trial[i])
            f[i] = fi
            for j in range(state.shape[1]):
                state[i, j] = trial[i, j]
            _commit(params[i], state[i], th[i], fi)
        if step % out_every == 0:
            k = step // out_every
            out_x[k] = x
            out_v[k] = v
            out_a[k] = a
            out_th[k] = th
            out_f[k] = f
    return 0


@jit
def _drive_kernel(params, state, theta, out_f):  # pragma: no cover - compiled
    trial = state.copy()
    for t in range(theta.shape[0]):
        fi, _ = _takeda_trial(params, state, theta[t], trial)
        for j in range(state.shape[0]):
            state[j] = trial[j]
        _commit(params, state, theta[t], fi)
        out_f[t] = fi


# ---------------------------------------------------------------------------------------------
# state, runs, truth


@dataclass(frozen=True)
class RCState:
    """The state of ``N`` RC springs (history variables), to carry from one run to the next.

    Attributes
    ----------
    values : ndarray, shape (N, 9)
        Per spring: angle (rad), moment (N·m), largest and smallest angle so far (rad),
        zero-moment crossings aimed from for positive and negative reloading (rad), last
        loading direction (0 none, 1 positive, 2 negative), ``∫ M dθ`` (J), strength factor.
    """

    values: np.ndarray

    def __post_init__(self) -> None:
        v = np.array(self.values, dtype=float)
        if v.ndim != 2 or v.shape[1] != _N_STATE or not np.all(np.isfinite(v)):
            raise InputDataError(f"RC state: expected a finite (N, {_N_STATE}) array, got shape "
                                 f"{v.shape}")
        v.setflags(write=False)
        object.__setattr__(self, "values", v)

    @classmethod
    def virgin(cls, springs: RCSprings) -> "RCState":
        """Uncracked springs at rest."""
        v = np.zeros((springs.n_springs, _N_STATE))
        v[:, _TMAXP] = springs.theta_c
        v[:, _TMAXN] = -springs.theta_c
        v[:, _D] = 1.0
        return cls(v)

    @property
    def theta(self) -> np.ndarray:
        """Angles, rad, shape (N,)."""
        return self.values[:, _TH].copy()

    @property
    def moment(self) -> np.ndarray:
        """Moments, N·m, shape (N,)."""
        return self.values[:, _M].copy()

    @property
    def peak_rotation(self) -> np.ndarray:
        """Largest ``|θ|`` reached so far (at least the cracking rotation), rad, shape (N,)."""
        return np.maximum(self.values[:, _TMAXP], -self.values[:, _TMAXN])

    @property
    def strength_factor(self) -> np.ndarray:
        """Strength factor ``D`` of the skeleton beyond cracking, shape (N,)."""
        return self.values[:, _D].copy()

    def unloading_stiffness(self, springs: RCSprings) -> np.ndarray:
        """Small-amplitude (unloading) stiffness ``k_u`` of this state, N·m/rad, shape (N,)."""
        tm = self.peak_rotation
        return np.minimum(springs.k0, springs.k_y * (springs.theta_y / tm) ** springs.alpha)

    def dissipated_energy(self, springs: RCSprings) -> np.ndarray:
        """Energy dissipated so far, J: ``∫ M dθ − M² / (2 k_u)``, shape (N,)."""
        m = self.values[:, _M]
        return self.values[:, _EINT] - m * m / (2.0 * self.unloading_stiffness(springs))


def rayleigh_coefficients(geometry: PierGeometry, springs: RCSprings,
                          zeta: float) -> tuple[float, float]:
    """``(a0, a1)`` of ``C = a0 M + a1 K0`` with damping ratio ``zeta`` on modes 1 and 2.

    ``K0 = Bᵀ diag(k0) B`` (uncracked).  With one level: ``a0 = ζ ω1``, ``a1 = ζ / ω1``.
    """
    if not (np.isfinite(zeta) and zeta >= 0):
        raise InputDataError(f"rayleigh_zeta: expected a non-negative damping ratio, got {zeta}")
    b = angle_matrix(geometry.section_heights_m)
    k0 = b.T @ (springs.k0[:, None] * b)
    w = np.sqrt(np.sort(linalg.eigh(k0, np.diag(geometry.masses_kg), eigvals_only=True)))
    w1 = float(w[0])
    w2 = float(w[1]) if w.size > 1 else w1
    return 2.0 * zeta * w1 * w2 / (w1 + w2), 2.0 * zeta / (w1 + w2)


@dataclass(frozen=True, eq=False)
class RCRun:
    """A simulated RC run: responses and the springs' state before and after it.

    Attributes
    ----------
    response : Response
        Responses (``x, v, a, theta, moment`` of shape (T, N)); ``moment`` is the springs'.
    springs : RCSprings
        The springs.
    state_start, state_end : RCState
        Spring states at the first and the last step.
    rayleigh : tuple of float
        ``(a0, a1)`` of the damping matrix, 1/s and s.
    """

    response: Response
    springs: RCSprings
    state_start: RCState
    state_end: RCState
    rayleigh: tuple[float, float]


def _check_springs(geometry: PierGeometry, springs: RCSprings) -> None:
    if springs.n_springs != geometry.n_levels:
        raise InputDataError(f"springs: expected {geometry.n_levels} sections for "
                             f"{geometry.n_levels} levels, got {springs.n_springs}")


def integrate_rc(geometry: PierGeometry, springs: RCSprings, ag: np.ndarray, ag_dt: float, *,
                 dt: float = 0.001, output_dt: float | None = None,
                 rayleigh_zeta: float = 0.03,
                 rayleigh: tuple[float, float] | None = None,
                 x0: np.ndarray | None = None, v0: np.ndarray | None = None,
                 state: RCState | None = None, max_iter: int = 40) -> RCRun:
    """Integrate the link model with RC springs and Rayleigh damping (module docstring).

    Newmark linear acceleration (γ = 1/2, β = 1/6, as
    :func:`~pier_monitor.core.model.solver.simulate`), Newton iteration on the step with the
    springs' tangents, ground motion linearly interpolated to ``dt``.

    Parameters
    ----------
    geometry : PierGeometry
        Heights and masses (``N`` levels).
    springs : RCSprings
        The ``N`` springs.
    ag : ndarray, shape (S,)
        Ground acceleration, m/s², every ``ag_dt`` s from ``t = 0``.
    ag_dt : float
        Sampling period of ``ag``, s.
    dt : float
        Internal step, s.
    output_dt : float, optional
        Output period, s, a whole multiple of ``dt``; default ``ag_dt``.
    rayleigh_zeta : float
        Damping ratio on modes 1 and 2 of the uncracked model.
    rayleigh : tuple of float, optional
        ``(a0, a1)`` given directly (1/s, s); overrides ``rayleigh_zeta``.
    x0, v0 : ndarray, shape (N,), optional
        Initial displacement (m) and velocity (m/s) relative to the foundation.
    state : RCState, optional
        Initial spring state (e.g. the end of an earlier run); default virgin springs.  Its
        angles must be those of ``x0`` (``B x0``).
    max_iter : int
        Newton passes per step.

    Raises
    ------
    InputDataError
        On shapes, non-finite values or inconsistent initial state.
    SolverError
        If a step does not converge or the solution diverges.
    """
    _check_springs(geometry, springs)
    n = geometry.n_levels
    ag = np.asarray(ag, dtype=float)
    if ag.ndim != 1 or ag.size < 2:
        raise InputDataError(f"ag: expected a 1-D record of at least 2 samples, got shape {ag.shape}")
    if not np.all(np.isfinite(ag)):
        i = int(np.flatnonzero(~np.isfinite(ag))[0])
        raise InputDataError(f"ag: non-finite value at sample {i} (t = {i * ag_dt:.4f} s)")
    for name, val in (("ag_dt", ag_dt), ("dt", dt)):
        if not (np.isfinite(val) and val > 0):
            raise InputDataError(f"{name}: expected a positive time step, got {val}")
    output_dt = ag_dt if output_dt is None else float(output_dt)
    out_every = int(round(output_dt / dt))
    if out_every < 1 or abs(out_every * dt - output_dt) > 1e-9 * output_dt:
        raise InputDataError(f"output_dt: must be an integer multiple of dt={dt}, got {output_dt}")
    x0 = _check_vector("x0", x0, n)
    v0 = _check_vector("v0", v0, n)
    b = angle_matrix(geometry.section_heights_m)
    st0 = RCState.virgin(springs) if state is None else state
    if st0.values.shape[0] != n:
        raise InputDataError(f"state: expected {n} springs, got {st0.values.shape[0]}")
    if not np.allclose(st0.theta, b @ x0, rtol=1e-9, atol=1e-12):
        raise InputDataError(f"state: spring angles {st0.theta.tolist()} rad differ from those "
                             f"of x0, {(b @ x0).tolist()} rad")
    a0, a1 = (rayleigh_coefficients(geometry, springs, rayleigh_zeta) if rayleigh is None
              else (float(rayleigh[0]), float(rayleigh[1])))
    if not (np.isfinite(a0) and np.isfinite(a1) and a0 >= 0 and a1 >= 0):
        raise InputDataError(f"rayleigh: expected non-negative (a0, a1), got ({a0}, {a1})")
    mass = np.ascontiguousarray(geometry.masses_kg, dtype=float)
    k0 = b.T @ (springs.k0[:, None] * b)
    cmat = a0 * np.diag(mass) + a1 * k0

    duration = (ag.size - 1) * ag_dt
    n_steps = int(np.floor(duration / dt + 1e-9)) + 1
    t_fine = np.arange(n_steps) * dt
    ag_fine = np.interp(t_fine, np.arange(ag.size) * ag_dt, ag)
    n_out = (n_steps - 1) // out_every + 1
    work = np.array(st0.values, dtype=float)
    outs = [np.empty((n_out, n)) for _ in range(5)]
    code = _rc_kernel(mass, b, cmat, springs._param_matrix(), work, ag_fine, float(dt),
                      out_every, x0, v0, int(max_iter), *outs)
    if code < 0:
        raise SolverError(f"RC Newmark iteration did not converge within {max_iter} passes at "
                          f"t = {-code * dt:.4f} s")
    x, v, a, th, f = outs
    if not np.all(np.isfinite(x)):
        bad = int(np.argwhere(~np.isfinite(x))[0, 0])
        raise SolverError(f"RC solution diverged at t = {bad * output_dt:.4f} s")
    t = np.arange(n_out) * output_dt
    resp = Response(t=t, ag=ag_fine[::out_every][:n_out], x=x, v=v, a=a, theta=th, moment=f)
    return RCRun(response=resp, springs=springs, state_start=st0, state_end=RCState(work),
                 rayleigh=(a0, a1))


def simulate_rc(geometry: PierGeometry, springs: RCSprings, ag: np.ndarray, ag_dt: float, *,
                dt: float = 0.001, output_dt: float | None = None, rayleigh_zeta: float = 0.03,
                x0: np.ndarray | None = None, v0: np.ndarray | None = None,
                state: RCState | None = None) -> Response:
    """Responses of the link model with RC springs and Rayleigh damping.

    :func:`integrate_rc` without the spring states; see it for the parameters.
    """
    return integrate_rc(geometry, springs, ag, ag_dt, dt=dt, output_dt=output_dt,
                        rayleigh_zeta=rayleigh_zeta, x0=x0, v0=v0, state=state).response


def drive_spring(springs: RCSprings, section: int, theta: np.ndarray,
                 state: RCState | None = None) -> tuple[np.ndarray, RCState]:
    """Moments of one spring driven through an angle history (no dynamics).

    Parameters
    ----------
    springs : RCSprings
        The springs; only ``section`` (0-based) is driven.
    section : int
        Which spring.
    theta : ndarray, shape (T,)
        Angles, rad, from the state's angle on.
    state : RCState, optional
        Starting state of all springs (default virgin).

    Returns
    -------
    moment : ndarray, shape (T,)
        N·m.
    state : RCState
        The state after the last angle (other springs unchanged).
    """
    theta = np.ascontiguousarray(theta, dtype=float)
    if theta.ndim != 1 or not np.all(np.isfinite(theta)):
        raise InputDataError(f"theta: expected a finite 1-D angle history, got shape "
                             f"{theta.shape}")
    if not 0 <= section < springs.n_springs:
        raise InputDataError(f"section: expected 0..{springs.n_springs - 1}, got {section}")
    st = RCState.virgin(springs) if state is None else state
    work = np.array(st.values, dtype=float)
    out = np.empty_like(theta)
    _drive_kernel(springs._param_matrix()[section], work[section], theta, out)
    return out, RCState(work)


def skeleton_moment(springs: RCSprings, section: int, theta: np.ndarray) -> np.ndarray:
    """The virgin skeleton ``S(θ)`` of one section, N·m, for angles ``theta`` (rad)."""
    p = springs._param_matrix()[section]
    th = np.asarray(theta, dtype=float)
    return np.vectorize(lambda t: _skeleton(p, 1.0, float(t))[0])(th)


def idealised_yield_rotation(springs: RCSprings, peak_rotation: np.ndarray) -> np.ndarray:
    """Equal-energy idealised yield rotation of each section at its peak rotation, rad, (N,).

    The bilinear with elastic slope ``k_y`` (secant to first yield) and end point
    ``(θp, S(θp))`` enclosing the area of the virgin skeleton up to ``θp``:
    ``θ* = (2 A − Mp θp) / (k_y θp − Mp)``, at most ``Mp / k_y`` (the elastic branch extended
    to the peak moment, RC_NOTES' ``θ'y Mn / M'y`` with ``Mn = Mp``: just past first yield the
    uncracked part of the skeleton holds more energy than the elastic triangle, and the
    equal-energy point runs off); ``θy`` while ``θp <= θy``.
    """
    tp = np.asarray(peak_rotation, dtype=float)
    if tp.shape != (springs.n_springs,) or not np.all(np.isfinite(tp) & (tp >= 0)):
        raise InputDataError(f"peak_rotation: expected {springs.n_springs} non-negative "
                             f"rotations, got {tp!r}")
    out = springs.theta_y.copy()
    for i in range(springs.n_springs):
        ty = springs.theta_y[i]
        if tp[i] <= ty:
            continue
        # the skeleton is piecewise linear: its area exactly from the corner points
        corners = [0.0, springs.theta_c[i], ty, min(tp[i], springs.theta_u[i]), tp[i]]
        m = skeleton_moment(springs, i, np.array(corners))
        area = float(np.sum(0.5 * (m[1:] + m[:-1]) * np.diff(corners)))
        mp = float(m[-1])
        ky = springs.k_y[i]
        den = ky * tp[i] - mp
        cap = mp / ky  # where the elastic branch reaches the peak moment
        out[i] = cap if den <= 0.0 else min((2.0 * area - mp * tp[i]) / den, cap)
    return out


@dataclass(frozen=True)
class RCSectionTruth:
    """What an engineer compares with, per section, for one run of an RC test-bed.

    All arrays have shape (N,), sections bottom to top.

    Attributes
    ----------
    peak_rotation_rad : ndarray
        Largest ``|θ|`` the section has reached (this run and before), rad.
    idealised_yield_rotation_rad : ndarray
        Equal-energy idealised yield rotation at that peak (:func:`idealised_yield_rotation`).
    ductility_factor : ndarray
        ``peak_rotation_rad / idealised_yield_rotation_rad``.
    first_yield_rotation_rad : ndarray
        Rotation at which the reinforcement yields (the skeleton's yield point), rad.
    yielded : ndarray of bool
        Whether the peak rotation passed first yield.
    cracked : ndarray of bool
        Whether the peak rotation passed cracking.
    hysteretic_energy_J : ndarray
        Energy dissipated by the spring during this run, J.
    k_small_before, k_small_after : ndarray
        Small-amplitude (unloading) stiffness at the start and at the end of the run, N·m/rad.
    strength_factor : ndarray
        Strength factor of the skeleton at the end of the run.
    """

    peak_rotation_rad: np.ndarray
    idealised_yield_rotation_rad: np.ndarray
    ductility_factor: np.ndarray
    first_yield_rotation_rad: np.ndarray
    yielded: np.ndarray
    cracked: np.ndarray
    hysteretic_energy_J: np.ndarray
    k_small_before: np.ndarray
    k_small_after: np.ndarray
    strength_factor: np.ndarray

    @property
    def k_small_change_pct(self) -> np.ndarray:
        """Change of the small-amplitude stiffness over the run, %, shape (N,)."""
        return 100.0 * (self.k_small_after / self.k_small_before - 1.0)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        out: dict[str, Any] = {}
        for name in ("peak_rotation_rad", "idealised_yield_rotation_rad", "ductility_factor",
                     "first_yield_rotation_rad", "hysteretic_energy_J", "k_small_before",
                     "k_small_after", "strength_factor"):
            out[name] = [float(v) for v in getattr(self, name)]
        out["yielded"] = [bool(v) for v in self.yielded]
        out["cracked"] = [bool(v) for v in self.cracked]
        out["k_small_change_pct"] = [float(v) for v in self.k_small_change_pct]
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "RCSectionTruth":
        """Inverse of :meth:`as_dict`."""
        return cls(**{k: np.array(d[k], dtype=bool if k in ("yielded", "cracked") else float)
                      for k in ("peak_rotation_rad", "idealised_yield_rotation_rad",
                                "ductility_factor", "first_yield_rotation_rad", "yielded",
                                "cracked", "hysteretic_energy_J", "k_small_before",
                                "k_small_after", "strength_factor")})


def rc_truth(springs: RCSprings, state_start: RCState, state_end: RCState) -> RCSectionTruth:
    """The per-section truth of a run from the spring states before and after it."""
    peak = state_end.peak_rotation
    tid = idealised_yield_rotation(springs, peak)
    return RCSectionTruth(
        peak_rotation_rad=peak,
        idealised_yield_rotation_rad=tid,
        ductility_factor=peak / tid,
        first_yield_rotation_rad=springs.theta_y.copy(),
        yielded=peak > springs.theta_y,
        cracked=peak > springs.theta_c * (1.0 + 1e-12),
        hysteretic_energy_J=(state_end.dissipated_energy(springs)
                             - state_start.dissipated_energy(springs)),
        k_small_before=state_start.unloading_stiffness(springs),
        k_small_after=state_end.unloading_stiffness(springs),
        strength_factor=state_end.strength_factor)
