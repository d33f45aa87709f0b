"""Read a rosbag2 directory or a plain mcap file back into a recording.

The result is a :class:`~pier_monitor.core.ingest.recording.Recording`.

Both formats are read with ``rosbags.rosbag2.Reader``, which opens rosbag2 directories
(``metadata.yaml`` + storage files) and bare ``.mcap`` files of the ``ros2`` profile alike.

The pier configuration comes from the bag itself: the ``std_msgs/msg/String`` on
``/<pier_id>/pier_configuration`` (its first message).  Each sensor of its map is read from
``/<pier_id>/<sensor topic>``, whose messages must be ``pier_monitor_msgs/msg/SampleBlock``
with the unit, kind and axes of the map.  Samples are kept exactly as stored, in the bag's
order, gaps, duplicates, NaNs and all: judging them is the ingest's job, which then can name
the sensor and time.  ``SampleBlock`` topics of sensors that are not in the map are listed in
:attr:`Recording.unmapped_topics`; other topics are ignored.

A logger that loses power leaves an mcap without its end (and a rosbag2 directory perhaps
without ``metadata.yaml``).  When the normal reader fails on an mcap, the file is read again
in order with mcap's stream reader up to the damage: the recording then holds every complete
message before it, and its :attr:`~Recording.findings` a ``bag_truncated`` finding that says
where the data end (time and message count).
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import yaml
from mcap import records
from mcap.stream_reader import StreamReader
from rosbags.rosbag2 import Reader

from pier_monitor.core.model.config import PierConfig, SensorSpec, config_from_yaml
from pier_monitor.core.errors import InputDataError, PierMonitorError
from pier_monitor.core.ingest.recording import Recording, SensorRecord
from pier_monitor.core.ingest.settings import Finding, fmt_time

from .errors import BagError
from .types import SAMPLE_BLOCK, STRING, get_typestore, sample_block_arrays
from .writer import CONFIG_TOPIC_NAME

__all__ = ["read_bag", "read_bag_config"]

log = logging.getLogger(__name__)


class _Conn(NamedTuple):
    """A topic and its message type (what the readers call a connection or channel)."""

    topic: str
    msgtype: str


@dataclass(frozen=True)
class _Recovered:
    """The messages of a damaged bag up to the damage, in log-time order."""

    connections: list[_Conn]
    messages: list[tuple[_Conn, int, bytes]]
    finding: Finding

    def iter(self, conns: list[Any]) -> Iterator[tuple[_Conn, int, bytes]]:
        topics = {c.topic for c in conns}
        return (m for m in self.messages if m[0].topic in topics)


def _check_path(path: Path) -> None:
    if not path.exists():
        raise BagError(f"{path}: no such bag (expected a rosbag2 directory or an .mcap file)")
    if path.is_dir():
        # without metadata.yaml but with mcap storage: a recording cut short, recovered below
        if not (path / "metadata.yaml").is_file() and not any(path.glob("*.mcap")):
            raise BagError(f"{path}: not a rosbag2 directory (no metadata.yaml)")
    elif path.suffix.lower() not in (".mcap", ".db3"):
        raise BagError(f"{path}: unknown bag format {path.suffix!r}; expected a rosbag2 "
                       "directory or an .mcap file")


def _config_connections(path: Path, connections: list[Any], pier_id: str | None) -> list[Any]:
    suffix = f"/{CONFIG_TOPIC_NAME}"
    found = [c for c in connections if c.topic.endswith(suffix)]
    if pier_id is not None:
        found = [c for c in found if c.topic == f"/{pier_id}{suffix}"]
    if not found:
        topics = sorted({c.topic for c in connections})
        want = f"/{pier_id}{suffix}" if pier_id is not None else f"/<pier_id>{suffix}"
        raise BagError(f"{path}: no pier configuration in the bag (expected a {STRING} on "
                       f"{want}); its topics are {topics}; give the configuration file "
                       "instead (pier-monitor identify --pier PIER.yaml)")
    topics = sorted({c.topic for c in found})
    if len(topics) > 1:
        raise BagError(f"{path}: configurations of several piers {topics}; choose one with "
                       "pier_id")
    for conn in found:
        if conn.msgtype != STRING:
            raise BagError(f"{path}: unknown message type {conn.msgtype!r} on {conn.topic}; "
                           f"expected {STRING} holding the pier configuration YAML")
    return found


def _read_config(path: Path, messages: Any, conns: list[Any]
                 ) -> tuple[PierConfig, str, list[tuple[int, PierConfig]]]:
    """The first configuration message, its topic, and the later ones with their log times.

    ``messages(conns)`` iterates ``(connection, log_ns, raw)`` of those connections."""
    typestore = get_typestore()
    topic = conns[0].topic
    configs: list[tuple[int, PierConfig]] = []
    for _, log_ns, raw in messages(conns):
        try:
            text = typestore.deserialize_cdr(raw, STRING).data
        except Exception as err:
            raise BagError(f"{path}: {topic}: cannot decode the configuration message at "
                           f"{log_ns} ns: {err}") from err
        configs.append((int(log_ns), config_from_yaml(text, source=f"{path.name}:{topic}")))
    if not configs:
        raise BagError(f"{path}: no pier configuration in the bag ({topic} has no messages)")
    return configs[0][1], topic, configs[1:]


def _block_arrays(path: Path, topic: str, spec: SensorSpec, msg: Any,
                  log_ns: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    try:
        return sample_block_arrays(msg, spec, f"{path}: {topic} at {log_ns} ns")
    except InputDataError as err:
        raise BagError(str(err)) from err


def _storage_files(path: Path) -> list[Path]:
    """The mcap storage files of a bag in order (the bag itself for a plain file)."""
    if path.is_file():
        return [path]
    try:
        meta = yaml.safe_load((path / "metadata.yaml").read_text(encoding="utf-8"))
        names = meta["rosbag2_bagfile_information"]["relative_file_paths"]
        files = [path / name for name in names]
    except Exception:  # metadata missing or damaged: the storage files by name
        files = sorted(path.glob("*.mcap"))
    return files


def _recover(path: Path, err: Exception) -> _Recovered:
    """Read a damaged mcap bag in order up to the damage; :class:`BagError` if nothing can be."""
    failure = f"{path}: cannot read bag, it may be truncated or corrupt: {type(err).__name__}: {err}"
    files = _storage_files(path)
    if not files or any(f.suffix.lower() != ".mcap" for f in files):
        raise BagError(failure) from err
    schemas: dict[int, str] = {}
    channels: dict[int, _Conn] = {}
    messages: list[tuple[_Conn, int, bytes]] = []
    damage = None
    for f in files:
        try:
            with f.open("rb") as fh:
                for rec in StreamReader(fh, validate_crcs=True).records:
                    if isinstance(rec, records.Schema):
                        schemas[rec.id] = rec.name
                    elif isinstance(rec, records.Channel):
                        channels[rec.id] = _Conn(rec.topic, schemas.get(rec.schema_id, ""))
                    elif isinstance(rec, records.Message) and rec.channel_id in channels:
                        messages.append((channels[rec.channel_id], rec.log_time, rec.data))
        except Exception as stop:  # the damage: keep what came before it
            damage = f"{f.name}: {type(stop).__name__}: {stop}".rstrip(": ")
            break
    if not messages:
        raise BagError(f"{failure}; no complete message before the damage") from err
    messages.sort(key=lambda m: m[1])
    last = messages[-1][1]
    where = f"damaged ({damage})" if damage else f"unreadable by index ({type(err).__name__})"
    finding = Finding("bag_truncated", str(path),
                      f"the bag is {where}: {len(messages)} messages read up to the damage; "
                      f"its data end at {fmt_time(last)}", last, last, "noted")
    log.warning("%s: %s", path, finding.message)
    return _Recovered(sorted(set(channels.values())), messages, finding)


def read_bag(path: str | Path, *, pier_id: str | None = None,
             config: PierConfig | None = None) -> Recording:
    """Read a bag of the layout :func:`~pier_monitor.bags.writer.write_bag` writes.

    Parameters
    ----------
    path : str or Path
        A rosbag2 directory (with ``metadata.yaml``) or a plain ``.mcap`` file.
    pier_id : str, optional
        The pier to read when the bag holds several; default: the only one.
    config : PierConfig, optional
        Configuration to use instead of the bag's (for a bag recorded without one, or to
        correct it); sensor topics are then ``/<config.pier_id>/<sensor topic>`` and the
        bag's own configuration messages, if any, are ignored.

    Returns
    -------
    Recording
        The configuration from the bag and, per sensor of its map that has samples in the
        bag, ``time_ns`` (T,), ``sample_index`` (T,) and ``data`` (T, n_axes) in the sensor's
        unit.  A truncated or partly corrupt mcap gives the messages before the damage and
        a ``bag_truncated`` finding in :attr:`Recording.findings` saying where they end.

    Raises
    ------
    BagError
        Naming the file: it does not exist; it is damaged and nothing can be recovered; it
        holds no configuration; a sensor topic has an unknown message type; a block
        contradicts the sensor map (sensor id, kind, unit, axes) or cannot be decoded.
    ConfigError
        The embedded configuration is invalid (names the bag and topic).
    """
    path = Path(path)
    _check_path(path)
    try:
        with Reader(path) as reader:
            return _recording(path, list(reader.connections),
                              lambda conns: reader.messages(connections=conns), pier_id, config)
    except PierMonitorError:
        raise
    except Exception as err:  # rosbags/OS/decompression errors of a damaged file
        recovered = _recover(path, err)
    return _recording(path, recovered.connections, recovered.iter, pier_id, config,
                      (recovered.finding,))


def _recording(path: Path, connections: list[Any], messages: Any, pier_id: str | None,
               config: PierConfig | None, findings: tuple[Finding, ...] = ()) -> Recording:
    """The recording of a bag, from its connections and ``messages(conns)``."""
    typestore = get_typestore()
    if config is None:
        config_conns = _config_connections(path, connections, pier_id)
        config, topic, updates = _read_config(path, messages, config_conns)
    else:
        topic, updates = f"/{config.pier_id}/{CONFIG_TOPIC_NAME}", []
    namespace = topic[: -len(CONFIG_TOPIC_NAME) - 1]
    by_topic = {f"{namespace}/{s.topic.lstrip('/')}": s for s in config.sensors}
    sensor_conns = []
    unmapped = set()
    for conn in connections:
        if conn.topic in by_topic:
            if conn.msgtype != SAMPLE_BLOCK:
                raise BagError(
                    f"{path}: unknown message type {conn.msgtype!r} on {conn.topic} "
                    f"(sensor {by_topic[conn.topic].sensor_id}); expected {SAMPLE_BLOCK}")
            sensor_conns.append(conn)
        elif conn.msgtype == SAMPLE_BLOCK:
            unmapped.add(conn.topic)
    parts: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
    rates: dict[str, float] = {}
    if sensor_conns:
        for conn, log_ns, raw in messages(sensor_conns):
            spec = by_topic[conn.topic]
            try:
                msg = typestore.deserialize_cdr(raw, SAMPLE_BLOCK)
            except Exception as err:
                raise BagError(f"{path}: {conn.topic} at {log_ns} ns: cannot decode "
                               f"{SAMPLE_BLOCK}: {type(err).__name__}: {err}") from err
            times, index, data, rate = _block_arrays(path, conn.topic, spec, msg, log_ns)
            previous = rates.setdefault(spec.sensor_id, rate)
            if rate != previous:
                raise BagError(f"{path}: {conn.topic} at {log_ns} ns: sample rate "
                               f"changes from {previous:g} Hz to {rate:g} Hz")
            parts.setdefault(spec.sensor_id, []).append((times, index, data))

    sensors = {}
    for spec in config.sensors:
        chunks = parts.get(spec.sensor_id)
        if not chunks:
            continue
        sensors[spec.sensor_id] = SensorRecord(
            spec.sensor_id,
            time_ns=np.concatenate([c[0] for c in chunks]),
            data=np.concatenate([c[2] for c in chunks]),
            rate_hz=rates[spec.sensor_id],
            sample_index=np.concatenate([c[1] for c in chunks]))
    return Recording(config, sensors, source=str(path), unmapped_topics=tuple(sorted(unmapped)),
                     config_updates=tuple(updates), findings=findings)


def read_bag_config(path: str | Path, *, pier_id: str | None = None) -> PierConfig:
    """Only the pier configuration embedded in a bag (see :func:`read_bag` for errors)."""
    path = Path(path)
    _check_path(path)
    try:
        with Reader(path) as reader:
            conns = _config_connections(path, list(reader.connections), pier_id)
            return _read_config(path, lambda c: reader.messages(connections=c), conns)[0]
    except PierMonitorError:
        raise
    except Exception as err:
        recovered = _recover(path, err)
    conns = _config_connections(path, recovered.connections, pier_id)
    return _read_config(path, recovered.iter, conns)[0]
