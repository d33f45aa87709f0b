"""Checks of each sensor against the other sensors of its level.

A level's accelerometers see one rigid motion, each along its own axes, so that any one
horizontal channel is predicted by the others (least squares, leaving it out), once each
channel's offset over the second (its median: a bias, or gravity leaking through a tilt the
configuration does not know) is taken out.  A channel
that departs from that prediction

* on single samples or short bursts, beyond ``glitch_threshold`` times the local spread and
  ``glitch_rel`` of the prediction, has a glitch: those samples become missing (and are
  interpolated when short);
* over whole seconds, by more than ``disagree_rel`` of the level's motion and well beyond
  its noise (a wrong gain, a reversed sign, a loose mount), disagrees: it is excluded over
  those seconds, not the level;
* in its offset (the mean of each second), once the offset it holds where the data begin
  is taken out, lastingly (an offset step, a drift, a slow bias; :func:`_offset_changes`):
  it is excluded from where the change shows, with an ``offset_step`` or ``drift`` finding.

A displacement sensor has no such neighbours (two wires per level give the two horizontal
components and nothing to spare), so each event compares it with its level's relative
acceleration integrated twice in the band 0.2-10 Hz, where both are exact; a wire that
disagrees is excluded for the event.  That band cannot see a slow drift, which the pier at
rest does (:func:`check_wires_at_rest`): a wire that moves while its samples and its level's
accelerometers show the level still is excluded for the whole recording.

Accelerometers whose level of motion is off by a unit factor from the others at the level
are caught first (:func:`check_units`).
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from pier_monitor.core.ingest.clean import (GLITCH, CleanSensor, block_median, fmt_recorded,
                                            nan_median, runs_of)
from pier_monitor.core.ingest.levels import HorizontalChannel, availability_patterns, horizontal_channels
from pier_monitor.core.ingest.settings import IngestReport, IngestSettings
from pier_monitor.core.ingest.findings import fmt_span
from pier_monitor.core.model.units import G_STANDARD, UNIT_FACTORS

__all__ = ["check_units", "check_accelerometers", "check_displacement", "check_wires_at_rest",
           "leave_one_out"]

_PASSES = 3  # bad channels per level and second that can be told apart
_BAND_HZ = (0.2, 10.0)
_REFERENCE_S = 10  # seconds at the start of the data that set the accelerometers' offsets
_REST_MIN_S = 3  # seconds at rest in a row over which a displacement sensor's drift is judged
_REST_PIECE_S = 10  # ... in pieces of at most this many seconds (a pier may settle slowly)
#: A still pier's slow motion over a piece stays within this many times glitch_threshold of a
#: displacement sensor's noise (the synthetic field piers: at most 0.22 of it)
_REST_SETTLE = 3.0
#: ... judged only this long after the level last moved, s: right after a strong shaking a
#: damaged pier (pinched springs) settles by as much in 10 s
_SETTLED_S = 30


def _noise_si(ch: HorizontalChannel) -> float:
    spec = ch.sensor.spec
    return max(spec.noise_rms * spec.si_factor / abs(spec.gain), 1e-9)


def check_units(cleaned: list[CleanSensor], report: IngestReport) -> None:
    """Exclude accelerometers whose level of motion is off by a unit factor from the others
    at the same level (e.g. recorded in g but declared m/s²).

    The level of motion is a robust spread (1.4826 × the median absolute deviation of each
    horizontal channel), so that a few wild samples (glitches, found later) do not make a
    sensor look like one in the wrong unit.

    First, on its own: an accelerometer whose configured ``z`` offset is gravity (it records
    the static 1 g) and whose ``z`` reads at rest a unit factor away from it (e.g. 1.0 where
    9.81 m/s² is configured: recorded in g) is excluded as a units problem, named with the
    unit it looks recorded in."""
    by_level: dict[int, list[tuple[CleanSensor, float]]] = {}
    for cs in cleaned:
        if cs.spec.kind != "acceleration":
            continue
        if _gravity_units(cs, report):
            continue
        h = [j for j, a in enumerate(cs.spec.axes) if a != "z"]
        sel = cs.usable[:, h].all(axis=1) & np.isfinite(cs.values[:, h]).all(axis=1)
        if len(h) == 0 or sel.sum() < 10:
            continue
        vals = cs.values[sel][:, h]
        mad = np.median(np.abs(vals - np.median(vals, axis=0)), axis=0)
        spread = float(1.4826 * np.sqrt(np.mean(mad ** 2)))
        by_level.setdefault(cs.spec.level, []).append((cs, spread))
    for level, items in by_level.items():
        if len(items) < 3:
            continue
        med = float(np.median([r for _, r in items]))
        for cs, r in items:
            ratio = r / med if med > 0 else 1.0
            if ratio > 5.0 or ratio < 0.2:
                cs.usable[:, :] = False
                n = cs.values.shape[0]
                report.add("implausible_units", cs.spec.sensor_id,
                           f"horizontal motion {r:.4g} m/s² (robust spread) is {ratio:.3g}x the "
                           f"median of the accelerometers at level {level} ({med:.4g} m/s²); "
                           f"declared unit "
                           f"{cs.spec.unit!r} looks wrong (or the sensor does not feel the motion); "
                           "sensor excluded",
                           cs.time_ns(0), cs.time_ns(n - 1), "excluded")


def _gravity_units(cs: CleanSensor, report: IngestReport) -> bool:
    """Whether the sensor's ``z`` contradicts its unit by the gravity it reads (see
    :func:`check_units`); then it is excluded with an ``implausible_units`` finding."""
    spec = cs.spec
    if "z" not in spec.axes:
        return False
    j = spec.axes.index("z")
    offset = float(spec.offsets[j])
    g_declared = abs(offset) * spec.si_factor / abs(spec.gain)
    col = cs.values[:, j]
    ok = cs.usable[:, j] & np.isfinite(col)
    if not 0.8 * G_STANDARD < g_declared < 1.25 * G_STANDARD or ok.sum() < 10:
        return False
    # the recorded z at rest, in the sensor's unit (gain, sign and offset put back)
    at_rest = float(np.median(col[ok])) * spec.gain * spec.signs[j] / spec.si_factor + offset
    ratio = at_rest / offset
    if 0.8 < ratio < 1.25:
        return False
    g_read = abs(at_rest) * spec.si_factor / abs(spec.gain)
    units = UNIT_FACTORS["acceleration"]
    guess = [u for u, f in units.items() if abs(abs(at_rest) * f / abs(spec.gain) - G_STANDARD)
             < 0.1 * G_STANDARD and u != spec.unit]
    looks = (f"; it looks recorded in {guess[0]!r}" if guess else "")
    cs.usable[:, :] = False
    n = cs.values.shape[0]
    report.add("implausible_units", spec.sensor_id,
               f"units: z reads {at_rest:.4g} {spec.unit} at rest where its configured offset "
               f"(gravity) is {offset:.4g} {spec.unit}: {g_read:.4g} m/s² of gravity instead of "
               f"{G_STANDARD:.4g}, a unit factor of {1 / ratio:.4g}; declared unit "
               f"{spec.unit!r}{looks}; sensor excluded", cs.time_ns(0), cs.time_ns(n - 1),
               "excluded")
    return True


def leave_one_out(m: np.ndarray, e: np.ndarray, avail: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Each channel predicted from the others of its sample, and its departure from it.

    Parameters
    ----------
    m : ndarray, shape (T, C)
        Measured components, SI.
    e : ndarray, shape (C, 2)
        Direction (X, Y) of each channel.
    avail : ndarray of bool, shape (T, C)
        Which channels take part at each sample.

    Returns
    -------
    residual, prediction : ndarray, shape (T, C)
        ``m - prediction`` and the least-squares prediction of each channel from the other
        available ones; NaN where fewer than two other directions are available.
    """
    res = np.full(m.shape, np.nan)
    pred = np.full(m.shape, np.nan)
    for rows, cols in availability_patterns(avail):
        if cols.size < 3:
            continue
        ep = e[cols]
        if np.linalg.matrix_rank(ep, tol=1e-6) < 2:
            continue
        hat = ep @ np.linalg.inv(ep.T @ ep) @ ep.T
        lever = 1.0 - np.diag(hat)
        ok = lever > 1e-9  # without channel j the others still span both directions
        whole = rows.size == m.shape[0]
        mm = m[:, cols] if whole else m[rows][:, cols]
        loo = (mm - mm @ hat.T)[:, ok] / lever[ok]
        if whole:
            res[:, cols[ok]] = loo
            pred[:, cols[ok]] = mm[:, ok] - loo
        else:
            res[np.ix_(rows, cols[ok])] = loo
            pred[np.ix_(rows, cols[ok])] = mm[:, ok] - loo
    return res, pred


def _per_sample(block_values: np.ndarray, starts: np.ndarray, n: int) -> np.ndarray:
    """Block values (n_blocks, C), the largest of each block and its neighbours, per sample."""
    v = np.where(np.isfinite(block_values), block_values, 0.0)
    pad = np.zeros((1, v.shape[1]))
    v = np.maximum.reduce([v, np.vstack([v[1:], pad]), np.vstack([pad, v[:-1]])])
    return v[np.searchsorted(starts, np.arange(n), side="right") - 1]


def check_accelerometers(cleaned: list[CleanSensor], starts: np.ndarray,
                         settings: IngestSettings, report: IngestReport) -> None:
    """Disagreeing seconds and glitches of every accelerometer channel, in place.

    ``starts`` are the first samples of the seconds (:func:`~pier_monitor.core.ingest.clean.
    block_starts`).  Levels with fewer than three horizontal channels are not checked.
    """
    levels = sorted({cs.spec.level for cs in cleaned if cs.spec.kind == "acceleration"})
    for level in levels:
        chans = horizontal_channels(cleaned, "acceleration", level)
        if len(chans) < 3:
            continue
        m = np.stack([c.sensor.values[:, c.column] for c in chans], axis=1)
        base = np.stack([c.sensor.usable[:, c.column] for c in chans], axis=1) & np.isfinite(m)
        e = np.array([c.direction for c in chans])
        sigma = np.array([_noise_si(c) for c in chans])
        block_of = np.searchsorted(starts, np.arange(m.shape[0]), side="right") - 1
        # compare the motion, not the offsets: a bias or a tilt that leaks gravity into a
        # horizontal channel is a constant the configuration may not know, and the ingest
        # removes it before an event; each channel's median of the second is taken out
        dc = block_median(np.where(base, m, np.nan), starts)
        excluded = _disagreeing_seconds(m - np.nan_to_num(dc)[block_of], e, base, sigma,
                                        starts, settings)
        _exclude_seconds(chans, excluded, starts, level, report)
        base &= ~excluded[0][block_of]
        # ... but a change of that offset during the recording (a step, a drift, a slow
        # bias) is a fault, not the motion; seconds in which the channel already disagrees
        # (a wrong gain or sign: its slow motion is as wrong as the rest) are left out, and
        # so are seconds a channel lacks part of.  The means of the seconds, not their
        # medians: a mean of a rigid motion is the rigid motion of the means, a median not
        lengths = np.diff(np.append(starts, m.shape[0]))[:, None]
        whole = np.add.reduceat(base, starts, axis=0) == lengths
        means = np.add.reduceat(np.where(base, m, 0.0), starts, axis=0) / lengths
        moved = _offset_changes(np.where(whole, means, np.nan), e, sigma, starts, m.shape[0],
                                settings)
        _exclude_offsets(chans, moved, excluded[0], starts, level, report)
        base &= ~moved[0][block_of]
        m = m - np.nan_to_num(dc)[block_of]
        _mark_glitches(chans, m, e, base, sigma, starts, level, settings)


def _disagreeing_seconds(m: np.ndarray, e: np.ndarray, base: np.ndarray, sigma: np.ndarray,
                         starts: np.ndarray, settings: IngestSettings
                         ) -> tuple[np.ndarray, np.ndarray]:
    """``(excluded, share)``, both (n_blocks, C): the seconds in which a channel disagrees
    with the others, and by what share of the signal; the worst channel of a second first."""
    nb = starts.size
    block_of = np.searchsorted(starts, np.arange(m.shape[0]), side="right") - 1
    excluded = np.zeros((nb, m.shape[1]), dtype=bool)
    share = np.zeros((nb, m.shape[1]))
    lengths = np.diff(np.append(starts, m.shape[0]))
    short = lengths < 0.5 * lengths.max()
    for _ in range(_PASSES):
        res, pred = leave_one_out(m, e, base & ~excluded[block_of])
        med_r = block_median(np.abs(res), starts)
        # against the level's motion, not the channel's own share of it: a half-degree
        # misalignment leaks about 1 % of the motion across, which is a large share of a
        # channel that lies across the shaking
        largest = np.max(np.where(np.isfinite(pred), np.abs(pred), -1.0), axis=1)
        med_p = block_median(np.where(largest >= 0, largest, np.nan), starts)[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = med_r / med_p
        ratio[short] = np.nan  # a stub of a second at the end says nothing
        # a median |residual| of 3 sigma is far beyond noise (noise alone gives ~0.8 sigma)
        bad = (ratio > settings.disagree_rel) & (med_r > 3.0 * sigma) & ~excluded
        bad &= np.isfinite(ratio)
        if not bad.any():
            break
        worst = np.argmax(np.where(bad, ratio, -np.inf), axis=1)
        rows = np.flatnonzero(bad.any(axis=1))
        excluded[rows, worst[rows]] = True
        share[rows, worst[rows]] = ratio[rows, worst[rows]]
    return excluded, share


def _offset_changes(dc: np.ndarray, e: np.ndarray, sigma: np.ndarray, starts: np.ndarray,
                    n: int, settings: IngestSettings) -> tuple[np.ndarray, np.ndarray]:
    """``(moved, dev)``, both (n_blocks, C): the seconds in which a channel's offset has left
    the one it holds where the data begin, and by how much (m/s²).

    ``dc`` are the channels' means of each second (NaN where a channel lacks part of
    it).  Each channel's offset where the data begin (its constant bias, or the gravity a
    tilt leaks into it; :func:`_offsets`) is taken out; what is left is the slow part of the
    level's rigid motion, which each channel must follow as the other channels of the level
    predict it (:func:`leave_one_out`).  A departure from that prediction that lasts (the
    offset has changed since) is an offset step, a drift or a slow bias of the channel: it is
    *moved* where it exceeds ``glitch_threshold`` times the channel's configured noise plus
    five times ``gain_rel`` of the predicted slow motion (the gains the configuration does
    not state), for at least two seconds in a row; a moved span then extends over the
    neighbouring seconds whose departure still exceeds half the noise term.  The worst
    channel of a second is taken first (:data:`_PASSES` channels per second at most), so that
    one faulty channel does not make its partners look faulty.
    """
    nb, n_ch = dc.shape
    moved = np.zeros((nb, n_ch), dtype=bool)
    dev = np.full((nb, n_ch), np.nan)
    lengths = np.diff(np.append(starts, n))
    short = lengths < 0.5 * lengths.max()  # a stub of a second at an end says little
    ok = np.isfinite(dc) & ~short[:, None]
    if ok.sum(axis=0).min(initial=nb) < 5:
        return moved, dev
    slow = dc - _offsets(dc, e, ok)
    floor = settings.glitch_threshold * sigma
    for _ in range(_PASSES):
        res, pred = leave_one_out(np.nan_to_num(slow), e, ok & ~moved)
        largest = np.max(np.where(np.isfinite(pred), np.abs(pred), 0.0), axis=1)
        thr = floor[None, :] + 5.0 * settings.gain_rel * largest[:, None]
        with np.errstate(invalid="ignore"):
            z = np.where(np.isfinite(res) & ~moved, np.abs(res) / thr, 0.0)
        worst = np.argmax(z, axis=1)
        hit = np.zeros_like(moved)
        rows = np.flatnonzero(z[np.arange(nb), worst] > 1.0)
        hit[rows, worst[rows]] = True
        new = False
        for c in range(n_ch):
            for b0, b1 in runs_of(hit[:, c]):
                if b1 == b0 and not (moved[max(b0 - 1, 0), c] or
                                     moved[min(b1 + 1, nb - 1), c]):
                    continue  # a single second: the disagreement check's business
                lo, hi = b0, b1
                weak = np.abs(np.nan_to_num(res[:, c])) > 0.5 * floor[c]
                while lo > 0 and weak[lo - 1] and not moved[lo - 1, c]:
                    lo -= 1
                while hi < nb - 1 and weak[hi + 1] and not moved[hi + 1, c]:
                    hi += 1
                moved[lo:hi + 1, c] = True
                dev[lo:hi + 1, c] = res[lo:hi + 1, c]
                new = True
        if not new:
            break
    return moved, dev


def _offsets(dc: np.ndarray, e: np.ndarray, ok: np.ndarray) -> np.ndarray:
    """The channels' constant offsets (C,), as they are when the data begin: the median,
    over the first :data:`_REFERENCE_S` seconds in which every channel has data, of the part
    of the means ``dc`` (n_blocks, C) that no rigid motion of the level explains (what is
    left after the least-squares fit of the two horizontal components).  That part is
    constant while the channels hold their offsets, shaking or not.  Without enough such
    seconds, each channel's median over the recording."""
    full = np.flatnonzero(ok.all(axis=1))[:_REFERENCE_S]
    fallback = nan_median(np.where(ok, dc, np.nan), axis=0)
    if full.size < 5 or np.linalg.matrix_rank(e, tol=1e-6) < 2:
        return np.nan_to_num(fallback)
    hat = e @ np.linalg.inv(e.T @ e) @ e.T
    rest = dc[full] - dc[full] @ hat.T
    return np.median(rest, axis=0)


def _exclude_offsets(chans: list[HorizontalChannel], moved: tuple[np.ndarray, np.ndarray],
                     disagreeing: np.ndarray, starts: np.ndarray, level: int,
                     report: IngestReport) -> None:
    """Exclude the seconds of :func:`_offset_changes`, one finding per span: ``offset_step``
    where the offset is already off in its first seconds, ``drift`` where it grows.  A span
    starts with the seconds just before it in which the channel already disagrees (the
    second of a step mixes both offsets), so that it names when the change happened."""
    mask, dev = moved
    n = chans[0].sensor.values.shape[0]
    for c, ch in enumerate(chans):
        for b0, b1 in runs_of(mask[:, c]):
            d = np.nan_to_num(dev[b0:b1 + 1, c])
            while b0 > 0 and disagreeing[b0 - 1, c]:
                b0 -= 1
            s0 = int(starts[b0])
            s1 = int(starts[b1 + 1]) - 1 if b1 + 1 < starts.size else n - 1
            ch.sensor.usable[s0:s1 + 1, ch.column] = False
            t0, t1 = ch.sensor.time_ns(s0), ch.sensor.time_ns(s1)
            peak = float(d[np.argmax(np.abs(d))])
            step = abs(np.mean(d[:2])) >= 0.5 * abs(np.median(d))
            code, what = (("offset_step", "steps") if step else ("drift", "drifts"))
            report.add(code, ch.name,
                       f"its offset {what} away from the other accelerometers at level "
                       f"{level} {fmt_span(t0, t1)}: by up to {peak:+.3g} m/s² against "
                       "the offset it holds where the data begin (beyond its noise and "
                       "gain); excluded there", t0, t1, "excluded")


def _exclude_seconds(chans: list[HorizontalChannel], excluded: tuple[np.ndarray, np.ndarray],
                     starts: np.ndarray, level: int, report: IngestReport) -> None:
    mask, share = excluded
    n = chans[0].sensor.values.shape[0]
    for c, ch in enumerate(chans):
        for b0, b1 in runs_of(mask[:, c]):
            s0 = int(starts[b0])
            s1 = int(starts[b1 + 1]) - 1 if b1 + 1 < starts.size else n - 1
            ch.sensor.usable[s0:s1 + 1, ch.column] = False
            t0, t1 = ch.sensor.time_ns(s0), ch.sensor.time_ns(s1)
            report.add("inconsistent", ch.name,
                       f"disagrees with the other accelerometers at level {level} "
                       f"{fmt_span(t0, t1)}: it departs from their prediction by "
                       f"{np.median(share[b0:b1 + 1, c]):.0%} of the signal (more than "
                       "its noise and gain allow); excluded there", t0, t1, "excluded")


def _mark_glitches(chans: list[HorizontalChannel], m: np.ndarray, e: np.ndarray,
                   base: np.ndarray, sigma: np.ndarray, starts: np.ndarray, level: int,
                   settings: IngestSettings) -> None:
    """Samples far off the other channels' prediction become missing (flag GLITCH)."""
    glitch = np.zeros(m.shape, dtype=bool)
    for _ in range(_PASSES):
        res, pred = leave_one_out(m, e, base & ~glitch)
        spread = _per_sample(1.4826 * block_median(np.abs(res), starts), starts, m.shape[0])
        thr = (settings.glitch_threshold * np.maximum(spread, sigma)
               + settings.glitch_rel * np.abs(pred))
        with np.errstate(invalid="ignore"):
            z = np.where(np.isfinite(res), np.abs(res) / thr, 0.0)
        worst = np.argmax(z, axis=1)
        rows = np.flatnonzero(z[np.arange(m.shape[0]), worst] > 1.0)
        if rows.size == 0:
            break
        glitch[rows, worst[rows]] = True
        for r, c in zip(rows, worst[rows]):  # what the finding will say
            chans[c].sensor.details.setdefault(
                (chans[c].column, int(r)),
                f"departs by {fmt_recorded(chans[c].sensor.spec, chans[c].column, res[r, c])} "
                f"from the other "
                f"accelerometers at level {level}")
    for c, ch in enumerate(chans):
        cs = ch.sensor
        for s0, s1 in runs_of(glitch[:, c]):
            cs.values[s0:s1 + 1, ch.column] = np.nan
            cs.flags[s0:s1 + 1, ch.column] = GLITCH
            first = cs.details.get((ch.column, s0))
            if first is None:  # a burst: describe it by its first marked sample
                hits = [k for k in range(s0, s1 + 1) if (ch.column, k) in cs.details]
                first = cs.details[(ch.column, hits[0])] if hits else "departs from its neighbours"
                cs.details[(ch.column, s0)] = first


def check_displacement(cleaned: list[CleanSensor], level: int, sl: slice,
                       a_rel_xy: np.ndarray, ag_xy: np.ndarray, rate_hz: float,
                       settings: IngestSettings) -> list[tuple[HorizontalChannel, float]]:
    """Displacement channels of a level that disagree with its relative acceleration.

    Over ``sl`` (an event and its context), each displacement channel usable there and the
    level's relative acceleration ``a_rel_xy`` (T, 2) integrated twice are compared in the
    band 0.2-10 Hz (tapered, detrended).  The accelerometers' gains are known to about a per
    cent, and a gain mismatch between the level's and the foundation's turns a per cent of
    the ground's displacement into apparent relative motion (large under a strong shaking,
    for a stiff level): the comparison first removes the best such mismatch (within
    ``5 × gain_rel``), using the foundation acceleration ``ag_xy`` (T, 2).  Returns
    ``[(channel, share), ...]`` for the channels whose residual exceeds ``disagree_rel`` of
    the predicted motion and five times their noise.
    """
    chans = [c for c in horizontal_channels(cleaned, "displacement", level)
             if c.sensor.usable[sl, c.column].all()]
    n = a_rel_xy.shape[0]
    if not chans or n < 64:
        return []
    taper = signal.windows.tukey(n, 0.1)
    f = np.fft.rfftfreq(n, 1.0 / rate_hz)
    band = (f >= _BAND_HZ[0]) & (f <= min(_BAND_HZ[1], 0.4 * rate_hz))
    w2 = (2.0 * np.pi * f[band]) ** 2

    def displacement(acc_xy: np.ndarray) -> np.ndarray:
        spec = np.fft.rfft(signal.detrend(acc_xy, axis=0) * taper[:, None], axis=0)[band]
        return -spec / w2[:, None]

    disp_xy = displacement(a_rel_xy)
    ground_xy = displacement(ag_xy)
    bound = 5.0 * settings.gain_rel
    out = []
    for ch in chans:
        x = ch.sensor.values[sl, ch.column]
        if not np.isfinite(x).all():
            continue  # a slower sensor (GNSS): it is fused, not judged here
        meas = np.fft.rfft(signal.detrend(x) * taper)[band]
        pred = disp_xy @ ch.direction
        # gains: (1 + e_l) of the level's absolute motion, (1 + e_0) of the foundation's
        cols = np.stack([pred, ground_xy @ ch.direction], axis=1)
        real = lambda z: np.concatenate([z.real, z.imag])
        coef = np.linalg.lstsq(np.column_stack([real(cols[:, 0]), real(cols[:, 1])]),
                               real(meas - pred), rcond=None)[0]
        pred = pred + cols @ np.clip(coef, -bound, bound)
        res_energy = float(np.sum(np.abs(meas - pred) ** 2))
        share = np.sqrt(res_energy / max(float(np.sum(np.abs(pred) ** 2)), 1e-300))
        res_rms = np.sqrt(2.0 * res_energy) / n  # Parseval, one-sided spectrum
        if share > settings.disagree_rel and res_rms > 5.0 * _noise_si(ch):
            out.append((ch, float(share)))
    return out


def _block_line_fit(x: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and RMS about a straight line of ``x`` (T,) over each block: ``(mean, spread)``,
    both (n_blocks,); NaN for a block that lacks a sample."""
    n = x.shape[0]
    lengths = np.diff(np.append(starts, n)).astype(float)
    block_of = np.searchsorted(starts, np.arange(n), side="right") - 1
    k = np.arange(n) - starts[block_of] - 0.5 * (lengths[block_of] - 1.0)  # centred time
    sx = np.add.reduceat(x, starts)
    mean = sx / lengths
    d = x - mean[block_of]
    skk = np.add.reduceat(k * k, starts)
    slope = np.add.reduceat(k * d, starts) / np.where(skk > 0, skk, np.inf)
    r = d - slope[block_of] * k
    spread = np.sqrt(np.add.reduceat(r * r, starts) / lengths)
    return mean, spread


def check_wires_at_rest(cleaned: list[CleanSensor], starts: np.ndarray,
                        settings: IngestSettings, report: IngestReport) -> None:
    """Exclude, in place, the displacement channels that drift while the pier is at rest.

    The double integral of the acceleration cannot see a displacement sensor's slow drift
    (a constant velocity is an integration constant), but the pier can: it does not creep by
    millimetres in seconds, and while its level is still a wire must hold a constant.  A
    second is *at rest* for a channel when the channel's own samples lie within three times
    its configured noise of a straight line over that second, and the level's accelerometers
    (where it has usable ones) stay within ``trigger_noise_factor`` times their noise of
    their mean.  Over each stretch of such seconds in a row, cut in pieces of
    :data:`_REST_PIECE_S` seconds (at least :data:`_REST_MIN_S`), the straight line through
    the channel's means of the seconds must not move by more than :data:`_REST_SETTLE` times
    ``glitch_threshold`` times its noise (3 mm for a 0.1 mm noise: drifts from about
    20 mm/min are found), and only where the level has been still since the data began or
    for :data:`_SETTLED_S` seconds (right after a strong shaking a damaged pier settles by
    that much).  A channel that moves more drifts: it is excluded for the whole recording
    (its drift over the events cannot be told), with a ``drift`` finding naming the stretch
    and the rate.  Channels sampled slower than the grid (GNSS) are not
    judged here.
    """
    n = cleaned[0].values.shape[0] if cleaned else 0
    if n == 0:
        return
    lengths = np.diff(np.append(starts, n))
    whole_len = lengths >= 0.5 * lengths.max()
    levels = sorted({cs.spec.level for cs in cleaned if cs.spec.kind == "displacement"})
    for level in levels:
        still = whole_len.copy()
        accs = horizontal_channels(cleaned, "acceleration", level)
        if accs:
            spreads = []
            for ch in accs:
                a = ch.sensor.values[:, ch.column]
                good = ch.sensor.usable[:, ch.column] & np.isfinite(a)
                _, spread = _block_line_fit(np.where(good, a, np.nan), starts)
                spreads.append(spread / (settings.trigger_noise_factor * _noise_si(ch)))
            quiet = nan_median(np.stack(spreads, axis=1), axis=1)
            still &= ~(quiet > 1.0)  # a second without usable accelerometers: the wire alone
        for ch in horizontal_channels(cleaned, "displacement", level):
            x = ch.sensor.values[:, ch.column]
            good = ch.sensor.usable[:, ch.column]
            if not good.any() or not np.isfinite(x[good]).all():
                continue  # no data, or a slower sensor (GNSS)
            sigma = _noise_si(ch)
            mean, spread = _block_line_fit(np.where(good, x, np.nan), starts)
            rest = still & np.isfinite(spread) & (spread < 3.0 * sigma)
            # a pier settles after it moved: only seconds still since the data began, or
            # for _SETTLED_S, are judged
            moving = np.append(-1, np.flatnonzero(~rest & whole_len))  # -1: none yet
            last = moving[np.searchsorted(moving, np.arange(rest.size)) - 1]
            since = np.where(last >= 0, np.arange(rest.size) - last, np.iinfo(np.int64).max)
            rest &= since > _SETTLED_S
            worst = None
            for r0, r1 in runs_of(rest):
                for b0 in range(r0, r1 + 1, _REST_PIECE_S):
                    b1 = min(b0 + _REST_PIECE_S - 1, r1)
                    if b1 - b0 + 1 < _REST_MIN_S:
                        continue
                    t = (starts[b0:b1 + 1] + 0.5 * lengths[b0:b1 + 1]) / ch.sensor.rate_hz
                    rate = float(np.polyfit(t, mean[b0:b1 + 1], 1)[0])
                    moved = rate * (t[-1] - t[0])
                    if worst is None or abs(moved) > abs(worst[2]):
                        worst = (b0, b1, moved, rate)
            allowed = _REST_SETTLE * settings.glitch_threshold * sigma
            if worst is not None and abs(worst[2]) > allowed:
                b0, b1, moved, rate = worst
                ch.sensor.usable[:, ch.column] = False
                s0 = int(starts[b0])
                s1 = int(starts[b1 + 1]) - 1 if b1 + 1 < starts.size else n - 1
                t0, t1 = ch.sensor.time_ns(s0), ch.sensor.time_ns(s1)
                report.add("drift", ch.name,
                           f"drifts while level {level} is at rest {fmt_span(t0, t1)}: it moves "
                           f"{moved * 1e3:+.3g} mm ({rate * 60e3:+.3g} mm/min) where its "
                           "samples and the level's accelerometers show no motion beyond "
                           "their noise; excluded for the whole recording",
                           ch.sensor.time_ns(0), ch.sensor.time_ns(n - 1), "excluded")
