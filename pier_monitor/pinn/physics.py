"""Physics residuals of the PINN (paper eqs. 20-26 with SPEC §3's corrections), in torch.

All residuals are evaluated on training pairs ``(t, t + Δt)``.  Responses come as tensors
of shape ``(..., P, N)`` (``P`` pairs, ``N`` levels; a leading member dimension for an
ensemble), the foundation acceleration as ``(..., P)``, parameters as tensors of shape
``(..., N)``, so that members and batches of parameter sets (the paper's update rule tries
several at once) broadcast to residuals of shape ``(..., P, N)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

__all__ = ["PairTensors", "Physics"]


@dataclass
class PairTensors:
    """Responses at the two instants of every pair; each tensor has shape (P, N)."""

    a0: torch.Tensor
    v0: torch.Tensor
    x0: torch.Tensor
    f0: torch.Tensor
    a1: torch.Tensor
    v1: torch.Tensor
    x1: torch.Tensor
    f1: torch.Tensor


class Physics:
    """The link model's matrices and residual functions on one device.

    Parameters
    ----------
    b : tensor, shape (N, N)
        Angle matrix ``B`` (``θ = B x``), 1/m.
    masses : tensor, shape (N,)
        Lumped masses, kg.
    dt : float
        Pair spacing ``Δt`` (the data's sampling period), s.
    """

    def __init__(self, b: torch.Tensor, masses: torch.Tensor, dt: float) -> None:
        self.b = b
        self.bt = b.T.contiguous()
        self.m = masses
        self.dt = dt
        self.bt_inv = torch.linalg.inv(self.bt)

    def angles(self, x: torch.Tensor) -> torch.Tensor:
        """``θ = B x`` for ``x`` of shape (P, N)."""
        return x @ self.b.T

    def eom(self, a: torch.Tensor, v: torch.Tensor, f: torch.Tensor, ag: torch.Tensor,
            c: torch.Tensor) -> torch.Tensor:
        """``M(ẍ + 1 a_g) + Bᵀ diag(c) B ẋ + Bᵀ f`` (eq. 21), N; shape (..., P, N)."""
        damper = (self.angles(v) * c.unsqueeze(-2)) @ self.b  # (..., P, N): Bᵀ diag(c) B ẋ
        return self.m * (a + ag.unsqueeze(-1)) + damper + f @ self.b

    def newmark_acceleration(self, p: PairTensors, ag1: torch.Tensor,
                             c: torch.Tensor) -> torch.Tensor:
        """Eq. 22 as a residual, m/s²: ``(M + Δt/2 C) ẍ1 + M a_g1 + Bᵀ f1 + C (ẋ0 + Δt/2 ẍ0)``,
        divided by the masses (the paper's explicit inverse is avoided; same zero set)."""
        h = 0.5 * self.dt
        lhs = self.eom(p.a1, p.v0 + h * p.a0 + h * p.a1, p.f1, ag1, c)
        return lhs / self.m

    def newmark_velocity(self, p: PairTensors) -> torch.Tensor:
        """Eq. 23: ``ẋ1 − ẋ0 − Δt/2 (ẍ0 + ẍ1)``, m/s."""
        return p.v1 - p.v0 - 0.5 * self.dt * (p.a0 + p.a1)

    def newmark_displacement(self, p: PairTensors) -> torch.Tensor:
        """Eq. 24 with SPEC's correction: ``x1 − x0 − Δt ẋ0 − Δt²/3 ẍ0 − Δt²/6 ẍ1``, m."""
        dt = self.dt
        return p.x1 - p.x0 - dt * p.v0 - dt * dt / 3.0 * p.a0 - dt * dt / 6.0 * p.a1

    def _hysteresis_parts(self, p: PairTensors, k1: torch.Tensor, k2: torch.Tensor,
                          fy: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The residual and the mask of pairs that end inside the elastic range."""
        th0, th1 = self.angles(p.x0), self.angles(p.x1)
        k1, k2, fy = k1.unsqueeze(-2), k2.unsqueeze(-2), fy.unsqueeze(-2)
        s = fy * (1.0 - k2 / k1)
        trial = p.f0 + k1 * (th1 - th0)
        lo, hi = k2 * th1 - s, k2 * th1 + s
        return p.f1 - torch.minimum(torch.maximum(trial, lo), hi), (trial > lo) & (trial < hi)

    def hysteresis(self, p: PairTensors, k1: torch.Tensor, k2: torch.Tensor,
                   fy: torch.Tensor) -> torch.Tensor:
        """Incremental bilinear residual (SPEC §3), N·m; shape (..., P, N).

        ``f1 − clip(f0 + k1 (θ1 − θ0), k2 θ1 − s, k2 θ1 + s)``, ``s = fy (1 − k2/k1)``.
        """
        return self._hysteresis_parts(p, k1, k2, fy)[0]

    def hysteresis_with_variance(self, p: PairTensors, k1: torch.Tensor, k2: torch.Tensor,
                                 fy: torch.Tensor, var_df: torch.Tensor,
                                 var_dtheta: torch.Tensor, var_f: torch.Tensor,
                                 var_theta: torch.Tensor, floor: torch.Tensor
                                 ) -> tuple[torch.Tensor, torch.Tensor]:
        """The hysteresis residual and its variance from the noise of ``f`` and ``θ``, (N·m)².

        Elastic pair (the residual is an increment): ``σ_Δf² + k1² σ_Δθ²``; pair ending on a
        yield line: ``σ_f² + k2² σ_θ²``; plus ``floor²``, the residual the 100 Hz sampling
        leaves on exact data.  For white noise ``σ_Δ² = 2 σ²``; smoothed data have
        correlated errors and much smaller increment noise.  Dividing the residual by its
        standard deviation makes the fit of ``k1`` an errors-in-variables (Deming) fit:
        without it, noise on the angle increments biases ``k1`` low, most on lightly loaded
        springs.  All variances and ``floor`` have shape (N,).
        """
        residual, elastic = self._hysteresis_parts(p, k1, k2, fy)
        var_el = var_df + k1.unsqueeze(-2) ** 2 * var_dtheta
        var_y = var_f + k2.unsqueeze(-2) ** 2 * var_theta
        return residual, torch.where(elastic, var_el, var_y) + floor ** 2

    def estimated_moments(self, a: torch.Tensor, v: torch.Tensor, ag: torch.Tensor,
                          c: torch.Tensor) -> torch.Tensor:
        """Eq. 27: ``(Bᵀ)⁻¹(−M(ẍ + 1 a_g)) − diag(c) B ẋ``, N·m; shape (..., P, N)."""
        g = (-(a + ag.unsqueeze(-1)) * self.m) @ self.bt_inv.T
        return g - self.angles(v) * c.unsqueeze(-2)
