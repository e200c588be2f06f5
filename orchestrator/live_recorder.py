"""The recording in a process of its own: ``drive``'s, and ``sim --realtime``'s.

In the executive process the recorder's writer thread (converting every raw unit and map
state to protobuf, the Foxglove views, MCAP's framing) held the interpreter lock about 13 % of
the time that the mapper and the sensors' receiver threads wait for it (a ``py-spy --gil``
profile of ``bench load``, issue 19). Here :class:`RecorderProcess` takes the
:class:`~recordings.recorder.Recorder`'s calls in the executive (``write``, ``write_proto``,
``write_raw_many``, ``write_gps_fix``) as references on a list; its ``recorder-link`` thread
sends them every :data:`SEND_PERIOD_S` as one :class:`RecordBatch` to a process that runs the
real :class:`~recordings.recorder.Recorder`, at the recording's niceness (lower than
planning's: control > mapping > planning > recording > rendering).

Nothing is lost silently, and the executive never waits: the recorder there is ``blocking``
(it waits for room, so the link fills when it falls behind); in the executive a message that
would take the list past ``recording.queue_length`` is dropped and counted in
:attr:`RecorderProcess.dropped`, logged at powers of two, as the in-process recorder drops.
When the executive process dies, the recorder's process sees its link close and finishes the
file (summary and footer): a killed executive (or a killed ``sim --realtime``) leaves a
complete recording, less at most :data:`SEND_PERIOD_S` of what it had not yet sent.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import socket
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from google.protobuf import descriptor_pool, message_factory

from common.car import CarConfig
from common.errors import RecordingError
from common.messages import CanFrame, GpsFix, RawBytes
from orchestrator.layer_messages import Final, LayerError, Loaded, Stop
from orchestrator.live_link import Link, link_pair
from orchestrator.priority import enter_child_process, nicer_by
from recordings.config import RecordingConfig
from recordings.drops import DropCount

log = logging.getLogger(__name__)

SEND_PERIOD_S = 0.05
"""How often the messages queued in the executive go to the recorder's process (s): one
pickled batch each time, so the file lags what was received by at most this much more."""
RECORDER_NICENESS_STEP = 8
"""The recorder's process runs this much nicer than the executive process (the planner's runs
5 nicer, the visualiser's 10)."""
START_TIMEOUT_S = 60.0
"""Longest wait (s) for the recorder's process to open its file."""
STOP_MARGIN_S = 5.0
"""Waited (s) past ``recording.stop_timeout_s`` for the recorder's process at the end."""


@dataclass(frozen=True, slots=True)
class RecordBatch:
    """Recorder calls in the order they were made: ``("msg", topic, message, log_time_s)``,
    ``("raws", units)``, ``("rawt", units as tuples)`` or ``("gps", fix)``."""

    calls: tuple[tuple[Any, ...], ...]


class RecorderProcess:
    """A :class:`~recordings.recorder.Recorder` in a process of its own (module docstring),
    writing ``path`` with ``config`` at ``niceness``.

    ``car`` and ``metadata`` go to the recording as the in-process recorder writes them.
    ``start_method`` is ``multiprocessing``'s: ``"spawn"`` (``drive``: a fresh interpreter,
    which imports what it needs) or ``"fork"`` (``sim --realtime``: ready at once, because the
    simulation's clock starts when it is; call it before the caller starts any thread).

    Thread-safe, and never blocks the caller. Call :meth:`wait_started` before the run (it
    reports a file that cannot be created) and :meth:`close` at the end.
    """

    def __init__(self, path: str | Path, config: RecordingConfig, niceness: int,
                 log_level: int = logging.INFO, car: CarConfig | None = None,
                 metadata: Mapping[str, str] | None = None,
                 start_method: Literal["spawn", "fork"] = "spawn", blocking: bool = False) -> None:
        self.path = Path(path)
        self.config = config
        self.blocking = blocking
        """Wait for room on the list instead of dropping (``sim`` as fast as it goes: a dropped
        message would break the replay; the loop then waits for the recorder's process)."""
        self._drops = DropCount()
        self.written = 0
        """Messages the recorder's process wrote (known after :meth:`close`)."""
        self.errors = 0
        """Messages it could not convert or write (known after :meth:`close`)."""
        self._capacity = max(1, config.queue_length)
        self._calls: list[tuple[Any, ...]] = []
        self._queued = 0
        self._lock = threading.Lock()
        self._room = threading.Condition(self._lock)
        self._closed = False
        self._wake = threading.Event()
        ours, theirs = link_pair()
        forked = start_method == "fork"
        if forked and threading.active_count() > 1:
            log.warning("the recorder's process is forked beside %d other thread(s): a lock one "
                        "of them holds stays held in it", threading.active_count() - 1)
        # A forked child holds a copy of our end too: it closes it, or it would never see the
        # link close when this process dies.
        context = mp.get_context("fork") if forked else mp.get_context("spawn")
        self._process = context.Process(
            target=recorder_main, name="fsd-recorder", daemon=True,
            args=(str(self.path), config, theirs, log_level, niceness, car,
                  dict(metadata) if metadata is not None else None, ours if forked else None))
        self._process.start()
        theirs.close()
        self._link = Link(ours)
        self._sender = threading.Thread(target=self._send_loop, name="recorder-link",
                                        daemon=True)
        self._sender.start()

    # -- the executive's side: never blocks ------------------------------------------------

    def write(self, topic: str, message: object, log_time_s: float) -> bool:
        """Queue ``message`` for ``topic`` at ``log_time_s`` (``Recorder.write``)."""
        return self._put(("msg", topic, message, log_time_s), 1)

    def __call__(self, topic: str, message: object, log_time_s: float) -> bool:
        return self.write(topic, message, log_time_s)

    def write_proto(self, topic: str, proto: Any, log_time_s: float) -> bool:
        """Queue a protobuf message as it is (``Recorder.write_proto``). It travels as its type's
        full name and its bytes: generated classes do not pickle."""
        return self._put(("proto", topic, proto.DESCRIPTOR.full_name, proto.SerializeToString(),
                          log_time_s), 1)

    def write_raw_many(self, units: tuple[RawBytes | CanFrame, ...] | list[Any]) -> bool:
        """Queue raw units, each on its source's topic at its time (``Recorder.write_raw_many``)."""
        if not units:
            return True
        # as plain tuples, which pickle in C: a frozen dataclass pickles through its
        # __reduce_ex__, about twice the time per unit, in this process (issue 42)
        flat = tuple((u.timestamp_s, u.source, u.payload) if isinstance(u, RawBytes)
                     else (u.timestamp_s, u.arbitration_id, u.data, u.is_extended_id)
                     for u in units)
        return self._put(("rawt", flat), len(units))

    def write_gps_fix(self, fix: GpsFix) -> bool:
        """Queue a parsed GNSS fix for the Foxglove view (``Recorder.write_gps_fix``)."""
        if not self.config.foxglove:
            return True
        return self._put(("gps", fix), 1)

    def _put(self, call: tuple[Any, ...], count: int) -> bool:
        with self._lock:
            while (self.blocking and not self._closed and self._queued
                   and self._queued + count > self._capacity and self._sender.is_alive()):
                self._wake.set()  # send what is queued now, not at the next period
                self._room.wait(SEND_PERIOD_S)
            if not self._closed and (self._queued + count <= self._capacity
                                     or (self.blocking and not self._queued)):
                self._calls.append(call)
                self._queued += count
                return True
        self._drops.add(count, "recorder closed" if self._closed else "queue full")
        return False

    @property
    def dropped(self) -> int:
        """Messages not recorded: the list full, the process gone, or dropped there."""
        return self._drops.count

    # -- the link -----------------------------------------------------------------------------

    def _send_loop(self) -> None:
        while True:
            self._wake.wait(SEND_PERIOD_S)
            self._wake.clear()
            with self._lock:
                calls, count = self._calls, self._queued
                self._calls, self._queued = [], 0
                closing = self._closed
                self._room.notify_all()
            try:
                sent = not calls or self._link.send(RecordBatch(tuple(calls)))
                why = "the recorder's process is gone"
            except Exception as exc:  # noqa: BLE001 (a message that cannot be sent ends nothing)
                sent, why = False, f"a message could not be sent ({exc})"
            if not sent:
                self._drops.add(count, why)
            if closing:
                return

    def wait_started(self, timeout_s: float = START_TIMEOUT_S) -> str | None:
        """Wait until the recorder's process has opened the file: None, or why it did not."""
        end = time.monotonic() + timeout_s
        while not self._link.closed and time.monotonic() < end:
            for message in self._link.recv(0.05):
                if isinstance(message, Loaded):
                    return None
                if isinstance(message, LayerError):
                    return message.text
        return "recorder: the recorder's process did not start"

    def close(self) -> None:
        """Send what is queued, let the process finish the file, take its counts. Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self._wake.set()
        self._sender.join()
        self._link.send(Stop())
        end = time.monotonic() + self.config.stop_timeout_s + STOP_MARGIN_S
        stats: dict[str, Any] | None = None
        while stats is None and not self._link.closed and time.monotonic() < end:
            for message in self._link.recv(0.1):
                if isinstance(message, Final):
                    stats = message.stats
        self._link.close()
        self._process.join(STOP_MARGIN_S)
        if self._process.is_alive():
            log.error("the recorder's process did not end: killing it (%s may lack its summary)",
                      self.path)
            self._process.kill()
            self._process.join(STOP_MARGIN_S)
        if stats is None:
            log.error("the recorder's process sent no counts: %s may be incomplete", self.path)
            return
        self.written = int(stats.get("written", 0))
        self.errors = int(stats.get("errors", 0))
        if int(stats.get("dropped", 0)):
            self._drops.add(int(stats["dropped"]), "in the recorder's process")


def _apply(recorder: Any, call: tuple[Any, ...]) -> None:
    kind = call[0]
    if kind == "msg":
        recorder.write(call[1], call[2], call[3])
    elif kind == "proto":
        descriptor = descriptor_pool.Default().FindMessageTypeByName(call[2])
        recorder.write_proto(call[1], message_factory.GetMessageClass(descriptor)
                             .FromString(call[3]), call[4])
    elif kind == "raws":
        recorder.write_raw_many(call[1])
    elif kind == "rawt":
        recorder.write_raw_many([RawBytes(*u) if len(u) == 3 else CanFrame(*u)
                                 for u in call[1]])
    elif kind == "gps":
        recorder.write_gps_fix(call[1])
    else:
        raise RecordingError(f"unknown recorder call {kind!r}")


def recorder_main(path: str, config: RecordingConfig, sock: socket.socket, log_level: int,
                  niceness: int, car: CarConfig | None = None,
                  metadata: dict[str, str] | None = None,
                  parent_end: socket.socket | None = None) -> None:
    """Entry point of the recorder's process (``multiprocessing`` target): record what comes
    over the link until :class:`Stop` or the link closes, then finish the file and send
    :class:`Final` with the counts. ``parent_end``: the other end of the link, inherited by a
    forked child, closed here first."""
    if parent_end is not None:
        parent_end.close()
    enter_child_process("recorder process", log_level, niceness)
    link = Link(sock)
    from recordings.recorder import Recorder

    try:
        recorder = Recorder(path, config, car, metadata=metadata, blocking=True)
    except Exception as exc:
        log.exception("the recorder's process could not start")
        link.send(LayerError(f"recorder start: {exc}"))
        link.close()
        return
    link.send(Loaded())
    failed = 0
    try:
        stopped = False
        while not stopped and not link.closed:
            for message in link.recv(0.5):
                if isinstance(message, RecordBatch):
                    for call in message.calls:
                        try:
                            _apply(recorder, call)
                        except Exception:  # noqa: BLE001 (one bad call must not end the file)
                            failed += 1
                            log.exception("recorder call %r failed", call[0])
                elif isinstance(message, Stop):
                    stopped = True
        if not stopped:
            log.error("the process that fed the recorder is gone: finishing %s", path)
    finally:
        recorder.close()
        link.send(Final({"written": recorder.written, "errors": recorder.errors + failed,
                         "dropped": recorder.dropped}))
        link.close()


def recorder_niceness(executive_niceness: int) -> int:
    """The recorder's process's niceness beside the executive's (within -20..19)."""
    return nicer_by(executive_niceness, RECORDER_NICENESS_STEP)
