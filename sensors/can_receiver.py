"""The CAN receiver: a python-can bus of any interface (``socketcan`` on the car, ``slcan`` for a
USB-CAN adapter or a pty, ``udp_multicast`` / ``virtual`` in tests), decoded with the car's DBC.

Frames are stamped ``clock.now_s()`` at receipt (not the interface's own timestamp, which is wall
time or the adapter's counter). Error frames are counted as errors; a bus-off error frame or a
failing ``recv`` closes the bus and reopens it with backoff. :meth:`CanReceiver.send` puts an
actuator command frame on the bus (thread-safe; a failure is counted, logged and reported as
False, never raised into the control loop). :meth:`CanReceiver.post` hands a frame to a sender
thread of its own and returns at once, so the control loop never waits on the bus; of the
frames waiting with one id only the latest is sent. An slcan adapter's frames are written by
:class:`sensors.slcan_writer.SlcanWriter`, which never polls the tty: pyserial's write does, and
on a busy computer issue 19 measured such sends held up to 480 ms (the control tick with them,
before the sender thread).

On the car (SocketCAN) reopening the socket does not restart a bus-off controller: give the
kernel an automatic restart, ``ip link set can0 type can bitrate 500000 restart-ms 100``.
A garbled line from a serial adapter (slcan) loses that frame only: it is counted, the bus
stays open.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from typing import Any

import can
import numpy as np
from can.interfaces.slcan import slcanBus

from common.clock import Clock
from common.errors import SensorError
from common.messages import CanFrame
from sensors.can_codec import CanCodec
from sensors.receiver import Intake, RawUnit, Receiver
from sensors.slcan_writer import SlcanWriter

logger = logging.getLogger(__name__)

CAN_ERR_BUSOFF = 0x00000040
"""Linux SocketCAN error class bit of a bus-off error frame (``linux/can/error.h``)."""


def _slcan_writer(bus: can.BusABC) -> SlcanWriter | None:
    """A :class:`SlcanWriter` on ``bus``'s tty when it is python-can's slcan bus on a serial
    port (not a ``socket://`` URL), else None (the bus's own ``send`` is used)."""
    port = getattr(bus, "serialPortOrig", None)
    fd = getattr(port, "fd", None)
    if isinstance(bus, slcanBus) and isinstance(fd, int):
        return SlcanWriter(fd)
    return None


SENDER_FINISH_S = 0.5
"""How long (s) a stopping receiver waits for its sender thread to send what is posted."""


class CanReceiver(Receiver):
    """Read a python-can bus in a thread and decode it with ``codec``.

    ``bus_kwargs`` are passed on to ``can.Bus`` (e.g. ``sleep_after_open`` for slcan).
    ``bitrate`` 0 leaves the interface's own setting alone.
    """

    def __init__(self, clock: Clock, codec: CanCodec, interface: str, channel: str,
                 bitrate: int = 500000, *, bus_kwargs: dict[str, Any] | None = None,
                 queue_length: int = 4096, rate_window_s: float = 2.0,
                 read_timeout_s: float = 0.05, reconnect_min_s: float = 0.05,
                 reconnect_max_s: float = 1.0, send_timeout_s: float = 0.01) -> None:
        super().__init__("can", clock, Intake("can", codec, queue_length, rate_window_s),
                         read_timeout_s=read_timeout_s, reconnect_min_s=reconnect_min_s,
                         reconnect_max_s=reconnect_max_s)
        self.codec = codec
        self.interface = interface
        self.channel = channel
        self.bitrate = int(bitrate)
        self.bus_kwargs = dict(bus_kwargs or {})
        self.send_timeout_s = send_timeout_s
        self.sent = 0
        self.send_errors = 0
        self.error_frames = 0
        self._bus: can.BusABC | None = None
        self._slcan: SlcanWriter | None = None
        """Writes this bus's frames when it is an slcan adapter on a tty (never waits)."""
        self._send_lock = threading.Lock()
        # The sender thread's side (post): frames waiting, by (id, extended), oldest first.
        self.superseded = 0
        """Posted frames replaced by a newer one with the same id before they were sent."""
        self._outbox: dict[tuple[int, bool], tuple[CanFrame, float]] = {}
        self._outbox_ready = threading.Condition()
        self._sender: threading.Thread | None = None
        self._sender_stop = False
        self._send_lags_s: deque[float] = deque(maxlen=100_000)
        self._echoes_own = interface == "udp_multicast"
        """python-can's ``udp_multicast`` hands every frame back to its sender (IP multicast
        loops back to every socket on the host); SocketCAN and slcan do not. On such a bus a
        frame with an id this receiver sends is its own, and is dropped on receipt."""
        self._sent_ids: set[tuple[int, bool]] = set()

    def describe(self) -> str:
        return f"CAN {self.interface}:{self.channel}"

    def _open(self) -> None:
        kwargs = dict(self.bus_kwargs)
        if self.bitrate > 0:
            kwargs.setdefault("bitrate", self.bitrate)
        bus = can.Bus(interface=self.interface, channel=self.channel, **kwargs)
        with self._send_lock:
            self._bus = bus
            self._slcan = _slcan_writer(bus)

    def _close(self) -> None:
        sender = self._sender
        if self._sender_stop and sender is not None and sender is not threading.current_thread():
            sender.join(SENDER_FINISH_S)  # stopping for good: what is posted goes out first
            if sender.is_alive():
                logger.error("%s: sender thread did not finish within %.2f s", self.describe(),
                             SENDER_FINISH_S)
        with self._send_lock:
            bus, self._bus = self._bus, None
            self._slcan = None
        if bus is not None:
            bus.shutdown()

    def _read(self, timeout_s: float) -> list[RawUnit]:
        bus = self._bus
        if bus is None:
            raise SensorError("bus is not open")
        try:
            msg = bus.recv(timeout_s)
        except (ValueError, IndexError) as exc:
            # a garbled line from a serial adapter (slcan): that frame is lost, the bus is fine
            self.intake.count_error("garbled", "garbled frame from %s: %r", self.describe(), exc)
            return []
        if msg is None:
            return []
        if msg.is_error_frame:
            self.error_frames += 1
            busoff = bool(msg.arbitration_id & CAN_ERR_BUSOFF)
            self.intake.count_error("error_frame", "error frame 0x%08X %s%s", msg.arbitration_id,
                                    bytes(msg.data).hex(), " (bus-off)" if busoff else "")
            if busoff:
                raise SensorError(f"{self.describe()}: bus-off")
            return []
        if msg.is_remote_frame:
            return []
        if self._echoes_own and (msg.arbitration_id, msg.is_extended_id) in self._sent_ids:
            return []
        return [CanFrame(self.clock.now_s(), msg.arbitration_id, bytes(msg.data),
                         msg.is_extended_id)]

    # -- sending ----------------------------------------------------------------------------

    def start(self) -> None:
        """Start the receiver thread and the sender thread (both inherit the caller's
        scheduling policy)."""
        super().start()
        if self._sender is not None and self._sender.is_alive():
            return
        with self._outbox_ready:
            self._sender_stop = False
        self._sender = threading.Thread(target=self._send_loop, name="sender-can", daemon=True)
        self._sender.start()

    def request_stop(self) -> None:
        """Ask both threads to stop (returns at once): the sender sends what is posted, then
        the receiver thread closes the bus (:meth:`_close` waits for the sender)."""
        with self._outbox_ready:
            self._sender_stop = True
            self._outbox_ready.notify()
        super().request_stop()

    def post(self, frame: CanFrame) -> None:
        """Hand ``frame`` to the sender thread and return at once (never waits on the bus).

        A frame still waiting with the same id (an older command or status) is replaced and
        counted in :attr:`superseded`: the bus gets the latest, never a stale one late. Before
        :meth:`start` or after :meth:`stop` the frame is sent here, synchronously.
        """
        sender = self._sender
        if sender is None or not sender.is_alive():
            self.send(frame)
            return
        key = (frame.arbitration_id, frame.is_extended_id)
        with self._outbox_ready:
            if self._outbox.pop(key, None) is not None:
                self.superseded += 1
            self._outbox[key] = (frame, self.clock.now_s())
            self._outbox_ready.notify()

    def send_stats(self) -> dict[str, float | int]:
        """Frames sent, failed and superseded, and how long (ms) posted frames waited for
        the bus: the 99th percentile and the maximum of the time from :meth:`post` to sent."""
        out: dict[str, float | int] = {"sent": self.sent, "errors": self.send_errors,
                                       "superseded": self.superseded}
        lags_ms = np.asarray(self._send_lags_s) * 1e3
        if lags_ms.size:
            out["lag_p99_ms"] = round(float(np.percentile(lags_ms, 99)), 3)
            out["lag_max_ms"] = round(float(lags_ms.max()), 3)
        return out

    def _send_loop(self) -> None:
        while True:
            with self._outbox_ready:
                while not self._outbox and not self._sender_stop:
                    self._outbox_ready.wait()
                if not self._outbox:
                    return
                waiting = list(self._outbox.values())
                self._outbox.clear()
            for frame, posted_s in waiting:
                self.send(frame)
                self._send_lags_s.append(self.clock.now_s() - posted_s)

    def send(self, frame: CanFrame) -> bool:
        """Send ``frame`` on the bus; False (counted, logged) when the bus is down or refuses."""
        with self._send_lock:
            bus = self._bus
            if bus is None:
                self.send_errors += 1
                self.intake.count_error("send", "cannot send 0x%03X: bus not open",
                                        frame.arbitration_id)
                return False
            try:
                msg = can.Message(arbitration_id=frame.arbitration_id, data=frame.data,
                                  is_extended_id=frame.is_extended_id, check=True)
                if self._echoes_own:
                    self._sent_ids.add((frame.arbitration_id, frame.is_extended_id))
                if self._slcan is not None:
                    self._slcan.send(msg)
                else:
                    bus.send(msg, timeout=self.send_timeout_s)
            except Exception as exc:  # can.CanError, OSError, serial errors, a bad frame
                self.send_errors += 1
                self.intake.count_error("send", "sending 0x%03X failed: %r",
                                        frame.arbitration_id, exc)
                return False
        self.sent += 1
        return True
