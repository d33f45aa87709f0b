"""Training the PINN: network and dynamic parameters together (paper §4, SPEC §4).

Loss ``L = w_d L1 + w_p (L2 + … + L6)`` on the training pairs ``(t_i, t_i + Δt)``:

* ``L1`` data misfit of the measured quantities, each in units of its largest measured
  value (the paper's α1-α4 = reciprocals of the maxima); a quantity that is not measured
  gets weight 0 — unmeasured moments are replaced by the estimated moments of eq. 27 with
  the current damping, so they follow ``c`` as it moves;
* ``L2`` equation of motion at ``t`` and ``t+Δt`` (in units of the largest inertia force
  per level), ``L3`` Newmark acceleration update (units of max ẍ), ``L4``/``L5`` Newmark
  velocity/displacement increments on absolute scales (max ẋ, max x: the paper's α7 = α2,
  α8 = α3), ``L6`` incremental hysteresis (units of each spring's largest moment).

The data term outweighs the physics by ``data_weight / physics_weight`` (default 10⁴).
Parameters are optimised as log-values under Adam with projection (``k2 <= k1/2``,
``fy`` below the largest plausible yield moment) — or with the paper's Fig. 6 rule
(``param_rule="paper"``).  By default they start from a physics-only equation-error fit
(:mod:`pier_monitor.core.identify.equation_error`, itself started from the design values), which
also tells which springs yielded; ``k2``/``fy`` of springs that did not are held and
flagged as not identifiable.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np
import torch

from pier_monitor.core.model.config import SpringParameters
from pier_monitor.core.identify.damage import IdentificationResult, build_sections, overall_state
from pier_monitor.core.identify.ensemble import member_windows
from pier_monitor.core.identify.equation_error import fit_equation_error, inertia_moments, yield_test
from pier_monitor.core.identify.field import FieldSettings, fit_field
from pier_monitor.core.errors import IdentificationError, InputDataError
from pier_monitor.core.model.link_model import angle_matrix
from pier_monitor.core.identify.uncertainty import (MemberResponses, overall_state_probabilities,
                                                    summarize_members)
from pier_monitor.core.ingest.window import MeasuredWindow, Reproduced
from .network import MemberNet
from .physics import PairTensors, Physics

__all__ = ["PAPER_TERM_WEIGHTS", "DEFAULT_TERM_WEIGHTS", "PinnSettings", "Progress", "Reproduced",
           "IdentificationRun", "identify", "resolve_device"]

log = logging.getLogger(__name__)

TERMS = ("data", "eom", "newmark_a", "newmark_v", "newmark_x", "hysteresis")

#: Relative weights of the physics terms, the paper's: α5 = 0.01 α4 (equation of motion),
#: α6 = 1e-4 α1 (eq. 22), α7 = α2 and α8 = α3 (Newmark increments), α9 = 0.01 α4 (hysteresis).
PAPER_TERM_WEIGHTS = {"eom": 1e-2, "newmark_a": 1e-4, "newmark_v": 1.0, "newmark_x": 1.0,
                      "hysteresis": 1e-2}

#: The default: the paper's weights without eq. 22.  Eq. 22 is eq. 21 at ``t+Δt`` with the
#: velocity replaced by its trapezoid update (eq. 23); on data sampled at 100 Hz the trapezoid
#: is off by about 1.5 % of max|Δẋ|, and eq. 22 multiplies that error by the damping matrix,
#: so minimising it drags ``c`` towards zero (measured on the paper case without moments:
#: c −2 % to −20 % with it, within 0.3 % without it).  Eqs. 21 and 23 keep what it says.
DEFAULT_TERM_WEIGHTS = dict(PAPER_TERM_WEIGHTS, newmark_a=0.0)


@dataclass
class PinnSettings:
    """Settings of one identification (defaults: the benchmarked configuration).

    Attributes
    ----------
    pair_stride : int
        Training pairs every ``pair_stride`` samples (``t_s = pair_stride · Δt``; the paper
        used 0.1-0.5 s; 1 = every consecutive pair of the window).
    arch, hidden, layers, n_fourier :
        Network (see :class:`~pier_monitor.pinn.network.MemberNet`); ``n_fourier = 0``
        picks ``min(32, P // 4)`` frequencies.
    residual : bool
        Network outputs are corrections to the measured data (in noise units).
    max_epochs, min_epochs, warmup_epochs : int
        Epoch limits; ``warmup_epochs`` data-only epochs with frozen parameters first.
    lr_network, lr_params : float
        Adam learning rates (parameters as log-values).
    data_weight, physics_weight : float
        ``w_d`` and ``w_p``.
    term_weights : dict
        Relative weights of the physics terms (default :data:`DEFAULT_TERM_WEIGHTS`;
        :data:`PAPER_TERM_WEIGHTS` are the paper's).
    param_rule : {"adam", "paper"}
        Parameter update: Adam on log-parameters, or the paper's Fig. 6 rule.
    paper_lr2 : float
        The paper's ``lr2`` (step as a share of the initial value).
    init : {"equation_error", "design"}
        Starting parameters: the equation-error fit, or the window's design values.
    patience, tol :
        Early stopping: stop once no parameter moved by more than ``tol`` (relative) over
        ``patience`` epochs.
    device : {"auto", "cpu", "cuda"}
    seed : int
    yield_score : float
        Threshold of the yield test (see :func:`~pier_monitor.core.identify.equation_error.yield_test`).
    field_settings : FieldSettings
        The reconstruction of windows from field networks (levels without a displacement
        sensor, or without any sensor).
    members : int
        Members of the ensemble trained together (1: one identification, no uncertainty).
        Member 0 trains on the measured window from the start; the others on copies
        perturbed as the noise model allows (:mod:`pier_monitor.core.identify.ensemble`),
        each from the start scattered by ``member_start_sd`` (a multi-start).
    member_start_sd : float
        Relative spread of the members' starting parameters (log-normal).
    method : {"auto", "pinn", "field"}
        ``pinn``: the equation-error start and the PINN, for windows with a displacement
        and an acceleration at every level (a shaking table with calibrated sensors: the
        most accurate there); ``field``: the reconstruction from the accelerations
        (:func:`~pier_monitor.core.identify.field.fit_field`, measured displacements used
        where there are any), for windows that start at rest; it tolerates uncalibrated
        gains (about 1 %) and misaligned sensors, which bias the equation-error start.
        ``auto``: ``pinn`` with every level fully measured, else ``field``.
    """

    pair_stride: int = 1
    arch: str = "fourier"
    hidden: int = 32
    layers: int = 2
    n_fourier: int = 0
    residual: bool = True
    max_epochs: int = 3000
    min_epochs: int = 300
    warmup_epochs: int = 0
    lr_network: float = 1e-3
    lr_params: float = 1e-3
    data_weight: float = 1.0
    physics_weight: float = 1e-2
    term_weights: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_TERM_WEIGHTS))
    param_rule: str = "adam"
    paper_lr2: float = 1e-3
    init: str = "equation_error"
    patience: int = 200
    tol: float = 2e-5
    device: str = "auto"
    seed: int = 0
    yield_score: float = 50.0
    field_settings: FieldSettings = field(default_factory=FieldSettings)
    members: int = 1
    method: str = "auto"
    member_start_sd: float = 0.02

    def as_dict(self) -> dict[str, Any]:
        """Plain JSON form (lists for tuples), as a result records it."""
        return json.loads(json.dumps(asdict(self)))

    def validate(self) -> None:
        """Raise :class:`InputDataError` naming the first bad setting."""
        checks = [
            ("pair_stride", self.pair_stride >= 1),
            ("arch", self.arch in ("fourier", "paper")),
            ("hidden", self.hidden >= 1), ("layers", self.layers >= 1),
            ("n_fourier", self.n_fourier >= 0),
            ("max_epochs", self.max_epochs >= 1),
            ("min_epochs", 0 <= self.min_epochs <= self.max_epochs),
            ("warmup_epochs", self.warmup_epochs >= 0),
            ("lr_network", self.lr_network > 0), ("lr_params", self.lr_params > 0),
            ("data_weight", self.data_weight > 0), ("physics_weight", self.physics_weight > 0),
            ("term_weights", set(self.term_weights) <= set(TERMS[1:])
             and all(v >= 0 for v in self.term_weights.values())),
            ("param_rule", self.param_rule in ("adam", "paper")),
            ("paper_lr2", self.paper_lr2 > 0),
            ("init", self.init in ("equation_error", "design")),
            ("patience", self.patience >= 1), ("tol", self.tol > 0),
            ("device", self.device in ("auto", "cpu", "cuda")),
            ("members", self.members >= 1),
            ("method", self.method in ("auto", "pinn", "field")),
            ("member_start_sd", self.member_start_sd >= 0),
            ("param_rule", self.param_rule == "adam" or self.members == 1),
        ]
        for name, ok in checks:
            if not ok:
                raise InputDataError(f"PINN setting {name}: invalid value {getattr(self, name)!r}")


@dataclass(frozen=True)
class Progress:
    """What the trainer reports to the callback after each epoch."""

    epoch: int
    max_epochs: int
    loss: float
    terms: dict[str, float]
    k1: np.ndarray
    k2: np.ndarray
    fy: np.ndarray
    c: np.ndarray
    elapsed_s: float


@dataclass(frozen=True)
class IdentificationRun:
    """Everything one identification produced."""

    result: IdentificationResult
    reproduced: Reproduced
    initial: SpringParameters
    history: dict[str, list[Any]] = field(default_factory=dict)
    #: parameters after each stage of the identification, in order (the last is the result)
    stages: dict[str, SpringParameters] = field(default_factory=dict)
    #: the members' reproduced histories (M, T, N) when an ensemble was trained
    members: MemberResponses | None = None


def resolve_device(name: str) -> torch.device:
    """``auto`` → CUDA when present, else CPU (with a log line); ``cuda`` without a GPU raises."""
    if name == "cpu":
        return torch.device("cpu")
    if torch.cuda.is_available():
        return torch.device("cuda")
    if name == "cuda":
        raise IdentificationError("device 'cuda' requested but no CUDA GPU is available")
    log.info("no CUDA GPU found: training on the CPU")
    return torch.device("cpu")


class _Problem:
    """Tensors and loss of one window's members on one device.

    Member ``m`` trains on ``windows[m]`` (member 0: the measured window; the others its
    perturbed copies, :func:`~pier_monitor.core.identify.ensemble.member_windows`).  Data
    tensors have shape (M, P, N), the foundation acceleration (M, P); scales, noise and the
    errors-in-variables variances come from the measured window and are shared.
    """

    def __init__(self, windows: list[MeasuredWindow], settings: PinnSettings,
                 device: torch.device, init: SpringParameters) -> None:
        window = windows[0]
        self.window = window
        self.settings = settings
        self.device = device
        self.members = len(windows)
        dt_ = torch.float64
        n = window.n_levels
        self.n = n
        tt = lambda arr: torch.tensor(np.asarray(arr, dtype=float), dtype=dt_, device=device)
        b = angle_matrix(window.geometry.section_heights_m)
        self.phys = Physics(tt(b), tt(window.geometry.masses_kg), window.dt)
        t_len = window.t.size
        self.idx0 = np.arange(0, t_len - 1, settings.pair_stride)
        idx1 = self.idx0 + 1
        span = window.t[-1] - window.t[0]
        self.tau_all = tt(2.0 * (window.t - window.t[0]) / span - 1.0)[:, None]
        self.tau = self.tau_all[self.idx0]
        self.ag_all = tt(np.stack([w.ag for w in windows]))
        self.ag0, self.ag1 = self.ag_all[:, self.idx0], self.ag_all[:, idx1]
        keys = ("a", "v", "x")
        self.measured_f = window.moments is not None
        if self.measured_f:
            keys += ("f",)
        stacked = {k: np.stack([getattr(w, "moments" if k == "f" else k) for w in windows])
                   for k in keys}
        self.data_all = {k: tt(v) for k, v in stacked.items()}
        self.data0 = {k: v[:, self.idx0] for k, v in self.data_all.items()}
        self.data1 = {k: v[:, idx1] for k, v in self.data_all.items()}
        # scales (α of the paper) from the measured maxima
        f_ref = window.moments if self.measured_f else (
            inertia_moments(window.geometry, window.a, window.ag)
            - (window.v @ b.T) * init.c)
        self.scale = {"a": float(np.abs(window.a).max()), "v": float(np.abs(window.v).max()),
                      "x": float(np.abs(window.x).max()),
                      "f": tt(np.abs(f_ref).max(axis=0))}
        inertia = np.abs((window.a + window.ag[:, None]) * window.geometry.masses_kg).max(axis=0)
        self.scale_eom = tt(inertia)
        self.f_cap = tt(2.0 * np.abs(f_ref).max(axis=0))  # largest plausible yield moment
        # noise scales of the residual network's corrections
        sig = window.noise
        self.noise = {}
        for q in ("a", "v", "x", "f"):
            default = 1e-3 * (self.scale[q] if q != "f" else float(self.scale["f"].max()))
            val = np.where(np.isfinite(getattr(sig, q)), getattr(sig, q), default)
            self.noise[q] = tt(np.maximum(val, 1e-9 * (default / 1e-3)))
        # noise of the angles and moments and of their increments, for the
        # errors-in-variables weighting; increments of smoothed data (sigma "dx", "dv")
        # are far less noisy than twice the level noise
        var_x = self.noise["x"].cpu().numpy() ** 2
        var_theta = (b ** 2) @ var_x
        var_dtheta = (b ** 2) @ _increment_variance(sig.dx, var_x)
        if self.measured_f:
            var_f = self.noise["f"].cpu().numpy() ** 2
            var_df = 2.0 * var_f
        else:  # eq. 27 from noisy accelerations (white) and velocities
            bt_inv = np.linalg.inv(b.T)
            m = window.geometry.masses_kg
            var_a = self.noise["a"].cpu().numpy() ** 2
            var_ag = (sig.ag if np.isfinite(sig.ag) else float(np.sqrt(var_a.mean()))) ** 2
            var_v = self.noise["v"].cpu().numpy() ** 2
            var_inertia = (bt_inv ** 2) @ (m ** 2 * var_a) + (bt_inv @ m) ** 2 * var_ag
            var_f = var_inertia + init.c ** 2 * ((b ** 2) @ var_v)
            var_df = 2.0 * var_inertia + init.c ** 2 * ((b ** 2) @ _increment_variance(sig.dv, var_v))
        floor = 1e-4 * np.abs(f_ref).max(axis=0)
        self.var_theta, self.var_f = tt(var_theta), tt(var_f)
        self.var_dtheta, self.var_df = tt(var_dtheta), tt(var_df)
        self.hyst_floor = tt(floor)
        self.var_ref = tt(var_df + init.k1 ** 2 * var_dtheta + floor ** 2)

    def outputs(self, net: MemberNet, c: torch.Tensor, tau: torch.Tensor,
                idx0: np.ndarray | None) -> tuple[PairTensors, dict[str, torch.Tensor]]:
        """Network outputs as responses (M, P, N), and the data targets at those times;
        ``c`` of shape (M, N)."""
        n = self.n
        raw = net(tau).reshape(self.members, -1, 2, 4, n)  # (M, P, instant, quantity, N)
        if idx0 is None:  # training pairs
            d0, d1, ag0, ag1 = self.data0, self.data1, self.ag0, self.ag1
        else:
            d0 = {k: v[:, idx0] for k, v in self.data_all.items()}
            d1 = {k: v[:, idx0 + 1] for k, v in self.data_all.items()}
            ag0, ag1 = self.ag_all[:, idx0], self.ag_all[:, idx0 + 1]
        if not self.measured_f:
            d0 = dict(d0, f=self.phys.estimated_moments(d0["a"], d0["v"], ag0, c))
            d1 = dict(d1, f=self.phys.estimated_moments(d1["a"], d1["v"], ag1, c))
        out = []
        for inst, d in ((0, d0), (1, d1)):
            for qi, q in enumerate(("a", "v", "x", "f")):
                if self.settings.residual:
                    out.append(d[q] + self.noise[q] * raw[:, :, inst, qi])
                else:
                    out.append(self.scale[q] * raw[:, :, inst, qi])
        pairs = PairTensors(*out)
        targets = {"a0": d0["a"], "v0": d0["v"], "x0": d0["x"], "f0": d0["f"],
                   "a1": d1["a"], "v1": d1["v"], "x1": d1["x"], "f1": d1["f"],
                   "ag0": ag0, "ag1": ag1}
        return pairs, targets

    def loss_terms(self, p: PairTensors, tg: dict[str, torch.Tensor], k1: torch.Tensor,
                   k2: torch.Tensor, fy: torch.Tensor, c: torch.Tensor
                   ) -> dict[str, torch.Tensor]:
        """Loss terms of every member, each of shape (M,) (parameters (M, N)); a batch of
        parameter sets (S, M, N) gives terms (S, M)."""
        ms = lambda r: (r ** 2).mean(dim=(-2, -1))
        sc = self.scale
        data = 0.0
        for q in ("a", "v", "x", "f"):  # unmeasured f: eq. 27's estimate is the target
            for inst in "01":
                data = data + ms((getattr(p, q + inst) - tg[q + inst]) / sc[q])
        ph = self.phys
        eom = 0.5 * (ms(ph.eom(p.a0, p.v0, p.f0, tg["ag0"], c) / self.scale_eom)
                     + ms(ph.eom(p.a1, p.v1, p.f1, tg["ag1"], c) / self.scale_eom))
        # hysteresis residual over its own standard deviation (relative to the one at the
        # start, so the term keeps the paper's scale): an errors-in-variables fit of springs
        hyst, var = ph.hysteresis_with_variance(p, k1, k2, fy, self.var_df, self.var_dtheta,
                                                self.var_f, self.var_theta, self.hyst_floor)
        return {
            "data": data / 8.0,
            "eom": eom,
            "newmark_a": ms(ph.newmark_acceleration(p, tg["ag1"], c) / sc["a"]),
            "newmark_v": ms(ph.newmark_velocity(p) / sc["v"]),
            "newmark_x": ms(ph.newmark_displacement(p) / sc["x"]),
            "hysteresis": ms(hyst / sc["f"] * torch.sqrt(self.var_ref / var)),
        }

    def total(self, terms: dict[str, torch.Tensor]) -> torch.Tensor:
        """The loss of each member (terms of shape (...))."""
        s = self.settings
        physics = sum(s.term_weights.get(k, 1.0) * terms[k] for k in TERMS[1:])
        return s.data_weight * terms["data"] + s.physics_weight * physics


def _increment_variance(sigma_increment: np.ndarray, var_level: np.ndarray) -> np.ndarray:
    """Variance of one-sample increments, (N,): the known increment noise, else white
    (twice the level variance)."""
    return np.where(np.isfinite(sigma_increment), sigma_increment ** 2, 2.0 * var_level)


def _params_from_log(logp: torch.Tensor, ref: torch.Tensor) -> tuple[torch.Tensor, ...]:
    k = ref * torch.exp(logp)
    return k[..., 0, :], k[..., 1, :], k[..., 2, :], k[..., 3, :]


def _project(logp: torch.Tensor, ref: torch.Tensor, f_cap: torch.Tensor) -> None:
    """In place, every member: ``k2 <= k1/2`` and ``fy <= f_cap`` (positivity holds by the
    log form); ``logp`` and ``ref`` of shape (M, 4, N)."""
    with torch.no_grad():
        k1, k2, fy, _ = _params_from_log(logp, ref)
        logp[:, 1] = torch.log(torch.minimum(k2, 0.5 * k1) / ref[:, 1])
        logp[:, 2] = torch.log(torch.minimum(fy, f_cap) / ref[:, 2])


def _paper_rule_step(problem: _Problem, pairs: PairTensors, tg: dict[str, torch.Tensor],
                     k: torch.Tensor, k_in: torch.Tensor, lr2: float,
                     free: torch.Tensor) -> torch.Tensor:
    """The paper's Fig. 6 rule on all 4N parameters at once; returns the new values (4, N).

    For each parameter: the loss at ``K``, ``K + lr2 K_in`` and ``K − lr2 K_in`` (the others
    held); keep the best; cancel a move that breaks a constraint (all positive,
    ``k1 >= 2 k2``, ``fy`` below the largest plausible yield moment).
    """
    n = k.shape[1]
    cands = [k]
    for sign in (1.0, -1.0):
        for j in range(4):
            for i in range(n):
                kk = k.clone()
                kk[j, i] = kk[j, i] + sign * lr2 * k_in[j, i]
                cands.append(kk)
    batch = torch.stack(cands)  # (S, 4, N)
    with torch.no_grad():
        if not problem.measured_f:
            # estimated moments are linear in c: f̂(c') = f̂(c) − θ̇ (c' − c), outputs follow
            dc = (batch[:, 3, :] - k[3]).unsqueeze(-2)  # (S, 1, N)
            sh0 = -problem.phys.angles(tg["v0"]) * dc
            sh1 = -problem.phys.angles(tg["v1"]) * dc
            shifted = problem.settings.residual
            pairs = PairTensors(pairs.a0, pairs.v0, pairs.x0, pairs.f0 + sh0 * shifted,
                                pairs.a1, pairs.v1, pairs.x1, pairs.f1 + sh1 * shifted)
            tg = dict(tg, f0=tg["f0"] + sh0, f1=tg["f1"] + sh1)
        terms = problem.loss_terms(pairs, tg, batch[:, 0], batch[:, 1], batch[:, 2],
                                   batch[:, 3])
        loss = problem.total(terms)
    base = loss[0]
    plus = loss[1:1 + 4 * n].reshape(4, n)
    minus = loss[1 + 4 * n:].reshape(4, n)
    step = torch.zeros_like(k)
    step = torch.where((plus < base) & (plus <= minus), lr2 * k_in, step)
    step = torch.where((minus < base) & (minus < plus), -lr2 * k_in, step)
    step = step * free
    new = k + step
    # a move is cancelled when it breaks a rule that the parameter it changes takes part in
    ok = new > 0
    ok[0] &= new[0] >= 2 * k[1]
    ok[1] &= k[0] >= 2 * new[1]
    ok[2] &= (new[2] <= problem.f_cap) | (step[2] < 0)
    return torch.where(ok, new, k)


def identify(window: MeasuredWindow, settings: PinnSettings | None = None,
             callback: Callable[[Progress], None] | None = None,
             baseline_k1: np.ndarray | None = None) -> IdentificationRun:
    """Identify ``k1, k2, fy, c`` of every spring of a measured window with the PINN.

    Parameters
    ----------
    window : MeasuredWindow
        The event window (relative responses, foundation acceleration, design values).
    settings : PinnSettings, optional
        Training settings; the defaults are the benchmarked ones.
    callback : callable, optional
        Called with a :class:`Progress` after every epoch.
    baseline_k1 : ndarray, shape (N,), optional
        Reference ``k1`` for the change in the results (design values when omitted).

    Raises
    ------
    IdentificationError
        When the loss becomes NaN/Inf, or ``device="cuda"`` without a GPU.
    """
    settings = settings or PinnSettings()
    settings.validate()
    device = resolve_device(settings.device)
    t_start = time.perf_counter()
    torch.manual_seed(settings.seed)
    np.random.seed(settings.seed)
    geometry = window.geometry
    if settings.method == "pinn" and not window.coverage.is_full:
        raise IdentificationError(
            f"window {window.event_id}: method 'pinn' needs a displacement and an acceleration "
            f"at every level; this window's layout is {window.coverage.layout}")
    if settings.method == "field" or not window.coverage.is_full:
        return _identify_field(window, settings, baseline_k1, t_start, device)

    # starting point
    if settings.init == "equation_error":
        fit = fit_equation_error(geometry, window.x, window.v, window.a, window.ag, window.design,
                                 moments=window.moments, yield_score=settings.yield_score)
        init, yielded0 = fit.params, fit.yielded
    else:
        init, yielded0 = window.design, np.ones(window.n_levels, dtype=bool)

    windows = member_windows(window, settings.members, seed=settings.seed)
    problem = _Problem(windows, settings, device, init)
    members = problem.members
    n = window.n_levels
    n_pairs = problem.idx0.size
    n_fourier = settings.n_fourier or int(min(32, max(8, n_pairs // 4)))
    net = MemberNet(members, 8 * n, settings.arch, settings.hidden, settings.layers,
                    n_fourier).to(device=device)
    start = torch.as_tensor(np.stack([init.k1, init.k2, init.fy, init.c]), dtype=torch.float64,
                            device=device)
    start = torch.where(start > 0, start, torch.ones_like(start))
    # a spring that did not yield is held elastic: its fy goes to the cap, far from the
    # moments, so the clip of the hysteresis rule never acts on noise at the peaks (a held
    # fy equal to the largest moment would clip there and drag k1)
    held = torch.as_tensor(~yielded0, device=device)
    start[2] = torch.where(held, problem.f_cap, start[2])
    # every member starts from the start, the others a multi-start spread around it
    spread = torch.ones(members, 4, n, dtype=torch.float64, device=device)
    if members > 1:
        gen = torch.Generator(device="cpu").manual_seed(settings.seed + 1)
        draw = torch.randn(members - 1, 4, n, generator=gen, dtype=torch.float64)
        spread[1:] = torch.exp(settings.member_start_sd * draw).to(device)
    ref = start * spread
    logp = torch.zeros_like(ref, requires_grad=True)
    # held parameters: k2, fy of springs that did not yield
    free = torch.ones_like(ref)
    free[:, 1] = torch.where(held, 0.0, 1.0)
    free[:, 2] = torch.where(held, 0.0, 1.0)
    _project(logp, ref, problem.f_cap)
    opt_net = torch.optim.Adam(net.parameters(), lr=settings.lr_network)
    opt_par = torch.optim.Adam([logp], lr=settings.lr_params)
    history: dict[str, list[Any]] = {k: [] for k in ("loss", *TERMS)}
    history["params"] = []
    recent: list[torch.Tensor] = []
    epoch = 0
    loss_val = float("nan")
    for epoch in range(1, settings.max_epochs + settings.warmup_epochs + 1):
        warm = epoch <= settings.warmup_epochs
        k1, k2, fy, c = _params_from_log(logp, ref)
        pairs, tg = problem.outputs(net, c, problem.tau, None)
        terms = problem.loss_terms(pairs, tg, k1, k2, fy, c)
        per_member = terms["data"] if warm else problem.total(terms)
        loss = per_member.sum()  # members are independent: their gradients do not mix
        opt_net.zero_grad()
        opt_par.zero_grad()
        loss.backward()
        opt_net.step()
        if not warm:
            if settings.param_rule == "adam":
                logp.grad.mul_(free)
                opt_par.step()
                _project(logp, ref, problem.f_cap)
            else:
                with torch.no_grad():
                    k_now = torch.stack(_params_from_log(logp[0], ref[0]))
                    k_in = ref[0] if settings.init == "design" else torch.as_tensor(
                        np.stack([window.design.k1, window.design.k2, window.design.fy,
                                  window.design.c]), dtype=torch.float64, device=device)
                    new = _paper_rule_step(problem, _detach(pairs), _detach_dict(tg), k_now,
                                           k_in, settings.paper_lr2, free[0])
                    logp[0].copy_(torch.log(new / ref[0]))
        with torch.no_grad():
            k_cur = torch.stack(_params_from_log(logp, ref), dim=1)  # (M, 4, N)
            # one transfer per epoch: member 0's loss terms and parameters
            report = torch.cat([per_member[:1], torch.stack([v[0] for v in terms.values()]),
                                k_cur[0].reshape(-1)]).cpu().numpy()
        loss_val = float(report[0])
        if not np.isfinite(report[:len(terms) + 1]).all() or not torch.isfinite(
                per_member).all():
            raise IdentificationError(
                f"training diverged at epoch {epoch}: loss is {loss_val} (member 0 terms: "
                f"{', '.join(f'{k}={v:.3g}' for k, v in zip(terms, report[1:]))})")
        history["loss"].append(loss_val)
        for k, v in zip(terms, report[1:1 + len(terms)]):
            history[k].append(float(v))
        k_np = report[1 + len(terms):].reshape(4, n)
        history["params"].append(k_np.tolist())
        if callback is not None:
            callback(Progress(epoch=epoch, max_epochs=settings.max_epochs + settings.warmup_epochs,
                              loss=loss_val,
                              terms={k: float(v) for k, v in zip(terms, report[1:])},
                              k1=k_np[0], k2=k_np[1], fy=k_np[2], c=k_np[3],
                              elapsed_s=time.perf_counter() - t_start))
        if warm:
            continue
        recent.append(k_cur)
        if len(recent) > settings.patience:
            recent.pop(0)
            moved = float((torch.abs(recent[-1] / recent[0] - 1.0) * free).max())
            if epoch - settings.warmup_epochs >= settings.min_epochs and moved < settings.tol:
                break

    # reproduce responses over the whole window and evaluate the damage indices
    with torch.no_grad():
        net.eval()
        k1, k2, fy, c = _params_from_log(logp, ref)
        idx = np.arange(window.t.size - 1)
        pairs, _ = problem.outputs(net, c, problem.tau_all[idx], idx)
        take = lambda q: torch.cat([getattr(pairs, q + "0"), getattr(pairs, q + "1")[:, -1:]],
                                   dim=1).cpu().numpy()
        rep = {q: take(q) for q in ("a", "v", "x", "f")}  # (M, T, N)
        member_params = np.stack([t.cpu().numpy() for t in (k1, k2, fy, c)], axis=-1)
    b = angle_matrix(geometry.section_heights_m)
    theta = rep["x"] @ b.T  # (M, T, N)
    yielded = np.array([[yielded0[i] and yield_test(
        theta[m, :, i], rep["f"][m, :, i], member_params[m, i, 0], member_params[m, i, 1],
        member_params[m, i, 2], settings.yield_score)[0] for i in range(n)]
        for m in range(members)])
    # never yielded: fy only bounded below by the largest moment (k2, fy not identifiable)
    f_max = np.abs(rep["f"]).max(axis=1)
    member_params[..., 2] = np.where(yielded, member_params[..., 2], f_max)
    params = SpringParameters(*(member_params[0, :, j] for j in range(4)))
    ductility = np.abs(theta).max(axis=1) / (member_params[..., 2] / member_params[..., 0])
    ductility = np.where(yielded, ductility, np.minimum(ductility, 1.0))
    uncertainty = None
    if members > 1:
        kept = _converged_members(member_params, ductility)
        masked = member_params.copy()
        masked[..., 1:3] = np.where(yielded[..., None], masked[..., 1:3], np.nan)
        uncertainty = summarize_members(masked[kept], ductility[kept], yielded[kept])
    sections = build_sections(geometry, params, theta[0], yielded[0],
                              baseline_k1=window.design.k1 if baseline_k1 is None else baseline_k1,
                              uncertainty=uncertainty)
    wall = time.perf_counter() - t_start
    result = IdentificationResult(
        pier_id=window.pier_id, event_id=window.event_id, sections=sections,
        overall_state=overall_state(sections), window_start_s=float(window.t[0]),
        window_duration_s=window.duration_s, epochs=epoch, final_loss=loss_val,
        wall_time_s=wall, device=str(device), success=True,
        message=(f"trained {epoch} epochs on {n_pairs} pairs"
                 + (f", {members} members" if members > 1 else "")),
        settings=settings.as_dict(),
        history={k: v for k, v in history.items() if k != "params"},
        p_overall_state=(overall_state_probabilities(ductility, yielded) if members > 1
                         else None))
    reproduced = Reproduced(t=window.t.copy(), a=rep["a"][0], v=rep["v"][0], x=rep["x"][0],
                            theta=theta[0], moment=rep["f"][0])
    member_responses = None if members == 1 else MemberResponses(
        theta=theta, moment=rep["f"], x=rep["x"], a=rep["a"])
    return IdentificationRun(result=result, reproduced=reproduced, initial=init,
                             history=history, stages={"equation_error": init, "pinn": params},
                             members=member_responses)


def _converged_members(params: np.ndarray, ductility: np.ndarray) -> np.ndarray:
    """Members whose parameters and ductility factors are finite and positive, (M,) bool."""
    return (np.isfinite(params[..., [0, 3]]).all(axis=(1, 2))
            & (params[..., [0, 3]] > 0).all(axis=(1, 2))
            & np.isfinite(ductility).all(axis=1) & (ductility > 0).all(axis=1))


def _identify_field(window: MeasuredWindow, settings: PinnSettings,
                    baseline_k1: np.ndarray | None, t_start: float,
                    device: torch.device) -> IdentificationRun:
    """A window from a field network: the springs and the unmeasured motion reconstructed
    from the physics (:func:`~pier_monitor.core.identify.field.fit_field`)."""
    fit = fit_field(window, settings.field_settings, members=settings.members,
                    seed=settings.seed)
    params = fit.params
    uncertainty = p_overall = member_responses = None
    if fit.members is not None:
        ens = fit.members
        masked = ens.params.copy()
        masked[..., 1:3] = np.where(ens.yielded[..., None], masked[..., 1:3], np.nan)
        uncertainty = summarize_members(masked, ens.ductility, ens.yielded)
        p_overall = overall_state_probabilities(ens.ductility, ens.yielded)
        x_members = ens.theta @ np.linalg.inv(angle_matrix(window.geometry.section_heights_m)).T
        member_responses = MemberResponses(theta=ens.theta, moment=ens.moment, x=x_members)
    sections = build_sections(window.geometry, params, fit.theta, fit.yielded,
                              baseline_k1=window.design.k1 if baseline_k1 is None else baseline_k1,
                              uncertainty=uncertainty)
    wall = time.perf_counter() - t_start
    stage_names = list(fit.stages)
    result = IdentificationResult(
        pier_id=window.pier_id, event_id=window.event_id, sections=sections,
        overall_state=overall_state(sections), window_start_s=float(window.t[0]),
        window_duration_s=window.duration_s, epochs=0, final_loss=float("nan"),
        wall_time_s=wall, device=str(device), success=True,
        message=(f"{window.coverage.layout} layout: springs reconstructed from the physics "
                 f"({', '.join(stage_names)})"
                 + (f", {settings.members} members" if fit.members is not None else "")),
        settings=settings.as_dict(), history={}, p_overall_state=p_overall)
    a = np.where(window.coverage.acceleration, window.a, np.gradient(fit.v, window.dt, axis=0))
    reproduced = Reproduced(t=window.t.copy(), a=a, v=fit.v, x=fit.x, theta=fit.theta,
                            moment=fit.moment)
    return IdentificationRun(result=result, reproduced=reproduced,
                             initial=fit.stages[stage_names[0]], history={},
                             stages=dict(fit.stages), members=member_responses)


def _detach(p: PairTensors) -> PairTensors:
    return PairTensors(*(t.detach() for t in (p.a0, p.v0, p.x0, p.f0, p.a1, p.v1, p.x1, p.f1)))


def _detach_dict(d: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    return {k: v.detach() for k, v in d.items()}
