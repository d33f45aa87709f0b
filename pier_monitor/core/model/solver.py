"""Newmark linear-acceleration solver of the nonlinear link model (SPEC §3).

γ = 1/2, β = 1/6, internal step ``dt`` (default 1 ms), ground motion linearly
interpolated to it, responses returned at a coarser output step.  Within a step the
coupled update ``ẍ → x → θ → f → ẍ`` is iterated to convergence.  The iteration uses the
tangent of the bilinear springs (Newton's method on the piecewise-linear step), so it
reaches the same fixed point as the paper's repeated substitution, exactly, usually in
one or two passes: the step is converged when the set of yielding springs no longer
changes, because the step equations are linear for a given set.

The step loop is compiled with numba when it is installed; without numba the same
code runs as plain Python (slower, identical results).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError, SolverError
from pier_monitor.core.model.link_model import angle_matrix, damping_matrix

from pier_monitor.core._jit import HAVE_NUMBA, jit as _jit

__all__ = ["Response", "simulate", "HAVE_NUMBA"]


@dataclass(frozen=True)
class Response:
    """Simulated or reproduced responses, time-first, relative to the foundation.

    Attributes
    ----------
    t : ndarray, shape (T,)
        Time, s.
    ag : ndarray, shape (T,)
        Ground (foundation) acceleration, m/s².
    x, v, a : ndarray, shape (T, N)
        Relative displacement (m), velocity (m/s) and acceleration (m/s²) of the masses.
    theta : ndarray, shape (T, N)
        Spring angles, rad.
    moment : ndarray, shape (T, N)
        Restoring moments of the springs, N·m.
    """

    t: np.ndarray
    ag: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    theta: np.ndarray
    moment: np.ndarray

    @property
    def dt(self) -> float:
        """Output sampling period, s."""
        return float(self.t[1] - self.t[0])

    def window(self, t_start: float, t_end: float) -> "Response":
        """The samples with ``t_start <= t < t_end`` (small tolerance)."""
        eps = 1e-9 * max(1.0, abs(t_end))
        sel = (self.t >= t_start - eps) & (self.t < t_end - eps)
        return Response(*(getattr(self, k)[sel] for k in ("t", "ag", "x", "v", "a", "theta",
                                                          "moment")))

    def as_dict(self) -> dict[str, np.ndarray]:
        """Arrays by name, as written to ``.npz`` files."""
        return {k: getattr(self, k) for k in ("t", "ag", "x", "v", "a", "theta", "moment")}


@_jit
def _newmark_kernel(m, b, cmat, k1, k2, s, ag, dt, out_every, x0, v0, max_iter,
                    out_x, out_v, out_a, out_th, out_f):  # pragma: no cover - compiled
    n = m.shape[0]
    n_steps = ag.shape[0]
    bt = b.T.copy()
    x = x0.copy()
    v = v0.copy()
    th = b @ x
    f = np.empty(n)
    for i in range(n):
        trial = k1[i] * th[i]
        f[i] = min(max(trial, k2[i] * th[i] - s[i]), k2[i] * th[i] + s[i])
    # initial acceleration from equilibrium
    rhs = -m * ag[0] - cmat @ v - bt @ f
    a = rhs / m
    out_x[0] = x
    out_v[0] = v
    out_a[0] = a
    out_th[0] = th
    out_f[0] = f
    h1 = dt * dt / 6.0
    state = np.zeros(n, dtype=np.int64)  # 0 elastic, 1 on a yield line
    new_state = np.zeros(n, dtype=np.int64)
    kt = np.empty(n)
    f_new = np.empty(n)
    jac = np.empty((n, n))
    worst = 0
    for step in range(1, n_steps):
        x_known = x + dt * v + (dt * dt / 3.0) * a
        v_known = v + 0.5 * dt * a
        a_new = a.copy()
        converged = False
        for it in range(max_iter):
            x_new = x_known + h1 * a_new
            th_new = b @ x_new
            for i in range(n):
                trial = f[i] + k1[i] * (th_new[i] - th[i])
                lo = k2[i] * th_new[i] - s[i]
                hi = k2[i] * th_new[i] + s[i]
                if trial <= lo:
                    f_new[i] = lo
                    new_state[i] = 1
                    kt[i] = k2[i]
                elif trial >= hi:
                    f_new[i] = hi
                    new_state[i] = 1
                    kt[i] = k2[i]
                else:
                    f_new[i] = trial
                    new_state[i] = 0
                    kt[i] = k1[i]
            if it > 0:
                same = True
                for i in range(n):
                    if new_state[i] != state[i]:
                        same = False
                if same:
                    converged = True
                    if it + 1 > worst:
                        worst = it + 1
                    break
            for i in range(n):
                state[i] = new_state[i]
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
            a_new = a_new - np.linalg.solve(jac, r)
        if not converged:
            return -step
        x = x_known + h1 * a_new
        v = v_known + 0.5 * dt * a_new
        a = a_new
        th = b @ x
        f = f_new.copy()
        if step % out_every == 0:
            k = step // out_every
            out_x[k] = x
            out_v[k] = v
            out_a[k] = a
            out_th[k] = th
            out_f[k] = f
    return worst


def _check_vector(name: str, value: np.ndarray | None, n: int) -> np.ndarray:
    if value is None:
        return np.zeros(n)
    arr = np.asarray(value, dtype=float)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise InputDataError(f"{name}: expected {n} finite values, got {arr!r}")
    return arr


def simulate(geometry: PierGeometry, params: SpringParameters, ag: np.ndarray, ag_dt: float, *,
             dt: float = 0.001, output_dt: float | None = None, x0: np.ndarray | None = None,
             v0: np.ndarray | None = None, max_iter: int = 30) -> Response:
    """Integrate the nonlinear link model under a ground acceleration record.

    Parameters
    ----------
    geometry : PierGeometry
        Section heights and masses (``N`` levels).
    params : SpringParameters
        ``k1, k2, fy, c`` of the ``N`` springs.
    ag : ndarray, shape (S,)
        Ground acceleration, m/s², sampled every ``ag_dt`` from ``t = 0``.
    ag_dt : float
        Sampling period of ``ag``, s.
    dt : float
        Internal integration step, s (SPEC: 1 ms).
    output_dt : float, optional
        Output sampling period, s; an integer multiple of ``dt``.  Default ``ag_dt``.
    x0, v0 : ndarray, shape (N,), optional
        Initial relative displacement (m) and velocity (m/s); default at rest.
    max_iter : int
        Iteration limit per step; exceeding it raises :class:`SolverError`.

    Returns
    -------
    Response
        Responses at ``t = 0, output_dt, ...`` up to the end of the record.
    """
    n = geometry.n_levels
    if params.n_springs != n:
        raise InputDataError(f"params: expected {n} springs for {n} levels, got {params.n_springs}")
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
        raise InputDataError(
            f"output_dt: must be an integer multiple of dt={dt}, got {output_dt}")
    duration = (ag.size - 1) * ag_dt
    n_steps = int(np.floor(duration / dt + 1e-9)) + 1
    t_fine = np.arange(n_steps) * dt
    ag_fine = np.interp(t_fine, np.arange(ag.size) * ag_dt, ag)
    n_out = (n_steps - 1) // out_every + 1

    b = angle_matrix(geometry.section_heights_m)
    cmat = damping_matrix(b, params.c)
    s = params.fy * (1.0 - params.k2 / params.k1)
    outs = [np.empty((n_out, n)) for _ in range(5)]
    worst = _newmark_kernel(np.ascontiguousarray(geometry.masses_kg, dtype=float), b, cmat,
                            np.ascontiguousarray(params.k1), np.ascontiguousarray(params.k2), s,
                            ag_fine, float(dt), out_every, _check_vector("x0", x0, n),
                            _check_vector("v0", v0, n), int(max_iter), *outs)
    if worst < 0:
        raise SolverError(
            f"Newmark iteration did not converge within {max_iter} passes at t = {-worst * dt:.4f} s")
    x, v, a, th, f = outs
    if not np.all(np.isfinite(x)):
        bad = int(np.argwhere(~np.isfinite(x))[0, 0])
        raise SolverError(f"solution diverged at t = {bad * output_dt:.4f} s (time step too large?)")
    t = np.arange(n_out) * output_dt
    return Response(t=t, ag=ag_fine[::out_every][:n_out], x=x, v=v, a=a, theta=th, moment=f)
