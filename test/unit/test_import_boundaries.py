"""The layers import only downward: core → nothing heavy; pinn → torch; bags → rosbags/mcap;
nodes alone → rclpy (STYLE.md)."""

from __future__ import annotations

import subprocess
import sys

import pytest

HEAVY = ("rclpy", "torch", "rosbags", "mcap", "matplotlib.pyplot")


def loaded_after_import(modules: list[str]) -> set[str]:
    code = ("import sys\n" + "".join(f"import {m}\n" for m in modules)
            + f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    return set(out.split())


CORE = ["pier_monitor.core." + m for m in (
    "errors", "resources", "model.config", "model.link_model", "model.solver",
    "model.ground_motion", "model.units", "ingest", "ingest.recording", "ingest.fusion",
    "ingest.window", "identify.equation_error", "identify.damage", "synthetic.shaking_table",
    "synthetic.reference")]


@pytest.mark.parametrize("modules, allowed", [
    (CORE, set()),
    (["pier_monitor.pinn"], {"torch"}),
    (["pier_monitor.bags"], {"rosbags", "mcap"}),
    (["pier_monitor.report", "pier_monitor.report.figures", "pier_monitor.report.compare"],
     {"rosbags", "mcap"}),
    (["pier_monitor.cli", "pier_monitor.pipeline", "pier_monitor.bench"], set()),
])
def test_layers_import_only_what_they_may(modules, allowed):
    assert loaded_after_import(modules) <= allowed
