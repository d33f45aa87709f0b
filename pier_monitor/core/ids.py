"""Ids that become names on disk, and output paths confined to their root.

A pier id comes from a configuration file, a bag or a ROS message; an event id is made
from it.  Both become directory and file names, so both are checked where they enter:
1 to :data:`ID_MAX_LEN` characters of ``[A-Za-z0-9_-]`` (no separator, no dot, so no
``..``, no absolute path, no hidden file).  :func:`safe_child` is the one way to put such a
name under an output root.
"""

from __future__ import annotations

import re
from pathlib import Path

from pier_monitor.core.errors import UnsafeNameError

__all__ = ["ID_MAX_LEN", "EVENT_ID_MAX_LEN", "ID_PATTERN", "check_id", "safe_child"]

#: Longest pier id (and any other id unless stated), characters.
ID_MAX_LEN = 64
#: Longest event id: a pier id, ``_`` and a UTC time stamp fit with room to spare.
EVENT_ID_MAX_LEN = 96
#: Characters an id may hold.
ID_PATTERN = re.compile(r"[A-Za-z0-9_-]+")


def check_id(kind: str, value: object, *, max_len: int = ID_MAX_LEN) -> str:
    """Return ``value`` if it is a safe id, else raise naming ``kind`` and the value.

    Parameters
    ----------
    kind : str
        What the id is, for the message (``"pier_id"``, ``"event_id"``).
    value : object
        The id; must be a ``str`` of 1 to ``max_len`` characters of ``[A-Za-z0-9_-]``.
    max_len : int, optional
        Longest accepted id, characters.

    Raises
    ------
    UnsafeNameError
        Naming ``kind``, the offending value and what is allowed.
    """
    if not isinstance(value, str):
        raise UnsafeNameError(f"{kind}: expected a string, got {type(value).__name__} {value!r}")
    if not value:
        raise UnsafeNameError(f"{kind}: empty; expected 1 to {max_len} characters of "
                              "A-Z, a-z, 0-9, '_' and '-'")
    if len(value) > max_len:
        raise UnsafeNameError(f"{kind}: {len(value)} characters ({value[:40]!r}...); at most "
                              f"{max_len} are allowed")
    if not ID_PATTERN.fullmatch(value):
        bad = sorted({c for c in value if not ID_PATTERN.fullmatch(c)})
        raise UnsafeNameError(f"{kind}: {value!r} holds {''.join(bad)!r}; only A-Z, a-z, 0-9, "
                              "'_' and '-' are allowed (an id becomes a directory name)")
    return value


def safe_child(root: str | Path, name: str) -> Path:
    """``root / name`` resolved, refused unless it lies strictly inside ``root``.

    ``name`` may have several parts (``"run1/window.npz"``); symbolic links are resolved,
    so a link that points out of ``root`` is refused as well.

    Raises
    ------
    UnsafeNameError
        Naming ``name`` and ``root`` when the result would not be below ``root``.
    """
    base = Path(root).resolve()
    if not isinstance(name, str) or not name or Path(name).is_absolute():
        raise UnsafeNameError(f"output name {name!r}: expected a relative path below {base}")
    target = (base / name).resolve()
    if target == base or base not in target.parents:
        raise UnsafeNameError(f"output name {name!r} resolves to {target}, outside {base}")
    return target
