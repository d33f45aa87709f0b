"""Benchmarks with known truth: fixed seeds, a printed table, JSON results.

``pier-monitor bench`` runs them.  Each case returns a plain dict with at least
``case``, ``wall_s`` and ``device``; the command prints a table and can write the list
as JSON.
"""

from __future__ import annotations

import platform
import time
from typing import Any, Callable

import numpy as np

from .core.ground_motion import synthetic_near_fault
from .core.reference import table1_model
from .core.solver import HAVE_NUMBA, simulate

__all__ = ["bench_solver", "SUITES", "format_table"]


def bench_solver(repeats: int = 5) -> list[dict[str, Any]]:
    """Time 60 s of the Table 1 pier at a 1 ms step under the synthetic near-fault record.

    The first call includes numba's compilation (or loading its cache); the reported
    ``wall_s`` is the median of ``repeats`` further calls.
    """
    geometry, params = table1_model()
    gm = synthetic_near_fault(duration_s=60.0, pga_mps2=8.0)
    t0 = time.perf_counter()
    resp = simulate(geometry, params, gm.acc, gm.dt)
    first = time.perf_counter() - t0
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate(geometry, params, gm.acc, gm.dt)
        times.append(time.perf_counter() - t0)
    df = np.abs(resp.theta).max(axis=0) / params.yield_angles
    return [{
        "case": "solver_table1_60s_1ms",
        "description": "Newmark linear acceleration, 60 s at dt 1 ms, Table 1 pier, PGA 8 m/s2",
        "wall_s": float(np.median(times)),
        "first_call_s": first,
        "steps": int(round(gm.duration_s / 0.001)),
        "numba": HAVE_NUMBA,
        "device": f"cpu ({platform.processor() or platform.machine()})",
        "ductility_factors": [round(float(v), 3) for v in df],
    }]


SUITES: dict[str, Callable[[], list[dict[str, Any]]]] = {
    "solver": bench_solver,
}


def format_table(results: list[dict[str, Any]]) -> str:
    """A plain-text table of the benchmark results."""
    lines = [f"{'case':<34} {'wall_s':>9} {'first_s':>9}  notes"]
    for r in results:
        notes = ", ".join(f"{k}={v}" for k, v in r.items()
                          if k in ("numba", "steps", "ductility_factors"))
        lines.append(f"{r['case']:<34} {r['wall_s']:>9.3f} {r.get('first_call_s', float('nan')):>9.3f}"
                     f"  {notes}")
    return "\n".join(lines)
