"""Grey-box spring: the event's best parametric family plus a small residual network per section.

The contender of the pre-registered test ``benchmarks/pinn_preregistration.json``, built for
the full layout only (every level's displacement and acceleration measured, so the section
rotations ``θ``, their rates ``θ̇`` and the inertia moments ``g`` are known, as the
equation-error and family fits use them).  Per section ``n``::

    g_n(t) = f_family(θ_n history; p_n) + c_n θ̇_n(t) + r_n(θ_n, θ̇_n, θmax_n, sign θ̇_n)

with ``f_family`` the event's family chosen by evidence
(:func:`~pier_monitor.core.identify.families.fit_families`: bilinear or modified Takeda, at
its fitted parameters), ``θmax`` the running peak ``|θ|`` and ``r_n`` a 2×16 tanh network.

The cheap variant: the family's moment is a history-dependent compiled loop, not
differentiable, so its parameters stay at the parametric fit; only ``r_n`` and ``c_n``
(started at the family's ``c``) are trained, by Adam (weight decay) on the moment residual
weighted by the noise model's moment variance, with early stopping on a held-out 20 % of
the time samples (contiguous blocks chosen at random, so that correlated neighbours of a
validation sample are not in the training set).

DF: the skeleton of the combined model is monotonic loading from 0 to the peak ``|θ|``
(``θ̇ = 0`` in the network's rate input, the running peak equal to ``θ``, loading direction
``+1`` on the positive side and ``−1`` on the negative side, the two averaged as an odd
envelope): ``S(θ) = S_family(θ) + ½ (r(θ, 0, θ, +1) − r(−θ, 0, θ, −1))``, idealised by the
equal-energy rule (:func:`~pier_monitor.core.model.springs.idealised_yield`, first yield at
the family's, the Takeda's floor on the elastic branch for a Takeda family) as the
reference does; ``DF = θp / θ*``, at most 1 where the family fit did
not yield (:attr:`FamilyChoice.yielded`).  torch is imported only when a grey-box is trained.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.identify.families import FamilyChoice
from pier_monitor.core.identify.states import classify_ductility
from pier_monitor.core.model.springs import (
    Skeleton,
    TakedaParameters,
    bilinear_moment,
    idealised_yield,
    takeda_moment,
    yield_peak_fraction,
)

__all__ = ["GreyboxSettings", "GreyboxSection", "GreyboxResult", "family_moment",
           "fit_greybox"]


@dataclass(frozen=True)
class GreyboxSettings:
    """Training knobs of the residual networks (fixed a priori, not tuned on held-out seeds).

    Attributes
    ----------
    hidden : int
        Width of the two tanh layers.
    epochs : int
        Most full-batch Adam steps per section.
    lr : float
        Adam learning rate.
    weight_decay : float
        Decoupled weight decay (AdamW) of the network's weights.
    val_fraction : float
        Share of the time samples held out for early stopping (in contiguous blocks).
    n_blocks : int
        Number of blocks the window is cut into for the split.
    patience : int
        Steps without a better validation loss before stopping.
    seed : int
        Initialisation and split seed.
    """

    hidden: int = 16
    epochs: int = 600
    lr: float = 1e-2
    weight_decay: float = 1e-3
    val_fraction: float = 0.2
    n_blocks: int = 50
    patience: int = 80
    seed: int = 0


@dataclass(frozen=True)
class GreyboxSection:
    """One section's grey-box.

    Attributes
    ----------
    c : float
        Trained damping, N·m·s/rad.
    rms_family, rms_greybox : float
        Moment residual RMS of the family alone (``g − f − c_family θ̇``) and of the
        grey-box (``g − f − c θ̇ − r``) over the whole window, N·m.
    val_rms_family, val_rms_greybox : float
        The same over the held-out samples, N·m.
    epochs : int
        Adam steps taken (early stopping included).
    peak_rotation, idealised_yield_rotation, ductility_factor : float
        ``θp`` (rad), ``θ*`` of the combined skeleton (rad), ``θp / θ*`` (at most 1 where
        the family fit did not yield).
    fallback : bool
        True where the combined skeleton gave no positive finite ``θ*`` and the family's
        own ``θ*`` was used.
    """

    c: float
    rms_family: float
    rms_greybox: float
    val_rms_family: float
    val_rms_greybox: float
    epochs: int
    peak_rotation: float
    idealised_yield_rotation: float
    ductility_factor: float
    fallback: bool


@dataclass(frozen=True)
class GreyboxResult:
    """The grey-box of one event: the family it started from and its sections (bottom up)."""

    family: str
    sections: tuple[GreyboxSection, ...]
    wall_s: float

    @property
    def ductility_factor(self) -> np.ndarray:
        """DF per section, (N,)."""
        return np.array([s.ductility_factor for s in self.sections])

    @property
    def states(self) -> list[str]:
        """State per section from the DF by the project's thresholds."""
        return [classify_ductility(d).name.lower() for d in self.ductility_factor]


def family_moment(choice: FamilyChoice, section: int, theta: np.ndarray) -> np.ndarray:
    """The chosen family's moment history (N·m) of ``section`` driven by ``theta`` (rad)."""
    fit = choice.sections[section].fits[choice.family]
    p = fit.params
    if choice.family == "takeda":
        tp = TakedaParameters(p["k0"], p["mc"], p["my"], p["theta_y"], p["kp"], p["alpha"],
                              p["pinch_x"], p["pinch_y"])
        return takeda_moment(theta, tp)
    return bilinear_moment(theta, p["k1"], p["k2"], p["fy"])


def _features(theta: np.ndarray, theta_dot: np.ndarray, peak: float, rate: float
              ) -> np.ndarray:
    run_peak = np.maximum.accumulate(np.abs(theta))
    return np.column_stack([theta / peak, theta_dot / rate, run_peak / peak,
                            np.sign(theta_dot)])


def _split(t_len: int, settings: GreyboxSettings, rng: np.random.Generator) -> np.ndarray:
    """Boolean mask of the held-out samples: random contiguous blocks."""
    edges = np.linspace(0, t_len, settings.n_blocks + 1).astype(int)
    n_val = max(1, int(round(settings.val_fraction * settings.n_blocks)))
    chosen = rng.choice(settings.n_blocks, size=n_val, replace=False)
    mask = np.zeros(t_len, dtype=bool)
    for b in chosen:
        mask[edges[b]:edges[b + 1]] = True
    return mask


def _early_stopped(residual, net, c_s, opt, split, sigma2: float,
                   settings: GreyboxSettings) -> tuple[int, float]:
    """Train ``net`` and the scaled damping ``c_s`` on the training samples of ``split``
    (boolean tensors ``(train, validation)``) until the validation loss stopped falling for
    ``settings.patience`` epochs; the best network is loaded back.  Returns the epochs run and
    the best scaled damping."""
    import torch  # optional heavy dependency

    tr, va = split
    best, best_state, best_c, since, steps = np.inf, None, float(c_s.detach()), 0, 0
    for steps in range(1, settings.epochs + 1):
        opt.zero_grad()
        loss = torch.mean(residual()[tr] ** 2) / sigma2
        loss.backward()
        opt.step()
        with torch.no_grad():
            c_s.clamp_(min=0.0)
            v = float(torch.mean(residual()[va] ** 2)) / sigma2
        if v < best * (1.0 - 1e-4):
            best, since = v, 0
            best_state = {k: t.clone() for k, t in net.state_dict().items()}
            best_c = float(c_s.detach())
        else:
            since += 1
            if since >= settings.patience:
                break
    if best_state is not None:
        net.load_state_dict(best_state)
    return steps, best_c


def _train_section(theta: np.ndarray, theta_dot: np.ndarray, g: np.ndarray, f: np.ndarray,
                   c0: float, noise_var: float, skel: Skeleton, yielded: bool,
                   settings: GreyboxSettings, seed: int, yield_floor: float = 0.0
                   ) -> GreyboxSection:
    import torch  # optional heavy dependency

    t_len = theta.size
    peak = float(np.max(np.abs(theta)))
    rate = max(float(np.max(np.abs(theta_dot))), 1e-300)
    scale = max(float(np.std(g)), 1e-300)
    # residual weights: the noise model's moment variance (floored so a section whose noise
    # is unknown keeps a finite loss); a constant per section, it fixes the loss's units
    sigma2 = max(float(noise_var), 1e-12 * scale ** 2) / scale ** 2
    rng = np.random.default_rng(seed)
    val = _split(t_len, settings, rng)
    torch.manual_seed(seed)
    dt = torch.float64
    x = torch.as_tensor(_features(theta, theta_dot, peak, rate), dtype=dt)
    e = torch.as_tensor((g - f) / scale, dtype=dt)
    thd = torch.as_tensor(theta_dot / rate, dtype=dt)
    tr, va = torch.as_tensor(~val), torch.as_tensor(val)
    h = settings.hidden
    net = torch.nn.Sequential(torch.nn.Linear(4, h), torch.nn.Tanh(), torch.nn.Linear(h, h),
                              torch.nn.Tanh(), torch.nn.Linear(h, 1)).to(dt)
    with torch.no_grad():  # start at r = 0: the grey-box starts at the parametric fit
        net[-1].weight.mul_(0.0)
        net[-1].bias.zero_()
    c_s = torch.nn.Parameter(torch.tensor(c0 * rate / scale, dtype=dt))
    opt = torch.optim.AdamW([{"params": net.parameters(), "weight_decay": settings.weight_decay},
                             {"params": [c_s], "weight_decay": 0.0}], lr=settings.lr)

    def residual() -> torch.Tensor:
        return e - c_s * thd - net(x)[:, 0]

    steps, best_c = _early_stopped(residual, net, c_s, opt, (tr, va), sigma2, settings)
    with torch.no_grad():
        c_s.fill_(best_c)
        r_gb = residual().numpy() * scale

        def r_of(th: np.ndarray, sign: float) -> np.ndarray:
            feats = np.column_stack([th / peak, np.zeros_like(th), np.abs(th) / peak,
                                     np.full_like(th, sign)])
            return net(torch.as_tensor(feats, dtype=dt))[:, 0].numpy() * scale

        # combined skeleton on a grid holding the family's corners (first yield among them)
        top = max(peak, skel.theta_first_yield) * 1.0001
        grid = np.union1d(np.linspace(0.0, top, 401), skel.theta[skel.theta < top])
        s_comb = skel(grid) + 0.5 * (r_of(grid, 1.0) - r_of(-grid, -1.0))
        s_comb[0] = 0.0
    r_fam = g - f - c0 * theta_dot
    c = best_c * scale / rate
    fallback = False
    try:
        comb = Skeleton(grid, s_comb, float((s_comb[-1] - s_comb[-2]) / (grid[-1] - grid[-2])),
                        skel.theta_first_yield)
        ty = idealised_yield(comb, peak, yield_floor)
    except InputDataError:
        ty = np.nan
    if not (np.isfinite(ty) and ty > 0):
        fallback, ty = True, idealised_yield(skel, peak, yield_floor)
    df = peak / ty if yielded else min(peak / ty, 1.0)

    def rms(a: np.ndarray) -> float:
        return float(np.sqrt(np.mean(a ** 2)))

    return GreyboxSection(c=c, rms_family=rms(r_fam), rms_greybox=rms(r_gb),
                          val_rms_family=rms(r_fam[val]), val_rms_greybox=rms(r_gb[val]),
                          epochs=steps, peak_rotation=peak, idealised_yield_rotation=float(ty),
                          ductility_factor=float(df), fallback=fallback)


def fit_greybox(theta: np.ndarray, theta_dot: np.ndarray, g: np.ndarray,
                noise_var: np.ndarray, choice: FamilyChoice,
                settings: GreyboxSettings | None = None) -> GreyboxResult:
    """Train the grey-box of one event from its family choice.

    Parameters
    ----------
    theta, theta_dot : ndarray, shape (T, N)
        Section rotations (rad) and rates (rad/s) of the window.
    g : ndarray, shape (T, N)
        Inertia moments the springs and dampers carry, N·m (as the family fit used them).
    noise_var : ndarray, shape (N,)
        Moment noise variance per section, (N·m)².
    choice : FamilyChoice
        The event's family fit (:func:`~pier_monitor.core.identify.families.fit_families`).
    settings : GreyboxSettings, optional

    Raises
    ------
    InputDataError
        On shapes that do not match the family choice's sections.
    """
    settings = settings or GreyboxSettings()
    th = np.asarray(theta, dtype=float)
    td, gg = np.asarray(theta_dot, dtype=float), np.asarray(g, dtype=float)
    nv = np.asarray(noise_var, dtype=float)
    if th.ndim != 2 or td.shape != th.shape or gg.shape != th.shape:
        raise InputDataError(f"theta, theta_dot, g: expected equal (T, N) shapes, got "
                             f"{th.shape}, {td.shape}, {gg.shape}")
    n = th.shape[1]
    if len(choice.sections) != n or nv.shape != (n,):
        raise InputDataError(f"expected {n} sections in the family choice and noise_var, got "
                             f"{len(choice.sections)} and {nv.shape}")
    if not (np.all(np.isfinite(th)) and np.all(np.isfinite(td)) and np.all(np.isfinite(gg))):
        raise InputDataError("theta, theta_dot, g: non-finite values")
    started = time.perf_counter()
    sections = []
    # the idealisation of the reference family's DF (the Takeda's floor on its elastic branch)
    floor = yield_peak_fraction(choice.family)
    for i in range(n):
        fit = choice.sections[i].fits[choice.family]
        f = family_moment(choice, i, np.ascontiguousarray(th[:, i]))
        sections.append(_train_section(th[:, i], td[:, i], gg[:, i], f, fit.c,
                                       float(np.nan_to_num(nv[i])), fit.skeleton,
                                       bool(choice.yielded[i]), settings,
                                       settings.seed * 1000 + i, floor))
    return GreyboxResult(choice.family, tuple(sections), time.perf_counter() - started)
