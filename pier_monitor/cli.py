"""Command line of pier_monitor (``pier-monitor``).

Subcommands
-----------
simulate  simulate a pier under a ground motion; write responses (.npz) or a synthetic
          E-Defense-style or field-network bag (rosbag2 directory or .mcap) with its
          ground truth
bench     benchmarks against known truth (prints a table, ``--json`` writes results)
identify  ingest a bag, identify every event with the PINN, write results and figures
          (exit status: 0 every event identified and reliable, 1 an event failed or was
          cut or the bag is damaged, 2 an error and nothing identified, 3 an event's
          result is unreliable and none failed)
fleet     identify every event of many bags on a process pool or a Ray cluster
compare   change between two identification results of the same pier
demo      the main job on the embedded default data
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pier_monitor.bags.synthetic_bag import (SyntheticBagInfo, write_synthetic_bag,
                                              write_synthetic_edefense_bag)
from pier_monitor.bags.synthetic_fleet import FLEET_TRUTH_JSON, write_synthetic_fleet
from pier_monitor.bench import DEFAULT_SUITES, SUITES, format_table
from pier_monitor.core.errors import PierMonitorError, ReportError
from pier_monitor.core.fileio import to_strict_json
from pier_monitor.core.identify.damage import ductility_factors
from pier_monitor.core.ingest.findings import Finding, fmt_span
from pier_monitor.core.model.config import load_config
from pier_monitor.core.model.ground_motion import load_accelerogram, synthetic_near_fault
from pier_monitor.core.model.solver import simulate
from pier_monitor.core.synthetic.measurement import SensorImperfections
from pier_monitor.core.synthetic.rc import HYSTERESIS_FAMILIES
from pier_monitor.core.synthetic.reference import table1_model
from pier_monitor.fleet import FleetOptions, FleetProgress, LocalPool, RayBackend, run_fleet
from pier_monitor.core.identify.methods import DEFAULT_MEMBERS, METHODS, IdentifySettings
from pier_monitor.events import EventOutcome
from pier_monitor.pipeline import BagOutcome, identify_bag
from pier_monitor.training_progress import TrainingProgress
from pier_monitor.report._common import format_df
from pier_monitor.report.compare import write_comparison
from pier_monitor.report.results import load_result
from pier_monitor.report.tables import uncertainty_table

__all__ = ["main", "build_parser", "ingest_summary", "EXIT_OK", "EXIT_FAILED", "EXIT_ERROR",
           "EXIT_UNRELIABLE"]


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive whole number, got {text!r}")
    return value


def _seed(text: str) -> int:
    """A random seed: a whole number from 0 to 2**32 - 1 (what numpy's generators take)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 0 <= value < 2 ** 32:
        raise argparse.ArgumentTypeError(f"expected a seed from 0 to 4294967295, got {text!r}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``pier-monitor``."""
    parser = argparse.ArgumentParser(
        prog="pier-monitor",
        description="Physics-informed damage identification of reinforced-concrete bridge piers.")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    sim = sub.add_parser(
        "simulate", help="simulate a pier; write responses (.npz) or a synthetic bag",
        description="Simulate the nonlinear link model of a pier (Newmark linear acceleration, "
                    "1 ms step). With OUT ending in .npz: write t, ag, x, v, a, theta, moment "
                    "(SI, time-first, relative to the foundation). With OUT ending in .mcap or "
                    "any other name: write a synthetic E-Defense-style bag (two runs of "
                    "increasing damage; .mcap = single file, else a rosbag2 directory) and its "
                    "ground truth beside it. With --layout: a field-network bag (the layout's "
                    "sensors, imperfect sensors, anti-aliasing data loggers; one earthquake).")
    sim.add_argument("--pier", type=Path, help="pier configuration YAML (default: the paper's "
                     "Table 1 pier for .npz, the E-Defense-like pier for bags)")
    sim.add_argument("--ground-motion", type=Path,
                     help="accelerogram file (default: the seeded synthetic near-fault record)")
    sim.add_argument("--dt", type=_positive_float,
                     help="sampling period of a one-column accelerogram file, s")
    sim.add_argument("--units", choices=("g", "gal", "mps2"), default="mps2",
                     help="unit of the accelerogram values (default mps2)")
    sim.add_argument("--column", type=int, default=None,
                     help="acceleration column of an accelerogram file with more than two "
                          "columns, counted from 1 (time in column 1 unless --dt is given)")
    scale = sim.add_mutually_exclusive_group()
    scale.add_argument("--scale", type=_positive_float, help="multiply the record by S")
    scale.add_argument("--pga", type=_positive_float, help="scale the record to this PGA, m/s^2")
    sim.add_argument("--seed", type=_seed, default=None,
                     help="seed of the synthetic record / bag noise")
    sim.add_argument("--output-rate", type=_positive_float, default=100.0,
                     help="output sampling rate of .npz responses, Hz (default 100)")
    sim.add_argument("--out", type=Path, required=True, help="OUT.npz, OUT.mcap or a bag directory")
    sim.add_argument("--fleet", type=int, metavar="N", default=None,
                     help="write N synthetic piers (2-8 sections, sensor layouts, motions, damage "
                          "levels) into the directory OUT: one bag each, its truth beside it and "
                          "fleet_truth.json")
    sim.add_argument("--layout", action="append", choices=("full", "accel", "sparse"),
                     default=None,
                     help="sensor layout: full = the configuration's sensor map, accel = "
                          "accelerometers at every level, sparse = accelerometers at the "
                          "foundation, mid-height and top. One bag: once, for a field-network "
                          "bag (default: the shaking-table bag of the configuration's sensor "
                          "map). --fleet: repeatable, given to the piers in turn (default: full)")
    sim.add_argument("--gnss", action="store_true",
                     help="with --layout: add a GNSS receiver at the top (10 Hz, 5 mm)")
    sim.add_argument("--imperfections", action=argparse.BooleanOptionalAction, default=None,
                     help="record with sensors that differ from the configuration (1 %% gain, "
                          "0.5 deg azimuth, tilt, bias; reported in the truth); default on "
                          "with --layout, off without")
    sim.add_argument("--scenario", choices=("edefense", "strong", "just_yield"), default=None,
                     help="edefense = the two-run shaking-table test of the E-Defense-like pier; "
                          "strong / just_yield = one earthquake that yields the lower sections / "
                          "only just yields the base, for the E-Defense-like or Table 1 pier "
                          "(default: edefense, or strong with --layout)")
    sim.add_argument("--hysteresis", choices=HYSTERESIS_FAMILIES, default="bilinear",
                     help="springs of a synthetic bag's pier: bilinear = the model the "
                          "identifier assumes (per-spring dampers); takeda = the RC test-bed "
                          "(modified-Takeda springs: cracking, stiffness degradation, pinching, "
                          "strength loss); bwbn = the RC test-bed with smooth Bouc-Wen-Baber-"
                          "Noori springs (degradation, pinching). Both: Rayleigh damping, "
                          "scenario amplitudes of their own, "
                          "truth with idealised DF, bar yield and small-amplitude stiffness). "
                          "Default bilinear")
    sim.add_argument("--bag-format", choices=("mcap", "rosbag2", "mixed"), default="mcap",
                     help="bag format of the fleet's piers (mixed: alternating)")
    sim.add_argument("--record-s", type=_positive_float, default=30.0,
                     help="length of each table record of the fleet's piers, s (default 30)")

    bench = sub.add_parser("bench", help="benchmarks against known truth",
                           description="Run benchmarks with fixed seeds; print a table.")
    bench.add_argument("--suite", action="append", default=None,
                       help="suite to run (repeatable): solver, ingest, paper, more, fleet, "
                            "field, coverage, missed_damage, selfcheck, rc (the RC test-bed "
                            "through the default route), rc_sequence_drawn (two shakings "
                            "of drawn RC piers: the stiffness change of the second), latency "
                            "(the live graph: end of shaking to the published state), and "
                            "the others listed in the README (default: solver, ingest and "
                            "paper)")
    bench.add_argument("--all", action="store_true",
                       help="every suite (more: noise 0.1/10 mgal, a long-duration record, El "
                            "Centro, the realistic-noise case; field, coverage, fleet take tens "
                            "of minutes on a 2-core CPU)")
    bench.add_argument("--json", type=Path, help="write the results as JSON to this file")

    ident = sub.add_parser(
        "identify", help="identify every event of a bag",
        description="Read a bag (rosbag2 directory or .mcap with the pier configuration "
                    "inside), detect the mainshock windows, identify k1, k2, fy, c of every "
                    "section with the PINN and write one results directory per event "
                    "(window.npz, result.json, damage_state.mcap, figures; failed.json for "
                    "an event that failed). Exit status: 0 every event identified and "
                    "reliable; 1 an event failed or was cut, or the bag is damaged (the "
                    "other events still have results); 2 an error, nothing identified; 3 an "
                    "event's result is unreliable (failed its self-check) and none failed.")
    ident.add_argument("bag", type=Path, metavar="BAG", help="rosbag2 directory or .mcap file")
    ident.add_argument("--out", type=Path, default=None,
                       help="results root (default results/<bag name>)")
    ident.add_argument("--pier", type=Path, default=None,
                       help="pier configuration YAML to use instead of the bag's (required for "
                            "a bag recorded without one)")
    ident.add_argument("--no-figures", action="store_true",
                       help="no per-event figures (a few seconds less per event)")
    _add_training_options(ident)

    fleet = sub.add_parser(
        "fleet", help="identify every event of many bags, in parallel",
        description="Find the bags (rosbag2 directories and .mcap files) under the paths given, "
                    "ingest each once, identify every event as a task of its own on a local "
                    "process pool (default) or a Ray cluster, and write one results directory "
                    "per event into OUT with the fleet summary (fleet.json, fleet.png, "
                    "fleet_state.mcap). A rerun skips the events that have a result.")
    fleet.add_argument("paths", type=Path, nargs="+", metavar="BAG_OR_DIR",
                       help="bags and directories searched for bags")
    fleet.add_argument("--out", type=Path, required=True, help="results root")
    backend = fleet.add_mutually_exclusive_group()
    backend.add_argument("--workers", type=int, default=None,
                         help="processes of the local pool (default: one per CPU)")
    backend.add_argument("--ray", nargs="?", const="", default=None, metavar="ADDRESS",
                         help="run on Ray: 'auto' (the cluster of this machine), an address "
                              "(host:port, ray://host:10001), or nothing for a local instance")
    fleet.add_argument("--force", action="store_true",
                       help="identify every event again, also those with a result")
    fleet.add_argument("--no-figures", action="store_true",
                       help="no per-event figures (a few seconds less per event)")
    fleet.add_argument("--gpus-per-task", type=_positive_float, default=0.25,
                       help="share of a GPU per event when training on CUDA with Ray "
                            "(default 0.25: four events per GPU)")
    _add_training_options(fleet)

    demo = sub.add_parser("demo", help="the main job on the embedded synthetic bag",
                          description="Write the synthetic E-Defense-style bag (two runs of "
                                      "increasing damage), identify both events, then a field-network bag of the same pier "
                                      "(accelerometers and GNSS only), print the "
                                      "per-section tables and their comparison, and leave the "
                                      "figures in the output directory.")
    demo.add_argument("--out", type=Path, default=Path("results/demo"),
                      help="output directory (default results/demo)")
    demo.add_argument("--seed", type=_seed, default=0, help="seed of the synthetic bag")
    _add_training_options(demo)

    cmp_ = sub.add_parser(
        "compare", help="change between two identifications of the same pier",
        description="Compare two identification results of the same pier (A before, B after): "
                    "k1 change (%%), ductility factor and state per section. Prints a table and "
                    "one line per section; writes compare.json and compare_profile.png (k1 and "
                    "DF along the height of both events).")
    cmp_.add_argument("result_a", type=Path, metavar="RESULT_A",
                      help="result.json of the earlier event, or a results directory holding one")
    cmp_.add_argument("result_b", type=Path, metavar="RESULT_B",
                      help="result.json of the later event, or a results directory holding one")
    cmp_.add_argument("--out", type=Path, default=None,
                      help="output directory (default: the directory of RESULT_B)")
    return parser


def _add_training_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--device", choices=("auto", "cpu", "cuda"), default="auto",
                        help="where to train (auto: a CUDA GPU when there is one)")
    parser.add_argument("--train-seed", type=_seed, default=0, help="seed of the training")
    parser.add_argument("--max-epochs", type=_positive_int, default=None,
                        help="epoch limit of the training (default: the benchmarked setting)")
    parser.add_argument("--members", type=_positive_int, default=None,
                        help="ensemble members identified together, for the 90 %% interval of "
                             "every number (default: the route's own, "
                             + ", ".join(f"{v} {k}" for k, v in DEFAULT_MEMBERS.items())
                             + "; 1: no uncertainty, the fastest)")
    parser.add_argument("--method", choices=METHODS, default="auto",
                        help="pinn: equation-error start and PINN (every level with a "
                             "displacement and an acceleration); equation_error: that start "
                             "alone; field: the reconstruction from the accelerations "
                             "(uncalibrated field sensors); auto: equation_error where every "
                             "level is fully measured, else field")
    parser.add_argument("--no-progress", action="store_true",
                        help="no training progress (a bar on a terminal, else a line every 10 s)")


def _settings(args: argparse.Namespace) -> IdentifySettings:
    """The training settings of the command line's options."""
    settings = IdentifySettings(device=args.device, seed=args.train_seed, method=args.method)
    if args.members is not None:
        settings.members = args.members
    if args.max_epochs is not None:
        pinn = settings.pinn_settings
        pinn.max_epochs = args.max_epochs
        pinn.min_epochs = min(pinn.min_epochs, args.max_epochs)
    return settings


def _identify(bag: Path, out: Path, args: argparse.Namespace,
              pier: Path | None = None, figures: bool = True) -> BagOutcome:
    """Run :func:`pier_monitor.pipeline.identify_bag` with training progress on stderr."""
    settings = _settings(args)
    config = load_config(pier) if pier is not None else None
    if args.no_progress:
        return identify_bag(bag, out, settings=settings, config=config, figures=figures)
    with TrainingProgress() as progress:
        return identify_bag(bag, out, settings=settings, progress=progress, config=config,
                            figures=figures)


#: Exit status of ``identify`` and ``demo``: every event identified and reliable; an event
#: failed (ingest, cut by the data's edge, training) or the bag is damaged; an error before
#: anything was identified; an event's result unreliable (none failed).
EXIT_OK, EXIT_FAILED, EXIT_ERROR, EXIT_UNRELIABLE = 0, 1, 2, 3
#: Lines of ingest findings printed per event (the full list is in result.json).
SUMMARY_LINES = 6


def _exit_status(outcome: BagOutcome) -> int:
    """The exit status of an identified bag (see :data:`EXIT_OK` and the others)."""
    if outcome.with_status("failed", "cut") or outcome.bag_findings:
        return EXIT_FAILED
    return EXIT_UNRELIABLE if outcome.with_status("unreliable") else EXIT_OK


def ingest_summary(findings: Sequence[Finding], limit: int = SUMMARY_LINES) -> list[str]:
    """A few lines on what the ingest repaired or excluded in an event, by sensor and time.

    Findings of one sensor channel with the same code and action are one line (with their
    count and the first time); ``noted`` findings are only counted.
    """
    groups: dict[tuple[str, str, str], list[Finding]] = {}
    for f in findings:
        if f.action != "noted":
            groups.setdefault((f.action, f.where, f.code), []).append(f)
    if not groups:
        return []
    lines = [f"ingest: {len(findings)} findings (all in result.json / failed.json)"]
    for (action, where, code), group in list(groups.items())[:limit]:
        first = group[0]
        times = fmt_span(first.start_ns, first.end_ns)
        more = f" (x{len(group)}, first {times})" if len(group) > 1 else f" ({times})"
        lines.append(f"  {action:<9} {where}: {code}{more}")
    if len(groups) > limit:
        lines.append(f"  ... and {len(groups) - limit} more")
    return lines


def _print_event(ev: EventOutcome) -> None:
    """One event: its table of sections, or why it has none; its ingest summary."""
    r = ev.result
    if ev.status in ("failed", "cut"):
        print(f"\nevent {r.event_id}: {ev.status.upper()}: {r.message}")
    else:
        w = ev.window
        part = " (PARTIAL: the data end during the shaking)" if r.partial else ""
        how = (f"trained {r.epochs} epochs" if r.epochs else "identified") + (
            f", {r.family['family']} springs" if r.family else "")
        print(f"\nevent {r.event_id}{part}: window {w.duration_s:.1f} s, {how} "
              f"in {r.wall_time_s:.1f} s on {r.device}; overall state {r.overall_state.upper()}")
        if r.model_misfit and r.model_misfit.get("fires"):
            print("model misfit: " + "; ".join((*r.model_misfit.get("reasons", ()),
                                                 *r.model_misfit.get("reproduction_misfits",
                                                                     ()))))
        print(f"{'section':>8} {'z (m)':>11} {'k1 (N·m/rad)':>13} {'k2 (N·m/rad)':>13} "
              f"{'fy (N·m)':>10} {'c (N·m·s/rad)':>14} {'DF':>7} {'state':>10} "
              f"{'k1 change':>10} {'vs design':>10}")
        for sec in r.sections:
            k2 = f"{sec.k2:.4g}" if sec.k2_identifiable else "n/a"
            fy = f"{sec.fy:.4g}" if sec.fy_identifiable else f">={sec.fy:.3g}"
            # a change only against an earlier event; the first event's "-"
            ch = "-" if sec.k1_change_pct is None else f"{sec.k1_change_pct:+.1f} %"
            design = "" if sec.k1_vs_design_pct is None else f"{sec.k1_vs_design_pct:+.1f} %"
            print(f"{sec.index + 1:>8} {sec.z_bottom_m:>5.1f}-{sec.z_top_m:<5.1f} {sec.k1:>13.4g} "
                  f"{k2:>13} {fy:>10} {sec.c:>14.4g} {format_df(sec.ductility_factor, not sec.ductility_factor_upper_bound):>7} "
                  f"{sec.state:>10} {ch:>10} {design:>10}")
        print(f"k1 change: against {r.k1_baseline or 'nothing (no earlier event)'}; vs design: "
              "difference from the design values, not a change")
        if any(not sec.yielded for sec in r.sections):
            print("DF ≤: the spring did not yield; its DF is only an upper bound")
        if any(sec.ductility_reference for sec in r.sections):
            own = ", ".join("-" if sec.event_ductility_factor is None
                            else f"{sec.event_ductility_factor:.2f}" for sec in r.sections)
            print("DF: cumulative (the largest rotation so far over the virgin section's yield "
                  f"rotation, {r.k1_baseline}); this event's own fit alone: {own}")
        for reason in r.unreliable_reasons:
            print(f"unreliable: {reason}")
        table = uncertainty_table(r)
        if table:
            print(table)
    if r.partial:
        print(f"partial: {r.partial}")
    findings = ev.ingest.findings if ev.ingest is not None else r.findings
    for line in ingest_summary(findings):
        print(line)
    print(f"results: {ev.out_dir}")


def _print_outcome(outcome: BagOutcome) -> None:
    """Per-event tables of the identified sections (and their uncertainty, for an ensemble),
    the failed events with their reasons, and the warnings on the bag itself."""
    for f in outcome.bag_findings:
        print(f"pier-monitor: warning: {f.where}: {f.message}", file=sys.stderr)
    if not outcome.events:
        print(f"{outcome.bag}: no mainshock found; nothing to identify")
    for ev in outcome.events:
        _print_event(ev)
    if outcome.events:
        counts = {k: len(outcome.with_status(k))
                  for k in ("identified", "unreliable", "failed", "cut")}
        print(f"\n{len(outcome.events)} events: "
              + ", ".join(f"{n} {k}" for k, n in counts.items() if n))


def _cmd_identify(args: argparse.Namespace) -> int:
    # the bag's own name, also when it is given as BAG/sub/.. or ./
    default = Path("results") / args.bag.resolve().name.removesuffix(".mcap")
    out = args.out if args.out is not None else default
    _check_out(out)
    outcome = _identify(args.bag, out, args, pier=args.pier, figures=not args.no_figures)
    _print_outcome(outcome)
    return _exit_status(outcome)


def _check_out(path: Path) -> None:
    """Refuse an output path below an existing file, naming it (before any work is done)."""
    if not str(path).strip():
        raise ReportError("--out: empty path")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ReportError(f"--out {path}: {parent} is a file, not a directory")
            return


def _cmd_fleet(args: argparse.Namespace) -> int:
    options = FleetOptions(settings=_settings(args), figures=not args.no_figures,
                           force=args.force, gpus_per_task=args.gpus_per_task)
    if args.ray is not None:
        backend: LocalPool | RayBackend = RayBackend(args.ray or None)
    else:
        backend = LocalPool(args.workers)
    progress = None if args.no_progress else FleetProgress()
    try:
        run = run_fleet(args.paths, args.out, backend, options, progress)
    finally:
        if progress is not None:
            progress.close()
        backend.close()
    print(run.summary.table())
    first = "-" if run.first_result_s is None else f"{run.first_result_s:.0f} s"
    print(f"\n{len(run.bags)} bags on {run.backend} ({run.workers} workers): {run.identified} "
          f"events identified, {run.failed} failed, {run.skipped} skipped (done before), "
          f"{run.retried} retried; {run.wall_s:.0f} s, first result after {first}")
    for bag, error in run.failed_bags:
        print(f"not ingested: {bag}: {error}")
    print(f"wrote {run.paths.fleet_json}, {run.paths.fleet_png}"
          + (f", {run.paths.fleet_state_mcap}" if run.paths.fleet_state_mcap else ""))
    return 0 if not run.failed and not run.failed_bags else 1


def _cmd_simulate(args: argparse.Namespace) -> int:
    out: Path = args.out
    _check_out(out)
    if args.fleet is not None:
        return _simulate_fleet(args)
    if out.suffix == ".npz":
        return _simulate_npz(args)
    return _simulate_bag(args)


def _simulate_npz(args: argparse.Namespace) -> int:
    if args.layout is not None or args.gnss or args.scenario is not None \
            or args.imperfections is not None or args.hysteresis != "bilinear":
        raise PierMonitorError("--layout/--gnss/--scenario/--imperfections/--hysteresis apply "
                               f"to bags; {args.out} is .npz responses")
    if args.pier is not None:
        cfg = load_config(args.pier)
        geometry, params, name = cfg.geometry, cfg.design, cfg.pier_id
    else:
        (geometry, params), name = table1_model(), "table1"
    if args.ground_motion is not None:
        gm = load_accelerogram(args.ground_motion, units=args.units, dt=args.dt,
                               column=args.column)
    else:
        gm = synthetic_near_fault(seed=8 if args.seed is None else args.seed)
    if args.scale is not None:
        gm = gm.scaled(args.scale)
    elif args.pga is not None:
        gm = gm.scaled_to_pga(args.pga)
    output_dt = 1.0 / args.output_rate
    resp = simulate(geometry, params, gm.acc, gm.dt, output_dt=output_dt)
    df = ductility_factors(resp.theta, params)
    try:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ReportError(f"--out {args.out}: cannot create {args.out.parent}: "
                          f"{err.strerror}") from err
    np.savez_compressed(
        args.out, **resp.as_dict(), section_heights_m=geometry.section_heights_m,
        masses_kg=geometry.masses_kg, k1=params.k1, k2=params.k2, fy=params.fy, c=params.c,
        ductility_factors=df)
    print(f"pier {name}: {geometry.n_levels} levels; ground motion {gm.name}, "
          f"PGA {gm.pga:.3g} m/s^2, {gm.duration_s:.1f} s")
    print("spring  max|theta| (rad)  DF")
    for n in range(geometry.n_levels):
        print(f"{n + 1:>6}  {np.abs(resp.theta[:, n]).max():>16.5f}  {df[n]:.3f}")
    print(f"wrote {args.out}")
    return 0


def _simulate_bag(args: argparse.Namespace) -> int:
    if (args.ground_motion is not None or args.scale is not None or args.pga is not None
            or args.column is not None):
        raise PierMonitorError(
            "--ground-motion/--column/--scale/--pga apply to .npz output; the synthetic bag uses "
            "its own seeded runs (choose them with --seed)")
    if args.layout is not None and len(args.layout) > 1:
        raise PierMonitorError(f"one --layout for a bag, got {args.layout} (several are for "
                               "--fleet)")
    layout = args.layout[0] if args.layout else None
    if args.gnss and layout is None:
        raise PierMonitorError("--gnss adds a GNSS receiver to a field layout; give --layout "
                               "full, accel or sparse")
    field = layout is not None
    imperfect = field if args.imperfections is None else args.imperfections
    scenario = args.scenario or ("strong" if field else "edefense")
    fmt = "mcap" if args.out.suffix == ".mcap" else "rosbag2"
    info = write_synthetic_bag(args.out, fmt=fmt, seed=0 if args.seed is None else args.seed,
                               config_path=args.pier, scenario=scenario, layout=layout,
                               gnss=args.gnss,
                               imperfections=SensorImperfections() if imperfect else None,
                               hysteresis=args.hysteresis)
    print(_bag_summary(info))
    return 0


def _simulate_fleet(args: argparse.Namespace) -> int:
    if args.gnss or args.scenario is not None or args.imperfections is not None \
            or args.hysteresis != "bilinear":
        raise PierMonitorError("--gnss/--scenario/--imperfections/--hysteresis apply to one bag; "
                               "the fleet's piers have scenarios and ideal sensors of their own")
    written = write_synthetic_fleet(args.out, args.fleet, seed=0 if args.seed is None else
                                    args.seed, layouts=tuple(args.layout or ("full",)),
                                    fmt=args.bag_format, record_s=args.record_s)
    print(f"wrote {len(written)} piers into {args.out} (truth: {args.out / FLEET_TRUTH_JSON})")
    print(f"{'pier':<10} {'format':<8} {'layout':<7} {'sections':>8} {'damage':<9} "
          "runs: PGA m/s2 -> true ductility factors (bottom to top)")
    for w in written:
        s = w.summary()
        runs = "; ".join(f"{r['pga_mps2']:.2f} -> {', '.join(f'{d:.2f}' for d in r['ductility_factors'])}"
                         for r in s["runs"])
        print(f"{s['pier_id']:<10} {s['format']:<8} {s['layout']:<7} {s['sections']:>8} "
              f"{s['damage']:<9} {runs}")
    return 0


def _bag_summary(info: SyntheticBagInfo) -> str:
    """Readable overview of a written synthetic bag."""
    s = info.summary()
    w = max(6, *(len(r["name"]) for r in s["runs"]))  # width of the run names
    lines = [f"wrote {s['format']} bag {s['bag']}: {s['messages']} messages, "
             f"{s['size_bytes'] / 1e6:.1f} MB, {s['duration_s']:.1f} s of data "
             f"(simulated and written in {s['elapsed_s']:.1f} s)",
             f"pier configuration {s['config']} (embedded in the bag), seed {s['seed']}",
             f"sensors: {s['sensors']}, layout "
             + (f"{s['layout']}{' + GNSS top' if s['gnss'] else ''} (field network)"
                if s["layout"] else "of the configuration (shaking table)")
             + f"; imperfect sensors: {'yes' if s['imperfect_sensors'] else 'no'}, "
               f"anti-aliasing: {'yes' if s['anti_alias'] else 'no'}",
             f"ground truth: {s['truth_json']}, {s['truth_npz']}",
             f"{'run':<{w}} {'start s':>8} {'mainshock window s':>20} {'PGA m/s2':>9} "
             f"{'T1 s':>6}  true ductility factors (sections bottom to top)"]
    for r in s["runs"]:
        win = f"{r['window_s'][0]:.2f}-{r['window_s'][1]:.2f}"
        lines.append(f"{r['name']:<{w}} {r['start_s']:>8.2f} {win:>20} {r['pga_mps2']:>9.2f} "
                     f"{r['first_period_s']:>6.3f}  {', '.join(f'{d:.2f}' for d in r['ductility_factors'])}")
    if any("rc" in r for r in s["runs"]):
        lines.append(f"RC springs ({s['hysteresis']}): DF on the idealised yield rotation, "
                     "bars yielded, small-amplitude stiffness before -> after (GN*m/rad)")
        for r in s["runs"]:
            rc = r["rc"]
            cells = [f"{df:.2f}{' Y' if y else '  '} {kb / 1e9:.2f}->{ka / 1e9:.2f}"
                     for df, y, kb, ka in zip(rc["ductility_factor"], rc["yielded"],
                                              rc["k_small_before"], rc["k_small_after"])]
            lines.append(f"{r['name']:<{w}} " + " | ".join(cells))
    return "\n".join(lines)


def _cmd_bench(args: argparse.Namespace) -> int:
    names = list(SUITES) if args.all else (args.suite or list(DEFAULT_SUITES))
    unknown = [n for n in names if n not in SUITES]
    if unknown:
        raise PierMonitorError(f"unknown benchmark suite {unknown[0]!r}; "
                               f"choose from {sorted(SUITES)}")
    results = []
    for name in names:
        results.extend(SUITES[name]())
    print(format_table(results))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(to_strict_json(results, indent=2) + "\n")
        print(f"wrote {args.json}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    _check_out(args.out / "identified")
    _check_out(args.out / "identified_field")
    args.out.mkdir(parents=True, exist_ok=True)
    bag = args.out / "edefense_synthetic"
    field_bag = args.out / "edefense_field.mcap"
    # the demo's own output of an earlier run
    if bag.exists():
        shutil.rmtree(bag)
    for stale in (bag.with_suffix(".truth.npz"), bag.with_suffix(".truth.json"), field_bag,
                  field_bag.with_suffix(".truth.npz"), field_bag.with_suffix(".truth.json")):
        stale.unlink(missing_ok=True)
    info = write_synthetic_edefense_bag(bag, fmt="rosbag2", seed=args.seed)
    print(_bag_summary(info))
    outcome = _identify(bag, args.out / "identified", args)
    _print_outcome(outcome)
    compared = [ev for ev in outcome.events if ev.result.success]
    if len(compared) >= 2:
        first, last = compared[0], compared[-1]
        comparison, paths = write_comparison(first.result, last.result, args.out,
                                             sources=(str(first.out_dir), str(last.out_dir)))
        print("\ncomparison of the first and the last event")
        print(comparison.table())
        print("\n".join(comparison.summary_lines()))
        print(f"figures: {paths.profile_png} and in each event directory")
    # the same pier as a field network sees it: accelerometers at every level and a GNSS
    # receiver at the top, imperfect sensors, no wire
    print("\nthe pier in the field: accelerometers and a GNSS receiver only")
    field = write_synthetic_bag(field_bag, fmt="mcap", seed=args.seed, layout="accel",
                                gnss=True, scenario="strong",
                                imperfections=SensorImperfections())
    print(_bag_summary(field))
    field_outcome = _identify(field_bag, args.out / "identified_field", args)
    _print_outcome(field_outcome)
    true_df = ", ".join(f"{d:.2f}" for d in field.truth.runs[0].ductility_factors)
    print(f"true DF of the field event (from the simulation): {true_df}")
    codes = {_exit_status(outcome), _exit_status(field_outcome)}
    return next((c for c in (EXIT_ERROR, EXIT_FAILED, EXIT_UNRELIABLE) if c in codes), EXIT_OK)


def _cmd_compare(args: argparse.Namespace) -> int:
    a, b = load_result(args.result_a), load_result(args.result_b)
    out = args.out
    if out is None:
        out = args.result_b if args.result_b.is_dir() else args.result_b.parent
    comparison, paths = write_comparison(a, b, out, sources=(str(args.result_a),
                                                             str(args.result_b)))
    print(comparison.table())
    print()
    print("\n".join(comparison.summary_lines()))
    print(f"wrote {paths.compare_json}, {paths.profile_png}")
    return 0


_COMMANDS = {"simulate": _cmd_simulate, "bench": _cmd_bench, "demo": _cmd_demo,
             "compare": _cmd_compare, "identify": _cmd_identify, "fleet": _cmd_fleet}


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    try:
        return _COMMANDS[args.command](args)
    except PierMonitorError as err:
        print(f"pier-monitor {args.command}: error: {err}", file=sys.stderr)
        return EXIT_ERROR


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
