"""Locating the package's data files (configurations, message definitions).

Installed, data files live under ``<prefix>/share/<package>/`` (``setup.py``'s
``data_files``, or ``rosidl`` for the message package), where ``<prefix>`` is the running
interpreter's ``sys.prefix`` or one of the ``AMENT_PREFIX_PATH`` entries of a sourced ROS
workspace.  In a source checkout they are found relative to the repository instead.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from pier_monitor.core.errors import ConfigError

__all__ = ["REPO_ROOT", "share_dirs", "find_share_path", "find_config_file"]

#: The repository root when running from a source checkout (``pier_monitor/core/..``/..).
REPO_ROOT = Path(__file__).resolve().parents[2]


def share_dirs(package: str) -> list[Path]:
    """Candidate ``share/<package>`` directories, most specific first.

    ``sys.prefix`` (a venv with the package installed into it) comes before the
    ``AMENT_PREFIX_PATH`` entries (a sourced ROS 2 workspace).  Directories that do not
    exist are left out.
    """
    prefixes = [Path(sys.prefix)]
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry:
            prefixes.append(Path(entry))
    seen: set[Path] = set()
    out: list[Path] = []
    for prefix in prefixes:
        candidate = prefix / "share" / package
        if candidate in seen:
            continue
        seen.add(candidate)
        if candidate.is_dir():
            out.append(candidate)
    return out


def find_share_path(package: str, relative: str | Path, repo_relative: str | Path) -> Path:
    """The installed ``share/<package>/<relative>``, else ``<repo>/<repo_relative>``.

    Parameters
    ----------
    package : str
        Package name of the share directory, e.g. ``"pier_monitor_msgs"``.
    relative : str or Path
        Path inside ``share/<package>``.
    repo_relative : str or Path
        Path inside the repository checkout, used when no installed copy exists.

    Raises
    ------
    FileNotFoundError
        If neither exists; the message lists every place that was tried.
    """
    tried: list[Path] = []
    for share in share_dirs(package):
        candidate = share / relative
        if candidate.exists():
            return candidate
        tried.append(candidate)
    if not tried:
        tried.append(Path(sys.prefix) / "share" / package / relative)
    candidate = REPO_ROOT / repo_relative
    if candidate.exists():
        return candidate
    tried.append(candidate)
    raise FileNotFoundError(
        f"{Path(relative).name} not found; looked in: " + ", ".join(str(p) for p in tried))


def find_config_file(name: str) -> Path:
    """A pier configuration shipped with the package, e.g. ``"edefense_like.yaml"``.

    Looks in ``share/pier_monitor/config`` (installed) and then in the repository's
    ``config/`` directory.

    Raises
    ------
    ConfigError
        If the file is in neither place.
    """
    try:
        return find_share_path("pier_monitor", Path("config") / name, Path("config") / name)
    except FileNotFoundError as err:
        raise ConfigError(f"pier configuration {err}") from err
