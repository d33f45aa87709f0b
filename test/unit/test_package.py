"""The ROS 2 package metadata: setup.py, setup.cfg, package.xml and the launch file agree."""

from __future__ import annotations

import ast
import configparser
import runpy
import xml.etree.ElementTree as ET
from pathlib import Path

import pier_monitor

ROOT = Path(__file__).resolve().parents[2]
LAUNCH_FILE = ROOT / "launch_files" / "pier_monitor.launch.py"
read_setup_kwargs = runpy.run_path(str(ROOT / "scripts" / "link_data_files.py"))[
    "read_setup_kwargs"]


def console_scripts() -> dict[str, str]:
    kwargs = read_setup_kwargs(ROOT / "setup.py")
    return dict(entry.replace(" ", "").split("=", 1)
                for entry in kwargs["entry_points"]["console_scripts"])


def test_setup_py_and_package_xml_describe_the_same_ament_python_package() -> None:
    kwargs = read_setup_kwargs(ROOT / "setup.py")
    xml = ET.parse(ROOT / "package.xml").getroot()
    assert xml.get("format") == "3"
    assert kwargs["name"] == xml.findtext("name") == "pier_monitor"
    assert kwargs["version"] == xml.findtext("version") == pier_monitor.__version__
    assert kwargs["license"] == xml.findtext("license")
    maintainer = xml.find("maintainer")
    assert (kwargs["maintainer"], kwargs["maintainer_email"]) == (maintainer.text,
                                                                  maintainer.get("email"))
    assert xml.find("export/build_type").text == "ament_python"
    data = dict(kwargs["data_files"])
    assert data["share/ament_index/resource_index/packages"] == ["resource/pier_monitor"]
    assert (ROOT / "resource" / "pier_monitor").is_file()
    assert data["share/pier_monitor"] == ["package.xml"]
    assert data["share/pier_monitor/launch"] == ["launch_files/pier_monitor.launch.py"]
    assert "pier_monitor_msgs" in {d.text for d in xml.findall("exec_depend")}


def test_node_executables_are_installed_where_ros2_run_looks() -> None:
    scripts = console_scripts()
    assert scripts["ingest"] == "pier_monitor.nodes.ingest_node:main"
    assert scripts["identifier"] == "pier_monitor.nodes.identifier_node:main"
    for target in scripts.values():  # each names a function that exists (read, not imported)
        module, func = target.split(":")
        tree = ast.parse((ROOT / (module.replace(".", "/") + ".py")).read_text())
        assert func in {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}, target
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    assert cfg["develop"]["script_dir"] == cfg["install"]["install_scripts"] == \
        "$base/lib/pier_monitor"


def test_the_launch_file_starts_the_declared_executables() -> None:
    tree = ast.parse(LAUNCH_FILE.read_text())
    assigned = {t.id: node.value for node in tree.body if isinstance(node, ast.Assign)
                for t in node.targets if isinstance(t, ast.Name)}
    nodes = ast.literal_eval(assigned["NODES"])
    assert ast.literal_eval(assigned["PACKAGE"]) == "pier_monitor"
    assert {executable for executable, _ in nodes} == {"ingest", "identifier"} <= set(
        console_scripts())
    assert "generate_launch_description" in {n.name for n in tree.body
                                             if isinstance(n, ast.FunctionDef)}


def test_no_folder_of_the_repository_shadows_the_launch_package() -> None:
    # Python puts the working directory first on sys.path: a launch/ folder there would be
    # imported instead of the launch package by everything started from the repository root
    assert not (ROOT / "launch").exists() and not (ROOT / "launch_ros").exists()


def test_the_launch_file_compiles() -> None:
    compile(LAUNCH_FILE.read_text(encoding="utf-8"), str(LAUNCH_FILE), "exec")


def test_the_launch_file_gives_a_launch_description_where_launch_ros_is_installed() -> None:
    import importlib.util

    import pytest

    for name in ("launch", "launch_ros", "ament_index_python"):
        if importlib.util.find_spec(name) is None:
            pytest.skip(f"{name} is not installed (the ROS 2 PyPI wheels of this environment "
                        "have no launch_ros); the launch file is checked by compiling it and "
                        "reading its nodes")
    import launch
    import launch_ros.actions

    namespace = runpy.run_path(str(LAUNCH_FILE))
    description = namespace["generate_launch_description"]()
    assert isinstance(description, launch.LaunchDescription)
    nodes = [e for e in description.entities if isinstance(e, launch_ros.actions.Node)]
    assert len(nodes) == len(namespace["NODES"]) == 2


def test_launchers_in_lib_pier_monitor_are_what_ros2_run_finds_and_they_run(
        tmp_path: Path, monkeypatch) -> None:
    import os
    import subprocess
    import sys

    from ament_index_python.packages import get_package_prefix

    # a prefix as scripts/setup_env.sh leaves the venv: the ament index marker and the launchers
    write_launchers = runpy.run_path(str(ROOT / "scripts" / "link_data_files.py"))[
        "write_launchers"]
    marker = tmp_path / "share" / "ament_index" / "resource_index" / "packages" / "pier_monitor"
    marker.parent.mkdir(parents=True)
    marker.touch()
    (tmp_path / "lib" / "pier_monitor").mkdir(parents=True)
    (tmp_path / "lib" / "pier_monitor" / "old_node").write_text(
        "# written by scripts/link_data_files.py\n")  # a launcher no longer declared
    written = write_launchers(ROOT / "setup.py", tmp_path, sys.executable)
    assert sorted(p.name for p in written) == sorted(console_scripts())
    assert sorted(p.name for p in (tmp_path / "lib" / "pier_monitor").iterdir()) == sorted(
        console_scripts())
    # what `ros2 run pier_monitor ingest` does: the package's prefix from the ament index,
    # then an executable file of that name in <prefix>/lib/pier_monitor
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    prefix = Path(get_package_prefix("pier_monitor"))
    assert prefix == tmp_path
    executable = prefix / "lib" / "pier_monitor" / "ingest"
    assert executable.is_file() and os.access(executable, os.X_OK)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run([str(executable), "--help"], capture_output=True, text=True,
                          timeout=120, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("usage: ros2 run pier_monitor ingest [--ros-args")
    assert "Ingest node: sensor topics" in done.stdout
