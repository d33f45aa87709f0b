"""The lumped-mass link model of a pier (SPEC §3).

Levels ``z_0 = 0`` (foundation) to ``z_N``; mass ``m_n`` at level ``n``; spring and damper
``n`` at level ``n-1``, i.e. at the bottom of section ``n``.  ``x`` is the horizontal
displacement of the masses relative to the foundation, m.  Spring angles are ``θ = B x``
(paper eqs. 3-5) and the equation of motion is (paper eq. 12)::

    M ẍ + Bᵀ diag(c) B ẋ + Bᵀ f = −M 1 a_g

All functions take time-first arrays: shape ``(T, N)`` for responses, ``(T,)`` for ``a_g``.
"""

from __future__ import annotations

import numpy as np
from scipy import linalg

from pier_monitor.core._jit import jit
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.config import PierGeometry, SpringParameters

__all__ = [
    "angle_matrix",
    "damping_matrix",
    "elastic_stiffness_matrix",
    "natural_periods",
    "spring_angles",
    "estimated_moments",
    "bilinear_step",
    "check_response_array",
    "inverse_bilinear",
    "damped_bilinear",
]


def check_response_array(name: str, arr: np.ndarray, n: int | None = None,
                         length: int | None = None) -> np.ndarray:
    """Return ``arr`` as a finite float array of shape ``(T, n)``; raise otherwise."""
    a = np.asarray(arr, dtype=float)
    if a.ndim != 2 or (n is not None and a.shape[1] != n) or (length is not None
                                                             and a.shape[0] != length):
        want = f"({length if length is not None else 'T'}, {n if n is not None else 'N'})"
        raise InputDataError(f"{name}: expected shape {want}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        t, j = np.argwhere(~np.isfinite(a))[0]
        raise InputDataError(f"{name}: non-finite value {a[t, j]} at sample {t}, column {j}")
    return a


def angle_matrix(section_heights_m: np.ndarray) -> np.ndarray:
    """The matrix ``B`` with ``θ = B x`` (paper eqs. 3-5), shape (N, N), 1/m.

    With the chord slopes ``s_n = (x_n − x_{n−1}) / h_n`` (``x_0 = 0``) the angle of
    spring ``n`` is ``θ_n = s_n − s_{n−1}`` (``s_0 = 0``).
    """
    h = np.asarray(section_heights_m, dtype=float)
    if h.ndim != 1 or h.size == 0 or np.any(~np.isfinite(h) | (h <= 0)):
        raise InputDataError(f"section heights: expected N positive values, got {h!r}")
    n = h.size
    slope = np.zeros((n, n))  # s = slope @ x
    for i in range(n):
        slope[i, i] = 1.0 / h[i]
        if i > 0:
            slope[i, i - 1] = -1.0 / h[i]
    diff = np.eye(n) - np.eye(n, k=-1)  # θ_n = s_n − s_{n−1}
    return diff @ slope


def damping_matrix(b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``C = Bᵀ diag(c) B``, shape (N, N), N·s/m."""
    return b.T @ (np.asarray(c, dtype=float)[:, None] * b)


def elastic_stiffness_matrix(b: np.ndarray, k1: np.ndarray) -> np.ndarray:
    """``K = Bᵀ diag(k1) B`` of the elastic model, shape (N, N), N/m."""
    return damping_matrix(b, k1)


def natural_periods(geometry: PierGeometry, params: SpringParameters) -> np.ndarray:
    """Undamped elastic natural periods, longest first, s, shape (N,)."""
    b = angle_matrix(geometry.section_heights_m)
    k = elastic_stiffness_matrix(b, params.k1)
    omega2 = linalg.eigh(k, np.diag(geometry.masses_kg), eigvals_only=True)
    return np.sort(2.0 * np.pi / np.sqrt(omega2))[::-1]


def spring_angles(section_heights_m: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Spring angles ``θ = B x`` for displacements ``x`` of shape (T, N); rad, (T, N)."""
    b = angle_matrix(section_heights_m)
    x = check_response_array("x", x, n=b.shape[0])
    return x @ b.T


def estimated_moments(geometry: PierGeometry, c: np.ndarray, a_rel: np.ndarray,
                      v_rel: np.ndarray, ag: np.ndarray) -> np.ndarray:
    """Restoring moments from measured motion (paper eq. 27), N·m, shape (T, N).

    ``f̂ = (Bᵀ)⁻¹ (−M (ẍ + 1 a_g)) − diag(c) B ẋ``.

    Parameters
    ----------
    geometry : PierGeometry
        Heights and masses.
    c : ndarray, shape (N,)
        Current damping estimate, N·m·s/rad.
    a_rel, v_rel : ndarray, shape (T, N)
        Relative acceleration (m/s²) and velocity (m/s) of the masses.
    ag : ndarray, shape (T,)
        Foundation (ground) acceleration, m/s².
    """
    n = geometry.n_levels
    a_rel = check_response_array("a_rel", a_rel, n=n)
    v_rel = check_response_array("v_rel", v_rel, n=n, length=a_rel.shape[0])
    ag = np.asarray(ag, dtype=float)
    if ag.shape != (a_rel.shape[0],):
        raise InputDataError(f"ag: expected shape ({a_rel.shape[0]},), got {ag.shape}")
    c = np.asarray(c, dtype=float)
    if c.shape != (n,):
        raise InputDataError(f"c: expected shape ({n},), got {c.shape}")
    b = angle_matrix(geometry.section_heights_m)
    inertia = -(a_rel + ag[:, None]) * geometry.masses_kg  # (T, N): −M(ẍ + 1 a_g)
    # Solve Bᵀ g = inertia for each time: g = inertia @ B⁻¹ (row form).
    g = linalg.solve(b.T, inertia.T).T
    return g - (v_rel @ b.T) * c


def bilinear_step(f_prev: np.ndarray, theta_prev: np.ndarray, theta: np.ndarray,
                  k1: np.ndarray, k2: np.ndarray, fy: np.ndarray) -> np.ndarray:
    """One step of the bilinear kinematic-hardening spring (SPEC §3), N·m.

    ``f = clip(f_prev + k1 (θ − θ_prev), k2 θ − s, k2 θ + s)`` with ``s = fy (1 − k2/k1)``:
    the elastic trial from the previous state, bounded by the skeleton lines through
    ``(±θy, ±fy)``.  All arguments broadcast against each other.
    """
    s = fy * (1.0 - k2 / k1)
    trial = f_prev + k1 * (theta - theta_prev)
    return np.clip(trial, k2 * theta - s, k2 * theta + s)


@jit
def _inverse_bilinear_kernel(f, k1, k2, fy, theta0, out):  # pragma: no cover - compiled
    s = fy * (1.0 - k2 / k1)
    out[0] = theta0
    for i in range(f.size - 1):
        elastic = out[i] + (f[i + 1] - f[i]) / k1
        if f[i + 1] > k2 * elastic + s:
            out[i + 1] = (f[i + 1] - s) / k2
        elif f[i + 1] < k2 * elastic - s:
            out[i + 1] = (f[i + 1] + s) / k2
        else:
            out[i + 1] = elastic


def inverse_bilinear(f: np.ndarray, k1: float, k2: float, fy: float,
                     theta0: float = 0.0) -> np.ndarray:
    """The angle history of one bilinear kinematic-hardening spring driven by its moment.

    The inverse of :func:`bilinear_step`: from ``θ_i`` and the moments ``f_i, f_{i+1}``
    (N·m), the elastic step ``θ_i + (f_{i+1} − f_i)/k1`` holds while the point stays between
    the skeleton lines ``k2 θ ± s``; beyond them the spring is on a yield line,
    ``θ = (f ∓ s)/k2``.  Unique for ``0 < k2 < k1``, and stable: moment noise does not
    accumulate, because every angle is tied to the current moment and the last reversal.

    Parameters
    ----------
    f : ndarray, shape (T,)
        Moment history, N·m, starting where the angle is ``theta0``.
    k1, k2, fy : float
        Elastic stiffness, second stiffness (N·m/rad) and yield moment (N·m).
    theta0 : float
        Angle at the first sample, rad.

    Returns
    -------
    ndarray, shape (T,)
        Angles, rad.
    """
    f = np.ascontiguousarray(f, dtype=float)
    if f.ndim != 1 or not np.all(np.isfinite(f)):
        raise InputDataError(f"f: expected a finite 1-D moment history, got shape {f.shape}")
    if not (0.0 < k2 < k1 and fy > 0.0):
        raise InputDataError(f"inverse_bilinear: need 0 < k2 < k1 and fy > 0, got k1={k1:g}, "
                             f"k2={k2:g}, fy={fy:g}")
    out = np.empty_like(f)
    _inverse_bilinear_kernel(f, float(k1), float(k2), float(fy), float(theta0), out)
    return out


@jit
def _damped_bilinear_kernel(g, dt, k1, k2, fy, c, shift, theta, f):  # pragma: no cover - compiled
    s = fy * (1.0 - k2 / k1)
    theta[0] = 0.0
    f[0] = g[0]
    a = c / dt
    for i in range(g.size - 1):
        # trapezoidal rule for c θ' = g − f, elastic branch first
        rhs = 0.5 * (g[i] - f[i] + g[i + 1])
        d = (rhs - 0.5 * f[i]) / (a + 0.5 * k1)
        th = theta[i] + d
        fe = f[i] + k1 * d
        up = k2 * th + shift + s
        lo = k2 * th + shift - s
        if fe > up:
            d = (rhs - 0.5 * (k2 * theta[i] + shift + s)) / (a + 0.5 * k2)
            th = theta[i] + d
            fe = k2 * th + shift + s
        elif fe < lo:
            d = (rhs - 0.5 * (k2 * theta[i] + shift - s)) / (a + 0.5 * k2)
            th = theta[i] + d
            fe = k2 * th + shift - s
        theta[i + 1] = th
        f[i + 1] = fe


def damped_bilinear(g: np.ndarray, dt: float, k1: float, k2: float, fy: float, c: float,
                    shift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Angle and spring-moment histories of one spring and its damper under a known moment.

    Spring ``n`` and damper ``n`` carry together the moment ``g_n`` that the accelerations
    of the masses above them impose (``c θ̇ + f(θ) = g``, SPEC §3); ``f`` follows the bilinear
    kinematic-hardening rule.  Integrated by the trapezoidal rule, exactly on each branch,
    from rest (``θ = 0``) at the first sample.

    Parameters
    ----------
    g : ndarray, shape (T,)
        Moment carried by the spring and the damper together, N·m, sampled every ``dt`` s.
    k1, k2, fy, c : float
        Spring (N·m/rad, N·m) and damper (N·m·s/rad) parameters, ``0 < k2 < k1``, ``c > 0``.
    shift : float
        Offset of the yield lines ``k2 θ + shift ± s``, N·m: the back moment that yielding
        before the first sample left (0 for a spring that never yielded).

    Returns
    -------
    theta, f : ndarray, shape (T,)
        Angle (rad) and spring moment (N·m).
    """
    g = np.ascontiguousarray(g, dtype=float)
    if g.ndim != 1 or not np.all(np.isfinite(g)):
        raise InputDataError(f"g: expected a finite 1-D moment history, got shape {g.shape}")
    if not (0.0 < k2 < k1 and fy > 0.0 and c > 0.0 and dt > 0.0):
        raise InputDataError(f"damped_bilinear: need 0 < k2 < k1, fy > 0, c > 0, dt > 0; got "
                             f"k1={k1:g}, k2={k2:g}, fy={fy:g}, c={c:g}, dt={dt:g}")
    theta = np.empty_like(g)
    f = np.empty_like(g)
    _damped_bilinear_kernel(g, float(dt), float(k1), float(k2), float(fy), float(c),
                            float(shift), theta, f)
    return theta, f
