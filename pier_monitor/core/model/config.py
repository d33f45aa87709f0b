"""Pier configuration: geometry, masses, design parameters and sensor map.

One YAML file describes one pier.  It is loaded into frozen, validated types;
every problem is reported as a :class:`~pier_monitor.core.errors.ConfigError`
that names the file and the dotted path of the offending field, e.g.
``table1.yaml: sections[2].k1_Nm_per_rad: expected a positive number, got -1.0``.

Layout of the file (SI units, names carry them)::

    pier_id: table1
    description: free text
    sample_rate_hz: 100.0            # rate of the recorded channels
    principal_direction_deg: null    # azimuth of the shaking direction, or null = estimate
    sections:                        # bottom to top; section n spans [z_{n-1}, z_n]
      - height_m: 1.0                # h_n
        mass_kg: 14400.0             # m_n, lumped at the top of the section (level n)
        k1_Nm_per_rad: 1.0e9         # design elastic stiffness of spring n (at level n-1)
        k2_Nm_per_rad: 1.0e8         # design second stiffness
        fy_Nm: 5.0e6                 # design yield moment
        c_Nms_per_rad: 2.0e7         # design rotational damping
    sensors:                         # optional
      - id: acc_l1_n
        topic: sensors/l1/acc_n      # relative ROS topic name
        level: 1                     # 0 = foundation, n = level n
        kind: acceleration           # acceleration | velocity | displacement
        unit: gal                    # see pier_monitor.core.model.units
        axes: [x, y, z]              # channel names as recorded
        orientation_deg: 90.0        # azimuth of the sensor's x axis in the pier frame
        signs: [1, -1, 1]            # per-axis sign of the mounting
        gain: 1.0                    # recorded = gain * true + offset (in ``unit``)
        offsets: [0.0, 0.0, 0.0]
        noise_rms: 0.1               # expected noise, in ``unit`` (optional)
        full_scale: 2000.0           # |recorded| above this is impossible, in ``unit``
                                     # (optional; accelerometers and velocity meters)
        location: north face         # free text (optional)
        rate_hz: 20.0                # own sampling rate (optional; default sample_rate_hz;
                                     # must divide sample_rate_hz into a whole number)
      - id: wire_l1_n                # a displacement transducer
        ...
        range: [0.0, 1000.0]         # recorded values outside are impossible, in ``unit``
                                     # (optional; displacement sensors)

``pier_id`` names directories on disk: 1 to 64 characters of ``[A-Za-z0-9_-]``
(:func:`pier_monitor.core.ids.check_id`).

Level ``n`` sits at height ``z_n = h_1 + ... + h_n``; the foundation is level 0 at ``z_0 = 0``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import yaml

from pier_monitor.core.errors import ConfigError, UnsafeNameError
from pier_monitor.core.ids import check_id
from pier_monitor.core.model.units import UNIT_FACTORS, to_si_factor

__all__ = [
    "SpringParameters",
    "PierGeometry",
    "SensorSpec",
    "PierConfig",
    "load_config",
    "config_from_yaml",
    "config_from_dict",
]

SENSOR_KINDS = tuple(UNIT_FACTORS)  # acceleration, velocity, displacement


def _frozen(values: Sequence[float] | np.ndarray) -> np.ndarray:
    arr = np.array(values, dtype=float)
    arr.setflags(write=False)
    return arr


def _arrays_equal(a: object, b: object, names: tuple[str, ...]) -> bool:
    return type(a) is type(b) and all(
        np.array_equal(getattr(a, n), getattr(b, n)) for n in names)


@dataclass(frozen=True, eq=False)
class SpringParameters:
    """Dynamic parameters of the ``N`` bilinear rotational springs and dampers.

    Attributes
    ----------
    k1 : ndarray, shape (N,)
        Elastic (first) stiffness, N·m/rad.
    k2 : ndarray, shape (N,)
        Second (post-yield) stiffness, N·m/rad; ``0 <= k2 < k1``.
    fy : ndarray, shape (N,)
        Yield moment, N·m.
    c : ndarray, shape (N,)
        Rotational viscous damping, N·m·s/rad.
    """

    k1: np.ndarray
    k2: np.ndarray
    fy: np.ndarray
    c: np.ndarray

    def __post_init__(self) -> None:
        arrays = {}
        for name in ("k1", "k2", "fy", "c"):
            arr = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            if arr.ndim != 1 or arr.size == 0:
                raise ConfigError(f"{name}: expected a 1-D array of N values, got shape {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ConfigError(f"{name}: expected finite values, got {arr.tolist()}")
            arrays[name] = arr
        n = arrays["k1"].size
        for name, arr in arrays.items():
            if arr.size != n:
                raise ConfigError(f"{name}: expected {n} values (one per spring), got {arr.size}")
        for name in ("k1", "fy"):
            bad = np.flatnonzero(arrays[name] <= 0)
            if bad.size:
                raise ConfigError(
                    f"{name}[{bad[0]}]: expected a positive value, got {arrays[name][bad[0]]}")
        for name in ("k2", "c"):
            bad = np.flatnonzero(arrays[name] < 0)
            if bad.size:
                raise ConfigError(
                    f"{name}[{bad[0]}]: expected a non-negative value, got {arrays[name][bad[0]]}")
        bad = np.flatnonzero(arrays["k2"] >= arrays["k1"])
        if bad.size:
            i = bad[0]
            raise ConfigError(
                f"k2[{i}]: second stiffness must be below the elastic stiffness, got "
                f"k2={arrays['k2'][i]:g} >= k1={arrays['k1'][i]:g}")
        for name, arr in arrays.items():
            object.__setattr__(self, name, _frozen(arr))

    def __eq__(self, other: object) -> bool:
        return _arrays_equal(self, other, ("k1", "k2", "fy", "c"))

    __hash__ = None  # type: ignore[assignment]

    @property
    def n_springs(self) -> int:
        """Number of springs ``N``."""
        return int(self.k1.size)

    @property
    def yield_angles(self) -> np.ndarray:
        """Yield angle ``θy = fy / k1`` of each spring, rad, shape (N,)."""
        return self.fy / self.k1

    def scaled(self, k1: float = 1.0, k2: float = 1.0, fy: float = 1.0,
               c: float = 1.0) -> "SpringParameters":
        """Return a copy with every parameter multiplied by the given factor."""
        return SpringParameters(self.k1 * k1, self.k2 * k2, self.fy * fy, self.c * c)

    def as_dict(self) -> dict[str, list[float]]:
        """Plain-list form, for JSON and YAML."""
        return {name: getattr(self, name).tolist() for name in ("k1", "k2", "fy", "c")}


@dataclass(frozen=True, eq=False)
class PierGeometry:
    """Heights and lumped masses of the link model.

    Attributes
    ----------
    section_heights_m : ndarray, shape (N,)
        ``h_n``, the height of section ``n`` (between levels ``n-1`` and ``n``), m.
    masses_kg : ndarray, shape (N,)
        ``m_n``, the mass lumped at level ``n``, kg.
    """

    section_heights_m: np.ndarray
    masses_kg: np.ndarray

    def __post_init__(self) -> None:
        h = np.atleast_1d(np.asarray(self.section_heights_m, dtype=float))
        m = np.atleast_1d(np.asarray(self.masses_kg, dtype=float))
        for name, arr in (("section_heights_m", h), ("masses_kg", m)):
            if arr.ndim != 1 or arr.size == 0:
                raise ConfigError(f"{name}: expected a 1-D array of N values, got shape {arr.shape}")
            bad = np.flatnonzero(~np.isfinite(arr) | (arr <= 0))
            if bad.size:
                raise ConfigError(
                    f"{name}[{bad[0]}]: expected a positive finite value, got {arr[bad[0]]}")
        if h.size != m.size:
            raise ConfigError(
                f"masses_kg: expected {h.size} values (one per section), got {m.size}")
        object.__setattr__(self, "section_heights_m", _frozen(h))
        object.__setattr__(self, "masses_kg", _frozen(m))

    def __eq__(self, other: object) -> bool:
        return _arrays_equal(self, other, ("section_heights_m", "masses_kg"))

    __hash__ = None  # type: ignore[assignment]

    @property
    def n_levels(self) -> int:
        """Number of lumped masses ``N`` (levels above the foundation)."""
        return int(self.section_heights_m.size)

    @property
    def level_heights_m(self) -> np.ndarray:
        """Heights ``z_0 = 0, z_1, ..., z_N`` of the levels, m, shape (N+1,)."""
        return np.concatenate(([0.0], np.cumsum(self.section_heights_m)))


@dataclass(frozen=True)
class SensorSpec:
    """One physical sensor and how its recorded channels map to the pier frame.

    A recorded channel ``j`` of a sensor at ``level`` is modelled as::

        recorded_j = gain * signs_j * (u · e_j) / unit_factor + offsets_j + noise

    where ``u`` is the true horizontal (x, y) or vertical (z) motion in the pier frame
    in SI units and ``e_j`` the unit vector of axis ``j``: axis ``x`` points at azimuth
    ``orientation_deg`` (counter-clockwise from the pier's X axis), ``y`` at
    ``orientation_deg + 90``, ``z`` up.  A displacement transducer usually has a single
    axis ``x`` pointing along its wire.

    ``full_scale`` (accelerometers, velocity meters) and ``value_range`` (displacement
    sensors; ``range`` in the YAML file) bound the recorded values, in ``unit``: a sample
    beyond them is physically impossible and is treated as missing.  None = not known.

    ``rate_hz`` is the sensor's own sampling rate, Hz, for a sensor slower than the pier's
    ``sample_rate_hz`` (a GNSS receiver at 10 Hz among 200 Hz accelerometers); ``None``
    means the pier's rate (:meth:`PierConfig.sensor_rate_hz`).
    """

    sensor_id: str
    topic: str
    level: int
    kind: str
    unit: str
    axes: tuple[str, ...]
    orientation_deg: float = 0.0
    signs: tuple[float, ...] = ()
    gain: float = 1.0
    offsets: tuple[float, ...] = ()
    noise_rms: float = 0.0
    location: str = ""
    full_scale: float | None = None
    value_range: tuple[float, float] | None = None
    rate_hz: float | None = None

    def __post_init__(self) -> None:
        if not self.signs:
            object.__setattr__(self, "signs", tuple(1.0 for _ in self.axes))
        if not self.offsets:
            object.__setattr__(self, "offsets", tuple(0.0 for _ in self.axes))

    @property
    def si_factor(self) -> float:
        """Factor converting a value in ``unit`` to SI."""
        return to_si_factor(self.kind, self.unit)

    def axis_direction(self, axis: str) -> np.ndarray:
        """Unit vector (X, Y, Z) of one recorded axis in the pier frame, shape (3,)."""
        a = math.radians(self.orientation_deg)
        if axis == "x":
            return np.array([math.cos(a), math.sin(a), 0.0])
        if axis == "y":
            return np.array([-math.sin(a), math.cos(a), 0.0])
        if axis == "z":
            return np.array([0.0, 0.0, 1.0])
        raise ConfigError(f"sensor {self.sensor_id}: unknown axis {axis!r}")

    def as_dict(self) -> dict[str, Any]:
        """Plain form, as written in the YAML file (optional fields only when set)."""
        return {
            "id": self.sensor_id, "topic": self.topic, "level": self.level, "kind": self.kind,
            "unit": self.unit, "axes": list(self.axes), "orientation_deg": self.orientation_deg,
            "signs": list(self.signs), "gain": self.gain, "offsets": list(self.offsets),
            "noise_rms": self.noise_rms, "location": self.location,
            **({"full_scale": self.full_scale} if self.full_scale is not None else {}),
            **({"range": list(self.value_range)} if self.value_range is not None else {}),
            **({"rate_hz": self.rate_hz} if self.rate_hz is not None else {}),
        }

    def recorded_bounds(self) -> tuple[float, float] | None:
        """Lowest and highest possible recorded value, in ``unit``; None when not known."""
        if self.full_scale is not None:
            return (-self.full_scale, self.full_scale)
        return self.value_range


def _rate_problem(rate_hz: float, pier_rate_hz: float) -> str | None:
    """Why a sensor's own rate does not fit the pier's rate, or ``None`` when it does."""
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        return f"expected a positive number, got {rate_hz}"
    ratio = pier_rate_hz / rate_hz
    if round(ratio) < 1 or abs(ratio - round(ratio)) > 1e-9 * ratio:
        return (f"must divide the pier's sample_rate_hz={pier_rate_hz:g} into a whole number, "
                f"got {rate_hz:g}")
    return None


@dataclass(frozen=True)
class PierConfig:
    """A validated pier configuration (see the module docstring for the file layout)."""

    pier_id: str
    geometry: PierGeometry
    design: SpringParameters
    sample_rate_hz: float = 100.0
    principal_direction_deg: float | None = None
    sensors: tuple[SensorSpec, ...] = ()
    description: str = ""
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        try:
            check_id("pier_id", self.pier_id)
        except UnsafeNameError as err:
            raise ConfigError(f"{self.source}: {err}" if self.source else str(err)) from None
        if self.design.n_springs != self.geometry.n_levels:
            raise ConfigError(
                f"{self.source or self.pier_id}: design parameters have {self.design.n_springs} "
                f"springs but the geometry has {self.geometry.n_levels} sections")
        for s in self.sensors:
            problem = None if s.rate_hz is None else _rate_problem(s.rate_hz, self.sample_rate_hz)
            if problem:
                raise ConfigError(f"{self.source or self.pier_id}: sensor {s.sensor_id}: "
                                  f"rate_hz: {problem}")

    @property
    def n_levels(self) -> int:
        """Number of levels above the foundation (= sections = springs), ``N``."""
        return self.geometry.n_levels

    def sensors_at(self, level: int, kind: str | None = None) -> tuple[SensorSpec, ...]:
        """Sensors at a level, optionally of one kind."""
        return tuple(s for s in self.sensors
                     if s.level == level and (kind is None or s.kind == kind))

    def sensor_rate_hz(self, sensor: SensorSpec) -> float:
        """Sampling rate of a sensor of the map, Hz: its own ``rate_hz``, else the pier's."""
        return self.sample_rate_hz if sensor.rate_hz is None else sensor.rate_hz

    def sensor(self, sensor_id: str) -> SensorSpec:
        """The sensor with this id; :class:`ConfigError` if there is none."""
        for s in self.sensors:
            if s.sensor_id == sensor_id:
                return s
        raise ConfigError(f"{self.source or self.pier_id}: no sensor with id {sensor_id!r}")

    def as_dict(self) -> dict[str, Any]:
        """Plain form that :func:`config_from_dict` reads back to an equal configuration."""
        g, d = self.geometry, self.design
        return {
            "pier_id": self.pier_id,
            "description": self.description,
            "sample_rate_hz": self.sample_rate_hz,
            "principal_direction_deg": self.principal_direction_deg,
            "sections": [
                {"height_m": float(g.section_heights_m[i]), "mass_kg": float(g.masses_kg[i]),
                 "k1_Nm_per_rad": float(d.k1[i]), "k2_Nm_per_rad": float(d.k2[i]),
                 "fy_Nm": float(d.fy[i]), "c_Nms_per_rad": float(d.c[i])}
                for i in range(self.n_levels)
            ],
            "sensors": [s.as_dict() for s in self.sensors],
        }

    def to_yaml(self) -> str:
        """YAML text of :meth:`as_dict`."""
        return yaml.safe_dump(self.as_dict(), sort_keys=False)


# ---------------------------------------------------------------------------------------------
# parsing


class _Ctx:
    """Builds error messages that name the file and the dotted field path."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, path: str, msg: str) -> ConfigError:
        prefix = f"{self.source}: " if self.source else ""
        return ConfigError(f"{prefix}{path}: {msg}")

    def number(self, mapping: Mapping[str, Any], key: str, path: str, *, positive: bool = False,
               nonneg: bool = False, default: Any = ...) -> float:
        if key not in mapping:
            if default is ...:
                raise self.fail(f"{path}.{key}" if path else key, "missing required field")
            return default
        value = mapping[key]
        where = f"{path}.{key}" if path else key
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(where, f"expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise self.fail(where, f"expected a finite number, got {value}")
        if positive and value <= 0:
            raise self.fail(where, f"expected a positive number, got {value}")
        if nonneg and value < 0:
            raise self.fail(where, f"expected a non-negative number, got {value}")
        return value

    def string(self, mapping: Mapping[str, Any], key: str, path: str, default: Any = ...) -> str:
        where = f"{path}.{key}" if path else key
        if key not in mapping:
            if default is ...:
                raise self.fail(where, "missing required field")
            return default
        value = mapping[key]
        if not isinstance(value, str) or (default is ... and not value):
            raise self.fail(where, f"expected a non-empty string, got {value!r}")
        return value


_SECTION_KEYS = {"height_m", "mass_kg", "k1_Nm_per_rad", "k2_Nm_per_rad", "fy_Nm", "c_Nms_per_rad"}
_SENSOR_KEYS = {"id", "topic", "level", "kind", "unit", "axes", "orientation_deg", "signs", "gain",
                "offsets", "noise_rms", "location", "full_scale", "range", "rate_hz"}
_TOP_KEYS = {"pier_id", "description", "sample_rate_hz", "principal_direction_deg", "sections",
             "sensors"}


def _check_keys(ctx: _Ctx, mapping: Mapping[str, Any], allowed: set[str], path: str) -> None:
    unknown = sorted(set(mapping) - allowed)
    if unknown:
        where = f"{path}.{unknown[0]}" if path else unknown[0]
        raise ctx.fail(where, f"unknown field (allowed: {', '.join(sorted(allowed))})")


def _parse_sensor(ctx: _Ctx, raw: Any, i: int, n_levels: int,
                  pier_rate_hz: float) -> SensorSpec:
    path = f"sensors[{i}]"
    if not isinstance(raw, Mapping):
        raise ctx.fail(path, f"expected a mapping, got {type(raw).__name__}")
    _check_keys(ctx, raw, _SENSOR_KEYS, path)
    sensor_id = ctx.string(raw, "id", path)
    kind = ctx.string(raw, "kind", path)
    if kind not in SENSOR_KINDS:
        raise ctx.fail(f"{path}.kind", f"expected one of {list(SENSOR_KINDS)}, got {kind!r}")
    unit = ctx.string(raw, "unit", path)
    if unit not in UNIT_FACTORS[kind]:
        raise ctx.fail(f"{path}.unit",
                       f"unknown unit {unit!r} for {kind}; expected one of {sorted(UNIT_FACTORS[kind])}")
    level = raw.get("level")
    if isinstance(level, bool) or not isinstance(level, int) or not 0 <= level <= n_levels:
        raise ctx.fail(f"{path}.level", f"expected an integer level 0..{n_levels}, got {level!r}")
    axes = raw.get("axes", ["x"])
    if (not isinstance(axes, list) or not axes
            or any(a not in ("x", "y", "z") for a in axes) or len(set(axes)) != len(axes)):
        raise ctx.fail(f"{path}.axes", f"expected a list of distinct axes from x, y, z, got {axes!r}")
    signs = raw.get("signs", [1] * len(axes))
    if (not isinstance(signs, list) or len(signs) != len(axes)
            or any(s not in (1, -1) or isinstance(s, bool) for s in signs)):
        raise ctx.fail(f"{path}.signs", f"expected {len(axes)} values of +1 or -1, got {signs!r}")
    offsets = raw.get("offsets", [0.0] * len(axes))
    if (not isinstance(offsets, list) or len(offsets) != len(axes)
            or any(isinstance(o, bool) or not isinstance(o, (int, float)) or not math.isfinite(o)
                   for o in offsets)):
        raise ctx.fail(f"{path}.offsets", f"expected {len(axes)} finite numbers, got {offsets!r}")
    gain = ctx.number(raw, "gain", path, default=1.0)
    if gain == 0:
        raise ctx.fail(f"{path}.gain", "expected a non-zero number, got 0")
    full_scale, value_range = _parse_bounds(ctx, raw, path, kind, unit, offsets)
    rate_hz = ctx.number(raw, "rate_hz", path, positive=True, default=None)
    problem = None if rate_hz is None else _rate_problem(rate_hz, pier_rate_hz)
    if problem:
        raise ctx.fail(f"{path}.rate_hz", problem)
    return SensorSpec(
        sensor_id=sensor_id,
        topic=ctx.string(raw, "topic", path),
        level=level,
        kind=kind,
        unit=unit,
        axes=tuple(axes),
        orientation_deg=ctx.number(raw, "orientation_deg", path, default=0.0),
        signs=tuple(float(s) for s in signs),
        gain=gain,
        offsets=tuple(float(o) for o in offsets),
        noise_rms=ctx.number(raw, "noise_rms", path, nonneg=True, default=0.0),
        location=ctx.string(raw, "location", path, default=""),
        full_scale=full_scale,
        value_range=value_range,
        rate_hz=rate_hz,
    )


def _parse_bounds(ctx: _Ctx, raw: Mapping[str, Any], path: str, kind: str, unit: str,
                  offsets: list[float]) -> tuple[float | None, tuple[float, float] | None]:
    """``full_scale`` (acceleration, velocity) and ``range`` (displacement) of a sensor."""
    full_scale = value_range = None
    if "full_scale" in raw:
        if kind == "displacement":
            raise ctx.fail(f"{path}.full_scale", "a displacement sensor states its range "
                           "[min, max] instead (field range)")
        full_scale = ctx.number(raw, "full_scale", path, positive=True)
        bad = [o for o in offsets if abs(o) >= full_scale]
        if bad:
            raise ctx.fail(f"{path}.full_scale", f"{full_scale:g} {unit} does not cover the "
                           f"offset {bad[0]:g} {unit} (the reading at rest)")
    if "range" in raw:
        if kind != "displacement":
            raise ctx.fail(f"{path}.range", f"only displacement sensors have a range; a "
                           f"{kind} sensor states its full_scale")
        r = raw["range"]
        if (not isinstance(r, list) or len(r) != 2
                or any(isinstance(v, bool) or not isinstance(v, (int, float))
                       or not math.isfinite(v) for v in r) or not r[0] < r[1]):
            raise ctx.fail(f"{path}.range", f"expected [min, max] with min < max in {unit}, "
                           f"got {r!r}")
        value_range = (float(r[0]), float(r[1]))
        bad = [o for o in offsets if not value_range[0] <= o <= value_range[1]]
        if bad:
            raise ctx.fail(f"{path}.range", f"{list(value_range)} {unit} does not hold the "
                           f"offset {bad[0]:g} {unit} (the reading at rest)")
    return full_scale, value_range


def config_from_dict(raw: Any, source: str = "") -> PierConfig:
    """Validate a parsed YAML mapping into a :class:`PierConfig`.

    Raises
    ------
    ConfigError
        Naming ``source`` and the dotted path of the first bad field.
    """
    ctx = _Ctx(source)
    if not isinstance(raw, Mapping):
        raise ctx.fail("(top level)", f"expected a mapping, got {type(raw).__name__}")
    _check_keys(ctx, raw, _TOP_KEYS, "")
    pier_id = ctx.string(raw, "pier_id", "")
    sections = raw.get("sections")
    if not isinstance(sections, list) or not sections:
        raise ctx.fail("sections", f"expected a non-empty list of sections, got {sections!r}")
    cols: dict[str, list[float]] = {k: [] for k in ("h", "m", "k1", "k2", "fy", "c")}
    for i, sec in enumerate(sections):
        path = f"sections[{i}]"
        if not isinstance(sec, Mapping):
            raise ctx.fail(path, f"expected a mapping, got {type(sec).__name__}")
        _check_keys(ctx, sec, _SECTION_KEYS, path)
        cols["h"].append(ctx.number(sec, "height_m", path, positive=True))
        cols["m"].append(ctx.number(sec, "mass_kg", path, positive=True))
        k1 = ctx.number(sec, "k1_Nm_per_rad", path, positive=True)
        k2 = ctx.number(sec, "k2_Nm_per_rad", path, nonneg=True)
        if k2 >= k1:
            raise ctx.fail(f"{path}.k2_Nm_per_rad",
                           f"second stiffness must be below k1_Nm_per_rad={k1:g}, got {k2:g}")
        cols["k1"].append(k1)
        cols["k2"].append(k2)
        cols["fy"].append(ctx.number(sec, "fy_Nm", path, positive=True))
        cols["c"].append(ctx.number(sec, "c_Nms_per_rad", path, nonneg=True))
    n = len(sections)
    sample_rate_hz = ctx.number(raw, "sample_rate_hz", "", positive=True, default=100.0)
    sensors_raw = raw.get("sensors", []) or []
    if not isinstance(sensors_raw, list):
        raise ctx.fail("sensors", f"expected a list, got {type(sensors_raw).__name__}")
    sensors = tuple(_parse_sensor(ctx, s, i, n, sample_rate_hz)
                    for i, s in enumerate(sensors_raw))
    seen: dict[str, int] = {}
    topics: dict[str, int] = {}
    for i, s in enumerate(sensors):
        if s.sensor_id in seen:
            raise ctx.fail(f"sensors[{i}].id",
                           f"duplicate sensor id {s.sensor_id!r} (also sensors[{seen[s.sensor_id]}])")
        if s.topic in topics:
            raise ctx.fail(f"sensors[{i}].topic",
                           f"topic {s.topic!r} already used by sensors[{topics[s.topic]}]")
        seen[s.sensor_id] = i
        topics[s.topic] = i
    direction = raw.get("principal_direction_deg")
    if direction is not None:
        direction = ctx.number(raw, "principal_direction_deg", "")
    return PierConfig(
        pier_id=pier_id,
        description=ctx.string(raw, "description", "", default=""),
        geometry=PierGeometry(np.array(cols["h"]), np.array(cols["m"])),
        design=SpringParameters(np.array(cols["k1"]), np.array(cols["k2"]),
                                np.array(cols["fy"]), np.array(cols["c"])),
        sample_rate_hz=sample_rate_hz,
        principal_direction_deg=direction,
        sensors=sensors,
        source=source,
    )


def config_from_yaml(text: str, source: str = "") -> PierConfig:
    """Parse YAML text into a :class:`PierConfig` (``source`` names it in errors)."""
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise ConfigError(f"{source or '<text>'}: not valid YAML: {err}") from err
    return config_from_dict(raw, source)


def load_config(path: str | Path) -> PierConfig:
    """Load and validate a pier configuration file.

    Raises
    ------
    ConfigError
        If the file cannot be read or any field is invalid.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise ConfigError(f"{path}: cannot read pier configuration: {err.strerror}") from err
    except UnicodeDecodeError as err:
        raise ConfigError(f"{path}: not UTF-8 text (byte 0x{err.object[err.start]:02x} at "
                          f"offset {err.start}); save the configuration as UTF-8") from None
    return config_from_yaml(text, source=path.name)
