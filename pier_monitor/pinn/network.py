"""The PINN's network: time in, the ``8N`` responses at ``t`` and ``t + Δt`` out.

Two architectures:

* ``"fourier"`` (default): Fourier features ``sin/cos(π j τ)``, ``j = 1..J``, of the scaled
  time ``τ ∈ [-1, 1]`` in front of an MLP with tanh.  A plain-``t`` input cannot follow a
  seismic record closely enough for the parameters to come out right.
* ``"paper"``: the paper's ``q`` fully connected layers of ``p`` units with ReLU and batch
  normalisation, input ``τ``.

The output is either the responses themselves in units of their scales (``residual=False``,
the paper) or a correction to the measured responses in units of their noise
(``residual=True``): the network then starts at the data and learns only what the physics
asks it to change.
"""

from __future__ import annotations

import math

import torch
from torch import nn

__all__ = ["MemberNet"]


class MemberNet(nn.Module):
    """``M`` independent networks of the same shape, evaluated as one batched computation.

    Every weight has a leading member dimension, so that an ensemble trains in one pass:
    ``τ`` of shape (P, 1), shared by the members, → outputs of shape (M, P, n_out); one
    identification is ``M = 1``.  ``"paper"`` normalises each member's own batch of times,
    in training and evaluation alike.  Output layers start at zero, so that a residual
    network starts at its data.

    Parameters
    ----------
    members : int
        Number of networks ``M``.
    n_out : int
        Number of outputs (``8N``).
    arch : {"fourier", "paper"}
        Architecture (see the module docstring).
    hidden : int
        Units per hidden layer (the paper's ``p``).
    layers : int
        Hidden layers (the paper's ``q``).
    n_fourier : int
        Number of frequencies ``J`` of the Fourier features.
    """

    def __init__(self, members: int, n_out: int, arch: str = "fourier", hidden: int = 64,
                 layers: int = 3, n_fourier: int = 64) -> None:
        super().__init__()
        if arch not in ("fourier", "paper"):
            raise ValueError(f"arch: expected 'fourier' or 'paper', got {arch!r}")
        if members < 1:
            raise ValueError(f"members: expected at least 1, got {members}")
        self.arch = arch
        self.members = members
        if arch == "fourier":
            self.register_buffer("freqs", math.pi * torch.arange(1, n_fourier + 1,
                                                                dtype=torch.float64))
            width = 2 * n_fourier
        else:
            self.register_buffer("freqs", torch.zeros(0, dtype=torch.float64))
            width = 1
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for _ in range(layers):
            bound = 1.0 / math.sqrt(width)  # nn.Linear's default initialisation
            self.weights.append(nn.Parameter(torch.empty(members, width, hidden,
                                                         dtype=torch.float64).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.empty(members, 1, hidden,
                                                        dtype=torch.float64).uniform_(-bound, bound)))
            width = hidden
        self.head_w = nn.Parameter(torch.zeros(members, width, n_out, dtype=torch.float64))
        self.head_b = nn.Parameter(torch.zeros(members, 1, n_out, dtype=torch.float64))

    def forward(self, tau: torch.Tensor) -> torch.Tensor:
        """Outputs (M, P, n_out) for scaled times ``tau`` of shape (P, 1)."""
        if self.arch == "fourier":
            z = tau * self.freqs
            h = torch.cat([torch.sin(z), torch.cos(z)], dim=-1)
        else:
            h = tau
        h = h.unsqueeze(0).expand(self.members, -1, -1)
        for w, b in zip(self.weights, self.biases):
            h = torch.baddbmm(b, h, w)
            if self.arch == "fourier":
                h = torch.tanh(h)
            else:
                h = torch.relu(h)  # batch statistics over each member's times
                mean = h.mean(dim=1, keepdim=True)
                var = h.var(dim=1, unbiased=False, keepdim=True)
                h = (h - mean) / torch.sqrt(var + 1e-5)
        return torch.baddbmm(self.head_b, h, self.head_w)
