"""A message link between the two processes of ``drive``: pickled messages over a socket.

Each message is one pickled object behind an 8-byte little-endian length. The control process
uses only the non-blocking calls (:meth:`Link.send_nowait`, :meth:`Link.poll`): a layer that
stops reading can never stall a control tick; what it cannot send yet waits in an outbox, and
past ``max_outbox_bytes`` new messages are dropped and counted. The other process uses the
blocking calls (:meth:`Link.send` from any thread, :meth:`Link.recv` from one).

A closed peer (its process ended or died) shows as :attr:`Link.closed`; nothing raises.
"""

from __future__ import annotations

import logging
import pickle
import select
import socket
import struct
import threading
import time
from typing import Any

log = logging.getLogger(__name__)

_HEADER = struct.Struct("<Q")
_READ_CHUNK = 1 << 16
MAX_MESSAGE_BYTES = 64 << 20
"""A length larger than this means a corrupt stream: the link is closed."""


def link_pair() -> tuple[socket.socket, socket.socket]:
    """Two connected stream sockets (one for each process)."""
    return socket.socketpair(socket.AF_UNIX, socket.SOCK_STREAM)


class Link:
    """Framed pickled messages over a connected stream socket (left in blocking mode)."""

    def __init__(self, sock: socket.socket, max_outbox_bytes: int = 8 << 20) -> None:
        self.sock = sock
        self.max_outbox_bytes = int(max_outbox_bytes)
        self.closed = False
        self._eof = False
        """The peer's stream has ended (a send error closes the link, but what the peer sent
        before it went is still read)."""
        self.sent = 0
        self.received = 0
        self.dropped = 0
        """Messages :meth:`send_nowait` dropped because the outbox was full."""
        self._inbox = bytearray()
        self._outbox = bytearray()
        self._send_lock = threading.Lock()

    # -- encoding ---------------------------------------------------------------------------

    @staticmethod
    def encode(message: Any) -> bytes:
        body = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        return _HEADER.pack(len(body)) + body

    def _decode_inbox(self) -> list[Any]:
        out: list[Any] = []
        buf = self._inbox
        pos = 0
        while len(buf) - pos >= _HEADER.size:
            (size,) = _HEADER.unpack_from(buf, pos)
            if size > MAX_MESSAGE_BYTES:
                log.error("link: message of %d bytes announced: corrupt stream, closing", size)
                self._mark_closed()
                self._eof = True
                break
            end = pos + _HEADER.size + size
            if len(buf) < end:
                break
            out.append(pickle.loads(bytes(buf[pos + _HEADER.size:end])))
            pos = end
        if pos:
            del buf[:pos]
        self.received += len(out)
        return out

    def _mark_closed(self) -> None:
        self.closed = True

    # -- non-blocking (control process) -----------------------------------------------------

    def send_nowait(self, message: Any) -> bool:
        """Queue ``message`` and send what the socket takes now; False (counted in
        :attr:`dropped`) when the outbox is full or the link is closed."""
        if self.closed:
            return False
        if len(self._outbox) > self.max_outbox_bytes:
            self.dropped += 1
            self.flush()
            return False
        self._outbox += self.encode(message)
        self.sent += 1
        self.flush()
        return True

    def flush(self) -> int:
        """Send as much of the outbox as the socket takes without waiting; bytes left."""
        while self._outbox and not self.closed:
            try:
                n = self.sock.send(self._outbox, socket.MSG_DONTWAIT)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self._mark_closed()
                break
            del self._outbox[:n]
        return len(self._outbox)

    def poll(self) -> list[Any]:
        """Every complete message that has arrived, without waiting."""
        while not self._eof:
            try:
                data = self.sock.recv(_READ_CHUNK, socket.MSG_DONTWAIT)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self._mark_closed()
                self._eof = True
                break
            if not data:
                self._mark_closed()
                self._eof = True
                break
            self._inbox += data
            if len(data) < _READ_CHUNK:
                break
        return self._decode_inbox()

    # -- blocking (the other process) -------------------------------------------------------

    def send(self, message: Any) -> bool:
        """Send ``message`` whole (thread-safe; waits while the peer's buffer is full);
        False when the link is closed."""
        data = self.encode(message)
        with self._send_lock:
            if self.closed:
                return False
            try:
                self.sock.sendall(data)
            except OSError:
                self._mark_closed()
                return False
        self.sent += 1
        return True

    def recv(self, timeout_s: float) -> list[Any]:
        """Wait at most ``timeout_s`` for data; the complete messages received (maybe none).

        Call from one thread only."""
        end = time.monotonic() + timeout_s
        while not self.closed:
            messages = self.poll()
            if messages or self.closed:
                return messages
            left = end - time.monotonic()
            if left <= 0.0:
                return []
            try:
                select.select([self.sock], [], [], left)
            except (OSError, ValueError):
                self._mark_closed()
        return self._decode_inbox()

    def close(self) -> None:
        """Close the socket (the peer sees the link closed)."""
        self.closed = True
        try:
            self.sock.close()
        except OSError:
            pass
