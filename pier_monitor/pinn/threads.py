"""How many CPU threads the identifier uses in this process."""

from __future__ import annotations

import torch

from pier_monitor.core.errors import InputDataError

__all__ = ["set_threads"]


def set_threads(n: int) -> None:
    """Train with ``n`` CPU threads in this process (e.g. one per worker of a pool).

    Workers that share a machine each take their share of its cores; left alone, every
    worker's torch would use all of them and the workers would slow each other down.
    """
    if n < 1:
        raise InputDataError(f"threads: expected a positive number, got {n}")
    if torch.get_num_threads() != n:
        torch.set_num_threads(n)
