"""Writing files so that a reader never sees half of one (the package's one way to do it)."""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from pathlib import Path

__all__ = ["atomic_path", "remove_temporaries"]

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
