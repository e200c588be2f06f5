"""The player: a recording's messages in log-time order, on the recording's own clock.

``Player(path)`` iterates ``(log_time_s, topic, message)`` with ``message`` converted back to its
:mod:`common.messages` type (a :class:`common.track.TrackLayout` on ``/truth/track``).
The order is the recording's log-time order across all topics, whatever the rate: the rate only
decides how long the pacer sleeps before yielding, never what is yielded or in which order
(the rosbag2 #2091 failure). ``rate=None`` plays as fast as possible (``--max``); ``rate=R``
paces so that R seconds of recording pass per wall second (1 = real time).

The pacer is the only use of wall time: it sleeps on a wall :class:`common.clock.Clock`
(``clock``, a :class:`common.clock.RealClock` by default) and never changes what is yielded.
Decoding is protobuf only (no pickle, no eval).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from common.clock import Clock, RealClock
from common.errors import RecordingError
from recordings import topics as topic_names
from recordings.codec import PROTO_CLASSES, from_proto
from recordings.reader import RecordedMessage, RecordingReader

log = logging.getLogger(__name__)


class Player:
    """Iterate a recording (see the module docstring).

    ``topics`` limits what is played; by default every topic except the derived Foxglove views
    (ask for those by name to get their protobuf messages as they are). A message that cannot
    be decoded is skipped, logged and counted in :attr:`decode_errors`. After (or during)
    iteration, :attr:`recovered` says whether the file had to be recovered.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        rate: float | None = None,
        clock: Clock | None = None,
        topics: Iterable[str] | None = None,
    ) -> None:
        if rate is not None and not rate > 0.0:
            raise ValueError(f"replay rate must be positive (or None for as fast as possible), "
                             f"got {rate!r}")
        self.path = Path(path)
        self.rate = rate
        self._clock = clock
        self._topics = None if topics is None else tuple(topics)
        self.decode_errors = 0
        self.played = 0
        self.recovered = False
        with RecordingReader(self.path) as reader:
            self.recovered = reader.recovered
            self.metadata = reader.metadata
            self.available_topics = reader.topics

    def __iter__(self) -> Iterator[tuple[float, str, object]]:
        with RecordingReader(self.path) as reader:
            wanted = self._topics
            if wanted is None:
                wanted = tuple(
                    t for t in reader.topics if t not in topic_names.DERIVED_TOPICS
                )
            pacer = _Pacer(self.rate, self._clock) if self.rate is not None else None
            decoders: dict[int, tuple[str, Callable[[bytes], object]]] = {}
            try:
                for log_time_ns, _, _, channel_id, data in reader.iter_entries(wanted):
                    log_time_s = log_time_ns * 1e-9
                    try:
                        known = decoders.get(channel_id)
                        if known is None:
                            known = decoders[channel_id] = _decoder(reader, channel_id)
                        topic, decode = known
                        message = decode(data)
                    except RecordingError as exc:
                        self.decode_errors += 1
                        if self.decode_errors <= 10:
                            log.warning("%s: skipping a message at %.6f s: %s", self.path,
                                        log_time_s, exc)
                        continue
                    if pacer is not None:
                        pacer.wait(log_time_s)
                    self.played += 1
                    yield log_time_s, topic, message
            finally:
                self.recovered = reader.recovered


def _decoder(reader: RecordingReader, channel_id: int) -> tuple[str, Callable[[bytes], object]]:
    """(topic, bytes -> message) for a channel: protobuf, then :func:`from_proto` for ``fsd``."""
    channel = reader.channels[channel_id]
    schema = reader.schemas.get(channel.schema_id)
    name = schema.name if schema is not None else ""
    cls = PROTO_CLASSES.get(name)
    if cls is not None:
        from_string = cls.FromString

        def decode(data: bytes) -> object:
            try:
                proto = from_string(data)
            except Exception as exc:  # noqa: BLE001 (DecodeError)
                raise RecordingError(f"cannot decode a {name} on {channel.topic}: {exc}") from exc
            return from_proto(proto)

        return channel.topic, decode

    def decode_other(data: bytes) -> object:
        return reader.decode(RecordedMessage(0, channel.topic, name, data, channel_id))

    return channel.topic, decode_other


class _Pacer:
    """Sleep so that recording time advances ``rate`` times as fast as wall time."""

    def __init__(self, rate: float, clock: Clock | None) -> None:
        self._rate = rate
        self._clock: Clock = clock if clock is not None else RealClock()
        self._origin: tuple[float, float] | None = None  # (recording s, wall s)

    def wait(self, t_s: float) -> None:
        if self._origin is None:
            self._origin = (t_s, self._clock.now_s())
            return
        t0_s, wall0_s = self._origin
        self._clock.sleep_until(wall0_s + (t_s - t0_s) / self._rate)
