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

One malformed block never costs more than itself.  A block that cannot be decoded, that
contradicts the sensor map (sensor id, kind, unit, axes, whole samples, a first sample
index that fits 64 bits), that declares a rate none of the sensor's other blocks declares,
or whose stamp and first sample index disagree with both neighbouring blocks by more than
:data:`STAMP_TOLERANCE_NS` (a logger without a clock yet: stamped 0) is dropped with a
``bad_block`` finding naming the sensor, the block (its number and log time) and the field.
Messages of another type on a sensor's topic are ignored with a ``wrong_message_type``
finding.  The findings are in :attr:`Recording.findings`, and the ingest reports them with
its own.

A logger that loses power leaves an mcap without its end (and a rosbag2 directory perhaps
without ``metadata.yaml``); a bad sector overwrites bytes in the middle.  When the normal
reader refuses a bag, its mcap files are scanned record by record
(:func:`~pier_monitor.bags.recover.scan_mcap`): every readable record is kept, before and
after a damage.  The findings say what was lost: ``bag_truncated`` (where the data end),
``bag_damaged`` (the byte range lost and the time around it, or a damaged file magic),
``bag_metadata`` (a missing or broken ``metadata.yaml`` alone: the storage files were read
directly).
"""

from __future__ import annotations

import dataclasses
import logging
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import yaml
from rosbags.rosbag2 import Reader

from pier_monitor.core.model.config import PierConfig, SensorSpec, config_from_yaml
from pier_monitor.core.errors import PierMonitorError
from pier_monitor.core.ingest.recording import Recording, SensorRecord, stamp_to_ns
from pier_monitor.core.ingest.findings import Finding, fmt_time

from .errors import BagError
from .recover import scan_mcap
from .types import SAMPLE_BLOCK, STRING, block_problem, get_typestore, sample_block_arrays
from .writer import CONFIG_TOPIC_NAME

__all__ = ["read_bag", "read_bag_config"]

log = logging.getLogger(__name__)


class _Conn(NamedTuple):
    """A topic and its message type (what the readers call a connection or channel)."""

    topic: str
    msgtype: str


@dataclass(frozen=True)
class _Recovered:
    """The readable messages of a bag the normal reader refused, in log-time order."""

    connections: list[_Conn]
    messages: list[tuple[_Conn, int, bytes]]
    findings: tuple[Finding, ...]

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


def _storage_files(path: Path) -> tuple[list[Path], str | None]:
    """The mcap storage files of a bag in order (the bag itself for a plain file), and what
    is wrong with its ``metadata.yaml`` (None when it is readable)."""
    if path.is_file():
        return [path], None
    meta_path = path / "metadata.yaml"
    try:
        meta = yaml.safe_load(meta_path.read_text(encoding="utf-8"))
        names = meta["rosbag2_bagfile_information"]["relative_file_paths"]
        files = [path / str(name) for name in names]
        if files and all(f.is_file() for f in files):
            return files, None
        problem = f"it lists storage files {[str(n) for n in names]} that are not all there"
    except FileNotFoundError:
        problem = "it is missing"
    except Exception as err:  # damaged YAML or missing keys
        problem = f"it cannot be read ({type(err).__name__}: {err})".replace("\n", " ")
    return sorted(path.glob("*.mcap")), problem


def _time_span(messages: list[tuple[int, int, bytes, int]], start: int, end: int
               ) -> tuple[int | None, int | None]:
    """Log times of the last message before byte ``start`` and the first after ``end``."""
    before = [m[1] for m in messages if m[3] < start]
    after = [m[1] for m in messages if m[3] >= end]
    return (max(before) if before else None), (min(after) if after else None)


def _recover(path: Path, err: Exception) -> _Recovered:
    """Read every readable record of a bag the normal reader refused (see the module doc);
    :class:`BagError` if no message can be read."""
    failure = f"{path}: cannot read bag, it may be truncated or corrupt: {type(err).__name__}: {err}"
    files, meta_problem = _storage_files(path)
    if not files or any(f.suffix.lower() != ".mcap" for f in files):
        raise BagError(failure) from err
    schemas: dict[str, str] = {}
    conns: dict[tuple[str, int], _Conn] = {}
    messages: list[tuple[_Conn, int, bytes]] = []
    findings: list[Finding] = []
    truncated = None
    for f in files:
        try:
            scanned = scan_mcap(f)
        except OSError as stop:
            raise BagError(f"{failure}; {f.name}: {stop}") from stop
        for cid, (topic, schema_id) in scanned.channels.items():
            conns[(f.name, cid)] = _Conn(topic, scanned.schemas.get(schema_id, ""))
        for cid, log_ns, raw, _ in scanned.messages:
            if (f.name, cid) in conns:
                messages.append((conns[(f.name, cid)], log_ns, raw))
        for d in scanned.damage:
            if d.cut and d.start > 8:  # the file is cut short: its end is lost
                if truncated is None:
                    truncated = (f.name, d)
                continue
            before, after = _time_span(scanned.messages, d.start, d.end)
            t0 = before if before is not None else after if after is not None else 0
            t1 = after if after is not None else t0
            if d.start == 0 and d.end <= 8:
                text = (f"{f.name}: the file magic (bytes 0-{d.end}) is damaged; the records "
                        "after it were read")
            else:
                lost = ("" if before is None or after is None else
                        f"; data lost around {fmt_time(before)}" if before == after else
                        f"; data lost from {fmt_time(before)} to {fmt_time(after)}")
                text = (f"{f.name}: bytes {d.start}-{d.end} ({d.end - d.start} bytes) are "
                        f"unreadable ({d.reason}); the records before and after them were "
                        f"read{lost}")
            findings.append(Finding("bag_damaged", str(path), text, t0, max(t0, t1), "noted"))
    if not messages:
        raise BagError(f"{failure}; no complete message before the damage") from err
    messages.sort(key=lambda m: m[1])
    last = messages[-1][1]
    if truncated is not None:
        name, d = truncated
        findings.insert(0, Finding(
            "bag_truncated", str(path),
            f"the bag is damaged ({name}: cut at byte {d.start}: {d.reason}): "
            f"{len(messages)} messages read up to the damage; its data end at "
            f"{fmt_time(last)}", last, last, "noted"))
    if meta_problem is not None:
        first = messages[0][1]
        findings.append(Finding(
            "bag_metadata", str(path / "metadata.yaml"),
            f"the rosbag2 metadata.yaml: {meta_problem}; the storage files "
            f"{[f.name for f in files]} were read directly", first, last, "noted"))
    if not findings:
        findings.append(Finding(
            "bag_unindexed", str(path), f"the bag reader refused the bag ({type(err).__name__}:"
            f" {err}); its records are whole and were read in order", messages[0][1], last,
            "noted"))
    for finding in findings:
        log.warning("%s: %s", path, finding.message)
    return _Recovered(sorted(set(conns.values())), messages, tuple(findings))


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
        unit.  What was dropped or lost is in :attr:`Recording.findings` (see the module
        doc): malformed blocks, stray message types, damaged or missing bytes, a broken
        ``metadata.yaml``.

    Raises
    ------
    BagError
        Naming the file: it does not exist; it is damaged and nothing can be recovered; it
        holds no configuration.
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
                      recovered.findings)


#: A block whose stamp and first sample index disagree with both neighbouring blocks of its
#: sensor by more than this is dropped (a logger without a clock yet, a flipped index); the
#: ingest re-times smaller disagreements from the sample index.
STAMP_TOLERANCE_NS = 60 * 1_000_000_000
_MAX_BLOCK_FINDINGS = 10  # per sensor; later ones are summed up in one


@dataclass
class _Block:
    """One SampleBlock of a sensor as it came from the bag, before it is judged."""

    number: int  # 1-based, in log order among the sensor's blocks
    topic: str
    log_ns: int
    msg: Any = None
    problem: tuple[str, str] | None = None


class _Drops:
    """The findings of the blocks dropped by the reader, at most a few per sensor."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.findings: list[Finding] = []
        self._count: dict[str, list[int]] = {}

    def add(self, sid: str, block: _Block, field: str, what: str) -> None:
        counted = self._count.setdefault(sid, [0, block.log_ns, block.log_ns])
        counted[0] += 1
        counted[2] = max(counted[2], block.log_ns)
        if counted[0] <= _MAX_BLOCK_FINDINGS:
            n = _samples(block)
            self.findings.append(Finding(
                "bad_block", sid, f"{block.topic}: block {block.number} (logged at "
                f"{fmt_time(block.log_ns)}): {field}: {what}; block dropped"
                f"{f' ({n} samples)' if n else ''}", block.log_ns, block.log_ns, "excluded"))

    def summary(self) -> list[Finding]:
        out = list(self.findings)
        for sid, (n, t0, t1) in self._count.items():
            if n > _MAX_BLOCK_FINDINGS:
                out.append(Finding("bad_block", sid, f"{n} blocks of sensor {sid} dropped in "
                                   f"all (only the first {_MAX_BLOCK_FINDINGS} are listed)",
                                   t0, t1, "excluded"))
        return out


def _samples(block: _Block) -> int:
    try:
        return len(block.msg.data) // max(1, len(block.msg.axes))
    except Exception:
        return 0


def _stamp_offsets(blocks: list[_Block]) -> np.ndarray:
    """Per block: stamp − first sample index × period, ns (NaN where not defined)."""
    out = np.full(len(blocks), np.nan)
    for k, b in enumerate(blocks):
        m = b.msg
        out[k] = (float(stamp_to_ns(m.header.stamp.sec, m.header.stamp.nanosec))
                  - float(m.first_sample_index) * 1e9 / float(m.sample_rate_hz))
    return out


def _judge_blocks(spec: SensorSpec, rate_hz: float, blocks: list[_Block], drops: _Drops
                  ) -> tuple[list[tuple[np.ndarray, np.ndarray, np.ndarray]], float | None]:
    """The arrays of the sensor's good blocks and their rate; the others dropped."""
    sid = spec.sensor_id
    for b in blocks:
        if b.problem is not None:
            drops.add(sid, b, *b.problem)
    ok = [b for b in blocks if b.problem is None]
    if not ok:
        return [], None
    # the rate most blocks declare (the configured one on a tie): a block that declares
    # another is dropped; a sensor whose blocks all declare another rate keeps it, and the
    # ingest names the contradiction with the configuration
    rates = Counter(float(b.msg.sample_rate_hz) for b in ok)
    rate = max(rates, key=lambda r: (rates[r], r == rate_hz))
    good = []
    for b in ok:
        r = float(b.msg.sample_rate_hz)
        if r != rate:
            drops.add(sid, b, "sample_rate_hz", f"{r:g} Hz where the sensor's other blocks "
                      f"declare {rate:g} Hz")
        else:
            good.append(b)
    # a block whose stamp disagrees with its sample index by far more than both its
    # neighbours' do (an index restart is a step: one neighbour agrees)
    off = _stamp_offsets(good)
    prev = np.r_[np.inf, np.abs(np.diff(off))]
    nxt = np.r_[np.abs(np.diff(off)), np.inf]
    odd = (prev > STAMP_TOLERANCE_NS) & (nxt > STAMP_TOLERANCE_NS) & (len(good) > 1)
    kept = []
    for k, b in enumerate(good):
        if not odd[k]:
            kept.append(b)
            continue
        ref = off[k - 1] if k > 0 else off[k + 1]
        stamp = stamp_to_ns(b.msg.header.stamp.sec, b.msg.header.stamp.nanosec)
        drops.add(sid, b, "header.stamp/first_sample_index",
                  f"stamp {fmt_time(stamp)} "
                  f"(sec {b.msg.header.stamp.sec}) and first_sample_index "
                  f"{b.msg.first_sample_index} disagree with the neighbouring blocks by "
                  f"{abs(off[k] - ref) / 1e9:.4g} s")
    arrays = []
    for b in kept:
        times, index, data, _ = sample_block_arrays(b.msg, spec, b.topic, checked=True)
        arrays.append((times, index, data))
    return arrays, rate


def _recording(path: Path, connections: list[Any], messages: Any, pier_id: str | None,
               config: PierConfig | None, findings: tuple[Finding, ...] = ()) -> Recording:
    """The recording of a bag, from its connections and ``messages(conns)``.

    A block that cannot be decoded or contradicts the sensor map is dropped with a
    ``bad_block`` finding naming the sensor, the block and the field; a topic of the map
    with another message type is ignored with a ``wrong_message_type`` finding."""
    typestore = get_typestore()
    if config is None:
        config_conns = _config_connections(path, connections, pier_id)
        config, topic, updates = _read_config(path, messages, config_conns)
    else:
        topic, updates = f"/{config.pier_id}/{CONFIG_TOPIC_NAME}", []
    namespace = topic[: -len(CONFIG_TOPIC_NAME) - 1]
    by_topic = {f"{namespace}/{s.topic.lstrip('/')}": s for s in config.sensors}
    found = list(findings)
    sensor_conns = []
    unmapped = set()
    for conn in connections:
        if conn.topic in by_topic:
            if conn.msgtype != SAMPLE_BLOCK:
                found.append(Finding(
                    "wrong_message_type", by_topic[conn.topic].sensor_id,
                    f"{path.name}: messages of type {conn.msgtype!r} on {conn.topic} (sensor "
                    f"{by_topic[conn.topic].sensor_id}), where {SAMPLE_BLOCK} is expected; "
                    "ignored", 0, 0, "noted"))
                continue
            sensor_conns.append(conn)
        elif conn.msgtype == SAMPLE_BLOCK:
            unmapped.add(conn.topic)
    blocks: dict[str, list[_Block]] = {}
    if sensor_conns:
        for conn, log_ns, raw in messages(sensor_conns):
            spec = by_topic[conn.topic]
            own = blocks.setdefault(spec.sensor_id, [])
            block = _Block(len(own) + 1, conn.topic, int(log_ns))
            own.append(block)
            try:
                block.msg = typestore.deserialize_cdr(raw, SAMPLE_BLOCK)
            except Exception as err:
                block.problem = ("message", f"cannot decode {SAMPLE_BLOCK}: "
                                 f"{type(err).__name__}: {err}")
                continue
            block.problem = block_problem(block.msg, spec)
    times = [b.log_ns for bl in blocks.values() for b in bl]
    if times:  # the ignored topics' findings span the recording
        t0, t1 = min(times), max(times)
        found = [dataclasses.replace(f, start_ns=t0, end_ns=t1)
                 if f.code == "wrong_message_type" else f for f in found]
    drops = _Drops(path)
    sensors = {}
    for spec in config.sensors:
        chunks, rate = _judge_blocks(spec, config.sensor_rate_hz(spec),
                                     blocks.get(spec.sensor_id, []), drops)
        if not chunks:
            continue
        sensors[spec.sensor_id] = SensorRecord(
            spec.sensor_id,
            time_ns=np.concatenate([c[0] for c in chunks]),
            data=np.concatenate([c[2] for c in chunks]),
            rate_hz=rate,
            sample_index=np.concatenate([c[1] for c in chunks]))
    for finding in drops.summary():
        log.warning("%s: %s", path, finding.message)
    found.extend(drops.summary())
    return Recording(config, sensors, source=str(path), unmapped_topics=tuple(sorted(unmapped)),
                     config_updates=tuple(updates), findings=tuple(found))


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
