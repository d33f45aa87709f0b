"""The nodes in this process: ``config/nodes.yaml`` lists every parameter they declare, at its
default, with its range; the ingest status when every channel is silent.

The nodes are created in this process (real rclpy, no graph traffic needed) without a
parameters file, so that what they hold is their defaults; each is compared with the file.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from ros_helpers import REPO_ROOT

pytestmark = [pytest.mark.ros, pytest.mark.timeout(120)]

NODES_YAML = REPO_ROOT / "config" / "nodes.yaml"


def _comments(section: str) -> dict[str, str]:
    """The comment of each parameter line of ``section`` (``/**/ingest``) of nodes.yaml."""
    out: dict[str, str] = {}
    current = None
    for line in NODES_YAML.read_text(encoding="utf-8").splitlines():
        if line and not line.startswith((" ", "#")):
            current = line.rstrip(":")
            continue
        m = re.match(r"^ {4}(\w+):[^#]*(?:#(.*))?$", line)
        if current == section and m:
            out[m.group(1)] = (m.group(2) or "").strip()
    return out


def _declared(node: Any, rclpy_defaults: set[str]) -> dict[str, tuple[Any, Any]]:
    """``name -> (value, descriptor)`` of what the node declared itself."""
    names = [n for n in node._parameters if n not in rclpy_defaults]
    # get_parameter refuses an unset, statically typed parameter (an empty string array)
    return {n: (node._parameters[n].value, node.describe_parameter(n)) for n in names}


def _num(value: float) -> str:
    return str(value) if isinstance(value, int) else f"{value:g}"


def _plain(value: Any) -> Any:
    if isinstance(value, (list, tuple)) or type(value).__name__ == "array":
        return [v for v in value if v != ""]  # a params file cannot hold [], it holds [""]
    return value


@pytest.mark.parametrize("section, module, cls", [
    ("/**/ingest", "pier_monitor.nodes.ingest_node", "IngestNode"),
    ("/**/identifier", "pier_monitor.nodes.identifier_node", "IdentifierNode"),
])
def test_nodes_yaml_lists_every_parameter_with_its_default_and_range(
        rclpy_context: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, section: str,
        module: str, cls: str) -> None:
    import importlib

    import rclpy

    monkeypatch.chdir(tmp_path)  # the default directories are relative: keep them here
    bare = rclpy.create_node("bare", context=rclpy_context)
    rclpy_defaults = set(bare._parameters)  # use_sim_time, ...: rclpy's, not ours
    bare.destroy_node()
    node = getattr(importlib.import_module(module), cls)(context=rclpy_context)
    try:
        declared = _declared(node, rclpy_defaults)
    finally:
        node.destroy_node()
    listed = yaml.safe_load(NODES_YAML.read_text(encoding="utf-8"))[section]["ros__parameters"]
    assert sorted(listed) == sorted(declared), "nodes.yaml and the node's declarations differ"
    comments = _comments(section)
    for name, (value, descriptor) in declared.items():
        assert _plain(listed[name]) == _plain(value if value is not None else []), name
        text = comments[name]
        for r in (*descriptor.integer_range, *descriptor.floating_point_range):
            assert f"({_num(r.from_value)} to {_num(r.to_value)})" in text, f"{name}: range not listed"
        if descriptor.additional_constraints.startswith("one of: "):
            choices = descriptor.additional_constraints.removeprefix("one of: ").split(", ")
            assert f"({' | '.join(choices)})" in text, f"{name}: choices not listed"
        assert ("fixed at start" in text) == bool(descriptor.read_only), name


def test_ingest_status_goes_warn_then_stale_when_every_channel_is_silent(
        rclpy_context: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import time

    from diagnostic_msgs.msg import DiagnosticStatus
    from rclpy.parameter import Parameter

    from pier_monitor.core.resources import find_config_file
    from pier_monitor.nodes.ingest_node import IngestNode

    monkeypatch.chdir(tmp_path)
    node = IngestNode(context=rclpy_context, parameter_overrides=[
        Parameter("config_file", value=str(find_config_file("edefense_like.yaml"))),
        Parameter("alive_timeout_s", value=2.0), Parameter("stale_timeout_s", value=30.0)])
    try:
        sensors = sorted(node._specs)
        st = node.status()
        assert st.level == DiagnosticStatus.WARN and st.message.startswith("no data yet")
        # as if each sensor's last message came 1 s ago (one alive) / 5 s / 40 s ago
        now = time.monotonic()
        for age, level, start in ((1.0, DiagnosticStatus.OK, f"{len(sensors)} channels alive"),
                                  (5.0, DiagnosticStatus.WARN, "every channel silent for "),
                                  (40.0, DiagnosticStatus.STALE, "stale: every channel silent")):
            node._last_seen = {s: now - age for s in sensors}
            st = node.status()
            values = {kv.key: kv.value for kv in st.values}
            assert st.level == level and st.message.startswith(start), st.message
            assert values["channels_alive"] == (str(len(sensors)) if age < 2.0 else "0")
        # dropped messages: WARN while channels are alive, still STALE once all are silent
        node._dropped = 2
        node._last_seen = {s: now - 1.0 for s in sensors}
        st = node.status()
        assert st.level == DiagnosticStatus.WARN and st.message.startswith("2 messages dropped")
        node._last_seen = {s: now - 40.0 for s in sensors}
        st = node.status()
        assert st.level == DiagnosticStatus.STALE and "; 2 messages dropped" in st.message
    finally:
        node.destroy_node()


def test_identifier_hangs_each_pier_frame_from_parent_frame_where_tf2_msgs_exists(
        rclpy_context: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from rclpy.parameter import Parameter

    from pier_monitor.nodes import conversions
    from pier_monitor.nodes.identifier_node import IdentifierNode

    monkeypatch.chdir(tmp_path)
    node = IdentifierNode(context=rclpy_context,
                          parameter_overrides=[Parameter("parent_frame", value="site")])
    try:
        node._publish_frame("p1")
        node._publish_frame("p2")
        node._publish_frame("p1")  # once per pier
        assert node._frames == ["p1", "p2"]
        if conversions.TFMessage is None:
            # the environment's ROS wheels have no tf2_msgs: nothing is published (logged)
            assert node._tf_pub is None
            with pytest.raises(RuntimeError, match="tf2_msgs is not installed"):
                conversions.pier_transforms_msg(["p1"], 0)
            return
        msg = conversions.pier_transforms_msg(node._frames, 5_000_000_001, parent_frame="site")
        assert [(t.header.frame_id, t.child_frame_id) for t in msg.transforms] == [
            ("site", "p1"), ("site", "p2")]
        assert (msg.transforms[0].header.stamp.sec,
                msg.transforms[0].header.stamp.nanosec) == (5, 1)
        assert msg.transforms[0].transform.rotation.w == 1.0
        assert node.count_publishers("/tf_static") == 1
    finally:
        node.destroy_node()
