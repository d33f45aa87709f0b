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

import logging
import time
from typing import Any, Callable

import numpy as np
import torch

from pier_monitor.core.errors import IdentificationError
from pier_monitor.core.identify.damage import member_ductility
from pier_monitor.core.identify.ensemble import member_windows
from pier_monitor.core.identify.equation_error import fit_window, inertia_moments, yield_test
from pier_monitor.core.identify.methods import (TERMS, EnsembleDraws, IdentifySettings,
                                                MethodOutput, Progress)
from pier_monitor.core.identify.uncertainty import MemberResponses
from pier_monitor.core.ingest.window import MeasuredWindow, Reproduced
from pier_monitor.core.model.config import SpringParameters
from pier_monitor.core.model.link_model import angle_matrix
from .network import MemberNet
from .physics import PairTensors, Physics
from .threads import set_threads

__all__ = ["resolve_device", "train_pinn"]

log = logging.getLogger(__name__)

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

class _PinnProblem:
    """Tensors and loss of one window's members on one device.

    Member ``m`` trains on ``windows[m]`` (member 0: the measured window; the others its
    perturbed copies, :func:`~pier_monitor.core.identify.ensemble.member_windows`).  Data
    tensors have shape (M, P, N), the foundation acceleration (M, P); scales, noise and the
    errors-in-variables variances come from the measured window and are shared.
    """

    def __init__(self, windows: list[MeasuredWindow], settings: IdentifySettings,
                 device: torch.device, init: SpringParameters) -> None:
        window = windows[0]
        self.window = window
        self.settings = settings
        self.pinn = settings.pinn_settings
        self.device = device
        self.members = len(windows)
        dt_ = torch.float64
        n = window.n_levels
        self.n = n
        tt = lambda arr: torch.tensor(np.asarray(arr, dtype=float), dtype=dt_, device=device)
        b = angle_matrix(window.geometry.section_heights_m)
        self.phys = Physics(tt(b), tt(window.geometry.masses_kg), window.dt)
        t_len = window.t.size
        self.idx0 = np.arange(0, t_len - 1, self.pinn.pair_stride)
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
                if self.pinn.residual:
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
        s = self.pinn
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


def _paper_rule_step(problem: _PinnProblem, pairs: PairTensors, tg: dict[str, torch.Tensor],
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
            shifted = problem.pinn.residual
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

def train_pinn(window: MeasuredWindow, settings: IdentifySettings,
               callback: Callable[[Progress], None] | None = None) -> MethodOutput:
    """Identify ``k1, k2, fy, c`` of every spring of a fully measured window with the PINN.

    The method :class:`~pier_monitor.core.identify.methods.PinnMethod` behind
    :func:`~pier_monitor.core.identify.methods.identify`, which assembles the result.

    Parameters
    ----------
    window : MeasuredWindow
        The event window, a displacement and an acceleration at every level.
    settings : IdentifySettings
        Training settings (validated by the caller): ``settings.pinn_settings`` the
        training's, ``settings.equation_error_settings`` its start's and yield test's.
    callback : callable, optional
        Called with a :class:`Progress` after every epoch.

    Raises
    ------
    IdentificationError
        When the loss becomes NaN/Inf, or ``device="cuda"`` without a GPU.
    """
    t_start = time.perf_counter()
    if settings.threads:
        set_threads(settings.threads)
    device = resolve_device(settings.device)
    torch.manual_seed(settings.seed)
    np.random.seed(settings.seed)
    pinn = settings.pinn_settings
    windows = member_windows(  # the equation-error route's member windows
        window, settings.members, seed=settings.seed,
        gain_scale=settings.equation_error_settings.member_gain_scale,
        velocity_from_acceleration=True)
    inits, yielded0 = _member_starts(windows, settings)
    init = inits[0]
    problem = _PinnProblem(windows, settings, device, init)
    n_fourier = pinn.n_fourier or int(min(32, max(8, problem.idx0.size // 4)))
    net = MemberNet(problem.members, 8 * window.n_levels, pinn.arch, pinn.hidden,
                    pinn.layers, n_fourier).to(device=device)
    ref, free = _start(problem, inits, yielded0)
    logp = torch.zeros_like(ref, requires_grad=True)
    _project(logp, ref, problem.f_cap)
    epoch, loss_val, history = _train(problem, net, logp, ref, free, callback, t_start)
    return _reproduce(problem, net, logp, ref, init, yielded0, epoch, loss_val, history)


def _member_starts(windows: list[MeasuredWindow], settings: IdentifySettings
                   ) -> tuple[list[SpringParameters], np.ndarray]:
    """Every member's start and yield decision: the equation-error fit of its own window
    (randomise-then-optimise: the members differ by their data alone), or for
    ``init="design"`` the design values, every spring free to yield.

    Returns the starts (M of them) and the yield decisions, (M, N) bool.
    """
    if settings.pinn_settings.init != "equation_error":
        design = windows[0].design
        return ([design] * len(windows),
                np.ones((len(windows), windows[0].n_levels), dtype=bool))
    inits, yielded = [], []
    for w in windows:
        fit = fit_window(w, settings.equation_error_settings.yield_score)
        inits.append(fit.params)
        yielded.append(fit.yielded)
    return inits, np.stack(yielded)


def _start(problem: _PinnProblem, inits: list[SpringParameters], yielded0: np.ndarray
           ) -> tuple[torch.Tensor, torch.Tensor]:
    """Every member's starting parameters ``ref`` (M, 4, N) and the mask of the free ones.

    Member ``m`` starts from ``inits[m]``, its own window's fit (the start is no source of
    spread: no scatter is added).  A spring that member did not find yielded
    (``yielded0[m]``, (M, N)) is held elastic: its ``fy`` goes to the cap, far from the
    moments, so the clip of the hysteresis rule never acts on noise at the peaks (a held
    ``fy`` equal to the largest moment would clip there and drag ``k1``); its ``k2`` and
    ``fy`` are held.
    """
    device = problem.device
    start = torch.as_tensor(np.stack([np.stack([p.k1, p.k2, p.fy, p.c]) for p in inits]),
                            dtype=torch.float64, device=device)  # (M, 4, N)
    start = torch.where(start > 0, start, torch.ones_like(start))
    held = torch.as_tensor(~yielded0, device=device)  # (M, N)
    start[:, 2] = torch.where(held, problem.f_cap, start[:, 2])
    free = torch.ones_like(start)
    free[:, 1] = torch.where(held, 0.0, 1.0)
    free[:, 2] = torch.where(held, 0.0, 1.0)
    return start, free


def _paper_rule_update(problem: _PinnProblem, logp: torch.Tensor, ref: torch.Tensor,
                       free: torch.Tensor, pairs: PairTensors,
                       tg: dict[str, torch.Tensor]) -> None:
    """One step of the paper's Fig. 6 rule on member 0's parameters, in place."""
    pinn, window = problem.pinn, problem.window
    with torch.no_grad():
        k_now = torch.stack(_params_from_log(logp[0], ref[0]))
        k_in = ref[0] if pinn.init == "design" else torch.as_tensor(
            np.stack([window.design.k1, window.design.k2, window.design.fy,
                      window.design.c]), dtype=torch.float64, device=problem.device)
        new = _paper_rule_step(problem, _detach(pairs), _detach_dict(tg), k_now, k_in,
                               pinn.paper_lr2, free[0])
        logp[0].copy_(torch.log(new / ref[0]))


def _train(problem: _PinnProblem, net: MemberNet, logp: torch.Tensor, ref: torch.Tensor,
           free: torch.Tensor, callback: Callable[[Progress], None] | None, t_start: float
           ) -> tuple[int, float, dict[str, list[Any]]]:
    """The training loop; returns the last epoch, its loss and the history.  Stops once no
    free parameter of any member moved by more than ``tol`` over ``patience`` epochs."""
    pinn, n = problem.pinn, problem.n
    opt_net = torch.optim.Adam(net.parameters(), lr=pinn.lr_network)
    opt_par = torch.optim.Adam([logp], lr=pinn.lr_params)
    history: dict[str, list[Any]] = {k: [] for k in ("loss", *TERMS)}
    history["params"] = []
    recent: list[torch.Tensor] = []
    epoch, loss_val = 0, float("nan")
    total_epochs = pinn.max_epochs + pinn.warmup_epochs
    for epoch in range(1, total_epochs + 1):
        warm = epoch <= pinn.warmup_epochs
        k1, k2, fy, c = _params_from_log(logp, ref)
        pairs, tg = problem.outputs(net, c, problem.tau, None)
        terms = problem.loss_terms(pairs, tg, k1, k2, fy, c)
        per_member = terms["data"] if warm else problem.total(terms)
        loss = per_member.sum()  # members are independent: their gradients do not mix
        opt_net.zero_grad()
        opt_par.zero_grad()
        loss.backward()
        opt_net.step()
        if not warm and pinn.param_rule == "adam":
            logp.grad.mul_(free)
            opt_par.step()
            _project(logp, ref, problem.f_cap)
        elif not warm:
            _paper_rule_update(problem, logp, ref, free, pairs, tg)
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
            callback(Progress(epoch=epoch, max_epochs=total_epochs, loss=loss_val,
                              terms={k: float(v) for k, v in zip(terms, report[1:])},
                              k1=k_np[0], k2=k_np[1], fy=k_np[2], c=k_np[3],
                              elapsed_s=time.perf_counter() - t_start))
        if warm:
            continue
        recent.append(k_cur)
        if len(recent) > pinn.patience:
            recent.pop(0)
            moved = float((torch.abs(recent[-1] / recent[0] - 1.0) * free).max())
            if epoch - pinn.warmup_epochs >= pinn.min_epochs and moved < pinn.tol:
                break
    return epoch, loss_val, history


def _reproduce(problem: _PinnProblem, net: MemberNet, logp: torch.Tensor, ref: torch.Tensor,
               init: SpringParameters, yielded0: np.ndarray, epoch: int, loss_val: float,
               history: dict[str, list[Any]]) -> MethodOutput:
    """Responses over the whole window, every member's yield test, parameters and DF."""
    settings, window, n, members = problem.settings, problem.window, problem.n, problem.members
    with torch.no_grad():
        net.eval()
        k1, k2, fy, c = _params_from_log(logp, ref)
        idx = np.arange(window.t.size - 1)
        pairs, _ = problem.outputs(net, c, problem.tau_all[idx], idx)
        take = lambda q: torch.cat([getattr(pairs, q + "0"), getattr(pairs, q + "1")[:, -1:]],
                                   dim=1).cpu().numpy()
        rep = {q: take(q) for q in ("a", "v", "x", "f")}  # (M, T, N)
        member_params = np.stack([t.cpu().numpy() for t in (k1, k2, fy, c)], axis=-1)
    theta = rep["x"] @ angle_matrix(window.geometry.section_heights_m).T  # (M, T, N)
    yielded = np.array([[yielded0[m, i] and yield_test(
        theta[m, :, i], rep["f"][m, :, i], member_params[m, i, 0], member_params[m, i, 1],
        member_params[m, i, 2], settings.equation_error_settings.yield_score)[0]
        for i in range(n)]
        for m in range(members)])
    # never yielded: fy only bounded below by the largest moment (k2, fy not identifiable)
    f_max = np.abs(rep["f"]).max(axis=1)
    member_params[..., 2] = np.where(yielded, member_params[..., 2], f_max)
    params = SpringParameters(*(member_params[0, :, j] for j in range(4)))
    draws = member_responses = None
    if members > 1:
        ductility = member_ductility(theta, member_params, yielded)
        draws = EnsembleDraws(params=member_params, ductility=ductility, yielded=yielded)
        member_responses = MemberResponses(theta=theta, moment=rep["f"], x=rep["x"],
                                           a=rep["a"])
    reproduced = Reproduced(t=window.t.copy(), a=rep["a"][0], v=rep["v"][0], x=rep["x"][0],
                            theta=theta[0], moment=rep["f"][0])
    message = (f"trained {epoch} epochs on {problem.idx0.size} pairs"
               + (f", {members} members" if members > 1 else ""))
    return MethodOutput(params=params, yielded=yielded[0], reproduced=reproduced, initial=init,
                        stages={"equation_error": init, "pinn": params}, draws=draws,
                        member_responses=member_responses, device=str(problem.device),
                        message=message, epochs=epoch, final_loss=loss_val, history=history)


def _detach(p: PairTensors) -> PairTensors:
    return PairTensors(*(t.detach() for t in (p.a0, p.v0, p.x0, p.f0, p.a1, p.v1, p.x1, p.f1)))


def _detach_dict(d: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    return {k: v.detach() for k, v in d.items()}
