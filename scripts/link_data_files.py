"""Link the package's ``data_files`` (ament index marker, package.xml, config) into the venv,
and write its executables where ``ros2 run`` looks for them.

An editable install (``pip install -e .``) installs the code and the console scripts but not
``data_files``, which ROS tooling looks up under ``<prefix>/share``. This mirrors what
``colcon build --symlink-install`` does for an ament_python package: each data file is
symlinked from the venv prefix to the source tree, so edits show up without reinstalling.

pip also puts the console scripts into ``<prefix>/bin`` (it ignores setup.cfg's
``install_scripts``), while ``ros2 run pier_monitor ingest`` looks in
``<prefix>/lib/pier_monitor/`` of the package's prefix in the ament index.  So every console
script also gets a launcher there, as colcon installs it (:func:`write_launchers`).

Run it with the venv's python: the prefix is ``sys.prefix``.
"""

from __future__ import annotations

import os
import runpy
import shutil
import sys
from pathlib import Path
from typing import Any

import setuptools

ROOT = Path(__file__).resolve().parent.parent


def read_setup_kwargs(setup_py: Path) -> dict[str, Any]:
    """Return the keyword arguments that ``setup_py`` passes to ``setup()`` (nothing built)."""
    captured: dict[str, Any] = {}
    real_setup = setuptools.setup
    setuptools.setup = lambda **kwargs: captured.update(kwargs)
    cwd = os.getcwd()
    try:
        os.chdir(setup_py.parent)  # setup.py globs relative to its own directory
        runpy.run_path(str(setup_py), run_name="__main__")
    finally:
        os.chdir(cwd)
        setuptools.setup = real_setup
    return captured


def read_data_files(setup_py: Path) -> list[tuple[str, list[str]]]:
    """Return the ``data_files`` argument that ``setup_py`` passes to ``setup()``."""
    return read_setup_kwargs(setup_py).get("data_files", [])


def link_data_files(setup_py: Path, prefix: Path) -> int:
    """Symlink every data file of ``setup_py`` into ``prefix``; returns how many."""
    data_files = read_data_files(setup_py)
    # Start from a clean share/<package> so that removed config files do not linger.
    owned = {Path(directory).parts[:2] for directory, _ in data_files}
    for owned_dir in owned:
        if len(owned_dir) == 2 and owned_dir[0] == "share" and owned_dir[1] != "ament_index":
            shutil.rmtree(prefix.joinpath(*owned_dir), ignore_errors=True)
    count = 0
    for directory, files in data_files:
        target_dir = prefix / directory
        target_dir.mkdir(parents=True, exist_ok=True)
        for name in files:
            source = (setup_py.parent / name).resolve()
            if not source.is_file():
                raise FileNotFoundError(f"data file {name} listed in {setup_py} does not exist")
            target = target_dir / source.name
            if target.is_symlink() or target.exists():
                target.unlink()
            target.symlink_to(source)
            count += 1
    return count


LAUNCHER = """#!{python}
# {name}: the {package} executable `ros2 run {package} {name}` starts (written by
# scripts/link_data_files.py, as colcon installs an ament_python console script)
import sys

from {module} import {function}

if __name__ == "__main__":
    sys.exit({function}())
"""


def write_launchers(setup_py: Path, prefix: Path, python: str | Path) -> list[Path]:
    """Write ``<prefix>/lib/<package>/<name>`` for every console script of ``setup_py``.

    Each is an executable Python script run by ``python`` that calls the entry point, what
    colcon installs for an ament_python package; launchers of console scripts that are no
    longer declared are removed.  Returns the launchers written.
    """
    kwargs = read_setup_kwargs(setup_py)
    package = kwargs["name"]
    scripts = kwargs.get("entry_points", {}).get("console_scripts", [])
    target_dir = prefix / "lib" / package
    target_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for entry in scripts:
        name, target = (part.strip() for part in entry.split("=", 1))
        module, function = (part.strip() for part in target.split(":", 1))
        path = target_dir / name
        if path.is_symlink() or path.exists():
            path.unlink()
        path.write_text(LAUNCHER.format(python=python, name=name, package=package,
                                        module=module, function=function), encoding="utf-8")
        path.chmod(0o755)
        written.append(path)
    for stale in target_dir.iterdir():
        if stale not in written and stale.is_file() and stale.read_text(
                encoding="utf-8", errors="replace").find("scripts/link_data_files.py") >= 0:
            stale.unlink()
    return written


def main() -> int:
    if sys.prefix == sys.base_prefix:
        print("link_data_files: run this with the virtual environment python (.venv/bin/python)",
              file=sys.stderr)
        return 2
    count = link_data_files(ROOT / "setup.py", Path(sys.prefix))
    print(f"link_data_files: linked {count} data files into {sys.prefix}/share")
    launchers = write_launchers(ROOT / "setup.py", Path(sys.prefix), Path(sys.prefix) / "bin" /
                                "python")
    print(f"link_data_files: wrote {len(launchers)} executables into "
          f"{sys.prefix}/lib/{read_setup_kwargs(ROOT / 'setup.py')['name']} (ros2 run)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
