"""The CAN receiver: a python-can bus of any interface (``socketcan`` on the car, ``slcan`` for a
USB-CAN adapter or a pty, ``udp_multicast`` / ``virtual`` in tests), decoded with the car's DBC.

Frames are stamped ``clock.now_s()`` at receipt (not the interface's own timestamp, which is wall
time or the adapter's counter). Error frames are counted as errors; a bus-off error frame or a
failing ``recv`` closes the bus and reopens it with backoff. :meth:`CanReceiver.send` puts an
actuator command frame on the bus (thread-safe; a failure is counted, logged and reported as
False, never raised into the control loop).

On the car (SocketCAN) reopening the socket does not restart a bus-off controller: give the
kernel an automatic restart, ``ip link set can0 type can bitrate 500000 restart-ms 100``.
A garbled line from a serial adapter (slcan) loses that frame only: it is counted, the bus
stays open.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

import can

from common.clock import Clock
from common.errors import SensorError
from common.messages import CanFrame
from sensors.can_codec import CanCodec
from sensors.receiver import Intake, RawUnit, Receiver

logger = logging.getLogger(__name__)

CAN_ERR_BUSOFF = 0x00000040
"""Linux SocketCAN error class bit of a bus-off error frame (``linux/can/error.h``)."""


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
        self._send_lock = threading.Lock()

    def describe(self) -> str:
        return f"CAN {self.interface}:{self.channel}"

    def _open(self) -> None:
        kwargs = dict(self.bus_kwargs)
        if self.bitrate > 0:
            kwargs.setdefault("bitrate", self.bitrate)
        self._bus = can.Bus(interface=self.interface, channel=self.channel, **kwargs)

    def _close(self) -> None:
        with self._send_lock:
            bus, self._bus = self._bus, None
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
        return [CanFrame(self.clock.now_s(), msg.arbitration_id, bytes(msg.data),
                         msg.is_extended_id)]

    def send(self, frame: CanFrame) -> bool:
        """Send ``frame`` on the bus; False (counted, logged) when the bus is down or refuses."""
        with self._send_lock:
            bus = self._bus
            if bus is None:
                self.send_errors += 1
                self.intake.count_error("send", "cannot send 0x%03X: bus not open",
                                        frame.arbitration_id)
                return False
            msg = can.Message(arbitration_id=frame.arbitration_id, data=frame.data,
                              is_extended_id=frame.is_extended_id)
            try:
                bus.send(msg, timeout=self.send_timeout_s)
            except Exception as exc:  # can.CanError, OSError, serial errors
                self.send_errors += 1
                self.intake.count_error("send", "sending 0x%03X failed: %r",
                                        frame.arbitration_id, exc)
                return False
        self.sent += 1
        return True
