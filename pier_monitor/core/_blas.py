"""One BLAS thread for the small dense algebra of an identification.

The field reconstruction's least-squares fits factorise Jacobians of a few thousand rows
and a few dozen columns hundreds of times.  OpenBLAS spreads such a factorisation over
every core; on a shared 2-core machine under load its threads wait for each other, and an
SVD that takes 5 ms on one thread took 190 ms of CPU time (the joint fit of a sparse
event went from 4 s to 44 s).  :func:`single_blas_thread` runs a function with one BLAS
thread in the calling thread and restores the previous count after it (results on the
held-out benchmark's cases: the same numbers).

Only OpenBLAS (the numpy and scipy wheels' BLAS) is limited, through its
``openblas_set_num_threads_local``; elsewhere, and where the environment sets a thread
count (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``), nothing changes.
"""

from __future__ import annotations

import ctypes
import functools
import os
from typing import Callable, TypeVar

F = TypeVar("F", bound=Callable)

__all__ = ["single_blas_thread"]

#: Setters of the OpenBLAS libraries seen loaded, by path (None: the library has none).
_SETTERS: dict[str, Callable[[int], int] | None] = {}


def _setters() -> list[Callable[[int], int]]:
    """``openblas_set_num_threads_local`` of every OpenBLAS loaded in this process."""
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower()}
    except OSError:  # not Linux
        return []
    out = []
    for path in sorted(p for p in paths if p.startswith("/")):
        if path not in _SETTERS:
            try:
                fn = getattr(ctypes.CDLL(path), "openblas_set_num_threads_local", None)
            except OSError:
                fn = None
            if fn is not None:
                fn.argtypes = [ctypes.c_int]
                fn.restype = ctypes.c_int
            _SETTERS[path] = fn
        if _SETTERS[path] is not None:
            out.append(_SETTERS[path])
    return out


def single_blas_thread(fn: F) -> F:
    """``fn`` run with one OpenBLAS thread in the calling thread (see the module doc)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if "OPENBLAS_NUM_THREADS" in os.environ or "OMP_NUM_THREADS" in os.environ:
            return fn(*args, **kwargs)
        setters = _setters()
        previous = [set_threads(1) for set_threads in setters]
        try:
            return fn(*args, **kwargs)
        finally:
            for set_threads, n in zip(setters, previous):
                set_threads(max(int(n), 1))

    return wrapper  # type: ignore[return-value]
