"""Measurement model of the synthetic recordings: sensor specs, imperfections, anti-aliasing.

A sensor of the configuration's map records the true 3-D motion ``u`` of its level (pier
frame, SI) as (:class:`~pier_monitor.core.model.config.SensorSpec`)::

    recorded_j = gain * signs_j * (u · e_j) / unit_factor + offsets_j + noise

With :class:`SensorImperfections` the sensor that records is not quite the one the
configuration describes, as on a real installation where gains and orientations are known
to about 1 % and 0.5° (SPEC §6): every channel's gain is off by a factor
``1 + N(0, gain_sd)``, the sensor's azimuth by ``N(0, misalignment_sd_deg)``, and an
accelerometer is also tilted (``N(0, tilt_sd_deg)`` about the pier's X and Y axes) and
biased (``N(0, acc_bias_sd_mps2)`` per channel).  An accelerometer senses gravity: the
configuration's offsets hold the reading of gravity for the nominal mounting (the ``z``
channel of a DC-coupled accelerometer reads ``gain * 1 g``), so the true sensor adds what
the nominal offsets miss, the static error ::

    offset_error_j = signs_j * G * (gain_true_j * ẑ · e_true_j - gain * ẑ · e_j) / unit_factor
                     + bias_j

(a tilt leaks gravity into the horizontal channels), and records
``gain_true_j * signs_j * (u · e_true_j) / unit_factor + offsets_j + offset_error_j + noise``.
The configuration keeps the nominal values; the errors actually drawn are the
:class:`SensorError` of each sensor, reported in the ground truth.

Like a real data logger, a sensor can low-pass its signal before sampling it
(:func:`anti_alias_filter`: zero-phase Butterworth at ``0.4 ×`` its own rate on the simulation's
1 ms signal), so that the higher modes of the pier do not alias into the band.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from scipy import signal
from scipy.spatial.transform import Rotation

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.config import PierConfig, SensorSpec
from pier_monitor.core.model.units import G_STANDARD

__all__ = [
    "ANTI_ALIAS_ORDER",
    "ANTI_ALIAS_CUTOFF_FRACTION",
    "SensorImperfections",
    "SensorError",
    "draw_sensor_errors",
    "anti_alias_filter",
    "record_sensor",
]

#: Order of the anti-aliasing Butterworth low-pass (applied forward and backward).
ANTI_ALIAS_ORDER = 8
#: Corner frequency of the anti-aliasing low-pass, as a fraction of the sensor's rate.
ANTI_ALIAS_CUTOFF_FRACTION = 0.4

_UP = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True)
class SensorImperfections:
    """How far the true sensors are from the nominal ones of the configuration.

    Attributes
    ----------
    gain_sd : float
        Standard deviation of the relative gain error of each channel (0.01 = 1 %).
    misalignment_sd_deg : float
        Standard deviation of the azimuth error of each sensor (about the vertical), deg.
    tilt_sd_deg : float
        Standard deviation of an accelerometer's tilt about each of the pier's horizontal
        axes, deg; leaks gravity into the horizontal channels.
    acc_bias_sd_mps2 : float
        Standard deviation of an accelerometer's extra bias per channel, m/s².
    seed : int or None
        Seed of the draws (one installation); ``None`` derives them from the seed of the
        recording, so that every noise seed also gets its own installation errors.
    """

    gain_sd: float = 0.01
    misalignment_sd_deg: float = 0.5
    tilt_sd_deg: float = 0.2
    acc_bias_sd_mps2: float = 0.005
    seed: int | None = None

    def __post_init__(self) -> None:
        for name in ("gain_sd", "misalignment_sd_deg", "tilt_sd_deg", "acc_bias_sd_mps2"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (math.isfinite(value) and value >= 0):
                raise InputDataError(f"sensor imperfections: {name}: expected a non-negative "
                                     f"number, got {value}")
        if self.gain_sd >= 0.2:
            raise InputDataError(f"sensor imperfections: gain_sd: expected a relative error "
                                 f"well below 0.2, got {self.gain_sd}")

    def as_dict(self) -> dict[str, Any]:
        """Plain form, for JSON."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class SensorError:
    """The true deviations of one sensor from its nominal specification.

    Attributes
    ----------
    gain_factors : tuple of float, shape (n_axes,)
        True gain of each channel divided by the nominal ``gain``.
    orientation_error_deg : float
        True azimuth minus the nominal ``orientation_deg``, deg.
    tilt_deg : tuple of float, shape (2,)
        Rotation of the sensor about the pier's X and Y axes, deg (zero but for
        accelerometers).
    bias : tuple of float, shape (n_axes,)
        Extra bias of each channel, in the sensor's unit (zero but for accelerometers).
    offset_error : tuple of float, shape (n_axes,)
        Static reading of each channel that the configuration's offsets miss (tilted
        gravity, gain error on gravity, bias), in the sensor's unit.
    """

    gain_factors: tuple[float, ...]
    orientation_error_deg: float
    tilt_deg: tuple[float, float]
    bias: tuple[float, ...]
    offset_error: tuple[float, ...]

    def directions(self, spec: SensorSpec) -> np.ndarray:
        """True unit vectors (X, Y, Z) of the sensor's axes in the pier frame, shape (n_axes, 3)."""
        turned = dataclasses.replace(spec, orientation_deg=spec.orientation_deg
                                     + self.orientation_error_deg)
        nominal = np.stack([turned.axis_direction(a) for a in spec.axes])
        tilt = Rotation.from_rotvec(np.radians([*self.tilt_deg, 0.0])).as_matrix()
        return nominal @ tilt.T

    def as_dict(self, spec: SensorSpec | None = None) -> dict[str, Any]:
        """Plain form for JSON; with ``spec``, also its kind, unit, axes and SI values."""
        out: dict[str, Any] = {
            "gain_factors": list(self.gain_factors),
            "orientation_error_deg": self.orientation_error_deg,
            "tilt_deg": list(self.tilt_deg),
            "bias": list(self.bias),
            "offset_error": list(self.offset_error),
        }
        if spec is not None:
            out.update(kind=spec.kind, unit=spec.unit, axes=list(spec.axes),
                       bias_si=[b * spec.si_factor for b in self.bias],
                       offset_error_si=[o * spec.si_factor for o in self.offset_error])
        return out

    @classmethod
    def from_dict(cls, raw: Mapping[str, Any]) -> "SensorError":
        """Inverse of :meth:`as_dict`."""
        return cls(gain_factors=tuple(float(g) for g in raw["gain_factors"]),
                   orientation_error_deg=float(raw["orientation_error_deg"]),
                   tilt_deg=tuple(float(t) for t in raw["tilt_deg"]),  # type: ignore[arg-type]
                   bias=tuple(float(b) for b in raw["bias"]),
                   offset_error=tuple(float(o) for o in raw["offset_error"]))


def _nominal_directions(spec: SensorSpec) -> np.ndarray:
    return np.stack([spec.axis_direction(a) for a in spec.axes])  # (n_axes, 3)


def _draw_one(spec: SensorSpec, imperfections: SensorImperfections,
              rng: np.random.Generator) -> SensorError:
    n = len(spec.axes)
    gains = 1.0 + imperfections.gain_sd * rng.standard_normal(n)
    yaw = imperfections.misalignment_sd_deg * float(rng.standard_normal())
    tilt = imperfections.tilt_sd_deg * rng.standard_normal(2)
    bias_si = imperfections.acc_bias_sd_mps2 * rng.standard_normal(n)
    accelerometer = spec.kind == "acceleration"
    if not accelerometer:
        tilt, bias_si = np.zeros(2), np.zeros(n)
    bias = bias_si / spec.si_factor
    error = SensorError(tuple(gains.tolist()), yaw, (float(tilt[0]), float(tilt[1])),
                        tuple(bias.tolist()), tuple(bias.tolist()))
    if accelerometer:
        signs = np.asarray(spec.signs, dtype=float)
        gravity = signs * G_STANDARD * (spec.gain * gains * (error.directions(spec) @ _UP)
                                        - spec.gain * (_nominal_directions(spec) @ _UP))
        error = dataclasses.replace(
            error, offset_error=tuple((gravity / spec.si_factor + bias).tolist()))
    return error


def draw_sensor_errors(config: PierConfig, imperfections: SensorImperfections,
                       seq: np.random.SeedSequence) -> dict[str, SensorError]:
    """Draw the true errors of every sensor of the map (one child seed per sensor).

    Parameters
    ----------
    config : PierConfig
        The nominal sensor map.
    imperfections : SensorImperfections
        Spread of the errors.
    seq : numpy.random.SeedSequence
        Seed of the draws (``imperfections.seed`` takes precedence when set).

    Returns
    -------
    dict of str to SensorError
        By sensor id, in the order of the map.
    """
    if imperfections.seed is not None:
        seq = np.random.SeedSequence(imperfections.seed)
    children = seq.spawn(len(config.sensors))
    return {spec.sensor_id: _draw_one(spec, imperfections, np.random.default_rng(child))
            for spec, child in zip(config.sensors, children)}


def anti_alias_filter(x: np.ndarray, rate_hz: float, sensor_rate_hz: float) -> np.ndarray:
    """Low-pass a signal like a data logger before sampling it at ``sensor_rate_hz``.

    Zero-phase (forward and backward) Butterworth of order :data:`ANTI_ALIAS_ORDER` with its
    corner at :data:`ANTI_ALIAS_CUTOFF_FRACTION` ``× sensor_rate_hz``.

    Parameters
    ----------
    x : ndarray, shape (T, C)
        Signal sampled at ``rate_hz``, time-first.
    rate_hz : float
        Its sampling rate, Hz.
    sensor_rate_hz : float
        The rate it is about to be sampled at, Hz; at most ``rate_hz``.

    Returns
    -------
    ndarray, shape (T, C)
    """
    if not (0 < sensor_rate_hz <= rate_hz):
        raise InputDataError(f"anti_alias_filter: sensor rate {sensor_rate_hz:g} Hz must be positive "
                             f"and at most the signal's {rate_hz:g} Hz")
    sos = signal.butter(ANTI_ALIAS_ORDER, ANTI_ALIAS_CUTOFF_FRACTION * sensor_rate_hz,
                        fs=rate_hz, output="sos")
    return signal.sosfiltfilt(sos, x, axis=0)


def record_sensor(spec: SensorSpec, motion: np.ndarray, rng: np.random.Generator,
                  error: SensorError | None = None) -> np.ndarray:
    """Record the true motion of the sensor's level with the measurement model.

    Parameters
    ----------
    spec : SensorSpec
        The nominal sensor.
    motion : ndarray, shape (T, 3)
        True motion (X, Y, Z) in the pier frame, SI, at the sensor's sample times.
    rng : numpy.random.Generator
        Source of the white noise of ``spec.noise_rms``.
    error : SensorError, optional
        How the true sensor differs from ``spec``; ``None``: it is exactly ``spec``.

    Returns
    -------
    ndarray, shape (T, n_axes)
        The recorded channels, in the sensor's unit.
    """
    if error is None:
        directions, gain, static = _nominal_directions(spec), spec.gain, None
    else:
        directions = error.directions(spec)
        gain = spec.gain * np.asarray(error.gain_factors)
        static = np.asarray(error.offset_error)
    projected = motion @ directions.T  # (T, n_axes)
    signs = np.asarray(spec.signs, dtype=float)
    offsets = np.asarray(spec.offsets, dtype=float)
    recorded = gain * signs * projected / spec.si_factor + offsets
    if static is not None:
        recorded = recorded + static
    if spec.noise_rms > 0:
        recorded = recorded + spec.noise_rms * rng.standard_normal(recorded.shape)
    return recorded
