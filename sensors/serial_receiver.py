"""Serial receivers (pyserial ``serial_for_url``: a device path, a pty, ``socket://``,
``rfc2217://``, ``loop://``...) for the NMEA GPS and the IMU.

The port is reopened (with backoff) when it vanishes and comes back, e.g. a USB adapter
unplugged and replugged. What is read is cut into raw units by a framer: NMEA by line (one
sentence with its CR LF per ``RawBytes``, as the simulator and the recorder use them), the IMU by
read chunk (its parser reassembles packets across chunks, so replaying the chunks gives the same
samples).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import serial

from common.clock import Clock
from common.messages import RawBytes
from sensors.receiver import Intake, Parser, RawUnit, Receiver

logger = logging.getLogger(__name__)

Framer = Callable[[bytes], list[bytes]]


class LineFramer:
    """Cut a byte stream into lines ending in LF (the LF kept).

    A run of ``max_line`` bytes without LF (binary, junk) is passed on as it is, so the
    parser sees and counts it and memory stays bounded.
    """

    def __init__(self, max_line: int = 4096) -> None:
        self.max_line = max_line
        self._buffer = bytearray()

    def __call__(self, data: bytes) -> list[bytes]:
        self._buffer.extend(data)
        units: list[bytes] = []
        start = 0
        while True:
            end = self._buffer.find(b"\n", start)
            if end < 0:
                break
            units.append(bytes(self._buffer[start:end + 1]))
            start = end + 1
        del self._buffer[:start]
        while len(self._buffer) >= self.max_line:
            units.append(bytes(self._buffer[:self.max_line]))
            del self._buffer[:self.max_line]
        return units

    def reset(self) -> None:
        """Forget a partial line (after the port was reopened)."""
        self._buffer.clear()


def chunk_framer(data: bytes) -> list[bytes]:
    """Every read chunk is one raw unit."""
    return [data]


class SerialReceiver(Receiver):
    """Read a serial port (any pyserial URL) in a thread; parse with ``parser``.

    ``framer`` cuts what is read into raw units (default: one unit per read chunk). Each unit is
    stamped ``clock.now_s()`` when the read returned.
    """

    def __init__(self, clock: Clock, parser: Parser, port: str, baudrate: int = 115200, *,
                 framer: Framer | None = None, queue_length: int = 4096,
                 rate_window_s: float = 2.0, read_timeout_s: float = 0.05,
                 reconnect_min_s: float = 0.05, reconnect_max_s: float = 1.0,
                 max_read: int = 65536) -> None:
        source = parser.source
        super().__init__(source, clock, Intake(source, parser, queue_length, rate_window_s),
                         read_timeout_s=read_timeout_s, reconnect_min_s=reconnect_min_s,
                         reconnect_max_s=reconnect_max_s)
        self.port = port
        self.baudrate = int(baudrate)
        self.framer: Framer = framer if framer is not None else chunk_framer
        self.max_read = max_read
        self._serial: serial.SerialBase | None = None

    def describe(self) -> str:
        return f"serial port {self.port} @ {self.baudrate}"

    def _open(self) -> None:
        # a reopened port starts a new byte stream: drop partial lines / packets (and, for the
        # IMU, the sensor-clock offset: a replugged unit restarts its clock)
        for obj in (self.framer, self.intake.parser) if self._opened_once else (self.framer,):
            reset = getattr(obj, "reset", None)
            if callable(reset):
                reset()
        self._serial = serial.serial_for_url(self.port, baudrate=self.baudrate,
                                             timeout=self.read_timeout_s)

    def _close(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            port.close()

    def _read(self, timeout_s: float) -> list[RawUnit]:
        port = self._serial
        if port is None:
            raise serial.SerialException("port is not open")
        if port.timeout != timeout_s:
            port.timeout = timeout_s
        waiting = port.in_waiting
        data = port.read(min(max(waiting, 1), self.max_read))
        if not data:
            return []
        if len(data) < self.max_read:  # woken by the first byte: take what came with it
            more = port.in_waiting
            if more:
                data += port.read(min(more, self.max_read - len(data)))
        t_s = self.clock.now_s()
        return [RawBytes(t_s, self.source, unit) for unit in self.framer(data) if unit]


def gps_receiver(clock: Clock, port: str, baudrate: int = 115200,
                 parser: Parser | None = None, **kwargs: float | int) -> SerialReceiver:
    """A NMEA GPS receiver (``sensors.nmea.NmeaParser``, one sentence per raw unit)."""
    if parser is None:
        from sensors.nmea import NmeaParser
        parser = NmeaParser()
    return SerialReceiver(clock, parser, port, baudrate, framer=LineFramer(),
                          **kwargs)  # type: ignore[arg-type]


def imu_receiver(clock: Clock, port: str, baudrate: int = 921600,
                 parser: Parser | None = None, **kwargs: float | int) -> SerialReceiver:
    """An IMU receiver (``sensors.imu_protocol.ImuParser``, one read chunk per raw unit)."""
    if parser is None:
        from sensors.imu_protocol import ImuParser
        parser = ImuParser()
    return SerialReceiver(clock, parser, port, baudrate, **kwargs)  # type: ignore[arg-type]
