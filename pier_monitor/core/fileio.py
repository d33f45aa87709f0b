"""Writing files so that a reader never sees half of one, and JSON that strict readers accept
(the package's one way to do each).

Strict JSON (RFC 8259) has no ``NaN`` or ``Infinity``.  Every JSON the package writes goes
through :func:`to_strict_json`: a float that is not finite is written as ``null``, and a value
that still is not strict JSON raises instead of being written.  The schema rule that goes with
it: **a number field that holds** ``null`` **is not a number** (not identified, not known);
readers turn it back into NaN with :func:`nan_if_none` where they expect a float.  A field
that is optional by its schema (e.g. a ``k1`` change without a baseline) is ``null`` when
absent, as before.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import threading
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

__all__ = ["atomic_path", "finite_or_none", "nan_if_none", "remove_temporaries",
           "to_strict_json"]

#: Names of the temporary files :func:`atomic_path` writes (``.<name>.<pid>.<thread>.tmp``).
_TEMPORARY_GLOB = ".*.*.*.tmp"


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` atomically.

    Write the whole file to the yielded path inside the ``with`` block.  When the block
    raises, the temporary file is removed and ``path`` is left as it was; ``OSError`` of the
    final rename propagates (callers turn it into their own error naming the file).

    The temporary name is hidden (leading dot), in the same directory (the rename stays on
    one file system) and unique per process and thread.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
        raise


def remove_temporaries(directory: str | Path) -> list[Path]:
    """Remove the temporary files of :func:`atomic_path` left in ``directory``; return them.

    A process killed while writing (SIGKILL, out of memory, a broken process pool) leaves
    its temporary file behind.  Call this only where no other writer can be at work in
    ``directory`` (e.g. an event directory whose identification is starting anew).
    """
    removed = []
    for tmp in Path(directory).glob(_TEMPORARY_GLOB):
        with contextlib.suppress(OSError):
            tmp.unlink()
            removed.append(tmp)
    return removed


def finite_or_none(obj: Any) -> Any:
    """``obj`` with every float that is not finite (NaN, ±inf) replaced by None.

    Recurses into mappings (keys made ``str``), lists and tuples (as lists); NumPy scalars
    and arrays become Python numbers and lists.  Other values are returned as they are.
    """
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {k if isinstance(k, str) else str(k): finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite_or_none(v) for v in obj]
    tolist = getattr(obj, "tolist", None)  # NumPy scalars and arrays, without importing NumPy
    if callable(tolist):
        return finite_or_none(tolist())
    return obj


def to_strict_json(obj: Any, *, indent: int | None = None) -> str:
    """``obj`` as strict JSON text: non-finite floats as ``null`` (:func:`finite_or_none`).

    Raises
    ------
    ValueError
        If a value is still not strict JSON (``allow_nan=False``).
    TypeError
        If a value is not JSON-serialisable.
    """
    return json.dumps(finite_or_none(obj), indent=indent, allow_nan=False)


def nan_if_none(value: Any) -> float:
    """A float read from strict JSON: ``null`` (None) is NaN (see the module documentation)."""
    return math.nan if value is None else float(value)
