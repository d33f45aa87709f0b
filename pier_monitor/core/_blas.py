"""One BLAS thread for the small dense algebra of an identification.

The field reconstruction's least-squares fits factorise Jacobians of a few thousand rows
and a few dozen columns hundreds of times.  OpenBLAS spreads such a factorisation over
every core; on a shared 2-core machine under load its threads wait for each other, and an
SVD that takes 5 ms on one thread took 190 ms of CPU time (the joint fit of a sparse
event went from 4 s to 44 s).  :func:`single_blas_thread` runs a function with one BLAS
thread and restores the previous count after it (results on the held-out benchmark's
cases: the same numbers as with ``OPENBLAS_NUM_THREADS=1``).

Only OpenBLAS (the numpy and scipy wheels' BLAS) is limited, through its
``openblas_set_num_threads_local``; elsewhere, and where the environment sets a thread
count (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``), nothing changes.
"""

from __future__ import annotations

import ctypes
import functools
import os
import threading
from typing import Callable, TypeVar

F = TypeVar("F", bound=Callable)

__all__ = ["single_blas_thread"]

#: Setters of the OpenBLAS libraries seen loaded, by path (None: the library has none).
_SETTERS: dict[str, Callable[[int], int] | None] = {}
#: Calls of :func:`single_blas_thread` functions running now, and the counts to restore
#: when the last returns.
_LOCK = threading.Lock()
_ACTIVE = 0
_BEFORE: list[tuple[Callable[[int], int], int]] = []


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
    """``fn`` run with one OpenBLAS thread (see the module doc).

    ``openblas_set_num_threads_local`` sets the calling thread's count in an OpenMP build
    and the process's in a pthreads build (the wheels'); so that calls in several threads
    at once do not restore each other's count in the middle of a fit, the count in force
    before the first of them is restored when the last one returns."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        global _ACTIVE
        if "OPENBLAS_NUM_THREADS" in os.environ or "OMP_NUM_THREADS" in os.environ:
            return fn(*args, **kwargs)
        with _LOCK:
            for set_threads in _setters():
                before = set_threads(1)
                if not any(s is set_threads for s, _ in _BEFORE):
                    _BEFORE.append((set_threads, before))
            _ACTIVE += 1
        try:
            return fn(*args, **kwargs)
        finally:
            with _LOCK:
                _ACTIVE -= 1
                if _ACTIVE == 0:
                    for set_threads, before in _BEFORE:
                        set_threads(max(int(before), 1))
                    _BEFORE.clear()

    return wrapper  # type: ignore[return-value]
