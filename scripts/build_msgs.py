"""Build the pier_monitor_msgs interface package and install it into the running venv.

Run it with the venv's own python (``.venv/bin/python scripts/build_msgs.py``): the ROS 2
wheels' bootstrap has then already put their libraries on ``LD_LIBRARY_PATH``, and the
install prefix is ``sys.prefix``, so nothing has to be sourced afterwards.

The ROS 2 wheels ship CMake export files that name the wheel build machine's Python and
NumPy include directories; they are rewritten to this interpreter's before configuring
(see ROS_WHEELS.md).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Include directories of the machine the ROS wheels were built on.
_FOREIGN_PYTHON_INCLUDE = re.compile(r"/opt/python/cp3\d+-cp3\d+/include/python3\.\d+")
_FOREIGN_NUMPY_INCLUDE = re.compile(
    r"/opt/python/cp3\d+-cp3\d+/lib/python3\.\d+/site-packages/numpy/(?:_core|core)/include")


class BuildError(RuntimeError):
    """The message package could not be built."""


def fix_export_cmake(prefix: Path) -> int:
    """Point the wheels' ``*Export.cmake`` files at this interpreter's include dirs.

    Parameters
    ----------
    prefix
        The venv prefix holding the ROS 2 wheels' ``share/`` tree.

    Returns
    -------
    int
        Number of files rewritten (0 when they were already fixed).
    """
    import numpy  # noqa: PLC0415 - only needed here, after the venv check

    python_include = sysconfig.get_paths()["include"]
    numpy_include = numpy.get_include()
    for path, name in ((python_include, "Python.h"), (numpy_include, "numpy/arrayobject.h")):
        if not (Path(path) / name).is_file():
            raise BuildError(f"{name} not found in {path}: install the Python development headers")
    changed = 0
    for export in sorted((prefix / "share").glob("*/cmake/*Export.cmake")):
        text = export.read_text()
        new = _FOREIGN_NUMPY_INCLUDE.sub(lambda _: numpy_include, text)
        new = _FOREIGN_PYTHON_INCLUDE.sub(lambda _: python_include, new)
        if new != text:
            export.write_text(new)
            changed += 1
    return changed


def run(cmd: list[str], env: dict[str, str], verbose: bool) -> None:
    """Run a build command; on failure raise with the tail of its output."""
    capture = None if verbose else subprocess.PIPE
    result = subprocess.run(cmd, env=env, text=True, stdout=capture, stderr=subprocess.STDOUT)
    if result.returncode != 0:
        output = result.stdout[-8000:] if result.stdout else ""
        raise BuildError(f"command failed ({result.returncode}): {' '.join(cmd)}\n{output}")


def build(source: Path, build_dir: Path, prefix: Path, verbose: bool = False) -> None:
    """Configure, build and install the ament_cmake package in ``source`` into ``prefix``."""
    cmake = shutil.which("cmake")
    if cmake is None:
        raise BuildError("cmake not found on PATH (need cmake >= 3.16 and a C/C++ compiler)")
    env = dict(os.environ)
    # Only the venv: a sourced ROS installation must not leak into this build.
    env["AMENT_PREFIX_PATH"] = str(prefix)
    env["CMAKE_PREFIX_PATH"] = str(prefix)
    env.pop("COLCON_PREFIX_PATH", None)
    env["PATH"] = os.pathsep.join([str(prefix / "bin"), env.get("PATH", "")])

    # A clean build: the cache would otherwise keep paths of a venv that has been recreated.
    if build_dir.exists():
        shutil.rmtree(build_dir)
    build_dir.mkdir(parents=True)
    jobs = str(os.cpu_count() or 1)
    run([cmake, "-S", str(source), "-B", str(build_dir),
         f"-DCMAKE_PREFIX_PATH={prefix}",
         f"-DCMAKE_INSTALL_PREFIX={prefix}",
         f"-DPython3_EXECUTABLE={sys.executable}",
         "-DCMAKE_BUILD_TYPE=Release",
         "-DBUILD_TESTING=OFF"], env, verbose)
    run([cmake, "--build", str(build_dir), "--parallel", jobs], env, verbose)
    run([cmake, "--install", str(build_dir)], env, verbose)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=ROOT / "msg_defs",
                        help="interface package to build (default: msg_defs/)")
    parser.add_argument("--build-dir", type=Path, default=ROOT / "build" / "pier_monitor_msgs",
                        help="CMake build directory, wiped first (default: build/pier_monitor_msgs)")
    parser.add_argument("-v", "--verbose", action="store_true", help="show the build output")
    args = parser.parse_args(argv)

    prefix = Path(sys.prefix)
    if sys.prefix == sys.base_prefix:
        print("build_msgs: run this with the virtual environment python (.venv/bin/python)",
              file=sys.stderr)
        return 2
    try:
        changed = fix_export_cmake(prefix)
        if changed:
            print(f"build_msgs: rewrote include paths in {changed} *Export.cmake files")
        build(args.source.resolve(), args.build_dir.resolve(), prefix, args.verbose)
    except BuildError as err:
        print(f"build_msgs: {err}", file=sys.stderr)
        return 1
    print(f"build_msgs: installed {args.source} into {prefix}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
