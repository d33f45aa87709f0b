"""A network of synthetic piers with known answers: varied designs, layouts, motions, damage.

:func:`fleet_piers` draws ``N`` piers from one seed.  Each pier is a circular RC column of
2-8 sections with a deck mass at its top, designed like ``config/edefense_like.yaml``
(cracked flexural rigidity, ``k2 = k1 / 10``, yield moments from a design lateral
acceleration with some overstrength up the height, stiffness-proportional damping of 3 % in
the first mode), instrumented with the E-Defense sensor-map pattern generalised to its
``N`` levels (:func:`full_layout`), and shaken by one or two table runs of a drawn damage
level.  :func:`~pier_monitor.core.synthetic.shaking_table.generate_recording` then plays each
pier's scenario and keeps its ground truth.

Sensor layouts are named: ``"full"`` is the shaking-table layout, ``"accel"`` and ``"sparse"``
the field networks of :func:`~pier_monitor.core.synthetic.layouts.layout_config`
(accelerometers at every level; at the foundation, mid-height and top).  :func:`apply_layout`
maps the full-layout configuration to the configuration of a layout.

Everything random derives from ``(seed, index)``: pier ``i`` of a fleet does not depend on
how many piers are drawn.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.model.config import PierConfig, PierGeometry, SensorSpec, SpringParameters
from pier_monitor.core.model.link_model import natural_periods
from pier_monitor.core.synthetic.layouts import layout_config
from pier_monitor.core.synthetic.shaking_table import RunSpec, Scenario

__all__ = ["DAMAGE_LEVELS", "FleetPier", "LAYOUTS", "apply_layout", "fleet_pier", "fleet_piers",
           "full_layout"]

#: Damage levels of a pier's last run and the range of its peak table acceleration, m/s².
DAMAGE_LEVELS: dict[str, tuple[float, float]] = {
    "none": (1.0, 2.0),
    "moderate": (3.0, 4.0),
    "severe": (5.0, 6.5),
}
_G = 9.80665
_RHO_RC_KG_M3 = 2400.0
_E_CONCRETE_PA = 25e9
_CRACKED = 0.2  # cracked share of the gross flexural rigidity
_DAMPING_RATIO = 0.03
_SAMPLE_RATE_HZ = 200.0


@dataclass(frozen=True)
class FleetPier:
    """One synthetic pier of a fleet: its configuration and the runs it is shaken by.

    Attributes
    ----------
    index : int
        Position in the fleet (0-based).
    config : PierConfig
        Geometry, design values and the sensor map of ``layout``.
    scenario : Scenario
        The table runs (one or two), with the quiet stretches around them.
    layout : str
        Name of the sensor layout (a key of :data:`LAYOUTS`).
    damage : str
        Damage level of the last run (a key of :data:`DAMAGE_LEVELS`).
    """

    index: int
    config: PierConfig
    scenario: Scenario
    layout: str
    damage: str

    @property
    def pier_id(self) -> str:
        """The configuration's pier id."""
        return self.config.pier_id


def _acc(sid: str, level: int, orientation_deg: float, unit: str, location: str,
         rng: np.random.Generator) -> SensorSpec:
    """A DC-coupled 3-axis accelerometer: small biases, gravity on z, 1e-3 m/s² noise."""
    factor = 0.01 if unit == "gal" else 1.0  # m/s² per unit
    bias = rng.normal(0.0, 0.01, 2) / factor
    return SensorSpec(sensor_id=sid, topic=f"sensors/level{level}/{sid.split('_', 1)[1]}",
                      level=level, kind="acceleration", unit=unit, axes=("x", "y", "z"),
                      orientation_deg=orientation_deg, signs=(1.0, 1.0, 1.0),
                      gain=float(np.round(rng.uniform(0.99, 1.01), 3)),
                      offsets=(float(bias[0]), float(bias[1]), _G / factor),
                      noise_rms=1e-3 / factor, location=location)


def _vel(sid: str, level: int, location: str) -> SensorSpec:
    return SensorSpec(sensor_id=sid, topic=f"sensors/level{level}/vel", level=level,
                      kind="velocity", unit="cm/s", axes=("x", "y", "z"), orientation_deg=0.0,
                      noise_rms=0.05, location=location)


def _wire(level: int, face: str, orientation_deg: float, z_m: float,
          rng: np.random.Generator) -> SensorSpec:
    return SensorSpec(sensor_id=f"l{level}_wire_{face}", topic=f"sensors/level{level}/wire_{face}",
                      level=level, kind="displacement", unit="mm", axes=("x",),
                      orientation_deg=orientation_deg, signs=(-1.0,),
                      offsets=(float(np.round(rng.uniform(250.0, 650.0), 1)),), noise_rms=0.1,
                      location=f"z = {z_m:.2f} m, {face} face, wire to the frame on that side")


def full_layout(n_levels: int, level_heights_m: np.ndarray, rng: np.random.Generator
                ) -> tuple[SensorSpec, ...]:
    """The E-Defense shaking-table sensor map generalised to ``n_levels`` levels.

    Foundation: four corner accelerometers and a velocity meter; levels 1..N-1: an
    accelerometer on each face; the top level: four corner and two side accelerometers and a
    velocity meter; wire displacement transducers on the north and west faces of every
    level.  Units alternate between gal and m/s² as in ``edefense_like.yaml``.

    Parameters
    ----------
    n_levels : int
        ``N``, the levels above the foundation.
    level_heights_m : ndarray, shape (N+1,)
        Heights of the levels, foundation first, m.
    rng : numpy.random.Generator
        Draws the channels' biases, gains and wire lengths.
    """
    corners = (("ne", 0.0), ("nw", 90.0), ("sw", 180.0), ("se", 270.0))
    faces = (("n", 90.0), ("e", 0.0), ("s", 270.0), ("w", 180.0))
    units = ("gal", "m/s^2")
    sensors: list[SensorSpec] = []
    for k, (name, az) in enumerate(corners):
        sensors.append(_acc(f"l0_acc_{name}", 0, az, units[k % 2], f"foundation, "
                            f"{name.upper()} corner", rng))
    sensors.append(_vel("l0_vel", 0, "foundation, centre"))
    for level in range(1, n_levels + 1):
        z = float(level_heights_m[level])
        spots = faces if level < n_levels else (*corners, faces[0], faces[3])
        for k, (name, az) in enumerate(spots):
            sensors.append(_acc(f"l{level}_acc_{name}", level, az, units[k % 2],
                                f"z = {z:.2f} m, {name.upper()}", rng))
    sensors.append(_vel(f"l{n_levels}_vel", n_levels, "top level, centre"))
    for level in range(1, n_levels + 1):
        z = float(level_heights_m[level])
        sensors.append(_wire(level, "n", 90.0, z, rng))
        sensors.append(_wire(level, "w", 180.0, z, rng))
    return tuple(sensors)


#: Sensor layouts by name: each maps the full-layout configuration to that layout's.
LAYOUTS: dict[str, Callable[[PierConfig], PierConfig]] = {
    "full": lambda config: config,
    "accel": lambda config: layout_config(config, "accel"),
    "sparse": lambda config: layout_config(config, "sparse"),
}


def apply_layout(config: PierConfig, layout: str) -> PierConfig:
    """The configuration of ``config``'s pier with the sensors of ``layout``.

    Raises
    ------
    InputDataError
        If the layout is not one of :data:`LAYOUTS`.
    """
    if layout not in LAYOUTS:
        raise InputDataError(f"sensor layout {layout!r}: expected one of {sorted(LAYOUTS)}")
    return LAYOUTS[layout](config)


def _design(n: int, rng: np.random.Generator) -> tuple[PierGeometry, SpringParameters, float]:
    """Heights, masses and design springs of a drawn pier; also its column diameter, m."""
    height = rng.uniform(6.0, 12.0)
    h = rng.uniform(0.85, 1.15, n)
    h = np.round(height * h / h.sum(), 2)
    diameter = rng.uniform(1.5, 2.4)
    per_m = _RHO_RC_KG_M3 * np.pi / 4 * diameter ** 2
    masses = per_m * 0.5 * (h + np.append(h[1:], 0.0))
    masses[-1] += rng.uniform(150e3, 350e3)  # pier head and deck
    ei = _E_CONCRETE_PA * np.pi * diameter ** 4 / 64 * _CRACKED
    k1 = ei / h
    k1[-1] *= 1.25  # the top spring includes the head-to-column joint
    z = np.concatenate(([0.0], np.cumsum(h)))
    # moment at the bottom of each section from a uniform lateral acceleration of 1 m/s²
    unit_moment = np.array([np.sum(masses[i:] * (z[i + 1:] - z[i])) for i in range(n)])
    design_acc = rng.uniform(3.0, 4.5)
    fy = design_acc * unit_moment * (1.0 + 0.4 * z[:-1] / z[-1])
    geometry = PierGeometry(h, np.round(masses, -1))
    springs = SpringParameters(k1, k1 / 10.0, fy, np.zeros(n))
    omega1 = 2 * np.pi / natural_periods(geometry, springs)[0]
    c = 2 * _DAMPING_RATIO / omega1 * k1
    return geometry, SpringParameters(k1, k1 / 10.0, fy, c), float(diameter)


def _runs(n: int, damage: str, n_runs: int, record_s: float,
          rng: np.random.Generator) -> tuple[RunSpec, ...]:
    """One or two table runs ending at ``damage``; a second run finds the pier weakened."""
    lo, hi = DAMAGE_LEVELS[damage]
    last_pga = float(rng.uniform(lo, hi))
    common = dict(duration_s=record_s, strong_start_s=0.25 * record_s,
                  strong_duration_s=0.3 * record_s)
    if n_runs == 1:
        return (RunSpec("run1", pga_mps2=last_pga, pulse_period_s=float(rng.uniform(0.8, 1.6)),
                        motion_seed=int(rng.integers(2 ** 31)), **common),)
    first_pga = float(rng.uniform(*DAMAGE_LEVELS["none"])) if damage != "severe" else \
        float(rng.uniform(*DAMAGE_LEVELS["moderate"]))
    weakened = np.ones(n)
    if damage == "severe":  # the first run yielded the bottom: it is softer for the second
        weakened[:2] = rng.uniform(0.83, 0.92, 2)
    return (
        RunSpec("run1", pga_mps2=first_pga, pulse_period_s=float(rng.uniform(0.8, 1.6)),
                motion_seed=int(rng.integers(2 ** 31)), **common),
        RunSpec("run2", pga_mps2=last_pga, pulse_period_s=float(rng.uniform(0.8, 1.6)),
                motion_seed=int(rng.integers(2 ** 31)),
                k1_factors=tuple(float(v) for v in weakened),
                fy_factors=tuple(float(v) for v in np.where(weakened < 1, 0.9, 1.0)),
                **common),
    )


def fleet_pier(index: int, seed: int = 0, *, layout: str = "full", record_s: float = 30.0,
               lead_s: float = 15.0, gap_s: float = 25.0, tail_s: float = 15.0,
               sections: tuple[int, int] = (2, 8)) -> FleetPier:
    """Draw pier ``index`` of the fleet of ``seed``.

    Parameters
    ----------
    index : int
        The pier's position in the fleet; its id is ``pier_<index, 3 digits>``.
    seed : int
        Seed of the fleet.
    layout : str
        Sensor layout (a key of :data:`LAYOUTS`).
    record_s : float
        Length of each table record, s.
    lead_s, gap_s, tail_s : float
        Quiet recording before, between and after the runs, s.
    sections : tuple of two int
        Smallest and largest number of sections drawn from (inclusive, within 2-8).

    Raises
    ------
    InputDataError
        For a negative index, an unknown layout or a section range outside 2-8.
    """
    if index < 0:
        raise InputDataError(f"pier index: expected a non-negative integer, got {index}")
    lo, hi = sections
    if not 2 <= lo <= hi <= 8:
        raise InputDataError(f"sections: expected 2 <= min <= max <= 8, got {sections}")
    rng = np.random.default_rng([int(seed), int(index)])
    n = int(rng.integers(lo, hi + 1))
    geometry, design, diameter = _design(n, rng)
    damage = str(rng.choice(list(DAMAGE_LEVELS)))
    n_runs = int(rng.integers(1, 3))
    runs = _runs(n, damage, n_runs, record_s, rng)
    pier_id = f"pier_{index:03d}"
    config = PierConfig(
        pier_id=pier_id, geometry=geometry, design=design, sample_rate_hz=_SAMPLE_RATE_HZ,
        principal_direction_deg=float(np.round(rng.uniform(0.0, 360.0), 1)),
        sensors=full_layout(n, geometry.level_heights_m, rng),
        description=f"synthetic fleet pier {index} (seed {seed}): {n} sections, "
                    f"{geometry.level_heights_m[-1]:.2f} m, column diameter {diameter:.2f} m",
        source=f"{pier_id}.yaml")
    config = apply_layout(config, layout)
    scenario = Scenario(runs=runs, lead_s=lead_s, gap_s=gap_s, tail_s=tail_s)
    return FleetPier(index=index, config=config, scenario=scenario, layout=layout,
                     damage=damage)


def fleet_piers(n: int, seed: int = 0, *, layouts: Sequence[str] = ("full",),
                **kwargs: float | tuple[int, int]) -> tuple[FleetPier, ...]:
    """``n`` piers of the fleet of ``seed``; pier ``i`` gets ``layouts[i % len(layouts)]``.

    Further keyword arguments go to :func:`fleet_pier` (record lengths, section range).

    Raises
    ------
    InputDataError
        If ``n`` is not positive or no layout is given (and see :func:`fleet_pier`).
    """
    if n < 1:
        raise InputDataError(f"fleet size: expected a positive number of piers, got {n}")
    if not layouts:
        raise InputDataError("layouts: expected at least one sensor layout")
    return tuple(fleet_pier(i, seed, layout=layouts[i % len(layouts)], **kwargs)
                 for i in range(n))

