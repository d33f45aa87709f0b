"""Identifier node: mainshock windows → PINN → damage state and diagnostics (SPEC §4, §5, §7).

Topics (relative; run the node in the pier's namespace):

* in ``mainshock_window`` (``MainshockWindow``, reliable, transient local);
* out ``identification_progress`` (``IdentificationProgress``) every ``progress_every``
  epochs while training;
* out ``damage_state`` (``PierDamageState``, reliable, transient local depth 1: latched);
* out ``/diagnostics`` (``DiagnosticArray``): one status per section, OK / WARN / ERROR for
  intact / suspicious / damaged (STALE when the identification failed), republished every
  ``diagnostics_period_s``.

Every window is on disk before training starts: ``window_dir/<event_id>.npz`` (written by
the ingest node, or by this node from the message when missing).  At start the node queues
every window there without a result in ``results_dir/<event_id>/`` — so a crash or a kill
mid-training loses no event.  Training runs on a worker thread, never on the executor; a
failure (NaN loss, out of memory, no GPU) is published as a damage state with
``success = false`` and the node keeps running.  Results (``result.json``,
``damage_state.mcap``, optionally the figures) go to ``results_dir/<event_id>/``; from the
second event of a pier on, ``k1`` changes are relative to its first event, as in
:func:`pier_monitor.pipeline.identify_bag`.
"""

from __future__ import annotations

import json
import queue
import sys
import threading
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from pier_monitor_msgs.msg import IdentificationProgress, MainshockWindow, PierDamageState
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.ingest.window import MeasuredWindow, load_window, save_window

from ._params import declare
from .conversions import (MessageError, damage_state_msg, failed_state_fields, progress_msg,
                          section_diagnostics, window_from_msg)
from .ingest_node import WINDOW_QOS, run_node

__all__ = ["IdentifierNode", "main", "DAMAGE_STATE_QOS", "DEVICES"]

#: Latched: a late subscriber gets the latest diagnosis.
DAMAGE_STATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                              reliability=ReliabilityPolicy.RELIABLE,
                              durability=DurabilityPolicy.TRANSIENT_LOCAL)
DEVICES = ("auto", "cpu", "cuda")
_STOP = object()
_FAILED_JSON = "failed.json"


class _Abort(Exception):
    """Raised from the progress callback to end a training at shutdown."""


class IdentifierNode(Node):
    """Queues windows and identifies them one by one on a worker thread."""

    def __init__(self, name: str = "identifier", **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        from pier_monitor.pinn import PinnSettings

        d = PinnSettings()  # defaults: the benchmarked settings, as offline
        self._window_dir = Path(declare(
            self, "window_dir", "pier_monitor_data/windows", "Directory of the raw windows "
            "(shared with the ingest node); scanned at start for unprocessed windows",
            read_only=True))
        self._results_dir = Path(declare(
            self, "results_dir", "pier_monitor_data/results", "Results root: one directory "
            "per event with result.json and damage_state.mcap", read_only=True))
        declare(self, "device", d.device, "Training device; auto = CUDA when present, else the "
                "CPU (with a warning)", choices=DEVICES)
        declare(self, "seed", d.seed, "Seed of the network initialisation and sampling",
                lo=0, hi=2 ** 31 - 1)
        declare(self, "max_epochs", d.max_epochs, "Upper limit of training epochs",
                lo=1, hi=1_000_000)
        declare(self, "min_epochs", d.min_epochs, "Epochs before early stopping may end training",
                lo=0, hi=1_000_000)
        declare(self, "patience", d.patience, "Early stopping: epochs without a parameter move",
                unit="epochs", lo=1, hi=1_000_000)
        declare(self, "pair_stride", d.pair_stride, "Training pairs every pair_stride samples",
                unit="samples", lo=1, hi=1000)
        declare(self, "hidden", d.hidden, "Units per hidden layer", lo=1, hi=4096)
        declare(self, "layers", d.layers, "Hidden layers", lo=1, hi=64)
        declare(self, "lr_network", d.lr_network, "Adam learning rate of the network",
                lo=1e-9, hi=1.0)
        declare(self, "lr_params", d.lr_params, "Adam learning rate of the log-parameters",
                lo=1e-9, hi=1.0)
        declare(self, "progress_every", 10, "Publish progress every this many epochs",
                unit="epochs", lo=1, hi=100_000)
        declare(self, "write_figures", True, "Also write the report figures (a few seconds "
                "per event)")
        declare(self, "diagnostics_period_s", 1.0, "Period of /diagnostics republication",
                unit="s", lo=0.1, hi=60.0)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # The first check ran before the callback existed: apply it to the declared values.
        result = self._on_set_parameters([self.get_parameter(n) for n in ("device",)])
        if not result.successful:
            raise ValueError(result.reason)

        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._seen: set[str] = set()
        self._diagnostics: DiagnosticArray | None = None
        self.busy_event = ""
        self._closing = False
        self._progress_pub = self.create_publisher(IdentificationProgress,
                                                   "identification_progress", 10)
        self._state_pub = self.create_publisher(PierDamageState, "damage_state",
                                                DAMAGE_STATE_QOS)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._diag_timer = self.create_timer(self.get_parameter("diagnostics_period_s").value,
                                             self._publish_diagnostics)
        self._window_sub = self.create_subscription(
            MainshockWindow, "mainshock_window", self._on_window, WINDOW_QOS)
        self._warn_device()
        for path in self._unprocessed_windows():
            self._seen.add(path.stem)
            self._queue.put(("file", path))
            self.get_logger().info(f"{path}: window without results, queued")
        self._worker = threading.Thread(target=self._work, name="identifier_worker",
                                        daemon=True)
        self._worker.start()

    # -- parameters -------------------------------------------------------------------------
    def _on_set_parameters(self, params: list[Any]) -> SetParametersResult:
        values = {p.name: p.value for p in params}
        if "device" in values and values["device"] not in DEVICES:
            return SetParametersResult(successful=False, reason=(
                f"device: {values['device']!r} is not one of {', '.join(DEVICES)}"))
        if {"min_epochs", "max_epochs"} & set(values):
            lo = values.get("min_epochs", self._param("min_epochs"))
            hi = values.get("max_epochs", self._param("max_epochs"))
            if lo is not None and hi is not None and lo > hi:
                return SetParametersResult(successful=False, reason=(
                    f"min_epochs ({lo}) must not exceed max_epochs ({hi})"))
        if "diagnostics_period_s" in values and hasattr(self, "_diag_timer"):
            self._diag_timer.timer_period_ns = int(values["diagnostics_period_s"] * 1e9)
        return SetParametersResult(successful=True)

    def _param(self, name: str) -> Any:
        return self.get_parameter(name).value if self.has_parameter(name) else None

    def settings(self) -> Any:
        """The PinnSettings of the current parameters."""
        from pier_monitor.pinn import PinnSettings

        return PinnSettings(**{n: self._param(n) for n in (
            "device", "seed", "max_epochs", "min_epochs", "patience", "pair_stride", "hidden",
            "layers", "lr_network", "lr_params")})

    def _warn_device(self) -> None:
        import torch

        if self._param("device") == "auto" and not torch.cuda.is_available():
            self.get_logger().warning("device auto: no CUDA GPU found, training on the CPU")

    # -- windows ----------------------------------------------------------------------------
    def _done(self, event_id: str) -> bool:
        d = self._results_dir / event_id
        return (d / "result.json").is_file() or (d / _FAILED_JSON).is_file()

    def _unprocessed_windows(self) -> list[Path]:
        if not self._window_dir.is_dir():
            return []
        found = []
        for path in self._window_dir.glob("*.npz"):
            if self._done(path.stem):
                continue
            try:
                found.append((load_window(path).start_time_ns, path))
            except Exception as err:
                self.get_logger().error(f"{path}: unreadable window, skipped: {err}")
        return [p for _, p in sorted(found)]

    def _on_window(self, msg: MainshockWindow) -> None:
        if msg.event_id in self._seen:
            return  # already queued (e.g. found on disk at start, or re-delivered latched)
        self._seen.add(msg.event_id)
        self._queue.put(("msg", msg))

    # -- worker -----------------------------------------------------------------------------
    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            try:
                window = self._window_of(item)
                if window is not None and not self._done(window.event_id):
                    self._identify(window)
            except Exception as err:
                self.get_logger().error(f"identifier worker: {type(err).__name__}: {err}")

    def _window_of(self, item: tuple[str, Any]) -> MeasuredWindow | None:
        kind, obj = item
        if kind == "file":
            return load_window(obj)
        path = self._window_dir / f"{obj.event_id}.npz"
        if path.is_file():  # the ingest wrote it: the exact window
            return load_window(path)
        try:
            window = window_from_msg(obj, self.resolve_topic_name("mainshock_window"))
        except MessageError as err:
            self.get_logger().error(f"dropped a window: {err}")
            return None
        self._window_dir.mkdir(parents=True, exist_ok=True)
        save_window(window, path)  # on disk before training starts
        return window

    def _baseline(self, window: MeasuredWindow) -> IdentificationResult | None:
        """The earliest earlier result of the same pier (as identify_bag uses)."""
        best = None
        if not self._results_dir.is_dir():
            return None
        for path in self._results_dir.glob("*/result.json"):
            try:
                r = IdentificationResult.load_json(path)
            except Exception:
                continue
            if r.pier_id == window.pier_id and r.success \
                    and r.window_start_ns < window.start_time_ns \
                    and (best is None or r.window_start_ns < best.window_start_ns):
                best = r
        return best

    def _identify(self, window: MeasuredWindow) -> None:
        from pier_monitor.pinn import identify

        settings = self.settings()
        every = self._param("progress_every")
        out = self._results_dir / window.event_id
        self.busy_event = window.event_id
        self.get_logger().info(f"training on {window.event_id} ({window.duration_s:.2f} s, "
                               f"max {settings.max_epochs} epochs, device {settings.device})")

        def progress(p: Any) -> None:
            if self._closing:
                raise _Abort()
            if p.epoch % every == 0 or p.epoch == 1 or p.epoch == p.max_epochs:
                self._progress_pub.publish(progress_msg(window.event_id, p, self._now_ns()))

        try:
            baseline = self._baseline(window)
            run = identify(window, settings, callback=progress,
                           baseline_k1=None if baseline is None else baseline.params.k1)
            result = self._write(run, window, out, baseline)
        except _Abort:
            self.get_logger().info(f"{window.event_id}: training stopped at shutdown; the "
                                   "window stays on disk for the next start")
            return
        except Exception as err:  # divergence, OOM, no GPU: an error state, keep running
            message = f"identification failed: {type(err).__name__}: {err}"
            self.get_logger().error(f"{window.event_id}: {message}")
            out.mkdir(parents=True, exist_ok=True)
            (out / _FAILED_JSON).write_text(json.dumps({"event_id": window.event_id,
                                                        "error": message}) + "\n")
            fields = failed_state_fields(window, message, settings.device, self._now_ns())
        else:
            from pier_monitor.report.results import damage_state_fields

            fields = damage_state_fields(result, stamp_ns=self._now_ns())
            self.get_logger().info(f"{window.event_id}: {result.overall_state}, DF "
                                   f"{[round(s.ductility_factor, 2) for s in result.sections]}")
        finally:
            self.busy_event = ""
        self._state_pub.publish(damage_state_msg(fields))
        self._diagnostics = section_diagnostics(fields, self._now_ns())
        self._diagnostics.status.append(self._identifier_status(fields))
        self._diag_pub.publish(self._diagnostics)

    def _write(self, run: Any, window: MeasuredWindow, out: Path,
               baseline: IdentificationResult | None) -> IdentificationResult:
        from pier_monitor.report.results import write_results

        if self._param("write_figures"):
            paths = write_results(run, window, out, baseline=baseline)
            return IdentificationResult.load_json(paths.result_json)
        from pier_monitor.report._common import atomic_write_text, ensure_dir
        from pier_monitor.report.results import (DAMAGE_STATE_MCAP, RESULT_JSON,
                                                 prepare_result, write_damage_state_mcap)

        ensure_dir(out)
        result = prepare_result(run, window, baseline=baseline)
        write_damage_state_mcap(result, out / DAMAGE_STATE_MCAP)
        atomic_write_text(out / RESULT_JSON,  # last: its presence marks the event done
                          json.dumps(result.to_dict(), indent=2, allow_nan=True) + "\n")
        return IdentificationResult.load_json(out / RESULT_JSON)

    def _identifier_status(self, fields: dict[str, Any]) -> DiagnosticStatus:
        st = DiagnosticStatus()
        st.name = f"pier_monitor/{fields['pier_id']}/identifier"
        st.hardware_id = fields["pier_id"]
        st.level = DiagnosticStatus.OK if fields["success"] else DiagnosticStatus.ERROR
        st.message = fields["message"][:500] or "ok"
        st.values = [KeyValue(key="event_id", value=fields["event_id"]),
                     KeyValue(key="epochs", value=str(fields["epochs"])),
                     KeyValue(key="device", value=fields["device"])]
        return st

    def _now_ns(self) -> int:
        return self.get_clock().now().nanoseconds

    def _publish_diagnostics(self) -> None:
        if self._diagnostics is not None:
            self._diagnostics.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(self._diagnostics)

    def destroy_node(self) -> None:
        """Stop the worker (ending a training at its next epoch), then the node."""
        self._closing = True  # a training stops at its next epoch; the window stays on disk
        self._queue.put(_STOP)
        self._worker.join(timeout=30.0)
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point: ``python -m pier_monitor.nodes.identifier_node --ros-args ...``."""
    return run_node(IdentifierNode, args if args is not None else sys.argv)


if __name__ == "__main__":
    sys.exit(main())
