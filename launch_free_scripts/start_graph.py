#!/usr/bin/env python3
"""Start a pier's graph: the ingest and identifier nodes as two processes (no ros2 launch).

``start_graph.py --namespace /edefense_pier [--params-file config/nodes.yaml] [-- ROS ARGS]``

Both children share the namespace (relative topics: one namespace per pier) and the
parameters file.  Ctrl-C (or SIGTERM) is passed on to both; a child that has not exited
after ``--grace`` seconds is killed.  The exit code is the first non-zero child code.  On
Linux the children get SIGTERM (a clean shutdown) when this script dies in any way, also
killed: no node is left running without it.
"""

from __future__ import annotations

import argparse
import ctypes
import signal
import subprocess
import sys
import time

NODES = ("pier_monitor.nodes.ingest_node", "pier_monitor.nodes.identifier_node")
_PR_SET_PDEATHSIG = 1
# resolved before any fork: the child only makes the call
_LIBC = ctypes.CDLL(None, use_errno=True) if sys.platform.startswith("linux") else None


def _term_with_parent() -> None:
    """In the child before exec: SIGTERM when this script's process dies."""
    if _LIBC is not None:
        _LIBC.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--namespace", default="/", help="e.g. /edefense_pier")
    parser.add_argument("--params-file", default=None)
    parser.add_argument("--grace", type=float, default=15.0, help="s")
    parser.add_argument("--only", choices=("ingest", "identifier"), default=None)
    args, extra = parser.parse_known_args(argv)
    extra = [a for a in extra if a != "--"]
    ros_args = ["--ros-args", "-r", f"__ns:={args.namespace}"]
    if args.params_file:
        ros_args += ["--params-file", args.params_file]
    ros_args += extra
    modules = [m for m in NODES if args.only is None or m.endswith(f"{args.only}_node")]
    # own sessions: a terminal's Ctrl-C reaches this script only, which passes it on once
    children = [subprocess.Popen([sys.executable, "-m", m, *ros_args], start_new_session=True,
                                 preexec_fn=_term_with_parent) for m in modules]
    stopping = False

    def stop(signum: int, _frame: object) -> None:
        nonlocal stopping
        stopping = True
        for child in children:
            if child.poll() is None:
                child.send_signal(signal.SIGINT)

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    while all(c.poll() is None for c in children) and not stopping:
        time.sleep(0.2)
    if not stopping:  # one child died: stop the other
        stop(signal.SIGINT, None)
    deadline = time.monotonic() + args.grace
    for child in children:
        try:
            child.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            child.kill()
            child.wait()
    codes = [c.returncode for c in children]
    return next((c for c in codes if c not in (0, -signal.SIGINT)), 0)


if __name__ == "__main__":
    sys.exit(main())
