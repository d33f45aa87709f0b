"""Benchmarks with known truth: fixed seeds, a printed table, JSON results.

``pier-monitor bench`` runs them.  Each case returns a plain dict with at least
``case``, ``wall_s`` and ``device``; the command prints a table and can write the list
as JSON.
"""

from __future__ import annotations

import dataclasses
import operator
import platform
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from pier_monitor.bags import read_bag
from pier_monitor.bench_greybox import greybox_suite
from pier_monitor.bench_heldout import (DESIGN_LOG_SD, heldout_pinn_suite, heldout_suite,
                                        identify_default, identify_rc_case)
from pier_monitor.bench_live import bench_latency
from pier_monitor.bench_fiber import bench_fiber
from pier_monitor.store import ResultsStore
from pier_monitor.bags.synthetic_bag import write_synthetic_edefense_bag
from pier_monitor.bags.synthetic_fleet import write_synthetic_fleet
from pier_monitor.core.identify.damage import (ductility_factors, split_unmeasured_evidence,
                                               yield_out_of_reach_evidence)
from pier_monitor.core.ingest import StreamIngest, ingest_recording
from pier_monitor.core.errors import InputDataError, SolverError
from pier_monitor.core.identify.selfcheck import (ENERGY_INDEX_LARGE, ENERGY_INDEX_MISFIT,
                                                  MisfitEntry, MisfitLimits, ModelMisfit,
                                                  energy_indices, judge_misfit, model_misfit,
                                                  section_evidence)
from pier_monitor.core.identify.states import DAMAGED_DF, classify_ductility
from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.core.model.config import PierConfig, SpringParameters, load_config
from pier_monitor.core.model.ground_motion import GroundMotion, el_centro_1940, synthetic_near_fault
from pier_monitor.core.model.solver import HAVE_NUMBA, Response, simulate
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.field import field_case_recording, field_pier, field_recording
from pier_monitor.core.synthetic.shaking_table import (RunSpec, Scenario, SyntheticRecording,
                                                       generate_recording)
from pier_monitor.core.synthetic.reference import (paper_case_window, realistic_case_window,
                                                   table1_model)
from pier_monitor.fleet import FleetOptions, LocalPool, RayBackend, run_fleet
from pier_monitor.core.identify.methods import (IdentificationRun, IdentifySettings, PinnSettings,
                                               identify)

__all__ = ["bench_solver", "bench_ingest", "bench_paper", "bench_more", "bench_fleet",
           "run_identification_case",
           "score_identification", "SUITES", "DEFAULT_SUITES", "format_table"]


def bench_solver(repeats: int = 5) -> list[dict[str, Any]]:
    """Time 60 s of the Table 1 pier at a 1 ms step under the synthetic near-fault record.

    The first call includes numba's compilation (or loading its cache); the reported
    ``wall_s`` is the median of ``repeats`` further calls.
    """
    geometry, params = table1_model()
    gm = synthetic_near_fault(duration_s=60.0, pga_mps2=8.0)
    t0 = time.perf_counter()
    resp = simulate(geometry, params, gm.acc, gm.dt)
    first = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(geometry, params, gm.acc, gm.dt)
        times.append(time.perf_counter() - t0)
    df = ductility_factors(resp.theta, params)
    return [{
        "case": "solver_table1_60s_1ms",
        "description": "Newmark linear acceleration, 60 s at dt 1 ms, Table 1 pier, PGA 8 m/s2",
        "wall_s": float(np.median(times)),
        "first_call_s": first,
        "steps": int(round(gm.duration_s / 0.001)),
        "numba": HAVE_NUMBA,
        "device": f"cpu ({platform.processor() or platform.machine()})",
        "ductility_factors": [round(float(v), 3) for v in df],
    }]


def _errors_pct(estimate: np.ndarray, truth: np.ndarray) -> list[float]:
    return [float(v) for v in 100.0 * (np.asarray(estimate) / np.asarray(truth) - 1.0)]


def _stage_errors(params: SpringParameters, truth: SpringParameters,
                  yielding: np.ndarray) -> dict[str, float]:
    """MAE (%) of k1 and c over all springs and over the truly yielding ones."""
    out = {}
    for k in ("k1", "c"):
        err = np.abs(_errors_pct(getattr(params, k), getattr(truth, k)))
        out[k] = float(np.mean(err))
        out[f"{k}_yielded"] = float(np.mean(err[yielding])) if yielding.any() else float("nan")
    return out


def score_run(case: str, run: IdentificationRun, truth: SpringParameters,
              theta_true: np.ndarray, **info: Any) -> dict[str, Any]:
    """Score an identification against known truth (errors in % of the truth).

    ``mae_pct``: ``k1`` and ``c`` over all springs and over the springs that truly yield
    (true DF >= 1: ``*_yielded``); ``k2``, ``fy`` and ``df`` over the yielding springs;
    ``k2_fy_df2`` the largest |error| of ``k2``/``fy`` over springs with true DF >= 2.
    ``stages``: the same k1/c errors after each stage of the identification.  ``states_ok``:
    every section's state equals the state of its true DF.  With an ensemble, ``coverage``
    says per section whether the 90 % intervals of k1, c and DF hold the truth.
    """
    result = run.result
    est = result.params
    df_true = np.abs(theta_true).max(axis=0) / truth.yield_angles
    df_est = result.ductility_factors
    yielding = df_true >= 1.0
    strong = df_true >= 2.0
    err = {k: np.array(_errors_pct(getattr(est, k), getattr(truth, k)))
           for k in ("k1", "k2", "fy", "c")}
    err["df"] = np.array(_errors_pct(df_est, df_true))
    true_states = [classify_ductility(d).name.lower() for d in df_true]
    springs = []
    coverage: dict[str, list[bool]] = {"k1": [], "c": [], "df": []}
    for i, sec in enumerate(result.sections):
        entry = {
            "spring": i + 1, "true_df": float(df_true[i]), "df": sec.ductility_factor,
            "yielded": sec.yielded, "state": sec.state, "true_state": true_states[i],
            **{k: getattr(sec, k) for k in ("k1", "k2", "fy", "c")},
            "error_pct": {k: float(err[k][i]) for k in ("k1", "k2", "fy", "c", "df")},
        }
        u = sec.uncertainty
        if u is not None:
            entry["interval"] = {"k1": [u.k1.lo, u.k1.hi], "c": [u.c.lo, u.c.hi],
                                 "df": [u.ductility_factor.lo, u.ductility_factor.hi],
                                 "p_yielded": u.p_yielded, "p_state": list(u.p_state)}
            for key, spread, value in (("k1", u.k1, truth.k1[i]), ("c", u.c, truth.c[i]),
                                       ("df", u.ductility_factor, df_true[i])):
                # the DF of a section reported as not yielded is an upper bound ("DF <= 1")
                lo = 0.0 if key == "df" and not sec.yielded else spread.lo
                coverage[key].append(bool(lo <= value <= spread.hi))
        springs.append(entry)
    mae = {
        "k1": float(np.mean(np.abs(err["k1"]))),
        "c": float(np.mean(np.abs(err["c"]))),
        "k1_yielded": float(np.mean(np.abs(err["k1"][yielding]))) if yielding.any() else None,
        "c_yielded": float(np.mean(np.abs(err["c"][yielding]))) if yielding.any() else None,
        "k2": float(np.mean(np.abs(err["k2"][yielding]))) if yielding.any() else None,
        "fy": float(np.mean(np.abs(err["fy"][yielding]))) if yielding.any() else None,
        "df": float(np.mean(np.abs(err["df"][yielding]))) if yielding.any() else None,
        "k2_fy_df2": float(max(np.abs(err["k2"][strong]).max(initial=0.0),
                               np.abs(err["fy"][strong]).max(initial=0.0))),
    }
    out = {"case": case, **info, "wall_s": result.wall_time_s, "device": result.device,
           "epochs": result.epochs, "members": result.members, "mae_pct": mae,
           "initializer_mae_pct": _stage_errors(run.initial, truth, yielding),
           "stages": {name: _stage_errors(p, truth, yielding) for name, p in run.stages.items()},
           "yield_detected_ok": bool(np.array_equal(
               np.array([s.yielded for s in result.sections]), yielding)),
           "states_ok": [s["state"] for s in springs] == true_states,
           "springs": springs}
    if coverage["k1"]:
        out["coverage"] = coverage
    return out


def score_identification(case: str, window: MeasuredWindow, truth: SpringParameters,
                         resp: Response, settings: IdentifySettings | None = None,
                         **info: Any) -> dict[str, Any]:
    """Identify one window with known truth (``resp``: the true responses over the window)
    and score it (:func:`score_run`)."""
    settings = settings or IdentifySettings(seed=info.get("seed", 0))
    run = identify(window, settings)
    scored = score_run(case, run, truth, resp.theta, **info)
    scored.update(moments_measured=window.moments_measured, pairs=int(window.t.size - 1))
    return scored


def run_identification_case(case: str, *, moments_measured: bool, seed: int,
                            noise_mgal: float = 1.0, ground_motion: GroundMotion | None = None,
                            window_s: tuple[float, float] = (30.0, 50.0)) -> dict[str, Any]:
    """The paper's case (Table 1 pier, 1 mgal noise, paper starting point), scored."""
    window, truth, resp = paper_case_window(moments_measured=moments_measured,
                                            noise_mgal=noise_mgal, seed=seed,
                                            ground_motion=ground_motion, window_s=window_s)
    return score_identification(case, window, truth, resp, seed=seed, noise_mgal=noise_mgal)


def bench_paper(seeds: int = 5) -> list[dict[str, Any]]:
    """The paper's case with and without measured moments, ``seeds`` noise draws each."""
    out = []
    for moments in (True, False):
        name = "paper_moments" if moments else "paper_no_moments"
        for seed in range(seeds):
            out.append(run_identification_case(name, moments_measured=moments, seed=seed))
    return out


def bench_more() -> list[dict[str, Any]]:
    """The paper's Tables 4-5 and the realistic-noise case (one seed each)."""
    out = []
    for noise in (0.1, 10.0):
        for moments in (True, False):
            out.append(run_identification_case(
                f"noise_{noise:g}mgal_{'moments' if moments else 'no_moments'}",
                moments_measured=moments, seed=0, noise_mgal=noise))
    # a long-duration, pulse-free record (the paper's Tohoku case in spirit), window 30-60 s
    long_gm = synthetic_near_fault(duration_s=90.0, strong_start_s=30.0, strong_duration_s=25.0,
                                   pulse_share=0.0, dominant_hz=1.0, seed=1, pga_mps2=6.0)
    for moments in (True, False):
        out.append(run_identification_case(
            f"long_duration_{'moments' if moments else 'no_moments'}", moments_measured=moments,
            seed=0, ground_motion=long_gm, window_s=(30.0, 60.0)))
    # a real record: El Centro 1940 NS at its own scale (PGA 3.07 m/s², DF 4.8 / 3.7 / 0.95)
    for moments in (True, False):
        out.append(run_identification_case(
            f"el_centro_1940_{'moments' if moments else 'no_moments'}", moments_measured=moments,
            seed=0, ground_motion=el_centro_1940(), window_s=(1.0, 21.0)))
    window, truth, resp = realistic_case_window(seed=0)
    out.append(score_identification("realistic_noise", window, truth, resp, seed=0,
                                     noise="acc 1e-3 m/s2, wire 0.1 mm, no v, no f"))
    return out


#: Design values given to the identifier of the field cases, relative to the truth (the
#: configuration's values are the truth), from the base up: a design that is off, as in the
#: field.
DESIGN_FACTORS = {"k1": (0.85, 1.1, 1.2, 0.9, 1.15, 0.8), "k2": (1.2, 0.9, 0.8, 1.1, 1.0, 1.2),
                         "fy": (0.9, 1.15, 1.1, 0.85, 1.2, 0.9), "c": (1.3, 0.75, 1.2, 0.8, 1.25, 0.7)}
#: The layouts of the field suite: (layout, GNSS at the top, identification method).
FIELD_LAYOUTS = (("full", False, "field"), ("full", False, "pinn"), ("accel", False, "auto"),
                 ("accel", True, "auto"), ("sparse", False, "auto"), ("sparse", True, "auto"))


def field_case(pier: str, layout: str, gnss: bool, shaking: str, seed: int
               ) -> tuple[MeasuredWindow, SpringParameters, np.ndarray]:
    """One field case ingested as the product ingests it: ``(window, truth, θ_true)``,
    ``θ_true`` the true spring angles (T, N) at the window's samples."""
    return _field_window(field_case_recording(pier, layout, gnss, shaking, seed),
                         f"{pier}/{layout}/{shaking}/{seed}")


def _field_window(syn: SyntheticRecording, name: str
                  ) -> tuple[MeasuredWindow, SpringParameters, np.ndarray]:
    """A one-run synthetic field recording ingested: its window with design values off the
    truth by :data:`DESIGN_FACTORS`, the true parameters and the true angles (T, N) at the
    window's samples."""
    windows, report = ingest_recording(syn.recording)
    if len(windows) != 1:
        reasons = "; ".join(o.failure or "" for o in report.outcomes)
        raise InputDataError(f"field case {name}: expected one window, got {len(windows)} "
                             f"({reasons})")
    window = windows[0]
    run = syn.truth.runs[0]
    rate = syn.truth.sample_rate_hz
    first = int(round((window.start_time_ns - run.start_ns) * rate / 1e9))
    step = int(round(rate * window.dt))
    theta = run.response.theta[first:first + step * window.t.size:step]
    n = window.n_levels
    design = SpringParameters(*(getattr(run.params, k) * np.asarray(DESIGN_FACTORS[k][:n])
                                for k in ("k1", "k2", "fy", "c")))
    return dataclasses.replace(window, design=design), run.params, theta


def bench_field(seeds: int = 5, piers: tuple[str, ...] = ("edefense", "table1"),
                layouts: tuple[tuple[str, bool, str], ...] = FIELD_LAYOUTS,
                shakings: tuple[str, ...] = ("strong", "just_yield"),
                pinn_seeds: int = 1) -> list[dict[str, Any]]:
    """Every sensor layout on both piers under both shakings, ``seeds`` seeds each: synthetic
    recordings with imperfect sensors (gains 1 %, azimuths 0.5°, tilts, biases unknown to the
    configuration), ingested and identified like a bag.  The full layout also through the
    PINN (``method="pinn"``, minutes per case on a CPU: ``pinn_seeds`` seeds)."""
    out = []
    for pier in piers:
        for layout, gnss, method in layouts:
            for shaking in shakings:
                for seed in range(pinn_seeds if method == "pinn" else seeds):
                    window, truth, theta = field_case(pier, layout, gnss, shaking, seed)
                    run = identify(window, IdentifySettings(seed=seed, method=method))
                    name = (f"field_{pier}_{layout}{'+gnss' if gnss else ''}"
                            f"{'' if method == 'auto' else '_' + method}_{shaking}")
                    out.append(score_run(name, run, truth, theta, seed=seed, pier=pier,
                                         layout=layout, gnss=gnss, method=method,
                                         shaking=shaking,
                                         coverage_layout=window.coverage.layout))
    return out


def bench_coverage(seeds: int = 20, members: int = 32, first_seed: int = 200,
                   layouts: tuple[tuple[str, bool], ...] = (("accel", False), ("sparse", False)),
                   shakings: tuple[str, ...] = ("strong", "just_yield")
                   ) -> list[dict[str, Any]]:
    """Calibration of the intervals: field layouts on the E-Defense-style pier, ``seeds``
    seeds (from ``first_seed``: seeds the field suite does not use) with ``members``-member
    ensembles; ``coverage`` of every run says whether the 90 % intervals held the truth
    (seeds 100-109 were used to choose the posterior scaling; the default seeds check it)."""
    out = []
    for layout, gnss in layouts:
        for shaking in shakings:
            for seed in range(first_seed, first_seed + seeds):
                window, truth, theta = field_case("edefense", layout, gnss, shaking, seed)
                run = identify(window, IdentifySettings(seed=seed, members=members))
                name = f"coverage_edefense_{layout}{'+gnss' if gnss else ''}_{shaking}"
                out.append(score_run(name, run, truth, theta, seed=seed, pier="edefense",
                                     layout=layout, gnss=gnss, shaking=shaking))
    return out


def _pga_for_ductility(config: PierConfig, run: RunSpec, target: float) -> float:
    """PGA (m/s²) of ``run`` at which the base spring's true DF is ``target`` (bisection;
    the DF grows with the PGA)."""
    def df(pga: float) -> float:
        scenario = Scenario(runs=(dataclasses.replace(run, pga_mps2=pga),), lead_s=20.0,
                            tail_s=20.0)
        truth = generate_recording(config, scenario, seed=0).truth
        return float(truth.runs[0].ductility_factors[0])

    lo, hi = 0.25 * run.pga_mps2, 2.0 * run.pga_mps2
    for _ in range(12):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if df(mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def bench_missed_damage(seeds: int = 5, members: int = 32,
                        targets: tuple[float, ...] = (1.2, 1.5),
                        noise_factors: tuple[float, ...] = (1.0, 3.0)) -> list[dict[str, Any]]:
    """Missed damage: the E-Defense-style pier, accelerometers only, shaken so that its base
    spring reaches a true DF of 1.2 and of 1.5, at the sensors' noise and at three times it
    (the configuration knows the noise), ``seeds`` seeds, ``members``-member ensembles.
    Each run records the base spring's state and its probability of being intact; it must
    never be reported intact with a probability above 0.5."""
    spec = field_pier("edefense")
    base = load_config(find_config_file(spec.config_file))
    run = spec.runs["just_yield"]
    out = []
    for target in targets:
        pga = _pga_for_ductility(base, run, target)
        scenario = Scenario(runs=(dataclasses.replace(run, pga_mps2=pga),), lead_s=20.0,
                            tail_s=20.0)
        for factor in noise_factors:
            config = dataclasses.replace(base, sensors=tuple(
                dataclasses.replace(sp, noise_rms=sp.noise_rms * factor) for sp in base.sensors))
            for seed in range(seeds):
                name = f"missed_damage_df{target:g}_noise{factor:g}x"
                window, params, theta = _field_window(
                    field_recording(config, "accel", scenario, seed=seed), f"{name}/{seed}")
                identified = identify(window, IdentifySettings(seed=seed, members=members))
                scored = score_run(name, identified, params, theta, seed=seed,
                                   target_df=target, noise_factor=factor, pga_mps2=pga)
                base_spring = scored["springs"][0]
                p_intact = base_spring["interval"]["p_state"][0]
                scored["base_spring"] = {"state": base_spring["state"], "p_intact": p_intact,
                                         "true_df": base_spring["true_df"],
                                         "missed": bool(base_spring["state"] == "intact"
                                                        or p_intact > 0.5)}
                out.append(scored)
    return out


def bench_ingest() -> list[dict[str, Any]]:
    """Read and ingest the synthetic E-Defense-style bag (150 s, 32 sensors, 80 channels at
    200 Hz, two events): whole, and streamed in 0.1 s blocks."""
    with tempfile.TemporaryDirectory() as tmp:
        info = write_synthetic_edefense_bag(Path(tmp) / "bench.mcap", fmt="mcap", seed=0)
        t0 = time.perf_counter()
        rec = read_bag(info.bag.path)
        t_read = time.perf_counter() - t0
    t0 = time.perf_counter()
    windows, _ = ingest_recording(rec)
    t_ingest = time.perf_counter() - t0
    stream = StreamIngest(rec.config)
    for t_ns, cfg in rec.config_updates:
        stream.update_config(cfg, t_ns)
    n = max(r.n_samples for r in rec.sensors.values())
    t0 = time.perf_counter()
    got = []
    for b0 in range(0, n, 20):
        for sid, r in rec.sensors.items():
            got += stream.push(sid, r.time_ns[b0:b0 + 20], r.data[b0:b0 + 20],
                               r.sample_index[b0:b0 + 20])
    got += stream.flush()
    t_stream = time.perf_counter() - t0
    duration = (rec.end_ns - rec.start_ns) / 1e9
    channels = sum(r.n_axes for r in rec.sensors.values())
    return [{"case": "ingest_edefense_bag", "description": f"{duration:.0f} s, {len(rec.sensors)} "
             f"sensors, {channels} channels at {rec.config.sample_rate_hz:g} Hz, two events",
             "wall_s": t_read + t_ingest, "read_s": t_read, "ingest_s": t_ingest,
             "per_60s_of_data_s": (t_read + t_ingest) * 60.0 / duration,
             "stream_s": t_stream, "windows": len(windows), "stream_windows": len(got),
             "device": f"cpu ({platform.processor() or platform.machine()})"}]


def bench_fleet(piers: int = 4, max_epochs: int = 100) -> list[dict[str, Any]]:
    """Events per minute of ``pier-monitor fleet`` with 1 and 2 workers, local pool and Ray.

    A synthetic fleet of ``piers`` small piers (2-4 sections, 12 s records, seed 0) is
    identified with a short training (``max_epochs``, CPU, no figures) into a fresh results
    root per case.  Per case: wall time, events per minute, time to the first result; Ray's
    start-up is timed apart, and its overhead per task is its wall time less the local
    pool's with as many workers, per event.
    """
    settings = IdentifySettings(device="cpu", seed=0, pinn_settings=PinnSettings(
        max_epochs=max_epochs, min_epochs=1))
    options = FleetOptions(settings=settings, figures=False)
    out: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        bags = Path(tmp) / "bags"
        write_synthetic_fleet(bags, piers, seed=0, fmt="mixed", record_s=12.0, lead_s=8.0,
                              gap_s=14.0, tail_s=10.0, sections=(2, 4))
        for name in ("local", "ray"):
            for workers in (1, 2):
                t0 = time.perf_counter()
                backend: LocalPool | RayBackend = (
                    LocalPool(workers) if name == "local" else RayBackend(num_cpus=workers))
                start_s = time.perf_counter() - t0
                try:
                    run = run_fleet([bags], Path(tmp) / f"{name}{workers}", backend, options)
                finally:
                    backend.close()
                events = run.identified + run.failed
                out.append({"case": f"fleet_{name}_{workers}w",
                            "description": f"{piers} synthetic piers, {events} events, "
                                           f"{max_epochs} epochs max, CPU, {name} backend",
                            "backend": name, "workers": workers, "events": events,
                            "failed": run.failed, "wall_s": run.wall_s,
                            "events_per_min": 60.0 * events / run.wall_s,
                            "first_result_s": run.first_result_s, "backend_start_s": start_s,
                            "device": f"cpu ({platform.processor() or platform.machine()})"})
    local = {r["workers"]: r for r in out if r["backend"] == "local"}
    for r in out:
        if r["backend"] == "ray":
            base = local[r["workers"]]
            r["overhead_per_task_s"] = (r["wall_s"] - base["wall_s"]) / max(r["events"], 1)
    return out


#: Seeds of the self-check suite: thresholds are chosen on the tuning seeds
#: (:class:`~pier_monitor.core.identify.selfcheck.MisfitLimits`) and scored on the held-out
#: ones.
SELFCHECK_TUNING_SEEDS = (300,)
SELFCHECK_HELD_OUT_SEEDS = (302,)
#: Held-out seeds of the RC test-bed runs of the self-check suite (a minute and more per
#: run on two cores: one seed per pier, layout and shaking).
SELFCHECK_RC_SEEDS = (302,)
#: The sensor fault of the self-check suite: an offset step, m/s², in the relative
#: acceleration of one level from the middle of the window.
SELFCHECK_FAULT_MPS2 = 0.5


def _selfcheck_entry(run: IdentificationRun, window: MeasuredWindow, theta_true: np.ndarray,
                     truth: SpringParameters | None, **info: Any) -> dict[str, Any]:
    """One self-check run: the misfit of the identified model, the energy indices, the true
    DF (``truth`` None: the true DF is not a bilinear one and is left out)."""
    params = run.result.params
    misfit = model_misfit(window, params)
    a_rel = np.where(window.coverage.acceleration, window.a, run.reproduced.a)
    energy = energy_indices(window, params, run.reproduced.theta, a_rel)
    out = {**info, "wall_s": run.result.wall_time_s, "device": run.result.device,
           "misfit": misfit.as_dict(), "energy_index": [float(v) for v in energy],
           "df": [float(v) for v in run.result.ductility_factors],
           "states": [s.state for s in run.result.sections],
           "family": (run.result.family or {}).get("family"),
           "yielded": [bool(s.yielded) for s in run.result.sections],
           "measured_levels": [bool(v) for v in window.coverage.motion],
           "yield_rotation_vs_design": (run.result.family or {}).get("yield_rotation_vs_design"),
           # the lower end of each section's 90 % DF interval (None: no interval), which
           # rule 9 reads under a model misfit
           "df_lo": [None if s.uncertainty is None or s.uncertainty.members < 2
                     or not s.uncertainty.ductility_factor.defined
                     else float(s.uncertainty.ductility_factor.lo) for s in run.result.sections]}
    if truth is not None:
        out["true_df"] = [float(v) for v in np.abs(theta_true).max(axis=0)
                          / truth.yield_angles]
    return out


def _with_sensor_fault(window: MeasuredWindow, level: int, offset_mps2: float
                       ) -> MeasuredWindow:
    """``window`` with an offset step in the relative acceleration of ``level`` (0-based)
    from the middle of the window on."""
    a = np.array(window.a)
    a[window.t.size // 2:, level] += offset_mps2
    return dataclasses.replace(window, a=a)


def bench_selfcheck(tuning_seeds: tuple[int, ...] = SELFCHECK_TUNING_SEEDS,
                    held_out_seeds: tuple[int, ...] = SELFCHECK_HELD_OUT_SEEDS,
                    piers: tuple[str, ...] = ("edefense", "table1"),
                    layouts: tuple[str, ...] = ("full", "accel", "sparse"),
                    shakings: tuple[str, ...] = ("strong", "just_yield"),
                    fault_mps2: float = SELFCHECK_FAULT_MPS2,
                    variants: tuple[str, ...] = ("clean", "sensor_fault", "rc"),
                    rc_seeds: tuple[int, ...] = SELFCHECK_RC_SEEDS) -> list[dict[str, Any]]:
    """The output-error self-check (:mod:`pier_monitor.core.identify.selfcheck`) on clean
    in-model field cases (its false alarms), on the same windows with a sensor fault (an
    offset step of ``fault_mps2`` in one level's relative acceleration from the middle of
    the window, the level rotating with the seed) and on the RC test-bed (modified-Takeda
    springs with pinching, Rayleigh damping: a model the identifier does not assume;
    ``rc_seeds`` only, held out: nothing is tuned on it).  Field route (``method="field"``; ``auto`` is the
    same route on the accel and sparse layouts).  Every run says whether its seed was a
    tuning or a held-out one."""
    out = []
    for pier in piers:
        for layout in layouts:
            for shaking in shakings:
                for split, seeds in (("tuning", tuning_seeds), ("held_out", held_out_seeds)):
                    for seed in seeds:
                        out += _selfcheck_runs(pier, layout, shaking, seed, split, fault_mps2,
                                               tuple(v for v in variants if v != "rc"))
                for seed in rc_seeds:
                    out += _selfcheck_runs(pier, layout, shaking, seed, "held_out",
                                           fault_mps2, ("rc",) if "rc" in variants else ())
    return out


def _selfcheck_runs(pier: str, layout: str, shaking: str, seed: int, split: str,
                    fault_mps2: float, variants: tuple[str, ...]) -> list[dict[str, Any]]:
    """The self-check runs of one field case and seed (see :func:`bench_selfcheck`)."""
    out = []
    info = dict(pier=pier, layout=layout, shaking=shaking, seed=seed, split=split,
                method="field")
    settings = IdentifySettings(seed=seed, method="field")
    if "clean" in variants or "sensor_fault" in variants:
        window, truth, theta = field_case(pier, layout, False, shaking, seed)
    if "clean" in variants:
        run = identify(window, settings)
        out.append(_selfcheck_entry(run, window, theta, truth,
                                    case=f"selfcheck_{pier}_{layout}_{shaking}_clean",
                                    variant="clean", hysteresis="bilinear", **info))
    if "sensor_fault" in variants:
        levels = np.flatnonzero(window.coverage.acceleration)
        level = int(levels[seed % levels.size])
        faulty = _with_sensor_fault(window, level, fault_mps2)
        run = identify(faulty, settings)
        out.append(_selfcheck_entry(run, faulty, theta, truth,
                                    case=f"selfcheck_{pier}_{layout}_{shaking}_sensor_fault",
                                    variant="sensor_fault", fault_level=level + 1,
                                    fault_mps2=fault_mps2, hysteresis="bilinear", **info))
    if "rc" in variants:
        syn = field_case_recording(pier, layout, False, shaking, seed, hysteresis="takeda")
        window, _, theta = _field_window(syn, f"{pier}/{layout}/{shaking}/{seed}/takeda")
        rc = syn.truth.runs[0].rc
        run = identify(window, settings)
        entry = _selfcheck_entry(run, window, theta, None,
                                 case=f"selfcheck_{pier}_{layout}_{shaking}_rc",
                                 variant="rc", hysteresis="takeda", **info)
        entry.update(true_df=[float(v) for v in rc.ductility_factor],
                     rc_yielded=[bool(v) for v in rc.yielded])
        out.append(entry)
    return out


def _judged(run: dict[str, Any], limits: MisfitLimits) -> str:
    """The misfit kind of a self-check run under ``limits`` (from its raw entries)."""
    if not run["misfit"]["entries"]:
        return run["misfit"]["kind"]  # the simulation failed: a model misfit
    entries = [MisfitEntry(e["level"], e["quantity"], _nan_none(e["misfit_rel"]), 0.0,
                           _nan_none(e["systematic_r2"]), _nan_none(e["noise_rel"]),
                           _nan_none(e["offset_rel"])) for e in run["misfit"]["entries"]]
    return judge_misfit(entries, limits).kind


def _checked_states(run: dict[str, Any], limits: MisfitLimits) -> list[str]:
    """The states of a run after its self-check under ``limits`` (``identify_window``'s
    rules): every section unreliable for a sensor's misfit, else at least suspicious where
    the evidence says so, under a model misfit damaged only on a DF interval clear of 1.5
    of springs other than the bilinear (rules 8 and 9 of
    :mod:`~pier_monitor.core.identify.damage`), and the sections of a span no sensor splits
    neither intact where one yielded nor damaged under a model misfit or a
    reinforced-concrete family (rule 11, :func:`~pier_monitor.core.identify.damage.
    split_unmeasured_evidence`), and a section whose RC spring's yield is out of reach and its
    neighbours where one yielded neither intact nor damaged (rule 12, :func:`~pier_monitor.
    core.identify.damage.yield_out_of_reach_evidence`); rules 10 and 14 are not modelled."""
    kind = _judged(run, limits)
    if kind == "sensor":
        return ["unreliable"] * len(run["states"])
    entries = [MisfitEntry(e["level"], e["quantity"], _nan_none(e["misfit_rel"]), 0.0,
                           _nan_none(e["systematic_r2"]), _nan_none(e["noise_rel"]),
                           _nan_none(e["offset_rel"])) for e in run["misfit"]["entries"]]
    misfit = (judge_misfit(entries, limits) if entries else
              ModelMisfit(entries=(), kind=run["misfit"]["kind"],
                          reasons=tuple(run["misfit"]["reasons"])))
    evidence = section_evidence(misfit, np.array([_nan_none(e) for e in run["energy_index"]]))
    order = ["intact", "suspicious", "damaged"]
    states = [max(st, "suspicious", key=order.index) if ev and st in order else st
              for st, ev in zip(run["states"], evidence)]
    if misfit.kind == "model":
        bilinear = run.get("family") in (None, "bilinear")
        lows = run.get("df_lo") or [None] * len(states)
        states = ["suspicious" if st == "damaged" and (bilinear or lo is None or lo < DAMAGED_DF)
                  else st for st, lo in zip(states, lows)]
    if (misfit.kind == "model" or run.get("family") not in (None, "bilinear")) \
            and run.get("measured_levels") is not None:
        split = split_unmeasured_evidence(run["df"], run["yielded"], run["measured_levels"])
        states = ["suspicious" if sp and st in order else st for st, sp in zip(states, split)]
    if run.get("family") not in (None, "bilinear"):  # rule 12
        reach = yield_out_of_reach_evidence(run["df"], run["yielded"],
                                            run.get("yield_rotation_vs_design"))
        states = ["suspicious" if far and st in order else st for st, far in zip(states, reach)]
    return states


def _state_counts(runs: list[dict[str, Any]], checked: list[list[str]]) -> dict[str, Any]:
    """Over the sections with a known true DF: how many are reported intact at a true DF >=
    1.5 and damaged at a true DF < 1.2, before and after the self-check; how many runs are
    unreliable after it."""
    out: dict[str, Any] = {"unreliable_runs": sum(c[0] == "unreliable" for c in checked)}
    for label, states_of in (("before", lambda r, c: r["states"]), ("after", lambda r, c: c)):
        intact_damaged = damaged_elastic = sections = 0
        for r, c in zip(runs, checked):
            for st, d in zip(states_of(r, c), r.get("true_df", ())):
                sections += 1
                intact_damaged += st == "intact" and d >= 1.5
                damaged_elastic += st == "damaged" and d < 1.2
        out[f"intact_at_df_ge_1.5_{label}"] = intact_damaged
        out[f"damaged_at_df_lt_1.2_{label}"] = damaged_elastic
    return out


def _nan_none(value: float | None) -> float:
    return float("nan") if value is None else float(value)


def _ceil_to(value: float, step: float) -> float:
    return float(np.ceil(value / step - 1e-9) * step)


def calibrate_selfcheck(runs: list[dict[str, Any]]) -> dict[str, float]:
    """Thresholds of the self-check from the clean runs of the tuning seeds: 1.5 times the
    largest clean misfit (rounded up to 0.05) and offset (rounded up to 0.01, at least
    0.02); the energy index that promotes, twice the largest of the sections that truly
    stayed elastic (rounded up to 0.1, at least 0.2: the index of a spring that barely
    yielded is of that order), and the one under a model misfit, half of it."""
    clean = [r for r in runs if r["split"] == "tuning" and r["variant"] == "clean"]
    entries = [e for r in clean for e in r["misfit"]["entries"]]
    misfit = max((e["misfit_rel"] for e in entries if e["misfit_rel"] is not None),
                 default=0.0)
    offset = max((e["offset_rel"] for e in entries if e["offset_rel"] is not None),
                 default=0.0)
    elastic = [e for r in clean if "true_df" in r
               for e, d in zip(r["energy_index"], r["true_df"]) if d < 1.0 and np.isfinite(e)]
    energy = max(0.2, _ceil_to(2.0 * max(elastic, default=0.0), 0.1))
    return {"model_rel": _ceil_to(1.5 * misfit, 0.05), "offset_rel": max(
        0.02, _ceil_to(1.5 * offset, 0.01)), "energy_index_large": energy,
        "energy_index_misfit": 0.5 * energy}


def summarize_selfcheck(runs: list[dict[str, Any]], limits: MisfitLimits | None = None
                        ) -> dict[str, Any]:
    """Rates of the self-check per split (tuning / held-out) and variant under ``limits``
    (default: the product's): false alarms on the clean runs, detections (fires) and
    right attributions (``sensor`` for a sensor fault, ``model`` for a model the
    identifier does not assume) on the others; and, over the sections, how often a section
    that truly stayed elastic (DF < 1) reaches the promoting energy index."""
    limits = limits or MisfitLimits()
    out: dict[str, Any] = {"case": "selfcheck_summary", "limits": dataclasses.asdict(limits),
                           "energy_index_large": ENERGY_INDEX_LARGE,
                           "energy_index_misfit": ENERGY_INDEX_MISFIT,
                           "rule": "sensor misfit: every section unreliable; model misfit or "
                                   "large energy index: at least suspicious (selfcheck module)",
                           "calibrated_on_tuning": calibrate_selfcheck(runs),
                           "tuning_seeds": sorted({r["seed"] for r in runs
                                                   if r["split"] == "tuning"}),
                           "held_out_seeds": sorted({r["seed"] for r in runs
                                                     if r["split"] == "held_out"}),
                           "rates": {}, "wall_s": 0.0, "device": "cpu"}
    expected = {"clean": "none", "sensor_fault": "sensor", "rc": "model"}
    for split in ("tuning", "held_out"):
        for variant in ("clean", "sensor_fault", "rc"):
            sel = [r for r in runs if r["split"] == split and r["variant"] == variant]
            if not sel:
                continue
            kinds = [_judged(r, limits) for r in sel]
            fires = sum(k != "none" for k in kinds)
            entry = {"runs": len(sel), "fires": fires, "fire_rate": fires / len(sel),
                     "kind_as_expected": sum(k == expected[variant] for k in kinds),
                     "by_layout": {}}
            for layout in sorted({r["layout"] for r in sel}):
                ks = [k for k, r in zip(kinds, sel) if r["layout"] == layout]
                entry["by_layout"][layout] = {"runs": len(ks),
                                              "fires": sum(k != "none" for k in ks)}
            checked = [_checked_states(r, limits) for r in sel]
            entry.update(_state_counts(sel, checked))
            elastic = [e for r in sel if "true_df" in r
                       for e, d in zip(r["energy_index"], r["true_df"]) if d < 1.0]
            if elastic:
                entry["elastic_sections"] = len(elastic)
                entry["elastic_sections_over_energy_large"] = int(sum(
                    e >= ENERGY_INDEX_LARGE for e in elastic if e is not None))
            out["rates"][f"{split}/{variant}"] = entry
    return out


def _selfcheck_suite() -> list[dict[str, Any]]:
    """The ``selfcheck`` suite: :func:`bench_selfcheck` and its summary (last entry)."""
    runs = bench_selfcheck()
    return [*runs, summarize_selfcheck(runs)]


#: Held-out seeds of the RC suite (nothing in the product was tuned on them).
RC_HELD_OUT_SEEDS = (302, 303)
#: Tuning seeds of the RC test-bed: the ``rc_tuning`` suite, the same cases as ``rc`` on the
#: seeds the RC rules were chosen on (e.g. :data:`~pier_monitor.core.identify.damage.
#: BILINEAR_MISFIT`'s rule 8, rule 9 of the same module, the Takeda posterior's settings).
RC_TUNING_SEEDS = (300, 301)


def bench_rc(seeds: tuple[int, ...] = RC_HELD_OUT_SEEDS,
             hystereses: tuple[str, ...] = ("bilinear", "takeda", "bwbn"),
             piers: tuple[str, ...] = ("edefense", "table1"),
             layouts: tuple[str, ...] = ("full", "accel", "sparse"),
             shakings: tuple[str, ...] = ("strong", "just_yield")) -> list[dict[str, Any]]:
    """The default route on the RC test-bed, as the product runs it.

    Each case (imperfect sensors, design values off the truth) is ingested and identified
    by :func:`~pier_monitor.events.identify_window` with the default settings (``auto``: the
    equation-error fit with the spring family chosen by evidence on the full layout, the
    field reconstruction otherwise; then the self-check), so the states scored are the ones
    the product reports.  Truth: the bilinear springs' DF, or for the RC springs
    (:mod:`pier_monitor.core.synthetic.rc`) the DF on the idealised yield of the skeleton
    and whether the reinforcement yielded.  Seeds held out (:data:`RC_HELD_OUT_SEEDS`).
    Each case is a pier of its own, in a store of its own: no case is another's baseline."""
    out = []
    with tempfile.TemporaryDirectory(prefix="pier_monitor_rc_") as tmp:
        for hyst in hystereses:
            for pier in piers:
                for layout in layouts:
                    for shaking in shakings:
                        for seed in seeds:
                            store = ResultsStore(Path(tmp) / f"{hyst}_{pier}_{layout}_"
                                                 f"{shaking}_{seed}")
                            out.append(_rc_run(store, hyst, pier, layout, shaking, seed))
    return out


def _rc_run(store: ResultsStore, hyst: str, pier: str, layout: str, shaking: str,
            seed: int) -> dict[str, Any]:
    window, true_df, yielded, outcome, wall = identify_rc_case(
        store, _field_window, "rc", hyst, pier, layout, shaking, seed)
    result = outcome.result
    states = [s.state for s in result.sections]
    df = np.array([s.ductility_factor for s in result.sections])
    err = 100.0 * np.abs(df / true_df - 1.0)
    misfit = result.model_misfit or {}
    interval = _df_intervals(result.sections)
    return {
        "case": f"rc_{hyst}_{pier}_{layout}_{shaking}", "seed": seed,
        "split": "tuning" if seed in RC_TUNING_SEEDS else "held_out",
        "hysteresis": hyst, "pier": pier, "layout": layout, "shaking": shaking,
        "method": "equation_error" if window.coverage.is_full else "field",
        "family": (result.family or {}).get("family"),
        "misfit_kind": misfit.get("kind"), "misfit_fires": bool(misfit.get("fires")),
        # the self-check's worst level: its misfit over what the noise model allows
        "misfit_ratio": (misfit["worst_misfit_rel"] / misfit["worst_allowed_rel"]
                         if misfit.get("worst_misfit_rel") is not None
                         and misfit.get("worst_allowed_rel") else None),
        "states": states, "true_df": true_df.tolist(), "df": df.tolist(),
        "reinforcement_yielded": yielded.tolist(),
        "df_err_pct_yielded": [float(e) for e, y in zip(err, yielded) if y],
        # per yielded section: whether its DF is flagged poorly identified (shown as not
        # identified, never read as a number)
        "df_flagged_yielded": [bool("DF" in s.poorly_identified)
                               for s, y in zip(result.sections, yielded) if y],
        "df_interval": interval,
        # per yielded section: whether its DF interval holds the truth (None: no interval)
        "df_in_interval_yielded": [None if iv is None else bool(iv[0] <= t <= iv[1])
                                   for iv, t, y in zip(interval, true_df, yielded) if y],
        "intact_at_df_ge_1.5": int(sum(st == "intact" and d >= 1.5
                                       for st, d in zip(states, true_df))),
        "damaged_where_elastic": int(sum(st == "damaged" and not y
                                         for st, y in zip(states, yielded))),
        "unreliable": result.overall_state == "unreliable",
        "wall_s": round(wall, 2), "device": "cpu"}


def _held_of(held: list[bool | None]) -> dict[str, int]:
    """``{"held": ..., "with_interval": ..., "without_interval": ...}`` of per-section
    coverage flags (None: no interval)."""
    with_iv = [h for h in held if h is not None]
    return {"held": int(sum(with_iv)), "with_interval": len(with_iv),
            "without_interval": len(held) - len(with_iv)}


def summarize_rc(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Per hysteresis and layout: runs, family chosen, misfit fired, DF error on the
    yielded sections (mean, max; and over those whose DF is shown as identified, not
    flagged, with their count), their DF interval coverage, sections intact at a true
    DF >= 1.5, damaged where the reinforcement stayed elastic, unreliable runs, the slowest
    event."""
    out: dict[str, Any] = {"case": "rc_summary", "groups": {}, "wall_s": 0.0, "device": "cpu"}
    for hyst in sorted({r["hysteresis"] for r in runs}):
        for layout in sorted({r["layout"] for r in runs}):
            sel = [r for r in runs if r["hysteresis"] == hyst and r["layout"] == layout]
            if not sel:
                continue
            errs = [e for r in sel for e in r["df_err_pct_yielded"]]
            shown = [e for r in sel if not r["unreliable"]
                     for e, f in zip(r["df_err_pct_yielded"], r["df_flagged_yielded"]) if not f]
            out["groups"][f"{hyst}/{layout}"] = {
                "runs": len(sel),
                "family": {f: sum(str(r["family"]) == f for r in sel)
                           for f in sorted({str(r["family"]) for r in sel})},
                "misfit_fired": sum(r["misfit_fires"] for r in sel),
                "df_err_pct_yielded_mean": float(np.mean(errs)) if errs else None,
                "df_err_pct_yielded_max": float(np.max(errs)) if errs else None,
                # the same over the yielded sections of reliable runs whose DF is shown as
                # identified (not flagged), and how many of the yielded sections those are
                "df_err_pct_yielded_shown_mean": float(np.mean(shown)) if shown else None,
                "df_err_pct_yielded_shown_max": float(np.max(shown)) if shown else None,
                "df_shown_yielded": {"shown": len(shown), "yielded": len(errs)},
                # yielded sections whose DF interval holds the truth, of those with one
                # (reliable runs only: an unreliable result shows no state), and without one
                "df_coverage_yielded": _held_of([c for r in sel if not r["unreliable"]
                                                 for c in r["df_in_interval_yielded"]]),
                "intact_at_df_ge_1.5": sum(r["intact_at_df_ge_1.5"] for r in sel),
                "damaged_where_elastic": sum(r["damaged_where_elastic"] for r in sel),
                "unreliable_runs": sum(r["unreliable"] for r in sel),
                "max_wall_s": max(r["wall_s"] for r in sel)}
    return out


def _drawn_sequence_runs(spec: Any, hysteresis: str, seed: int,
                         n: int) -> tuple[tuple[RunSpec, ...], dict[str, np.ndarray], dict]:
    """The two shakings of a drawn sequence and the design factors, as the held-out suite
    draws one shaking (:func:`~pier_monitor.bench_heldout.heldout_case`): per shaking
    (``just_yield``, then ``strong``) its own record (El Centro 1940 NS with probability 1/3,
    else the seeded synthetic near-fault record with its own seed and pulse period) and a PGA
    of 0.8-1.25 times the test-bed's; the design values the truth times independent
    log-normal factors (σ = :data:`~pier_monitor.bench_heldout.DESIGN_LOG_SD` in log) per
    parameter and section.  Returns ``(runs, factors, info)``."""
    rng = np.random.default_rng([seed, 19])
    runs, info = [], {}
    for name in ("just_yield", "strong"):
        record = "el_centro_1940" if rng.random() < 1.0 / 3.0 else "synthetic"
        pga = spec.rc_pga_mps2[hysteresis][name] * float(rng.uniform(0.8, 1.25))
        runs.append(dataclasses.replace(spec.runs[name], pga_mps2=pga, record=record,
                                        motion_seed=int(rng.integers(1, 2 ** 31 - 1)),
                                        pulse_period_s=float(rng.uniform(0.8, 1.6))))
        info[name] = {"record": record, "pga_mps2": round(pga, 3)}
    factors = {k: np.exp(rng.normal(0.0, DESIGN_LOG_SD, n)) for k in ("k1", "k2", "fy", "c")}
    return tuple(runs), factors, info


def rc_sequence_windows(seed: int, pier: str, layout: str, hysteresis: str = "takeda",
                        drawn: bool = False) -> tuple[list[MeasuredWindow], Any, dict | None]:
    """The two windows of one RC pier's two-shaking sequence (:func:`bench_rc_sequence`),
    ingested, with their design values and event ids: ``(windows, recording, drawn)``,
    ``recording`` the test-bed's (its ``truth.runs`` one per window), ``drawn`` the drawn
    records and PGAs per shaking (None where not ``drawn``)."""
    spec = field_pier(pier)
    config = load_config(find_config_file(spec.config_file))
    n_springs = len(config.design.k1)
    if drawn:
        runs, factors, drawn_info = _drawn_sequence_runs(spec, hysteresis, seed, n_springs)
    else:
        runs = tuple(dataclasses.replace(spec.runs[s], pga_mps2=spec.rc_pga_mps2[hysteresis][s])
                     for s in ("just_yield", "strong"))
        factors = {k: np.asarray(DESIGN_FACTORS[k][:n_springs]) for k in DESIGN_FACTORS}
        drawn_info = None
    tag = "rcseqdraw" if drawn else "rcseq"
    syn = field_recording(config, layout, Scenario(runs=runs), seed=seed, hysteresis=hysteresis)
    windows, report = ingest_recording(syn.recording)
    if len(windows) != len(runs):
        reasons = "; ".join(o.failure or "" for o in report.outcomes)
        raise InputDataError(f"rc sequence {pier}/{layout}: expected {len(runs)} windows, "
                             f"got {len(windows)} ({reasons})")
    n = windows[0].n_levels
    first = syn.truth.runs[0].params
    design = SpringParameters(*(getattr(first, k) * factors[k][:n]
                                for k in ("k1", "k2", "fy", "c")))
    return [dataclasses.replace(
        window, design=design,
        event_id=f"{tag}_{hysteresis}_{pier}_{layout}_{seed}_{i + 1}_{run.name}")
        for i, (window, run) in enumerate(zip(windows, syn.truth.runs))], syn, drawn_info


def bench_rc_sequence(seed: int = RC_HELD_OUT_SEEDS[0], pier: str = "edefense",
                      layouts: tuple[str, ...] = ("full", "accel"),
                      hysteresis: str = "takeda", drawn: bool = False,
                      roundoff: float = 0.0) -> list[dict[str, Any]]:
    """Two shakings of one RC pier, as the product sees them: the k1 change it reports
    against the stiffness the test-bed's springs really lost.

    One recording of the RC test-bed (:mod:`~pier_monitor.core.synthetic.rc`): the pier's
    ``just_yield`` shaking, 30 s of quiet, then its ``strong`` one, the springs carrying
    their cracks, yielding and offsets from the first into the second.  Each window is
    ingested and identified in order by :func:`~pier_monitor.events.identify_window` into one
    store (default settings, design values off the truth by :data:`DESIGN_FACTORS`), so the
    second event's ``k1_change_pct`` is against the store's baseline (the first, when it is
    reliable).  Per layout, one entry per event (with its sections' DF intervals, the k1
    change's 90 % interval and the quantities flagged poorly identified) and a last one
    comparing, per section: the reported k1 change (the store's, its interval and whether it
    holds the true change, and ``k1`` of event 2 over event 1 directly), the
    family's small-amplitude stiffness after each event (``k_small_after``) and its change,
    and the truth's small-amplitude (unloading) stiffness before and after each event
    (:func:`~pier_monitor.core.synthetic.rc.rc_truth`).

    ``drawn``: the records, PGAs and design values are drawn from ``seed``
    (:func:`_drawn_sequence_runs`), not the test-bed's fixed record and
    :data:`DESIGN_FACTORS`; the cases are named ``rcseqdraw_...``.  ``roundoff``: every
    window's accelerations are multiplied by ``1 + roundoff`` before they are identified
    (:func:`bench_rc_sequence_roundoff`).
    """
    tag = "rcseqdraw" if drawn else "rcseq"
    out: list[dict[str, Any]] = []
    for layout in layouts:
        windows, syn, drawn_info = rc_sequence_windows(seed, pier, layout, hysteresis, drawn)
        events = []
        with tempfile.TemporaryDirectory(prefix=f"pier_monitor_{tag}_") as tmp:
            store = ResultsStore(Path(tmp))
            for i, (window, run) in enumerate(zip(windows, syn.truth.runs)):
                if roundoff:
                    window = dataclasses.replace(window, a=window.a * (1.0 + roundoff))
                outcome, wall = identify_default(window, store, seed)
                result = outcome.result
                truth = run.rc
                events.append({
                    "case": f"{tag}_{hysteresis}_{pier}_{layout}", "seed": seed,
                    "event": i + 1, "shaking": run.name, "layout": layout,
                    **({} if drawn_info is None else {"drawn": drawn_info[run.name]}),
                    "family": (result.family or {}).get("family"),
                    "family_reason": (result.family or {}).get("reason"),
                    "yield_gain_share": [sec.get("yield_gain_share") for sec in
                                         (result.family or {}).get("sections") or ()],
                    "overall_state": result.overall_state,
                    "states": [s.state for s in result.sections],
                    "df": [s.ductility_factor for s in result.sections],
                    "true_df": [float(v) for v in truth.ductility_factor],
                    "k1": [s.k1 for s in result.sections],
                    "k1_change_pct": [s.k1_change_pct for s in result.sections],
                    "k1_change_interval_pct": [
                        None if s.k1_change_lo_pct is None
                        else [s.k1_change_lo_pct, s.k1_change_hi_pct] for s in result.sections],
                    "df_interval": _df_intervals(result.sections),
                    "poorly_identified": [list(s.poorly_identified) for s in result.sections],
                    "k_small_after": [s.k_small_after for s in result.sections],
                    "true_k_small_before": [float(v) for v in truth.k_small_before],
                    "true_k_small_after": [float(v) for v in truth.k_small_after],
                    "wall_s": round(wall, 2), "device": "cpu"})
        ev1, ev2 = events

        def change(a: list[float | None], b: list[float | None]) -> list[float | None]:
            return [None if x is None or y is None else 100.0 * (y / x - 1.0)
                    for x, y in zip(a, b)]

        out.extend(events)
        out.append({
            "case": f"{tag}_{hysteresis}_{pier}_{layout}_summary", "seed": seed,
            "layout": layout,
            "reported_k1_change_pct": ev2["k1_change_pct"],
            "reported_k1_change_interval_pct": ev2["k1_change_interval_pct"],
            "true_change_in_interval": [
                None if iv is None else bool(iv[0] <= t <= iv[1])
                for iv, t in zip(ev2["k1_change_interval_pct"],
                                 change(ev2["true_k_small_before"], ev2["true_k_small_after"]))],
            "k1_change_pct_event2_vs_event1": change(ev1["k1"], ev2["k1"]),
            "family_k_small_change_pct_event2_vs_event1": change(ev1["k_small_after"],
                                                                 ev2["k_small_after"]),
            "true_k_small_change_pct_event2": change(ev2["true_k_small_before"],
                                                     ev2["true_k_small_after"]),
            "true_k_small_change_pct_event1": change(ev1["true_k_small_before"],
                                                     ev1["true_k_small_after"]),
            "true_k_small_change_pct_both": change(ev1["true_k_small_before"],
                                                   ev2["true_k_small_after"]),
            "wall_s": ev1["wall_s"] + ev2["wall_s"], "device": "cpu"})
    return out


#: Seeds of the drawn two-shaking sequences (:func:`bench_rc_sequence_drawn`).  The history
#: carried into the second event (``ResultsStore.rotation_peaks_before``) and
#: ``damage.VIRGIN_START_STIFFNESS`` were built and chosen on 620-625; 610-615 were then
#: scored as held out, and two fixes were found on them (the per-section choice between the
#: history and a virgin start, seed 614; the cumulative DF interval of a section started
#: from its history, seed 613), so they count as tuning now; 640-645 were drawn after
#: every choice and only scored.
RC_SEQUENCE_TUNING_SEEDS = (610, 611, 612, 613, 614, 615, 620, 621, 622, 623, 624, 625)
RC_SEQUENCE_HELD_OUT_SEEDS = (640, 641, 642, 643, 644, 645)
#: A second held-out set, drawn after rules 14 and 15 (``damage.YIELD_SPLIT``,
#: ``damage.SECTION_UNIDENTIFIED``), which had been measured on 640-645; first scored before
#: any later change (suite ``rc_sequence_drawn_fresh``).
RC_SEQUENCE_FRESH_SEEDS = (660, 661, 662, 663, 664, 665, 666, 667, 668, 669, 670, 671)
#: A third held-out set, drawn for the yield profile of the sections read not yielded
#: (``field_families.YIELD_PROFILE``), whose need was seen on the two sets above; scored
#: once, accelerometers only, with the code before and after it (suite
#: ``rc_sequence_drawn_third_accel``).
RC_SEQUENCE_THIRD_SEEDS = tuple(range(680, 692))
#: The RC acceptance's bound on a stiffness change, percentage points of the true change of
#: the small-amplitude stiffness.
K_CHANGE_TARGET_POINTS = 10.0


def bench_rc_sequence_drawn(seeds: tuple[int, ...] = RC_SEQUENCE_HELD_OUT_SEEDS,
                            piers: tuple[str, ...] = ("edefense", "table1"),
                            layouts: tuple[str, ...] = ("full", "accel"),
                            roundoff: float = 0.0) -> list[dict[str, Any]]:
    """:func:`bench_rc_sequence` on drawn sequences (``drawn=True``: each shaking's record
    and PGA, the design values drawn from the seed) of the modified-Takeda test-bed, both
    piers, and a summary per pier and layout (last entry) of the second event's stiffness
    change per section against the true change of the small-amplitude stiffness: how many
    are shown as identified (``k1`` not flagged in either event), how many of those have
    their 90 % interval holding the truth, are within :data:`K_CHANGE_TARGET_POINTS` of it
    and have its sign (a true change within ±1 % has none to get wrong), their mean and
    largest error; and the intervals of the flagged ones; and, under ``df``, the DFs and
    states of both events' sections (:func:`_count_df`).  A sequence whose test-bed
    simulation fails is an entry with ``skipped`` (the test-bed's own Newmark iteration).
    """
    out: list[dict[str, Any]] = []
    for seed in seeds:
        for pier in piers:
            split = "tuning" if seed in RC_SEQUENCE_TUNING_SEEDS else "held_out"
            try:
                runs = bench_rc_sequence(seed=seed, pier=pier, layouts=layouts, drawn=True,
                                         roundoff=roundoff)
            except SolverError as err:
                out.append({"case": f"rcseqdraw_takeda_{pier}", "seed": seed, "pier": pier,
                            "split": split, "skipped": str(err), "wall_s": 0.0,
                            "device": "cpu"})
                continue
            out.extend({**r, "pier": pier, "split": split} for r in runs)
    return [*out, summarize_rc_sequence(out)]


#: The relative change of the accelerations in :func:`bench_rc_sequence_roundoff`: far
#: below any sensor's noise, of the order of what another CPU's floating-point rounding
#: leaves in a long computation.
ROUNDOFF = 1e-9


def roundoff_counts(plain: list[dict[str, Any]], moved: list[dict[str, Any]]
                    ) -> dict[str, dict[str, int]]:
    """Per ``pier/layout``, the sections of the events of ``moved`` (both events of each
    sequence) against the same events of ``plain`` (matched by seed, pier, layout and event;
    entries without ``event`` are skipped): how many there are, whose state changed, whose
    DF moved by more than 5 % (of the true DF, at least 1), and, of the yielded ones (true DF
    above 1), how many there are and whose DF moved by more than 15 % of the true DF."""
    key = operator.itemgetter("seed", "pier", "layout", "event")
    first = {key(r): r for r in plain if "event" in r}
    groups: dict[str, dict[str, int]] = {}
    for r in moved:
        if "event" not in r or key(r) not in first:
            continue
        g = groups.setdefault(f"{r['pier']}/{r['layout']}", {
            "sections": 0, "state_changed": 0, "df_moved_5pct": 0, "yielded": 0,
            "yielded_df_moved_15pct": 0})
        a = first[key(r)]
        for df_a, df_b, t, st_a, st_b in zip(a["df"], r["df"], a["true_df"], a["states"],
                                             r["states"]):
            g["sections"] += 1
            g["state_changed"] += int(st_a != st_b)
            g["df_moved_5pct"] += int(abs(df_a - df_b) > 0.05 * max(t, 1.0))
            if t > 1.0:
                g["yielded"] += 1
                g["yielded_df_moved_15pct"] += int(abs(df_a - df_b) > 0.15 * t)
    return groups


def bench_rc_sequence_roundoff(seeds: tuple[int, ...] = RC_SEQUENCE_HELD_OUT_SEEDS,
                               layouts: tuple[str, ...] = ("full", "accel")
                               ) -> list[dict[str, Any]]:
    """How much of an answer is the optimiser's path, not the data: the drawn sequences of
    :func:`bench_rc_sequence_drawn` identified twice, as measured and with every window's
    accelerations multiplied by ``1 + ROUNDOFF``, and a last entry counting, per
    ``pier/layout``, the sections (both events) whose state changed, whose DF moved by more
    than 5 % (of the true DF, at least 1) and, of the yielded ones (true DF above 1), by more
    than 15 % (:func:`roundoff_counts`).  Entries of the perturbed runs carry
    ``"roundoff": ROUNDOFF``."""
    plain = [r for r in bench_rc_sequence_drawn(seeds, layouts=layouts)
             if r.get("case") != "rc_sequence_drawn_summary"]
    moved = [{**r, "roundoff": ROUNDOFF}
             for r in bench_rc_sequence_drawn(seeds, layouts=layouts, roundoff=ROUNDOFF)
             if r.get("case") != "rc_sequence_drawn_summary"]
    groups = roundoff_counts(plain, moved)
    return [*plain, *moved, {"case": "rc_sequence_roundoff_summary", "roundoff": ROUNDOFF,
                             "seeds": list(seeds), "groups": groups,
                             "wall_s": float(sum(r.get("wall_s", 0.0) for r in plain + moved
                                                 if "event" in r)),
                             "device": "cpu"}]


def _df_counts() -> dict[str, Any]:
    """Empty DF and state counts of :func:`_count_df`."""
    return {"yielded": 0, "yielded_err_pct": [], "yielded_within_15pct": 0,
            "yielded_interval_holds": 0, "yielded_shown": 0, "yielded_shown_missed": 0,
            "yielded_not_yielded_shown": 0, "elastic": 0, "elastic_intact": 0,
            "elastic_df_flagged": 0, "intact_at_df_ge_1.5": 0, "damaged_at_df_lt_1.2": 0}


def _count_df(d: dict[str, Any], event: dict[str, Any]) -> None:
    """Adds one event's sections to the counts ``d`` (:func:`_df_counts`): over the sections
    whose reinforcement yielded (true DF above 1) the DF error, how many are within 15 %,
    whose 90 % interval holds the truth, how many DFs are shown as identified (not flagged)
    and of those how many miss their interval, and how many read "not yielded" (DF at most
    1) while shown; over the elastic sections how many are intact and how many have their
    DF flagged; the wrong states of the RC acceptance."""
    for df, t, iv, flags, st in zip(event["df"], event["true_df"], event["df_interval"],
                                    event["poorly_identified"], event["states"]):
        if df is None or t is None:
            continue
        d["intact_at_df_ge_1.5"] += int(st == "intact" and t >= 1.5)
        d["damaged_at_df_lt_1.2"] += int(st == "damaged" and t < 1.2)
        holds = iv is not None and iv[0] <= t <= iv[1]
        if t > 1.0:
            d["yielded"] += 1
            d["yielded_err_pct"].append(100.0 * abs(df / t - 1.0))
            d["yielded_within_15pct"] += int(abs(df / t - 1.0) <= 0.15)
            d["yielded_interval_holds"] += int(holds)
            if "DF" not in flags:
                d["yielded_shown"] += 1
                d["yielded_shown_missed"] += int(not holds)
                d["yielded_not_yielded_shown"] += int(df <= 1.0)
        else:
            d["elastic"] += 1
            d["elastic_intact"] += int(st == "intact")
            d["elastic_df_flagged"] += int("DF" in flags)


def summarize_rc_sequence(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """The summary of :func:`bench_rc_sequence_drawn` (see there), per ``pier/layout``."""
    events = {(r["seed"], r["pier"], r["layout"], r["event"]): r for r in runs
              if "event" in r}
    groups: dict[str, dict[str, Any]] = {}
    for r in runs:
        if not str(r["case"]).endswith("_summary"):
            continue
        key = (r["seed"], r["pier"], r["layout"])
        first, second = events[key + (1,)], events[key + (2,)]
        g = groups.setdefault(f"{r['pier']}/{r['layout']}", {
            "sequences": 0, "shown": 0, "held": 0, "within_target": 0, "sign_right": 0,
            "abs_err_points": [], "flagged": 0, "flagged_held": 0, "no_change": 0})
        g["sequences"] += 1
        true = r["true_k_small_change_pct_event2"]
        for i, (rep, iv, t) in enumerate(zip(r["reported_k1_change_pct"],
                                             r["reported_k1_change_interval_pct"], true)):
            if rep is None or t is None:
                g["no_change"] += 1
                continue
            held = iv is not None and iv[0] <= t <= iv[1]
            if "k1" in first["poorly_identified"][i] or "k1" in second["poorly_identified"][i]:
                g["flagged"] += 1
                g["flagged_held"] += int(held)
                continue
            g["shown"] += 1
            g["held"] += int(held)
            g["within_target"] += int(abs(rep - t) <= K_CHANGE_TARGET_POINTS)
            g["sign_right"] += int(abs(t) <= 1.0 or (rep < 0) == (t < 0))
            g["abs_err_points"].append(abs(rep - t))
    for key, r in events.items():
        _count_df(groups[f"{key[1]}/{key[2]}"].setdefault("df", _df_counts()), r)
    for g in groups.values():
        errs = g.pop("abs_err_points")
        g["abs_err_points_mean"] = float(np.mean(errs)) if errs else None
        g["abs_err_points_max"] = float(np.max(errs)) if errs else None
        d = g.get("df")
        if d is not None:
            errs = d.pop("yielded_err_pct")
            d["yielded_err_pct_mean"] = float(np.mean(errs)) if errs else None
    return {"case": "rc_sequence_drawn_summary",
            "tuning_seeds": sorted({r["seed"] for r in runs if r.get("split") == "tuning"}),
            "held_out_seeds": sorted({r["seed"] for r in runs
                                      if r.get("split") == "held_out"}),
            "skipped": [{"seed": r["seed"], "pier": r["pier"], "why": r["skipped"]}
                        for r in runs if "skipped" in r],
            "groups": groups, "wall_s": float(sum(r.get("wall_s", 0.0) for r in runs
                                                   if "event" in r)),
            "device": "cpu"}


def _finite_pair(lo: float, hi: float) -> list[float] | None:
    """``[lo, hi]``, or None where either bound is not finite (strict JSON)."""
    return [float(lo), float(hi)] if np.isfinite(lo) and np.isfinite(hi) else None


def _df_intervals(sections: Any) -> list[list[float] | None]:
    """Each section's 90 % DF interval ``[lo, hi]``, None where it has none."""
    return [None if s.uncertainty is None else
            _finite_pair(s.uncertainty.ductility_factor.lo, s.uncertainty.ductility_factor.hi)
            for s in sections]


def _rc_suite(seeds: tuple[int, ...] = RC_HELD_OUT_SEEDS) -> list[dict[str, Any]]:
    """The ``rc`` suite (``rc_tuning`` with :data:`RC_TUNING_SEEDS`): :func:`bench_rc` and its
    summary (last entry)."""
    runs = bench_rc(seeds)
    return [*runs, summarize_rc(runs)]


SUITES: dict[str, Callable[[], list[dict[str, Any]]]] = {
    "solver": bench_solver,
    "ingest": bench_ingest,
    "paper": bench_paper,
    "more": bench_more,
    "fleet": bench_fleet,
    "field": bench_field,
    "coverage": bench_coverage,
    "missed_damage": bench_missed_damage,
    "selfcheck": _selfcheck_suite,
    "rc": _rc_suite,
    "rc_tuning": lambda: _rc_suite(RC_TUNING_SEEDS),
    "rc_sequence": lambda: bench_rc_sequence(),
    "rc_sequence_drawn": lambda: bench_rc_sequence_drawn(),
    "rc_sequence_drawn_tuning": lambda: bench_rc_sequence_drawn(RC_SEQUENCE_TUNING_SEEDS),
    "rc_sequence_drawn_fresh": lambda: bench_rc_sequence_drawn(RC_SEQUENCE_FRESH_SEEDS),
    "rc_sequence_drawn_third_accel": lambda: bench_rc_sequence_drawn(RC_SEQUENCE_THIRD_SEEDS,
                                                                     layouts=("accel",)),
    "rc_sequence_roundoff": lambda: bench_rc_sequence_roundoff(),
    "latency": lambda: bench_latency(),
    "heldout": lambda: heldout_suite(),
    "heldout_pinn": lambda: heldout_pinn_suite(),
    "fiber": lambda: bench_fiber(),
    "greybox": lambda: greybox_suite(_field_window),
}

#: Suites run by ``pier-monitor bench`` without options; ``--all`` runs every suite.
DEFAULT_SUITES = ("solver", "ingest", "paper")


def format_table(results: list[dict[str, Any]]) -> str:
    """Plain-text tables: the solver timing, and per identification case the errors (%)."""
    lines = []
    for r in results:
        if r["case"].startswith("solver"):
            lines.append(f"{r['case']}: {r['wall_s']:.3f} s (first call {r['first_call_s']:.3f} "
                         f"s, numba={r['numba']}, {r['steps']} steps), DF "
                         f"{r['ductility_factors']}")
        elif r["case"].startswith("fleet"):
            first = "-" if r["first_result_s"] is None else f"{r['first_result_s']:.1f} s"
            extra = f", Ray start {r['backend_start_s']:.1f} s, overhead per task " \
                    f"{r['overhead_per_task_s']:+.2f} s" if "overhead_per_task_s" in r else ""
            lines.append(f"{r['case']}: {r['events']} events in {r['wall_s']:.1f} s = "
                         f"{r['events_per_min']:.1f} events/min, first result after "
                         f"{first}{extra}")
        elif r["case"].startswith("ingest"):
            lines.append(f"{r['case']} ({r['description']}): read {r['read_s']:.2f} s + ingest "
                         f"{r['ingest_s']:.2f} s = {r['per_60s_of_data_s']:.2f} s per 60 s of "
                         f"data; streamed in 0.1 s blocks {r['stream_s']:.1f} s; windows "
                         f"{r['windows']} (stream {r['stream_windows']})")
    summary = [r for r in results if r["case"] == "selfcheck_summary"]
    for r in summary:
        lines.append(f"self-check (tuning seeds {r['tuning_seeds']}, held-out seeds "
                     f"{r['held_out_seeds']}; limits {r['limits']}, energy index "
                     f"{r['energy_index_large']:g} / {r['energy_index_misfit']:g} under a "
                     f"misfit; calibrated on tuning: {r['calibrated_on_tuning']})")
        lines.append(f"  {'split/variant':<24} {'runs':>5} {'fires':>6} {'rate':>6} "
                     f"{'kind ok':>8}  by layout (fires/runs)")
        for key, e in r["rates"].items():
            layouts = ", ".join(f"{k} {v['fires']}/{v['runs']}" for k, v in e["by_layout"].items())
            lines.append(f"  {key:<24} {e['runs']:>5} {e['fires']:>6} {e['fire_rate']:>6.0%} "
                         f"{e['kind_as_expected']:>8}  {layouts}; intact at DF>=1.5 "
                         f"{e['intact_at_df_ge_1.5_before']} -> "
                         f"{e['intact_at_df_ge_1.5_after']}, damaged at DF<1.2 "
                         f"{e['damaged_at_df_lt_1.2_before']} -> "
                         f"{e['damaged_at_df_lt_1.2_after']}, unreliable runs "
                         f"{e['unreliable_runs']}")
    for r in results:
        if r["case"] != "rc_sequence_roundoff_summary":
            continue
        lines.append(f"the same sequences with the accelerations times 1 + {r['roundoff']:g} "
                     f"(seeds {r['seeds']}): sections that moved")
        lines.append(f"  {'pier/layout':<18} {'sections':>8} {'state':>6} {'DF >5%':>7} "
                     f"{'yielded':>8} {'DF >15%':>8}")
        for key, g in r["groups"].items():
            lines.append(f"  {key:<18} {g['sections']:>8} {g['state_changed']:>6} "
                         f"{g['df_moved_5pct']:>7} {g['yielded']:>8} "
                         f"{g['yielded_df_moved_15pct']:>8}")
    for r in results:
        if r["case"] != "rc_sequence_drawn_summary":
            continue
        lines.append(f"two-shaking sequences (tuning seeds {r['tuning_seeds']}, held-out seeds "
                     f"{r['held_out_seeds']}): stiffness change of the second event")
        lines.append(f"  {'pier/layout':<18} {'seq':>4} {'shown':>6} {'held':>5} "
                     f"{'<=10pt':>7} {'sign':>5} {'err mean/max pt':>16} {'flagged held':>13}")
        for key, g in r["groups"].items():
            err = ("-" if g["abs_err_points_mean"] is None else
                   f"{g['abs_err_points_mean']:.1f}/{g['abs_err_points_max']:.1f}")
            lines.append(f"  {key:<18} {g['sequences']:>4} {g['shown']:>6} {g['held']:>5} "
                         f"{g['within_target']:>7} {g['sign_right']:>5} {err:>16} "
                         f"{g['flagged_held']:>6}/{g['flagged']:<6}")
        lines.append("  DFs of both events (true DF above 1: yielded; intervals 90 %)")
        lines.append(f"  {'pier/layout':<18} {'yielded':>7} {'err %':>6} {'<=15%':>6} "
                     f"{'iv holds':>8} {'shown':>6} {'shown out':>9} {'shown <=1':>9} "
                     f"{'elastic':>7} {'intact':>6} {'DF flag':>7}")
        for key, g in r["groups"].items():
            d = g.get("df")
            if d is None:
                continue
            err = "-" if d["yielded_err_pct_mean"] is None else f"{d['yielded_err_pct_mean']:.1f}"
            lines.append(f"  {key:<18} {d['yielded']:>7} {err:>6} {d['yielded_within_15pct']:>6} "
                         f"{d['yielded_interval_holds']:>8} {d['yielded_shown']:>6} "
                         f"{d['yielded_shown_missed']:>9} {d['yielded_not_yielded_shown']:>9} "
                         f"{d['elastic']:>7} {d['elastic_intact']:>6} "
                         f"{d['elastic_df_flagged']:>7}")
        for sk in r["skipped"]:
            lines.append(f"  skipped: seed {sk['seed']} {sk['pier']}: {sk['why']}")
    ident = [r for r in results if "mae_pct" in r]
    if ident:
        lines.append("")
        lines.append(f"{'case':<28} {'seed':>4} {'wall_s':>7} {'epochs':>6} "
                     f"{'MAE k1%':>8} {'k2%':>7} {'fy%':>7} {'c%':>7} {'DF%':>7} "
                     f"{'k2/fy DF>=2':>11} {'yield ok':>8} {'init k1%':>8} {'init c%':>7} device")
        for r in ident:
            m = r["mae_pct"]
            lines.append(f"{r['case']:<28} {r['seed']:>4} {r['wall_s']:>7.1f} {r['epochs']:>6} "
                         f"{m['k1']:>8.3f} {m['k2']:>7.3f} {m['fy']:>7.3f} {m['c']:>7.3f} "
                         f"{m['df']:>7.3f} {m['k2_fy_df2']:>11.3f} {str(r['yield_detected_ok']):>8} "
                         f"{r['initializer_mae_pct']['k1']:>8.3f} "
                         f"{r['initializer_mae_pct']['c']:>7.3f} {r['device']}")
        lines.append("(MAE in % of the truth; k2, fy, DF over the springs that truly yield; "
                     "'init': the equation-error start the PINN trained from)")
        lines.append("")
        lines.append("Per spring (first seed of each case): estimate (error %)")
        seen = set()
        for r in ident:
            if r["case"] in seen:
                continue
            seen.add(r["case"])
            lines.append(f"  {r['case']} (seed {r['seed']})")
            lines.append(f"  {'n':>2} {'k1':>20} {'k2':>20} {'fy':>20} {'c':>20} {'DF (true)':>16}")
            for sp in r["springs"]:
                e = sp["error_pct"]
                cells = [f"{sp[k]:.4g} ({e[k]:+.2f})" if (k in ("k1", "c") or sp["yielded"])
                         else f"{sp[k]:.4g} (n/a)" for k in ("k1", "k2", "fy", "c")]
                df = f"{sp['df']:.3f} ({sp['true_df']:.3f})" if sp["yielded"] else \
                    f"<=1 ({sp['true_df']:.3f})"
                lines.append(f"  {sp['spring']:>2} " + " ".join(f"{c:>20}" for c in cells)
                             + f" {df:>16}")
    if ident:
        lines.append("")
        lines.append(summarize_cases(ident))
    return "\n".join(lines)


def _mean(values: list[float | None]) -> float:
    kept = [v for v in values if v is not None]
    return float(np.mean(kept)) if kept else float("nan")


def summarize_cases(results: list[dict[str, Any]]) -> str:
    """Per case, means over its seeds: MAE (%) of k1 and c over the springs that truly
    yield after every stage, of DF, and how many runs got every section's state right."""
    cases: dict[str, list[dict[str, Any]]] = {}
    for r in results:
        cases.setdefault(r["case"], []).append(r)
    lines = [f"{'case (means over seeds)':<44} {'runs':>4} {'states ok':>9} {'DF%':>6} "
             f"{'wall_s':>7}  k1% / c% over the yielding springs, after each stage"]
    for case, runs in cases.items():
        stages = " ".join(
            f"{name} {_mean([r['stages'][name]['k1_yielded'] for r in runs]):.2f}/"
            f"{_mean([r['stages'][name]['c_yielded'] for r in runs]):.1f}"
            for name in runs[0]["stages"])
        final = (f"final {_mean([r['mae_pct']['k1_yielded'] for r in runs]):.2f}/"
                 f"{_mean([r['mae_pct']['c_yielded'] for r in runs]):.1f}")
        ok = sum(bool(r["states_ok"]) for r in runs)
        missed = ""
        if all("base_spring" in r for r in runs):
            missed = (f"  base spring missed (intact, or P(intact) > 0.5) in "
                      f"{sum(r['base_spring']['missed'] for r in runs)}/{len(runs)}, largest "
                      f"P(intact) {max(r['base_spring']['p_intact'] for r in runs):.2f}")
        cov = ""
        if all("coverage" in r for r in runs):
            cov = "  90 % intervals hold the truth: " + ", ".join(
                f"{k} {100 * _mean([float(np.mean(r['coverage'][k])) for r in runs]):.0f} %"
                for k in ("k1", "c", "df"))
        lines.append(f"{case:<44} {len(runs):>4} {f'{ok}/{len(runs)}':>9} "
                     f"{_mean([r['mae_pct']['df'] for r in runs]):>6.2f} "
                     f"{_mean([r['wall_s'] for r in runs]):>7.1f}  {stages} | {final}{cov}{missed}")
    return "\n".join(lines)
