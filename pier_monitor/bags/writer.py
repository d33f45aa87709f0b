"""Write a :class:`~pier_monitor.core.ingest.recording.Recording` to a rosbag2 directory or an mcap file.

Layout of a bag (both formats):

* ``/<pier_id>/pier_configuration`` — ``std_msgs/msg/String``, the pier configuration YAML,
  one message 1 ms before the first sample (offered latched: reliable, transient local), so
  that the bag replays with no side files;
* ``/<pier_id>/<sensor topic>`` — ``pier_monitor_msgs/msg/SampleBlock``, one topic per sensor
  of the map, consecutive blocks of ``block_s`` (0.1 s: 20 samples at 200 Hz).  A block's
  ``header.stamp`` is the time of its first sample, ``header.frame_id`` and ``sensor_id`` the
  sensor id, ``first_sample_index`` the running index of its first sample; it is logged at
  the time of its last sample (when a live sensor would publish it).

Blocks are uniformly sampled by definition (sample ``i`` at ``stamp + round(i·1e9/rate)``
ns): where a recording's timestamps or sample indices are not, a new block starts, so the
bag reads back to exactly the recorded times, indices and values.

The rosbag2 directory (``metadata.yaml`` + one ``.mcap``) is written with
``rosbags.rosbag2.Writer``; the plain ``.mcap`` file with the ``mcap`` library (``ros2``
profile, ``ros2msg`` schemas, CDR messages, zstd chunks), readable by the standard mcap
tools and ``mcap-ros2-support``.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator, Literal

import mcap.writer
import numpy as np
import yaml
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.metadata import dump_qos_v9

from pier_monitor import __version__
from pier_monitor.core.model.config import PierConfig, SensorSpec
from pier_monitor.core.errors import InputDataError
from pier_monitor.core.ingest.recording import NS_PER_S, Recording, SensorRecord, ns_to_stamp

from .errors import BagError
from .types import KIND_CODES, SAMPLE_BLOCK, STRING, get_typestore, message_definition

__all__ = ["BagFormat", "BagSummary", "write_bag", "write_mcap_messages", "iter_messages",
           "bag_format", "config_topic", "sensor_topic", "CONFIG_TOPIC_NAME", "DEFAULT_BLOCK_S"]

BagFormat = Literal["rosbag2", "mcap"]

#: Last name of the topic that carries the pier configuration.
CONFIG_TOPIC_NAME = "pier_configuration"
#: Default length of a SampleBlock, s.
DEFAULT_BLOCK_S = 0.1
_CONFIG_LEAD_NS = 1_000_000  # the configuration is logged 1 ms before the first sample


@dataclass(frozen=True)
class BagSummary:
    """What :func:`write_bag` wrote.

    Attributes
    ----------
    path : Path
        The bag: a rosbag2 directory or an ``.mcap`` file.
    fmt : {"rosbag2", "mcap"}
        Its format.
    n_messages : int
        Messages written (configuration + sample blocks).
    topics : tuple of str
        Topics written, configuration first.
    size_bytes : int
        Total size on disk (all files of a rosbag2 directory).
    start_ns, end_ns : int
        First and last log time, ns since the Unix epoch.
    """

    path: Path
    fmt: str
    n_messages: int
    topics: tuple[str, ...]
    size_bytes: int
    start_ns: int
    end_ns: int


def config_topic(pier_id: str) -> str:
    """Absolute topic of a pier's configuration: ``/<pier_id>/pier_configuration``."""
    return f"/{pier_id}/{CONFIG_TOPIC_NAME}"


def sensor_topic(pier_id: str, spec: SensorSpec) -> str:
    """Absolute topic of a sensor: ``/<pier_id>/<relative topic of the sensor map>``."""
    return f"/{pier_id}/{spec.topic.lstrip('/')}"


def bag_format(path: str | Path) -> BagFormat:
    """The format a path names: ``"mcap"`` for a ``.mcap`` file, else ``"rosbag2"``."""
    return "mcap" if Path(path).suffix.lower() == ".mcap" else "rosbag2"


def _size_on_disk(path: Path) -> int:
    if path.is_dir():
        return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())
    return path.stat().st_size


def _qos(latched: bool) -> Qos:
    zero = QosTime(0, 0)
    return Qos(history=QosHistory.KEEP_LAST, depth=1 if latched else 100,
               reliability=QosReliability.RELIABLE,
               durability=QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
               deadline=zero, lifespan=zero, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=zero, avoid_ros_namespace_conventions=False)


def _block_bounds(rec: SensorRecord, block_len: int, where: str) -> list[tuple[int, int]]:
    """Split ``rec`` into blocks of at most ``block_len`` uniformly sampled, consecutive samples."""
    t = rec.time_ns
    idx = rec.sample_index
    n = rec.n_samples
    period = NS_PER_S / rec.rate_hz
    if n and int(idx.min()) < 0:
        raise BagError(f"{where}: negative sample index {int(idx.min())} cannot be written")
    offsets = np.rint(np.arange(block_len) * period).astype(np.int64)
    consecutive = np.arange(block_len, dtype=np.int64)
    # fast path: a uniform series with a whole-ns period splits anywhere
    if (n and float(period).is_integer()
            and np.array_equal(t, t[0] + np.arange(n, dtype=np.int64) * int(period))
            and np.array_equal(idx, idx[0] + np.arange(n, dtype=np.int64))):
        return [(i, min(i + block_len, n)) for i in range(0, n, block_len)]
    bounds = []
    i0 = 0
    while i0 < n:
        i1 = min(i0 + block_len, n)
        m = i1 - i0
        ok = ((t[i0:i1] == t[i0] + offsets[:m]) & (idx[i0:i1] == idx[i0] + consecutive[:m]))
        bad = np.flatnonzero(~ok)
        if bad.size:
            i1 = i0 + int(bad[0])  # bad[0] >= 1: the first sample always matches itself
        bounds.append((i0, i1))
        i0 = i1
    return bounds


def _stamp(typestore: Any, t_ns: int, where: str) -> Any:
    try:
        sec, nanosec = ns_to_stamp(t_ns)
    except InputDataError as err:
        raise BagError(f"{where}: {err}") from err
    return typestore.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _messages(recording: Recording, block_s: float) -> tuple[list[tuple[str, str, bool]],
                                                             list[tuple[int, int, bytes]]]:
    """Connections ``(topic, type, latched)`` and time-ordered ``(log_ns, conn, cdr)`` messages."""
    typestore = get_typestore()
    config: PierConfig = recording.config
    types = typestore.types
    header_cls = types["std_msgs/msg/Header"]
    block_cls = types[SAMPLE_BLOCK]
    sensors = [(spec, recording.sensors[spec.sensor_id]) for spec in config.sensors
               if spec.sensor_id in recording.sensors]
    starts = [int(rec.time_ns.min()) for _, rec in sensors if rec.n_samples]
    if not starts:
        raise BagError(f"recording of pier {config.pier_id!r} has no samples to write")
    conns = [(config_topic(config.pier_id), STRING, True)]
    msgs: list[tuple[int, int, bytes]] = [
        (min(starts) - _CONFIG_LEAD_NS, 0,
         bytes(typestore.serialize_cdr(types[STRING](data=config.to_yaml()), STRING)))]
    # later configurations (e.g. deck mass added between runs), at the time they hold from
    msgs += [(t_ns, 0, bytes(typestore.serialize_cdr(types[STRING](data=c.to_yaml()), STRING)))
             for t_ns, c in recording.config_updates]
    for spec, rec in sensors:
        topic = sensor_topic(config.pier_id, spec)
        where = f"sensor {spec.sensor_id} ({topic})"
        conn = len(conns)
        conns.append((topic, SAMPLE_BLOCK, False))
        block_len = max(1, int(round(block_s * rec.rate_hz)))
        period = NS_PER_S / rec.rate_hz
        for i0, i1 in _block_bounds(rec, block_len, where):
            t0 = int(rec.time_ns[i0])
            msg = block_cls(
                header=header_cls(stamp=_stamp(typestore, t0, where), frame_id=spec.sensor_id),
                sensor_id=spec.sensor_id, kind=KIND_CODES[spec.kind], unit=spec.unit,
                sample_rate_hz=rec.rate_hz, first_sample_index=int(rec.sample_index[i0]),
                axes=list(spec.axes), data=np.ascontiguousarray(rec.data[i0:i1]).ravel())
            log_ns = t0 + int(round((i1 - i0 - 1) * period))
            msgs.append((log_ns, conn, bytes(typestore.serialize_cdr(msg, SAMPLE_BLOCK))))
    msgs.sort(key=lambda m: m[0])  # stable: the configuration stays first
    return conns, msgs


def _write_rosbag2(path: Path, conns: list[tuple[str, str, bool]],
                   msgs: list[tuple[int, int, bytes]], compress: bool) -> None:
    typestore = get_typestore()
    writer = Writer(path, version=Writer.VERSION_LATEST, storage_plugin=StoragePlugin.MCAP)
    if compress:
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        handles = [writer.add_connection(topic, msgtype, typestore=typestore,
                                         offered_qos_profiles=[_qos(latched)])
                   for topic, msgtype, latched in conns]
        for log_ns, conn, data in msgs:
            writer.write(handles[conn], log_ns, data)


def _write_mcap(path: Path, conns: list[tuple[str, str, bool]],
                msgs: list[tuple[int, int, bytes]], compress: bool) -> None:
    kind = mcap.writer.CompressionType
    compression = kind.ZSTD if compress else kind.NONE
    with path.open("xb") as stream:
        writer = mcap.writer.Writer(stream, compression=compression)
        writer.start(profile="ros2", library=f"pier_monitor {__version__}")
        schemas: dict[str, int] = {}
        channels = []
        for topic, msgtype, latched in conns:
            if msgtype not in schemas:
                msgdef, _ = message_definition(msgtype)
                schemas[msgtype] = writer.register_schema(msgtype, "ros2msg", msgdef.encode())
            qos = yaml.safe_dump(dump_qos_v9([_qos(latched)]), sort_keys=False)
            channels.append(writer.register_channel(
                topic, "cdr", schemas[msgtype], metadata={"offered_qos_profiles": qos}))
        sequence = [0] * len(conns)
        for log_ns, conn, data in msgs:
            writer.add_message(channels[conn], log_time=log_ns, data=data, publish_time=log_ns,
                               sequence=sequence[conn])
            sequence[conn] += 1
        writer.finish()


def write_bag(recording: Recording, path: str | Path, *, fmt: BagFormat | None = None,
              block_s: float = DEFAULT_BLOCK_S, compress: bool | None = None) -> BagSummary:
    """Write a recording and its configuration as a bag.

    Parameters
    ----------
    recording : Recording
        Configuration and per-sensor samples.
    path : str or Path
        The bag to create: a rosbag2 directory, or an ``.mcap`` file.  It must not exist.
    fmt : {"rosbag2", "mcap"}, optional
        Format; default from ``path`` (``.mcap`` suffix: a plain mcap file).
    block_s : float
        Length of a SampleBlock, s (rounded to whole samples, at least one).
    compress : bool, optional
        zstd-compress the mcap chunks.  Default: yes for a plain ``.mcap`` (like the mcap
        CLI), no for a rosbag2 directory (like ``ros2 bag record``).

    Returns
    -------
    BagSummary

    Raises
    ------
    BagError
        Naming the path: it exists, the format is unknown, the recording has no samples or
        times that a message cannot hold, or writing fails.  A partly written bag is removed.
    """
    path = Path(path)
    fmt = bag_format(path) if fmt is None else fmt
    if fmt not in ("rosbag2", "mcap"):
        raise BagError(f"{path}: unknown bag format {fmt!r}; expected 'rosbag2' or 'mcap'")
    if not (np.isfinite(block_s) and block_s > 0):
        raise BagError(f"{path}: block_s: expected a positive block length in s, got {block_s}")
    if path.exists() or path.is_symlink():
        raise BagError(f"{path}: exists already, not overwriting")
    if not path.parent.is_dir():
        raise BagError(f"{path}: parent directory {path.parent} does not exist")
    if compress is None:
        compress = fmt == "mcap"
    conns, msgs = _messages(recording, block_s)
    try:
        if fmt == "rosbag2":
            _write_rosbag2(path, conns, msgs, compress)
        else:
            _write_mcap(path, conns, msgs, compress)
    except BagError:
        _remove(path)
        raise
    except Exception as err:  # rosbags/mcap/OS errors: report them with the path
        _remove(path)
        raise BagError(f"{path}: cannot write bag: {type(err).__name__}: {err}") from err
    return BagSummary(path=path, fmt=fmt, n_messages=len(msgs),
                      topics=tuple(topic for topic, _, _ in conns),
                      size_bytes=_size_on_disk(path), start_ns=msgs[0][0], end_ns=msgs[-1][0])


def write_mcap_messages(path: str | Path, connections: list[tuple[str, str, bool]],
                        messages: list[tuple[int, int, bytes]], *, compress: bool = True) -> None:
    """Write serialized messages to a plain ``.mcap`` file (``ros2`` profile, CDR).

    The same writer as :func:`write_bag` uses, for messages other than a recording's
    (e.g. the results of an identification).

    Parameters
    ----------
    path : str or Path
        The file to create; it must not exist.
    connections : list of (topic, type name, latched)
        One channel each; latched topics are offered transient local.
    messages : list of (log time ns, connection index, CDR bytes)
        In log-time order.
    compress : bool
        zstd-compress the chunks.

    Raises
    ------
    BagError
        Naming the path: it exists, a message names no connection, or writing fails.  A
        partly written file is removed.
    """
    path = Path(path)
    if path.exists() or path.is_symlink():
        raise BagError(f"{path}: exists already, not overwriting")
    bad = [conn for _, conn, _ in messages if not 0 <= conn < len(connections)]
    if bad:
        raise BagError(f"{path}: message for connection {bad[0]}, but there are "
                       f"{len(connections)} connections")
    try:
        _write_mcap(path, connections, messages, compress)
    except Exception as err:  # mcap/OS errors: report them with the path
        _remove(path)
        raise BagError(f"{path}: cannot write mcap: {type(err).__name__}: {err}") from err


def _remove(path: Path) -> None:
    """Remove a partly written bag (file or rosbag2 directory) without raising."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def iter_messages(recording: Recording, block_s: float = DEFAULT_BLOCK_S
                ) -> Iterator[tuple[int, str, bytes]]:
    """``(log_ns, topic, cdr_bytes)`` of every message a bag of ``recording`` would hold.

    In log-time order, configuration first; for replaying a recording into a live graph
    without writing a bag.
    """
    conns, msgs = _messages(recording, block_s)
    for log_ns, conn, data in msgs:
        yield log_ns, conns[conn][0], data
