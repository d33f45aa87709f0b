"""Reference cases with known truth (the paper's simulation pier)."""

from __future__ import annotations

import numpy as np

from pier_monitor.core.ingest.fusion import fuse_acceleration_displacement
from pier_monitor.core.ingest.window import MeasuredWindow, NoiseModel
from pier_monitor.core.model.config import PierGeometry, SpringParameters
from pier_monitor.core.model.ground_motion import GroundMotion, synthetic_near_fault
from pier_monitor.core.model.solver import Response, simulate

__all__ = ["table1_model", "paper_case_window", "realistic_case_window"]


def table1_model() -> tuple[PierGeometry, SpringParameters]:
    """The pier of the paper's Table 1, SI units.

    Six 1 m sections; masses 14.4, 9.6 (x4) and 1033.8 t; ``k1 = [1, 0.9, 1, 1, 1, 1]·10⁹``
    N·m/rad, ``k2 = k1/10``, ``fy = [5, 4.5, 5, 5, 5, 5]·10⁶`` N·m,
    ``c = [2, 2.2, 2, 2, 2, 2]·10⁷`` N·m·s/rad.  ``config/table1.yaml`` holds the same.
    """
    k1 = np.array([1.0, 0.9, 1.0, 1.0, 1.0, 1.0]) * 1e9
    return (PierGeometry(np.ones(6), np.array([14.4, 9.6, 9.6, 9.6, 9.6, 1033.8]) * 1e3),
            SpringParameters(k1, k1 / 10, np.array([5, 4.5, 5, 5, 5, 5]) * 1e6,
                             np.array([2, 2.2, 2, 2, 2, 2]) * 1e7))


def paper_case_window(*, moments_measured: bool = True, noise_mgal: float = 1.0, seed: int = 0,
                      ground_motion: GroundMotion | None = None,
                      window_s: tuple[float, float] = (30.0, 50.0)
                      ) -> tuple[MeasuredWindow, SpringParameters, Response]:
    """The paper's simulation case (section 5-6) as a measured window with known truth.

    The Table 1 pier under the synthetic near-fault record at PGA 8 m/s² (or
    ``ground_motion``), simulated at 1 ms, sampled at 100 Hz, cut to ``window_s``.
    Gaussian noise of ``noise_mgal`` (1 mgal = 1e-5 m/s²) on the accelerations (relative
    and foundation), and the same signal-to-noise ratio on velocity, displacement and, when
    measured, moment.  The design values given to the identifier are the paper's starting
    point: half the true ``k1, k2, c`` and a tenth of the true ``fy``.

    Returns
    -------
    window : MeasuredWindow
        The noisy measured window.
    truth : SpringParameters
        The true parameters.
    response : Response
        The noise-free responses over the window.
    """
    geometry, truth = table1_model()
    gm = ground_motion if ground_motion is not None else synthetic_near_fault(pga_mps2=8.0)
    resp = simulate(geometry, truth, gm.acc, gm.dt, output_dt=0.01).window(*window_s)
    rng = np.random.default_rng(seed)
    sigma_a = noise_mgal * 1e-5
    snr = np.max(np.abs(resp.a)) / sigma_a
    sigma = {}
    noisy = {}
    for key, arr in (("a", resp.a), ("v", resp.v), ("x", resp.x), ("f", resp.moment)):
        s = sigma_a if key == "a" else float(np.max(np.abs(arr))) / snr
        sigma[key] = np.full(geometry.n_levels, s)
        noisy[key] = arr + s * rng.standard_normal(arr.shape)
    nan = np.full(geometry.n_levels, np.nan)
    noise = NoiseModel(ag=sigma_a, a=sigma["a"], v=sigma["v"], x=sigma["x"], dx=nan, dv=nan,
                       f=sigma["f"] if moments_measured else nan)
    window = MeasuredWindow(
        pier_id="table1", event_id=f"paper_case_seed{seed}", geometry=geometry,
        design=truth.scaled(k1=0.5, k2=0.5, fy=0.1, c=0.5), t=resp.t,
        ag=resp.ag + sigma_a * rng.standard_normal(resp.ag.shape), a=noisy["a"], v=noisy["v"],
        x=noisy["x"], moments=noisy["f"] if moments_measured else None, noise=noise)
    return window, truth, resp


def realistic_case_window(*, seed: int = 0, acc_noise_mps2: float = 1e-3,
                          wire_noise_m: float = 1e-4, sensor_rate_hz: float = 200.0,
                          window_s: tuple[float, float] = (30.0, 50.0), pad_s: float = 5.0
                          ) -> tuple[MeasuredWindow, SpringParameters, Response]:
    """The Table 1 case with realistic sensors: no velocity meters, no moments.

    Relative and foundation accelerations with ``acc_noise_mps2`` RMS noise, wire
    displacements with ``wire_noise_m`` RMS noise, at ``sensor_rate_hz``.  Velocities and
    displacements are reconstructed by the Kalman/RTS fusion at the sensor rate over the
    window padded by ``pad_s``, then everything is taken at 100 Hz.  Design values: the
    paper's starting point (half ``k1, k2, c``, a tenth of ``fy``); nothing uses the truth.
    """
    geometry, truth = table1_model()
    gm = synthetic_near_fault(pga_mps2=8.0)
    full = simulate(geometry, truth, gm.acc, gm.dt, output_dt=1.0 / sensor_rate_hz)
    padded = full.window(window_s[0] - pad_s, window_s[1] + pad_s)
    rng = np.random.default_rng(seed)
    a_meas = padded.a + acc_noise_mps2 * rng.standard_normal(padded.a.shape)
    ag_meas = padded.ag + acc_noise_mps2 * rng.standard_normal(padded.ag.shape)
    x_meas = padded.x + wire_noise_m * rng.standard_normal(padded.x.shape)
    fused = fuse_acceleration_displacement(a_meas, x_meas, sensor_rate_hz, acc_noise_mps2,
                                           wire_noise_m)
    step = int(round(sensor_rate_hz / 100.0))
    sel = np.flatnonzero((padded.t >= window_s[0] - 1e-9) & (padded.t < window_s[1] - 1e-9))
    sel = sel[::step]
    truth_resp = full.window(*window_s)
    truth_resp = type(truth_resp)(*(getattr(truth_resp, k)[::step] for k in
                                    ("t", "ag", "x", "v", "a", "theta", "moment")))
    window = MeasuredWindow(
        pier_id="table1", event_id=f"realistic_seed{seed}", geometry=geometry,
        design=truth.scaled(k1=0.5, k2=0.5, fy=0.1, c=0.5), t=padded.t[sel], ag=ag_meas[sel],
        a=a_meas[sel], v=fused.v[sel], x=fused.x[sel], moments=None,
        noise=NoiseModel(ag=acc_noise_mps2, a=np.full(geometry.n_levels, acc_noise_mps2),
                         v=fused.v_sigma[sel].mean(axis=0), x=fused.x_sigma[sel].mean(axis=0),
                         dx=np.sqrt(step * np.mean(fused.dx_sigma[sel] ** 2, axis=0)),
                         dv=np.sqrt(step * np.mean(fused.dv_sigma[sel] ** 2, axis=0)),
                         f=np.full(geometry.n_levels, np.nan)),
        report={"fusion_q": fused.q.tolist()})
    return window, truth, truth_resp
