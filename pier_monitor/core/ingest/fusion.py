"""Velocity and displacement from accelerometers and wire transducers (Kalman/RTS smoother).

Integrating accelerations and removing a trend leaves mm/s velocity errors that ruin the
identification; wires alone are too noisy to difference.  Per channel, a linear Gaussian
state-space model with state ``[x, ẋ]`` is driven by the measured acceleration (linear
acceleration between samples, as the Newmark solver assumes) and observed by the wire::

    x_{k+1} = x_k + h ẋ_k + h²/3 a_k + h²/6 a_{k+1} + w_x
    ẋ_{k+1} = ẋ_k + h/2 (a_k + a_{k+1})           + w_v

The process noise has the part that the accelerometer noise ``σ_a`` explains and an extra
white-acceleration part of spectral density ``q`` (the integration rule's own error and any
unmodelled motion), which is estimated per channel by maximising the innovations'
likelihood.  A Rauch-Tung-Striebel pass then gives smoothed ``x, ẋ`` and their standard
deviations.  Run it at the sensor rate before resampling: halving ``h`` roughly halves the
velocity error.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pier_monitor.core._jit import jit
from pier_monitor.core.errors import InputDataError

__all__ = ["FusedMotion", "fuse_acceleration_displacement"]


@dataclass(frozen=True)
class FusedMotion:
    """Smoothed motion of ``C`` channels, time-first.

    Attributes
    ----------
    x, v : ndarray, shape (T, C)
        Displacement (m) and velocity (m/s).
    x_sigma, v_sigma : ndarray, shape (T, C)
        Their posterior standard deviations.
    q : ndarray, shape (C,)
        Estimated extra process-noise density per channel, (m/s²)²·s.
    dx_sigma, dv_sigma : ndarray, shape (T, C)
        Standard deviations of the increments from sample k to k+1 (last row repeated).
        The smoothed errors are correlated in time, so these are far below
        ``√2 x_sigma``: what matters for quantities built from increments.
    """

    x: np.ndarray
    v: np.ndarray
    x_sigma: np.ndarray
    v_sigma: np.ndarray
    q: np.ndarray
    dx_sigma: np.ndarray
    dv_sigma: np.ndarray


@jit
def _kalman_rts(a, z, h, sigma_a, sigma_x, q, smooth):  # pragma: no cover - compiled
    """One channel.  Returns (log-likelihood, x, v, var_x, var_v, var_dx, var_dv).

    ``var_dx[k]``, ``var_dv[k]``: variance of the smoothed increment from sample k to k+1
    (from the lag-one smoothed cross-covariance ``P_{k+1|N} G_kᵀ``); last entry repeated.
    """
    n = a.shape[0]
    # process noise: accelerometer noise through the input weights, plus white acceleration q
    g0a, g0b, g1a, g1b = h * h / 3.0, h * h / 6.0, 0.5 * h, 0.5 * h
    sa2 = sigma_a * sigma_a
    q00 = sa2 * (g0a * g0a + g0b * g0b) + q * h ** 3 / 3.0
    q01 = sa2 * (g0a * g1a + g0b * g1b) + q * h * h / 2.0
    q11 = sa2 * (g1a * g1a + g1b * g1b) + q * h
    r = sigma_x * sigma_x
    mx = np.empty(n)
    mv = np.empty(n)
    p00 = np.empty(n)
    p01 = np.empty(n)
    p11 = np.empty(n)
    px = np.empty(n)  # predicted means and covariances, for the smoother
    pv = np.empty(n)
    pp00 = np.empty(n)
    pp01 = np.empty(n)
    pp11 = np.empty(n)
    # initial state: at the first displacement reading, velocity unknown
    first = 0
    while first < n - 1 and np.isnan(z[first]):
        first += 1
    x, v = z[first], 0.0
    c00, c01, c11 = r, 0.0, 1.0
    loglik = 0.0
    vdx = np.zeros(n)
    vdv = np.zeros(n)
    for k in range(n):
        if k > 0:
            xp = x + h * v + g0a * a[k - 1] + g0b * a[k]
            vp = v + g1a * a[k - 1] + g1b * a[k]
            d00 = c00 + 2.0 * h * c01 + h * h * c11 + q00
            d01 = c01 + h * c11 + q01
            d11 = c11 + q11
        else:
            xp, vp, d00, d01, d11 = x, v, c00, c01, c11
        px[k], pv[k], pp00[k], pp01[k], pp11[k] = xp, vp, d00, d01, d11
        if np.isnan(z[k]):  # no displacement reading at this sample (a slower sensor)
            x, v, c00, c01, c11 = xp, vp, d00, d01, d11
        else:
            s = d00 + r
            innov = z[k] - xp
            if k > 0:
                loglik += -0.5 * (np.log(2.0 * np.pi * s) + innov * innov / s)
            k0 = d00 / s
            k1 = d01 / s
            x = xp + k0 * innov
            v = vp + k1 * innov
            c00 = (1.0 - k0) * d00
            c01 = (1.0 - k0) * d01
            c11 = d11 - k1 * d01
        mx[k], mv[k], p00[k], p01[k], p11[k] = x, v, c00, c01, c11
    if smooth:
        for k in range(n - 2, -1, -1):
            # gain G = P_k F^T Pp_{k+1}^{-1}
            a00 = p00[k] + h * p01[k]
            a01 = p01[k]
            a10 = p01[k] + h * p11[k]
            a11 = p11[k]
            det = pp00[k + 1] * pp11[k + 1] - pp01[k + 1] * pp01[k + 1]
            i00 = pp11[k + 1] / det
            i01 = -pp01[k + 1] / det
            i11 = pp00[k + 1] / det
            g00 = a00 * i00 + a01 * i01
            g01 = a00 * i01 + a01 * i11
            g10 = a10 * i00 + a11 * i01
            g11 = a10 * i01 + a11 * i11
            dx = mx[k + 1] - px[k + 1]
            dv = mv[k + 1] - pv[k + 1]
            mx[k] += g00 * dx + g01 * dv
            mv[k] += g10 * dx + g11 * dv
            e00 = p00[k + 1] - pp00[k + 1]
            e01 = p01[k + 1] - pp01[k + 1]
            e11 = p11[k + 1] - pp11[k + 1]
            n00 = p00[k] + g00 * g00 * e00 + 2.0 * g00 * g01 * e01 + g01 * g01 * e11
            n01 = p01[k] + g00 * g10 * e00 + (g00 * g11 + g01 * g10) * e01 + g01 * g11 * e11
            n11 = p11[k] + g10 * g10 * e00 + 2.0 * g10 * g11 * e01 + g11 * g11 * e11
            p00[k], p01[k], p11[k] = n00, n01, n11
            # cross-covariance of the smoothed states k+1 and k: P_{k+1|N} G_kᵀ
            c00 = p00[k + 1] * g00 + p01[k + 1] * g01
            c11 = p01[k + 1] * g10 + p11[k + 1] * g11
            vdx[k] = max(p00[k] + p00[k + 1] - 2.0 * c00, 0.0)
            vdv[k] = max(p11[k] + p11[k + 1] - 2.0 * c11, 0.0)
        vdx[n - 1] = vdx[n - 2]
        vdv[n - 1] = vdv[n - 2]
    return loglik, mx, mv, p00, p11, vdx, vdv


def fuse_acceleration_displacement(acc: np.ndarray, disp: np.ndarray, rate_hz: float,
                                   sigma_acc: float | np.ndarray, sigma_disp: float | np.ndarray,
                                   q_grid: np.ndarray | None = None) -> FusedMotion:
    """Smoothed displacement and velocity of each channel from acceleration and displacement.

    Parameters
    ----------
    acc : ndarray, shape (T, C)
        Relative acceleration of each channel, m/s².
    disp : ndarray, shape (T, C)
        Relative displacement of the same channels (wire transducers, GNSS), m; NaN where
        a slower sensor has no reading.
    rate_hz : float
        Sampling rate of both, Hz.
    sigma_acc, sigma_disp : float or ndarray of shape (C,)
        Noise standard deviations, m/s² and m.
    q_grid : ndarray, optional
        Candidate extra process-noise densities, (m/s²)²·s; default a log grid 1e-10 .. 1e-1.

    Returns
    -------
    FusedMotion
    """
    acc = np.asarray(acc, dtype=float)
    disp = np.asarray(disp, dtype=float)
    if acc.ndim != 2 or acc.shape != disp.shape or acc.shape[0] < 10:
        raise InputDataError(f"acc and disp: expected equal shapes (T >= 10, C), got {acc.shape} "
                             f"and {disp.shape}")
    if not (np.all(np.isfinite(acc)) and not np.any(np.isinf(disp))
            and np.isfinite(disp).any(axis=0).all()):
        raise InputDataError("acc and disp: non-finite samples must be handled before fusion "
                             "(disp may be NaN where a slower sensor has no reading)")
    if not (np.isfinite(rate_hz) and rate_hz > 0):
        raise InputDataError(f"rate_hz: expected a positive rate, got {rate_hz}")
    n_ch = acc.shape[1]
    sig_a = np.broadcast_to(np.asarray(sigma_acc, dtype=float), (n_ch,))
    sig_x = np.broadcast_to(np.asarray(sigma_disp, dtype=float), (n_ch,))
    if np.any(sig_a <= 0) or np.any(sig_x <= 0):
        raise InputDataError("sigma_acc and sigma_disp must be positive")
    grid = np.geomspace(1e-10, 1e-1, 19) if q_grid is None else np.asarray(q_grid, dtype=float)
    h = 1.0 / rate_hz
    out = {k: np.empty_like(acc) for k in ("x", "v", "vx", "vv", "vdx", "vdv")}
    q_best = np.empty(n_ch)
    for c in range(n_ch):
        a_c, z_c = np.ascontiguousarray(acc[:, c]), np.ascontiguousarray(disp[:, c])
        lls = [(_kalman_rts(a_c, z_c, h, sig_a[c], sig_x[c], q, False)[0], q) for q in grid]
        i = int(np.argmax([ll for ll, _ in lls]))
        # refine around the best grid point on a finer log grid
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        fine = np.geomspace(lo, hi, 9)
        q = max(((_kalman_rts(a_c, z_c, h, sig_a[c], sig_x[c], qq, False)[0], qq) for qq in fine),
                key=lambda t: t[0])[1]
        _, x, v, vx, vv, vdx, vdv = _kalman_rts(a_c, z_c, h, sig_a[c], sig_x[c], q, True)
        for key, arr in (("x", x), ("v", v), ("vx", vx), ("vv", vv), ("vdx", vdx), ("vdv", vdv)):
            out[key][:, c] = arr
        q_best[c] = q
    return FusedMotion(x=out["x"], v=out["v"], x_sigma=np.sqrt(np.maximum(out["vx"], 0.0)),
                       v_sigma=np.sqrt(np.maximum(out["vv"], 0.0)), q=q_best,
                       dx_sigma=np.sqrt(out["vdx"]), dv_sigma=np.sqrt(out["vdv"]))
