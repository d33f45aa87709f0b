"""Figures of an identification: damage profile, hysteresis, responses, training (PNG).

All figures are drawn with Matplotlib's object API on the Agg canvas (no ``pyplot``, no
global backend switch), so that a ROS node can make them in its worker thread (the style is
set with a temporary ``rc_context``: draw from one thread at a time).  Every
figure has a fixed size (``*_FIGSIZE_IN`` at :data:`FIGURE_DPI`), names the pier and event in
its title and writes its units on every axis (SI, with a prefix where it reads better:
GN·m/rad, MN·m, mrad, mm).

* :func:`plot_profile` — the paper's Fig. 18: ``k1`` and the ductility factor along the
  height, one step line per event, the DF panel shaded intact / suspicious / damaged; error
  bars give the 90 % interval of an ensemble identification.
* :func:`plot_hysteresis` — reproduced moment–rotation loops of every spring with the
  identified bilinear skeleton (paper Fig. 9), over the loops of the ensemble's members when
  they are given.
* :func:`plot_responses` — measured against reproduced relative displacement and
  acceleration of every level over time, with the members' 90 % band when given.
* :func:`plot_training` — loss terms and parameters per epoch (paper Figs. 10–11).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any, Protocol

import matplotlib
import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from pier_monitor.core.errors import ReportError
from pier_monitor.core.identify.damage import (DAMAGED_DF, IDENTIFIABILITY_LIMITS,
                                               SUSPICIOUS_DF, IdentificationResult,
                                               SectionResult)
from pier_monitor.core.identify.uncertainty import MemberResponses
from pier_monitor.core.ingest.window import MeasuredWindow, Reproduced
from pier_monitor.core.model.config import SpringParameters

from ._common import STATE_COLORS, check_same_pier, engineering_scale, format_df, format_interval


__all__ = [
    "FIGURE_DPI",
    "PROFILE_FIGSIZE_IN",
    "RunLike",
    "plot_profile",
    "plot_hysteresis",
    "plot_responses",
    "plot_training",
]

#: Resolution of the PNG files, dots per inch.
FIGURE_DPI = 120
#: Size of the profile figure, inches (width, height).
PROFILE_FIGSIZE_IN = (11.0, 6.8)

_STYLE = {
    "font.size": 10.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 10.0,
    "xtick.labelsize": 9.0,
    "ytick.labelsize": 9.0,
    "legend.fontsize": 9.0,
    "figure.titlesize": 12.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.formatter.useoffset": False,
}

_BAND_ALPHA = 0.25
_EVENT_COLORS = ("#1f4e9c", "#222222", "#7b3294", "#8c510a", "#01665e")
_EVENT_MARKERS = ("o", "s", "^", "D", "v")
_BAND_COLORS = STATE_COLORS
_TERM_LABELS = {
    "data": "data misfit (L1)",
    "eom": "equation of motion (L2)",
    "newmark_a": r"Newmark $\ddot{x}$ update (L3)",
    "newmark_v": r"Newmark $\dot{x}$ increment (L4)",
    "newmark_x": r"Newmark $x$ increment (L5)",
    "hysteresis": "hysteresis (L6)",
}
_PARAM_LABELS = (
    (r"elastic stiffness $k_1$", "k1"),
    (r"second stiffness $k_2$", "k2"),
    (r"yield moment $f_y$", "fy"),
    (r"damping coefficient $c$", "c"),
)


class RunLike(Protocol):
    """What the figures need of an identification run (``pinn.IdentificationRun``).

    Declared here so that this module never imports torch.
    """

    result: IdentificationResult
    reproduced: Reproduced
    initial: SpringParameters
    history: dict[str, list[Any]]


@contextlib.contextmanager
def _style() -> Iterator[None]:
    with matplotlib.rc_context(_STYLE):
        yield


def _figure(size_in: tuple[float, float]) -> Figure:
    return Figure(figsize=size_in, dpi=FIGURE_DPI, layout="constrained")


def _save(fig: Figure, path: str | Path) -> Path:
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ReportError(f"{path}: figures are written as PNG; expected a .png path")
    try:
        fig.savefig(path, dpi=FIGURE_DPI, format="png")
    except OSError as err:
        raise ReportError(f"{path}: cannot write figure: {err.strerror or err}") from err
    return path


def _section_span(r: IdentificationResult, i: int) -> str:
    s = r.sections[i]
    return f"{s.z_bottom_m:g}–{s.z_top_m:g} m"


def _check_run(run: RunLike) -> tuple[IdentificationResult, Reproduced]:
    res, rep = run.result, run.reproduced
    n = len(res.sections)
    for name in ("theta", "moment", "x", "a"):
        arr = np.asarray(getattr(rep, name))
        if arr.ndim != 2 or arr.shape[1] != n or arr.shape[0] != np.asarray(rep.t).size:
            raise ReportError(f"reproduced {name}: expected shape ({np.asarray(rep.t).size}, {n}) "
                              f"for {n} sections, got {arr.shape}")
    return res, rep


def check_members_match(members: MemberResponses | None, rep: Reproduced) -> None:
    """Raise :class:`ReportError` unless the members' histories have ``rep``'s (T, N)."""
    if members is None:
        return
    want = np.asarray(rep.theta).shape
    if members.theta.shape[1:] != want:
        raise ReportError(f"member histories: expected shape (M, {want[0]}, {want[1]}) like the "
                          f"reproduced responses, got {members.theta.shape}")


def _interval_errors(results: Sequence[IdentificationResult], name: str, scale: np.ndarray
                     ) -> np.ndarray | None:
    """Error-bar lengths (2, R, N) of a quantity's 90 % interval; None without uncertainty.

    ``scale`` (R, N) divides the values (units or a baseline); NaN where a section has no
    interval, so that no bar is drawn there.
    """
    if not any(s.uncertainty is not None for r in results for s in r.sections):
        return None
    point = np.array([[getattr(s, name) for s in r.sections] for r in results])
    lo = np.array([[np.nan if s.uncertainty is None else getattr(s.uncertainty, name).lo
                    for s in r.sections] for r in results])
    hi = np.array([[np.nan if s.uncertainty is None else getattr(s.uncertainty, name).hi
                    for s in r.sections] for r in results])
    # the interval is of the members; the point may lie outside it: bars never negative
    return np.stack([np.maximum(point - lo, 0.0), np.maximum(hi - point, 0.0)]) / scale


def _df_interval(section: SectionResult) -> str:
    """`` [lo, hi]`` of the section's DF over the ensemble; empty without uncertainty."""
    u = section.uncertainty
    return "" if u is None else " " + format_interval(u.ductility_factor.lo,
                                                      u.ductility_factor.hi)


def _steps(values: Sequence[float], zb: Sequence[float], zt: Sequence[float]
           ) -> tuple[np.ndarray, np.ndarray]:
    """Polyline of a per-section value drawn as a step over each section's height."""
    x = np.repeat(np.asarray(values, dtype=float), 2)
    z = np.ravel(np.column_stack([zb, zt]))
    return x, z


# --------------------------------------------------------------------------------- profile


def plot_profile(results: Sequence[IdentificationResult], labels: Sequence[str] | None,
                 path: str | Path, *, baseline_k1: np.ndarray | Sequence[float] | None = None,
                 baseline_label: str = "baseline") -> Path:
    """Elastic stiffness and ductility factor along the pier height (paper Fig. 18).

    Each result is one step line over the section heights ``[z_bottom, z_top]`` with a
    marker at mid-section.  The DF panel is shaded intact (DF < 1.2), suspicious
    (1.2 <= DF < 1.5) and damaged (DF >= 1.5) with dashed lines at the thresholds.  Sections
    whose spring never yielded have an open marker: their DF is only an upper bound (≈ 1).
    With exactly two results, the ``k1`` change of the second against the first (%) is
    written beside its markers.  Sections identified by an ensemble have error bars from
    the 5th to the 95th percentile of the members, on ``k1`` and on the DF; a bar is dashed
    where the quantity is poorly identified (``SectionResult.poorly_identified``: its
    interval too wide to tell), and a figure of single identifications says "no interval
    (1 member)" in its legend.  An unreliable
    result (failed its self-check) is drawn grey and dashed, "no diagnosis" in the legend.

    Parameters
    ----------
    results : sequence of IdentificationResult
        One to five results of the same pier (same ``pier_id`` and sections).
    labels : sequence of str, optional
        Legend label of each result (default: the event ids).
    path : str or Path
        The ``.png`` file to write.
    baseline_k1 : array_like, shape (N,), optional
        When given, ``k1`` is drawn relative to it (dimensionless) instead of in N·m/rad.
    baseline_label : str
        What the baseline is, for the axis label (e.g. ``"design values"``).

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ReportError
        If the results are of different piers or geometry, the labels or baseline do not
        match them, or the file cannot be written.
    """
    results = list(results)
    if not 1 <= len(results) <= len(_EVENT_COLORS):
        raise ReportError(f"plot_profile: expected 1 to {len(_EVENT_COLORS)} results, "
                          f"got {len(results)}")
    labels = [r.event_id for r in results] if labels is None else list(labels)
    if len(labels) != len(results):
        raise ReportError(f"plot_profile: {len(results)} results but {len(labels)} labels")
    check_same_pier(results, labels)
    ref = results[0]
    n = len(ref.sections)
    zb = np.array([s.z_bottom_m for s in ref.sections])
    zt = np.array([s.z_top_m for s in ref.sections])
    zm = 0.5 * (zb + zt)
    if baseline_k1 is not None:
        base = np.asarray(baseline_k1, dtype=float)
        if base.shape != (n,) or not np.all(np.isfinite(base) & (base > 0)):
            raise ReportError(f"plot_profile: baseline k1: expected {n} finite positive values "
                              f"in N·m/rad, got {base.tolist()}")
    with _style():
        fig = _figure(PROFILE_FIGSIZE_IN)
        ax_k, ax_df = fig.subplots(1, 2, sharey=True)
        k1_all = np.array([[s.k1 for s in r.sections] for r in results])
        if baseline_k1 is None:
            k_fac, k_unit = engineering_scale(k1_all, "N·m/rad")
            k_scale = np.full_like(k1_all, k_fac)
            ax_k.set_xlabel(rf"elastic stiffness $k_1$ ({k_unit})")
        else:
            k_scale = np.broadcast_to(base, k1_all.shape)
            ax_k.axvline(1.0, color="0.4", lw=1.0, ls="--")
            ax_k.set_xlabel(rf"$k_1$ / $k_1$ of {baseline_label} (–)")
        k_vals = k1_all / k_scale
        df_all = np.array([[s.ductility_factor for s in r.sections] for r in results])
        k_err = _interval_errors(results, "k1", k_scale)
        df_err = _interval_errors(results, "ductility_factor", np.ones_like(df_all))
        # the axes hold the bars too
        k_ext = k_vals if k_err is None else np.concatenate(
            [k_vals, np.fmin(k_vals, k_vals - k_err[0]), np.fmax(k_vals, k_vals + k_err[1])])
        df_ext = df_all if df_err is None else np.fmax(df_all, df_all + df_err[1])
        df_max = float(np.nanmax(df_ext)) if np.any(np.isfinite(df_ext)) else 1.0
        df_right = max(2.0, 1.12 * df_max)
        spans = (("intact", 0.0, SUSPICIOUS_DF), ("suspicious", SUSPICIOUS_DF, DAMAGED_DF),
                 ("damaged", DAMAGED_DF, df_right))
        for name, lo, hi in spans:
            ax_df.axvspan(lo, hi, color=_BAND_COLORS[name], alpha=0.16, lw=0)
        for thr in (SUSPICIOUS_DF, DAMAGED_DF):
            ax_df.axvline(thr, color="0.25", lw=1.0, ls="--")
        for ax in (ax_k, ax_df):
            for z in np.unique(np.concatenate([zb, zt])):
                ax.axhline(z, color="0.6", lw=0.6, zorder=0)
        any_bound = any_poor = False
        event_handles = []
        # markers of the events a little apart in height, so that equal values stay visible
        zj = [zm - (j - 0.5 * (len(results) - 1)) * 0.2 * (zt - zb) for j in range(len(results))]
        for j, r in enumerate(results):
            color, marker = _EVENT_COLORS[j], _EVENT_MARKERS[j]
            ls = "-"
            if r.unreliable_reasons:  # grey and dashed: numbers, not a diagnosis
                color, ls = STATE_COLORS["unreliable"], "--"
            yielded = np.array([s.yielded for s in r.sections])
            any_bound |= bool(np.any(~yielded))
            xs, zs = _steps(k_vals[j], zb, zt)
            (line,) = ax_k.plot(xs, zs, color=color, lw=2.0, ls=ls, marker="none")
            ax_k.plot(k_vals[j], zj[j], ls="none", marker=marker, ms=7, color=color)
            xs, zs = _steps(df_all[j], zb, zt)
            ax_df.plot(xs, zs, color=color, lw=2.0, ls=ls)
            ax_df.plot(df_all[j][yielded], zj[j][yielded], ls="none", marker=marker, ms=7,
                       color=color)
            ax_df.plot(df_all[j][~yielded], zj[j][~yielded], ls="none", marker=marker, ms=7,
                       mfc="white", mec=color, mew=1.6)
            if k_err is not None:
                # a poorly identified k1 or DF: its bar dashed (its interval too wide to tell)
                for ax, vals, err, name in ((ax_k, k_vals, k_err, "k1"),
                                            (ax_df, df_all, df_err, "DF")):
                    poor = np.array([name in s.poorly_identified for s in r.sections])
                    any_poor |= bool(poor.any())
                    for mask, style in ((~poor, "-"), (poor, "--")):
                        if mask.any():
                            bars = ax.errorbar(vals[j][mask], zj[j][mask], xerr=err[:, j][:, mask],
                                               ls="none", color=color, elinewidth=1.4, capsize=4)
                            bars[2][0].set_linestyle(style)
            overall = ("unreliable, no diagnosis" if r.unreliable_reasons
                       else r.overall_state)
            event_handles.append((line, marker, color, f"{labels[j]} (overall: {overall})"))
        line_colors = [c for _, _, c, _ in event_handles]
        if len(results) <= 2:  # DF values as numbers, right of the section's markers
            for j, r in enumerate(results):
                for i, s in enumerate(r.sections):
                    ax_df.annotate(format_df(s.ductility_factor, not s.ductility_factor_upper_bound),
                                   (float(np.nanmax(df_ext[:, i])), zj[j][i]), xytext=(8, 0),
                                   textcoords="offset points", fontsize=8.5,
                                   color=line_colors[j], va="center",
                                   bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none",
                                             alpha=0.75))
        if len(results) == 2:
            change = 100.0 * (k1_all[1] / k1_all[0] - 1.0)
            for i in range(n):
                ax_k.annotate(f"{change[i]:+.1f} %", (float(np.nanmax(k_ext[:, i])), zm[i]),
                              xytext=(9, 0), textcoords="offset points", fontsize=8.5,
                              color=_EVENT_COLORS[1], va="center",
                              bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none",
                                        alpha=0.75))
        # k1 axis from zero, so that a change reads at its true size
        if baseline_k1 is None:
            ax_k.set_xlim(0.0, 1.22 * float(np.nanmax(k_ext)))
        else:  # around the baseline (1), with room for the markers
            lo = min(1.0, float(np.nanmin(k_ext)))
            hi = max(1.0, float(np.nanmax(k_ext)))
            pad = max(0.05, 0.15 * (hi - lo))
            ax_k.set_xlim(lo - pad, hi + pad)
        ax_df.set_xlim(0.0, df_right)
        ax_df.set_xlabel(r"ductility factor DF = max$|\theta|$ / $\theta_y$ (–)")
        ax_k.set_ylabel("height above the foundation z (m)")
        ax_k.set_ylim(min(0.0, float(zb.min())), float(zt.max()))
        ax_k.set_title(r"elastic stiffness $k_1$ per section"
                       + ("\n(% labels: change of the later event)" if len(results) == 2
                          else ""))
        ax_df.set_title("ductility factor per section")
        # section numbers on the right
        ax_sec = ax_df.twinx()
        ax_sec.set_ylim(ax_k.get_ylim())
        ax_sec.set_yticks(zm, [f"section {i + 1}" for i in range(n)])
        ax_sec.grid(False)
        ax_sec.tick_params(axis="y", length=0)

        handles = [Line2D([], [], color=c, lw=2.0, ls=line.get_linestyle(), marker=m, ms=7,
                          label=lab) for line, m, c, lab in event_handles]
        handles += [Patch(color=_BAND_COLORS["intact"], alpha=0.35,
                          label=f"intact: DF < {SUSPICIOUS_DF:g}"),
                    Patch(color=_BAND_COLORS["suspicious"], alpha=0.45,
                          label=f"suspicious: {SUSPICIOUS_DF:g} ≤ DF < {DAMAGED_DF:g}"),
                    Patch(color=_BAND_COLORS["damaged"], alpha=0.35,
                          label=f"damaged: DF ≥ {DAMAGED_DF:g}")]
        if any_bound:
            handles.append(Line2D([], [], ls="none", marker="o", ms=7, mfc="white", mec="0.2",
                                  mew=1.6, label="open marker: spring did not yield,\n"
                                                 "DF is only an upper bound"))
        if k_err is not None:
            members = max(r.members for r in results)
            handles.append(Line2D([], [], color="0.2", lw=1.4, marker="|", ms=9,
                                  label=f"bars: 90 % interval over the ensemble\n"
                                        f"({members} members, 5th–95th percentile)"))
            if any_poor:
                handles.append(Line2D([], [], color="0.2", lw=1.4, ls="--", marker="|", ms=9,
                                      label=f"dashed bar: poorly identified (interval wider\n"
                                            f"than ±{100 * IDENTIFIABILITY_LIMITS['k1']:.0f} % "
                                            f"on k1, ±{100 * IDENTIFIABILITY_LIMITS['DF']:.0f} % "
                                            "on DF)"))
        else:
            handles.append(Line2D([], [], ls="none", label=f"intervals: {results[-1].intervals}"))
        fig.legend(handles=handles, loc="outside lower center", ncols=min(3, len(handles)),
                   frameon=False)
        events = " vs ".join(labels) if len(labels) > 1 else labels[0]
        fig.suptitle(f"Pier {ref.pier_id}: $k_1$ and ductility factor along the height — "
                     f"event{'s' if len(labels) > 1 else ''} {events}")
        return _save(fig, path)


# ------------------------------------------------------------------------------ hysteresis


def plot_hysteresis(run: RunLike, path: str | Path, *,
                    members: MemberResponses | None = None) -> Path:
    """Reproduced moment–rotation loops of every spring with the identified skeleton.

    One subplot per spring: ``θ`` against the moment from ``run.reproduced``, the skeleton
    lines ``k2 θ ± s`` (``s = fy (1 − k2/k1)``) and the elastic branch through the yield
    points ``(±θy, ±fy)``.  For a spring that never yielded only the elastic line ``k1 θ`` is
    drawn: its ``k2`` and ``fy`` are not identifiable.  With ``members``, the loops of the
    ensemble's members are drawn faintly beneath: together they are the band the ensemble
    allows.  A title gives the DF, with its 90 % interval for an ensemble.

    Parameters
    ----------
    run : IdentificationRun
        The identification (its result and reproduced responses).
    path : str or Path
        The ``.png`` file to write.
    members : MemberResponses, optional
        The members' angles and moments, (M, T, N) each.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ReportError
        If the reproduced responses do not match the result, or the file cannot be written.
    """
    res, rep = _check_run(run)
    check_members_match(members, rep)
    theta = np.asarray(rep.theta, dtype=float)
    moment = np.asarray(rep.moment, dtype=float)
    n = len(res.sections)
    ncols = min(3, n)
    nrows = math.ceil(n / ncols)
    t_fac, t_unit = engineering_scale(theta, "rad")
    m_fac, m_unit = engineering_scale(moment, "N·m")
    # the axes take in the members' loops
    th_all = theta[None] if members is None else np.concatenate([theta[None], members.theta])
    m_all = moment[None] if members is None else np.concatenate([moment[None], members.moment])
    with _style():
        fig = _figure((4.1 * ncols + 0.3, 3.4 * nrows + 1.1))
        axes = fig.subplots(nrows, ncols, squeeze=False)
        for ax in axes.flat[n:]:
            ax.set_visible(False)
        for i, s in enumerate(res.sections):
            ax = axes.flat[i]
            th, m = theta[:, i], moment[:, i]
            if members is not None:
                for k in range(members.members):
                    ax.plot(members.theta[k, :, i] / t_fac, members.moment[k, :, i] / m_fac,
                            color="#9ecae1", lw=0.6, alpha=_BAND_ALPHA)
            ax.plot(th / t_fac, m / m_fac, color="#1f77b4", lw=0.8)
            lo, hi = float(th_all[:, :, i].min()), float(th_all[:, :, i].max())
            pad = 0.08 * max(hi - lo, 1e-12)
            grid = np.array([lo - pad, hi + pad])
            mlo, mhi = float(m_all[:, :, i].min()), float(m_all[:, :, i].max())
            if s.yielded:  # show the yield points even where the response did not reach them
                lo, hi = min(lo, -s.yield_angle_rad), max(hi, s.yield_angle_rad)
                mlo, mhi = min(mlo, -s.fy), max(mhi, s.fy)
                pad = 0.08 * (hi - lo)
                grid = np.array([lo - pad, hi + pad])
                offset = s.fy * (1.0 - s.k2 / s.k1)
                for sign in (1.0, -1.0):
                    ax.plot(grid / t_fac, (s.k2 * grid + sign * offset) / m_fac, ls="--",
                            color="0.3", lw=1.1)
                ty = s.yield_angle_rad
                ax.plot(np.array([-ty, ty]) / t_fac, np.array([-s.fy, s.fy]) / m_fac, ls=":",
                        color="#d62728", lw=1.3)
                ax.plot(np.array([-ty, ty]) / t_fac, np.array([-s.fy, s.fy]) / m_fac, ls="none",
                        marker="o", ms=5, color="#d62728")
                title = f"yielded, DF {s.ductility_factor:.2f}{_df_interval(s)}"
            else:
                ax.plot(grid / t_fac, s.k1 * grid / m_fac, ls=":", color="#d62728", lw=1.3)
                peak = float(np.max(np.abs(m)))
                ax.text(0.03, 0.97, "did not yield: $k_2$, $f_y$ not identifiable\n"
                        f"($f_y$ ≥ max|M| = {peak / m_fac:.3g} {m_unit})",
                        transform=ax.transAxes, va="top", ha="left", fontsize=8.5,
                        bbox=dict(boxstyle="round,pad=0.25", fc="white", ec="0.7", alpha=0.9))
                title = (f"{s.yield_status}, DF {'≤ ' if s.ductility_factor_upper_bound else ''}"
                         f"{s.ductility_factor:.2f}{_df_interval(s)}")
            mpad = 0.12 * max(mhi - mlo, 1e-12)
            ax.set_xlim((lo - pad) / t_fac, (hi + pad) / t_fac)
            ax.set_ylim((mlo - mpad) / m_fac, (mhi + mpad) / m_fac)
            ax.axhline(0.0, color="0.5", lw=0.5)
            ax.axvline(0.0, color="0.5", lw=0.5)
            ax.set_title(f"spring {i + 1} ({_section_span(res, i)}): {title}")
            ax.set_xlabel(rf"rotation $\theta_{{{i + 1}}}$ ({t_unit})")
            ax.set_ylabel(f"moment $M_{{{i + 1}}}$ ({m_unit})")

        handles = [Line2D([], [], color="#1f77b4", lw=1.0, label="reproduced response (PINN)"),
                   Line2D([], [], color="0.3", ls="--", lw=1.1,
                          label=r"skeleton $k_2\theta \pm f_y(1-k_2/k_1)$"),
                   Line2D([], [], color="#d62728", ls=":", lw=1.3, marker="o", ms=5,
                          label=r"elastic $k_1\theta$ to the yield points "
                                r"$(\pm\theta_y, \pm f_y)$")]
        if members is not None:
            handles.append(Line2D([], [], color="#9ecae1", lw=2.0,
                                  label=f"the {members.members} ensemble members' responses"))
        fig.legend(handles=handles, loc="outside lower center", ncols=min(3, len(handles)),
                   frameon=False)
        fig.suptitle(f"Pier {res.pier_id}, event {res.event_id}: moment–rotation of the "
                     "springs, identified bilinear model")
        return _save(fig, path)


# ------------------------------------------------------------------------------- responses


def plot_responses(window: MeasuredWindow, run: RunLike, path: str | Path, *,
                   members: MemberResponses | None = None) -> Path:
    """Measured against reproduced relative displacement and acceleration of every level.

    Rows are the levels, top of the pier first; the left column is the displacement, the
    right the acceleration relative to the foundation, against time.  Each panel gives the
    RMS misfit as a share of the measured peak.  With ``members`` holding their ``x`` and
    ``a``, a band shades the 5th to 95th percentile of the members at each time.

    Parameters
    ----------
    window : MeasuredWindow
        The measured window the run identified.
    run : IdentificationRun
        The identification (its reproduced responses).
    path : str or Path
        The ``.png`` file to write.
    members : MemberResponses, optional
        The members' histories, (M, T, N); the band needs their ``x`` and ``a``.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ReportError
        If the window and the run differ in pier, event, levels or samples, the members'
        histories in shape, or the file cannot be written.
    """
    res, rep = _check_run(run)
    check_window_matches(window, run)
    check_members_match(members, rep)
    bands = {q: None if members is None else members.band(q) for q in ("x", "a")}
    n = window.n_levels
    z = window.geometry.level_heights_m
    x_fac, x_unit = engineering_scale(window.x, "m")
    cols = (("x", "relative displacement", x_fac, x_unit),
            ("a", "relative acceleration", 1.0, "m/s²"))
    with _style():
        fig = _figure((11.5, 1.45 * n + 1.6))
        axes = fig.subplots(n, 2, sharex=True, squeeze=False)
        for row, lvl in enumerate(reversed(range(n))):
            for col, (q, name, fac, unit) in enumerate(cols):
                ax = axes[row, col]
                meas = np.asarray(getattr(window, q))[:, lvl]
                repro = np.asarray(getattr(rep, q))[:, lvl]
                ax.plot(window.t, meas / fac, color="0.6", lw=1.8)
                if bands[q] is not None:
                    lo, hi = bands[q]
                    ax.fill_between(rep.t, lo[:, lvl] / fac, hi[:, lvl] / fac, color="#1f4e9c",
                                    alpha=_BAND_ALPHA, lw=0)
                ax.plot(rep.t, repro / fac, color="#1f4e9c", lw=0.9, ls="--")
                peak = float(np.max(np.abs(meas)))
                misfit = 100.0 * float(np.sqrt(np.mean((repro - meas) ** 2))) / peak \
                    if peak > 0 else float("nan")
                text = "< 0.01" if misfit < 0.01 else f"{misfit:.2g}"
                ax.text(0.99, 0.94, f"RMS misfit {text} % of peak", transform=ax.transAxes,
                        ha="right", va="top", fontsize=8,
                        bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.8", alpha=0.85))
                sym = "x" if q == "x" else r"\ddot{x}"
                label = f"${sym}_{{{lvl + 1}}}$ ({unit})"
                if col == 0:
                    label = f"level {lvl + 1}, z = {z[lvl + 1]:g} m\n" + label
                ax.set_ylabel(label)
                if row == 0:
                    ax.set_title(f"{name} ({unit})")
        for ax in axes[-1]:
            ax.set_xlabel("time t (s)")
            ax.set_xlim(float(window.t[0]), float(window.t[-1]))

        handles = [Line2D([], [], color="0.6", lw=1.8, label="measured"),
                   Line2D([], [], color="#1f4e9c", lw=0.9, ls="--", label="reproduced (PINN)")]
        if bands["x"] is not None or bands["a"] is not None:
            handles.append(Patch(color="#1f4e9c", alpha=_BAND_ALPHA,
                                 label=f"90 % band of the {members.members} ensemble members"))
        fig.legend(handles=handles, loc="outside lower center", ncols=len(handles),
                   frameon=False)
        fig.suptitle(f"Pier {res.pier_id}, event {res.event_id}: responses relative to the "
                     "foundation, measured and reproduced")
        return _save(fig, path)


def check_window_matches(window: MeasuredWindow, run: RunLike) -> None:
    """Raise :class:`ReportError` unless ``run`` identified ``window`` (pier, event, shapes)."""
    res = run.result
    if (window.pier_id, window.event_id) != (res.pier_id, res.event_id):
        raise ReportError(f"window is pier {window.pier_id!r} event {window.event_id!r}, but the "
                          f"run is pier {res.pier_id!r} event {res.event_id!r}")
    if window.n_levels != len(res.sections):
        raise ReportError(f"window has {window.n_levels} levels, the run {len(res.sections)} "
                          "sections")
    t_rep = np.asarray(run.reproduced.t)
    if t_rep.shape != window.t.shape:
        raise ReportError(f"window has {window.t.size} samples, the reproduced responses "
                          f"{t_rep.size}")


# -------------------------------------------------------------------------------- training


def plot_training(run: RunLike, path: str | Path) -> Path:
    """Loss terms and parameters per epoch.

    Top: the total loss and the weighted contribution of each term to it (log scale;
    terms with weight 0 are listed, not drawn).  Below: ``k1, k2, fy, c`` of every spring as
    the change from their initial values (%), epoch 0 being the initial value.  ``k2`` and
    ``fy`` of a spring that did not yield are dotted: they are held or not identifiable.

    Parameters
    ----------
    run : IdentificationRun
        The identification (its ``history``, ``initial`` parameters and result).
    path : str or Path
        The ``.png`` file to write.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    ReportError
        If the history is inconsistent (lengths, parameter shapes), or the file cannot be
        written.
    """
    res = run.result
    hist = run.history
    n = len(res.sections)
    loss = np.asarray(hist.get("loss", []), dtype=float)
    n_ep = loss.size
    params = np.asarray(hist.get("params", []), dtype=float)
    if params.size and params.shape != (n_ep, 4, n):
        raise ReportError(f"history params: expected shape ({n_ep}, 4, {n}), got {params.shape}")
    for key in _TERM_LABELS:
        if key in hist and len(hist[key]) != n_ep:
            raise ReportError(f"history {key}: expected {n_ep} epochs, got {len(hist[key])}")
    settings = res.settings or {}
    weighted = "data_weight" in settings and "physics_weight" in settings
    epochs = np.arange(1, n_ep + 1)
    warmup = int(settings.get("warmup_epochs", 0) or 0)
    with _style():
        fig = _figure((11.5, 9.0))
        gs = fig.add_gridspec(3, 2, height_ratios=(1.3, 1.0, 1.0))
        ax_l = fig.add_subplot(gs[0, :])
        skipped = []
        if n_ep:
            ax_l.plot(epochs, _positive(loss), color="black", lw=2.2, label="total loss L")
            for j, (key, label) in enumerate(_TERM_LABELS.items()):
                if key not in hist:
                    continue
                if weighted:
                    w = float(settings["data_weight"]) if key == "data" else (
                        float(settings["physics_weight"])
                        * float(settings.get("term_weights", {}).get(key, 1.0)))
                else:
                    w = 1.0
                if w == 0.0:
                    skipped.append(label)
                    continue
                vals = w * np.asarray(hist[key], dtype=float)
                ax_l.plot(epochs, _positive(vals), lw=1.2, color=f"C{j}",
                          label=f"{label}, weight {w:.3g}" if weighted else label)
            ax_l.set_yscale("log")
            ax_l.set_xlim(0, max(n_ep, 1))
        else:
            ax_l.text(0.5, 0.5, "no training history", transform=ax_l.transAxes, ha="center")
        ax_l.set_xlabel("epoch")
        ax_l.set_ylabel("weighted loss (dimensionless)" if weighted else "loss (dimensionless)")
        note = f"; not in the loss (weight 0): {', '.join(skipped)}" if skipped else ""
        ax_l.set_title("loss: total and contribution of each term" + note)
        if n_ep:
            ax_l.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8.5,
                        frameon=False)

        init = np.stack([run.initial.k1, run.initial.k2, run.initial.fy, run.initial.c])
        cmap = _spring_colors(n)
        yielded = np.array([s.yielded for s in res.sections])
        start = {"equation_error": "equation-error fit", "design": "design values"}.get(
            str(settings.get("init", "")), "initial values")
        for j, (name, _) in enumerate(_PARAM_LABELS):
            ax = fig.add_subplot(gs[1 + j // 2, j % 2], sharex=ax_l)
            if params.size:
                traj = np.concatenate([init[None], params], axis=0)
                rel = 100.0 * (traj / init[None] - 1.0)
                ep = np.arange(0, n_ep + 1)
                for i in range(n):
                    held = j in (1, 2) and not yielded[i]
                    ax.plot(ep, rel[:, j, i], color=cmap[i], lw=1.3, ls=":" if held else "-")
            ax.axhline(0.0, color="0.5", lw=0.6)
            ax.set_title(f"{name} of each spring")
            ax.set_ylabel(f"change from {start} (%)", fontsize=9)
            if j >= 2:
                ax.set_xlabel("epoch")
            ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 4), useOffset=False)
            if warmup:
                ax.axvspan(0, warmup, color="0.85", lw=0)
        if warmup:
            ax_l.axvspan(0, warmup, color="0.85", lw=0, label="data-only warm-up")

        handles = [Line2D([], [], color=cmap[i], lw=1.5,
                          label=f"spring {i + 1} ({_section_span(res, i)})") for i in range(n)]
        if np.any(~yielded):
            handles.append(Line2D([], [], color="0.3", ls=":", lw=1.5,
                                  label="dotted: spring did not yield, "
                                        "$k_2$/$f_y$ not identifiable"))
        fig.legend(handles=handles, loc="outside lower center", ncols=min(4, len(handles)),
                   frameon=False)
        fig.suptitle(f"Pier {res.pier_id}, event {res.event_id}: training — {res.epochs} "
                     f"epochs, final loss {res.final_loss:.3g}, {res.wall_time_s:.1f} s on "
                     f"{res.device}")
        return _save(fig, path)


def _positive(values: np.ndarray) -> np.ndarray:
    """Values with non-positive entries as NaN (gaps on a log axis)."""
    out = np.asarray(values, dtype=float).copy()
    out[~(out > 0)] = np.nan
    return out


def _spring_colors(n: int) -> list[Any]:
    cmap = colormaps["viridis"]
    return [cmap(0.9 * i / max(n - 1, 1)) for i in range(n)]
