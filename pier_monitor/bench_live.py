"""Time from the end of the shaking to the published damage state, on the live graph.

The stock graph (``launch_free_scripts/start_graph.py`` with ``config/nodes.yaml``, only its
directories moved to a temporary one) runs as real processes; a synthetic bag is replayed into
it in real time (``replay_bag.py --rate 1``, which prints the data time of its first message
and the wall clock it was sent at); ``echo_damage_state.py`` subscribes to the damage state
and its lines are time-stamped here on arrival.  The end of the shaking is the truth's: the
95 % point of the Arias intensity of the foundation's record.  Its wall-clock time is the
replay's clock mapped through the data time.  Data times and the wall clock are used only
to compare with each other, never to decide anything in the product.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import yaml

from pier_monitor.bags.synthetic_bag import write_synthetic_bag
from pier_monitor.core.errors import PierMonitorError
from pier_monitor.core.resources import find_config_file
from pier_monitor.core.synthetic.field import field_pier
from pier_monitor.core.synthetic.measurement import SensorImperfections
from pier_monitor.core.synthetic.shaking_table import load_truth

__all__ = ["bench_latency"]

_REPO = Path(__file__).resolve().parents[1]
_SCRIPTS = _REPO / "launch_free_scripts"


class _Lines:
    """The stdout lines of a child, each with the wall clock (Unix s) it arrived at."""

    def __init__(self, popen: subprocess.Popen) -> None:
        self.popen = popen
        self.lines: list[tuple[float, str]] = []
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        for line in self.popen.stdout:  # type: ignore[union-attr]
            self.lines.append((time.time(), line.rstrip("\n")))

    def first(self, prefix: str, timeout_s: float) -> tuple[float, str]:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            for stamp, line in list(self.lines):
                if line.startswith(prefix):
                    return stamp, line
            if self.popen.poll() is not None and not self._thread.is_alive():
                break
            time.sleep(0.05)
        raise PierMonitorError(f"no '{prefix}' line within {timeout_s:g} s (last lines: "
                               f"{[l for _, l in self.lines[-3:]]})")


def _spawn(args: list[str], env: dict[str, str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True, env=env,
                            start_new_session=True)


def _stop(popen: subprocess.Popen) -> None:
    if popen.poll() is None:
        popen.send_signal(2)  # SIGINT: the nodes shut down cleanly
        try:
            popen.wait(timeout=30)
        except subprocess.TimeoutExpired:
            popen.kill()
            popen.wait()


def _params_file(path: Path, data: Path) -> Path:
    """The stock ``config/nodes.yaml`` with its directories under ``data``."""
    doc = yaml.safe_load(find_config_file("nodes.yaml").read_text())
    doc["/**/ingest"]["ros__parameters"]["window_dir"] = str(data / "windows")
    ident = doc["/**/identifier"]["ros__parameters"]
    ident["window_dir"] = str(data / "windows")
    ident["results_dir"] = str(data / "results")
    path.write_text(yaml.safe_dump(doc))
    return path


def _one_case(pier: str, layout: str, shaking: str, seed: int, work: Path) -> dict[str, Any]:
    bag = work / f"{pier}_{layout}_{shaking}_{seed}"
    info = write_synthetic_bag(bag, seed=seed, layout=layout, scenario=shaking,
                               config_path=find_config_file(field_pier(pier).config_file),
                               imperfections=SensorImperfections())
    truth = load_truth(info.truth_npz, info.truth_json)
    run = truth.runs[0]
    end_shaking_ns = run.window_end_ns - int(round(truth.scenario.window_post_s * 1e9))
    namespace = f"/{truth.pier_id}"
    env = dict(os.environ, ROS_DOMAIN_ID=str(100 + os.getpid() % 100),  # away from other graphs
               OMP_NUM_THREADS=os.environ.get("OMP_NUM_THREADS", "1"))
    ros = ["--ros-args", "-r", f"__ns:={namespace}"]
    graph = _spawn([str(_SCRIPTS / "start_graph.py"), "--namespace", namespace,
                    "--params-file", str(_params_file(work / "nodes.yaml", work / "data"))], env)
    echo = _Lines(_spawn([str(_SCRIPTS / "echo_damage_state.py"), "--count", "1", *ros], env))
    replay = None
    try:
        replay = _Lines(_spawn([str(_SCRIPTS / "replay_bag.py"), str(info.bag.path), "--rate", "1",
                                "--wait-timeout", "120", *ros], env))
        _, clock = replay.first("CLOCK", 180.0)
        fields = dict(kv.split("=") for kv in clock.split()[1:])
        t0_ns, t0_unix = int(fields["log_ns"]), float(fields["unix_s"])
        arrived, line = echo.first("DAMAGE_STATE", 600.0)
        state = json.loads(line.split(" ", 1)[1])
    finally:
        for p in (replay.popen if replay else None, echo.popen, graph):
            if p is not None:
                _stop(p)
    end_unix = t0_unix + (end_shaking_ns - t0_ns) / 1e9
    return {"case": f"latency_{pier}_{layout}_{shaking}", "seed": seed, "pier": pier,
            "layout": layout, "shaking": shaking,
            "end_of_shaking_to_state_s": round(arrived - end_unix, 2),
            "overall_state": state.get("overall_state"), "epochs": state.get("epochs"),
            "target_s": 30.0}


def bench_latency(cases: tuple[tuple[str, str, str], ...] = (
        ("edefense", "full", "strong"), ("edefense", "accel", "strong")),
        seed: int = 0) -> list[dict[str, Any]]:
    """End of shaking → published damage state on the live graph with the stock settings,
    one synthetic field bag per case ``(pier, layout, shaking)``, replayed in real time."""
    out = []
    with tempfile.TemporaryDirectory(prefix="pier_monitor_latency_") as tmp:
        for i, (pier, layout, shaking) in enumerate(cases):
            work = Path(tmp) / str(i)
            work.mkdir()
            out.append(_one_case(pier, layout, shaking, seed, work))
    return out
