"""Field sensor layouts derived from a shaking-table sensor map (SPEC §6).

A pier in service is not instrumented like a shaking-table specimen: nothing stands still to
anchor wire displacement transducers, and a monitoring network has accelerometers at the
foundation (or in the free field), at the pier head and at some intermediate heights,
sometimes with a GNSS receiver on the top.  :func:`layout_config` derives such a network from
a configuration's full sensor map:

``full``
    the map unchanged (the shaking-table reference);
``accel``
    accelerometers at every level, no displacement or velocity sensor;
``sparse``
    accelerometers at the foundation, the top and the chosen intermediate level(s) (default:
    the level nearest mid-height), nothing else.

and, with ``gnss=True``, one differential GNSS receiver at the top: the east and north
components (pier X and Y) of the top's displacement relative to a reference receiver on the
foundation, at 10 Hz with 5 mm noise.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from pier_monitor.core.errors import ConfigError
from pier_monitor.core.model.config import PierConfig, SensorSpec

__all__ = ["LAYOUTS", "GNSS_SENSOR_ID", "GNSS_RATE_HZ", "GNSS_NOISE_M", "gnss_sensor",
           "layout_config", "mid_height_level"]

#: Sensor layouts of :func:`layout_config`.
LAYOUTS = ("full", "accel", "sparse")
#: Id of the GNSS receiver that :func:`layout_config` adds at the top.
GNSS_SENSOR_ID = "gnss_top"
#: Output rate of the GNSS receiver, Hz.
GNSS_RATE_HZ = 10.0
#: Noise of each horizontal GNSS component (differential, short baseline), m.
GNSS_NOISE_M = 0.005


def mid_height_level(config: PierConfig) -> int:
    """The intermediate level (1..N-1) nearest mid-height of the pier; the lower one on a tie.

    Raises
    ------
    ConfigError
        If the pier has no intermediate level (a single section).
    """
    z = config.geometry.level_heights_m
    if config.n_levels < 2:
        raise ConfigError(f"pier {config.pier_id}: a single section has no intermediate level")
    return 1 + int(np.argmin(np.abs(z[1:-1] - z[-1] / 2)))


def gnss_sensor(config: PierConfig, *, rate_hz: float = GNSS_RATE_HZ,
                noise_m: float = GNSS_NOISE_M) -> SensorSpec:
    """The differential GNSS receiver at the top of the pier.

    Kind displacement, unit m, axes ``x, y`` along the pier's X (east) and Y (north) axes:
    the top's displacement relative to a reference receiver on the foundation.
    """
    top = config.n_levels
    return SensorSpec(
        sensor_id=GNSS_SENSOR_ID, topic=f"sensors/level{top}/gnss", level=top,
        kind="displacement", unit="m", axes=("x", "y"), orientation_deg=0.0,
        noise_rms=noise_m, rate_hz=rate_hz,
        location="top, GNSS antenna; east and north displacement relative to a reference "
                 "receiver on the foundation")


def _intermediate(config: PierConfig, levels: Sequence[int] | None) -> tuple[int, ...]:
    if levels is None:
        return (mid_height_level(config),)
    chosen = tuple(levels)
    top = config.n_levels
    if not chosen or any(isinstance(v, bool) or not isinstance(v, (int, np.integer))
                         or not 0 < v < top for v in chosen):
        raise ConfigError(f"pier {config.pier_id}: intermediate_levels: expected levels "
                          f"between 1 and {top - 1}, got {list(chosen)}")
    return tuple(sorted({int(v) for v in chosen}))


def layout_config(config: PierConfig, layout: str, gnss: bool = False,
                  intermediate_levels: Sequence[int] | None = None, *,
                  gnss_rate_hz: float = GNSS_RATE_HZ) -> PierConfig:
    """A field configuration derived from a shaking-table one.

    Parameters
    ----------
    config : PierConfig
        The pier with its full sensor map.
    layout : {"full", "accel", "sparse"}
        Which sensors to keep (see the module docstring).
    gnss : bool
        Add the GNSS receiver of :func:`gnss_sensor` at the top.
    intermediate_levels : sequence of int, optional
        The intermediate levels of the ``sparse`` layout; default the level nearest
        mid-height.  Ignored by the other layouts.
    gnss_rate_hz : float
        Rate of the GNSS receiver, Hz (10 or 20 are usual); must divide the pier's rate.

    Returns
    -------
    PierConfig
        The same pier with the layout's sensor map (sensors in the original order, the GNSS
        receiver last); ``description`` says which layout it is.

    Raises
    ------
    ConfigError
        If the layout is unknown, a level it needs has no accelerometer in the map, the
        intermediate levels are not between the foundation and the top, the map already has
        a sensor with the GNSS id or topic, or the GNSS rate does not divide the pier's.
    """
    if layout not in LAYOUTS:
        raise ConfigError(f"layout: expected one of {list(LAYOUTS)}, got {layout!r}")
    levels: Sequence[int] = ()  # levels that must keep an accelerometer
    if layout == "full":
        sensors = config.sensors
    elif layout == "accel":
        sensors = tuple(s for s in config.sensors if s.kind == "acceleration")
        levels = range(config.n_levels + 1)
    else:
        levels = (0, *_intermediate(config, intermediate_levels), config.n_levels)
        sensors = tuple(s for s in config.sensors
                        if s.kind == "acceleration" and s.level in levels)
    if levels:
        bare = [lv for lv in levels if not any(s.level == lv for s in sensors)]
        if bare:
            raise ConfigError(f"pier {config.pier_id}: layout {layout}: no accelerometer at "
                              f"level {bare[0]} in the sensor map")
    label = layout
    if gnss:
        receiver = gnss_sensor(config, rate_hz=gnss_rate_hz)
        clash = [s.sensor_id for s in sensors
                 if s.sensor_id == receiver.sensor_id or s.topic == receiver.topic]
        if clash:
            raise ConfigError(f"pier {config.pier_id}: sensor {clash[0]} already uses the GNSS "
                              f"receiver's id or topic ({receiver.sensor_id}, {receiver.topic})")
        sensors = (*sensors, receiver)
        label += " + GNSS top"
    if layout == "full" and not gnss:
        return config
    description = f"{config.description} [field layout: {label}]".strip()
    return dataclasses.replace(config, sensors=sensors, description=description)
