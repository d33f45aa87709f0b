"""Small numerical helpers shared by the core's layers (time-first arrays)."""

from __future__ import annotations

import numpy as np

__all__ = ["cumulative_trapezoid", "Detrend"]


def cumulative_trapezoid(y: np.ndarray, dt: float) -> np.ndarray:
    """Integral of ``y`` from its first sample along axis 0 (trapezoid rule), same shape.

    ``y`` of shape (T,) or (T, C), sampled every ``dt`` seconds; the result starts at 0.
    """
    y = np.asarray(y, dtype=float)
    out = np.zeros_like(y)
    out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1]) * dt, axis=0)
    return out


class Detrend:
    """Removes the least-squares polynomial of ``degree`` over windows of ``n_samples``.

    The polynomials are Legendre polynomials of the scaled time, orthonormalised once, so
    that ``Detrend(T, d)(y)`` is one projection per call for ``y`` of shape (T,) or (T, C).
    """

    def __init__(self, n_samples: int, degree: int) -> None:
        tau = np.linspace(-1.0, 1.0, n_samples)
        self._q = np.linalg.qr(np.polynomial.legendre.legvander(tau, degree))[0]

    def __call__(self, y: np.ndarray) -> np.ndarray:
        """``y`` without its polynomial part."""
        return y - self._q @ (self._q.T @ y)
