"""A ROS user's build: colcon builds this package and msg_defs/ into a workspace, and the
installed node executables diagnose a replayed bag.

The workspace holds a copy of the repository in ``src/pier_monitor``; colcon (from PyPI, in
the venv) builds ``pier_monitor_msgs`` (ament_cmake) and ``pier_monitor`` (ament_python)
into ``install/``.  The environment is that of ``install/local_setup.sh``, as a user sources
it, plus the test's private ROS graph.  The nodes are the executables ``ros2 run
pier_monitor ingest`` / ``identifier`` would start: ``install/pier_monitor/lib/pier_monitor/``.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from ros_helpers import (NS, REPO_ROOT, RUN_SCRIPT, Listener, interrupt, kill_children,
                         params_file, start_child)

pytestmark = [pytest.mark.ros, pytest.mark.timeout(400)]

VENV = Path(sys.prefix)
#: What a checkout holds besides the sources: never copied into the workspace.
NOT_SOURCES = shutil.ignore_patterns(".git", ".venv", "build", "install", "log", "results",
                                     "__pycache__", "*.egg-info", ".pytest_cache",
                                     "pier_monitor_data")


def _colcon_env() -> dict[str, str]:
    """The venv's ROS prefix and tools only, as scripts/build_msgs.py builds (ROS_WHEELS.md)."""
    env = dict(os.environ)
    env.update(AMENT_PREFIX_PATH=str(VENV), CMAKE_PREFIX_PATH=str(VENV),
               PATH=os.pathsep.join([str(VENV / "bin"), env.get("PATH", "")]))
    env.pop("COLCON_PREFIX_PATH", None)
    env.pop("PYTHONPATH", None)
    return env


@pytest.fixture(scope="module")
def workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A colcon workspace with this package and its interfaces built into ``install/``."""
    ws = tmp_path_factory.mktemp("colcon_ws")
    shutil.copytree(REPO_ROOT, ws / "src" / "pier_monitor", ignore=NOT_SOURCES)
    cmd = [str(VENV / "bin" / "colcon"), "build", "--event-handlers", "console_direct-",
           "--base-paths", "src/pier_monitor", "src/pier_monitor/msg_defs",
           "--cmake-args", f"-DPython3_EXECUTABLE={VENV / 'bin' / 'python'}",
           "-DBUILD_TESTING=OFF"]
    proc = subprocess.run(cmd, cwd=ws, env=_colcon_env(), capture_output=True, text=True,
                          timeout=300)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"colcon build failed:\n{log[-8000:]}"
    assert "Finished <<< pier_monitor_msgs" in log and "Finished <<< pier_monitor " in log, log
    return ws


def sourced_env(install: Path, base: dict[str, str]) -> dict[str, str]:
    """``base`` after ``. install/local_setup.sh``: what a user's shell has."""
    out = subprocess.run(["sh", "-c", '. "$1/local_setup.sh" && env -0', "sh", str(install)],
                         env=base, capture_output=True, check=True, timeout=60).stdout
    return dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)


@pytest.fixture
def short_bag(tmp_path: Path) -> tuple[Path, list[str]]:
    """A two-run bag (0.5 s blocks) and the events the ingest finds in it."""
    from pier_monitor.bags import read_bag, write_bag
    from pier_monitor.core.ingest import ingest_recording
    from pier_monitor.core.model.config import load_config
    from pier_monitor.core.resources import find_config_file
    from pier_monitor.core.synthetic.shaking_table import edefense_scenario, generate_recording

    config = load_config(find_config_file("edefense_like.yaml"))
    scenario = edefense_scenario(record_s=20.0, lead_s=12.0, gap_s=18.0, tail_s=18.0)
    path = tmp_path / "short.mcap"
    write_bag(generate_recording(config, scenario, seed=1).recording, path, block_s=0.5)
    windows, _ = ingest_recording(read_bag(path))
    return path, [w.event_id for w in windows]


def test_colcon_built_executables_diagnose_a_replayed_bag(
        workspace: Path, short_bag: tuple[Path, list[str]], ros_env: dict[str, str],
        rclpy_context: Any, msg_typestore: Any, tmp_path: Path) -> None:
    install = workspace / "install"
    lib = install / "pier_monitor" / "lib" / "pier_monitor"
    assert {p.name for p in lib.iterdir()} >= {"ingest", "identifier", "pier-monitor"}
    assert (install / "pier_monitor" / "share" / "pier_monitor" / "launch" /
            "pier_monitor.launch.py").is_file()
    env = sourced_env(install, ros_env)
    where = subprocess.run([str(VENV / "bin" / "python"), "-c",
                            "import pier_monitor, pier_monitor_msgs; "
                            "print(pier_monitor.__file__); print(pier_monitor_msgs.__file__)"],
                           env=env, cwd=tmp_path, capture_output=True, text=True, check=True)
    assert all(line.startswith(str(install)) for line in where.stdout.split()), where.stdout

    bag, events = short_bag
    params = params_file(tmp_path / "params.yaml", tmp_path)
    listener = Listener(rclpy_context, msg_typestore)
    nodes = [start_child([str(lib / name), "--ros-args", "-r", f"__ns:={NS}", "--params-file",
                          str(params)], env, tmp_path) for name in ("ingest", "identifier")]
    try:
        for node in nodes:
            node.wait_for_line("READY", 60)
            # the workspace's message libraries only: the venv holds another build of them,
            # which a library path in another order would mix in
            libs = {line.split()[-1] for line in
                    Path(f"/proc/{node.popen.pid}/maps").read_text().splitlines()
                    if "pier_monitor_msgs" in line}
            assert libs and all(lib.startswith(str(install)) for lib in libs), libs
        replay = start_child([str(VENV / "bin" / "python"), "-c", RUN_SCRIPT,
                              str(REPO_ROOT / "launch_free_scripts" / "replay_bag.py"), str(bag),
                              "--rate", "8"], env, tmp_path)
        nodes.append(replay)  # killed with the nodes if anything below fails
        replay.wait_for_line("SENT", 120)
        assert replay.stop() == 0
        listener.wait(lambda: len(listener.states) >= len(events), 120,
                      f"{len(events)} damage states")
        assert [s.event_id for s in listener.states] == events
        for state in listener.states:
            assert state.success and len(state.sections) == 4
            assert all(0.0 < s.ductility_factor < 20.0 for s in state.sections)
        assert (tmp_path / "results" / events[-1] / "result.json").is_file()
        assert [interrupt(node) for node in nodes[:2]] == [0, 0]
    finally:
        listener.close()
        kill_children(nodes)
