"""UDP receivers: the LiDAR (the config's ``lidar.model``: a Velodyne's 1206-byte data packets,
an Ouster OS1's 12 608-byte legacy lidar packets) and the camera's cone datagrams.

One datagram is one raw unit. The socket is bound to the configured host and port (port 0 picks
a free one: see :attr:`UdpReceiver.bound_address`); every read has a timeout; a socket error
closes and rebinds it. Truncated or garbage datagrams are the parser's business: it counts them,
or raises ``DecodeError`` and the intake counts them; nothing stops the thread.
"""

from __future__ import annotations

import logging
import socket

from common.car import CarConfig
from common.clock import Clock
from common.messages import RawBytes
from sensors.config import LidarConfig
from sensors.receiver import Intake, Parser, RawUnit, Receiver

logger = logging.getLogger(__name__)

MAX_DATAGRAM = 65535


class UdpReceiver(Receiver):
    """Read datagrams from ``host``:``port`` in a thread; parse each with ``parser``.

    After one blocking read (at most ``read_timeout_s``) up to ``max_batch`` datagrams already
    queued are drained without blocking, so a 750 packet/s LiDAR costs few wake-ups (an
    HDL-32E sends 1800 packets/s, an OS1-64 at 1024x10 640 of 12.6 kB: 8 MB/s, so the 4 MB
    receive buffer holds half a second).
    """

    def __init__(self, clock: Clock, parser: Parser, host: str, port: int, *,
                 queue_length: int = 4096, rate_window_s: float = 2.0,
                 read_timeout_s: float = 0.05, reconnect_min_s: float = 0.05,
                 reconnect_max_s: float = 1.0, rcvbuf_bytes: int = 4 * 1024 * 1024,
                 max_batch: int = 256) -> None:
        source = parser.source
        super().__init__(source, clock, Intake(source, parser, queue_length, rate_window_s),
                         read_timeout_s=read_timeout_s, reconnect_min_s=reconnect_min_s,
                         reconnect_max_s=reconnect_max_s)
        self.host = host
        self.port = int(port)
        self.rcvbuf_bytes = rcvbuf_bytes
        self.max_batch = max_batch
        self.bound_address: tuple[str, int] | None = None
        self._sock: socket.socket | None = None

    def describe(self) -> str:
        return f"udp {self.host}:{self.port}"

    def _open(self) -> None:
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.rcvbuf_bytes)
            except OSError as exc:
                logger.debug("%s: cannot enlarge the receive buffer: %s", self.source, exc)
            sock.bind((self.host, self.port))
        except OSError:
            sock.close()
            raise
        self.bound_address = sock.getsockname()
        self._sock = sock

    def _close(self) -> None:
        sock, self._sock = self._sock, None
        if sock is not None:
            sock.close()

    def _read(self, timeout_s: float) -> list[RawUnit]:
        sock = self._sock
        if sock is None:
            raise OSError("socket is not open")
        sock.settimeout(timeout_s)
        try:
            payload = sock.recv(MAX_DATAGRAM)
        except TimeoutError:
            return []
        t_s = self.clock.now_s()
        units: list[RawUnit] = [RawBytes(t_s, self.source, payload)]
        sock.setblocking(False)
        try:
            for _ in range(self.max_batch):
                try:
                    payload = sock.recv(MAX_DATAGRAM)
                except (BlockingIOError, InterruptedError):
                    break
                units.append(RawBytes(self.clock.now_s(), self.source, payload))
        finally:
            sock.setblocking(True)
        return units


def lidar_receiver(clock: Clock, config: LidarConfig, car: CarConfig, host: str, port: int,
                   parser: Parser | None = None, **kwargs: float | int) -> UdpReceiver:
    """A receiver of the LiDAR ``config.model`` (``sensors.lidar_parser.LidarParser(config,
    car)``; an Ouster sends to port 7502, a Velodyne to 2368: ``config.port``)."""
    if parser is None:
        from sensors.lidar_parser import LidarParser
        parser = LidarParser(config, car)
    return UdpReceiver(clock, parser, host, port, **kwargs)  # type: ignore[arg-type]


def camera_receiver(clock: Clock, host: str, port: int, parser: Parser | None = None,
                    **kwargs: float | int) -> UdpReceiver:
    """A camera cone receiver (``sensors.camera_codec.CameraParser``)."""
    if parser is None:
        from sensors.camera_codec import CameraParser
        parser = CameraParser()
    return UdpReceiver(clock, parser, host, port, **kwargs)  # type: ignore[arg-type]
