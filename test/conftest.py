"""Fixtures shared by all tests: an isolated ROS 2 graph per test, child processes, messages.

rclpy is imported inside the fixtures only, so that collecting the unit tests never loads it.
The helpers the fixtures hand out live in ``ros_helpers.py``.
"""

from __future__ import annotations

import itertools
import os
import sys
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from ros_helpers import (MSG_DIR, REPO_ROOT, RosProcess, assert_fields_equal, kill_children,
                         start_child)

# One BLAS/OpenMP thread per test process and for its children (nodes, pool workers), set
# before anything imports numpy or torch (nothing above does): on a shared 2-core machine,
# multi-threaded matrix products ran more than 10x slower under load than single-threaded
# ones.  A value in the environment wins.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# ROS_DOMAIN_IDs 1..101 (0 is everyone's default). Each test takes the next one; the start
# depends on the process id so that test runs started together rarely share a domain.
_DOMAIN_IDS = itertools.cycle(
    [1 + (os.getpid() * 17 + i) % 101 for i in range(101)])


@pytest.fixture
def ros_domain_id() -> int:
    """A ROS_DOMAIN_ID of this test's own (1..101)."""
    return next(_DOMAIN_IDS)


@pytest.fixture
def ros_env(ros_domain_id: int, monkeypatch: pytest.MonkeyPatch) -> dict[str, str]:
    """Environment of an isolated ROS 2 graph, applied to this process and returned for children.

    UDP only (no shared-memory files left in /dev/shm by a killed process), discovery limited
    to this host, and this test's own domain id.
    """
    settings = {
        "ROS_DOMAIN_ID": str(ros_domain_id),
        "FASTDDS_BUILTIN_TRANSPORTS": "UDPv4",
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
    }
    for key, value in settings.items():
        monkeypatch.setenv(key, value)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    return dict(os.environ)


@pytest.fixture
def rclpy_context(ros_env: dict[str, str]) -> Iterator[Any]:
    """An initialised rclpy ``Context`` of this test's own, shut down afterwards.

    Destroy nodes and shut down executors (joining their threads) before the test returns:
    ``rclpy.shutdown`` with a live executor thread aborts the process.
    """
    import rclpy
    from rclpy.context import Context

    context = Context()
    rclpy.init(context=context, domain_id=int(ros_env["ROS_DOMAIN_ID"]))
    try:
        yield context
    finally:
        rclpy.shutdown(context=context)


@pytest.fixture
def spawn_python(ros_env: dict[str, str]) -> Iterator[Callable[..., RosProcess]]:
    """Start ``python -c CODE ARGS...`` with the venv interpreter in this test's ROS graph.

    stdout and stderr come back merged, line by line; stdin stays open until ``stop()``.
    Children still running at the end of the test are killed with their process groups, and
    every child dies with the test process (:func:`ros_helpers.start_child`).
    """
    children: list[RosProcess] = []

    def spawn(code: str, *args: str) -> RosProcess:
        child = start_child([sys.executable, "-c", code, *args], ros_env, REPO_ROOT)
        children.append(child)
        return child

    try:
        yield spawn
    finally:
        kill_children(children)


@pytest.fixture(scope="session")
def msg_typestore() -> Any:
    """A rosbags typestore (ROS 2 Kilted) with the pier_monitor_msgs types from msg_defs/."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    typestore = get_typestore(Stores.ROS2_KILTED)
    types: dict[str, Any] = {}
    for path in sorted(MSG_DIR.glob("*.msg")):
        types.update(get_types_from_msg(path.read_text(), f"pier_monitor_msgs/msg/{path.stem}"))
    typestore.register(types)
    return typestore


@pytest.fixture(scope="session")
def fields_equal() -> Callable[[Any, Any], None]:
    """``assert_fields_equal(expected, actual)``: compare messages field by field."""
    return assert_fields_equal
