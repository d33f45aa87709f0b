"""Physics-only equation-error fit of the spring parameters (the PINN's initializer).

On consecutive samples ``i → i+1`` of a window, the bilinear spring of SPEC §3 says::

    f_{i+1} = clip(f_i + k1 (θ_{i+1} − θ_i), k2 θ_{i+1} − s, k2 θ_{i+1} + s),  s = fy (1 − k2/k1)

and the equation of motion, multiplied by ``(Bᵀ)⁻¹``, says ``f + diag(c) θ̇ = g`` with
``g = (Bᵀ)⁻¹ (−M (ẍ + 1 a_g))``.  With measured moments, ``c`` follows from the second by
linear least squares and ``k1, k2, fy`` from the first; without them, ``f = g − c θ̇``
(the paper's eq. 27) and all four parameters come from the first.  Each spring is fitted on
its own (``f_n`` depends on ``c_n`` only):

1. ``k1`` (and ``c``) by a robust regression of the increments on the pairs that behave
   elastically (iterative trimming of the pairs that yield);
2. ``k2, fy`` with ``k1, c`` held by a global search: for each of 41 ratios ``k2/k1`` in
   [0, 0.5] the exact least cost over ``fy`` (:func:`_profile`, one sort per ratio), then
   local least-squares fits from the four best local minima of that profile that lie
   apart, lowest cost wins.  It replaced 24 local fits from a 3 × 8 grid of starts.  On the
   held-out tuning seeds 620-623 of the fully measured layout (both piers: 8 cases, 40
   sections, 640 spring fits) the spring fits of an identification (the measured window's
   and its members') took 29 instead of 76 s of CPU time (the whole identification 37
   instead of 87 s); states, flags and the DF intervals' coverage of the true DF were
   unchanged, DFs within 1e-6, interval bounds within 1e-3, the measured windows' fit
   costs within 1e-8 except two sections that did not yield (+0.034 %, −0.040 %).  On the
   same inputs, of the 180 fits that yielded 3 cost more (at most
   +0.025 %) and 4 less (down to −0.11 %), the others within 1e-6; of the 460 that did not,
   whose ``k2, fy`` lie on a plateau of the cost, the joint step below ended up to 2.4 %
   costlier in 39 and cheaper in 40 (none changed its yield decision).  A grid of
   ``fy/max|f|`` in steps of 0.01 instead of the exact minimum missed a valley narrower than
   its step (a yielded section's fit 0.22 % costlier, its DF 1.0076 instead of 1.0067);
3. all parameters of the spring jointly from the best start.

A spring whose bilinear fit is no better than the elastic one never yielded: its ``k2`` and
``fy`` are not identifiable and are flagged (``fy`` then carries only the lower bound
``max |f|``).  This module uses no truth and no torch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, optimize

from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.link_model import angle_matrix, check_response_array

__all__ = ["SpringFit", "EquationErrorFit", "inertia_moments", "fit_equation_error",
           "fit_window", "yield_test", "robust_increments"]


@dataclass(frozen=True)
class SpringFit:
    """Fit of one spring.

    Attributes
    ----------
    k1, k2, fy, c : float
        Estimates (SI).  ``k2``/``fy`` are meaningless when ``yielded`` is false.
    yielded : bool
        The data show yielding: the bilinear fit is clearly better than the elastic one.
    cost_bilinear, cost_elastic : float
        Mean squared hysteresis residuals, (N·m)².
    n_yield_pairs : int
        Pairs that end on a yield line under the fitted parameters.
    """

    k1: float
    k2: float
    fy: float
    c: float
    yielded: bool
    cost_bilinear: float
    cost_elastic: float
    n_yield_pairs: int


@dataclass(frozen=True)
class EquationErrorFit:
    """Per-spring fits and the resulting parameter set."""

    springs: tuple[SpringFit, ...]
    params: SpringParameters

    @property
    def yielded(self) -> np.ndarray:
        """Boolean per spring, shape (N,)."""
        return np.array([s.yielded for s in self.springs])


def inertia_moments(geometry: PierGeometry, a_rel: np.ndarray, ag: np.ndarray) -> np.ndarray:
    """``g = (Bᵀ)⁻¹ (−M (ẍ + 1 a_g))``, the moments the springs and dampers carry, (T, N), N·m."""
    n = geometry.n_levels
    a_rel = check_response_array("a_rel", a_rel, n=n)
    ag = np.asarray(ag, dtype=float)
    if ag.shape != (a_rel.shape[0],):
        raise InputDataError(f"ag: expected shape ({a_rel.shape[0]},), got {ag.shape}")
    b = angle_matrix(geometry.section_heights_m)
    return linalg.solve(b.T, (-(a_rel + ag[:, None]) * geometry.masses_kg).T).T


def _hyst_residual(f: np.ndarray, th: np.ndarray, k1: float, k2: float, fy: float) -> np.ndarray:
    s = fy * (1.0 - k2 / k1)
    trial = f[:-1] + k1 * np.diff(th)
    return f[1:] - np.clip(trial, k2 * th[1:] - s, k2 * th[1:] + s)


def robust_increments(df: np.ndarray, cols: np.ndarray, n_iter: int = 10,
                       rows: np.ndarray | None = None) -> np.ndarray:
    """Robust least squares of ``df ≈ cols @ p`` (``cols`` of 1 or 2 columns).

    The pairs that yield follow another slope, possibly on many pairs, so plain trimming
    from the all-pairs fit can lock onto the wrong branch.  Least-trimmed-squares
    concentration steps (keep the half with the smallest residuals) from robust starts
    find the elastic branch; then pairs beyond 4 robust sigmas are trimmed and refitted.
    ``rows`` restricts the fit to a subset of pairs (e.g. the unloading ones).
    """
    if rows is not None and np.count_nonzero(rows) >= 4 * cols.shape[1]:
        df, cols = df[rows], cols[rows]
    n = df.size
    half = max(cols.shape[1] + 1, n // 2)
    big = np.abs(cols[:, 0]) > np.median(np.abs(cols[:, 0]))

    def slope_given(c2: float) -> np.ndarray:
        rest = df - (cols[:, 1] * c2 if cols.shape[1] > 1 else 0.0)
        k = float(np.median(rest[big] / cols[big, 0]))
        return np.array([k, c2]) if cols.shape[1] > 1 else np.array([k])

    if cols.shape[1] == 1:
        starts = [slope_given(0.0)]
    else:
        c_ls = np.linalg.lstsq(cols, df, rcond=None)[0][1]
        scale = max(abs(c_ls), 1e-12 * np.abs(df).max() / (np.abs(cols[:, 1]).max() + 1e-300))
        starts = [slope_given(c2) for c2 in np.concatenate(([0.0], scale * np.geomspace(1e-2, 1e2, 25)))]
    best_p, best_cost = None, np.inf
    for p in starts:
        for _ in range(n_iter):
            r = np.abs(df - cols @ p)
            keep = np.argsort(r)[:half]
            p = np.linalg.lstsq(cols[keep], df[keep], rcond=None)[0]
        cost = float(np.sort((df - cols @ p) ** 2)[:half].sum())
        if cost < best_cost:
            best_p, best_cost = p, cost
    p = best_p
    keep = np.ones(n, dtype=bool)
    for _ in range(n_iter):
        r = df - cols @ p
        scale = 1.4826 * np.median(np.abs(r)) + 1e-300
        new_keep = np.abs(r) < 4.0 * scale
        if new_keep.sum() < half or np.array_equal(new_keep, keep):
            break
        keep = new_keep
        p = np.linalg.lstsq(cols[keep], df[keep], rcond=None)[0]
    return p


def _levels_fit(theta: np.ndarray, y: np.ndarray, theta_dot: np.ndarray | None,
                elastic: np.ndarray) -> np.ndarray | None:
    """``k1`` (and ``c``) from the levels of the elastic stretches rather than increments.

    Within a stretch of consecutive elastic pairs the spring follows one elastic line,
    ``f = k1 θ + b`` (``b`` the stretch's offset), so ``y = k1 θ [+ c θ̇] + b_s`` holds sample
    by sample (``y`` = measured moment, or ``g`` when ``c`` is fitted too).  Regressing levels
    instead of increments keeps the sensor noise from biasing ``k1`` (errors in variables
    grow as the increments shrink, as on lightly loaded springs).  Returns ``[k1]`` or
    ``[k1, c]``, or None when there are too few elastic stretches.
    """
    seg = np.concatenate(([0], np.cumsum(~elastic)))  # samples i, i+1 share a stretch if elastic
    counts = np.bincount(seg)
    use = counts[seg] >= 5
    if np.count_nonzero(use) < 20:
        return None
    s_id = seg[use]
    cols = [theta[use]] + ([theta_dot[use]] if theta_dot is not None else [])
    yy = y[use]

    def demean(arr: np.ndarray) -> np.ndarray:
        means = np.bincount(s_id, weights=arr) / np.maximum(np.bincount(s_id), 1)
        return arr - means[s_id]

    mat = np.column_stack([demean(c_) for c_ in cols])
    return np.linalg.lstsq(mat, demean(yy), rcond=None)[0]


def yield_test(theta: np.ndarray, f: np.ndarray, k1: float, k2: float, fy: float,
               yield_score: float = 50.0) -> tuple[bool, float, float, int]:
    """Whether one spring's angle/moment history shows yielding.

    Compares the bilinear model with the elastic one (no yield) on consecutive pairs: the
    spring yielded when some pairs end on a yield line and the yield branch lowers the
    summed squared residuals by more than ``yield_score`` times the bilinear mean squared
    residual (an F-type test against the noise floor).

    Parameters
    ----------
    theta, f : ndarray, shape (T,)
        Angle (rad) and moment (N·m) history.
    k1, k2, fy : float
        The fitted spring.

    Returns
    -------
    yielded, cost_bilinear, cost_elastic, n_yield_pairs
    """
    cost_bilinear = float(np.mean(_hyst_residual(f, theta, k1, k2, fy) ** 2))
    fmax = float(np.max(np.abs(f)))
    cost_elastic = float(np.mean(_hyst_residual(f, theta, k1, 0.0, 1e6 * fmax + 1.0) ** 2))
    s = fy * (1 - k2 / k1)
    trial = f[:-1] + k1 * np.diff(theta)
    n_yield = int(np.sum((trial >= k2 * theta[1:] + s) | (trial <= k2 * theta[1:] - s)))
    gain = (theta.size - 1) * (cost_elastic - cost_bilinear) / max(cost_bilinear, 1e-300)
    return bool(n_yield > 0 and gain > yield_score), cost_bilinear, cost_elastic, n_yield


#: The ratios ``k2/k1`` of the global search for a spring's ``(k2/k1, fy/max|f|)``
#: (:func:`_grid_starts`), up to the local fits' bound (a minimum may lie on it);
#: ``fy/max|f|`` is searched exactly over the local fits' range :data:`SHARE_RANGE`.
GRID_RATIOS = np.linspace(0.0, 0.5, 41)
SHARE_RANGE = (1e-3, 2.0)
#: Local fits from the profile's best local minima, at least this far apart in
#: ``(k2/k1, fy/max|f|)`` (either coordinate).
GRID_POLISHED = 4
GRID_APART = (0.05, 0.1)


def _profile(f: np.ndarray, theta: np.ndarray, k1: float, fmax: float) -> tuple[np.ndarray,
                                                                                 np.ndarray]:
    """For each ratio of :data:`GRID_RATIOS`, the least summed squared hysteresis residuals
    (:func:`_hyst_residual`) with ``k1`` held over ``fy/fmax`` in :data:`SHARE_RANGE`, and
    the ``fy/fmax`` that gives it: ``(cost, share)``, each of shape (R,).

    With ``f`` held a pair's residual depends on the parameters through its clipping bounds
    alone: with ``d`` the trial moment less the yield lines' mid-line ``k2 θ`` and
    ``s = fy (1 − k2/k1)``, a pair with ``|d| ≤ s`` keeps its elastic residual and one beyond
    is on a yield line.  Sorted by ``|d|``, the pairs beyond ``s`` are a tail, so between
    consecutive ``|d|`` the cost is a quadratic in ``s``; one sort and cumulative sums per
    ratio give every piece's minimum, hence the exact minimum over ``s`` (no pass per trial
    ``fy``, and no valley of ``fy`` narrower than a grid step missed)."""
    trial = f[:-1] + k1 * np.diff(theta)
    th1, f1 = theta[1:], f[1:]
    q2 = (f1 - trial) ** 2
    m = trial.size
    tail = m - np.arange(m + 1)  # pairs on a yield line when the first n are within bounds
    cost = np.empty(GRID_RATIOS.size)
    share = np.empty(GRID_RATIOS.size)
    for i, ratio in enumerate(GRID_RATIOS):
        mid = (k1 * ratio) * th1
        d, e = trial - mid, f1 - mid
        order = np.argsort(np.abs(d))
        c0, ce, cd = (np.concatenate(([0.0], np.cumsum(v[order])))
                      for v in (q2, e * e, np.sign(d) * e))
        knots = np.concatenate(([0.0], np.abs(d)[order], [np.inf]))
        scale = fmax * (1.0 - ratio)
        lo = np.maximum(knots[:-1], SHARE_RANGE[0] * scale)
        hi = np.minimum(knots[1:], SHARE_RANGE[1] * scale)
        dt = cd[m] - cd
        s = np.clip(np.where(tail > 0, dt / np.maximum(tail, 1), lo), lo, hi)
        piece = c0 + (ce[m] - ce) - 2.0 * s * dt + s * s * tail
        piece[lo > hi] = np.inf
        j = int(np.argmin(piece))
        cost[i], share[i] = piece[j], s[j] / scale
    return cost, share


def _grid_starts(f: np.ndarray, theta: np.ndarray, k1: float, fmax: float) -> list[np.ndarray]:
    """Starts of the local fits of ``(k2/k1, fy/fmax)`` with ``k1`` held: the ratios that are
    local minima of :func:`_profile` among their neighbours, each with its best share,
    lowest first, each at least :data:`GRID_APART` from those taken and of another cost (of
    a plateau, such as the elastic spring's where no pair clips, one point), at most
    :data:`GRID_POLISHED`."""
    cost, share = _profile(f, theta, k1, fmax)
    padded = np.pad(cost, 1, constant_values=np.inf)
    minima = np.flatnonzero(np.isfinite(cost) & (cost <= np.minimum(padded[:-2], padded[2:])))
    starts: list[np.ndarray] = []
    costs: list[float] = []
    for k in minima[np.argsort(cost[minima], kind="stable")]:
        x = np.array([GRID_RATIOS[k], share[k]])
        if any(abs(cost[k] - c_) <= 1e-9 * abs(c_) for c_ in costs) or any(
                np.all(np.abs(x - x_) < GRID_APART) for x_ in starts):
            continue
        starts.append(x)
        costs.append(float(cost[k]))
        if len(starts) == GRID_POLISHED:
            break
    return starts or [np.array([0.1, 0.65])]  # no finite cost: the middle of the range


def _fit_one(theta: np.ndarray, g: np.ndarray, theta_dot: np.ndarray, f_meas: np.ndarray | None,
             init: tuple[float, float, float, float], yield_score: float) -> SpringFit:
    k1_0, k2_0 = init[0], init[1]  # the design fy, c are not needed: the data give them
    if f_meas is not None:
        # c from f + c θ̇ = g (linear), k1 from elastic increments of the measured moments
        c = float(np.clip(np.dot(theta_dot, g - f_meas) / max(np.dot(theta_dot, theta_dot),
                                                                1e-300), 0.0, None))
        unloading = f_meas[:-1] * np.diff(f_meas) < 0  # moving back towards zero: elastic
        k1 = float(robust_increments(np.diff(f_meas), np.diff(theta)[:, None],
                                      rows=unloading)[0])

        def moments(c_: float) -> np.ndarray:
            return f_meas
    else:
        cols = np.column_stack([np.diff(theta), np.diff(theta_dot)])
        unloading = g[:-1] * np.diff(g) < 0
        k1, c = (float(v) for v in robust_increments(np.diff(g), cols, rows=unloading))
        c = max(c, 0.0)

        def moments(c_: float) -> np.ndarray:
            return g - c_ * theta_dot
    k1 = k1 if k1 > 0 else k1_0
    f = moments(c)
    fmax = float(np.max(np.abs(f)))

    # global search for (k2, fy) with k1, c held: a grid, then local fits from its best minima
    def res_k2fy(p: np.ndarray) -> np.ndarray:
        return _hyst_residual(f, theta, k1, k1 * p[0], fmax * p[1])

    best = None
    for start in _grid_starts(f, theta, k1, fmax):
        sol = optimize.least_squares(res_k2fy, start, bounds=([0.0, 1e-3], [0.5, 2.0]),
                                     x_scale=[0.1, 0.1], method="trf")
        if best is None or sol.cost < best.cost:
            best = sol
    k2, fy = k1 * float(best.x[0]), fmax * float(best.x[1])

    # joint refinement of the spring
    free_c = f_meas is None
    x0 = np.array([1.0, max(k2 / k1, 1e-4), fy / fmax] + ([1.0] if free_c else []))
    c_ref = max(c, 1e-6 * k1)

    def res_all(p: np.ndarray) -> np.ndarray:
        cc = c_ref * p[3] if free_c else c
        return _hyst_residual(moments(cc), theta, k1 * p[0], k1 * p[0] * p[1], fmax * p[2])

    lo = [0.5, 0.0, 1e-3] + ([0.0] if free_c else [])
    hi = [2.0, 0.5, 2.0] + ([10.0] if free_c else [])
    sol = optimize.least_squares(res_all, np.clip(x0, lo, hi), bounds=(lo, hi), method="trf",
                                 x_scale="jac")
    k1 = k1 * float(sol.x[0])
    k2 = k1 * float(sol.x[1])
    fy = fmax * float(sol.x[2])
    if free_c:
        c = c_ref * float(sol.x[3])
    # k1 (and c) once more from the levels of the elastic stretches, then k2, fy with them held
    s_ = fy * (1 - k2 / k1)
    f = moments(c)
    trial = f[:-1] + k1 * np.diff(theta)
    elastic = (trial < k2 * theta[1:] + s_) & (trial > k2 * theta[1:] - s_)
    lv = _levels_fit(theta, f, None, elastic)
    if lv is not None and lv[0] > 0:
        k1 = float(lv[0])
        fmax = float(np.max(np.abs(f)))
        sol = optimize.least_squares(
            lambda p: _hyst_residual(f, theta, k1, k1 * p[0], fmax * p[1]),
            np.clip([k2 / k1, fy / fmax], [0.0, 1e-3], [0.5, 2.0]),
            bounds=([0.0, 1e-3], [0.5, 2.0]), x_scale=[0.1, 0.1], method="trf")
        k2, fy = k1 * float(sol.x[0]), fmax * float(sol.x[1])
    yielded, cost_bilinear, cost_elastic, n_yield = yield_test(theta, f, k1, k2, fy, yield_score)
    if not yielded:
        # elastic spring: one elastic line over the window; fy only bounded below
        lv = _levels_fit(theta, f, None, np.ones(theta.size - 1, dtype=bool))
        if lv is not None and lv[0] > 0:
            k1 = float(lv[0])
        fy = float(np.max(np.abs(f)))
        k2 = min(k2_0, 0.5 * k1) if k2_0 > 0 else 0.1 * k1
        n_yield = 0
    return SpringFit(k1=k1, k2=k2, fy=fy, c=c, yielded=yielded, cost_bilinear=cost_bilinear,
                     cost_elastic=cost_elastic, n_yield_pairs=n_yield)


def fit_equation_error(geometry: PierGeometry, x: np.ndarray, v: np.ndarray, a: np.ndarray,
                       ag: np.ndarray, init: SpringParameters, moments: np.ndarray | None = None,
                       yield_score: float = 50.0) -> EquationErrorFit:
    """Fit ``k1, k2, fy, c`` of every spring to a window of measured responses.

    Parameters
    ----------
    geometry : PierGeometry
        Heights and masses.
    x, v, a : ndarray, shape (T, N)
        Relative displacement (m), velocity (m/s), acceleration (m/s²), uniformly sampled.
    ag : ndarray, shape (T,)
        Foundation acceleration, m/s².
    init : SpringParameters
        Starting values; used only where the data say nothing (elastic springs' ``k2``).
    moments : ndarray, shape (T, N), optional
        Measured restoring moments, N·m; when absent they are estimated (eq. 27).
    yield_score : float
        A spring counts as yielded when the yield branch lowers the summed squared
        residuals by more than this many times the bilinear fit's mean squared residual
        (an F-type test against the noise floor).
    """
    n = geometry.n_levels
    x = check_response_array("x", x, n=n)
    t_len = x.shape[0]
    v = check_response_array("v", v, n=n, length=t_len)
    a = check_response_array("a", a, n=n, length=t_len)
    if moments is not None:
        moments = check_response_array("moments", moments, n=n, length=t_len)
    if init.n_springs != n:
        raise InputDataError(f"init: expected {n} springs, got {init.n_springs}")
    if t_len < 10:
        raise InputDataError(f"window: expected at least 10 samples, got {t_len}")
    b = angle_matrix(geometry.section_heights_m)
    theta, theta_dot = x @ b.T, v @ b.T
    g = inertia_moments(geometry, a, ag)
    fits = tuple(
        _fit_one(theta[:, i], g[:, i], theta_dot[:, i],
                 None if moments is None else moments[:, i],
                 (init.k1[i], init.k2[i], init.fy[i], init.c[i]), yield_score)
        for i in range(n))
    params = SpringParameters(np.array([f.k1 for f in fits]), np.array([f.k2 for f in fits]),
                              np.array([f.fy for f in fits]), np.array([f.c for f in fits]))
    return EquationErrorFit(springs=fits, params=params)


def fit_window(window: MeasuredWindow, yield_score: float = 50.0) -> EquationErrorFit:
    """:func:`fit_equation_error` of a measured window: its responses, foundation motion,
    measured moments where it has them, and its design values as the start."""
    return fit_equation_error(window.geometry, window.x, window.v, window.a, window.ag,
                              window.design, moments=window.moments, yield_score=yield_score)
