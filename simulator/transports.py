"""Real transports for the hardware emulator: pseudo-terminals, an slcan adapter, UDP senders.

Each plays the device side of a link the car's computer opens exactly as it opens the hardware:
a serial GPS or IMU is a pseudo-terminal whose slave path the stack opens with pyserial; the CAN
bus is an slcan adapter (the ASCII protocol a USB-CAN adapter speaks) on a pseudo-terminal that
the stack opens with python-can's ``slcan`` interface; the LiDAR and the camera send UDP
datagrams to loopback ports.
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
