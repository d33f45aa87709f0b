"""Optional numba compilation of the core's time-stepping loops.

The loops are written so that they run unchanged as plain Python when numba is not
installed (slower, identical results).
"""

from __future__ import annotations

from typing import Callable, TypeVar

F = TypeVar("F", bound=Callable)

try:  # pragma: no cover - depends on the environment
    from numba import njit as _njit

    HAVE_NUMBA = True

    def jit(fn: F) -> F:
        """Compile ``fn`` with numba (cached on disk, GIL released)."""
        return _njit(cache=True, nogil=True)(fn)

    def jit_inline(fn: F) -> F:
        """Compile ``fn`` with numba, inlined into every compiled caller (a small step
        function called once per sample: its state then stays in registers)."""
        return _njit(cache=True, nogil=True, inline="always")(fn)

except ImportError:  # pragma: no cover
    HAVE_NUMBA = False

    def jit(fn: F) -> F:
        """numba is not installed: run ``fn`` as plain Python."""
        return fn

    def jit_inline(fn: F) -> F:
        """numba is not installed: run ``fn`` as plain Python."""
        return fn

__all__ = ["HAVE_NUMBA", "jit", "jit_inline"]
