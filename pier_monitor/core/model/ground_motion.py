"""Ground motions: a seeded synthetic near-fault generator and accelerogram files.

Accelerations are held in m/s², time-first, uniformly sampled from ``t = 0``.

File formats read by :func:`load_accelerogram`:

* one value per line, with ``dt`` given;
* two columns ``time, acceleration`` (``dt`` taken from the time column, which must be
  uniform);
* more columns only with the acceleration column chosen (``column``, counted from 1); the
  time is then column 1 unless ``dt`` is given (a file of several components would
  otherwise be read as one record);
* PEER NGA ``.AT2`` files (four header lines, ``NPTS= …, DT= …`` on the fourth, values in g,
  several per row).

Lines starting with ``#`` or ``%`` are comments.  The unit must be declared: ``g``, ``gal``
(cm/s²) or ``mps2`` (m/s²).  A record whose peak exceeds :data:`MAX_PGA_MPS2` (5 g), read or
scaled, is refused as implausible.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from scipy import signal

from pier_monitor.core.errors import GroundMotionError
from pier_monitor.core.model.units import to_si_factor

__all__ = ["GroundMotion", "synthetic_near_fault", "load_accelerogram", "el_centro_1940",
           "UNIT_CHOICES", "MAX_PGA_MPS2"]

UNIT_CHOICES = ("g", "gal", "mps2")
#: Largest plausible peak ground acceleration, m/s² (5 g; the strongest records reach 3-4 g).
MAX_PGA_MPS2 = 50.0


def _check_plausible(acc: np.ndarray, what: str, hint: str = "") -> None:
    peak = float(np.max(np.abs(acc)))
    if peak > MAX_PGA_MPS2:
        raise GroundMotionError(f"{what}: peak {peak:.3g} m/s^2 is implausible for a ground "
                                f"motion (> {MAX_PGA_MPS2:g} m/s^2 = 5 g){hint}")


@dataclass(frozen=True)
class GroundMotion:
    """A uniformly sampled ground-acceleration record.

    Attributes
    ----------
    acc : ndarray, shape (S,)
        Acceleration, m/s².
    dt : float
        Sampling period, s.
    name : str
        Where it came from (file name or generator settings).
    """

    acc: np.ndarray
    dt: float
    name: str = ""

    def __post_init__(self) -> None:
        acc = np.asarray(self.acc, dtype=float)
        if acc.ndim != 1 or acc.size < 2:
            raise GroundMotionError(f"{self.name or 'ground motion'}: expected a 1-D record of at "
                                    f"least 2 samples, got shape {acc.shape}")
        bad = np.flatnonzero(~np.isfinite(acc))
        if bad.size:
            raise GroundMotionError(f"{self.name or 'ground motion'}: non-finite value at sample "
                                    f"{bad[0]} (t = {bad[0] * self.dt:.3f} s)")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise GroundMotionError(f"{self.name or 'ground motion'}: dt must be positive, "
                                    f"got {self.dt}")
        acc.setflags(write=False)
        object.__setattr__(self, "acc", acc)

    @property
    def t(self) -> np.ndarray:
        """Sample times, s, shape (S,)."""
        return np.arange(self.acc.size) * self.dt

    @property
    def duration_s(self) -> float:
        """Time of the last sample, s."""
        return (self.acc.size - 1) * self.dt

    @property
    def pga(self) -> float:
        """Peak ground acceleration, m/s²."""
        return float(np.max(np.abs(self.acc)))

    def scaled(self, factor: float) -> "GroundMotion":
        """The record multiplied by ``factor``; its peak must stay plausible
        (:data:`MAX_PGA_MPS2`)."""
        if not np.isfinite(factor) or factor <= 0:
            raise GroundMotionError(f"scale factor must be positive, got {factor}")
        acc = self.acc * factor
        _check_plausible(acc, f"{self.name or 'ground motion'} scaled by {factor:g}")
        return GroundMotion(acc, self.dt, f"{self.name} x{factor:g}")

    def scaled_to_pga(self, pga_mps2: float) -> "GroundMotion":
        """The record scaled so that its PGA is ``pga_mps2`` (m/s², at most
        :data:`MAX_PGA_MPS2`)."""
        if not np.isfinite(pga_mps2) or pga_mps2 <= 0:
            raise GroundMotionError(f"PGA must be positive, got {pga_mps2}")
        if pga_mps2 > MAX_PGA_MPS2:
            raise GroundMotionError(f"PGA {pga_mps2:g} m/s^2 is implausible for a ground motion "
                                    f"(> {MAX_PGA_MPS2:g} m/s^2 = 5 g)")
        if self.pga == 0:
            raise GroundMotionError(f"{self.name}: record is all zeros, cannot scale to a PGA")
        return GroundMotion(self.acc * (pga_mps2 / self.pga), self.dt,
                            f"{self.name} at PGA {pga_mps2:g} m/s2")

    def resampled(self, dt: float) -> "GroundMotion":
        """Linear interpolation onto a new step ``dt`` (s), same duration."""
        n = int(np.floor(self.duration_s / dt + 1e-9)) + 1
        return GroundMotion(np.interp(np.arange(n) * dt, self.t, self.acc), dt, self.name)


def _mp_pulse_velocity(t: np.ndarray, t0: float, fp: float, gamma: float, nu: float) -> np.ndarray:
    """Mavroeidis-Papageorgiou near-fault velocity pulse of unit amplitude."""
    arg = 2.0 * np.pi * fp * (t - t0)
    v = 0.5 * (1.0 + np.cos(arg / gamma)) * np.cos(arg + nu)
    v[np.abs(t - t0) > gamma / (2.0 * fp)] = 0.0
    return v


def synthetic_near_fault(duration_s: float = 60.0, dt: float = 0.01, pga_mps2: float = 8.0, *,
                         strong_start_s: float = 30.0, strong_duration_s: float = 8.0,
                         pulse_period_s: float = 1.2, pulse_share: float = 0.55,
                         dominant_hz: float = 2.0, seed: int = 8) -> GroundMotion:
    """A seeded synthetic near-fault accelerogram in the manner of JMA Kobe 1995.

    A velocity pulse (Mavroeidis & Papageorgiou 2003, period ``pulse_period_s``) on top of
    Kanai-Tajimi filtered noise (dominant frequency ``dominant_hz``, Clough-Penzien
    high-pass) under a build-up / strong / decay envelope that starts at
    ``strong_start_s``; weak pre-event noise before it.  Band-limited 0.1-20 Hz and scaled
    to ``pga_mps2``.

    Parameters
    ----------
    duration_s, dt : float
        Length and sampling period of the record, s.
    pga_mps2 : float
        Peak ground acceleration of the result, m/s².
    strong_start_s, strong_duration_s : float
        Onset and length of the strong-motion plateau, s.
    pulse_period_s : float
        Period of the near-fault velocity pulse, s.
    pulse_share : float
        Peak acceleration of the pulse relative to the noise part's peak, before scaling.
    dominant_hz : float
        Kanai-Tajimi ground frequency, Hz.
    seed : int
        Seed of the noise; the same arguments give the same record.

    Notes
    -----
    The defaults drive the paper's Table 1 pier at PGA 8 m/s² to ductility factors of
    about 4.9, 3.8, 1.03, 0.77, 0.51, 0.26 (springs 1-6), the pattern of the paper's
    Table 2 (5.2, 4.0, 1.04, elastic above), with the strong motion inside 30-50 s.
    """
    for name, val in (("duration_s", duration_s), ("dt", dt), ("pga_mps2", pga_mps2),
                      ("strong_duration_s", strong_duration_s), ("pulse_period_s", pulse_period_s),
                      ("dominant_hz", dominant_hz)):
        if not (np.isfinite(val) and val > 0):
            raise GroundMotionError(f"{name}: expected a positive number, got {val}")
    if not 0 <= strong_start_s < duration_s:
        raise GroundMotionError(
            f"strong_start_s: expected 0 <= value < duration_s={duration_s}, got {strong_start_s}")
    rng = np.random.default_rng(seed)
    n = int(round(duration_s / dt)) + 1
    t = np.arange(n) * dt
    # Kanai-Tajimi + Clough-Penzien filter as a continuous transfer function, discretised.
    wg, zg = 2 * np.pi * dominant_hz, 0.6
    wf, zf = 2 * np.pi * 0.25, 0.7
    num = np.polymul([2 * zg * wg, wg ** 2], [1.0, 0.0, 0.0])
    den = np.polymul([1.0, 2 * zg * wg, wg ** 2], [1.0, 2 * zf * wf, wf ** 2])
    bz, az = signal.bilinear(num, den, fs=1.0 / dt)
    noise = signal.lfilter(bz, az, rng.standard_normal(n))
    rise = 3.0
    env = np.where(t < strong_start_s - rise, 0.02,
                   np.where(t < strong_start_s,
                            0.02 + 0.98 * ((t - strong_start_s + rise) / rise) ** 2,
                            np.where(t < strong_start_s + strong_duration_s, 1.0,
                                     np.exp(-0.35 * (t - strong_start_s - strong_duration_s)))))
    acc = noise * env
    acc /= np.max(np.abs(acc))
    vel = _mp_pulse_velocity(t, strong_start_s + 0.4 * strong_duration_s, 1.0 / pulse_period_s,
                             gamma=2.0, nu=rng.uniform(0, np.pi))
    pulse = np.gradient(vel, dt)
    if np.max(np.abs(pulse)) > 0:
        acc = acc + pulse_share * pulse / np.max(np.abs(pulse))
    # band-limit like a processed strong-motion record; zero-phase, so no time shift
    sos = signal.butter(4, [0.1, min(20.0, 0.45 / dt)], btype="bandpass", fs=1.0 / dt,
                        output="sos")
    acc = signal.sosfiltfilt(sos, acc)
    taper = np.minimum(1.0, np.minimum(t, t[-1] - t) / 1.0)  # 1 s cosine-free ramps at the ends
    acc *= taper
    gm = GroundMotion(acc, dt, f"synthetic near-fault (seed {seed}, pulse {pulse_period_s:g} s)")
    return gm.scaled_to_pga(pga_mps2)


_AT2_HEADER = re.compile(r"NPTS\s*=\s*(\d+)\s*,?\s*DT\s*=\s*([0-9.eE+-]+)", re.IGNORECASE)


def load_accelerogram(path: str | Path, units: str, dt: float | None = None,
                      column: int | None = None) -> GroundMotion:
    """Read an accelerogram file (see the module docstring for the formats).

    Parameters
    ----------
    path : str or Path
        The file.
    units : {"g", "gal", "mps2"}
        Unit of the acceleration values in the file.
    dt : float, optional
        Sampling period, s; required for single-column files, checked against the file's
        own when it has one.
    column : int, optional
        The acceleration column, counted from 1; required for files of more than two
        columns (column 1 is then the time unless ``dt`` is given).

    Raises
    ------
    GroundMotionError
        Naming the file, and the line where the content is wrong.
    """
    path = Path(path)
    if units not in UNIT_CHOICES:
        raise GroundMotionError(f"{path.name}: units must be one of {UNIT_CHOICES}, got {units!r}")
    factor = to_si_factor("acceleration", units)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise GroundMotionError(f"{path}: cannot read accelerogram: {err.strerror}") from err
    lines = text.splitlines()
    file_dt: float | None = None
    start = 0
    # PEER .AT2: a header line with NPTS and DT among the first lines
    for i, line in enumerate(lines[:6]):
        m = _AT2_HEADER.search(line)
        if m:
            file_dt = float(m.group(2))
            start = i + 1
            break
    rows: list[list[float]] = []
    for lineno, line in enumerate(lines[start:], start=start + 1):
        stripped = line.strip()
        if not stripped or stripped[0] in "#%":
            continue
        try:
            rows.append([float(v) for v in stripped.replace(",", " ").split()])
        except ValueError:
            raise GroundMotionError(
                f"{path.name}: line {lineno}: not a number in {stripped[:60]!r}") from None
    if not rows:
        raise GroundMotionError(f"{path.name}: no acceleration values found")
    if column is not None and (isinstance(column, bool) or not isinstance(column, int)
                               or column < 1):
        raise GroundMotionError(f"{path.name}: column must be a column number from 1, got "
                                f"{column!r}")
    widths = {len(r) for r in rows}
    if file_dt is not None:  # AT2: values in rows of several columns, read row by row
        if column is not None:
            raise GroundMotionError(f"{path.name}: a PEER .AT2 file holds one record; do not "
                                    "choose a column")
        values = np.array([v for row in rows for v in row])
    elif len(widths) > 1:
        raise GroundMotionError(
            f"{path.name}: rows have different numbers of columns {sorted(widths)}; expected "
            "one column, two (time, acceleration), or a table with the acceleration column "
            "chosen")
    elif column is not None:
        (width,) = widths
        if column > width:
            raise GroundMotionError(f"{path.name}: column {column} chosen but the rows have "
                                    f"{width} columns")
        arr = np.array(rows)
        values = arr[:, column - 1]
        if dt is None and column != 1:
            file_dt = _time_column_step(path, arr[:, 0])
    else:
        (width,) = widths
        if width > 2:
            raise GroundMotionError(
                f"{path.name}: {width} columns; choose the acceleration column (column=, "
                "pier-monitor simulate --column N, counted from 1); the time is then column 1 "
                "unless dt is given")
        if width == 2:
            arr = np.array(rows)
            values = arr[:, 1]
            file_dt = _time_column_step(path, arr[:, 0])
        else:
            values = np.array([row[0] for row in rows])
    if file_dt is None:
        if dt is None:
            raise GroundMotionError(
                f"{path.name}: the file has no time column; give the sampling period dt")
        file_dt = dt
    elif dt is not None and abs(dt - file_dt) > 1e-6 * file_dt:
        raise GroundMotionError(f"{path.name}: dt={dt:g} s given, but the file says {file_dt:g} s")
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise GroundMotionError(
            f"{path.name}: non-finite value at sample {bad[0]} (t = {bad[0] * file_dt:.3f} s)")
    acc = values * factor
    _check_plausible(acc, f"{path.name}: after converting from {units!r}",
                     "; check the declared units")
    return GroundMotion(acc, float(file_dt), path.name)


def _time_column_step(path: Path, t_col: np.ndarray) -> float:
    """The step of a time column, which must increase uniformly from 0, s."""
    steps = np.diff(t_col)
    if steps.size == 0 or np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0]) if steps.size else 0
        raise GroundMotionError(
            f"{path.name}: time column must increase; it does not at row {i + 2}")
    file_dt = float(np.median(steps))
    off = np.flatnonzero(np.abs(steps - file_dt) > 1e-3 * file_dt)
    if off.size:
        raise GroundMotionError(
            f"{path.name}: time column is not uniform: step {steps[off[0]]:g} s at "
            f"t = {t_col[off[0]]:g} s, expected {file_dt:g} s")
    if abs(t_col[0]) > 1e-9:
        raise GroundMotionError(
            f"{path.name}: time column must start at 0, starts at {t_col[0]:g} s")
    return file_dt


def el_centro_1940() -> GroundMotion:
    """The 1940 Imperial Valley (El Centro, NS) record shipped with the package, m/s².

    US Geological Survey, public domain; 3995 samples at 0.02 s, PGA 3.07 m/s² (0.313 g).
    """
    ref = resources.files("pier_monitor") / "data" / "elcentro_1940_ns_g.txt"
    with resources.as_file(ref) as path:
        gm = load_accelerogram(path, units="g", dt=0.02)
    return GroundMotion(gm.acc, gm.dt, "El Centro 1940 NS")
