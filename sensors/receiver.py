"""The receiver base: one named daemon thread per sensor, in the style of python-can's
``BusABC`` / ``Notifier``.

Two pieces, kept apart so the simulation loop and replay run the very same parsing code with no
thread at all (seed 002, 4.1.1: acquisition apart from processing):

- :class:`Intake` parses raw units (``RawBytes`` / ``CanFrame``) of ONE source with that source's
  parser and keeps what came out: the latest reading of each kind, a bounded deque of recent
  readings, everything since the last :meth:`Intake.take` (raw units too, for the recorder), and
  the statistics health is built from (count, rate over a window, age, errors, rejects).
  Thread-safe: a receiver thread feeds it while Main takes from it.
- :class:`Receiver` owns a transport and a thread: ``while not stopped: read(timeout)``, every
  raw unit stamped with ``clock.now_s()`` at receipt and handed to its :class:`Intake`. A
  transport that fails (serial port gone, socket error, CAN bus-off) is closed and reopened with
  exponential backoff. Every error is counted and logged; no exception escapes the thread.

Subclasses implement ``_open()``, ``_close()`` and ``_read(timeout_s) -> list[raw unit]``.
"""

from __future__ import annotations

import abc
import bisect
import collections
import itertools
import logging
import math
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

from common.clock import Clock
from common.errors import DecodeError
from common.messages import (
    CameraCones,
    CanFrame,
    GpsFix,
    ImuSample,
    LidarCones,
    MissionSelect,
    RawBytes,
    Reading,
    RemoteStop,
    SteeringAngle,
    WheelSpeeds,
)

logger = logging.getLogger(__name__)

RawUnit = RawBytes | CanFrame

READING_KEYS: dict[type, str] = {
    GpsFix: "gps",
    ImuSample: "imu",
    WheelSpeeds: "wheel_speeds",
    SteeringAngle: "steering",
    RemoteStop: "res",
    MissionSelect: "mission",
    LidarCones: "lidar",
    CameraCones: "camera",
}
"""The key of each reading type in ``latest`` dicts and per-kind statistics."""


def reading_key(reading: object) -> str:
    """Key of a reading in ``latest``: ``gps``, ``imu``, ``wheel_speeds``, ``steering``,
    ``res``, ``mission``, ``lidar``, ``camera`` (else the lower-case type name)."""
    key = READING_KEYS.get(type(reading))
    return key if key is not None else type(reading).__name__.lower()


class Parser(Protocol):
    """A stream parser of one source (``sensors/nmea.py`` and friends)."""

    source: str
    rejects: collections.Counter[str]

    def feed(self, timestamp_s: float, data: bytes) -> Sequence[Any]:
        """Readings completed by ``data`` (arbitrary chunks allowed), stamped ``timestamp_s``."""
        ...


class FrameDecoder(Protocol):
    """A CAN frame decoder (``sensors.can_codec.CanCodec``)."""

    rejects: collections.Counter[str]

    def decode(self, frame: CanFrame) -> Sequence[Any]:
        """Readings in one frame."""
        ...


class RateLimitedLog:
    """Logs the first ``burst`` events of each kind, then one in ``every`` (with the count)."""

    def __init__(self, log: logging.Logger, burst: int = 5, every: int = 1000) -> None:
        self._log = log
        self._burst = burst
        self._every = every
        self._seen: collections.Counter[str] = collections.Counter()

    def __call__(self, level: int, kind: str, msg: str, *args: object,
                 exc_info: bool = False) -> None:
        self._seen[kind] += 1
        n = self._seen[kind]
        if n <= self._burst or n % self._every == 0:
            suffix = f" [{kind} #{n}]" if n > self._burst else ""
            self._log.log(level, msg + suffix, *args, exc_info=exc_info)


@dataclass(frozen=True, slots=True)
class ReceiverStats:
    """Statistics of one source at ``timestamp_s`` (what health is made of).

    ``rate_hz`` is readings per second over the rate window; ``age_s`` the time since the last
    reading (inf when none yet); ``rejects`` merges the parser's rejects with the receiver's own
    (``decode_error``, ``parser_exception``, ``dropped``...); ``kinds`` maps each reading key to
    (count, rate_hz, age_s).
    """

    timestamp_s: float
    source: str
    count: int
    raw_count: int
    rate_hz: float
    age_s: float
    errors: int
    rejects: dict[str, int]
    connected: bool
    running: bool
    reconnects: int
    kinds: dict[str, tuple[int, float, float]] = field(default_factory=dict)


class _KindStats:
    __slots__ = ("count", "times", "last_s")

    def __init__(self, maxlen: int) -> None:
        self.count = 0
        self.times: collections.deque[float] = collections.deque(maxlen=maxlen)
        self.last_s = float("-inf")


def _rate(times: collections.deque[float], now_s: float, window_s: float) -> float:
    """Readings per second in the window (s) ending at ``now_s``.

    While the source has been seen for less than a window, the rate is measured over the span
    between its first and last reading instead.
    """
    if not times:
        return 0.0
    start = now_s - window_s
    # Times arrive in order (to within a reading's jitter): bisect instead of a scan, since
    # health() asks for every source's rate on every control tick.
    lo = bisect.bisect_right(times, start)
    hi = bisect.bisect_right(times, now_s, lo)
    n = hi - lo
    if n <= 0:
        return 0.0
    first = times[lo]
    oldest = times[0]
    if oldest > start and len(times) < (times.maxlen or 0):
        # seen for less than a window: use the span of what we have
        span = times[-1] - first
        return (n - 1) / span if n >= 2 and span > 0.0 else 0.0
    return n / window_s


class Intake:
    """Parse raw units of one source and keep the results (thread-safe).

    ``parser`` is either a stream :class:`Parser` (``feed(timestamp_s, payload)``, for
    ``RawBytes``) or a :class:`FrameDecoder` (``decode(frame)``, for ``CanFrame``).
    ``queue_length`` bounds the recent deque and the pending (untaken) lists; what does not fit
    is dropped and counted in ``rejects["dropped"]``. ``sequence`` (shared by the intakes of
    one manager) numbers the raw units in arrival order, so units of several sources with equal
    timestamps can be merged in the order they arrived (:meth:`take_tagged`).
    """

    def __init__(self, source: str, parser: Parser | FrameDecoder, queue_length: int = 4096,
                 rate_window_s: float = 2.0,
                 sequence: Iterator[int] | None = None, keep_raw: bool = True) -> None:
        self.source = source
        self.keep_raw = keep_raw
        """Keep the raw units for :meth:`take` (for the recorder); False when nobody records
        them (replay), which saves a deque entry per unit."""
        self.parser = parser
        self.queue_length = max(1, int(queue_length))
        self.rate_window_s = float(rate_window_s)
        self._lock = threading.Lock()
        self._sequence = sequence if sequence is not None else itertools.count()
        self._pending_raw: collections.deque[tuple[int, RawUnit]] = collections.deque()
        self._pending: collections.deque[tuple[int, Reading]] = collections.deque()
        self.recent: collections.deque[Reading] = collections.deque(maxlen=self.queue_length)
        self.latest: dict[str, Reading] = {}
        self.rejects: collections.Counter[str] = collections.Counter()
        self.errors = 0
        self.count = 0
        self.raw_count = 0
        self._times: collections.deque[float] = collections.deque(maxlen=self.queue_length)
        self._last_s = float("-inf")
        self._kinds: dict[str, _KindStats] = {}
        self._log = RateLimitedLog(logger)
        self._feed: Callable[[RawUnit], Sequence[Any]] = self._make_feed(parser)

    def _make_feed(self, parser: Any) -> Callable[[RawUnit], Sequence[Any]]:
        if hasattr(parser, "feed"):
            def feed(raw: RawUnit) -> Sequence[Any]:
                if not isinstance(raw, RawBytes):
                    raise TypeError(f"{self.source}: expected RawBytes, got {type(raw).__name__}")
                return parser.feed(raw.timestamp_s, raw.payload)  # type: ignore[no-any-return]
            return feed

        def decode(raw: RawUnit) -> Sequence[Any]:
            if not isinstance(raw, CanFrame):
                raise TypeError(f"{self.source}: expected CanFrame, got {type(raw).__name__}")
            return parser.decode(raw)  # type: ignore[no-any-return]
        return decode

    # -- feeding --------------------------------------------------------------------------

    def count_error(self, kind: str, message: str, *args: object, exc_info: bool = False) -> None:
        """Count one transport error and log it (rate-limited per ``kind``)."""
        with self._lock:
            self.errors += 1
        self._log(logging.WARNING, kind, "%s: " + message, self.source, *args, exc_info=exc_info)

    def ingest(self, raw: RawUnit) -> list[Reading]:
        """Parse one raw unit; keep it and its readings; return the readings.

        A parser that raises :class:`DecodeError` has its unit counted in
        ``rejects["decode_error"]``; any other exception is an error (counted and logged with its
        traceback). Nothing propagates.
        """
        try:
            readings = list(self._feed(raw))
        except DecodeError as exc:
            with self._lock:
                self.rejects["decode_error"] += 1
            self._log(logging.DEBUG, "decode_error", "%s: bad unit: %s", self.source, exc)
            readings = []
        except Exception:
            with self._lock:
                self.rejects["parser_exception"] += 1
                self.errors += 1
            self._log(logging.ERROR, "parser_exception", "%s: parser raised on a %d-byte unit",
                      self.source, len(getattr(raw, "payload", getattr(raw, "data", b""))),
                      exc_info=True)
            readings = []
        t_s = raw.timestamp_s
        seq = next(self._sequence)
        with self._lock:
            self.raw_count += 1
            if self.keep_raw:
                if len(self._pending_raw) >= self.queue_length:
                    self._pending_raw.popleft()
                    self.rejects["dropped_raw"] += 1
                self._pending_raw.append((seq, raw))
            for reading in readings:
                key = reading_key(reading)
                self.latest[key] = reading
                self.recent.append(reading)
                if len(self._pending) >= self.queue_length:
                    self._pending.popleft()
                    self.rejects["dropped"] += 1
                self._pending.append((seq, reading))
                kind = self._kinds.get(key)
                if kind is None:
                    kind = self._kinds[key] = _KindStats(self.queue_length)
                kind.count += 1
                kind.times.append(t_s)
                kind.last_s = max(kind.last_s, t_s)
                self.count += 1
                self._times.append(t_s)
                self._last_s = max(self._last_s, t_s)
        return readings

    # -- taking ---------------------------------------------------------------------------

    def take_tagged(self) -> tuple[list[tuple[int, RawUnit]], list[tuple[int, Reading]]]:
        """Raw units and readings since the last call, each with the sequence number of its
        raw unit (in arrival order)."""
        with self._lock:
            raw = list(self._pending_raw)
            readings = list(self._pending)
            self._pending_raw.clear()
            self._pending.clear()
        return raw, readings

    def take(self) -> tuple[list[RawUnit], list[Reading]]:
        """Raw units and readings since the last call (in arrival order)."""
        raw, readings = self.take_tagged()
        return [u for _, u in raw], [r for _, r in readings]

    def latest_copy(self) -> dict[str, Reading]:
        """The latest reading of each kind (key from :func:`reading_key`)."""
        with self._lock:
            return dict(self.latest)

    def all_rejects(self) -> dict[str, int]:
        """The parser's rejects merged with this intake's own."""
        parser: dict[str, int] = {}
        for _ in range(3):  # the parser's counter may change under us in its own thread
            try:
                parser = dict(self.parser.rejects)
                break
            except RuntimeError:
                continue
        with self._lock:
            own = dict(self.rejects) if self.rejects else {}
        if not parser and not own:  # the usual case, asked on every control tick
            return {}
        for k, v in own.items():
            parser[k] = parser.get(k, 0) + v
        return {k: int(v) for k, v in sorted(parser.items()) if v}

    def stats(self, now_s: float, *, connected: bool = True, running: bool = False,
              reconnects: int = 0) -> ReceiverStats:
        """Statistics at ``now_s`` on the run's clock."""
        with self._lock:
            rate = _rate(self._times, now_s, self.rate_window_s)
            age = now_s - self._last_s if self.count else float("inf")
            kinds = {
                key: (k.count, _rate(k.times, now_s, self.rate_window_s), now_s - k.last_s)
                for key, k in self._kinds.items()
            }
            count, raw_count, errors = self.count, self.raw_count, self.errors
        return ReceiverStats(now_s, self.source, count, raw_count, rate, age, errors,
                             self.all_rejects(), connected, running, reconnects, kinds)


    def health_figures(self, now_s: float, kind: str | None = None
                       ) -> tuple[float, float, int, tuple[tuple[str, int], ...]]:
        """``(rate_hz, age_s, errors, rejects)`` at ``now_s`` as :meth:`stats` has them (of the
        readings of ``kind`` alone when given: no errors nor rejects then), without building
        a :class:`ReceiverStats`: health asks for it on every control tick."""
        window = self.rate_window_s
        with self._lock:
            if kind is not None:
                k = self._kinds.get(kind)
                if k is None:
                    return 0.0, float("inf"), 0, ()
                return _rate(k.times, now_s, window), now_s - k.last_s, 0, ()
            rate = _rate(self._times, now_s, window)
            age = now_s - self._last_s if self.count else float("inf")
            errors = self.errors
        rejects = self.all_rejects()
        return rate, age, errors, tuple(rejects.items()) if rejects else ()


class Receiver(abc.ABC):
    """A transport read by one named daemon thread, its units handed to an :class:`Intake`.

    Use as a context manager or ``start()`` / ``stop()``. ``read_timeout_s`` bounds every
    blocking read (so ``stop`` is prompt); a failing transport is reopened after
    ``reconnect_min_s``, doubling up to ``reconnect_max_s`` while it keeps failing.
    """

    def __init__(self, source: str, clock: Clock, intake: Intake, *,
                 read_timeout_s: float = 0.05, reconnect_min_s: float = 0.05,
                 reconnect_max_s: float = 1.0) -> None:
        self.source = source
        self.clock = clock
        self.intake = intake
        self.read_timeout_s = float(read_timeout_s)
        self.reconnect_min_s = float(reconnect_min_s)
        self.reconnect_max_s = max(float(reconnect_max_s), self.reconnect_min_s)
        self.reconnects = 0
        self.connected = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._opened_once = False
        self._log = RateLimitedLog(logger, burst=3, every=100)
        self.awake_s = -math.inf
        """Up to when (s, the clock's) this thread has proven the sensor silent since its last
        unit: when it came back from a read with all it had delivered taken in, or, after a
        read that returned nothing, when that read began (a thread of a busy process may come
        back long after its wait ended). The time since ``awake_s`` is the reader's own delay,
        not the sensor's silence (:meth:`sensors.manager.SensorManager.health`)."""

    # -- the transport (subclasses) -------------------------------------------------------

    @abc.abstractmethod
    def _open(self) -> None:
        """Open the transport; raise on failure (it is retried)."""

    @abc.abstractmethod
    def _close(self) -> None:
        """Close the transport (must not raise for an already closed one)."""

    @abc.abstractmethod
    def _read(self, timeout_s: float) -> list[RawUnit]:
        """Wait at most ``timeout_s`` for data; return the raw units received (maybe none).

        Raise when the transport failed: it is closed and reopened.
        """

    def describe(self) -> str:
        """Where this receiver reads from (for logs)."""
        return self.source

    # -- lifecycle ------------------------------------------------------------------------

    def start(self) -> None:
        """Start the thread (the transport is opened in it, and reopened when it fails)."""
        if self._thread is not None and self._thread.is_alive():
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"receiver-{self.source}",
                                        daemon=True)
        self._thread.start()

    def request_stop(self) -> None:
        """Ask the thread to stop (returns at once; see :meth:`join`)."""
        self._stop.set()

    def join(self, timeout_s: float | None = None) -> bool:
        """Wait for the thread to end; True when it has."""
        if self._thread is None:
            return True
        self._thread.join(timeout_s)
        return not self._thread.is_alive()

    def stop(self, timeout_s: float = 1.0) -> bool:
        """Stop the thread and wait at most ``timeout_s`` (s); True when it ended."""
        self.request_stop()
        ended = self.join(timeout_s)
        if not ended:
            logger.error("%s: receiver thread did not stop within %.2f s", self.source, timeout_s)
        return ended

    def is_alive(self) -> bool:
        """True while the thread runs."""
        return self._thread is not None and self._thread.is_alive()

    def wait_connected(self, timeout_s: float) -> bool:
        """Block until the transport is open (True) or ``timeout_s`` passed (False)."""
        return self.connected.wait(timeout_s)

    def __enter__(self) -> Receiver:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def stats(self, now_s: float) -> ReceiverStats:
        """Statistics of this receiver at ``now_s``."""
        return self.intake.stats(now_s, connected=self.connected.is_set(),
                                 running=self.is_alive(), reconnects=self.reconnects)

    # -- the thread -----------------------------------------------------------------------

    def _safe_close(self) -> None:
        self.connected.clear()
        try:
            self._close()
        except Exception as exc:
            self.intake.count_error("close", "closing %s failed: %r", self.describe(), exc)

    def _try_open(self) -> bool:
        try:
            self._open()
        except Exception as exc:
            self.intake.count_error("open", "cannot open %s: %r", self.describe(), exc)
            self._safe_close()
            return False
        if self._opened_once:
            self.reconnects += 1
            logger.info("%s: reconnected to %s", self.source, self.describe())
        else:
            logger.info("%s: opened %s", self.source, self.describe())
        self._opened_once = True
        self.connected.set()
        return True

    def _run(self) -> None:
        backoff = self.reconnect_min_s
        try:
            while not self._stop.is_set():
                if not self.connected.is_set():
                    if not self._try_open():
                        self.awake_s = self.clock.now_s()
                        self._stop.wait(backoff)
                        backoff = min(backoff * 2.0, self.reconnect_max_s)
                        continue
                started_s = self.clock.now_s()
                try:
                    units = self._read(self.read_timeout_s)
                except Exception as exc:
                    self.intake.count_error("read", "%s failed: %r; reopening", self.describe(),
                                            exc)
                    self._safe_close()
                    self.awake_s = self.clock.now_s()
                    self._stop.wait(backoff)
                    backoff = min(backoff * 2.0, self.reconnect_max_s)
                    continue
                returned_s = self.clock.now_s()
                if units:
                    backoff = self.reconnect_min_s
                    for unit in units:
                        self.intake.ingest(unit)
                    self.awake_s = returned_s  # only now: what the read returned is taken in
                else:
                    # An empty read proves the silence up to when it began waiting, no further:
                    # the thread may have waited long for the GIL after its wait ended, and
                    # what arrived meanwhile is read next time, not lost.
                    self.awake_s = started_s
        except BaseException:  # never let anything escape the thread unreported
            self.intake.count_error("thread", "receiver thread crashed", exc_info=True)
        finally:
            self._safe_close()
            logger.debug("%s: receiver thread ended", self.source)


def join_all(receivers: Iterable[Receiver], timeout_s: float) -> list[str]:
    """Stop every receiver against ONE deadline; return the sources whose thread did not end."""
    receivers = list(receivers)
    for r in receivers:
        r.request_stop()
    deadline = time.monotonic() + timeout_s
    late = []
    for r in receivers:
        if not r.join(max(0.0, deadline - time.monotonic())):
            late.append(r.source)
    if late:
        logger.error("receivers still running after %.2f s: %s", timeout_s, ", ".join(late))
    return late
