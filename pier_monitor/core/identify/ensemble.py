"""The data of an ensemble's members: the measured window, perturbed as its noise allows.

An identification's uncertainty comes from re-identifying under data that differ as much as
the measurement's own errors do (randomise-then-optimise: for a linear Gaussian problem the
members are exact samples of the posterior; here they are its honest approximation).  A
member's window is the measured one plus a draw of those errors:

* white noise of the accelerations' ``noise.a`` (and ``noise.ag`` on the foundation);
* for velocities and displacements that come from a smoother (wires fused with
  accelerometers), errors correlated in time: a stationary Gauss-Markov process per level with
  the level's standard deviation ``noise.x`` and one-sample increment noise ``noise.dx``
  (white where the increment noise is unknown), likewise for ``v``;
* measured moments: white ``noise.f``;
* the sensors' gains, known only to ``noise.gain_rel``: each level's absolute acceleration
  and displacement scaled by its own ``1 + ε``, ``ε ~ N(0, gain_rel)``.

Member 0 is the measured window itself.  Levels that nothing measures stay NaN.  A method
may draw the gains wider than ``noise.gain_rel`` (``gain_scale``) and the velocities'
increments no rougher than the accelerations allow (``velocity_from_acceleration``); the
equation-error route does both (:class:`~pier_monitor.core.identify.methods.EquationErrorMethod`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pier_monitor.core.ingest.window import MeasuredWindow

__all__ = ["EnsembleDraws", "member_windows", "correlated_noise", "phase_randomised"]


def correlated_noise(rng: np.random.Generator, t_len: int, sigma: np.ndarray,
                     sigma_increment: np.ndarray) -> np.ndarray:
    """Stationary Gauss-Markov noise (T, N): level standard deviation ``sigma`` (N,) and
    one-sample increment standard deviation ``sigma_increment`` (N,); white where the
    increment noise is unknown (NaN) or at least ``√2 sigma``."""
    sigma = np.nan_to_num(np.asarray(sigma, dtype=float))
    inc = np.asarray(sigma_increment, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(np.isfinite(inc) & (sigma > 0), 1.0 - inc ** 2 / (2.0 * sigma ** 2), 0.0)
    rho = np.clip(rho, 0.0, 1.0 - 1e-12)
    xi = rng.standard_normal((t_len, sigma.size))
    out = np.empty_like(xi)
    out[0] = xi[0]
    scale = np.sqrt(1.0 - rho ** 2)
    for k in range(1, t_len):
        out[k] = rho * out[k - 1] + scale * xi[k]
    return out * sigma


def phase_randomised(rng: np.random.Generator, res: np.ndarray) -> np.ndarray:
    """A surrogate of the residuals ``res`` (T, K): the same amplitude spectrum per channel
    (so the same level and correlation in time), the phases drawn anew, the same phase
    shifts for every channel (so the channels' cross-correlation is kept too)."""
    if res.size == 0:
        return res
    spec = np.fft.rfft(res, axis=0)
    phase = np.exp(2j * np.pi * rng.random(spec.shape[0]))
    phase[0] = 1.0
    if res.shape[0] % 2 == 0:
        phase[-1] = 1.0
    return np.fft.irfft(spec * phase[:, None], n=res.shape[0], axis=0)


def _perturbed(window: MeasuredWindow, rng: np.random.Generator, gain_scale: float = 1.0,
               velocity_from_acceleration: bool = False) -> MeasuredWindow:
    noise, cov = window.noise, window.coverage
    t_len, n = window.a.shape

    def sd(values: np.ndarray) -> np.ndarray:
        return np.nan_to_num(np.asarray(values, dtype=float))

    ag = window.ag + (sd(noise.ag) if np.isfinite(noise.ag) else 0.0) * rng.standard_normal(t_len)
    a = window.a + sd(noise.a) * rng.standard_normal((t_len, n))
    dv = noise.dv
    if velocity_from_acceleration:  # increments no rougher than the accelerations allow
        dv = np.fmin(dv, sd(noise.a) * window.dt)
    v = window.v + correlated_noise(rng, t_len, noise.v, dv)
    x = window.x + correlated_noise(rng, t_len, noise.x, noise.dx)
    moments = window.moments
    if moments is not None:
        moments = moments + sd(noise.f) * rng.standard_normal((t_len, n))
    if gain_scale > 0 and noise.gain_rel > 0:
        eps_a = gain_scale * noise.gain_rel * rng.standard_normal(n)
        eps_x = gain_scale * noise.gain_rel * rng.standard_normal(n)
        a = a + eps_a * (a + ag[:, None])  # level accelerometers scaled, foundation the reference
        x = np.where(cov.displacement, x * (1.0 + eps_x), x)
    return dataclasses.replace(window, ag=ag, a=a, v=v, x=x, moments=moments)


def member_windows(window: MeasuredWindow, members: int, seed: int = 0, *,
                   gain_scale: float = 1.0, velocity_from_acceleration: bool = False
                   ) -> list[MeasuredWindow]:
    """The windows of ``members`` members: the measured one, then perturbed copies.

    Parameters
    ----------
    window : MeasuredWindow
        The measured window (its noise model says how much each quantity may be off).
    members : int
        Number of members ``M`` (1: the measured window alone).
    seed : int
        Seed of the perturbations.
    gain_scale : float
        The gains are drawn with ``gain_scale · noise.gain_rel`` (0: none).
    velocity_from_acceleration : bool
        The velocities' one-sample increment noise at most ``noise.a · Δt`` (a fused
        velocity's increments are the measured accelerations'), instead of ``noise.dv``.
    """
    rng = np.random.default_rng(seed)
    return [window] + [_perturbed(window, rng, gain_scale, velocity_from_acceleration)
                       for _ in range(members - 1)]


@dataclass(frozen=True)
class EnsembleDraws:
    """The members of an ensemble, as a method found them (M members, N springs).

    Attributes
    ----------
    params : ndarray, shape (M, N, 4)
        ``k1, k2, fy, c`` of each member (SI); ``fy`` of a spring that did not yield is the
        lower bound, its largest moment.
    ductility : ndarray, shape (M, N)
        Ductility factors, at most 1 where the member's spring did not yield.
    yielded : ndarray of bool, shape (M, N)
    """

    params: np.ndarray
    ductility: np.ndarray
    yielded: np.ndarray
