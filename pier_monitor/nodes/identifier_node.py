"""Identifier node: mainshock windows → identification → damage state and diagnostics (SPEC §4, §5, §7).

Topics (relative; run the node in the pier's namespace):

* in ``mainshock_window`` (``MainshockWindow``, reliable, transient local);
* out ``identification_progress`` (``IdentificationProgress``) every ``progress_every``
  epochs while training;
* out ``damage_state`` (``PierDamageState``, reliable, transient local depth 1: latched);
* out ``damage_markers`` (``visualization_msgs/MarkerArray``, latched): the pier for RViz and
  Foxglove, a cylinder per section coloured by state, labelled with DF and the k1 change
  (:mod:`pier_monitor.report.markers`), in frame ``<pier_id>``;
* out ``/tf_static`` (``tf2_msgs/TFMessage``, reliable, transient local depth 1, as
  ``tf2_ros.StaticTransformBroadcaster`` offers it): the identity transform
  ``parent_frame`` (``map``) → ``<pier_id>`` of every pier the node published markers of,
  so that the markers' frame resolves.  Where ``tf2_msgs`` is not installed (the PyPI
  wheels of the project's environment have none) the node logs once that no transform is
  published: the markers are in frame ``<pier_id>``, which a display resolves when it is
  its fixed frame (the results mcap carries the transform in any case);
* out ``/diagnostics`` (``DiagnosticArray``): one status per section, OK / WARN / ERROR for
  intact / suspicious / damaged (WARN with the reasons when the result is unreliable, STALE
  when the identification failed), and the identifier's, republished every
  ``diagnostics_period_s``.

Each window goes through :func:`pier_monitor.events.identify_window`, the step
``pier-monitor identify`` runs for a bag: stored in ``results_dir/<event_id>/`` before
training starts, the baseline from the results store, results (or a failure record) written
there.  At start the node queues every window not done yet, of ``results_dir`` and of
``window_dir`` (where the ingest node writes them), so a crash or a kill mid-training loses
no event.  Training runs on a worker thread, never on the executor; a failure (NaN loss, out
of memory, no GPU) is published as a damage state with ``success = false`` and the node
keeps running.  A result that fails its self-check is published with every state
``STATE_UNRELIABLE`` and the reasons.  A window message whose pier or event id is not a safe
name (it would become a directory) is refused with a logged error naming the field.

With ``ray_address`` set, each training runs as a Ray task on that cluster
(:func:`pier_monitor.fleet.offload.identify_offloaded`, the task of ``pier-monitor fleet``),
so that the graphs of many piers on one machine are not bound by its CPUs; progress is then not
published per epoch.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from visualization_msgs.msg import MarkerArray
from pier_monitor_msgs.msg import IdentificationProgress, MainshockWindow, PierDamageState
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from pier_monitor.core.ingest.window import MeasuredWindow
from pier_monitor.events import TrainingStopped, identify_window
from pier_monitor.fleet import RayBackend, identify_offloaded
from pier_monitor.core.identify.methods import METHODS, IdentifySettings, Progress, prepare_method
from pier_monitor.report.markers import DEFAULT_PARENT_FRAME, TF_STATIC_TOPIC
from pier_monitor.report.results import damage_state_fields, k1_vs_design
from pier_monitor.store import ResultsStore

from ._params import declare
from ._runtime import QueueWorker, run_node
from .conversions import (TFMessage, damage_diagnostics, damage_markers_msg, damage_state_msg,
                          pier_transforms_msg, progress_msg, window_from_msg)
from .qos import DAMAGE_STATE_QOS, TF_STATIC_QOS, WINDOW_QOS

__all__ = ["IdentifierNode", "main", "DEVICES"]

DEVICES = ("auto", "cpu", "cuda")
#: Parameters that are IdentifySettings fields of the same name, flat
#: (:meth:`IdentifySettings.from_flat`: the PINN's are PinnSettings fields).
_SETTINGS = ("device", "seed", "max_epochs", "min_epochs", "patience", "pair_stride", "hidden",
             "layers", "lr_network", "lr_params", "members", "method")


class IdentifierNode(Node):
    """Queues windows and identifies them one by one on a worker thread."""

    def __init__(self, name: str = "identifier", **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        d = IdentifySettings()  # defaults: the benchmarked settings, as offline
        dp = d.pinn_settings
        self._window_dir = Path(declare(
            self, "window_dir", "pier_monitor_data/windows", "Directory where the ingest node "
            "writes windows; scanned at start for windows without results", read_only=True))
        self._store = ResultsStore(declare(
            self, "results_dir", "pier_monitor_data/results", "Results root: one directory "
            "per event with window.npz, result.json and damage_state.mcap", read_only=True))
        declare(self, "device", d.device, "Training device; auto = CUDA when present, else the "
                "CPU (with a warning)", choices=DEVICES)
        declare(self, "seed", d.seed, "Seed of the network initialisation and sampling",
                lo=0, hi=2 ** 31 - 1)
        declare(self, "max_epochs", dp.max_epochs, "Upper limit of training epochs",
                lo=1, hi=1_000_000)
        declare(self, "min_epochs", dp.min_epochs, "Epochs before early stopping may end "
                "training", lo=0, hi=1_000_000)
        declare(self, "patience", dp.patience, "Early stopping: epochs without a parameter move",
                unit="epochs", lo=1, hi=1_000_000)
        declare(self, "pair_stride", dp.pair_stride, "Training pairs every pair_stride samples",
                unit="samples", lo=1, hi=1000)
        declare(self, "hidden", dp.hidden, "Units per hidden layer", lo=1, hi=4096)
        declare(self, "layers", dp.layers, "Hidden layers", lo=1, hi=64)
        declare(self, "lr_network", dp.lr_network, "Adam learning rate of the network",
                lo=1e-9, hi=1.0)
        declare(self, "lr_params", dp.lr_params, "Adam learning rate of the log-parameters",
                lo=1e-9, hi=1.0)
        declare(self, "members", d.members, "Ensemble members identified together (the 90 % "
                "interval of every number; 0: the route's default; 1: none, the fastest)",
                lo=0, hi=1024)
        declare(self, "method", d.method, "pinn: equation-error start and PINN (every level "
                "with a displacement and an acceleration); field: the reconstruction from the "
                "accelerations; auto: pinn where every level is fully measured, else field",
                choices=METHODS)
        declare(self, "progress_every", 10, "Publish progress every this many epochs",
                unit="epochs", lo=1, hi=100_000)
        declare(self, "write_figures", True, "Also write the report figures (a few seconds "
                "per event)")
        ray_address = declare(
            self, "ray_address", "", "Train on this Ray cluster ('auto', host:port, "
            "ray://host:10001) instead of in this process; empty: here", read_only=True)
        declare(self, "diagnostics_period_s", 1.0, "Period of /diagnostics republication",
                unit="s", lo=0.1, hi=60.0)
        self._parent_frame = declare(
            self, "parent_frame", DEFAULT_PARENT_FRAME, "Frame of the static transform to "
            "each pier's frame (the markers' frame_id, the pier id) on /tf_static",
            read_only=True)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # The first check ran before the callback existed: apply it to the declared values.
        result = self._on_set_parameters([self.get_parameter("device"),
                                          self.get_parameter("method")])
        if not result.successful:
            raise ValueError(result.reason)

        self._seen: set[str] = set()
        self._diagnostics: DiagnosticArray | None = None
        self._closing = False
        self._progress_pub = self.create_publisher(IdentificationProgress,
                                                   "identification_progress", 10)
        self._state_pub = self.create_publisher(PierDamageState, "damage_state",
                                                DAMAGE_STATE_QOS)
        self._markers_pub = self.create_publisher(MarkerArray, "damage_markers",
                                                  DAMAGE_STATE_QOS)
        self._ray = RayBackend(ray_address) if ray_address else None
        self._frames: list[str] = []  # pier frames whose transform is on /tf_static
        self._tf_pub = None
        if TFMessage is not None:
            self._tf_pub = self.create_publisher(TFMessage, TF_STATIC_TOPIC, TF_STATIC_QOS)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._diag_timer = self.create_timer(self.get_parameter("diagnostics_period_s").value,
                                             self._publish_diagnostics)
        if self._ray is None:  # a PINN trained here: torch loaded in this (the main) thread
            prepare_method(self._param("method"))
        self._worker: QueueWorker[MeasuredWindow | MainshockWindow] = QueueWorker(
            "identifier_worker", self._identify, self._on_worker_error)
        self._window_sub = self.create_subscription(
            MainshockWindow, "mainshock_window", self._on_window, WINDOW_QOS)
        pending = self._store.pending(self._window_dir)
        for problem in pending.unreadable:
            self.get_logger().error(f"unreadable window, skipped: {problem}")
        for window in pending.windows:
            self._seen.add(window.event_id)
            self._worker.put(window)
            self.get_logger().info(f"{window.event_id}: window without results, queued")

    # -- parameters -------------------------------------------------------------------------
    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        values = {p.name: p.value for p in params}
        for name, choices in (("device", DEVICES), ("method", METHODS)):
            if name in values and values[name] not in choices:
                return SetParametersResult(successful=False, reason=(
                    f"{name}: {values[name]!r} is not one of {', '.join(choices)}"))
        if {"min_epochs", "max_epochs"} & set(values):
            lo = values.get("min_epochs", self._param("min_epochs"))
            hi = values.get("max_epochs", self._param("max_epochs"))
            if lo is not None and hi is not None and lo > hi:
                return SetParametersResult(successful=False, reason=(
                    f"min_epochs ({lo}) must not exceed max_epochs ({hi})"))
        if "method" in values and getattr(self, "_ray", None) is None:
            prepare_method(values["method"])
        if "diagnostics_period_s" in values and hasattr(self, "_diag_timer"):
            self._diag_timer.timer_period_ns = int(values["diagnostics_period_s"] * 1e9)
        return SetParametersResult(successful=True)

    def _param(self, name: str) -> Any:
        return self.get_parameter(name).value if self.has_parameter(name) else None

    def settings(self) -> IdentifySettings:
        """The IdentifySettings of the current parameters."""
        return IdentifySettings.from_flat(**{n: self._param(n) for n in _SETTINGS})

    # -- callbacks: only enqueue ------------------------------------------------------------
    def _on_window(self, msg: MainshockWindow) -> None:
        if msg.event_id in self._seen:
            return  # already queued (e.g. found on disk at start, or re-delivered latched)
        self._seen.add(msg.event_id)
        self._worker.put(msg)

    # -- worker -----------------------------------------------------------------------------
    def _identify(self, item: MeasuredWindow | MainshockWindow) -> None:
        window = item if isinstance(item, MeasuredWindow) else window_from_msg(
            item, self.resolve_topic_name("mainshock_window"))
        if self._store.is_done(window.event_id):
            return
        if self._closing:  # shutting down: keep the window for the next start, do not train
            self._store.start_event(window)
            return
        settings = self.settings()
        self.get_logger().info(f"training on {window.event_id} ({window.duration_s:.2f} s, "
                               f"max {settings.pinn_settings.max_epochs} epochs, device "
                               f"{settings.device})")
        try:
            if self._ray is not None:
                result = identify_offloaded(self._ray, window, settings, self._store,
                                            figures=bool(self._param("write_figures")),
                                            stopped=lambda: self._closing)
            else:
                result = identify_window(window, settings, self._store,
                                         progress=self._progress(window.event_id),
                                         figures=bool(self._param("write_figures"))).result
        except TrainingStopped:
            self.get_logger().info(f"{window.event_id}: training stopped at shutdown; the "
                                   "window stays stored for the next start")
            return
        if result.unreliable_reasons:
            self.get_logger().warning(f"{window.event_id}: {result.message}")
        elif result.success:
            self.get_logger().info(f"{window.event_id}: {result.overall_state}, DF "
                                   f"{[round(s.ductility_factor, 2) for s in result.sections]}")
        else:
            self.get_logger().error(f"{window.event_id}: {result.message}")
        fields = damage_state_fields(result, stamp_ns=self._now_ns())
        self._state_pub.publish(damage_state_msg(fields))
        self._publish_frame(result.pier_id)
        self._markers_pub.publish(damage_markers_msg(fields))
        self._diagnostics = damage_diagnostics(
            fields, self._now_ns(), k1_vs_design_pct=k1_vs_design(result),
            poorly_identified=[s.poorly_identified for s in result.sections])
        self._diag_pub.publish(self._diagnostics)

    def _publish_frame(self, pier_id: str) -> None:
        """Once per pier: the static transform parent_frame → pier_id (all piers in one
        message, as a latched /tf_static publisher keeps only its last)."""
        if pier_id in self._frames:
            return
        self._frames.append(pier_id)
        if self._tf_pub is None:
            self.get_logger().warning(
                f"tf2_msgs is not installed: no transform {self._parent_frame} -> {pier_id} "
                f"on {TF_STATIC_TOPIC}; the markers are in frame {pier_id!r} (use it as the "
                "display's fixed frame)")
            return
        try:
            msg = pier_transforms_msg(self._frames, self._now_ns(),
                                      parent_frame=self._parent_frame)
        except ValueError as err:
            self.get_logger().error(f"parent_frame: {err}")
            return
        self._tf_pub.publish(msg)

    def _progress(self, event_id: str) -> Callable[[Progress], None]:
        every = self._param("progress_every")

        def publish(p: Progress) -> None:
            if self._closing:
                raise TrainingStopped()
            if p.epoch % every == 0 or p.epoch == 1 or p.epoch == p.max_epochs:
                self._progress_pub.publish(progress_msg(event_id, p, self._now_ns()))

        return publish

    def _on_worker_error(self, item: MeasuredWindow | MainshockWindow, err: Exception) -> None:
        self.get_logger().error(f"window {item.event_id!r} dropped: {type(err).__name__}: {err}")

    # -- diagnostics ------------------------------------------------------------------------
    def _now_ns(self) -> int:
        return self.get_clock().now().nanoseconds

    def _publish_diagnostics(self) -> None:
        if self._diagnostics is not None:
            self._diagnostics.header.stamp = self.get_clock().now().to_msg()
            self._diag_pub.publish(self._diagnostics)

    def destroy_node(self) -> None:
        """Stop the worker (ending a training at its next epoch), then the node."""
        self._closing = True  # a training stops at its next epoch; the window stays stored
        self._worker.stop(self.get_logger().info)
        if self._ray is not None:
            self._ray.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Entry point (``ros2 run pier_monitor identifier``, ``python -m ...identifier_node``)."""
    return run_node(IdentifierNode, args if args is not None else sys.argv)


if __name__ == "__main__":
    sys.exit(main())
