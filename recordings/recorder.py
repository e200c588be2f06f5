"""The recorder: a listener writing the stack's messages to an MCAP file of protobuf messages.

The caller's side (:meth:`Recorder.write`, :meth:`Recorder.write_raw`, ...) only puts a reference
to the (immutable) message on a bounded queue and returns: it never blocks and never converts
(unless made with ``blocking=True``, for simulation, where it waits for room instead of dropping).
:meth:`Recorder.write_raw_many` queues a tick's raw units as one item (one put, one wake-up of
the writer), each unit still its own message in the file and in the queue's bound.
One writer thread converts with :mod:`recordings.codec`, serialises, and writes through ``mcap``'s
``Writer`` with each protobuf schema registered once (``mcap_protobuf``'s ``register_schema``).
When the queue is full the message is dropped, counted in :attr:`Recorder.dropped` and logged.

Chunks are zstd-compressed with CRCs. The writer closes a chunk itself (``Writer.flush``, which
also flushes the file to the operating system) once it spans ``chunk_duration_s`` of log time
(0.4 s by default), has been open that long on the wall clock, or holds ``chunk_size_bytes``: a
process killed with SIGKILL leaves a file that :mod:`recordings.reader` reads up to its last
complete chunk, so at most ``chunk_duration_s`` (plus what was still queued) of what was
received is lost. Shorter chunks compress a little worse (0.4 s: about 11 % larger files than
1 s). The wall clock is used only for that flushing; it never changes what is written.

Log times are nanoseconds on the run's clock: ``round(log_time_s * 1e9)``.
"""

from __future__ import annotations

import logging
import math
import os
import queue
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import IO, Any

from google.protobuf.message import Message as ProtoMessage
from mcap.well_known import MessageEncoding
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from mcap_protobuf.schema import register_schema

from common.car import CarConfig
from common.errors import RecordingError
from common.messages import CanFrame, GpsFix, MapState, Plan, RawBytes
from common.track import TrackLayout
from recordings import foxglove_views, topics
from recordings.codec import to_proto
from recordings.config import RecordingConfig
from recordings.drops import DropCount

log = logging.getLogger(__name__)

LIBRARY = "fsd-stack recordings"
#: Never let mcap close a chunk on its own: the recorder decides (size, log time, wall time).
_NO_AUTO_CHUNK = 1 << 62


def to_ns(t_s: float) -> int:
    """Log time in integer nanoseconds for ``t_s`` seconds (``round(t_s * 1e9)``)."""
    return round(t_s * 1e9)


def _checked_ns(t_s: float) -> int:
    """:func:`to_ns`, refusing what MCAP cannot store (NaN, infinities, negative times)."""
    if not math.isfinite(t_s) or t_s < 0.0 or t_s >= 1.8e10:
        raise RecordingError(f"log time {t_s!r} s cannot be recorded (must be in 0 .. 1.8e10 s)")
    return to_ns(t_s)


@dataclass(frozen=True, slots=True)
class _Item:
    kind: str  # "msg", "proto", "gps", "meta", "raws" (a tuple of raw units), "raw" (one of them)
    topic: str
    payload: Any
    log_time_s: float


def _unbatched(item: _Item) -> Iterator[_Item]:
    """The item itself, or each raw unit of a ``raws`` batch as a ``raw`` item."""
    if item.kind != "raws":
        yield item
        return
    for raw in item.payload:
        yield _Item("raw", "a batch's raw unit", raw, math.nan)


class Recorder:
    """Write the stack's messages to ``path`` (MCAP, protobuf); a listener and context manager.

    ``config`` gives the queue length and chunking; ``car`` the car's box drawn in the Foxglove
    scene; ``metadata`` is written once as an MCAP metadata record named ``"fsd"`` (e.g. the
    track, the seed, the configuration as TOML).

    ``blocking=False`` (on the car) never blocks the caller and drops what does not fit in the
    queue; ``blocking=True`` (simulation) waits for room instead, so nothing is lost.
    ``wall_clock_s`` is the monotonic clock (s) that closes a chunk left open too long (tests
    replace it); it is read by the writer thread only.

    Thread-safe: any thread may call the ``write*`` methods. After :meth:`close` they are ignored
    (counted in :attr:`dropped`).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        config: RecordingConfig | None = None,
        car: CarConfig | None = None,
        metadata: Mapping[str, str] | None = None,
        blocking: bool = False,
        wall_clock_s: Callable[[], float] = time.monotonic,
    ) -> None:
        self.path = Path(path)
        self.blocking = blocking
        """Wait for room in the queue instead of dropping (simulation, replay: completeness
        matters more than latency there, and a dropped message would break the replay)."""
        self.config = config if config is not None else RecordingConfig()
        self._wall_clock_s = wall_clock_s
        self._car = car if car is not None else CarConfig()
        self._drops = DropCount()
        self.written = 0
        """Messages written to the file (including the Foxglove views)."""
        self.errors = 0
        """Messages that could not be converted or written (each logged)."""
        self.error: BaseException | None = None
        """The first write error, if any."""
        self._closed = False
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._stream: IO[bytes] = open(self.path, "wb")  # noqa: SIM115 (closed in _finish)
        except OSError as exc:
            raise RecordingError(f"cannot create recording {self.path}: {exc}") from exc
        self._writer = McapWriter(
            self._stream,
            chunk_size=_NO_AUTO_CHUNK,
            compression=CompressionType.ZSTD,
            enable_crcs=True,
        )
        self._writer.start(profile="", library=LIBRARY)
        if metadata:
            self._writer.add_metadata("fsd", {str(k): str(v) for k, v in metadata.items()})
        self._stream.flush()
        # Writer-thread state.
        self._channels: dict[str, tuple[int, str]] = {}  # topic -> (channel id, schema name)
        self._schemas: dict[str, int] = {}  # schema name -> schema id
        self._chunk_messages = 0
        self._chunk_bytes = 0
        self._chunk_min_ns = 0
        self._chunk_max_ns = 0
        self._chunk_opened_wall_s = 0.0
        self._last_scene_ns: int | None = None
        self._trace = foxglove_views.TraceSegments()
        self._cone_drawer = foxglove_views.ConeDrawer()
        self._baseframe_memo = foxglove_views.LineMemo()
        # The queue itself is unbounded; _reserve bounds the messages in it (a tick's raw units
        # are one item), so a full queue holds queue_length messages however they are batched.
        self._queue: queue.SimpleQueue[_Item] = queue.SimpleQueue()
        self._room = threading.Condition()
        self._queued = 0
        self._capacity = max(1, self.config.queue_length)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="recorder", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------------------------------
    # The caller's side: never blocks
    # ------------------------------------------------------------------------------------------

    def write(self, topic: str, message: object, log_time_s: float) -> bool:
        """Queue a :mod:`common.messages` object (or a track) for ``topic`` at ``log_time_s``.

        Returns False when it was dropped (queue full or recorder closed).
        """
        return self._put(_Item("msg", topic, message, log_time_s))

    def write_raw(self, raw: RawBytes | CanFrame) -> bool:
        """Queue a raw unit on its source's topic (see :func:`topics.raw_topic`) at its time."""
        return self._put(_Item("msg", topics.raw_topic(raw), raw, raw.timestamp_s))

    def write_raw_many(self, units: Sequence[RawBytes | CanFrame]) -> bool:
        """Queue raw units (each on its source's topic at its time) as one queue item: a
        tick's units cost the caller one put, not one each. Returns False when they were
        dropped (each counted in :attr:`dropped`)."""
        if not units:
            return True
        return self._put(_Item("raws", "", tuple(units), 0.0), len(units))

    def write_gps_fix(self, fix: GpsFix) -> bool:
        """Queue a parsed GNSS fix for ``/foxglove/gps`` (``foxglove.LocationFix``)."""
        if not self.config.foxglove:
            return True
        return self._put(_Item("gps", topics.FOXGLOVE_GPS, fix, fix.timestamp_s))

    def write_proto(self, topic: str, proto: ProtoMessage, log_time_s: float) -> bool:
        """Queue a protobuf message as it is (its schema is registered on first use)."""
        return self._put(_Item("proto", topic, proto, log_time_s))

    def add_metadata(self, name: str, data: Mapping[str, str]) -> bool:
        """Queue an MCAP metadata record (string key-value pairs)."""
        return self._put(_Item("meta", name, {str(k): str(v) for k, v in data.items()}, 0.0))

    def __call__(self, topic: str, message: object, log_time_s: float) -> bool:
        """Listener form of :meth:`write`."""
        return self.write(topic, message, log_time_s)

    def _put(self, item: _Item, count: int = 1) -> bool:
        """Queue ``item`` holding ``count`` messages; False (each counted) when dropped."""
        if not self._closed and self._reserve(count):
            self._queue.put(item)
            return True
        reason = "recorder closed" if self._closed else "queue full"
        self._drops.add(count, f"{reason}; last on {item.topic or 'raw units'}")
        return False

    @property
    def dropped(self) -> int:
        """Messages not recorded because the queue was full (or the recorder closed)."""
        return self._drops.count

    def _reserve(self, count: int) -> bool:
        """Room in the queue for ``count`` more messages: at once, or (``blocking``) once the
        writer has taken enough; False when there is none (or the writer thread is gone). A
        batch larger than the whole queue goes into an empty one."""
        with self._room:
            while self._queued + count > self._capacity and self._queued > 0:
                if not self.blocking or not self._thread.is_alive():
                    return False
                self._room.wait(0.5)
            self._queued += count
            return True

    def _taken(self, item: _Item) -> None:
        """The writer took ``item`` off the queue: its messages no longer count there."""
        with self._room:
            self._queued -= len(item.payload) if item.kind == "raws" else 1
            self._room.notify_all()

    @property
    def queued(self) -> int:
        """Messages waiting for the writer thread."""
        return self._queued

    # ------------------------------------------------------------------------------------------
    # Closing
    # ------------------------------------------------------------------------------------------

    def close(self) -> None:
        """Write everything queued, finish the file (summary, footer) and close it.

        Waits at most ``stop_timeout_s`` for the writer thread; what is still queued then is
        lost (logged). Idempotent.
        """
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._thread.join(self.config.stop_timeout_s)
        if self._thread.is_alive():
            log.error("recorder thread did not finish within %.1f s; %d message(s) unwritten; "
                      "%s is left without its summary", self.config.stop_timeout_s,
                      self._queued, self.path)
            return
        if self.dropped:
            log.warning("recorder dropped %d message(s) in total", self.dropped)
        if self.errors:
            log.warning("recorder failed to write %d message(s); first error: %s", self.errors,
                        self.error)
        log.info("recording %s closed: %d message(s)", self.path, self.written)

    def __enter__(self) -> Recorder:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # ------------------------------------------------------------------------------------------
    # The writer thread
    # ------------------------------------------------------------------------------------------

    def _run(self) -> None:
        poll_s = max(0.01, min(0.25, 0.25 * self.config.chunk_duration_s))
        try:
            while True:
                try:
                    if self._stop.is_set():
                        item = self._queue.get_nowait()
                    else:
                        item = self._queue.get(timeout=poll_s)
                except queue.Empty:
                    if self._stop.is_set():
                        break
                    self._maybe_close_chunk(None)
                    continue
                self._taken(item)
                for one in _unbatched(item):
                    try:
                        self._handle(one)
                    except Exception as exc:  # noqa: BLE001 (a bad message must not stop recording)
                        self._count_error(one, exc)
        finally:
            self._finish()

    def _count_error(self, item: _Item, exc: BaseException) -> None:
        self.errors += 1
        if self.error is None:
            self.error = exc
        if self.errors <= 10 or self.errors & (self.errors - 1) == 0:
            log.error("recorder could not write a message on %s (%d so far): %s",
                      item.topic, self.errors, exc)

    def _handle(self, item: _Item) -> None:
        if item.kind == "raw":  # its topic and time found here, where a bad unit is counted
            raw = item.payload
            item = _Item("msg", topics.raw_topic(raw), raw, raw.timestamp_s)
        if item.kind == "meta":
            self._writer.add_metadata(item.topic, item.payload)
            return
        log_ns = _checked_ns(item.log_time_s)
        if item.kind == "gps":
            self._write_proto(item.topic, foxglove_views.location_fix(item.payload), log_ns)
        elif item.kind == "proto":
            self._write_proto(item.topic, item.payload, log_ns)
        else:
            message = item.payload
            self._write_proto(item.topic, to_proto(message), log_ns)
            if self.config.foxglove:
                self._write_views(message, log_ns)
        self._maybe_close_chunk(log_ns)

    def _write_views(self, message: object, log_ns: int) -> None:
        if isinstance(message, MapState):
            period_ns = to_ns(self.config.foxglove_scene_period_s)
            if self._last_scene_ns is None or abs(log_ns - self._last_scene_ns) >= period_ns:
                self._last_scene_ns = log_ns
                car = self._car
                scene = foxglove_views.map_scene(
                    message, car.length_m, car.width_m, car.rear_overhang_m, self._cone_drawer
                )
                self._write_proto(topics.FOXGLOVE_SCENE, scene, log_ns)
            self._write_proto(topics.FOXGLOVE_TF, foxglove_views.frame_transform(message.pose),
                              log_ns)
            trace = self._trace.add(log_ns * 1e-9, message.pose.x_m, message.pose.y_m)
            if trace is not None:
                self._write_proto(topics.FOXGLOVE_SCENE, trace, log_ns)
        elif isinstance(message, Plan):
            # the candidates stay in /plan; drawn in the recorded scene they cost the car's
            # executive process several ms per plan (the live view draws them)
            self._write_proto(topics.FOXGLOVE_SCENE,
                              foxglove_views.plan_scene(message, candidates=False,
                                                        baseframe_memo=self._baseframe_memo),
                              log_ns)
        elif isinstance(message, TrackLayout):
            scene = foxglove_views.track_scene(message, log_ns * 1e-9)
            self._write_proto(topics.FOXGLOVE_SCENE, scene, log_ns)

    def _write_proto(self, topic: str, proto: ProtoMessage, log_ns: int) -> None:
        name = proto.DESCRIPTOR.full_name
        channel = self._channels.get(topic)
        if channel is None:
            schema_id = self._schemas.get(name)
            if schema_id is None:
                schema_id = register_schema(self._writer, type(proto))
                self._schemas[name] = schema_id
            channel_id = self._writer.register_channel(
                topic=topic, message_encoding=MessageEncoding.Protobuf, schema_id=schema_id
            )
            channel = (channel_id, name)
            self._channels[topic] = channel
        elif channel[1] != name:
            raise RecordingError(f"topic {topic} carries {channel[1]}, cannot write a {name}")
        data = proto.SerializeToString()
        self._writer.add_message(
            channel_id=channel[0], log_time=log_ns, data=data, publish_time=log_ns
        )
        self.written += 1
        if self._chunk_messages == 0:
            self._chunk_min_ns = self._chunk_max_ns = log_ns
            self._chunk_opened_wall_s = self._wall_clock_s()
        else:
            self._chunk_min_ns = min(self._chunk_min_ns, log_ns)
            self._chunk_max_ns = max(self._chunk_max_ns, log_ns)
        self._chunk_messages += 1
        self._chunk_bytes += len(data) + 31  # + the message record's header

    def _maybe_close_chunk(self, log_ns: int | None) -> None:
        if self._chunk_messages == 0:
            return
        duration_s = self.config.chunk_duration_s
        if (
            self._chunk_bytes >= self.config.chunk_size_bytes
            or (self._chunk_max_ns - self._chunk_min_ns) * 1e-9 >= duration_s
            or self._wall_clock_s() - self._chunk_opened_wall_s >= duration_s
        ):
            self._close_chunk()

    def _close_chunk(self) -> None:
        self._writer.flush()  # finalises the chunk and flushes the file
        self._chunk_messages = 0
        self._chunk_bytes = 0

    def _finish(self) -> None:
        try:
            self._writer.finish()
        except Exception as exc:  # noqa: BLE001
            log.error("could not finish recording %s: %s", self.path, exc)
            if self.error is None:
                self.error = exc
        finally:
            try:
                self._stream.close()
            except OSError as exc:
                log.error("could not close recording %s: %s", self.path, exc)
