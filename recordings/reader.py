"""Reading recordings: messages in log-time order, from complete or truncated MCAP files.

A complete file is read through its summary (chunk indexes, channels, schemas) with ``mcap``'s
seeking reader. A file without a usable footer or summary (the writer was killed) is scanned
record by record from the start, without seeking ahead, and the scan stops at the first record
that is cut short or fails its CRC: everything up to the last complete chunk is read and
:attr:`RecordingReader.recovered` is True.

Either way messages come out in log-time order across all topics (ties in file order), by a
merge over the chunks' time ranges that holds only overlapping chunks in memory.

Decoding is protobuf only: the project's compiled classes for the ``fsd`` and ``foxglove``
schemas, or a class built from the schema stored in the file. No pickle, no eval.
"""

from __future__ import annotations

import bisect
import io
import logging
import os
import struct
import zlib
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import IO, Any

import lz4.frame
import zstandard
from google.protobuf.message import Message as ProtoMessage
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Message, Metadata, Schema
from mcap.stream_reader import MAGIC_SIZE
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap_protobuf.decoder import DecoderFactory

from common.errors import RecordingError
from recordings import fsd_pb2
from recordings.codec import PROTO_CLASSES
from recordings.foxglove import schemas as fg

log = logging.getLogger(__name__)

MCAP_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEADER = struct.Struct("<BQ")
_MESSAGE_HEADER = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time

Entry = tuple[int, int, int, int, bytes]
"""One message: (log_time_ns, unit sequence, index in unit, channel id, data)."""
#: A chunk claiming more than this uncompressed is treated as corrupt (guards memory).
MAX_CHUNK_BYTES = 1 << 30
_KNOWN_OPCODES = frozenset(int(op) for op in Opcode)

#: Compiled protobuf classes by schema name: the project's own and Foxglove's.
KNOWN_CLASSES: dict[str, type[ProtoMessage]] = dict(PROTO_CLASSES)
KNOWN_CLASSES.update(
    {
        cls.DESCRIPTOR.full_name: cls  # type: ignore[attr-defined]
        for cls in (fg.SceneUpdate, fg.LocationFix, fg.FrameTransform, fsd_pb2.PoseError)
    }
)


@dataclass(frozen=True, slots=True)
class RecordedMessage:
    """One message as stored: log time (ns), topic, schema name and the serialised bytes."""

    log_time_ns: int
    topic: str
    schema_name: str
    data: bytes
    channel_id: int

    @property
    def log_time_s(self) -> float:
        """Log time (s) on the recording's clock."""
        return self.log_time_ns * 1e-9


@dataclass(slots=True)
class _Unit:
    """A unit of the data section the merge loads at once: a chunk, or one loose message."""

    start_ns: int
    end_ns: int
    offset: int
    sequence: int
    message: Message | None = None  # a message outside any chunk (unchunked files)


@dataclass(slots=True)
class ScanResult:
    """What a pass over the data section found."""

    units: list[_Unit] = field(default_factory=list)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    complete: bool = False
    note: str = ""
    readable_bytes: int = 0


class RecordingReader:
    """Random-access reader of one MCAP recording (see the module docstring).

    Raises :class:`RecordingError` (one line) when the file cannot be opened or is not MCAP at
    all. Attributes: :attr:`recovered` (the file had to be scanned and ended early),
    :attr:`note` (why), :attr:`bad_chunks` (chunks skipped while reading), :attr:`size_bytes`.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        try:
            self._file: IO[bytes] = open(self.path, "rb")  # noqa: SIM115 (closed in close())
        except OSError as exc:
            raise RecordingError(f"cannot open recording {self.path}: {exc.strerror}") from exc
        try:
            self.size_bytes = os.fstat(self._file.fileno()).st_size
            if self._file.read(MAGIC_SIZE) != MCAP_MAGIC:
                raise RecordingError(
                    f"{self.path} is not an MCAP recording (no MCAP magic at the start; "
                    f"{self.size_bytes} bytes)"
                )
            self.recovered = False
            self.note = ""
            self.bad_chunks = 0
            self._decoders: dict[int, Callable[[bytes], Any]] = {}
            self._factory = DecoderFactory()
            self.indexed = self._load_summary()
            """True when the file's own summary index was used (a complete file)."""
            if not self.indexed:
                scan = scan_data_section(self._file, self.size_bytes)
                self._units = scan.units
                self.schemas = scan.schemas
                self.channels = scan.channels
                self.metadata = scan.metadata
                self.recovered = not scan.complete
                self.note = scan.note
                if self.recovered:
                    log.warning("%s: %s; read what was complete (%d of %d bytes)", self.path,
                                scan.note, scan.readable_bytes, self.size_bytes)
        except BaseException:
            self._file.close()
            raise

    def _load_summary(self) -> bool:
        """Index from the file's summary; False when it has none that can be used."""
        try:
            self._file.seek(0)
            seeking = SeekingReader(self._file, validate_crcs=True)
            summary = seeking.get_summary()
            if summary is None:
                return False
            metadata = {m.name: dict(m.metadata) for m in seeking.iter_metadata()}
        except (McapError, struct.error, ValueError, OSError, EOFError) as exc:
            log.debug("%s: no usable summary (%s)", self.path, exc)
            return False
        self.schemas = dict(summary.schemas)
        self.channels = dict(summary.channels)
        self.metadata = metadata
        indexes = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
        self._units = [
            _Unit(ci.message_start_time, ci.message_end_time, ci.chunk_start_offset, i)
            for i, ci in enumerate(indexes)
        ]
        if not self._units and summary.statistics is not None and summary.statistics.message_count:
            return False  # messages but no chunk index (unchunked file): scan it
        return True

    # ------------------------------------------------------------------------------------------

    @property
    def topics(self) -> dict[str, str]:
        """Schema name of each topic in the file."""
        out = {}
        for channel in self.channels.values():
            schema = self.schemas.get(channel.schema_id)
            out[channel.topic] = schema.name if schema is not None else ""
        return out

    @property
    def chunk_count(self) -> int:
        """Chunks (and loose messages) readable in the file."""
        return len(self._units)

    def iter_entries(self, topics: Iterable[str] | None = None) -> Iterator[Entry]:
        """Every readable message as an :data:`Entry` ``(log_time_ns, unit, index, channel_id,
        data)`` in log-time order (ties in file order), optionally only on ``topics``.

        A chunk that fails to read is skipped (logged, counted in :attr:`bad_chunks`, and the
        file marked :attr:`recovered`). Chunks are loaded when the merge reaches their start
        time, so only chunks overlapping in time are held in memory together.
        """
        wanted = None if topics is None else set(topics)
        units = sorted(self._units, key=lambda u: (u.start_ns, u.sequence))
        pending: list[Entry] = []
        pos = 0
        i = 0
        while True:
            if i < len(units):
                horizon = units[i].start_ns
                if pos >= len(pending) or pending[pos][0] >= horizon:
                    new = self._load(units[i], wanted)
                    i += 1
                    if new:
                        pending = sorted(pending[pos:] + new) if pos < len(pending) else new
                        pos = 0
                    continue
                end = bisect.bisect_left(pending, (horizon,), lo=pos)
            else:
                end = len(pending)
            yield from pending[pos:end]
            pos = end
            if i >= len(units):
                return

    def last_log_time_ns(self, topic: str) -> int | None:
        """Log time (ns) of the last message on ``topic``; None when it has none.

        Loads chunks from the latest-ending back only until no earlier one can hold a later
        message (usually one chunk), instead of reading the whole file.
        """
        best: int | None = None
        for unit in sorted(self._units, key=lambda u: (u.end_ns, u.sequence), reverse=True):
            if best is not None and unit.end_ns <= best:
                break
            entries = self._load(unit, {topic})
            if entries:
                last = entries[-1][0]
                best = last if best is None else max(best, last)
        return best

    def iter_messages(self, topics: Iterable[str] | None = None) -> Iterator[RecordedMessage]:
        """Every readable message in log-time order (ties in file order), optionally only on
        ``topics`` (see :meth:`iter_entries`)."""
        for log_time_ns, _, _, channel_id, data in self.iter_entries(topics):
            channel = self.channels[channel_id]
            schema = self.schemas.get(channel.schema_id)
            yield RecordedMessage(
                log_time_ns=log_time_ns,
                topic=channel.topic,
                schema_name=schema.name if schema is not None else "",
                data=data,
                channel_id=channel_id,
            )

    def _load(self, unit: _Unit, wanted: set[str] | None) -> list[Entry]:
        """The unit's messages on ``wanted`` topics, sorted."""
        if unit.message is not None:
            m = unit.message
            entries = [(m.log_time, unit.sequence, 0, m.channel_id, m.data)]
        else:
            try:
                chunk = read_chunk_at(self._file, unit.offset)
                entries, schemas, channels = parse_chunk_records(chunk, unit.sequence)
            except Exception as exc:  # noqa: BLE001 (any corruption: skip this chunk)
                self.bad_chunks += 1
                self.recovered = True
                self.note = self.note or f"chunk at offset {unit.offset} unreadable: {exc}"
                log.warning("%s: skipping the chunk at offset %d: %s", self.path, unit.offset,
                            exc)
                return []
            for schema in schemas:
                self.schemas.setdefault(schema.id, schema)
            for channel in channels:
                self.channels.setdefault(channel.id, channel)
        channels_ = self.channels
        keep = [
            e for e in entries
            if e[3] in channels_ and (wanted is None or channels_[e[3]].topic in wanted)
        ]
        keep.sort()
        return keep

    # ------------------------------------------------------------------------------------------

    def decode(self, message: RecordedMessage) -> ProtoMessage:
        """The protobuf message of a recorded message (raises :class:`RecordingError`)."""
        cls = KNOWN_CLASSES.get(message.schema_name)
        try:
            if cls is not None:
                return cls.FromString(message.data)
            decoder = self._decoders.get(message.channel_id)
            if decoder is None:
                decoder = self._make_decoder(message.channel_id)
                self._decoders[message.channel_id] = decoder
            result: ProtoMessage = decoder(message.data)
            return result
        except RecordingError:
            raise
        except Exception as exc:  # noqa: BLE001 (DecodeError and friends)
            raise RecordingError(
                f"cannot decode a {message.schema_name or 'schemaless'} message on "
                f"{message.topic}: {exc}"
            ) from exc

    def _make_decoder(self, channel_id: int) -> Callable[[bytes], Any]:
        channel = self.channels[channel_id]
        schema = self.schemas.get(channel.schema_id)
        if (
            channel.message_encoding != MessageEncoding.Protobuf
            or schema is None
            or schema.encoding != SchemaEncoding.Protobuf
        ):
            raise RecordingError(
                f"topic {channel.topic} is not protobuf ({channel.message_encoding!r}); "
                "only protobuf recordings are read"
            )
        decoder = self._factory.decoder_for(channel.message_encoding, schema)
        if decoder is None:
            raise RecordingError(f"no protobuf decoder for {schema.name} on {channel.topic}")
        return decoder

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def read_chunk_at(stream: IO[bytes], offset: int) -> Chunk:
    """The Chunk record starting at byte ``offset`` (its opcode byte)."""
    stream.seek(offset)
    header = stream.read(_RECORD_HEADER.size)
    if len(header) < _RECORD_HEADER.size:
        raise RecordingError(f"no record at offset {offset}")
    opcode, length = _RECORD_HEADER.unpack(header)
    if opcode != Opcode.CHUNK:
        raise RecordingError(f"expected a chunk at offset {offset}, found opcode {opcode:#x}")
    body = stream.read(length)
    if len(body) < length:
        raise RecordingError(f"chunk at offset {offset} is cut short")
    return _parse_chunk(body)


def chunk_data(chunk: Chunk) -> bytes:
    """A chunk's records, decompressed and checked against its CRC (raises on any mismatch)."""
    if chunk.compression == "zstd":
        data = zstandard.ZstdDecompressor().decompress(
            chunk.data, max_output_size=chunk.uncompressed_size
        )
    elif chunk.compression == "lz4":
        data = lz4.frame.decompress(chunk.data)
    elif chunk.compression == "":
        data = chunk.data
    else:
        raise RecordingError(f"unsupported chunk compression {chunk.compression!r}")
    if len(data) != chunk.uncompressed_size:
        raise RecordingError(
            f"chunk decompresses to {len(data)} bytes, not {chunk.uncompressed_size}"
        )
    if chunk.uncompressed_crc != 0 and zlib.crc32(data) != chunk.uncompressed_crc:
        raise RecordingError("chunk CRC mismatch")
    return data


def parse_chunk_records(
    chunk: Chunk, sequence: int
) -> tuple[list[Entry], list[Schema], list[Channel]]:
    """The messages (as entries), schemas and channels in a chunk.

    Message records are unpacked directly (they are most of a file and mcap's generic record
    reader costs several microseconds each); schemas and channels go through ``mcap``'s records.
    """
    data = chunk_data(chunk)
    entries: list[Entry] = []
    schemas: list[Schema] = []
    channels: list[Channel] = []
    header = _RECORD_HEADER
    message = _MESSAGE_HEADER
    offset = 0
    size = len(data)
    index = 0
    while offset < size:
        opcode, length = header.unpack_from(data, offset)
        offset += header.size
        end = offset + length
        if end > size:
            raise RecordingError("a record inside a chunk runs past the chunk's end")
        if opcode == Opcode.MESSAGE:
            channel_id, _, log_time, _ = message.unpack_from(data, offset)
            entries.append((log_time, sequence, index, channel_id, data[offset + message.size:end]))
            index += 1
        elif opcode == Opcode.SCHEMA:
            schemas.append(Schema.read(ReadDataStream(io.BytesIO(data[offset:end]))))
        elif opcode == Opcode.CHANNEL:
            channels.append(Channel.read(ReadDataStream(io.BytesIO(data[offset:end]))))
        offset = end
    return entries, schemas, channels


def _parse_chunk(body: bytes) -> Chunk:
    chunk = Chunk.read(ReadDataStream(io.BytesIO(body)))
    if chunk.uncompressed_size > MAX_CHUNK_BYTES:
        raise RecordingError(f"chunk claims {chunk.uncompressed_size} bytes uncompressed")
    return chunk


def scan_data_section(stream: IO[bytes], size_bytes: int) -> ScanResult:
    """Read records from just after the magic until the footer or the first bad record.

    Never seeks ahead of what it has read; a record cut short, an unparsable record or a chunk
    failing its CRC ends the scan (``complete`` False, ``note`` saying where and why).
    """
    result = ScanResult()
    offset = MAGIC_SIZE
    stream.seek(offset)
    sequence = 0
    data_end = False
    while True:
        header = stream.read(_RECORD_HEADER.size)
        if not header:
            result.note = "the file ends without a footer (the writer did not finish)"
            break
        if len(header) < _RECORD_HEADER.size:
            result.note = f"the file ends inside a record header at offset {offset}"
            break
        opcode, length = _RECORD_HEADER.unpack(header)
        if length > size_bytes - offset - _RECORD_HEADER.size:
            result.note = (f"the record at offset {offset} is cut short (the writer did not "
                           "finish)")
            break
        body = stream.read(length)
        try:
            if opcode == Opcode.CHUNK:
                chunk = _parse_chunk(body)
                entries, schemas, channels = parse_chunk_records(chunk, sequence)
                for schema in schemas:
                    result.schemas.setdefault(schema.id, schema)
                for channel in channels:
                    result.channels.setdefault(channel.id, channel)
                if entries:
                    times = [e[0] for e in entries]
                    result.units.append(_Unit(min(times), max(times), offset, sequence))
            elif opcode == Opcode.SCHEMA:
                schema = Schema.read(ReadDataStream(io.BytesIO(body)))
                result.schemas.setdefault(schema.id, schema)
            elif opcode == Opcode.CHANNEL:
                channel = Channel.read(ReadDataStream(io.BytesIO(body)))
                result.channels.setdefault(channel.id, channel)
            elif opcode == Opcode.MESSAGE:
                message = Message.read(ReadDataStream(io.BytesIO(body)), length)
                result.units.append(
                    _Unit(message.log_time, message.log_time, offset, sequence, message)
                )
            elif opcode == Opcode.METADATA:
                metadata = Metadata.read(ReadDataStream(io.BytesIO(body)))
                result.metadata[metadata.name] = dict(metadata.metadata)
            elif opcode == Opcode.DATA_END:
                data_end = True
            elif opcode == Opcode.FOOTER:
                result.complete = True
                result.readable_bytes = offset
                break
            elif opcode not in _KNOWN_OPCODES and opcode < 0x80:  # 0x80+: user records
                raise RecordingError(f"unknown record opcode {opcode:#x}")
        except Exception as exc:  # noqa: BLE001 (any corruption ends the scan)
            result.note = f"bad record at offset {offset} ({exc})"
            break
        sequence += 1
        offset += _RECORD_HEADER.size + length
        result.readable_bytes = offset
    if data_end and not result.complete:
        result.note = "all data is present but the summary and footer are cut off"
    # Drop loose messages of channels never declared.
    known = set(result.channels)
    result.units = [u for u in result.units if u.message is None or u.message.channel_id in known]
    return result
