"""Finding the bags of a fleet: rosbag2 directories and ``.mcap`` files under given paths."""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Sequence
from pathlib import Path

from pier_monitor.core.errors import BagError
from pier_monitor.report.results import DAMAGE_STATE_MCAP, RESULT_JSON
from pier_monitor.store import FAILED_JSON, WINDOW_NPZ

__all__ = ["bag_fingerprint", "bag_key", "find_bags"]

_ROSBAG2_METADATA = "metadata.yaml"
#: Files of a results directory: a directory holding one is not searched for bags.
_RESULT_FILES = (RESULT_JSON, FAILED_JSON, WINDOW_NPZ)
#: mcap files this package writes as results, never bags.
_RESULT_MCAPS = (DAMAGE_STATE_MCAP, "fleet_state.mcap")


def _is_rosbag2(path: Path) -> bool:
    return path.is_dir() and (path / _ROSBAG2_METADATA).is_file()


def _walk(root: Path, skip: set[Path]) -> Iterable[Path]:
    """Bags under the directory ``root``, depth first, sorted by name."""
    try:
        entries = sorted(root.iterdir())
    except OSError as err:
        raise BagError(f"{root}: cannot list the directory: {err.strerror or err}") from err
    if any((root / name).is_file() for name in _RESULT_FILES):
        return
    for entry in entries:
        if entry.name.startswith(".") or entry.resolve() in skip:
            continue
        if _is_rosbag2(entry):
            yield entry
        elif entry.is_dir():
            yield from _walk(entry, skip)
        elif entry.suffix.lower() == ".mcap" and entry.name not in _RESULT_MCAPS:
            yield entry


def find_bags(paths: Sequence[str | Path], *, exclude: Sequence[str | Path] = ()) -> list[Path]:
    """The bags named by ``paths``: each a bag, or a directory searched for bags.

    A bag is a rosbag2 directory (it holds ``metadata.yaml``) or a ``.mcap`` file.  In a
    directory, bags are found at any depth, in name order; hidden entries, the directories
    of ``exclude`` (e.g. the results root), results directories and the mcap files this
    package writes as results are left out.  A bag named twice counts once.

    Raises
    ------
    BagError
        Naming a path that does not exist, or that is neither a bag nor a directory; or,
        when no bag is found at all, the paths searched.
    """
    skip = {Path(p).resolve() for p in exclude}
    found: list[Path] = []
    seen: set[Path] = set()
    for raw in paths:
        path = Path(raw)
        if not path.exists():
            raise BagError(f"{path}: no such bag or directory")
        if _is_rosbag2(path) or (path.is_file() and path.suffix.lower() == ".mcap"):
            bags: Iterable[Path] = [path]
        elif path.is_dir():
            bags = _walk(path, skip)
        else:
            raise BagError(f"{path}: not a bag (a rosbag2 directory or an .mcap file) nor a "
                           "directory of bags")
        for bag in bags:
            if bag.resolve() not in seen:
                seen.add(bag.resolve())
                found.append(bag)
    if not found:
        raise BagError(f"no bags (rosbag2 directories or .mcap files) in "
                       f"{', '.join(str(p) for p in paths)}")
    return found


def bag_fingerprint(bag: Path) -> str:
    """Size and modification time of every file of a bag, hashed: it changes when the bag does.

    Raises
    ------
    BagError
        Naming the bag, if its files cannot be read.
    """
    files = sorted(p for p in bag.rglob("*") if p.is_file()) if bag.is_dir() else [bag]
    digest = hashlib.sha256()
    try:
        for f in files:
            st = f.stat()
            digest.update(f"{f.relative_to(bag) if bag.is_dir() else f.name}:{st.st_size}:"
                          f"{st.st_mtime_ns}\n".encode())
    except OSError as err:
        raise BagError(f"{bag}: cannot read the bag's files: {err.strerror or err}") from err
    return digest.hexdigest()


def bag_key(bag: Path) -> str:
    """A file name for the bag's record in the results root: its name and a path hash."""
    digest = hashlib.sha256(str(bag.resolve()).encode()).hexdigest()[:12]
    return f"{bag.name}-{digest}"
