"""Read what is readable of a damaged mcap file: every whole record, around the damage.

An mcap file is a magic (8 bytes) and a sequence of records, each ``opcode`` (1 byte),
``length`` (uint64, little-endian) and ``length`` bytes of content; messages mostly sit in
compressed chunk records whose uncompressed data carry a CRC.  A logger that loses power cuts
the sequence; a bad disk sector or a copy error overwrites some bytes of it.  Both are
handled by one forward scan:

* the records are read in order (a chunk is decompressed and its CRC checked);
* where one cannot be read, the scan looks forward for the next position where whole
  records start again: a chunk whose CRC holds, or two records that chain exactly (the
  second begins where the first ends) or a record that ends the file;
* the bytes in between are lost, and reported as a byte range.

A damaged magic costs nothing when the records after it are whole.  The summary section at
the end of a file (schemas and channels repeated) is read like any other record, so that
the channels of a chunk lost to the damage are still known.
"""

from __future__ import annotations

import io
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk

__all__ = ["Damage", "ScannedMcap", "scan_mcap"]

MAGIC = b"\x89MCAP0\r\n"
_OPCODES = frozenset(int(o) for o in Opcode)
#: A record header whose opcode is known and whose length fits 32 bits: resync candidates.
_CANDIDATE = re.compile(rb"[\x01-\x0f].{4}\x00\x00\x00\x00", re.S)


@dataclass(frozen=True)
class Damage:
    """Bytes ``[start, end)`` of a file that could not be read, and why; ``cut`` when the
    record there runs past the end of the file (the file is cut short)."""

    start: int
    end: int
    reason: str
    cut: bool = False


@dataclass
class ScannedMcap:
    """The readable content of one mcap file.

    Attributes
    ----------
    schemas : dict of int to str
        Schema name by schema id.
    channels : dict of int to (topic, schema id)
    messages : list of (channel id, log time ns, data bytes, file offset of its record)
        In file order.
    damage : list of Damage
        The unreadable byte ranges, in file order (a bad magic included).
    size : int
        The file's size in bytes.
    """

    schemas: dict[int, str] = field(default_factory=dict)
    channels: dict[int, tuple[str, int]] = field(default_factory=dict)
    messages: list[tuple[int, int, bytes, int]] = field(default_factory=list)
    damage: list[Damage] = field(default_factory=list)
    size: int = 0


def _record_at(data: bytes, pos: int) -> tuple[list[Any], int]:
    """The records of the top-level record at ``pos`` and the position after it.

    Raises ``ValueError`` (or the mcap/decompression error) when no whole, valid record
    starts there."""
    if pos + 9 > len(data):
        raise ValueError("a record header cut by the end of the file")
    opcode = data[pos]
    (length,) = struct.unpack_from("<Q", data, pos + 1)
    end = pos + 9 + length
    if opcode not in _OPCODES:
        raise ValueError(f"unknown record opcode 0x{opcode:02x}")
    if end > len(data):
        raise ValueError(f"a record of {length} bytes cut by the end of the file")
    stream = ReadDataStream(io.BytesIO(data[pos + 9:end]))
    if opcode == Opcode.CHUNK:
        chunk = Chunk.read(stream)
        records = breakup_chunk(chunk, validate_crc=True)
    elif opcode == Opcode.SCHEMA:
        records = [Schema.read(stream)]
    elif opcode == Opcode.CHANNEL:
        records = [Channel.read(stream)]
    elif opcode == Opcode.MESSAGE:
        records = [Message.read(stream, length)]
    else:
        records = []
    if stream.count > length:
        raise ValueError("a record longer than its length")
    return records, end


def _declared_end(data: bytes, pos: int) -> int:
    """Where the chunk at ``pos`` says it ends (``pos`` when there is no chunk header)."""
    if pos + 9 > len(data) or data[pos] != Opcode.CHUNK:
        return pos
    return pos + 9 + struct.unpack_from("<Q", data, pos + 1)[0]


def _strong(data: bytes, pos: int) -> tuple[list[Any], int] | None:
    """The record at ``pos`` when whole records certainly start there, else None: a chunk
    with a checked CRC, a footer that ends the file, or a record followed by another that
    chains exactly."""
    try:
        records, end = _record_at(data, pos)
    except Exception:
        return None
    opcode = data[pos]
    if opcode == Opcode.CHUNK and struct.unpack_from("<I", data, pos + 9 + 24)[0] != 0:
        return records, end
    if opcode == Opcode.FOOTER and data[end:] == MAGIC:
        return records, end
    if end == len(data) or data[end:] == MAGIC:
        return records, end
    try:
        _record_at(data, end)
    except Exception:
        return None
    return records, end


def _resync(data: bytes, start: int) -> tuple[int, list[Any], int] | None:
    """The first position after ``start`` where whole records start again."""
    for m in _CANDIDATE.finditer(data, start):
        found = _strong(data, m.start())
        if found is not None:
            return m.start(), *found
    return None


def scan_mcap(path: Path) -> ScannedMcap:
    """Every readable record of an mcap file, and the byte ranges lost to damage."""
    data = path.read_bytes()
    out = ScannedMcap(size=len(data))
    pos = len(MAGIC)
    if data[:len(MAGIC)] != MAGIC:
        out.damage.append(Damage(0, min(len(MAGIC), len(data)), "the file magic is damaged"))
    if data.endswith(MAGIC) and len(data) > 2 * len(MAGIC):
        data = data[:-len(MAGIC)]  # the closing magic is no record
    while pos < len(data):
        try:
            records, end = _record_at(data, pos)
        except Exception as err:
            reason = f"{type(err).__name__}: {err}".rstrip(": ")
            cut = "end of the file" in reason
            again = _resync(data, pos + 1)
            if again is None:
                out.damage.append(Damage(pos, len(data), reason, True))
                break
            good, records, end = again
            if not (pos < good < _declared_end(data, pos)):
                out.damage.append(Damage(pos, good, reason, cut))
            # else whole records start again inside the failed one (an uncompressed chunk
            # read record by record): only its framing is lost, and the damage inside it is
            # reported where the records stop
            pos = good
        for rec in records:
            if isinstance(rec, Schema):
                out.schemas[rec.id] = rec.name
            elif isinstance(rec, Channel):
                out.channels[rec.id] = (rec.topic, rec.schema_id)
            elif isinstance(rec, Message):
                out.messages.append((rec.channel_id, rec.log_time, rec.data, pos))
        if data[pos] == Opcode.FOOTER:
            break
        pos = end
    return out
