"""The rosbags typestore of the project: ROS 2 Kilted plus ``pier_monitor_msgs``.

The message definitions are read from their ``.msg`` text, so that bags are written and read
without a ROS installation and without building the interface package.  The text is taken
from the installed interface package when there is one (``<prefix>/share/pier_monitor_msgs/msg``
for ``sys.prefix`` and each ``AMENT_PREFIX_PATH`` entry: what a live ROS graph uses), else from
the repository's ``msg_defs/msg``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_msg
from rosbags.typesys import get_typestore as _get_typestore
from rosbags.typesys.store import Typestore

from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.recording import sample_times_ns, stamp_to_ns
from pier_monitor.core.model.config import SensorSpec
from pier_monitor.core.resources import find_share_path

from .errors import BagError

__all__ = [
    "MSG_PACKAGE",
    "SAMPLE_BLOCK",
    "STRING",
    "KIND_CODES",
    "KIND_NAMES",
    "block_problem",
    "sample_block_arrays",
    "find_msg_dir",
    "get_typestore",
    "message_definition",
    "message_from_fields",
]

MSG_PACKAGE = "pier_monitor_msgs"
#: Type name of the block message of high-rate channels.
SAMPLE_BLOCK = f"{MSG_PACKAGE}/msg/SampleBlock"
#: Type name of the message that carries the pier configuration YAML.
STRING = "std_msgs/msg/String"

#: SampleBlock.kind code of each sensor kind of the pier configuration.
KIND_CODES = {"acceleration": 0, "displacement": 1, "velocity": 2}
KIND_NAMES = {code: name for name, code in KIND_CODES.items()}


_INDEX_MAX = 2 ** 63 - 1


def block_problem(msg: Any, spec: SensorSpec, rate_hz: float | None = None
                  ) -> tuple[str, str] | None:
    """``(field, what is wrong)`` of a SampleBlock that contradicts the sensor map, or None.

    ``msg`` is a decoded ``pier_monitor_msgs/msg/SampleBlock`` (rosbags or rclpy: the same
    fields).  The block must match the sensor map: sensor id, kind, unit, axes, a positive
    rate (equal to ``rate_hz`` when given), whole samples and a first sample index whose
    samples fit a signed 64-bit index.
    """
    if msg.sensor_id != spec.sensor_id:
        return "sensor_id", (f"block of sensor {msg.sensor_id!r} on the topic of sensor "
                             f"{spec.sensor_id!r}")
    kind = KIND_NAMES.get(int(msg.kind))
    if kind != spec.kind:
        return "kind", (f"block kind {msg.kind} ({kind or 'unknown'}) but the configuration "
                        f"says {spec.kind}")
    if msg.unit != spec.unit:
        return "unit", f"block unit {msg.unit!r} but the configuration says {spec.unit!r}"
    if list(msg.axes) != list(spec.axes):
        return "axes", (f"block axes {list(msg.axes)} but the configuration says "
                        f"{list(spec.axes)}")
    rate = float(msg.sample_rate_hz)
    if not (math.isfinite(rate) and rate > 0):
        return "sample_rate_hz", f"invalid sample_rate_hz {rate}"
    if rate_hz is not None and abs(rate - rate_hz) > 1e-6 * rate_hz:
        return "sample_rate_hz", (f"sample_rate_hz {rate:g} but the configuration says "
                                  f"{rate_hz:g}")
    size = len(msg.data)
    n_axes = len(spec.axes)
    if size % n_axes:
        return "data", (f"{size} values are not a whole number of samples of {n_axes} axes")
    first = int(msg.first_sample_index)
    if first + size // n_axes > _INDEX_MAX:
        return "first_sample_index", (f"first_sample_index {first} does not fit a signed "
                                      "64-bit sample index")
    return None


def sample_block_arrays(msg: Any, spec: SensorSpec, where: str, rate_hz: float | None = None,
                        *, checked: bool = False
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """``(time_ns (T,), sample_index (T,), data (T, n_axes), rate_hz)`` of a SampleBlock.

    The block must pass :func:`block_problem` (not asked again when ``checked``: the caller
    did).

    Raises
    ------
    InputDataError
        Naming ``where`` and the field that contradicts the map.
    """
    problem = None if checked else block_problem(msg, spec, rate_hz)
    if problem is not None:
        raise InputDataError(f"{where}: {problem[1]}")
    rate = float(msg.sample_rate_hz)
    data = np.asarray(msg.data, dtype=np.float64)
    n_axes = len(spec.axes)
    n = data.size // n_axes
    times = sample_times_ns(stamp_to_ns(msg.header.stamp.sec, msg.header.stamp.nanosec), n, rate)
    index = int(msg.first_sample_index) + np.arange(n, dtype=np.int64)
    return times, index, data.reshape(n, n_axes), rate


def find_msg_dir() -> Path:
    """Directory holding the ``pier_monitor_msgs`` ``.msg`` files.

    Raises
    ------
    BagError
        If neither the installed interface package nor the repository's ``msg_defs/msg``
        can be found; the message lists where it looked.
    """
    try:
        path = find_share_path(MSG_PACKAGE, "msg", Path("msg_defs") / "msg")
    except FileNotFoundError as err:
        raise BagError(f"cannot find the {MSG_PACKAGE} message definitions: {err}. Install the "
                       "interface package (scripts/build_msgs.py) or run from a source "
                       "checkout") from err
    if not any(path.glob("*.msg")):
        raise BagError(f"no .msg files in {path} (the {MSG_PACKAGE} message definitions)")
    return path


@lru_cache(maxsize=1)
def get_typestore() -> Typestore:
    """A ROS 2 Kilted typestore with the ``pier_monitor_msgs`` types registered.

    The typestore is built once per process and shared: use it, do not register more types
    in it.

    Raises
    ------
    BagError
        If the message definitions cannot be found or parsed.
    """
    msg_dir = find_msg_dir()
    typestore = _get_typestore(Stores.ROS2_KILTED)
    types: dict[str, Any] = {}
    for path in sorted(msg_dir.glob("*.msg")):
        try:
            types.update(get_types_from_msg(path.read_text(encoding="utf-8"),
                                            f"{MSG_PACKAGE}/msg/{path.stem}"))
        except Exception as err:  # rosbags raises its own parser errors
            raise BagError(f"{path}: cannot parse message definition: {err}") from err
    typestore.register(types)
    return typestore


def message_definition(typename: str) -> tuple[str, str]:
    """The ROS 2 message definition text (with dependencies) and RIHS01 hash of a type."""
    typestore = get_typestore()
    msgdef, _ = typestore.generate_msgdef(typename, ros_version=2)
    return msgdef, typestore.hash_rihs01(typename)


_NUMPY_TYPES = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "octet": np.uint8,
                "int8": np.int8, "uint8": np.uint8, "int16": np.int16, "uint16": np.uint16,
                "int32": np.int32, "uint32": np.uint32, "int64": np.int64,
                "uint64": np.uint64, "float32": np.float32, "float64": np.float64}


def _field_value(typestore: Typestore, node: tuple[Any, Any], value: Any, where: str) -> Any:
    """A field's value as rosbags wants it; ``value`` None gives the type's default."""
    nodetype, desc = node
    if nodetype == Nodetype.NAME:
        return message_from_fields(desc, value or {}, _where=where)
    if nodetype == Nodetype.BASE:
        base = desc[0]
        if value is not None:
            return value
        return "" if base in ("string", "wstring") else False if base == "bool" else \
            0.0 if base.startswith("float") else 0
    (sub_type, sub_desc), length = desc
    if sub_type == Nodetype.BASE and sub_desc[0] in _NUMPY_TYPES:
        dtype = _NUMPY_TYPES[sub_desc[0]]
        default = np.zeros(length if nodetype == Nodetype.ARRAY else 0, dtype=dtype)
        return default if value is None else np.asarray(value, dtype=dtype)
    items = list(value or [])
    if nodetype == Nodetype.ARRAY and not items:
        items = [None] * length
    return [_field_value(typestore, (sub_type, sub_desc), v, f"{where}[{i}]")
            for i, v in enumerate(items)]


def message_from_fields(typename: str, fields: Mapping[str, Any], *, _where: str = "") -> Any:
    """A rosbags message object of ``typename`` from a mapping of (some of) its fields.

    Nested messages are mappings, sequences of messages lists of mappings; a field left out
    gets its type's zero value (0, ``""``, False, an empty sequence, a nested message of
    zeros).  Mind the fields whose ``.msg`` default is not zero (e.g. a quaternion's ``w``).

    Raises
    ------
    BagError
        If the type is unknown or a key is not a field of it (naming the dotted path).
    """
    typestore = get_typestore()
    where = _where or typename
    if typename not in typestore.fielddefs:
        raise BagError(f"{where}: unknown message type {typename!r}")
    _, fielddefs = typestore.fielddefs[typename]
    names = [name for name, _ in fielddefs]
    unknown = sorted(set(fields) - set(names))
    if unknown:
        raise BagError(f"{where}.{unknown[0]}: not a field of {typename} (fields: "
                       f"{', '.join(names)})")
    kwargs = {name: _field_value(typestore, node, fields.get(name), f"{where}.{name}")
              for name, node in fielddefs}
    return typestore.types[typename](**kwargs)
