"""Helpers shared by the report modules: checks, unit prefixes, file writing."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from pier_monitor.core.identify.damage import IdentificationResult
from pier_monitor.core.errors import ReportError
from pier_monitor.core.fileio import atomic_path

__all__ = ["STATE_COLORS", "check_same_pier", "engineering_scale", "ensure_dir", "format_df",
           "format_interval",
           "atomic_write_text"]

#: Tolerance on section boundaries when two results are said to be of the same pier, m.
Z_TOL_M = 1e-6

#: Colour of each section state in figures and markers: intact green, suspicious amber,
#: damaged red, no diagnosis (unknown, unreliable) grey.
STATE_COLORS = {"intact": "#2ca02c", "suspicious": "#ffbf00", "damaged": "#d62728",
                "unknown": "#9e9e9e", "unreliable": "#9e9e9e"}

_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"))


def engineering_scale(values: np.ndarray | Sequence[float] | float, unit: str
                      ) -> tuple[float, str]:
    """Divisor and prefixed unit that bring the largest ``|value|`` into [1, 1000).

    Parameters
    ----------
    values : array_like
        Values in the SI ``unit``.
    unit : str
        The SI unit, e.g. ``"N·m/rad"``, ``"rad"``, ``"m"``.

    Returns
    -------
    factor : float
        Divide the values by it.
    label : str
        The unit with its prefix, e.g. ``"GN·m/rad"``, ``"mrad"``.
    """
    arr = np.abs(np.asarray(values, dtype=float))
    arr = arr[np.isfinite(arr)]
    peak = float(arr.max()) if arr.size else 0.0
    if peak == 0.0:
        return 1.0, unit
    for factor, prefix in _PREFIXES:
        if peak >= factor:
            return factor, prefix + unit
    return _PREFIXES[-1][0], _PREFIXES[-1][1] + unit


def format_df(df: float, yielded: bool, *, bound: str = "≤ ") -> str:
    """A ductility factor as text; ``bound`` (``≤ ``) marks the upper bound of a spring that
    never yielded (e.g. ``≤ 1.00``): it did not yield, its DF is not "at yield".

    ``bound="<="`` gives ASCII (marker text, which some displays cannot draw otherwise).
    """
    if not np.isfinite(df):
        return "n/a"
    return f"{df:.2f}" if yielded else f"{bound}{df:.2f}"


def format_interval(lo: float | None, hi: float | None, fmt: str = ".2f") -> str:
    """A 90 % interval as ``[lo, hi]`` in the format ``fmt``; ``n/a`` when not known."""
    if lo is None or hi is None or not (np.isfinite(lo) and np.isfinite(hi)):
        return "n/a"
    return f"[{lo:{fmt}}, {hi:{fmt}}]"


def check_same_pier(results: Sequence[IdentificationResult],
                    names: Sequence[str] | None = None) -> None:
    """Raise unless all results are of one pier: same ``pier_id`` and section boundaries.

    Parameters
    ----------
    results : sequence of IdentificationResult
        At least one.
    names : sequence of str, optional
        How to call each result in the message (default ``"A"``, ``"B"``, ...).

    Raises
    ------
    ReportError
        Naming the results and the field (pier, number of sections, a section's span)
        that differs.
    """
    if not results:
        raise ReportError("no identification results given")
    names = list(names) if names is not None else [chr(ord("A") + i) for i in range(len(results))]
    ref, ref_name = results[0], names[0]

    def who(r: IdentificationResult, name: str) -> str:
        return f"{name} (pier {r.pier_id!r}, event {r.event_id!r})"

    for r, name in zip(results[1:], names[1:]):
        if r.pier_id != ref.pier_id:
            raise ReportError(f"results are of different piers: {who(ref, ref_name)} and "
                              f"{who(r, name)}; compare events of the same pier")
        if len(r.sections) != len(ref.sections):
            raise ReportError(f"results have different geometry: {who(ref, ref_name)} has "
                              f"{len(ref.sections)} sections, {who(r, name)} has "
                              f"{len(r.sections)}")
        for s0, s1 in zip(ref.sections, r.sections):
            if (abs(s0.z_bottom_m - s1.z_bottom_m) > Z_TOL_M
                    or abs(s0.z_top_m - s1.z_top_m) > Z_TOL_M):
                raise ReportError(
                    f"results have different geometry: section {s0.index + 1} spans "
                    f"{s0.z_bottom_m:g}-{s0.z_top_m:g} m in {who(ref, ref_name)} but "
                    f"{s1.z_bottom_m:g}-{s1.z_top_m:g} m in {who(r, name)}")


def ensure_dir(path: str | Path) -> Path:
    """Create ``path`` (and parents) if needed; raise :class:`ReportError` naming it if not."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ReportError(f"{path}: cannot create the output directory: "
                          f"{err.strerror or err}") from err
    if not path.is_dir():
        raise ReportError(f"{path}: output path exists and is not a directory")
    if not os.access(path, os.W_OK | os.X_OK):
        raise ReportError(f"{path}: output directory is not writable")
    return path


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (:func:`~pier_monitor.core.fileio.atomic_path`).

    Raises
    ------
    ReportError
        Naming the path, if it cannot be written.
    """
    try:
        with atomic_path(path) as tmp:
            tmp.write_text(text, encoding="utf-8")
    except OSError as err:
        raise ReportError(f"{path}: cannot write: {err.strerror or err}") from err
