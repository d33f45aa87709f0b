"""Reference cases with known truth (the paper's simulation pier)."""

from __future__ import annotations

import numpy as np

from .config import PierGeometry, SpringParameters

__all__ = ["table1_model"]


def table1_model() -> tuple[PierGeometry, SpringParameters]:
    """The pier of the paper's Table 1, SI units.

    Six 1 m sections; masses 14.4, 9.6 (x4) and 1033.8 t; ``k1 = [1, 0.9, 1, 1, 1, 1]·10⁹``
    N·m/rad, ``k2 = k1/10``, ``fy = [5, 4.5, 5, 5, 5, 5]·10⁶`` N·m,
    ``c = [2, 2.2, 2, 2, 2, 2]·10⁷`` N·m·s/rad.  ``config/table1.yaml`` holds the same.
    """
    k1 = np.array([1.0, 0.9, 1.0, 1.0, 1.0, 1.0]) * 1e9
    return (PierGeometry(np.ones(6), np.array([14.4, 9.6, 9.6, 9.6, 9.6, 1033.8]) * 1e3),
            SpringParameters(k1, k1 / 10, np.array([5, 4.5, 5, 5, 5, 5]) * 1e6,
                             np.array([2, 2.2, 2, 2, 2, 2]) * 1e7))
