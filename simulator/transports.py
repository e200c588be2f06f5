"""Real transports for the hardware emulator: pseudo-terminals, an slcan adapter, UDP senders.

Each plays the device side of a link the car's computer opens exactly as it opens the hardware:
a serial GPS or IMU is a pseudo-terminal whose slave path the stack opens with pyserial; the CAN
bus is an slcan adapter (the ASCII protocol a USB-CAN adapter speaks) on a pseudo-terminal that
the stack opens with python-can's ``slcan`` interface, or a kernel-socket bus
(:class:`UdpCanBus`, python-can's ``udp_multicast``) where the car's SocketCAN cannot be had;
the LiDAR and the camera send UDP datagrams to loopback ports.
"""

from __future__ import annotations

import fcntl
import logging
import os
import socket
import struct
import termios
import tty
from pathlib import Path
from typing import Any

import can

from common.messages import CanFrame

log = logging.getLogger(__name__)


class PtyPort:
    """The device end of a pseudo-terminal; the stack opens ``link_path`` (a symlink).

    Writes never block: when the other side is not reading (or gone), bytes that do not fit are
    dropped and counted, as a UART with no listener would lose them.
    """

    def __init__(self, link_path: Path) -> None:
        self.master_fd, self._slave_fd = os.openpty()
        tty.setraw(self._slave_fd)
        os.set_blocking(self.master_fd, False)
        self.slave_path = os.ttyname(self._slave_fd)
        self.link_path = Path(link_path)
        if self.link_path.is_symlink() or self.link_path.exists():
            self.link_path.unlink()
        self.link_path.symlink_to(self.slave_path)
        self.dropped_bytes = 0

    def write(self, data: bytes) -> None:
        """Send bytes to the stack (drops what the pty buffer cannot take)."""
        try:
            written = os.write(self.master_fd, data)
        except (BlockingIOError, OSError):
            written = 0
        self.dropped_bytes += len(data) - written

    def read(self) -> bytes:
        """Bytes the stack sent, without waiting (b"" when none).

        It asks the line discipline how many bytes wait (``FIONREAD``) and reads only when
        some do: Linux's tty ``read`` (and ``poll``) on an empty pty waits, even on a
        non-blocking descriptor, for the kernel worker that moves the other side's bytes in,
        and that worker runs at normal priority, so on a busy machine it held this real-time
        loop up to 0.4 s (issue 19). Bytes the worker has not moved yet are read next time.
        """
        try:
            waiting = struct.unpack("i", fcntl.ioctl(self.master_fd, termios.FIONREAD,
                                                     b"\0\0\0\0"))[0]
            if waiting <= 0:
                return b""
            return os.read(self.master_fd, max(waiting, 65536))
        except (BlockingIOError, OSError):
            return b""

    def close(self) -> None:
        for fd in (self.master_fd, self._slave_fd):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.link_path.is_symlink():
            self.link_path.unlink()


class SlcanAdapter(PtyPort):
    """An slcan (Lawicel) USB-CAN adapter on a pseudo-terminal.

    Frames to the stack are written as ``tIIILDD..\\r`` (``TIIIIIIIILDD..\\r`` extended);
    frames from the stack are parsed from the same form; commands (``O``, ``C``, ``S6``...) are
    acknowledged with ``\\r`` as an adapter does. Malformed lines are counted, never raised.
    """

    def __init__(self, link_path: Path) -> None:
        super().__init__(link_path)
        self._buffer = bytearray()
        self.bad_lines = 0
        self.is_open = False

    def drive_config(self) -> dict[str, Any]:
        """``[sensors.can]`` for ``drive``."""
        return {"interface": "slcan", "channel": str(self.link_path)}

    def describe(self) -> str:
        return f"slcan {self.link_path}"

    def send_frame(self, frame: CanFrame) -> None:
        data = frame.data.hex().upper()
        if frame.is_extended_id:
            line = f"T{frame.arbitration_id:08X}{len(frame.data)}{data}\r"
        else:
            line = f"t{frame.arbitration_id:03X}{len(frame.data)}{data}\r"
        self.write(line.encode("ascii"))

    def poll(self, timestamp_s: float) -> list[CanFrame]:
        """Frames the stack has sent since the last call."""
        self._buffer.extend(self.read())
        frames: list[CanFrame] = []
        while True:
            end = self._buffer.find(b"\r")
            if end < 0:
                if len(self._buffer) > 4096:  # no terminator in sight: garbage
                    self._buffer.clear()
                    self.bad_lines += 1
                break
            line = bytes(self._buffer[:end]).decode("ascii", "replace")
            del self._buffer[: end + 1]
            frame = self._parse(line, timestamp_s)
            if frame is not None:
                frames.append(frame)
        return frames

    def _parse(self, line: str, timestamp_s: float) -> CanFrame | None:
        if not line:
            return None
        kind = line[0]
        try:
            if kind == "t":
                dlc = int(line[4])
                return CanFrame(timestamp_s, int(line[1:4], 16),
                                bytes.fromhex(line[5:5 + 2 * dlc]))
            if kind == "T":
                dlc = int(line[9])
                return CanFrame(timestamp_s, int(line[1:9], 16),
                                bytes.fromhex(line[10:10 + 2 * dlc]), True)
        except (ValueError, IndexError):
            self.bad_lines += 1
            return None
        if kind in "OL":
            self.is_open = True
        elif kind == "C":
            self.is_open = False
        self.write(b"\r")  # acknowledge a command
        return None


class UdpCanBus:
    """The car's CAN bus as python-can's ``udp_multicast`` interface on this machine.

    The car's own bus is SocketCAN: frames pass through kernel sockets, never a tty. This
    machine may have no ``vcan`` module, and an slcan adapter on a pseudo-terminal puts the
    kernel's tty worker, which runs at normal priority, in the path of every frame (on a busy
    machine issue 19 measured frames held there 0.2-0.5 s). python-can's ``udp_multicast`` bus
    is a kernel socket too; the stack opens it as it opens any bus (``interface =
    "udp_multicast"``). Each emulator has a port of its own, so that two runs never share a bus.

    IP multicast hands every frame back to its sender: the frames with the ids this end sends
    are dropped on receipt (they are its own). The stack opens the bus by sending its first
    frame: :attr:`is_open` turns true then, as an slcan adapter's does on ``O``.
    """

    GROUP = "239.74.163.2"
    """python-can's default IPv4 group for ``udp_multicast``."""

    def __init__(self, port: int | None = None) -> None:
        self.port = port if port is not None else free_udp_port("0.0.0.0")
        self.bus = can.Bus(interface="udp_multicast", channel=self.GROUP, port=self.port)
        self._sent_ids: set[tuple[int, bool]] = set()
        self.bad_lines = 0
        """Datagrams that were not a CAN frame, and frames that could not be sent."""
        self.is_open = False

    def drive_config(self) -> dict[str, Any]:
        """``[sensors.can]`` for ``drive``."""
        return {"interface": "udp_multicast", "channel": self.GROUP, "udp_port": self.port}

    def describe(self) -> str:
        return f"udp_multicast {self.GROUP}:{self.port}"

    def send_frame(self, frame: CanFrame) -> None:
        self._sent_ids.add((frame.arbitration_id, frame.is_extended_id))
        try:
            self.bus.send(can.Message(arbitration_id=frame.arbitration_id, data=frame.data,
                                      is_extended_id=frame.is_extended_id))
        except (can.CanError, OSError) as exc:
            self.bad_lines += 1
            log.debug("CAN send failed: %r", exc)

    def poll(self, timestamp_s: float) -> list[CanFrame]:
        """Frames the stack has sent since the last call (never waits)."""
        frames: list[CanFrame] = []
        while True:
            try:
                msg = self.bus.recv(0.0)
            except (can.CanError, OSError, ValueError) as exc:
                self.bad_lines += 1
                log.debug("CAN datagram refused: %r", exc)
                return frames  # the rest next time (a closed socket fails every time)
            if msg is None:
                return frames
            if (msg.arbitration_id, msg.is_extended_id) in self._sent_ids:
                continue  # our own, looped back
            if msg.is_error_frame or msg.is_remote_frame:
                continue
            self.is_open = True
            frames.append(CanFrame(timestamp_s, msg.arbitration_id, bytes(msg.data),
                                   msg.is_extended_id))

    def close(self) -> None:
        self.bus.shutdown()


class UdpSender:
    """Sends datagrams to one address (loopback in the emulator)."""

    def __init__(self, host: str, port: int) -> None:
        self.address = (host, port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 20)
        self.errors = 0

    def send(self, payload: bytes) -> None:
        try:
            self.sock.sendto(payload, self.address)
        except OSError:
            self.errors += 1

    def close(self) -> None:
        self.sock.close()


def free_udp_port(host: str = "127.0.0.1") -> int:
    """A UDP port on ``host`` that is free right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind((host, 0))
        return int(sock.getsockname()[1])
