"""Frames to an slcan (Lawicel) USB-CAN adapter, written to its tty without ever waiting.

python-can's ``slcan`` bus writes each frame with pyserial, whose ``write`` polls the tty after
every write (even one that took all the bytes) and then drains it. On Linux a poll of a tty with
no input waiting first waits for the kernel worker that moves the adapter's incoming bytes in,
and that worker runs at normal priority: on a busy computer issue 19 measured sends held
30-290 ms there. :class:`SlcanWriter` writes the same ASCII line with one non-blocking
``os.write`` and never polls. python-can still opens, configures, reads and closes the adapter.

A line is never left half-written: what the tty did not take of a line is written first at the
next call (so the adapter never sees a garbled line), and a frame none of whose bytes fit is
refused (the caller counts it; the next command supersedes it, it is never sent late).
"""

from __future__ import annotations

import os

import can


def slcan_line(msg: can.Message) -> bytes:
    """The slcan ASCII line of a data frame: ``tIIILDD..\\r`` (``TIIIIIIIILDD..\\r`` extended)."""
    data = bytes(msg.data).hex().upper()
    if msg.is_extended_id:
        return f"T{msg.arbitration_id:08X}{len(msg.data)}{data}\r".encode("ascii")
    return f"t{msg.arbitration_id:03X}{len(msg.data)}{data}\r".encode("ascii")


class SlcanWriter:
    """Write slcan lines to the tty ``fd`` (opened non-blocking, as pyserial opens it)."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self._unfinished = bytearray()
        """The tail of the last line that the tty did not take (at most one line)."""

    def send(self, msg: can.Message) -> None:
        """Write ``msg``'s line now; raise :class:`can.CanOperationError` when the adapter took
        none of it (its tty buffer is full: it is not reading) or the tty failed."""
        if msg.is_remote_frame or msg.is_fd or msg.is_error_frame:
            raise can.CanOperationError("slcan writer: only classic data frames are sent")
        previous = len(self._unfinished)
        self._unfinished += slcan_line(msg)
        try:
            written = os.write(self.fd, self._unfinished)
        except BlockingIOError:
            written = 0
        except OSError as exc:
            del self._unfinished[previous:]
            raise can.CanOperationError(f"slcan write failed: {exc}") from exc
        if written <= previous:  # none of the new line went out: refuse it, keep the old tail
            del self._unfinished[previous:]
            del self._unfinished[:written]
            raise can.CanOperationError("slcan adapter is not taking bytes (tty buffer full)")
        del self._unfinished[:written]
